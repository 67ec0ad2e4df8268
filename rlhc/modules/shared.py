"""A discrete actor and a worker critic on one trunk (``model.shared_trunk``).

ML-Agents 0.5's discrete PPO, which trained the paper's soccer brains, is one network:
``num_layers`` hidden layers (the trunk) with a policy head (logits) and a value head
on top, trained on the sum of the policy, value and entropy losses. TorchRL's
:class:`~torchrl.modules.ActorValueOperator` is that shape:

| module | reads | writes |
|---|---|---|
| trunk: :class:`~rlhc.modules.mlp.GroupMLP`, ``num_layers`` activated layers | ``(g, "observation")`` | ``(g, "hidden")`` |
| policy head: ``Linear`` + ``Categorical`` | ``(g, "hidden")`` | ``(g, "logits")``, ``(g, "action")``, ``(g, "action_log_prob")`` |
| value head: ``Linear`` | ``(g, "hidden")`` | ``(g, "worker_value")`` |

Its ``get_policy_operator()`` (trunk + policy head) and ``get_value_operator()``
(trunk + value head) hold the *same* trunk module, hence the same ``Parameter``
objects: the PPO loss trains the trunk with both its policy and its critic terms
(:class:`~rlhc.objectives.HierarchicalPPOLoss` keeps TorchRL's default
``separate_losses=False``, which leaves shared parameters attached in the critic).
Each operator runs the trunk itself, so a loss that evaluates both runs it twice,
as TorchRL's own shared-trunk PPO examples do. The manager critic, which reads
``(g, "manager_observation")``, is not part of this and stays a separate network.
"""

from __future__ import annotations

import torch
from tensordict.nn import TensorDictModule
from torch import nn
from torchrl.data import Categorical, Composite
from torchrl.modules import ActorValueOperator, ProbabilisticActor

from rlhc.envs.keys import ACTION, HIDDEN, LOGITS, OBSERVATION, WORKER_VALUE
from rlhc.modules.mlp import GroupMLP
from rlhc.modules.schemas import NetworkConfig
from rlhc.modules.specs import HasSpecs, action_spec, observation_size


def shared_trunk_error(group: str, spec: object) -> str | None:
    """Why ``group`` cannot have a shared trunk, or ``None`` if it can.

    Args:
        group: the agent group, e.g. ``"striker"``.
        spec: its action spec ``(group, "action")``.

    Returns:
        ``None`` for a ``Categorical`` spec; otherwise a message naming the group, the
        spec's type and what is allowed.

    Examples:
        >>> from torchrl.data import Bounded, Categorical
        >>> shared_trunk_error("striker", Categorical(6, (2,))) is None
        True
        >>> shared_trunk_error("racket", Bounded(-1.0, 1.0, (4, 3)))
        "group 'racket' has a BoundedContinuous action spec; a shared trunk needs discrete (Categorical) actions"
    """
    if isinstance(spec, Categorical):
        return None
    return (
        f"group {group!r} has a {type(spec).__name__} action spec; "
        "a shared trunk needs discrete (Categorical) actions"
    )


def make_trunk(n_inputs: int, n_agents: int, cfg: NetworkConfig) -> GroupMLP:
    """The hidden layers of a shared network: ``cfg.num_layers`` layers, each activated.

    The same layers as the hidden part of :func:`~rlhc.modules.mlp.group_mlp` (one set
    of weights for every agent of the group), without its output layer.

    Args:
        n_inputs: per-agent observation size.
        n_agents: agents in the group.
        cfg: depth, width and activation.

    Returns:
        A :class:`~rlhc.modules.mlp.GroupMLP` mapping ``[*B, n_agents, n_inputs]`` to
        ``[*B, n_agents, cfg.hidden_size]``.

    Examples:
        >>> import torch
        >>> from rlhc.modules import NetworkConfig
        >>> trunk = make_trunk(8, 2, NetworkConfig(num_layers=2, hidden_size=16))
        >>> trunk(torch.randn(5, 2, 8)).shape
        torch.Size([5, 2, 16])
    """
    return GroupMLP(
        n_inputs,
        cfg.hidden_size,
        n_agents,
        depth=cfg.num_layers - 1,
        num_cells=cfg.hidden_size,
        activation_class=cfg.activation_class,
        activate_last_layer=True,
    )


def make_actor_value(env: HasSpecs, group: str, cfg: NetworkConfig) -> ActorValueOperator:
    """The actor and the worker critic of ``group`` on one trunk.

    Args:
        env: an env (or :class:`~rlhc.modules.specs.EnvSpecs`) holding
            ``(group, "observation")`` and a ``Categorical`` ``(group, "action")`` spec.
        group: the agent group, e.g. ``"striker"``.
        cfg: the trunk's shape (``cfg.shared_trunk`` itself is not read).

    Returns:
        An ``ActorValueOperator``: ``get_policy_operator()`` is the actor (as
        :func:`~rlhc.modules.make_actor`: writes ``(group, "action")`` and
        ``(group, "action_log_prob")``), ``get_value_operator()`` the worker critic
        (writes ``(group, "worker_value")``, ``[*B, n_g, 1]``); both write
        ``(group, "hidden")`` and share the trunk's parameters.

    Raises:
        ValueError: the action spec is not ``Categorical`` (the message names it).

    Examples:
        >>> import torch
        >>> from tensordict import TensorDict
        >>> from torchrl.data import Categorical, Composite, Unbounded
        >>> from rlhc.modules import EnvSpecs, NetworkConfig, make_actor_value
        >>> specs = EnvSpecs(
        ...     Composite(striker=Composite(observation=Unbounded((2, 8)), shape=(2,))),
        ...     Composite(striker=Composite(action=Categorical(6, (2,)), shape=(2,))),
        ... )
        >>> shared = make_actor_value(specs, "striker", NetworkConfig(hidden_size=16))
        >>> actor, critic = shared.get_policy_operator(), shared.get_value_operator()
        >>> actor.module[0] is critic.module[0]
        True
        >>> td = TensorDict({("striker", "observation"): torch.randn(5, 2, 8)}, [5])
        >>> actor(td)["striker", "action"].shape, critic(td)["striker", "worker_value"].shape
        (torch.Size([5, 2]), torch.Size([5, 2, 1]))
    """
    n_agents, n_inputs = observation_size(env, group)
    spec = action_spec(env, group)
    problem = shared_trunk_error(group, spec)
    if problem is not None:
        raise ValueError(problem)
    assert isinstance(spec, Categorical)
    hidden_key = (group, HIDDEN)
    trunk = TensorDictModule(
        make_trunk(n_inputs, n_agents, cfg),
        in_keys=[(group, OBSERVATION)],
        out_keys=[hidden_key],
    )
    # nn.Linear acts on the last dim: one head for every agent, as the trunk's weights.
    logits = TensorDictModule(
        nn.Linear(cfg.hidden_size, int(spec.space.n)),
        in_keys=[hidden_key],
        out_keys=[(group, LOGITS)],
    )
    policy = ProbabilisticActor(
        logits,
        in_keys=[(group, LOGITS)],
        out_keys=[(group, ACTION)],
        spec=Composite({(group, ACTION): spec}, shape=env.full_action_spec.shape),
        distribution_class=torch.distributions.Categorical,
        return_log_prob=True,
    )
    value = TensorDictModule(
        nn.Linear(cfg.hidden_size, 1), in_keys=[hidden_key], out_keys=[(group, WORKER_VALUE)]
    )
    return ActorValueOperator(trunk, policy, value)
