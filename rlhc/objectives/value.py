"""``HierarchicalValueEstimator``: TorchRL's GAE on the fused value of two critics."""

from __future__ import annotations

from dataclasses import dataclass

import torch
from tensordict import TensorDictBase
from tensordict.nn import TensorDictModule, dispatch
from tensordict.utils import NestedKey
from torch import Tensor
from torchrl.objectives.value.advantages import (
    ValueEstimatorBase,
    _self_set_grad_enabled,
    _self_set_skip_existing,
)

from rlhc.modules import keys
from rlhc.objectives._data import as_tuple, broadcast_to_value, require
from rlhc.objectives.functional import (
    check_fusion,
    check_manager_interval,
    fuse_values,
    hierarchical_gae,
    manager_consulted_mask,
)


class HierarchicalValueEstimator(ValueEstimatorBase):
    """Generalized advantage estimation on the fused value of a worker and a manager critic.

    RLHC (Cao & Lin, arXiv 1902.03079) computes the PPO advantage of every
    worker from ``V_hat = max(V_w(o_w), V_m(o_m))``, element-wise per agent and per
    step, used at ``t`` and at the bootstrap ``t + 1``. This estimator calls both
    critics on the root and ``"next"`` observations, fuses them with
    :func:`~rlhc.objectives.functional.fuse_values` and runs TorchRL's vectorised GAE
    on the result (:func:`~rlhc.objectives.functional.hierarchical_gae`). Truncated
    episodes bootstrap, terminated ones do not, and a done at one agent never leaks
    into another agent's trace.

    ``fusion="local"`` is plain PPO (it equals TorchRL's :class:`~torchrl.objectives.value.GAE`
    on the worker critic); ``"manager"``, ``"mean"`` and ``"weighted"`` are the paper's
    other critics. With ``manager_interval=k`` the manager is consulted only at
    observations whose ``step_count`` is a multiple of ``k`` (the paper's temporal
    scaling; its tennis variant used ``k = 5``); elsewhere ``V_hat = V_w``.

    .. note::
        The authors' released code reads both "critic" values from the same network
        output and compares ``sum(value1) > sum(value2)`` over the whole batch, so its
        max never selects a different critic. Here the two critics are separate
        networks and the max is taken element-wise, per agent and per step.

    Keyword Args:
        worker_value_network: ``V_w``, reads ``(group, "observation")`` and writes
            ``(group, "worker_value")`` (see :func:`~rlhc.modules.make_worker_critic`).
        manager_value_network: ``V_m``, reads ``(group, "manager_observation")`` and writes
            ``(group, "manager_value")`` (see :func:`~rlhc.modules.make_manager_critic`).
        gamma: discount.
        lmbda: GAE lambda.
        fusion: ``"local"``, ``"manager"``, ``"max"`` (RLHC), ``"mean"`` or ``"weighted"``.
        weight: the manager's weight ``w`` in ``"weighted"`` fusion, ``w V_m + (1 - w) V_w``.
        manager_interval: consult the manager every ``k >= 1`` steps.
        group: the agent group whose keys are used, e.g. ``"racket"``; ``None`` keeps
            TorchRL's un-nested default keys (set them with :meth:`set_keys`).
        differentiable: let gradients flow through ``V_hat(s_t)`` into the critics
            (never through the bootstrap). PPO leaves it ``False``: the policy must not
            receive gradient through the fused value.
        time_dim: the time dimension of the input; by default the one named ``"time"``,
            else the last batch dimension (the collector's ``[N_envs, T]`` layout).
        skip_existing: forwarded to the critics, as in TorchRL's estimators.

    The critics are borrowed, not owned (as TorchRL's ``GAE`` does with its value
    network): the loss and the trainer hold their parameters, so attaching the
    estimator to a loss lists no parameter twice.

    Keys (all configurable with :meth:`set_keys`; nested under ``group`` by default):
    reads ``("next", reward|done|terminated)``, ``step_count`` and
    ``("next", step_count)`` (root, only when ``manager_interval > 1``); writes
    ``worker_value``, ``manager_value``, ``value`` (the fused ``V_hat``,
    ``"state_value"``), ``advantage``, ``value_target`` and ``manager_selected``
    (the share of ``V_hat`` taken from the manager critic: in ``"max"`` mode 1 where
    the manager's critic wins, so its mean is the share of steps it wins). The
    critics' values of the next observations are left under ``"next"`` too.

    Examples:
        >>> import torch
        >>> from tensordict import TensorDict
        >>> from torchrl.data import Composite, Unbounded
        >>> from rlhc.modules import (
        ...     EnvSpecs, NetworkConfig, make_manager_critic, make_worker_critic)
        >>> from rlhc.objectives import HierarchicalValueEstimator
        >>> obs_spec = Composite(racket=Composite(
        ...     observation=Unbounded((4, 8)), manager_observation=Unbounded((4, 10)),
        ...     shape=(4,)))
        >>> specs, cfg = EnvSpecs(obs_spec, Composite()), NetworkConfig(hidden_size=16)
        >>> estimator = HierarchicalValueEstimator(
        ...     worker_value_network=make_worker_critic(specs, "racket", cfg),
        ...     manager_value_network=make_manager_critic(specs, "racket", cfg),
        ...     gamma=0.99, lmbda=0.95, fusion="max", group="racket")
        >>> N, T = 2, 5
        >>> agents = lambda d: torch.randn(N, T, 4, d)
        >>> flags = lambda: torch.zeros(N, T, 4, 1, dtype=torch.bool)
        >>> td = TensorDict({
        ...     "racket": {"observation": agents(8), "manager_observation": agents(10)},
        ...     "next": {"racket": {
        ...         "observation": agents(8), "manager_observation": agents(10),
        ...         "reward": agents(1), "done": flags(), "terminated": flags()}},
        ... }, [N, T])
        >>> td = estimator(td)
        >>> td["racket", "advantage"].shape
        torch.Size([2, 5, 4, 1])
        >>> bool((td["racket", "state_value"] == torch.maximum(
        ...     td["racket", "worker_value"], td["racket", "manager_value"])).all())
        True
    """

    @dataclass
    class _AcceptedKeys:
        """Keys configurable with :meth:`set_keys` (TorchRL's, plus RLHC's own).

        Attributes:
            advantage: where the advantage is written.
            value_target: where the lambda-return on ``V_hat`` is written.
            value: where the fused value ``V_hat`` is written (TorchRL's ``value`` key).
            reward: the reward, read under ``"next"``.
            done: episode ended after the step (terminated or truncated), under ``"next"``.
            terminated: episode ended without a future (no bootstrap), under ``"next"``.
            steps_to_next_obs: unused; kept for TorchRL's loss key forwarding.
            sample_log_prob: unused; kept for TorchRL's loss key forwarding.
            worker_value: the worker critic's output ``V_w``.
            manager_value: the manager critic's output ``V_m``.
            manager_selected: where the share of ``V_hat`` taken from ``V_m`` is written.
            step_count: steps taken in the episode before the observation (root).
        """

        advantage: NestedKey = keys.ADVANTAGE
        value_target: NestedKey = keys.VALUE_TARGET
        value: NestedKey = keys.STATE_VALUE
        reward: NestedKey = keys.REWARD
        done: NestedKey = keys.DONE
        terminated: NestedKey = keys.TERMINATED
        steps_to_next_obs: NestedKey = "steps_to_next_obs"
        sample_log_prob: NestedKey = keys.ACTION_LOG_PROB
        worker_value: NestedKey = keys.WORKER_VALUE
        manager_value: NestedKey = keys.MANAGER_VALUE
        manager_selected: NestedKey = keys.MANAGER_SELECTED
        step_count: NestedKey = keys.STEP_COUNT

    default_keys = _AcceptedKeys
    tensor_keys: _AcceptedKeys

    #: The keys that live under the group (``step_count`` is per world, at the root).
    GROUP_KEYS: tuple[str, ...] = (
        "advantage",
        "value_target",
        "value",
        "reward",
        "done",
        "terminated",
        "worker_value",
        "manager_value",
        "manager_selected",
    )

    def __init__(
        self,
        *,
        worker_value_network: TensorDictModule,
        manager_value_network: TensorDictModule,
        gamma: float | Tensor,
        lmbda: float | Tensor,
        fusion: str = "max",
        weight: float = 0.5,
        manager_interval: int = 1,
        group: str | None = None,
        differentiable: bool = False,
        time_dim: int | None = None,
        skip_existing: bool | None = None,
    ) -> None:
        check_fusion(fusion, weight)
        check_manager_interval(manager_interval)
        super().__init__(
            value_network=None, differentiable=differentiable, skip_existing=skip_existing
        )
        # Borrowed, not registered as submodules (see the class docstring).
        self.__dict__["worker_value_network"] = worker_value_network
        self.__dict__["manager_value_network"] = manager_value_network
        self.register_buffer("gamma", torch.as_tensor(gamma, dtype=torch.float32).clone())
        self.register_buffer("lmbda", torch.as_tensor(lmbda, dtype=torch.float32).clone())
        self.fusion = fusion
        self.weight = float(weight)
        self.manager_interval = manager_interval
        self.group = group
        self.time_dim = time_dim
        if group is not None:
            defaults = self.default_keys()
            self.set_keys(**{name: (group, getattr(defaults, name)) for name in self.GROUP_KEYS})

    worker_value_network: TensorDictModule
    manager_value_network: TensorDictModule

    @property
    def in_keys(self) -> list[NestedKey]:
        tk = self.tensor_keys
        observed = [*self.worker_value_network.in_keys, *self.manager_value_network.in_keys]
        in_keys = [
            *observed,
            *(("next", *as_tuple(key)) for key in observed),
            ("next", *as_tuple(tk.reward)),
            ("next", *as_tuple(tk.done)),
            ("next", *as_tuple(tk.terminated)),
        ]
        if self.manager_interval > 1:
            in_keys += [tk.step_count, ("next", *as_tuple(tk.step_count))]
        return in_keys

    @property
    def out_keys(self) -> list[NestedKey]:
        tk = self.tensor_keys
        return [
            tk.advantage,
            tk.value_target,
            tk.value,
            tk.worker_value,
            tk.manager_value,
            tk.manager_selected,
        ]

    @_self_set_skip_existing
    @_self_set_grad_enabled
    @dispatch
    def forward(
        self,
        tensordict: TensorDictBase,
        *,
        params: TensorDictBase | None = None,
        target_params: TensorDictBase | None = None,
        time_dim: int | None = None,
    ) -> TensorDictBase:
        """Write the two critics' values, ``V_hat``, the advantage and the value target.

        Args:
            tensordict: data of batch ``[*B, T]`` (time at ``time_dim``) holding the
                critics' inputs at the root and under ``"next"``, and the ``"next"``
                reward, done and terminated of the group (``[*B, T, n_g, 1]``, or
                ``[*B, T, 1]`` shared by the agents).

        Keyword Args:
            params: accepted for :class:`~torchrl.objectives.ClipPPOLoss`, which passes
                a detached view of its critic parameters. The estimator evaluates its
                critics with their current parameters, which are those same tensors.
            target_params: accepted for the same reason; PPO has no target critic.
            time_dim: overrides the constructor's ``time_dim``.

        Returns:
            ``tensordict``, updated in place.

        Raises:
            KeyError: an input is missing (the message names it).
            ValueError: the worker and manager values, or the reward, have
                incompatible shapes.
        """
        if tensordict.batch_dims < 1:
            raise RuntimeError(
                f"expected data of batch [*B, T], got batch_size {tuple(tensordict.batch_size)}"
            )
        tk = self.tensor_keys
        time_dim = self._get_time_dim(time_dim, tensordict)
        next_td = require(tensordict, "next", "the step's next-state data")
        worker_value, manager_value = self._critic_values(tensordict, grad=True)
        next_worker_value, next_manager_value = self._critic_values(
            next_td, grad=False, under=("next",)
        )

        reward = require(next_td, tk.reward, "the reward of step t", under=("next",))
        done = require(next_td, tk.done, "did the episode end after step t", under=("next",))
        terminated = require(next_td, tk.terminated, "did it end without a future", under=("next",))
        reward, done, terminated = (
            broadcast_to_value(signal, worker_value, tensordict.batch_dims, name)
            for signal, name in ((reward, "reward"), (done, "done"), (terminated, "terminated"))
        )
        consulted = self._manager_consulted(tensordict, worker_value, tensordict.batch_dims)
        next_consulted = self._manager_consulted(
            next_td, worker_value, tensordict.batch_dims, under=("next",)
        )
        gamma = self.gamma.to(reward.device)
        lmbda = self.lmbda.to(reward.device)
        estimate = hierarchical_gae(
            gamma,
            lmbda,
            worker_value=worker_value,
            manager_value=manager_value,
            next_worker_value=next_worker_value,
            next_manager_value=next_manager_value,
            reward=reward,
            done=done,
            terminated=terminated,
            time_dim=time_dim,
            fusion=self.fusion,
            weight=self.weight,
            manager_consulted=consulted,
            next_manager_consulted=next_consulted,
        )
        tensordict.set(tk.value, estimate.fused_value)
        tensordict.set(tk.manager_selected, estimate.manager_share)
        tensordict.set(tk.advantage, estimate.advantage)
        tensordict.set(tk.value_target, estimate.value_target)
        return tensordict

    def fuse(
        self, tensordict: TensorDictBase, worker_value: Tensor, manager_value: Tensor
    ) -> tuple[Tensor, Tensor]:
        """Fuse two value tensors at the steps of ``tensordict``, as :meth:`forward` does.

        Used by the loss to report the explained variance of the *current* fused value.

        Args:
            tensordict: the data the values belong to (read for ``step_count`` only).
            worker_value: ``V_w`` on that data.
            manager_value: ``V_m`` on that data.

        Returns:
            ``(fused_value, manager_share)``, as :func:`~rlhc.objectives.functional.fuse_values`.
        """
        consulted = self._manager_consulted(tensordict, worker_value, tensordict.batch_dims)
        return fuse_values(
            worker_value,
            manager_value,
            fusion=self.fusion,
            weight=self.weight,
            manager_consulted=consulted,
        )

    def value_estimate(
        self,
        tensordict: TensorDictBase,
        target_params: TensorDictBase | None = None,
        next_value: Tensor | None = None,
        **kwargs: object,
    ) -> Tensor:
        """The lambda-return on ``V_hat`` (the critics' regression target)."""
        return self.forward(tensordict.copy()).get(self.tensor_keys.value_target)

    def _manager_consulted(
        self, data: TensorDictBase, value: Tensor, batch_dims: int, under: tuple[str, ...] = ()
    ) -> Tensor | None:
        # Temporal scaling: the manager speaks at steps 0, k, 2k, ... of each episode.
        if self.manager_interval == 1:
            return None
        step_count = require(
            data, self.tensor_keys.step_count, "the episode step counter", under=under
        )
        return manager_consulted_mask(
            broadcast_to_value(step_count, value, batch_dims, "step_count"),
            self.manager_interval,
        )

    def _critic_values(
        self, data: TensorDictBase, *, grad: bool, under: tuple[str, ...] = ()
    ) -> tuple[Tensor, Tensor]:
        tk = self.tensor_keys
        outputs = []
        for network, key in (
            (self.worker_value_network, tk.worker_value),
            (self.manager_value_network, tk.manager_value),
        ):
            for in_key in network.in_keys:
                require(data, in_key, f"an input of the critic writing {key!r}", under=under)
            # The bootstrap V_hat(s_{t+1}) never carries gradient (as in TorchRL's GAE).
            with torch.set_grad_enabled(grad and torch.is_grad_enabled()):
                value = network(data).get(key, None)
            if value is None:
                raise KeyError(
                    f"the critic did not write {key!r}; its out_keys are {network.out_keys}"
                )
            outputs.append(value)
        worker_value, manager_value = outputs
        if worker_value.shape != manager_value.shape:
            raise ValueError(
                f"worker value {tk.worker_value!r} has shape {tuple(worker_value.shape)} but "
                f"manager value {tk.manager_value!r} has shape {tuple(manager_value.shape)}; "
                "both critics must output one value per agent, [*B, T, n_agents, 1]"
            )
        return worker_value, manager_value

    def extra_repr(self) -> str:
        return (
            f"fusion={self.fusion!r}, weight={self.weight}, "
            f"manager_interval={self.manager_interval}, group={self.group!r}"
        )
