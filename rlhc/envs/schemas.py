"""Hydra schemas of the ``env`` config group (one dataclass per game, one per env source).

Fields left at ``None`` fall back to the game's own default, so the game module
stays the single source of truth for its rules. Each game names its schema in its
registry entry (:attr:`GameSpec.env_config <rlhc.envs.registry.GameSpec>`), which
:func:`rlhc.config.train_schema.register_configs` stores as ``<game>_schema``; the
environments of other libraries (:mod:`rlhc.envs.generic`: ``env=pettingzoo``,
``env=vmas``) have theirs in :data:`SOURCE_SCHEMAS`.
"""

from __future__ import annotations

from dataclasses import dataclass, fields
from typing import Any

from omegaconf import MISSING


@dataclass
class EnvConfig:
    """Options common to every game.

    Attributes:
        name: the game, a registered name (:func:`~rlhc.envs.registry.games`); each
            subclass defaults it to its game's.
        num_envs: worlds simulated by the one env object, a divisor of the world-decisions
            of an update; ``None``: the smallest divisor that keeps every world's share
            of an update within ``algo.time_horizon`` decisions.
        max_cycles: decisions after which an episode is truncated (``None``: the game's
            default).
        decision_interval: physics frames per decision, the action held in between
            (``None``: the game's default — tennis 5 frames of 0.02 s, ML-Agents'
            default; soccer 1 frame of 0.1 s).
    """

    name: str = MISSING
    num_envs: int | None = None
    max_cycles: int | None = None
    decision_interval: int | None = None

    def game_options(self) -> dict[str, Any]:
        """The keyword options for the game constructor (unset fields omitted)."""
        skip = {"name", "num_envs"}
        return {
            f.name: getattr(self, f.name)
            for f in fields(self)
            if f.name not in skip and getattr(self, f.name) is not None
        }


@dataclass
class TennisEnvConfig(EnvConfig):
    """2 vs 2 doubles tennis.

    Attributes:
        extended_obs: add teammate distance and velocity difference to both observations
            (worker 8 → 12, manager 10 → 14), the paper's "extended observation" variant.
        fault_penalty: who pays the -0.1 of a lost point: ``team`` (both rackets of the
            team that lost it) or ``nearest`` (one racket, the rule of earlier versions);
            ``None``: ``team``.
    """

    name: str = "tennis"
    extended_obs: bool = False
    fault_penalty: str | None = None


@dataclass
class SoccerEnvConfig(EnvConfig):
    """2 vs 2 soccer (striker + goalie per team).

    Attributes:
        striker_time_reward: per-step reward of each striker (``None``: the game's -0.001).
        goalie_time_reward: per-step reward of each goalie (``None``: the game's +0.001).
    """

    name: str = "soccer"
    striker_time_reward: float | None = None
    goalie_time_reward: float | None = None


@dataclass
class SourceEnvConfig(EnvConfig):
    """Options common to the environments of other libraries (:mod:`rlhc.envs.generic`).

    Attributes:
        manager_view: what the manager critic reads of each agent: ``team`` (the agent's
            own observation, then its group mates' in index order after it, wrapping
            round: a centralised critic that knows whose value it gives), ``world`` (the
            group's observations in index order, the same for every agent: the input of
            BenchMARL's and TorchRL's MAPPO critic, run once per world), ``state`` (the
            environment's global ``state()``, where it has one; also run once per world)
            or ``<module>:<callable>`` (a function
            from one step's observations ``{group: [N, n_g, d_g]}`` to the manager's
            ``{group: [N, n_g, d_m]}``).
        groups: the agent groups, ``{group: [agent, ...]}``; ``None``: TorchRL's
            convention (agents named ``<group>_<i>`` grouped by prefix).
        kwargs: keyword arguments of the environment's constructor.
        max_cycles: decisions after which an episode is truncated (``None``: only when
            the environment itself truncates it).
    """

    manager_view: str = "team"
    groups: Any = None  # a mapping or None (Any: an override replaces it whole)
    kwargs: Any = None  # a mapping or None


@dataclass
class PettingZooEnvConfig(SourceEnvConfig):
    """Any PettingZoo ``ParallelEnv``, ``num_envs`` copies stepped as one batch.

    Attributes:
        factory: ``<module>:<callable>`` that returns the ``ParallelEnv``, called with
            ``kwargs``, e.g. ``mpe2.simple_spread_v3:parallel_env``.
    """

    name: str = "pettingzoo"
    factory: str = MISSING


@dataclass
class VmasEnvConfig(SourceEnvConfig):
    """Any VMAS scenario, ``num_envs`` vectorised worlds (TorchRL's ``VmasEnv``).

    Attributes:
        scenario: the VMAS scenario's name, e.g. ``navigation`` or ``balance``.
        continuous_actions: continuous (``true``) or discrete actions.
    """

    name: str = "vmas"
    scenario: str = MISSING
    continuous_actions: bool = True


#: The environments of other libraries: ``env=<name>`` -> its schema.
SOURCE_SCHEMAS: dict[str, type[SourceEnvConfig]] = {
    "pettingzoo": PettingZooEnvConfig,
    "vmas": VmasEnvConfig,
}
