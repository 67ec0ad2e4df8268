"""Rebuild a trained policy (actors + frozen observation normaliser) from a checkpoint.

A checkpoint (:meth:`rlhc.training.trainer.Trainer.state`) stores the training config,
each group's actor weights and the state of the training env's transforms. Actors
trained on normalised observations (``algo.normalize_observations``) must see them
through the *same* statistics, frozen: the training env is rebuilt with
:func:`rlhc.building.builders.make_training_env`, so that the normaliser's settings come
from the one place that defines them, and its statistics are read from the checkpoint.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any, cast

import torch
from omegaconf import OmegaConf
from tensordict import NestedKey, TensorDictBase
from tensordict.nn import TensorDictModuleBase
from torchrl.envs import EnvBase, Transform

from rlhc.building.builders import make_training_env, network_config
from rlhc.building.normalisation import SafeVecNorm
from rlhc.config.train_schema import TrainConfig
from rlhc.envs.keys import ACTION
from rlhc.envs.registry import game_spec
from rlhc.envs.schemas import SOURCE_SCHEMAS
from rlhc.modules import make_actor

#: Env config fields that do not change what a policy observes.
NON_OBSERVATION_OPTIONS = ("name", "num_envs", "max_cycles")
#: Settings of teams trained before the library's clean-up (git tag ``probes-2026-12``)
#: that no longer exist and do not change how the team plays.
RETIRED_SETTINGS = {
    "model": ("kind", "memory_size", "sequence_length", "loc_bound", "shared_trunk"),
    "algo": ("rescore_log_prob",),
}
#: Continuous policies of those teams, by the name of the one that plays them now: a
#: ``tanh_normal_exact`` team is today's ``tanh_normal``; an older ``tanh_normal`` team
#: (scored through ``atanh`` in training) plays with the same network and squashing.
RENAMED_POLICIES = {"tanh_normal_exact": "tanh_normal"}


def checkpoint_config(state: Mapping[str, Any]) -> TrainConfig:
    """The checkpoint's training config as a typed :class:`TrainConfig`
    (:class:`ValueError` if its env is neither a registered game nor another library's)."""
    config = OmegaConf.create(state["config"])
    for section, keys in RETIRED_SETTINGS.items():
        for key in keys:
            config[section].pop(key, None)
    # Teams older than the setting were TanhNormal policies.
    policy = config.model.get("action_dist") or "tanh_normal"
    config.model.action_dist = RENAMED_POLICIES.get(policy, policy)
    name = state["env"]
    env = SOURCE_SCHEMAS[name]() if name in SOURCE_SCHEMAS else game_spec(name).env_config()
    schema = OmegaConf.structured(TrainConfig(env=env))
    return OmegaConf.to_object(OmegaConf.merge(schema, config))  # type: ignore[return-value]


def load_actor_weights(actor: torch.nn.Module, weights: Mapping[str, torch.Tensor]) -> None:
    """``actor.load_state_dict(weights)``, also for a ``tanh_normal`` team trained before
    its pre-tanh draw was stored: the same parameters, one module level higher."""
    expected = list(actor.state_dict())
    nested = {f"module.0.{key}": value for key, value in weights.items()}
    actor.load_state_dict(nested if sorted(nested) == sorted(expected) else weights)


def observation_options(state: Mapping[str, Any]) -> dict[str, Any]:
    """The game options a checkpoint's policy depends on (e.g. ``extended_obs``)."""
    env = dict(state["config"]["env"])
    return {
        key: value
        for key, value in env.items()
        if key not in NON_OBSERVATION_OPTIONS and value is not None
    }


@dataclass
class RestoredPolicy:
    """Per-group actors of a checkpoint with their frozen observation normaliser.

    Attributes:
        actors: ``group -> actor`` (:func:`~rlhc.modules.make_actor`).
        loc: ``group -> [n_g, d]`` normaliser mean of what the actor reads, or ``None``
            (no normalisation).
        scale: ``group -> [n_g, d]`` normaliser scale, or ``None``.
        clip: the bound of the normalised observations (``algo.observation_clip``), or
            ``None``.
    """

    actors: dict[str, torch.nn.Module]
    loc: dict[str, torch.Tensor] | None
    scale: dict[str, torch.Tensor] | None
    clip: float | None = None

    def __call__(self, tensordict: TensorDictBase) -> dict[str, torch.Tensor]:
        """Actions of every agent of every group (the input is not modified)."""
        return {group: self.act(group, tensordict) for group in self.actors}

    def act(self, group: str, tensordict: TensorDictBase) -> torch.Tensor:
        """Actions of the agents of ``group`` (the input is not modified)."""
        return self.actors[group](self.inputs(group, tensordict))[group, ACTION]

    def inputs(self, group: str, tensordict: TensorDictBase) -> TensorDictBase:
        """What the actor of ``group`` reads, normalised, in a new tensordict."""
        key = observation_key(self.actors[group])
        observation = tensordict[key]
        if self.loc is not None and self.scale is not None:
            observation = (observation - self.loc[group]) / self.scale[group]
            if self.clip is not None:
                observation = observation.clamp(-self.clip, self.clip)
        inputs = tensordict.select(key).clone(recurse=False)
        inputs.set(key, observation)
        return inputs


def observation_key(actor: torch.nn.Module) -> NestedKey:
    """The one observation an actor of :func:`~rlhc.modules.make_actor` reads."""
    (key,) = cast(TensorDictModuleBase, actor).in_keys
    return key


def restore_policy(state: Mapping[str, Any], env: EnvBase) -> RestoredPolicy:
    """Rebuild the actors and frozen normaliser of a checkpoint for ``env``.

    ``state`` is a loaded checkpoint; ``env``'s specs must match the ones the policy was
    trained on. Returns a callable ``tensordict -> {group: actions}`` in eval mode.

    Raises:
        ValueError: the checkpoint's observation sizes do not fit ``env``; the
            message names the checkpoint and its env options.
    """
    cfg = checkpoint_config(state)
    net = network_config(cfg)
    actors: dict[str, torch.nn.Module] = {}
    for group, weights in state["actors"].items():
        actor = make_actor(env, group, net)
        try:
            load_actor_weights(actor, weights)
        except RuntimeError as error:
            raise ValueError(
                f"checkpoint {state.get('path', '?')!r} does not fit this env: it was trained "
                f"on {state['env']!r} with options {observation_options(state)}; "
                f"build the evaluation env with the same options ({error})"
            ) from None
        actors[group] = actor.eval()
    loc = scale = None
    if cfg.algo.normalize_observations:
        training_env = make_training_env(cfg, num_envs=1, seed=0)
        training_env.transform.load_state_dict(state["env_transform"])
        loc, scale = normaliser_statistics(training_env.transform, actors)
        training_env.close()
    return RestoredPolicy(actors, loc, scale, cfg.algo.observation_clip)


def normaliser_statistics(
    transform: Transform, actors: Mapping[str, torch.nn.Module]
) -> tuple[dict[str, torch.Tensor] | None, dict[str, torch.Tensor] | None]:
    """Copies of the ``loc`` and ``scale`` of the observation normaliser in ``transform`` for the
    observation each group's actor reads (``(None, None)`` when ``transform`` has none:
    observations are not normalised).

    Statistics that never saw data (a checkpoint saved before the first step) have a
    zero bias correction and come out NaN: those entries are left unnormalised.
    """
    normaliser = next((t for t in transform if isinstance(t, SafeVecNorm)), None)
    if normaliser is None:
        return None, None
    keys = {g: observation_key(actor) for g, actor in actors.items()}
    loc = {g: normaliser.loc[key].nan_to_num(0.0) for g, key in keys.items()}
    scale = {g: normaliser.scale[key].nan_to_num(1.0, posinf=1.0) for g, key in keys.items()}
    return loc, scale
