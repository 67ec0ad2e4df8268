"""The policy of one group: a shared ``GroupMLP`` turned into a distribution.

| action spec | head | distribution |
|---|---|---|
| ``Bounded`` ``[..., n_g, size]`` (tennis), ``action_dist=gaussian`` | loc; a learned log scale per action dimension, shared by every state and agent (``AddStateIndependentNormalScale``); both divided by ``cfg.pre_clip_range`` | ``IndependentNormal``, unsquashed: the env clips the sample |
| the same, ``action_dist=tanh_normal`` | loc, scale (``NormalParamExtractor``; the scale is ``cfg.initial_action_scale`` for a zero output) | :class:`PreTanhNormal` over the pre-tanh value ``u``, stored as ``(g, "action_pretanh")``; the action is ``u`` squashed into the bounds (:class:`Squash`) |
| ``Categorical`` ``[..., n_g]`` (soccer) | logits | ``torch.distributions.Categorical`` (integer actions, as the spec) |

Every actor reads :func:`actor_observation_key` and writes ``(g, "action")`` and its
log-probability (``tanh_normal``: that of its pre-tanh draw, which the loss scores).
"""

from __future__ import annotations

import math

import torch
from tensordict.nn import (
    AddStateIndependentNormalScale,
    NormalParamExtractor,
    ProbabilisticTensorDictModule,
    ProbabilisticTensorDictSequential,
    TensorDictModule,
    TensorDictModuleBase,
    TensorDictSequential,
)
from torch import nn
from torch.nn import functional as F
from torchrl.data import Bounded, Categorical, Composite
from torchrl.modules import IndependentNormal, ProbabilisticActor

from rlhc.envs.keys import (
    ACTION,
    LOC,
    LOGITS,
    MANAGER_OBSERVATION,
    OBSERVATION,
    PRE_TANH_ACTION,
    SCALE,
)
from rlhc.modules.mlp import GroupMLP, group_mlp
from rlhc.modules.schemas import NetworkConfig
from rlhc.modules.specs import HasSpecs, action_spec, observation_size

#: The distributions skip torch's argument checks: each costs a host sync per call (a
#: collection step, a minibatch), and the game rejects a non-finite action on its own.
_UNCHECKED = {"validate_args": False}


def _per_agent_bound(bound: torch.Tensor, size: int, name: str) -> torch.Tensor:
    # A shared policy needs one bound per action dimension: the env may repeat it
    # over worlds and agents, but it must be the same everywhere.
    rows = bound.reshape(-1, size)
    if not torch.all(rows == rows[0]):
        raise ValueError(f"action {name} bound differs between agents or worlds: {bound}")
    return rows[0].clone()


def _scale_head(mlp: GroupMLP, factor: float) -> GroupMLP:
    # The last Linear of the MLP is the policy head; ML-Agents 0.5 starts its mean head
    # at 1 % of the usual initial weights, so that every action starts near 0.
    if factor != 1.0:
        with torch.no_grad():
            for parameter in mlp.head.parameters():
                parameter.mul_(factor)
    return mlp


class PreTanhNormal(IndependentNormal):
    """The Normal of a ``TanhNormal`` action's pre-tanh value ``u``, scored as drawn.

    PPO's ratio ``pi'(a) / pi(a)`` equals ``N'(u) / N(u)`` (the tanh's Jacobian cancels),
    and ``u`` is stored next to the action, where TorchRL's ``TanhNormal`` rebuilds it as
    ``atanh(a)``, which float32 cannot once ``|u| > ~9``. The entropy is the squashed
    action's: the Normal's closed form plus a one-sample estimate of
    ``E[log(1 - tanh(u)^2)]`` per dimension, so that saturating costs entropy.

    Examples:
        >>> import torch
        >>> dist = PreTanhNormal(torch.full((2, 3), 12.0), torch.full((2, 3), 0.05))
        >>> u = dist.sample()
        >>> bool(torch.isfinite(dist.log_prob(u)).all())  # scored as drawn, far past atanh's range
        True
    """

    def entropy(self) -> torch.Tensor:
        u = self.rsample()
        # log(1 - tanh(u)^2) = 2 (log 2 - u - softplus(-2u)), stable at any |u|.
        log_jacobian = 2.0 * (math.log(2.0) - u - F.softplus(-2.0 * u))
        return super().entropy() + log_jacobian.sum(-1)


class Squash(nn.Module):
    """``u -> low + (high - low) (tanh(u) + 1) / 2``: a pre-tanh sample into the bounds."""

    low: torch.Tensor
    high: torch.Tensor

    def __init__(self, low: torch.Tensor, high: torch.Tensor) -> None:
        super().__init__()
        # Settings of the action spec, not learned: out of the state dict.
        self.register_buffer("low", low, persistent=False)
        self.register_buffer("high", high, persistent=False)

    def forward(self, u: torch.Tensor) -> torch.Tensor:
        return self.low + (self.high - self.low) * (torch.tanh(u) + 1.0) / 2.0


def scored_policy(actor: TensorDictModuleBase) -> ProbabilisticTensorDictSequential:
    """The part of a :func:`make_actor` actor whose distribution the loss scores.

    The actor itself, but for ``tanh_normal``, whose actor draws the pre-tanh
    value and then squashes it: the loss scores the draw.
    """
    if isinstance(actor, (ProbabilisticTensorDictSequential, ProbabilisticTensorDictModule)):
        return actor  # type: ignore[return-value]
    draw = actor.module[0]  # type: ignore[index]
    assert isinstance(draw, ProbabilisticTensorDictSequential), type(draw)
    return draw


class _Rescale(nn.Module):
    """``(loc, scale) -> (loc / r, scale / r)``: a Normal of ``u`` as one of ``u / r``."""

    def __init__(self, divisor: float) -> None:
        super().__init__()
        self.divisor = divisor

    def forward(self, params: tuple[torch.Tensor, torch.Tensor]) -> tuple[torch.Tensor, ...]:
        # nn.Sequential hands the previous module's (loc, scale) over as one tuple.
        return tuple(param / self.divisor for param in params)


def _continuous_head(n_inputs: int, size: int, n_agents: int, cfg: NetworkConfig) -> nn.Module:
    """The network writing the (loc, scale) of ``cfg.action_dist``."""
    if cfg.action_dist == "gaussian":
        mlp = _scale_head(group_mlp(n_inputs, size, n_agents, cfg), cfg.head_init_scale)
        scale = AddStateIndependentNormalScale(
            size, scale_mapping="exp", init_value=math.log(cfg.initial_action_scale)
        )
        head: list[nn.Module] = [mlp, scale]
        if cfg.pre_clip_range != 1.0:
            head.append(_Rescale(cfg.pre_clip_range))
        return nn.Sequential(*head)
    # biased_softplus_b maps a zero output to scale b: the initial exploration noise.
    mlp = _scale_head(group_mlp(n_inputs, 2 * size, n_agents, cfg), cfg.head_init_scale)
    extractor = NormalParamExtractor(scale_mapping=f"biased_softplus_{cfg.initial_action_scale}")
    return nn.Sequential(mlp, extractor)


def actor_observation_key(group: str, cfg: NetworkConfig) -> tuple[str, str]:
    """The observation the actor of ``group`` reads (``cfg.actor_view``).

    Examples:
        >>> from rlhc.modules import NetworkConfig
        >>> actor_observation_key("racket", NetworkConfig(actor_view="manager"))
        ('racket', 'manager_observation')
    """
    return (group, MANAGER_OBSERVATION if cfg.actor_view == "manager" else OBSERVATION)


def make_actor(env: HasSpecs, group: str, cfg: NetworkConfig) -> TensorDictModuleBase:
    """The stochastic policy shared by all agents of ``group``.

    Args:
        env: an env (or :class:`~rlhc.modules.specs.EnvSpecs`) holding the
            observation the actor reads (:func:`actor_observation_key`) and
            ``(group, "action")`` specs.
        group: the agent group, e.g. ``"racket"``.
        cfg: the MLP shape and the policy's parametrisation.

    Returns:
        A ``ProbabilisticActor`` (module table); for ``tanh_normal`` a
        ``TensorDictSequential`` of the one drawing the pre-tanh value
        (:func:`scored_policy`) and the :class:`Squash` writing ``(group, "action")``.

    Raises:
        TypeError: the action spec is neither ``Bounded`` nor ``Categorical``.

    Examples:
        >>> import torch
        >>> from tensordict import TensorDict
        >>> from torchrl.data import Bounded, Composite, Unbounded
        >>> from rlhc.modules import EnvSpecs, NetworkConfig, make_actor
        >>> specs = EnvSpecs(
        ...     Composite(racket=Composite(observation=Unbounded((4, 8)), shape=(4,))),
        ...     Composite(racket=Composite(action=Bounded(-1.0, 1.0, (4, 3)), shape=(4,))),
        ... )
        >>> actor = make_actor(specs, "racket", NetworkConfig(hidden_size=16))
        >>> td = TensorDict({("racket", "observation"): torch.randn(5, 4, 8)}, [5])
        >>> actor(td)["racket", "action"].shape
        torch.Size([5, 4, 3])
    """
    observation_key = actor_observation_key(group, cfg)
    n_agents, n_inputs = observation_size(env, group, manager=cfg.actor_view == "manager")
    spec = action_spec(env, group)
    action_key = (group, ACTION)
    out_spec = Composite({action_key: spec}, shape=env.full_action_spec.shape)
    if isinstance(spec, Bounded):
        size = int(spec.shape[-1])
        params = TensorDictModule(
            _continuous_head(n_inputs, size, n_agents, cfg),
            in_keys=[observation_key],
            out_keys=[(group, LOC), (group, SCALE)],
        )
        if cfg.action_dist != "gaussian":
            draw = ProbabilisticActor(
                params,
                in_keys=[(group, LOC), (group, SCALE)],
                out_keys=[(group, PRE_TANH_ACTION)],
                distribution_class=PreTanhNormal,
                return_log_prob=True,
                distribution_kwargs=_UNCHECKED,
            )
            squash = Squash(
                _per_agent_bound(spec.space.low, size, "low"),
                _per_agent_bound(spec.space.high, size, "high"),
            )
            return TensorDictSequential(
                draw,
                TensorDictModule(squash, in_keys=[(group, PRE_TANH_ACTION)], out_keys=[action_key]),
            )
        return ProbabilisticActor(
            params,
            in_keys=[(group, LOC), (group, SCALE)],
            out_keys=[action_key],
            spec=out_spec,
            distribution_class=IndependentNormal,
            return_log_prob=True,
            distribution_kwargs=_UNCHECKED,
        )
    if isinstance(spec, Categorical):
        logits = TensorDictModule(
            group_mlp(n_inputs, int(spec.space.n), n_agents, cfg),
            in_keys=[observation_key],
            out_keys=[(group, LOGITS)],
        )
        return ProbabilisticActor(
            logits,
            in_keys=[(group, LOGITS)],
            out_keys=[action_key],
            spec=out_spec,
            distribution_class=torch.distributions.Categorical,
            return_log_prob=True,
            distribution_kwargs=_UNCHECKED,
        )
    raise TypeError(
        f"action spec of group {group!r} is {type(spec).__name__}; "
        "expected Bounded (continuous) or Categorical (discrete)"
    )
