"""Why a tennis team does (not) rally: what its policy does near the ball.

A trained team plays itself on fresh courts twice, sampling its actions as in training
and with its mode actions as in matches, and reports:

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
racket-decisions per mode.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import torch
from tensordict import TensorDictBase
from tensordict.nn import InteractionType, set_interaction_type

from rlhc.envs import make_env
from rlhc.envs.keys import ACTION, ENDED_PREFIX, INFO, NEXT, OBSERVATION, SCALE
from rlhc.envs.tennis.observations import LENGTH_SCALE
from rlhc.envs.tennis.rules import POINT_ENDINGS
from rlhc.evaluation.policies import RestoredPolicy, observation_options, restore_policy

#: Metres between racket and ball under which a racket is "near the ball".
NEAR_BALL = 1.0
#: The three action dimensions of a racket.
ACTION_NAMES = ("move", "jump", "tilt")
GROUP = "racket"


def _play(
    restored: RestoredPolicy, options: Mapping[str, Any], worlds: int, decisions: int, seed: int
) -> TensorDictBase:
    def policy(tensordict: TensorDictBase) -> TensorDictBase:
        """The restored actors, also keeping each decision's scale."""
        out = restored.actors[GROUP](restored.inputs(GROUP, tensordict))
        tensordict.set((GROUP, ACTION), out[GROUP, ACTION])
        tensordict.set((GROUP, SCALE), out[GROUP, SCALE].expand_as(out[GROUP, ACTION]))
        return tensordict

    env = make_env("tennis", num_envs=worlds, seed=seed, **options)
    try:
        with torch.no_grad():
            return env.rollout(decisions, policy=policy, break_when_any_done=False)
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

    ``state`` is a loaded team (:func:`rlhc.storage.final_team.load_team`), played on
    ``worlds`` courts for ``decisions`` decisions per mode, courts and torch seeded with
    ``seed``. Returns a JSON-ready dict (per-dimension entries keyed by
    :data:`ACTION_NAMES`); :class:`ValueError` if ``state`` is not a tennis team.
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


def _per_dimension(values: torch.Tensor | None) -> dict[str, float]:
    if values is None:
        return dict.fromkeys(ACTION_NAMES, float("nan"))
    return {name: float(value) for name, value in zip(ACTION_NAMES, values, strict=True)}
