"""Team policies: what plays one side of a match.

A *team policy* maps the env's current TensorDict (batch ``[K]`` worlds) to an action
for **every** agent of every group, ``{group: [K, n_g, ...]}``; the match loop
(:mod:`rlhc.evaluation.matches`) keeps the actions of the agents on this policy's side
and discards the rest. Computing both teams' actions costs one batched call and keeps
every policy free of team bookkeeping.

| spec | policy |
|---|---|
| ``random`` | uniform over each agent's action space |
| ``scripted`` | the game's scripted players (:mod:`rlhc.envs.tennis.scripted`, :mod:`rlhc.envs.soccer.scripted`) |
| a path | a checkpoint file or a run directory (its ``checkpoints/latest.pt``) |
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any, Protocol

import torch
from tensordict import TensorDictBase

from rlhc.checkpoint import load_checkpoint
from rlhc.envs.torchrl_adapter import BatchedGameEnv
from rlhc.evaluation.policies import observation_options, restore_policy

BUILT_IN = ("random", "scripted")


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
        self.specs = {g.name: env.full_action_spec[g.name, "action"] for g in env.game.groups}

    def __call__(self, tensordict: TensorDictBase) -> dict[str, torch.Tensor]:
        return {group: spec.rand() for group, spec in self.specs.items()}


class ScriptedPolicy:
    """The game's scripted players, batched over worlds (deterministic).

    Tennis reads the worker observations; soccer reads the full state of the env's
    game, which is the state the given TensorDict describes.
    """

    def __init__(self, env: BatchedGameEnv) -> None:
        self.env = env
        self._act: Callable[[TensorDictBase], dict[str, torch.Tensor]]
        if env.game.name == "tennis":
            from rlhc.envs.tennis.scripted import ScriptedTennisPolicy

            tennis = ScriptedTennisPolicy(
                env.game.geometry,  # type: ignore[attr-defined]
                env.game.decision_interval,  # type: ignore[attr-defined]
            )
            self._act = lambda td: {
                "racket": torch.from_numpy(tennis(td["racket", "observation"].cpu().numpy()))
            }
        elif env.game.name == "soccer":
            from rlhc.envs.soccer.scripted import scripted_actions

            options = env.game.options  # type: ignore[attr-defined]
            self._act = lambda td: {
                group: torch.from_numpy(actions)
                for group, actions in scripted_actions(env.game.state(), options).items()
            }
        else:
            raise ValueError(f"no scripted players for env {env.game.name!r}")

    def __call__(self, tensordict: TensorDictBase) -> dict[str, torch.Tensor]:
        return self._act(tensordict)


def load_policy_checkpoint(spec: str, env_name: str) -> dict[str, Any]:
    """Load the checkpoint ``spec`` and check it was trained on ``env_name``.

    Raises:
        FileNotFoundError: the path does not exist or holds no checkpoint (named).
        ValueError: the checkpoint is from another game (names the path and both games).
    """
    state = load_checkpoint(spec)
    if state["env"] != env_name:
        raise ValueError(
            f"checkpoint {spec!r} ({state['path']}) was trained on {state['env']!r}, "
            f"but this evaluation plays {env_name!r}"
        )
    return state


def is_built_in(spec: str) -> bool:
    """Whether ``spec`` names a built-in opponent rather than a checkpoint path."""
    return spec in BUILT_IN


def player_options(specs: list[str], env_name: str) -> dict[str, Any]:
    """The observation-affecting game options the checkpoint players agree on.

    Raises:
        ValueError: two checkpoints were trained with different options (named).
    """
    agreed: dict[str, Any] = {}
    source: dict[str, str] = {}
    for spec in specs:
        if is_built_in(spec):
            continue
        for key, value in observation_options(load_policy_checkpoint(spec, env_name)).items():
            if key in agreed and agreed[key] != value:
                raise ValueError(
                    f"checkpoints {source[key]!r} and {spec!r} disagree on env option "
                    f"{key}: {agreed[key]!r} vs {value!r}; they cannot play in one env"
                )
            agreed[key], source[key] = value, spec
    return agreed


def make_team_policy(spec: str, env: BatchedGameEnv) -> TeamPolicy:
    """The team policy named ``spec`` (``random``, ``scripted`` or a checkpoint path).

    Args:
        spec: see the module table.
        env: the match env; checkpoints must have been trained on its game.

    Examples:
        >>> from rlhc.envs import make_env
        >>> env = make_env("tennis", num_envs=2, seed=0)
        >>> make_team_policy("scripted", env)(env.reset())["racket"].shape
        torch.Size([2, 4, 3])
    """
    if spec == "random":
        return RandomPolicy(env)
    if spec == "scripted":
        return ScriptedPolicy(env)
    if not Path(spec).expanduser().exists():
        raise FileNotFoundError(
            f"player {spec!r} is neither a built-in opponent ({', '.join(BUILT_IN)}) "
            "nor an existing checkpoint file or run directory"
        )
    return restore_policy(load_policy_checkpoint(spec, env.game.name), env)
