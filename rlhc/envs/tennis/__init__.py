"""2 vs 2 doubles tennis on pymunk (side view), after the Unity tennis of the RLHC paper.

* :class:`TennisGame` — N courts in lockstep (numpy), the training path via
  :func:`rlhc.envs.make_env`;
* :func:`parallel_env` / :func:`env` — PettingZoo envs of one court (parallel / AEC);
* :class:`ScriptedTennisPolicy` — a ball-tracking opponent for tests, demos and evaluation
  (:func:`~rlhc.envs.tennis.scripted.scripted_team`, the game's scripted team).

Importing this package registers the game (:data:`SPEC`) in :mod:`rlhc.envs.registry`.

Examples:
    >>> from rlhc.envs.tennis import parallel_env
    >>> env = parallel_env(render_mode="rgb_array", max_cycles=200)
    >>> observations, infos = env.reset(seed=0)
    >>> sorted(observations)
    ['racket_0', 'racket_1', 'racket_2', 'racket_3']
"""

from __future__ import annotations

from typing import Any

from pettingzoo.utils.env import AECEnv

from rlhc.envs import make_aec_env, make_parallel_env
from rlhc.envs.pettingzoo_adapter import BatchedGameParallelEnv
from rlhc.envs.registry import GameSpec, register_game
from rlhc.envs.schemas import TennisEnvConfig
from rlhc.envs.tennis.game import TennisGame
from rlhc.envs.tennis.scripted import ScriptedTennisPolicy, scripted_team

#: The game's entry in the registry.
SPEC = register_game(
    GameSpec(
        name="tennis",
        game=TennisGame,
        env_config=TennisEnvConfig,
        groups=("racket",),
        scripted=scripted_team,
        points_to_win=5,  # first to 5 points, within 5 rallies of max_cycles decisions
    )
)


def parallel_env(
    render_mode: str | None = None, seed: int | None = None, **options: Any
) -> BatchedGameParallelEnv:
    """The PettingZoo ``ParallelEnv`` of one tennis court.

    Args:
        render_mode: ``None`` or ``"rgb_array"``.
        seed: seed of the serve generator (``reset(seed=...)`` re-seeds).
        **options: :class:`TennisGame` options (``max_cycles``, ``extended_obs``, …).
    """
    return make_parallel_env(SPEC.name, render_mode=render_mode, seed=seed, **options)


def env(render_mode: str | None = None, seed: int | None = None, **options: Any) -> AECEnv:
    """The same court through PettingZoo's AEC API (``parallel_to_aec``)."""
    return make_aec_env(SPEC.name, render_mode=render_mode, seed=seed, **options)


__all__ = ["SPEC", "ScriptedTennisPolicy", "TennisGame", "env", "parallel_env"]
