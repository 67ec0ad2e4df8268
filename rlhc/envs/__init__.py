"""The games: 2 vs 2 doubles tennis and 2 vs 2 soccer, found through the game registry;
and any PettingZoo or VMAS environment (:mod:`rlhc.envs.generic`).

Each game is a :class:`~rlhc.envs.base.BatchedGame` (numpy, N worlds in lockstep),
registered once in :mod:`rlhc.envs.registry` by its package, and exposed two ways:

* :func:`make_env` — a batched TorchRL ``EnvBase`` (``batch_size=[num_envs]``), the
  training path (also of ``pettingzoo`` and ``vmas``, the :data:`SOURCES`);
* :func:`make_parallel_env` (or ``rlhc.envs.<game>.parallel_env()``) — a PettingZoo
  ``ParallelEnv`` of one world; :func:`make_aec_env` its AEC view.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from rlhc.envs.registry import GAMES, GameSpec, game_spec, games, register_game
from rlhc.envs.schemas import SOURCE_SCHEMAS

#: The environments of other libraries, ``env=<name>``: :mod:`rlhc.envs.generic`.
SOURCES: tuple[str, ...] = tuple(SOURCE_SCHEMAS)

if TYPE_CHECKING:
    from pettingzoo.utils.env import AECEnv
    from torchrl.envs import EnvBase

    from rlhc.envs.base import BatchedGame
    from rlhc.envs.pettingzoo_adapter import BatchedGameParallelEnv


def game_class(name: str) -> type[BatchedGame]:
    """The :class:`BatchedGame` subclass registered as ``name``.

    Raises:
        ValueError: no game has that name; the message lists the registered ones.

    Examples:
        >>> game_class("tennis").__name__
        'TennisGame'
    """
    return game_spec(name).game


def make_game(
    name: str, num_envs: int = 1, seed: int | None = None, **env_options: Any
) -> BatchedGame:
    """Build the numpy game ``name`` with ``num_envs`` worlds (options are the game's).

    Examples:
        >>> make_game("soccer", num_envs=3, seed=0).num_worlds
        3
    """
    return game_class(name)(num_worlds=num_envs, seed=seed, **env_options)


def make_env(
    name: str,
    num_envs: int = 1,
    seed: int | None = None,
    device: str = "cpu",
    **env_options: Any,
) -> EnvBase:
    """A batched TorchRL env over ``num_envs`` courts/pitches of game ``name`` (or worlds
    of a :data:`SOURCES` environment: :func:`rlhc.envs.generic.make_source_env`).

    Args:
        name: a registered game (:func:`~rlhc.envs.registry.games`), e.g. ``"tennis"``,
            or ``"pettingzoo"`` / ``"vmas"``.
        num_envs: number of worlds simulated by the one env object (its ``batch_size``).
        seed: seed of the game's random generator.
        device: torch device of the returned tensors.
        **env_options: game options, e.g. ``extended_obs=True`` or ``max_cycles=500``.

    Returns:
        A TorchRL ``EnvBase`` with ``batch_size=[num_envs]`` following the TensorDict
        contract of :mod:`rlhc.envs.torchrl_adapter` (groups, ``observation``,
        ``manager_observation``, …; the keys are in :mod:`rlhc.envs.keys`).

    Examples:
        >>> from rlhc.envs import make_env
        >>> env = make_env("tennis", num_envs=4, seed=0)
        >>> td = env.rollout(3)
        >>> td["racket", "observation"].shape
        torch.Size([4, 3, 4, 8])
    """
    if name in SOURCES:
        from rlhc.envs.generic import make_source_env

        return make_source_env(name, num_envs=num_envs, seed=seed, device=device, **env_options)
    from rlhc.envs.torchrl_adapter import BatchedGameEnv

    game = make_game(name, num_envs=num_envs, seed=seed, **env_options)
    return BatchedGameEnv(game, device=device)


def make_parallel_env(
    name: str, render_mode: str | None = None, seed: int | None = None, **options: Any
) -> BatchedGameParallelEnv:
    """The PettingZoo ``ParallelEnv`` of one world of game ``name``.

    Args:
        name: a registered game.
        render_mode: ``None`` or ``"rgb_array"``.
        seed: seed of the game's generator (``reset(seed=...)`` re-seeds).
        **options: the game's options (``max_cycles``, …).

    Examples:
        >>> env = make_parallel_env("tennis", max_cycles=200)
        >>> observations, infos = env.reset(seed=0)
        >>> sorted(observations)
        ['racket_0', 'racket_1', 'racket_2', 'racket_3']
    """
    from rlhc.envs.pettingzoo_adapter import BatchedGameParallelEnv

    return BatchedGameParallelEnv(make_game(name, seed=seed, **options), render_mode=render_mode)


def make_aec_env(
    name: str, render_mode: str | None = None, seed: int | None = None, **options: Any
) -> AECEnv:
    """The same world through PettingZoo's AEC API (``parallel_to_aec``): agents act in turn.

    Examples:
        >>> make_aec_env("soccer").possible_agents
        ['striker_0', 'striker_1', 'goalie_0', 'goalie_1']
    """
    from pettingzoo.utils.conversions import parallel_to_aec

    return parallel_to_aec(make_parallel_env(name, render_mode=render_mode, seed=seed, **options))


__all__ = [
    "GAMES",
    "SOURCES",
    "GameSpec",
    "game_class",
    "game_spec",
    "games",
    "make_aec_env",
    "make_env",
    "make_game",
    "make_parallel_env",
    "register_game",
]
