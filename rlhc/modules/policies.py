"""Every group's policy in one module, evaluated with the fewest calls per step.

A :func:`~rlhc.modules.make_actor` actor is a chain of TensorDict modules: the network
writes its distribution's parameters (``loc``/``scale`` or ``logits``) into the step's
TensorDict, a ``ProbabilisticActor`` reads them back, builds the distribution, draws and
writes the action and its log-probability. :class:`GroupPolicies` runs the same modules
on tensors: per group one network call, the distribution built once, the same draw
(``rsample`` where the distribution has one, else ``sample``, then ``log_prob``, as
``ProbabilisticActor`` does) and two writes, the action and its log-probability. The
parameters are not written: nothing reads them after collection. The draws, and so a
seeded run, are those of the actors themselves (tests/modules/test_policies.py).

:func:`policy_distribution` is the same distribution for the loss's minibatches
(:meth:`~rlhc.objectives.ppo.HierarchicalPPOLoss.terms`), :func:`draw_action` the same
draw for a league's past selves (:class:`~rlhc.training.league.LeaguePolicy`).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import NamedTuple

import torch
from tensordict import TensorDictBase
from tensordict.nn import (
    ProbabilisticTensorDictModule,
    ProbabilisticTensorDictSequential,
    TensorDictModule,
    TensorDictModuleBase,
    TensorDictSequential,
)
from tensordict.utils import NestedKey
from torch import nn
from torchrl.envs.utils import ExplorationType, exploration_type

from rlhc.modules.actors import scored_policy


class ActorParts(NamedTuple):
    """The pieces of a :func:`~rlhc.modules.make_actor` actor that :class:`GroupPolicies`
    calls on tensors."""

    #: observation -> the distribution's parameters.
    network: TensorDictModule
    #: the distribution: its class, keyword arguments, sample and log-probability keys.
    draw: ProbabilisticTensorDictModule
    #: the network's outputs as the distribution's keyword names, in order.
    parameter_names: tuple[str, ...]
    #: ``tanh_normal``: the draw squashed into the action bounds; else ``None``.
    squash: TensorDictModule | None


def actor_parts(actor: TensorDictModuleBase) -> ActorParts:
    """Split a :func:`~rlhc.modules.make_actor` actor into its network, its distribution
    and (``tanh_normal``) its squashing module.

    Raises:
        TypeError: ``actor`` is not one network followed by one probabilistic module (and
            an optional module on the draw).
    """
    scored = scored_policy(actor)
    modules = list(scored.module) if isinstance(scored, ProbabilisticTensorDictSequential) else []
    if len(modules) != 2 or not (
        isinstance(modules[0], TensorDictModule)
        and isinstance(modules[1], ProbabilisticTensorDictModule)
    ):
        raise TypeError(
            "expected a make_actor actor (a network, then a probabilistic module), got "
            f"{type(actor).__name__}"
        )
    network, draw = modules
    names = {key: name[-1] if isinstance(name, tuple) else name
             for name, key in zip(draw.dist_keys, draw.in_keys, strict=True)}  # fmt: skip
    squash = None
    if scored is not actor:
        assert isinstance(actor, TensorDictSequential)
        squash = actor.module[1]
    return ActorParts(
        network,
        draw,
        tuple(names[key] for key in network.out_keys),
        squash,  # type: ignore[arg-type]
    )


def policy_distribution(
    parts: ActorParts, tensordict: TensorDictBase
) -> torch.distributions.Distribution:
    """The distribution the actor builds on ``tensordict``: its network called on the
    observation tensor, the parameters handed to the distribution class directly."""
    out = parts.network.module(*(tensordict.get(key) for key in parts.network.in_keys))
    out = out if isinstance(out, tuple) else (out,)
    return parts.draw.distribution_class(
        **dict(zip(parts.parameter_names, out, strict=True)), **parts.draw.distribution_kwargs
    )


def draw_action(
    parts: ActorParts, tensordict: TensorDictBase, log_prob: bool = True
) -> dict[NestedKey, torch.Tensor]:
    """One draw of the actor on ``tensordict``, as ``ProbabilisticActor`` draws it under
    ``ExplorationType.RANDOM``: ``rsample`` where the distribution has one, else
    ``sample``; by output key, the draw, its log-probability (``log_prob``) and
    (``tanh_normal``) the squashed action."""
    dist = policy_distribution(parts, tensordict)
    sample = dist.rsample() if dist.has_rsample else dist.sample()
    out = {parts.draw.dist_sample_keys[0]: sample}
    if log_prob:
        out[parts.draw.log_prob_key] = dist.log_prob(sample)
    if parts.squash is not None:
        out[parts.squash.out_keys[0]] = parts.squash.module(sample)
    return out


class GroupPolicies(TensorDictModuleBase):
    """The actors of every group as one collection policy, drawing as they do.

    Under ``ExplorationType.RANDOM`` (a collector's default) each group's action is drawn
    from :func:`policy_distribution` and written with its log-probability (``tanh_normal``:
    the pre-tanh draw too); under any other interaction type the actors themselves run.

    Args:
        actors: the :func:`~rlhc.modules.make_actor` actor of each group; their parameters
            are this module's.

    Examples:
        >>> policy = GroupPolicies(trainer.actors)  # doctest: +SKIP
        >>> collector = Collector(env, policy, frames_per_batch=1024)  # doctest: +SKIP
    """

    def __init__(self, actors: Mapping[str, TensorDictModuleBase]) -> None:
        super().__init__()
        self.actors = nn.ModuleDict(dict(actors))
        self.parts = [actor_parts(actor) for actor in actors.values()]
        self.in_keys = list(dict.fromkeys(k for a in actors.values() for k in a.in_keys))
        self.out_keys: list[NestedKey] = []
        for parts in self.parts:
            self.out_keys += parts.draw.out_keys  # the draw and its log-probability
            if parts.squash is not None:
                self.out_keys += parts.squash.out_keys

    def forward(self, tensordict: TensorDictBase) -> TensorDictBase:
        if exploration_type() is not ExplorationType.RANDOM:
            for actor in self.actors.values():
                tensordict = actor(tensordict)
            return tensordict
        for parts in self.parts:
            for key, value in draw_action(parts, tensordict).items():
                tensordict.set(key, value)
        return tensordict
