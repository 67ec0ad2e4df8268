"""Potential-based reward shaping (beyond the paper; off unless ``shaping.scale > 0``).

Ng, Harada & Russell (1999): adding ``F(s, s') = γ Φ(s') − Φ(s)`` to every reward keeps
the optimal policies of an MDP for any potential ``Φ`` of the state (``Φ = 0`` once the
episode terminates). :class:`PotentialShaping` is placed *after* the episode-return
tracking, so the logged ``cumulative_reward`` stays the game's own reward. A game's
potential comes from its registry entry (soccer: the ball's progress towards the
opponents' goal, :mod:`rlhc.envs.soccer.shaping`).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import torch
from tensordict import TensorDictBase
from torchrl.envs import Transform

from rlhc.envs.keys import REWARD, TERMINATED
from rlhc.envs.registry import game_spec, games, shapable_games

Potential = Callable[[], dict[str, np.ndarray]]


def game_potential(game: object) -> Potential:
    """The shaping potential of a game (a closure over it).

    Raises:
        ValueError: the game has no potential (names it and the games that do).
    """
    name = getattr(game, "name", type(game).__name__)
    potential = game_spec(name).potential if name in games() else None
    if potential is None:
        raise ValueError(
            f"shaping.scale > 0 needs a potential; env {name!r} has none "
            f"(games with one: {', '.join(shapable_games())})"
        )
    return lambda: potential(game)  # type: ignore[arg-type]


class PotentialShaping(Transform):
    """Adds ``scale · (γ Φ(s') − Φ(s))`` to the reward of each of ``groups``, ``potential``
    returning ``Φ`` of the env's current state per group ``[N, n_g]``."""

    def __init__(self, potential: Potential, groups: list[str], gamma: float, scale: float):
        keys = [(g, REWARD) for g in groups]
        super().__init__(in_keys=keys, out_keys=keys)
        self.potential = potential
        self.groups = groups
        self.gamma = gamma
        self.scale = scale
        self._last: dict[str, torch.Tensor] = {}

    def _current(self) -> dict[str, torch.Tensor]:
        return {g: torch.tensor(v).unsqueeze(-1) for g, v in self.potential().items()}

    def _reset(
        self, tensordict: TensorDictBase, tensordict_reset: TensorDictBase
    ) -> TensorDictBase:
        # Φ depends on the state only: recomputing it for the worlds not reset is a no-op.
        self._last = self._current()
        return tensordict_reset

    def _step(self, tensordict: TensorDictBase, next_tensordict: TensorDictBase) -> TensorDictBase:
        after = self._current()
        for group in self.groups:
            terminated = next_tensordict[group, TERMINATED]
            following = torch.where(terminated, torch.zeros_like(after[group]), after[group])
            shaping = self.scale * (self.gamma * following - self._last[group])
            reward = next_tensordict[group, REWARD]
            next_tensordict.set((group, REWARD), reward + shaping.to(reward.dtype))
        self._last = after
        return next_tensordict
