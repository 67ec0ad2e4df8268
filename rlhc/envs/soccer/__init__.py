"""2 vs 2 soccer (striker + goalie per team) on pymunk, after the Unity soccer of the RLHC paper.

* :class:`SoccerGame` — N pitches in lockstep (numpy), the training path via
  :func:`rlhc.envs.make_env` (``make_env("soccer", num_envs=N)``);
* :func:`parallel_env` / :func:`env` — a PettingZoo env of one pitch;
* :func:`scripted_actions` — a ball-chasing striker and a goal-guarding goalie, batched,
  as evaluation opponents (:func:`~rlhc.envs.soccer.scripted.scripted_team`, the game's
  scripted team).

Importing this package registers the game (:data:`SPEC`) in :mod:`rlhc.envs.registry`.
"""

from __future__ import annotations

from typing import Any

from pettingzoo import AECEnv

from rlhc.envs import make_aec_env, make_parallel_env
from rlhc.envs.pettingzoo_adapter import BatchedGameParallelEnv
from rlhc.envs.registry import GameSpec, register_game
from rlhc.envs.schemas import SoccerEnvConfig
from rlhc.envs.soccer.game import SoccerGame
from rlhc.envs.soccer.options import SoccerOptions
from rlhc.envs.soccer.scripted import scripted_actions, scripted_team
from rlhc.envs.soccer.shaping import ball_progress

#: The game's entry in the registry.
SPEC = register_game(
    GameSpec(
        name="soccer",
        game=SoccerGame,
        env_config=SoccerEnvConfig,
        groups=("striker", "goalie"),
        scripted=scripted_team,
        points_to_win=1,  # one goal wins; no goal within one episode is a draw
        potential=ball_progress,
    )
)


def parallel_env(
    render_mode: str | None = None, seed: int | None = None, **options: Any
) -> BatchedGameParallelEnv:
    """The PettingZoo ``ParallelEnv`` of one pitch.

    Args:
        render_mode: ``None`` or ``"rgb_array"``.
        seed: seed of the kick-off jitter (``reset(seed=...)`` re-seeds).
        **options: fields of :class:`SoccerOptions`.

    Returns:
        Agents ``striker_0, striker_1, goalie_0, goalie_1``; the manager observation of
        each agent is in ``infos[agent]["manager_observation"]``.

    Examples:
        >>> env = parallel_env(seed=0)
        >>> observations, infos = env.reset(seed=0)
        >>> observations["striker_0"].shape, infos["goalie_1"]["manager_observation"].shape
        ((112,), (200,))
    """
    return make_parallel_env(SPEC.name, render_mode=render_mode, seed=seed, **options)


def env(render_mode: str | None = None, seed: int | None = None, **options: Any) -> AECEnv:
    """The PettingZoo AEC view of :func:`parallel_env` (agents act in turn)."""
    return make_aec_env(SPEC.name, render_mode=render_mode, seed=seed, **options)


__all__ = ["SPEC", "SoccerGame", "SoccerOptions", "env", "parallel_env", "scripted_actions"]
