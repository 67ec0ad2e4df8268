"""The registry of games: each game registers itself once, and every per-game table reads it.

A game package (``rlhc/envs/<game>/``) calls :func:`register_game` once, in its
``__init__.py``, with a :class:`GameSpec`: its :class:`~rlhc.envs.base.BatchedGame`,
its Hydra schema, its groups, its scripted team and its match rules. Everything that
used to list the games by hand reads the registry instead: :func:`rlhc.envs.make_env`,
the ``env`` config group (:func:`rlhc.config.train_schema.register_configs`), checkpoint restoring,
``rlhc.evaluate``'s validation, the match rules, the scripted opponent, and the tests
parametrised over the games.

The games are found without a list: on first use, :func:`games` imports every
sub-package of :mod:`rlhc.envs`, and each registers itself as it is imported.

Examples:
    >>> from rlhc.envs.registry import game_spec, games
    >>> games()
    ('soccer', 'tennis')
    >>> game_spec("soccer").groups, game_spec("tennis").points_to_win
    (('striker', 'goalie'), 5)
"""

from __future__ import annotations

import importlib
import pkgutil
from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    from rlhc.envs.base import BatchedGame
    from rlhc.envs.schemas import EnvConfig

#: A scripted team: the game (all its worlds, in their current state) -> an action for
#: every agent of every group, ``{group: [N, n_g, ...]}``, as :meth:`BatchedGame.step`
#: takes them. It may read the game's observations or its full state.
ScriptedTeam = Callable[["BatchedGame"], dict[str, np.ndarray]]
#: A shaping potential: a game of its spec -> ``Φ`` of every agent of every group,
#: ``[N, n_g]`` (``Any``: each game's potential reads its own game class).
Potential = Callable[[Any], dict[str, np.ndarray]]


@dataclass(frozen=True)
class GameSpec:
    """What the rest of the package needs to know about one game.

    Attributes:
        name: the game's name, e.g. ``"tennis"``: ``env=<name>`` on the command line,
            ``conf/env/<name>.yaml``, ``<name>_schema`` in Hydra's ConfigStore; equal
            to ``game.name``.
        game: the :class:`~rlhc.envs.base.BatchedGame` subclass, built as
            ``game(num_worlds=N, seed=seed, **options)``.
        env_config: the Hydra schema of its options, a subclass of
            :class:`~rlhc.envs.schemas.EnvConfig` whose ``name`` defaults to ``name``.
        groups: the names of its agent groups, in the game's order.
        scripted: its scripted team (:data:`ScriptedTeam`): the ``scripted`` player of
            ``rlhc.evaluate`` and of the league.
        points_to_win: match rule: the first team to this many points (points or goals)
            wins; a match still undecided after ``points_to_win × max_cycles`` decisions
            is a draw.
        potential: its reward-shaping potential (:data:`Potential`, for
            ``shaping.scale > 0``: :mod:`rlhc.building.shaping`), or ``None`` if it has none.

    Examples:
        >>> from rlhc.envs.registry import game_spec
        >>> spec = game_spec("tennis")
        >>> spec.game.__name__, spec.env_config.__name__, spec.groups
        ('TennisGame', 'TennisEnvConfig', ('racket',))
    """

    name: str
    game: type[BatchedGame]
    env_config: type[EnvConfig]
    groups: tuple[str, ...]
    scripted: ScriptedTeam
    points_to_win: int
    potential: Potential | None = None

    def __post_init__(self) -> None:
        if self.game.name != self.name:
            raise ValueError(
                f"game {self.name!r}: its class {self.game.__name__} is named "
                f"{self.game.name!r}; the two must be equal"
            )
        schema_name = getattr(self.env_config, "name", None)
        if schema_name != self.name:
            raise ValueError(
                f"game {self.name!r}: its schema {self.env_config.__name__} has "
                f"name={schema_name!r}; it must default to {self.name!r}"
            )
        if not self.groups:
            raise ValueError(f"game {self.name!r} has no groups; give at least one")
        if self.points_to_win < 1:
            raise ValueError(
                f"game {self.name!r}: points_to_win={self.points_to_win}; allowed: >= 1"
            )


_SPECS: dict[str, GameSpec] = {}
_discovered = False


def register_game(spec: GameSpec) -> GameSpec:
    """Add ``spec`` to the registry (once per game; returns it).

    Raises:
        ValueError: another spec is already registered under ``spec.name``.

    Examples:
        >>> from rlhc.envs.registry import game_spec, register_game
        >>> register_game(game_spec("soccer")) is game_spec("soccer")  # the same spec again
        True
    """
    known = _SPECS.get(spec.name)
    if known is not None and known != spec:
        raise ValueError(
            f"game {spec.name!r} is already registered (by {known.game.__module__}); "
            "a game registers once"
        )
    _SPECS[spec.name] = spec
    return spec


def _discover() -> None:
    """Import every sub-package of :mod:`rlhc.envs` once (each registers its game)."""
    global _discovered
    if _discovered:
        return
    _discovered = True
    for module in pkgutil.iter_modules([str(Path(__file__).parent)]):
        if module.ispkg:
            importlib.import_module(f"{__package__}.{module.name}")


def games() -> tuple[str, ...]:
    """The names of the registered games, sorted.

    Examples:
        >>> games()
        ('soccer', 'tennis')
    """
    _discover()
    return tuple(sorted(_SPECS))


def game_spec(name: str) -> GameSpec:
    """The :class:`GameSpec` registered as ``name``.

    Raises:
        ValueError: no game has that name; the message lists the registered ones.

    Examples:
        >>> game_spec("curling")
        Traceback (most recent call last):
        ...
        ValueError: unknown env 'curling'; choose one of ['soccer', 'tennis']
    """
    _discover()
    if name not in _SPECS:
        raise ValueError(f"unknown env {name!r}; choose one of {sorted(_SPECS)}")
    return _SPECS[name]


def shapable_games() -> list[str]:
    """The registered games that have a shaping potential (``shaping.scale > 0`` needs one).

    Examples:
        >>> shapable_games()
        ['soccer']
    """
    return [name for name in games() if game_spec(name).potential is not None]


class GameTable(Mapping[str, GameSpec]):
    """A read-only view ``name -> GameSpec`` of the registry (games found on first use)."""

    def __getitem__(self, name: str) -> GameSpec:
        _discover()
        return _SPECS[name]

    def __iter__(self) -> Iterator[str]:
        return iter(games())

    def __len__(self) -> int:
        return len(games())

    def __repr__(self) -> str:
        return f"GameTable({list(games())})"


#: ``name -> GameSpec`` of every registered game.
GAMES: Mapping[str, GameSpec] = GameTable()

__all__ = [
    "GAMES",
    "GameSpec",
    "GameTable",
    "ScriptedTeam",
    "game_spec",
    "games",
    "register_game",
    "shapable_games",
]
