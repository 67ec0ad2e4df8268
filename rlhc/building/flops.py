"""Arithmetic of the networks: FLOP of their ``Linear`` layers per world-decision.

Counted, not timed: every ``nn.Linear`` of a network, built as the trainer builds it
(:func:`rlhc.building.builders.make_agents`), costs ``in_features x out_features``
multiply-adds (MAC, 2 FLOP) per agent it is applied to. Activations, biases, the
distributions and the optimiser are left out (a few percent at Table 3's sizes).
"""

from __future__ import annotations

from dataclasses import dataclass

from torch import nn
from torchrl.envs import EnvBase

from rlhc.building.builders import make_agents
from rlhc.config.train_schema import TrainConfig
from rlhc.envs import make_env
from rlhc.modules.specs import observation_size

#: FLOP per multiply-add.
FLOP_PER_MAC = 2
#: A forward and a backward pass cost about this many forward passes (the backward
#: computes the gradients of both the inputs and the weights: two matmuls per layer).
FORWARD_BACKWARD = 3


def linear_macs(module: nn.Module) -> int:
    """Multiply-adds of one input row through every distinct ``nn.Linear`` of ``module``.

    Examples:
        >>> from torch import nn
        >>> linear_macs(nn.Sequential(nn.Linear(10, 4), nn.Tanh(), nn.Linear(4, 2)))
        48
    """
    return sum(
        layer.in_features * layer.out_features
        for layer in module.modules()
        if isinstance(layer, nn.Linear)
    )


@dataclass(frozen=True)
class GroupFlops:
    """Forward FLOP of one group's networks per world-decision (all its agents).

    A critic that is not run counts 0: ``manager_critic`` under PPO without
    ``critic.manager_diagnostics``, ``worker_critic`` under ``critic=manager`` without
    ``critic.worker_diagnostics``.
    """

    agents: int
    actor: int
    worker_critic: int
    manager_critic: int


@dataclass(frozen=True)
class TrainingFlops:
    """FLOP per world-decision of collecting it and of training on it.

    Attributes:
        collection: every group's actor, forward (the env's own cost excluded).
        update: the critics once forward (the value estimator) plus ``epochs`` passes of
            the loss (actor and critics, forward and backward: :data:`FORWARD_BACKWARD`).
    """

    collection: int
    update: int


def network_flops(cfg: TrainConfig, env: EnvBase | None = None) -> dict[str, GroupFlops]:
    """Forward FLOP per world-decision of each group's actor and critics under ``cfg``.

    ``env`` sizes the networks (``None``: a one-world env of ``cfg.env``).

    Examples:
        >>> from rlhc.config.train_schema import compose_config
        >>> cfg = compose_config("env=soccer")
        >>> sorted(network_flops(cfg))
        ['goalie', 'striker']
    """
    if env is None:
        env = make_env(cfg.env.name, num_envs=1, seed=0, **cfg.env.game_options())
    _, losses = make_agents(cfg, env)
    flops = {}
    for group, loss in losses.items():
        agents, _ = observation_size(env, group)
        estimator = loss.value_estimator
        networks = {"actor": loss.actor_network}
        if estimator.runs_worker:
            networks["worker_critic"] = estimator.worker_value_network
        if estimator.runs_manager:
            networks["manager_critic"] = estimator.manager_value_network
        counts = {
            # a critic on a view shared by the agents runs once per world
            name: FLOP_PER_MAC * (1 if _shared(net) else agents) * linear_macs(net)
            for name, net in networks.items()
        }
        flops[group] = GroupFlops(
            agents=agents, **{"worker_critic": 0, "manager_critic": 0} | counts
        )
    return flops


def _shared(network: nn.Module) -> bool:
    """Whether ``network`` runs once per world (a :class:`~rlhc.modules.mlp.GroupMLP`
    on an input shared by the agents)."""
    return any(getattr(module, "shared_input", False) for module in network.modules())


def training_flops(cfg: TrainConfig, env: EnvBase | None = None) -> TrainingFlops:
    """FLOP per world-decision of collection and of an update under ``cfg`` (``env``: as
    in :func:`network_flops`); every world-decision counts in every epoch.

    Examples:
        >>> from rlhc.config.train_schema import compose_config
        >>> cfg = compose_config("env=soccer")
        >>> cost = training_flops(cfg)
        >>> cost.update > cost.collection > 0
        True
    """
    groups = network_flops(cfg, env).values()
    actors = sum(group.actor for group in groups)
    critics = sum(group.worker_critic + group.manager_critic for group in groups)
    estimator = critics  # V(o_t) once per observation (shifted), no gradient
    loss = cfg.algo.epochs * FORWARD_BACKWARD * (actors + critics)
    return TrainingFlops(collection=actors, update=estimator + loss)
