"""How trained tennis teams lose points: the serves they miss and the balls they do not return.

Each team plays itself (sampled actions, as in training) on fresh courts, and for every
point that ended with the tossed ball untouched (``serve_missed``) or a ball not
returned (``missed``) it reads where the rackets of the team at fault were:

| key | what |
|---|---|
| ``serve_missed_share`` / ``missed_share`` | share of the points that ended so |
| ``serve_closest_back`` / ``serve_closest_front`` | median over missed serves of the closest approach (metres) of the serving team's back / front racket (by x at the serve) to the ball |
| ``serve_first_moves`` | mean move action of the serving team's two rackets over the first three decisions of a missed serve (``+``: towards the net) |
| ``missed_nearer`` | median over balls not returned of the horizontal distance (metres) between the ball where it came down and the nearer racket of the team at fault |
| ``missed_landing_x`` / ``missed_rackets_x`` | medians of the ball's landing x and of the back and front rackets' x then (team frame, metres; the net at 0) |

Usage::

    python -m benchmarks.tennis_misses benchmarks/results/tennis_play/actor_view_seed1_4M_team.pt \\
        --out benchmarks/results/tennis_play/misses.json
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from typing import Any

import numpy as np
import torch
from tensordict import TensorDictBase
from tensordict.nn import InteractionType, set_interaction_type

from benchmarks.tennis_play import team_arguments, write_results
from rlhc.envs import make_env
from rlhc.envs.keys import ACTION, INFO, NEXT, OBSERVATION
from rlhc.envs.tennis.observations import LENGTH_SCALE
from rlhc.evaluation.policies import RestoredPolicy, observation_options, restore_policy
from rlhc.storage.final_team import load_team

GROUP = "racket"


class _Acting:
    """A restored team as a rollout policy (both sides the same team)."""

    def __init__(self, team: RestoredPolicy) -> None:
        self.team = team

    def __call__(self, tensordict: TensorDictBase) -> TensorDictBase:
        tensordict.set((GROUP, ACTION), self.team(tensordict)[GROUP])
        return tensordict


def play(state: dict[str, Any], worlds: int, decisions: int, seed: int) -> TensorDictBase:
    """A sampled self-play rollout ``[worlds, decisions]`` of a tennis team."""
    options = observation_options(state)
    env = make_env("tennis", num_envs=worlds, seed=seed, **options)
    team = restore_policy(state, env)
    torch.manual_seed(seed)
    try:
        with set_interaction_type(InteractionType.RANDOM), torch.no_grad():
            return env.rollout(decisions, policy=_Acting(team), break_when_any_done=False)
    finally:
        env.close()


def misses(rollout: TensorDictBase) -> dict[str, Any]:
    """The table of the module docstring for one rollout."""
    after = rollout[NEXT, GROUP, OBSERVATION] * LENGTH_SCALE
    move = rollout[GROUP, ACTION][..., 0].clamp(-1.0, 1.0)
    done = rollout[NEXT, "done"].reshape(*rollout.batch_size, -1).any(-1)
    ended = {
        how: rollout[NEXT, INFO, f"ended_{how}"].reshape(*rollout.batch_size, -1).any(-1)
        for how in ("serve_missed", "missed")
    }
    closest: list[list[float]] = []
    first_moves: list[float] = []
    nearer: list[float] = []
    landing: list[float] = []
    rackets_x: list[list[float]] = []
    worlds, steps = rollout.batch_size
    for w in range(worlds):
        start = 0
        for t in range(steps):
            if not done[w, t]:
                continue
            # The team at fault has the ball in its half (team frame x < 0) at the end.
            team = 0 if after[w, t, 0, 0] < 0 else 1
            ours = [2 * team, 2 * team + 1]
            if ended["serve_missed"][w, t]:
                seg = rollout[GROUP, OBSERVATION][w, start : t + 1] * LENGTH_SCALE
                gap = (seg[:, ours, 0:2] - seg[:, ours, 4:6]).norm(dim=-1).min(0).values
                back_first = bool(seg[0, ours[0], 4] <= seg[0, ours[1], 4])
                closest.append(gap.tolist() if back_first else gap.flip(0).tolist())
                first_moves.append(float(move[w, start : start + 3, ours].mean()))
            elif ended["missed"][w, t]:
                ball_x = float(after[w, t, ours[0], 0])
                racket = after[w, t, ours, 4]
                nearer.append(float((racket - ball_x).abs().min()))
                landing.append(ball_x)
                rackets_x.append(sorted(racket.tolist()))
            start = t + 1
    points = max(int(done.sum()), 1)
    median = lambda v: float(np.median(v)) if len(v) else float("nan")  # noqa: E731
    return {
        "points": int(done.sum()),
        "serve_missed_share": float(ended["serve_missed"].sum()) / points,
        "missed_share": float(ended["missed"].sum()) / points,
        "serve_closest_back": median([c[0] for c in closest]),
        "serve_closest_front": median([c[1] for c in closest]),
        "serve_first_moves": float(np.mean(first_moves)) if first_moves else float("nan"),
        "missed_nearer": median(nearer),
        "missed_landing_x": median(landing),
        "missed_rackets_x": [median([r[0] for r in rackets_x]), median([r[1] for r in rackets_x])],
    }


def main(argv: Sequence[str] | None = None) -> int:
    parser = team_arguments(__doc__.split("\n")[0], worlds=16, decisions=600)
    args = parser.parse_args(argv)
    torch.set_num_threads(1)
    teams = {}
    for team in args.teams:
        state = load_team(team)
        if state["env"] != "tennis":
            parser.error(f"{team} is a team of {state['env']!r}; allowed: tennis teams")
        result = misses(play(state, args.worlds, args.decisions, args.seed))
        result["frames"] = int(state.get("frames", 0))
        teams[team] = result
        print(team, json.dumps(result), flush=True)
    write_results(args.out, "benchmarks.tennis_misses", teams)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
