"""Hydra schemas of the ``env`` config group (one dataclass per game).

Fields left at ``None`` fall back to the game's own default, so the game module
stays the single source of truth for its rules.
"""

from __future__ import annotations

from dataclasses import dataclass, fields
from typing import Any

from omegaconf import MISSING


@dataclass
class EnvConfig:
    """Options common to every game.

    Attributes:
        name: the game, ``"tennis"`` or ``"soccer"``.
        num_envs: worlds simulated by the one env object; ``None`` derives it from the
            algorithm's buffer size and time horizon (``ceil(buffer_size / time_horizon)``).
        max_cycles: steps after which an episode is truncated (``None``: the game's default).
    """

    name: str = MISSING
    num_envs: int | None = None
    max_cycles: int | None = None

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
    """

    name: str = "tennis"
    extended_obs: bool = False


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
