"""PPO for RLHC: TorchRL's ``ClipPPOLoss`` with two critics and the hierarchical estimator.

The policy term is TorchRL's clipped surrogate, unchanged, on the advantage of
:class:`~rlhc.objectives.value.HierarchicalValueEstimator` (computed without
gradient: the policy gets none through the fused value). The critic term is the
only change: both critics are regressed on the same lambda-return of ``V_hat``,
each with its own loss, so that neither critic starves when the other one wins
the max (the paper trains both; a loss on ``V_hat`` alone would only train, at
each step, the critic that was selected).
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
from torchrl.objectives import AUTO_LOSS_MASK_KEYS, ClipPPOLoss, ValueEstimators
from torchrl.objectives.utils import distance_loss

from rlhc.envs import keys
from rlhc.modules.actors import scored_policy
from rlhc.objectives.value import HierarchicalValueEstimator

#: Output keys of :class:`HierarchicalPPOLoss` that carry gradient; sum these.
LOSS_KEYS: tuple[str, ...] = ("loss_objective", "loss_critic", "loss_entropy")
#: Detached diagnostics added to TorchRL's (entropy, kl_approx, clip_fraction, ...).
LOSS_WORKER_CRITIC = "loss_worker_critic"
LOSS_MANAGER_CRITIC = "loss_manager_critic"
EXPLAINED_VARIANCE = "explained_variance"
EXPLAINED_VARIANCE_WORKER = "explained_variance_worker"
EXPLAINED_VARIANCE_MANAGER = "explained_variance_manager"


class _CriticTerms(NamedTuple):
    worker: Tensor
    manager: Tensor | None  # None: the manager critic is not run (PPO)
    explained_variance: Tensor  # of the fused value
    worker_explained_variance: Tensor
    manager_explained_variance: Tensor | None


def explained_variance(target: Tensor, value: Tensor, weight: Tensor | None = None) -> Tensor:
    """``1 - Var(target - value) / Var(target)`` over every element (no gradient).

    1 for a perfect prediction (up to a constant offset), 0 for a constant, negative
    for worse than a constant. With ``weight`` (broadcastable to ``target``, 0 or 1 per
    element) both variances are taken over the elements of weight 1 only.

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


#: Gamma and lambda of an estimator built without them (TorchRL's GAE defaults).
DEFAULT_GAE_HYPERPARAMS: dict[str, float] = {"gamma": 0.99, "lmbda": 0.95}


class HierarchicalPPOLoss(ClipPPOLoss):
    """``ClipPPOLoss`` whose critic loss trains a worker and a manager critic.

    ``loss_critic = c * (d(V_target, V_w) + d(V_target, V_m))`` where ``d`` is
    ``loss_critic_type`` and ``V_target`` the lambda-return of the fused value written
    by the attached estimator. It is computed by :meth:`loss_critic`, the critic hook
    that ``ClipPPOLoss.forward`` calls; everything else (clipping, entropy bonus,
    advantage normalisation, reductions) is TorchRL's. Attach the estimator with
    ``loss.make_value_estimator(HierarchicalValueEstimator(...))``, which also hands it
    this loss's keys, or build both with :func:`make_ppo_loss`. (A plain assignment,
    ``loss.value_estimator = estimator``, does not attach it: ``torch.nn.Module`` files
    a module value under its own name before TorchRL's setter is reached.)

    Args:
        actor_network: the group's ``ProbabilisticActor``.
        worker_critic: ``V_w``, writing the ``worker_value`` key.
        manager_critic: ``V_m``, writing the ``manager_value`` key.

    Keyword Args:
        critic_coeff: ``c``, the weight of the two critic terms.
        loss_critic_type: ``"l2"``, ``"l1"`` or ``"smooth_l1"``.
        **ppo_kwargs: forwarded to ``ClipPPOLoss`` (``clip_epsilon``, ``entropy_coeff``,
            ``normalize_advantage``, ...); value clipping (``clip_value``) and
            ``separate_losses`` are not supported.

    Output (``forward``): TorchRL's ``loss_objective``, ``loss_entropy``, ``entropy``,
    ``kl_approx``, ``clip_fraction``, ``ESS``, ``max_ratio``, ``mean_ratio``,
    ``loss_critic`` (the sum of the two critic terms) and ``explained_variance`` (of
    the current fused value), plus detached diagnostics ``loss_worker_critic`` and
    ``loss_manager_critic`` (the two terms, which add up to ``loss_critic``, reduced
    as TorchRL reduces ``loss_critic``) and ``explained_variance_worker`` and
    ``explained_variance_manager`` (of each critic's value against the same target).
    Only :data:`LOSS_KEYS` carry gradient.

    Under ``"local"`` fusion (PPO) the estimator does not run the manager critic unless
    built with ``manager_diagnostics=True``; the loss then neither evaluates nor trains
    it: ``loss_critic`` is the worker's term alone and ``loss_manager_critic`` and
    ``explained_variance_manager`` are absent.

    Raises:
        ValueError: ``critic_coeff <= 0``, ``clip_value`` or ``separate_losses`` given.
    """

    @dataclass
    class _AcceptedKeys(ClipPPOLoss.default_keys):
        """TorchRL's PPO keys plus the two critics' outputs.

        Attributes:
            worker_value: the worker critic's output ``V_w``.
            manager_value: the manager critic's output ``V_m``.
            learner: whether the learning policy chose the action (league worlds),
                read by :func:`~rlhc.objectives.weighting.learner_weighted_loss`.
        """

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
        # ClipPPOLoss reads its coefficients on the host while it builds (critic_coeff
        # > 0): its buffers are made there, then moved to the networks' device, which
        # leaves the parameters (already there) shared with the caller's modules.
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
        if self.max_importance_ratio is not None:
            # A setting (the config holds it), not learned state: checkpoints keep
            # their keys, and a cap set now applies to a run resumed from an older one.
            self.register_buffer(
                "max_importance_ratio", self.max_importance_ratio, persistent=False
            )
        self.to(device)
        # What the last loss_critic call computed, for forward's diagnostics (detached).
        self._critic_split: _CriticTerms | None = None

    @property
    def out_keys(self) -> list[str]:
        torchrl_keys = [key for key in super().out_keys if key != "loss_critic"]
        extra = [
            "loss_critic",
            LOSS_WORKER_CRITIC,
            LOSS_MANAGER_CRITIC,
            EXPLAINED_VARIANCE,
            EXPLAINED_VARIANCE_WORKER,
            EXPLAINED_VARIANCE_MANAGER,
        ]
        return list(dict.fromkeys([*torchrl_keys, *extra]))

    @out_keys.setter
    def out_keys(self, values: list[str]) -> None:
        ClipPPOLoss.out_keys.fset(self, values)

    def make_value_estimator(
        self, value_type: Any = None, **hyperparams: Any
    ) -> HierarchicalPPOLoss:
        """Attach a :class:`HierarchicalValueEstimator` and give it this loss's keys.

        Args:
            value_type: a :class:`HierarchicalValueEstimator` to attach; or ``None``,
                ``ValueEstimators.GAE`` (TorchRL's default for PPO) or the class
                :class:`HierarchicalValueEstimator`, to build one on this loss's two
                critics from ``hyperparams`` (``gamma`` and ``lmbda`` default to 0.99
                and 0.95, ``fusion`` to ``"max"``).
            **hyperparams: constructor arguments of the estimator to build.

        Returns:
            This loss.

        Raises:
            ValueError: any other estimator (the loss needs both critics' values).
        """
        if isinstance(value_type, HierarchicalValueEstimator):
            estimator = value_type
        elif (
            value_type is None
            or value_type is HierarchicalValueEstimator
            or (value_type == ValueEstimators.GAE)
        ):
            hyperparams.pop("device", None)  # passed by LossModule; buffers follow .to()
            estimator = HierarchicalValueEstimator(
                worker_value_network=self.critic_network[0],
                manager_value_network=self.critic_network[1],
                **{**DEFAULT_GAE_HYPERPARAMS, **hyperparams},
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
        """Set tensordict keys, as ``ClipPPOLoss.set_keys``, plus ``worker_value`` and
        ``manager_value``; an attached estimator receives the new keys."""
        super().set_keys(**kwargs)
        if self._has_hierarchical_estimator():
            self.value_estimator.set_keys(**self._estimator_keys())

    def _has_hierarchical_estimator(self) -> bool:
        # ``value_type`` is where LossModule.make_value_estimator records the class of
        # the attached estimator (read here so as not to build TorchRL's default one).
        value_type = getattr(self, "value_type", None)
        return isinstance(value_type, type) and issubclass(value_type, HierarchicalValueEstimator)

    def _estimator_keys(self) -> dict[str, NestedKey]:
        return {name: getattr(self.tensor_keys, name) for name in self.ESTIMATOR_KEYS}

    def forward(self, tensordict: TensorDictBase) -> TensorDictBase:
        """The PPO losses and diagnostics on a batch (or minibatch) of data.

        Args:
            tensordict: collected data; if it holds no advantage yet, the attached
                estimator computes it first (usually the trainer does so once per
                batch, before splitting it into minibatches).

        Returns:
            A TensorDict of scalars (see the class docstring), or of per-sample terms
            with ``reduction="none"``.
        """
        if tensordict.get(self.tensor_keys.advantage, None) is None:
            # Run here (rather than inside ClipPPOLoss.forward) so that the value
            # target lands in a copy (not the caller's data), where the critic terms
            # read it. ClipPPOLoss.forward copies the entries it writes to itself.
            tensordict = tensordict.clone(False)
            with torch.no_grad():
                self.value_estimator(tensordict)
        self._critic_split = None
        td_out = super().forward(tensordict)  # calls self.loss_critic once
        split, self._critic_split = self._critic_split, None
        if split is None:
            raise RuntimeError(
                "ClipPPOLoss.forward did not call loss_critic; this TorchRL version is "
                "not supported by HierarchicalPPOLoss"
            )
        td_out.set(LOSS_WORKER_CRITIC, self._reduce_like_torchrl(split.worker, tensordict))
        td_out.set(EXPLAINED_VARIANCE_WORKER, split.worker_explained_variance)
        if split.manager is not None:
            td_out.set(LOSS_MANAGER_CRITIC, self._reduce_like_torchrl(split.manager, tensordict))
            td_out.set(EXPLAINED_VARIANCE_MANAGER, split.manager_explained_variance)
        return td_out

    def loss_critic(self, tensordict: TensorDictBase) -> tuple[Tensor, None, Tensor]:
        """ClipPPOLoss's critic hook: both critics regressed on the fused value's target.

        ``ClipPPOLoss.forward`` calls it, stores the first output as ``loss_critic``
        (reduced) and the third as ``explained_variance``.

        Args:
            tensordict: data holding the value target.

        Returns:
            ``(loss, None, explained_variance)``: the unreduced sum of both critic
            terms, no value-clip fraction, and the explained variance of ``V_hat``.
        """
        terms = self._critic_terms(tensordict)
        manager = terms.manager.detach() if terms.manager is not None else None
        self._critic_split = terms._replace(worker=terms.worker.detach(), manager=manager)
        if terms.manager is None:
            return terms.worker, None, terms.explained_variance
        return terms.worker + terms.manager, None, terms.explained_variance

    def _reduce_like_torchrl(self, loss: Tensor, tensordict: TensorDictBase) -> Tensor:
        # ClipPPOLoss's reduction of a "loss_*" entry, after its documented contract:
        # positions outside the validity masks (``loss_mask_key``) are zeroed, then
        # ``reduction`` "none" keeps them (squeezing the feature dim), "sum" sums and
        # "mean" averages over the valid ones.
        mask = self._loss_mask(tensordict, loss)
        if mask is not None:
            loss = torch.where(mask, loss, torch.zeros_like(loss))
        if self.reduction == "none":
            return loss.squeeze(-1)
        if self.reduction == "sum":
            return loss.sum()
        if mask is None:
            return loss.mean()
        return loss.sum() / mask.sum().clamp_min(1)

    def _loss_mask(self, tensordict: TensorDictBase, loss: Tensor) -> Tensor | None:
        mask_key = self.loss_mask_key
        if mask_key is None:
            return None
        candidates = AUTO_LOSS_MASK_KEYS if mask_key == "auto" else (mask_key,)
        mask = None
        for key in candidates:
            found = tensordict.get(key, None)
            if found is None:
                continue
            # [B, T, 1] masks against [B, T, n, 1] terms: drop trailing singletons, then
            # append dims until the mask broadcasts.
            while found.ndim > loss.ndim and found.shape[-1] == 1:
                found = found.squeeze(-1)
            found = found.reshape(*found.shape, *(1,) * (loss.ndim - found.ndim))
            found = found.expand_as(loss).bool()
            mask = found if mask is None else mask & found
        return mask

    def _critic_terms(self, tensordict: TensorDictBase) -> _CriticTerms:
        tk = self.tensor_keys
        target = tensordict.get(tk.value_target, None)
        if target is None:
            raise KeyError(
                f"missing value target {tk.value_target!r}: run the value estimator first "
                "(loss.value_estimator(data)) or let forward run it"
            )
        target = target.detach()
        # Evaluate on a selection so that the values with gradient are never written
        # into the caller's data. The critics run with their own parameters, which are
        # the very tensors ClipPPOLoss holds (and the optimiser updates).
        estimator = self.value_estimator
        hierarchical = isinstance(estimator, HierarchicalValueEstimator)
        # PPO ("local" fusion) leaves the manager critic out unless asked to run it.
        critics = (
            self.critic_network
            if not hierarchical or estimator.runs_manager
            else self.critic_network[0]
        )
        inputs = tensordict.select(*critics.in_keys, strict=False)
        values = critics(inputs)
        worker_value = values.get(tk.worker_value)
        manager_value = values.get(tk.manager_value, None)
        worker = self.critic_coeff * distance_loss(target, worker_value, self.loss_critic_type)
        manager = None
        if manager_value is not None:
            manager = self.critic_coeff * distance_loss(
                target, manager_value, self.loss_critic_type
            )
        with torch.no_grad():
            if hierarchical:
                fused, _ = estimator.fused_value().fuse(tensordict, worker_value, manager_value)
            else:
                fused = worker_value
        # League worlds: the variances over the learner's experiences only.
        learner = tensordict.get(tk.learner, None)
        weight = learner.reshape(target.shape).to(target.dtype) if learner is not None else None
        return _CriticTerms(
            worker,
            manager,
            explained_variance(target, fused, weight),
            explained_variance(target, worker_value, weight),
            explained_variance(target, manager_value, weight)
            if manager_value is not None
            else None,
        )


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
    shifted: bool = False,
    max_importance_ratio: float | None = None,
) -> HierarchicalPPOLoss:
    """The PPO loss of one group, with its hierarchical value estimator attached.

    Args:
        actor: the group's policy (:func:`~rlhc.modules.make_actor`); the loss scores
            its :func:`~rlhc.modules.actors.scored_policy` (``tanh_normal``: the
            pre-tanh draw).
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
        normalize_advantage: standardise the advantage per minibatch, per agent slot
            (TorchRL's standardisation, over every experience).
        loss_critic_type: ``"l2"``, ``"l1"`` or ``"smooth_l1"``.
        reduction: TorchRL's reduction of the loss terms, ``"mean"``, ``"sum"`` or
            ``"none"`` (per-sample terms, e.g. for
            :func:`~rlhc.objectives.weighting.learner_weighted_loss`, which wants
            ``normalize_advantage=False`` too).
        manager_diagnostics: with ``fusion="local"`` (PPO), still run and train the
            manager critic (for its logged value); by default PPO leaves it out.
        shifted: the estimator reads trajectories and runs the critics once per batch
            (see :class:`~rlhc.objectives.value.HierarchicalValueEstimator`); the
            trainer's collected batches are.
        max_importance_ratio: cap of the ratio ``pi / pi_old`` in the surrogate
            (``ClipPPOLoss``'s; ``None``: none), so that a ratio whose exponential
            overflows cannot turn the loss infinite.

    Returns:
        A :class:`HierarchicalPPOLoss`; its ``value_estimator`` is a
        :class:`~rlhc.objectives.value.HierarchicalValueEstimator`. Optimise
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
            shifted=shifted,
        )
    )
    return loss
