"""2 vs 2 doubles tennis on pymunk (side view), after the Unity tennis of the RLHC paper.

* :class:`TennisGame` — N courts in lockstep (numpy), the training path via
  :func:`rlhc.envs.make_env`;
* :func:`parallel_env` / :func:`env` — PettingZoo envs of one court (parallel / AEC);
* :class:`ScriptedTennisPolicy` — a ball-tracking opponent for tests, demos and evaluation.

Examples:
    >>> from rlhc.envs.tennis import parallel_env
    >>> env = parallel_env(render_mode="rgb_array", max_cycles=200)
    >>> observations, infos = env.reset(seed=0)
    >>> sorted(observations)
    ['racket_0', 'racket_1', 'racket_2', 'racket_3']
"""

from __future__ import annotations

from typing import Any

from pettingzoo.utils import parallel_to_aec
from pettingzoo.utils.env import AECEnv

from rlhc.envs.pettingzoo_adapter import BatchedGameParallelEnv
from rlhc.envs.tennis.game import TennisGame
from rlhc.envs.tennis.scripted import ScriptedTennisPolicy


def parallel_env(
    render_mode: str | None = None, seed: int | None = None, **options: Any
) -> BatchedGameParallelEnv:
    """The PettingZoo ``ParallelEnv`` of one tennis court.

    Args:
        render_mode: ``None`` or ``"rgb_array"``.
        seed: seed of the serve generator (``reset(seed=...)`` re-seeds).
        **options: :class:`TennisGame` options (``max_cycles``, ``extended_obs``, …).
    """
    return BatchedGameParallelEnv(TennisGame(num_worlds=1, seed=seed, **options), render_mode)


def env(render_mode: str | None = None, seed: int | None = None, **options: Any) -> AECEnv:
    """The same court through PettingZoo's AEC API (``parallel_to_aec``)."""
    return parallel_to_aec(parallel_env(render_mode=render_mode, seed=seed, **options))


__all__ = ["ScriptedTennisPolicy", "TennisGame", "env", "parallel_env"]
