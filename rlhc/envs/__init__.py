"""The games: 2 vs 2 doubles tennis and 2 vs 2 soccer.

Each game is a :class:`~rlhc.envs.base.BatchedGame` (numpy, N worlds in lockstep),
exposed two ways:

* :func:`make_env` — a batched TorchRL ``EnvBase`` (``batch_size=[num_envs]``), the
  training path;
* ``rlhc.envs.<game>.parallel_env()`` — a PettingZoo ``ParallelEnv`` of one world.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from torchrl.envs import EnvBase

    from rlhc.envs.base import BatchedGame

#: game name -> "module:class" of its BatchedGame (imported lazily).
GAMES: dict[str, str] = {
    "tennis": "rlhc.envs.tennis.game:TennisGame",
    "soccer": "rlhc.envs.soccer.game:SoccerGame",
}


def game_class(name: str) -> type[BatchedGame]:
    """The :class:`BatchedGame` subclass registered as ``name``."""
    if name not in GAMES:
        raise ValueError(f"unknown env {name!r}; choose one of {sorted(GAMES)}")
    module_name, class_name = GAMES[name].split(":")
    return getattr(importlib.import_module(module_name), class_name)


def make_game(
    name: str, num_envs: int = 1, seed: int | None = None, **env_options: Any
) -> BatchedGame:
    """Build the numpy game ``name`` with ``num_envs`` worlds (options are the game's)."""
    return game_class(name)(num_worlds=num_envs, seed=seed, **env_options)


def make_env(
    name: str,
    num_envs: int = 1,
    seed: int | None = None,
    device: str = "cpu",
    **env_options: Any,
) -> EnvBase:
    """A batched TorchRL env over ``num_envs`` courts/pitches of game ``name``.

    Args:
        name: ``"tennis"`` or ``"soccer"``.
        num_envs: number of worlds simulated by the one env object (its ``batch_size``).
        seed: seed of the game's random generator.
        device: torch device of the returned tensors.
        **env_options: game options, e.g. ``extended_obs=True`` or ``max_cycles=500``.

    Returns:
        A TorchRL ``EnvBase`` with ``batch_size=[num_envs]`` following the TensorDict
        contract of the design (groups, ``observation``, ``manager_observation``, …).

    Examples:
        >>> from rlhc.envs import make_env
        >>> env = make_env("tennis", num_envs=4, seed=0)
        >>> td = env.rollout(3)
        >>> td["racket", "observation"].shape
        torch.Size([4, 3, 4, 8])
    """
    from rlhc.envs.torchrl_adapter import BatchedGameEnv

    game = make_game(name, num_envs=num_envs, seed=seed, **env_options)
    return BatchedGameEnv(game, device=device)


__all__ = ["GAMES", "game_class", "make_env", "make_game"]
