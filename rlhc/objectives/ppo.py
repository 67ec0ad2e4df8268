"""PPO for RLHC: TorchRL's ``ClipPPOLoss`` with two critics and the hierarchical estimator.

The policy term is TorchRL's clipped surrogate on the advantage of
:class:`~rlhc.objectives.value.HierarchicalValueEstimator`, which carries no gradient.
The critic term is the only change: both critics are regressed on the same
lambda-return of ``V_hat``, each with its own loss, so that neither starves when the
other wins the max (a loss on ``V_hat`` alone trains, at each step, only the critic
selected).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, NamedTuple

import torch
from tensordict import TensorDictBase
from tensordict.nn import (
    ProbabilisticTensorDictSequential,
    TensorDictModule,
    TensorDictModuleBase,
    TensorDictSequential,
)
from tensordict.utils import NestedKey
from torch import Tensor
from torchrl.objectives import ClipPPOLoss, ValueEstimators
from torchrl.objectives.utils import distance_loss

from rlhc.envs import keys
from rlhc.modules.actors import scored_policy
from rlhc.modules.policies import ActorParts, actor_parts, policy_distribution
from rlhc.objectives.value import HierarchicalValueEstimator

#: Output keys of :class:`HierarchicalPPOLoss` that carry gradient; sum these.
LOSS_KEYS: tuple[str, ...] = ("loss_objective", "loss_critic", "loss_entropy")
#: Detached diagnostics added to TorchRL's (entropy, kl_approx, clip_fraction, ...).
LOSS_WORKER_CRITIC = "loss_worker_critic"
LOSS_MANAGER_CRITIC = "loss_manager_critic"
EXPLAINED_VARIANCE = "explained_variance"
EXPLAINED_VARIANCE_WORKER = "explained_variance_worker"
EXPLAINED_VARIANCE_MANAGER = "explained_variance_manager"


def explained_variance(target: Tensor, value: Tensor, weight: Tensor | None = None) -> Tensor:
    """``1 - Var(target - value) / Var(target)`` over every element (no gradient), or
    over the elements of weight 1 only (``weight``: 0 or 1, broadcastable to ``target``).

    Examples:
        >>> target = torch.tensor([1.0, 2.0, 3.0])
        >>> explained_variance(target, target + 1.0)
        tensor(1.)
        >>> round(explained_variance(target, target.flip(0)).item(), 4)
        -3.0
    """
    with torch.no_grad():
        if weight is None:
            residual, spread = (target - value).var(correction=0), target.var(correction=0)
        else:
            weight = weight.expand_as(target)
            count = weight.sum().clamp_min(1.0)

            def variance(x: Tensor) -> Tensor:
                mean = (x * weight).sum() / count
                return ((x - mean) ** 2 * weight).sum() / count

            residual, spread = variance(target - value), variance(target)
        return 1.0 - residual / (spread + torch.finfo(target.dtype).eps)


class LossTerms(NamedTuple):
    """:meth:`HierarchicalPPOLoss.terms`: the loss's outputs, and the policy's per-sample
    ``log(pi / pi_old)`` and entropy ``[*B, n_g, 1]`` (detached), for weighted diagnostics."""

    values: dict[str, Tensor]
    log_weight: Tensor
    entropy: Tensor


def _reduced(term: Tensor, reduction: str) -> Tensor:
    # A per-sample term [*B, n_g, 1], reduced as ClipPPOLoss reduces its own (no masks).
    if reduction == "none":
        return term.squeeze(-1)
    return term.sum() if reduction == "sum" else term.mean()


class HierarchicalPPOLoss(ClipPPOLoss):
    """``ClipPPOLoss`` whose critic loss trains a worker and a manager critic.

    ``loss_critic = c * (d(V_target, V_w) + d(V_target, V_m))``, ``d`` being
    ``loss_critic_type`` and ``V_target`` the lambda-return of ``V_hat`` written by the
    attached :class:`HierarchicalValueEstimator`; it is computed by :meth:`loss_critic`,
    the hook ``ClipPPOLoss.forward`` calls. Everything else (clipping, entropy bonus,
    advantage standardisation, ``reduction``) is TorchRL's. Attach the estimator with
    :meth:`make_value_estimator` (a plain ``loss.value_estimator = ...`` is filed by
    ``torch.nn.Module`` before TorchRL's setter runs), or build both with
    :func:`make_ppo_loss`.

    ``forward`` writes TorchRL's outputs (``loss_critic`` the sum of the two terms,
    ``explained_variance`` that of ``V_hat``) plus the detached ``loss_worker_critic``
    and ``loss_manager_critic`` (the two terms, reduced as ``reduction`` says) and
    ``explained_variance_worker`` / ``_manager``. Only :data:`LOSS_KEYS` carry gradient.
    Under ``"local"`` fusion without ``manager_diagnostics`` the manager critic is
    neither evaluated nor trained, and its two entries are absent; so is the worker
    critic under ``"manager"`` fusion without ``worker_diagnostics`` (the terms then
    read ``c * d(V_target, V_m)``). Validity masks
    (TorchRL's ``loss_mask_key``) are not read: the learner weight plays that part
    (:func:`~rlhc.objectives.weighting.learner_weighted_loss`).

    Args:
        actor_network: the group's ``ProbabilisticActor``.
        worker_critic: ``V_w``, writing the ``worker_value`` key.
        manager_critic: ``V_m``, writing the ``manager_value`` key.

    Keyword Args:
        critic_coeff: ``c``, the weight of the two critic terms.
        loss_critic_type: ``"l2"``, ``"l1"`` or ``"smooth_l1"``.
        **ppo_kwargs: forwarded to ``ClipPPOLoss``; ``clip_value`` and
            ``separate_losses`` are not supported.

    Raises:
        ValueError: ``critic_coeff <= 0``, ``clip_value`` or ``separate_losses`` given.
    """

    @dataclass
    class _AcceptedKeys(ClipPPOLoss.default_keys):
        """TorchRL's PPO keys plus the critics' outputs and the league's ``learner`` flag
        (read by :func:`~rlhc.objectives.weighting.learner_weighted_loss`)."""

        worker_value: NestedKey = keys.WORKER_VALUE
        manager_value: NestedKey = keys.MANAGER_VALUE
        learner: NestedKey = keys.LEARNER

    default_keys = _AcceptedKeys
    tensor_keys: _AcceptedKeys

    #: The keys this loss forwards to its :class:`HierarchicalValueEstimator`.
    ESTIMATOR_KEYS: tuple[str, ...] = (
        "advantage",
        "value_target",
        "value",
        "reward",
        "done",
        "terminated",
        "sample_log_prob",
        "worker_value",
        "manager_value",
    )

    def __init__(
        self,
        actor_network: ProbabilisticTensorDictSequential,
        worker_critic: TensorDictModule,
        manager_critic: TensorDictModule,
        *,
        critic_coeff: float = 1.0,
        loss_critic_type: str = "l2",
        **ppo_kwargs: Any,
    ) -> None:
        if ppo_kwargs.get("clip_value"):
            raise ValueError("clip_value is not supported by HierarchicalPPOLoss")
        if ppo_kwargs.get("separate_losses"):
            raise ValueError(
                "separate_losses is not supported by HierarchicalPPOLoss: both critics are "
                "evaluated with their own parameters"
            )
        if critic_coeff <= 0:
            raise ValueError(
                f"critic_coeff must be > 0 (both critics must learn), got {critic_coeff}"
            )
        # ClipPPOLoss reads its coefficients on the host while it builds: built there,
        # then moved to the networks' device, which leaves the parameters shared.
        device = ppo_kwargs.pop("device", None)
        if device is None:
            first = next(actor_network.parameters(), None)
            device = first.device if first is not None else torch.device("cpu")
        # One critic module computing both values: ClipPPOLoss then holds (and hands
        # to the optimiser) the parameters of both critics next to the actor's.
        super().__init__(
            actor_network,
            TensorDictSequential(worker_critic, manager_critic),
            critic_coeff=critic_coeff,
            loss_critic_type=loss_critic_type,
            device=torch.device("cpu"),
            **ppo_kwargs,
        )
        self.loss_mask_key = None  # no validity masks: see the class docstring
        if self.max_importance_ratio is not None:
            # A setting (the config holds it), not learned state: checkpoints keep
            # their keys, and a cap set now applies to a run resumed from an older one.
            self.register_buffer(
                "max_importance_ratio", self.max_importance_ratio, persistent=False
            )
        self.to(device)
        # The last loss_critic call's per-critic terms, for forward's diagnostics.
        self._critic_split: dict[str, Tensor] = {}
        # The actor's network and distribution, for terms() (a tuple: not registered twice).
        self._actor_parts: ActorParts = actor_parts(self.actor_network)

    @property
    def out_keys(self) -> list[str]:
        extra = [
            "loss_critic",
            LOSS_WORKER_CRITIC,
            LOSS_MANAGER_CRITIC,
            EXPLAINED_VARIANCE,
            EXPLAINED_VARIANCE_WORKER,
            EXPLAINED_VARIANCE_MANAGER,
        ]
        return list(dict.fromkeys([*super().out_keys, *extra]))

    @out_keys.setter
    def out_keys(self, values: list[str]) -> None:
        ClipPPOLoss.out_keys.fset(self, values)

    def make_value_estimator(
        self, value_type: Any = None, **hyperparams: Any
    ) -> HierarchicalPPOLoss:
        """Attach a :class:`HierarchicalValueEstimator` and give it this loss's keys.

        Args:
            value_type: the estimator to attach; or ``None``, ``ValueEstimators.GAE``
                (TorchRL's default for PPO) or the class itself, to build one on this
                loss's critics from ``hyperparams`` (``gamma`` 0.99 and ``lmbda`` 0.95 by
                default).
            **hyperparams: constructor arguments of the estimator to build.

        Returns:
            This loss.

        Raises:
            ValueError: any other estimator (the loss needs both critics' values).
        """
        if isinstance(value_type, HierarchicalValueEstimator):
            estimator = value_type
        elif value_type in (None, ValueEstimators.GAE, HierarchicalValueEstimator):
            hyperparams.pop("device", None)  # passed by LossModule; buffers follow .to()
            estimator = HierarchicalValueEstimator(
                worker_value_network=self.critic_network[0],
                manager_value_network=self.critic_network[1],
                **{"gamma": 0.99, "lmbda": 0.95, **hyperparams},
            )
        else:
            raise ValueError(
                "HierarchicalPPOLoss estimates advantages with a HierarchicalValueEstimator "
                f"(it needs both critics' values), got {value_type!r}"
            )
        super().make_value_estimator(estimator)
        estimator.set_keys(**self._estimator_keys())
        return self

    def set_keys(self, **kwargs: Any) -> None:
        """``ClipPPOLoss.set_keys``, plus ``worker_value``, ``manager_value`` and
        ``learner``; an attached estimator receives the new keys."""
        super().set_keys(**kwargs)
        # LossModule.make_value_estimator records the estimator's class in value_type
        # (read here so as not to build TorchRL's default estimator).
        if isinstance(getattr(self, "value_type", None), type):
            self.value_estimator.set_keys(**self._estimator_keys())

    def _estimator_keys(self) -> dict[str, NestedKey]:
        return {name: getattr(self.tensor_keys, name) for name in self.ESTIMATOR_KEYS}

    def forward(self, tensordict: TensorDictBase) -> TensorDictBase:
        """The PPO losses and diagnostics on a (mini)batch; if it holds no advantage, the
        attached estimator runs first, on a copy (the trainer runs it once per batch)."""
        td_out = super().forward(tensordict)  # calls self.loss_critic once
        for key, value in self._critic_split.items():
            td_out.set(key, _reduced(value, self.reduction) if key.startswith("loss_") else value)
        self._critic_split = {}
        return td_out

    def terms(self, tensordict: TensorDictBase) -> LossTerms:
        """What :meth:`forward` writes (but ``ESS``, ``max_ratio`` and ``mean_ratio``), from
        one call of each network on the minibatch's tensors.

        ``ClipPPOLoss.forward`` and :meth:`loss_critic`, operation for operation, without
        their TensorDict work: the actor's network called on its observation tensor, its
        distribution built once (:func:`~rlhc.modules.policies.policy_distribution`), the
        critics' networks called on theirs. The values equal :meth:`forward`'s
        (tests/objectives/test_ppo_loss.py); the trainer's update runs this.

        Args:
            tensordict: a minibatch holding the advantage and the value target.

        Raises:
            ValueError: the loss standardises the advantage itself (build it with
                ``normalize_advantage=False`` and standardise before, as
                :func:`~rlhc.objectives.weighting.learner_weighted_loss` does).
        """
        if self.normalize_advantage:
            raise ValueError("terms() reads a standardised advantage: build the loss with "
                             "normalize_advantage=False")  # fmt: skip
        tk, estimator = self.tensor_keys, self.value_estimator
        advantage = tensordict.get(tk.advantage)
        # _log_weight: the ratio of the current policy to the behaviour policy.
        prev_log_prob = tensordict.get(tk.sample_log_prob)
        dist = policy_distribution(self._actor_parts, tensordict)
        log_prob = dist.log_prob(tensordict.get(tk.action))
        log_weight = (log_prob - prev_log_prob).unsqueeze(-1)
        kl_approx = (prev_log_prob - log_prob).unsqueeze(-1)
        log_is_weight = None
        if self.max_importance_ratio is not None:
            log_is_weight = torch.minimum(
                torch.zeros_like(log_weight), self.max_importance_ratio.log() - log_weight.detach()
            )
        # forward: the clipped surrogate.
        log_behav_weight = log_weight if log_is_weight is None else log_weight + log_is_weight
        gain1 = log_behav_weight.exp() * advantage
        log_weight_clip = log_weight.clamp(*self.log_ratio_bounds())
        clipped = log_weight_clip != log_weight
        if log_is_weight is not None:
            log_weight_clip = log_weight_clip + log_is_weight
        gain2 = log_weight_clip.exp() * advantage
        gain = torch.stack([gain1, gain2], -1).min(dim=-1).values
        entropy = dist.entropy().unsqueeze(-1)
        values: dict[str, Tensor] = {
            "loss_objective": -gain,
            "clip_fraction": clipped.to(log_weight.dtype).mean(),
            "kl_approx": kl_approx.detach().mean(),
            "entropy": entropy.detach().mean(),
            "loss_entropy": -self.entropy_coeff * entropy,
        }
        # loss_critic: the critics' networks that run, on their observations.
        worker_value = manager_value = None
        if estimator.runs_worker:
            worker = self.critic_network[0]
            worker_value = worker.module(*(tensordict.get(key) for key in worker.in_keys))
        if estimator.runs_manager:
            manager = self.critic_network[1]
            manager_value = manager.module(*(tensordict.get(key) for key in manager.in_keys))
        loss, split = self._critic_terms(tensordict, worker_value, manager_value)
        values["loss_critic"] = loss
        values.update(split)
        for key in list(values):
            if key.startswith("loss_"):
                values[key] = _reduced(values[key], self.reduction)
        return LossTerms(values, log_weight.detach(), entropy.detach())

    def log_ratio_bounds(self) -> tuple[Tensor, Tensor]:
        """``(log(1 - eps), log(1 + eps))``: where ``ClipPPOLoss`` clips ``log(pi / pi_old)``."""
        return (-self.clip_epsilon).log1p(), self.clip_epsilon.log1p()

    def loss_critic(self, tensordict: TensorDictBase) -> tuple[Tensor, None, Tensor]:
        """ClipPPOLoss's critic hook: both critics regressed on the fused value's target.

        Returns:
            ``(loss, None, explained_variance)``: the unreduced sum of both critic terms,
            no value-clip fraction, and the explained variance of ``V_hat``.
        """
        tk, estimator = self.tensor_keys, self.value_estimator
        if tk.value_target not in tensordict.keys(include_nested=True):
            raise KeyError(
                f"missing value target {tk.value_target!r}: run the value estimator first "
                "(loss.value_estimator(data)) or let forward run it"
            )
        # On a selection, so that values with gradient never land in the caller's data;
        # PPO ("local" fusion) leaves the manager critic out unless asked to run it, and
        # "manager" fusion the worker critic.
        critics = self.critic_network
        if not (estimator.runs_worker and estimator.runs_manager):
            critics = critics[0 if estimator.runs_worker else 1]
        values = critics(tensordict.select(*critics.in_keys, strict=False))
        worker_value = values.get(tk.worker_value, None)
        manager_value = values.get(tk.manager_value, None)
        loss, self._critic_split = self._critic_terms(tensordict, worker_value, manager_value)
        explained = self._critic_split.pop(EXPLAINED_VARIANCE)
        return loss, None, explained

    def _critic_terms(
        self, tensordict: TensorDictBase, worker_value: Tensor | None, manager_value: Tensor | None
    ) -> tuple[Tensor, dict[str, Tensor]]:
        """The unreduced critic loss, and its per-critic terms and explained variances
        (``None``: a critic that does not run)."""
        tk = self.tensor_keys
        target = tensordict.get(tk.value_target).detach()
        with torch.no_grad():
            fused, _ = self.value_estimator.fused_value().fuse(
                tensordict, worker_value, manager_value
            )
        # League worlds: the variances over the learner's experiences only.
        learner = tensordict.get(tk.learner, None)
        weight = learner.reshape(target.shape).to(target.dtype) if learner is not None else None
        terms = []
        split = {}
        for value, loss_key, variance_key in (
            (worker_value, LOSS_WORKER_CRITIC, EXPLAINED_VARIANCE_WORKER),
            (manager_value, LOSS_MANAGER_CRITIC, EXPLAINED_VARIANCE_MANAGER),
        ):
            if value is None:
                continue
            term = self.critic_coeff * distance_loss(target, value, self.loss_critic_type)
            terms.append(term)
            split[loss_key] = term.detach()
            split[variance_key] = explained_variance(target, value, weight)
        loss = sum(terms[1:], terms[0])
        split[EXPLAINED_VARIANCE] = explained_variance(target, fused, weight)
        return loss, split


def make_ppo_loss(
    *,
    actor: TensorDictModuleBase,
    worker_critic: TensorDictModule,
    manager_critic: TensorDictModule,
    group: str,
    gamma: float = 0.99,
    lmbda: float = 0.95,
    fusion: str = "max",
    weight: float = 0.5,
    manager_interval: int = 1,
    clip_epsilon: float = 0.2,
    entropy_coef: float = 0.005,
    critic_coef: float = 0.5,
    normalize_advantage: bool = True,
    loss_critic_type: str = "l2",
    reduction: str = "mean",
    manager_diagnostics: bool = False,
    worker_diagnostics: bool = False,
    shifted: bool = False,
    max_importance_ratio: float | None = None,
) -> HierarchicalPPOLoss:
    """The PPO loss of one group, with its hierarchical value estimator attached.

    Args:
        actor: the group's policy (:func:`~rlhc.modules.make_actor`); the loss scores
            its :func:`~rlhc.modules.actors.scored_policy`.
        worker_critic: ``V_w`` (:func:`~rlhc.modules.make_worker_critic`).
        manager_critic: ``V_m`` (:func:`~rlhc.modules.make_manager_critic`).
        group: the agent group, e.g. ``"racket"``; every key is nested under it.
        gamma: discount (paper, Table 3: 0.99).
        lmbda: GAE lambda (paper: 0.95).
        fusion: ``"local"`` (PPO), ``"manager"``, ``"max"`` (RLHC), ``"mean"``, ``"weighted"``.
        weight: the manager's weight in ``"weighted"`` fusion.
        manager_interval: consult the manager every ``k`` steps (temporal scaling).
        clip_epsilon: PPO ratio clip (paper: 0.2).
        entropy_coef: entropy bonus ``beta`` (paper: 0.005 tennis, 0.01 soccer).
        critic_coef: weight of each critic's regression term.
        normalize_advantage: TorchRL's standardisation of the advantage per minibatch,
            per agent slot.
        loss_critic_type: ``"l2"``, ``"l1"`` or ``"smooth_l1"``.
        reduction: TorchRL's reduction of the loss terms; ``"none"`` (with
            ``normalize_advantage=False``) for
            :func:`~rlhc.objectives.weighting.learner_weighted_loss`, as the trainer does.
        manager_diagnostics: under ``fusion="local"`` (PPO), still run and train the
            manager critic (for its logged value).
        worker_diagnostics: under ``fusion="manager"`` consulted at every step (a
            centralised critic, MAPPO's), still run and train the worker critic.
        shifted: the data are a collector's trajectories: the critics run once per batch
            (see :class:`~rlhc.objectives.value.HierarchicalValueEstimator`).
        max_importance_ratio: cap of the ratio ``pi / pi_old`` in the surrogate
            (``None``: none), so that an overflowing ratio cannot make the loss infinite.

    Returns:
        A :class:`HierarchicalPPOLoss` with its
        :class:`~rlhc.objectives.value.HierarchicalValueEstimator` attached. Optimise
        ``loss.parameters()`` on the sum of :data:`LOSS_KEYS`.

    Examples:
        >>> import torch
        >>> from torchrl.data import Bounded, Composite, Unbounded
        >>> from rlhc.modules import (EnvSpecs, NetworkConfig, make_actor,
        ...     make_manager_critic, make_worker_critic)
        >>> from rlhc.objectives import make_ppo_loss
        >>> specs = EnvSpecs(
        ...     Composite(racket=Composite(observation=Unbounded((4, 8)),
        ...         manager_observation=Unbounded((4, 10)), shape=(4,))),
        ...     Composite(racket=Composite(action=Bounded(-1.0, 1.0, (4, 3)), shape=(4,))))
        >>> cfg = NetworkConfig(hidden_size=16)
        >>> loss = make_ppo_loss(
        ...     actor=make_actor(specs, "racket", cfg),
        ...     worker_critic=make_worker_critic(specs, "racket", cfg),
        ...     manager_critic=make_manager_critic(specs, "racket", cfg),
        ...     group="racket", fusion="max")
        >>> loss.value_estimator.fusion
        'max'
    """
    loss = HierarchicalPPOLoss(
        scored_policy(actor),
        worker_critic,
        manager_critic,
        clip_epsilon=clip_epsilon,
        entropy_coeff=entropy_coef,
        critic_coeff=critic_coef,
        loss_critic_type=loss_critic_type,
        normalize_advantage=normalize_advantage,
        # Standardise each agent slot on its own (as TorchRL's MAPPO does), and
        # silence ClipPPOLoss's multi-agent warning.
        normalize_advantage_exclude_dims=(-2,),
        reduction=reduction,
        max_importance_ratio=max_importance_ratio,
    )
    loss.set_keys(
        advantage=(group, keys.ADVANTAGE),
        value_target=(group, keys.VALUE_TARGET),
        value=(group, keys.STATE_VALUE),
        reward=(group, keys.REWARD),
        done=(group, keys.DONE),
        terminated=(group, keys.TERMINATED),
        worker_value=(group, keys.WORKER_VALUE),
        manager_value=(group, keys.MANAGER_VALUE),
        learner=(group, keys.LEARNER),
    )
    loss.make_value_estimator(
        HierarchicalValueEstimator(
            worker_value_network=worker_critic,
            manager_value_network=manager_critic,
            gamma=gamma,
            lmbda=lmbda,
            fusion=fusion,
            weight=weight,
            manager_interval=manager_interval,
            group=group,
            manager_diagnostics=manager_diagnostics,
            worker_diagnostics=worker_diagnostics,
            shifted=shifted,
        )
    )
    return loss
