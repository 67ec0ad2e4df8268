"""Soccer against ML-Agents' SoccerTwos: goal rates and episode lengths of fixed players.

Plays whole episodes on ``--worlds`` pitches of the numpy game
(:class:`rlhc.envs.soccer.SoccerGame`, no TorchRL in the loop) for three match-ups:

* ``random_vs_random``: every player draws a uniform action each decision (seeded numpy
  generator);
* ``scripted_vs_random``: the scripted team of :mod:`rlhc.envs.soccer.scripted` on team 0
  in even pitches and on team 1 in odd ones, against random players;
* ``scripted_vs_scripted``: the scripted team on both sides.

Every pitch plays exactly ``--episodes`` episodes (a pitch that has played its quota keeps
stepping, uncounted), so short episodes are not over-represented. The goal rate is the
share of episodes that end in a goal (the rest reach ``max_cycles``), with a 95 % Wilson
interval; lengths are in decisions.

Each run is stored under its ``--label`` in ``benchmarks/results/soccer_calibration.json``
(other labels are kept), with the command, the full game options and the machine load.
``--preset before`` (the default for ``--label before``) plays the options the game had
before the calibration, kept below; ``--preset current`` (the default otherwise) plays the
current defaults; ``--set`` changes single options on top
(``--set decision_interval=5 --set step_seconds=0.02``). The scripted team is always the
current :mod:`rlhc.envs.soccer.scripted`: each run records the git commit and whether the
soccer package had uncommitted changes.

Examples:
    .venv/bin/python benchmarks/soccer_calibration.py --label before --worlds 256 --episodes 8
    .venv/bin/python benchmarks/soccer_calibration.py --label after --worlds 256 --episodes 8
"""

from __future__ import annotations

import argparse
import ast
import dataclasses
import json
import os
import shlex
import subprocess
import sys
import time
from datetime import datetime, timezone
from pathlib import Path
from typing import Any

import numpy as np

from rlhc.envs.soccer import SoccerGame, SoccerOptions
from rlhc.envs.soccer.scripted import scripted_actions
from rlhc.evaluation.stats import wilson_interval

RESULTS = Path(__file__).parent / "results" / "soccer_calibration.json"

#: the defaults of :class:`SoccerOptions` before the calibration against SoccerTwos.
BEFORE: dict[str, Any] = {
    "max_cycles": 500,
    "decision_interval": 1,
    "striker_time_reward": -0.001,
    "goalie_time_reward": 0.001,
    "pitch_length": 16.0,
    "pitch_width": 10.0,
    "goal_width": 3.0,
    "goal_depth": 1.0,
    "step_seconds": 0.1,
    "physics_substeps": 2,
    "player_radius": 0.4,
    "ball_radius": 0.25,
    "player_speed": 3.0,
    "side_speed": 2.25,
    "rotation_speed": 3.0,
    "kick_speed": 5.0,
    "ball_max_speed": 8.0,
    "ball_drag": 0.95,
    "worker_ray_length": 10.0,
    "manager_ray_length": 24.0,
    "kickoff_jitter": 0.5,
    "kickoff_angle_jitter": 0.25,
}

MATCHUPS = ("random_vs_random", "scripted_vs_random", "scripted_vs_scripted")


def random_team(rng: np.random.Generator, num_worlds: int) -> dict[str, np.ndarray]:
    """Uniform actions for both players of both teams."""
    return {
        "striker": rng.integers(0, 6, (num_worlds, 2)),
        "goalie": rng.integers(0, 4, (num_worlds, 2)),
    }


def play(
    matchup: str, options: dict[str, Any], worlds: int, episodes: int, seed: int
) -> dict[str, Any]:
    """Play ``episodes`` episodes on each of ``worlds`` pitches; summarise them.

    Returns:
        Goal rate with its Wilson interval, episode lengths (decisions), goals by team
        and, where the scripted team plays, goals by the scripted and the random side.
    """
    game = SoccerGame(num_worlds=worlds, seed=seed, **options)
    rng = np.random.default_rng(seed + 1)
    scripted_side = np.arange(worlds) % 2  # scripted_vs_random: scripted team per pitch
    played = np.zeros(worlds, dtype=np.int64)
    lengths: list[np.ndarray] = []
    scorers: list[np.ndarray] = []  # -1: truncated
    scripted_sides: list[np.ndarray] = []
    steps = 0
    start = time.perf_counter()
    while (played < episodes).any():
        if matchup == "random_vs_random":
            actions = random_team(rng, worlds)
        else:
            actions = scripted_actions(game.state(), game.options)
            if matchup == "scripted_vs_random":
                noise = random_team(rng, worlds)
                for group in actions:
                    random_side = 1 - scripted_side
                    actions[group][np.arange(worlds), random_side] = noise[group][
                        np.arange(worlds), random_side
                    ]
        outcome = game.step(actions)
        steps += 1
        done = outcome.terminated | outcome.truncated
        counted = done & (played < episodes)
        lengths.append(game.step_count[counted].copy())
        scorers.append(np.where(outcome.terminated, outcome.scoring_team, -1)[counted])
        scripted_sides.append(scripted_side[counted])
        played += done
        if done.any():
            game.reset(done)
    seconds = time.perf_counter() - start
    length = np.concatenate(lengths)
    scorer = np.concatenate(scorers)
    side = np.concatenate(scripted_sides)
    goals = int((scorer >= 0).sum())
    total = len(scorer)
    low, high = wilson_interval(goals, total)
    summary: dict[str, Any] = {
        "episodes": total,
        "goals": goals,
        "goal_rate": goals / total,
        "goal_rate_ci95": [low, high],
        "mean_length": float(length.mean()),
        "mean_length_to_goal": float(length[scorer >= 0].mean()) if goals else None,
        "median_length": float(np.median(length)),
        "goals_by_team": [int((scorer == 0).sum()), int((scorer == 1).sum())],
        "pitch_steps": steps * worlds,
        "pitch_steps_per_s": steps * worlds / seconds,
    }
    if matchup == "scripted_vs_random":
        scripted_goals = int((scorer == side).sum())
        random_goals = int(((scorer >= 0) & (scorer != side)).sum())
        low, high = wilson_interval(scripted_goals, total)
        summary.update(
            scripted_goals=scripted_goals,
            random_goals=random_goals,
            scripted_win_rate=scripted_goals / total,
            scripted_win_rate_ci95=[low, high],
            scripted_win_rate_by_side=[
                float((scorer[side == s] == s).mean()) if (side == s).any() else None
                for s in (0, 1)
            ],
        )
    return summary


def throughput(options: dict[str, Any], worlds: int, decisions: int, seed: int) -> float:
    """Pitch-decisions per second of random play, observations included (as in training)."""
    game = SoccerGame(num_worlds=worlds, seed=seed, **options)
    rng = np.random.default_rng(seed)
    actions = [random_team(rng, worlds) for _ in range(decisions)]
    start = time.perf_counter()
    for batch in actions:
        outcome = game.step(batch)
        game.observe()
        done = outcome.terminated | outcome.truncated
        if done.any():
            game.reset(done)
    return worlds * decisions / (time.perf_counter() - start)


def parse_settings(pairs: list[str]) -> dict[str, Any]:
    """``["name=value", ...]`` -> options (values are Python literals)."""
    settings = {}
    for pair in pairs:
        name, _, value = pair.partition("=")
        if not value:
            raise SystemExit(f"--set expects name=value, got {pair!r}")
        settings[name] = ast.literal_eval(value)
    return settings


def git_state() -> dict[str, Any]:
    """The commit checked out and whether the soccer package differs from it."""

    def git(*args: str) -> str:
        result = subprocess.run(
            ["git", *args], capture_output=True, text=True, cwd=Path(__file__).parent
        )
        return result.stdout.strip()

    return {
        "commit": git("rev-parse", "HEAD") or None,
        "soccer_uncommitted": bool(git("status", "--porcelain", "--", "../rlhc/envs/soccer")),
    }


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--label", required=True, help="'before', 'after', ... (JSON key)")
    parser.add_argument("--preset", choices=("before", "current"), default=None)
    parser.add_argument("--note", default=None, help="stored with the run")
    parser.add_argument("--worlds", type=int, default=256)
    parser.add_argument("--episodes", type=int, default=4, help="episodes per pitch")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--matchups", nargs="+", default=list(MATCHUPS), choices=MATCHUPS)
    parser.add_argument("--set", dest="settings", action="append", default=[])
    parser.add_argument("--output", type=Path, default=RESULTS)
    parser.add_argument(
        "--throughput",
        action="store_true",
        help="also time this run's options against the 'before' preset, interleaved, best of 3",
    )
    args = parser.parse_args(argv)

    preset = args.preset or ("before" if args.label == "before" else "current")
    options = {**(BEFORE if preset == "before" else {}), **parse_settings(args.settings)}
    resolved = dataclasses.asdict(SoccerOptions.from_options(options))
    run: dict[str, Any] = {
        "command": shlex.join(
            [".venv/bin/python", "benchmarks/soccer_calibration.py", *(argv or sys.argv[1:])]
        ),
        "note": args.note,
        "measured_at": datetime.now(timezone.utc).strftime("%Y-%m-%d %H:%M UTC"),
        **git_state(),
        "preset": preset,
        "load_average": os.getloadavg()[0],
        "worlds": args.worlds,
        "episodes_per_world": args.episodes,
        "seed": args.seed,
        "options": resolved,
        "seconds_per_decision": resolved["step_seconds"] * resolved["decision_interval"],
        "episode_cap_seconds": resolved["step_seconds"]
        * resolved["decision_interval"]
        * resolved["max_cycles"],
        "matchups": {},
    }
    for matchup in args.matchups:
        summary = play(matchup, options, args.worlds, args.episodes, args.seed)
        run["matchups"][matchup] = summary
        low, high = summary["goal_rate_ci95"]
        line = (
            f"{args.label:>12} {matchup:<22} goals {summary['goals']:>5}/{summary['episodes']:<5}"
            f" rate {summary['goal_rate']:.3f} [{low:.3f}, {high:.3f}]"
            f"  length {summary['mean_length']:6.1f}  by team {summary['goals_by_team']}"
        )
        if "scripted_goals" in summary:
            line += (
                f"  scripted {summary['scripted_goals']} : random {summary['random_goals']}"
                f" (by side {summary['scripted_win_rate_by_side']})"
            )
        print(line, flush=True)

    if args.throughput:
        best = {"before": 0.0, "this run": 0.0}
        for _ in range(3):  # interleaved: both see the same machine load
            for name, settings in (("before", BEFORE), ("this run", options)):
                rate = throughput(settings, args.worlds, 200, args.seed)
                best[name] = max(best[name], rate)
        run["pitch_decisions_per_s"] = {**best, "ratio": best["this run"] / best["before"]}
        print(f"pitch-decisions/s with observations (best of 3): {run['pitch_decisions_per_s']}")

    data: dict[str, Any] = {"runs": {}}
    if args.output.exists():
        data = json.loads(args.output.read_text())
    data["runs"][args.label] = run
    args.output.parent.mkdir(parents=True, exist_ok=True)
    args.output.write_text(json.dumps(data, indent=2) + "\n")
    print(f"wrote {args.output} [{args.label}]")


if __name__ == "__main__":
    main()
