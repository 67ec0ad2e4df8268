"""The built-in team policies: ``random`` and the game's ``scripted`` team.

A *team policy* maps the env's current TensorDict (``[K]`` worlds) to an action for
**every** agent of every group, ``{group: [K, n_g, ...]}``; the match loop keeps those
of the agents on its side. One batched call for both teams keeps every policy free of
team bookkeeping. This module reads only the env layer, so that the league
(:mod:`rlhc.training.league`) can use the built-in teams without the checkpoint machinery.
"""

from __future__ import annotations

from typing import Protocol

import torch
from tensordict import TensorDictBase

from rlhc.envs.keys import ACTION
from rlhc.envs.registry import game_spec
from rlhc.envs.torchrl_adapter import BatchedGameEnv


class TeamPolicy(Protocol):
    """``tensordict [K] -> {group: actions of all agents}``; see the module docstring."""

    def __call__(self, tensordict: TensorDictBase) -> dict[str, torch.Tensor]: ...


class RandomPolicy:
    """Uniform actions from the env's action specs (torch's global generator: seed it).

    Examples:
        >>> from rlhc.envs import make_env
        >>> env = make_env("soccer", num_envs=2, seed=0)
        >>> sorted(RandomPolicy(env)(env.reset()))
        ['goalie', 'striker']
    """

    def __init__(self, env: BatchedGameEnv) -> None:
        self.specs = {g.name: env.full_action_spec[g.name, ACTION] for g in env.game.groups}

    def __call__(self, tensordict: TensorDictBase) -> dict[str, torch.Tensor]:
        return {group: spec.rand() for group, spec in self.specs.items()}


class ScriptedPolicy:
    """The game's scripted team (:attr:`GameSpec.scripted <rlhc.envs.registry.GameSpec>`),
    batched over worlds (deterministic); it reads the env's game, not the TensorDict.

    Raises:
        ValueError: the env's game is not registered.

    Examples:
        >>> from rlhc.envs import make_env
        >>> env = make_env("tennis", num_envs=2, seed=0)
        >>> ScriptedPolicy(env)(env.reset())["racket"].shape
        torch.Size([2, 4, 3])
    """

    def __init__(self, env: BatchedGameEnv) -> None:
        self.env = env
        self.team = game_spec(env.game.name).scripted

    def __call__(self, tensordict: TensorDictBase) -> dict[str, torch.Tensor]:
        return {
            group: torch.from_numpy(actions) for group, actions in self.team(self.env.game).items()
        }
