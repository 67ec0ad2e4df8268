"""Why a tennis team does (not) rally: what its policy does near the ball.

A trained team plays self-play (both sides the same policy, as in training) on fresh
courts twice, once sampling its actions as in training and once with its mode actions
as in matches, and reports:

| key | what |
|---|---|
| ``hits_per_point`` | hits over the net per point (episode), sampled / ``_mode`` |
| ``points`` | points played, sampled / ``_mode`` |
| ``sigma_near`` / ``sigma_far`` | the policy's mean scale per action dimension (move, jump, tilt) where the racket is within :data:`NEAR_BALL` metres of the ball / farther (pre-squash for a TanhNormal, the learned state-free scale for a Gaussian) |
| ``saturated`` | share of sampled action components at their bound (``abs >= 0.99`` after the env's clip), per dimension |
| ``toward_ball`` | share of decisions, with the ball in the racket's half and more than :data:`NEAR_BALL` away along the court, whose move action points at the ball (sampled) |
| ``toward_ball_mode`` | the same for the mode actions |
| ``ended`` / ``ended_mode`` | share of points that ended each way (:data:`~rlhc.envs.tennis.rules.POINT_ENDINGS`: the serve not touched, a ball not returned, out, net, wall), sampled / mode |

The numbers are per decision of every racket, over ``worlds x decisions``
racket-decisions per mode. ``python -m rlhc.evaluation.diagnostics <run dir or .pt>``
prints them as JSON.

:func:`tracking_probe` asks the policy one controlled question instead: a ball falls
(:data:`PROBE_BALL`) at each of a grid of places in the racket's half, the racket stands
at each of a grid of places; where does the mode action move it? A team that runs to
the ball moves with the ball's offset (the scripted team: a gain of 0.32 per metre,
saturated, and towards the ball at 85 % of the grid points, the others being balls
it leaves to its front racket); one that plays a routine moves the same wherever the
ball is (gain near 0).

Examples:
    >>> from rlhc.evaluation.diagnostics.tennis import NEAR_BALL, ACTION_NAMES
    >>> NEAR_BALL, ACTION_NAMES
    (1.0, ('move', 'jump', 'tilt'))
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from typing import Any

import numpy as np
import torch
from tensordict import TensorDict, TensorDictBase
from tensordict.nn import InteractionType, set_interaction_type

from rlhc.envs import make_env
from rlhc.envs.keys import ACTION, ENDED_PREFIX, INFO, MANAGER_OBSERVATION, NEXT, OBSERVATION, SCALE
from rlhc.envs.tennis.game import HOME_X
from rlhc.envs.tennis.observations import LENGTH_SCALE, TEAM_SIGN, observe_rackets
from rlhc.envs.tennis.physics import CourtGeometry
from rlhc.envs.tennis.rules import POINT_ENDINGS
from rlhc.evaluation.policies import RestoredPolicy, observation_options, restore_policy

#: Metres between racket and ball under which a racket is "near the ball".
NEAR_BALL = 1.0
#: The three action dimensions of a racket.
ACTION_NAMES = ("move", "jump", "tilt")
GROUP = "racket"


class _RecordingPolicy:
    """The restored actors as a rollout policy that also keeps each decision's scale."""

    def __init__(self, restored: RestoredPolicy) -> None:
        self.restored = restored

    def __call__(self, tensordict: TensorDictBase) -> TensorDictBase:
        out = self.restored.actors[GROUP](self.restored.inputs(GROUP, tensordict))
        tensordict.set((GROUP, ACTION), out[GROUP, ACTION])
        tensordict.set((GROUP, SCALE), out[GROUP, SCALE].expand_as(out[GROUP, ACTION]))
        return tensordict


def _play(
    restored: RestoredPolicy, options: Mapping[str, Any], worlds: int, decisions: int, seed: int
) -> TensorDictBase:
    env = make_env("tennis", num_envs=worlds, seed=seed, **options)
    try:
        with torch.no_grad():
            return env.rollout(
                decisions, policy=_RecordingPolicy(restored), break_when_any_done=False
            )
    finally:
        env.close()


def _geometry(rollout: TensorDictBase) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
    """Per racket-decision: distance to the ball (m), ball minus racket along the court
    in the racket's frame (m, ``+``: towards the net), and whether the ball is in the
    racket's half."""
    observation = rollout[GROUP, OBSERVATION]  # raw, in each racket's team frame
    ball, racket = observation[..., 0:2], observation[..., 4:6]
    distance = (ball - racket).norm(dim=-1) * LENGTH_SCALE
    along = (ball[..., 0] - racket[..., 0]) * LENGTH_SCALE
    return distance, along, ball[..., 0] < 0


def _hits_per_point(rollout: TensorDictBase) -> tuple[float, int]:
    points = int(rollout[NEXT, "done"].sum())
    hits = float(rollout[NEXT, INFO, "hits_over_net"].sum())
    return hits / max(points, 1), points


def _endings(rollout: TensorDictBase) -> dict[str, float]:
    points = max(int(rollout[NEXT, "done"].sum()), 1)
    return {
        how: float(rollout[NEXT, INFO, f"{ENDED_PREFIX}{how}"].sum()) / points
        for how in POINT_ENDINGS
    }


def _toward_ball(rollout: TensorDictBase) -> float:
    _, along, own_half = _geometry(rollout)
    chasing = own_half & (along.abs() > NEAR_BALL)
    move = rollout[GROUP, ACTION][..., 0]
    toward = torch.sign(move) == torch.sign(along)
    return float(toward[chasing].float().mean()) if chasing.any() else float("nan")


def tennis_diagnostics(
    state: Mapping[str, Any], *, worlds: int = 32, decisions: int = 1000, seed: int = 0
) -> dict[str, Any]:
    """The table of the module docstring for a trained tennis team.

    Args:
        state: a loaded checkpoint or final team (:func:`rlhc.storage.final_team.load_team`).
        worlds: courts played at once.
        decisions: decisions per court and mode.
        seed: the courts' seed (the same for both modes); torch is seeded with it too.

    Returns:
        A JSON-ready dict; per-dimension entries are dicts keyed by :data:`ACTION_NAMES`.

    Raises:
        ValueError: ``state`` is not a tennis team.
    """
    if state["env"] != "tennis":
        raise ValueError(f"tennis_diagnostics needs a tennis team, got one of {state['env']!r}")
    options = observation_options(state)
    probe = make_env("tennis", num_envs=1, seed=seed, **options)
    restored = restore_policy(state, probe)
    probe.close()
    result: dict[str, Any] = {"worlds": worlds, "decisions": decisions, "seed": seed}
    for mode, interaction in (
        ("", InteractionType.RANDOM),
        ("_mode", InteractionType.DETERMINISTIC),
    ):
        torch.manual_seed(seed)
        with set_interaction_type(interaction):
            rollout = _play(restored, options, worlds, decisions, seed)
        result[f"hits_per_point{mode}"], result[f"points{mode}"] = _hits_per_point(rollout)
        result[f"toward_ball{mode}"] = _toward_ball(rollout)
        result[f"ended{mode}"] = _endings(rollout)
        if mode:
            continue
        distance, _, _ = _geometry(rollout)
        near = distance < NEAR_BALL
        scale = rollout[GROUP, SCALE]
        action = rollout[GROUP, ACTION].clamp(-1.0, 1.0)
        result["near_share"] = float(near.float().mean())
        result["sigma_near"] = _per_dimension(scale[near].mean(0) if near.any() else None)
        result["sigma_far"] = _per_dimension(scale[~near].mean(0) if (~near).any() else None)
        saturated = (action.abs() >= 0.99).float().reshape(-1, len(ACTION_NAMES))
        result["saturated"] = _per_dimension(saturated.mean(0))
    return result


#: The probe's ball (team frame, metres and m/s): 2 m up, falling at 3 m/s, no
#: horizontal speed, so that it comes down where it is.
PROBE_BALL = {"y": 2.0, "vx": 0.0, "vy": -3.0}
#: The probe's grid (team-frame x, metres) of ball and racket places, the racket's half.
PROBE_X = (-5.5, -4.5, -3.5, -2.5, -1.5)


def tracking_probe(
    policy: Callable[[TensorDictBase], Mapping[str, torch.Tensor]],
    *,
    extended_obs: bool = False,
    ball_x: Sequence[float] = PROBE_X,
    racket_x: Sequence[float] = PROBE_X,
) -> dict[str, Any]:
    """The mode move action of a racket on a falling ball, over a grid of places.

    Racket 0 (team A's back racket) stands on the ground at each of ``racket_x``, with
    the ball of :data:`PROBE_BALL` above each of ``ball_x``; the three other rackets
    stand at their serve positions, nothing moves. The observations are the game's own
    (:func:`~rlhc.envs.tennis.observations.observe_rackets`), raw.

    Args:
        policy: ``tensordict -> {"racket": actions}`` on raw observations, e.g. a
            restored team (:func:`~rlhc.evaluation.policies.restore_policy`).
        extended_obs: the team's observation option.
        ball_x: team-frame x of the ball (metres; negative: the racket's half).
        racket_x: team-frame x of the racket.

    Returns:
        ``move``: ``[len(ball_x)][len(racket_x)]`` mode move actions (``+``: towards the
        net); ``gain``: the least-squares slope of the move on the ball's offset (ball
        minus racket, per metre); ``toward``: the share of grid points with the ball at
        least 1 m away whose move points at it; ``ball_x``, ``racket_x``.

    Examples:
        >>> from rlhc.envs.tennis.scripted import ScriptedTennisPolicy
        >>> scripted = ScriptedTennisPolicy()  # reads raw worker observations
        >>> def team(td):
        ...     return {"racket": torch.from_numpy(scripted(td["racket", "observation"].numpy()))}
        >>> probe = tracking_probe(team)
        >>> round(probe["gain"], 2), probe["toward"]
        (0.32, 0.85)
    """
    bx, rx = np.meshgrid(np.asarray(ball_x, float), np.asarray(racket_x, float), indexing="ij")
    n = bx.size
    ball = np.stack([bx.ravel(), np.full(n, PROBE_BALL["y"])], axis=-1)
    ball_velocity = np.tile([PROBE_BALL["vx"], PROBE_BALL["vy"]], (n, 1))
    home = np.concatenate([HOME_X, HOME_X]) * TEAM_SIGN
    rackets = np.zeros((n, 4, 2))
    rackets[..., 0] = home
    rackets[:, 0, 0] = rx.ravel()
    rackets[..., 1] = CourtGeometry().racket_ground_y  # standing
    worker, manager = observe_rackets(
        ball, ball_velocity, rackets, np.zeros((n, 4, 2)), extended_obs
    )
    td = TensorDict(
        {
            (GROUP, OBSERVATION): torch.from_numpy(worker),
            (GROUP, MANAGER_OBSERVATION): torch.from_numpy(manager),
        },
        [n],
    )
    with set_interaction_type(InteractionType.DETERMINISTIC), torch.no_grad():
        move = policy(td)[GROUP][:, 0, 0].clamp(-1.0, 1.0).numpy().reshape(bx.shape)
    offset = bx - rx
    centred = offset - offset.mean()
    gain = float((centred * (move - move.mean())).sum() / (centred**2).sum())
    far = np.abs(offset) >= 1.0
    toward = float((np.sign(move[far]) == np.sign(offset[far])).mean())
    return {
        "ball_x": [float(x) for x in ball_x],
        "racket_x": [float(x) for x in racket_x],
        "move": move.round(4).tolist(),
        "gain": gain,
        "toward": toward,
    }


def _per_dimension(values: torch.Tensor | None) -> dict[str, float]:
    if values is None:
        return dict.fromkeys(ACTION_NAMES, float("nan"))
    return {name: float(value) for name, value in zip(ACTION_NAMES, values, strict=True)}
