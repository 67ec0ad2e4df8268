"""``HierarchicalValueEstimator``: TorchRL's GAE on the fused value of two critics.

Two public pieces, built only on TorchRL's and tensordict's public API:

* :class:`FusedValue`, a :class:`~tensordict.nn.TensorDictModuleBase` that runs the
  worker and the manager critic and writes their fused value ``V_hat`` (and which
  critic it came from). It is an ordinary TorchRL value network: it can be handed to
  TorchRL's :class:`~torchrl.objectives.value.GAE` as ``value_network``.
* :class:`HierarchicalValueEstimator`, a subclass of TorchRL's
  :class:`~torchrl.objectives.value.GAE` that evaluates :class:`FusedValue` on the
  root and ``"next"`` observations itself (so the critics' own outputs stay in the
  data), then lets the stock ``GAE.forward`` run on the fused values, as GAE does
  whenever it is built with ``value_network=None``.
"""

from __future__ import annotations

import contextlib
from dataclasses import dataclass

import torch
from tensordict import TensorDict, TensorDictBase
from tensordict.nn import TensorDictModule, TensorDictModuleBase, dispatch, set_skip_existing
from tensordict.utils import NestedKey
from torch import Tensor
from torchrl.objectives.value import GAE

from rlhc.envs import keys
from rlhc.objectives._data import as_tuple, broadcast_to_value, require, resolve_time_dim
from rlhc.objectives.functional import (
    check_fusion,
    check_manager_interval,
    fuse_values,
    manager_consulted_mask,
)


class FusedValue(TensorDictModuleBase):
    """The RLHC value network: a worker critic, a manager critic and their fusion.

    Reads the two critics' inputs (and ``step_count`` when ``manager_interval > 1``),
    and writes ``worker_value`` (``V_w``), ``manager_value`` (``V_m``), ``value``
    (the fused ``V_hat``, per agent and per step) and ``manager_selected`` (the share
    of ``V_hat`` taken from ``V_m``). Being a plain TensorDict module, it can serve as
    the ``value_network`` of TorchRL's :class:`~torchrl.objectives.value.GAE`;
    :class:`HierarchicalValueEstimator` builds one from its keys with
    :meth:`HierarchicalValueEstimator.fused_value`.

    Args:
        worker_value_network: ``V_w``, writing ``worker_value_key``.
        manager_value_network: ``V_m``, writing ``manager_value_key``.

    Keyword Args:
        fusion: ``"local"``, ``"manager"``, ``"max"`` (RLHC), ``"mean"`` or ``"weighted"``.
        weight: the manager's weight ``w`` in ``"weighted"`` fusion.
        manager_interval: consult the manager every ``k >= 1`` steps.
        worker_value_key: the worker critic's output.
        manager_value_key: the manager critic's output.
        value_key: where ``V_hat`` is written.
        manager_selected_key: where the manager's share of ``V_hat`` is written.
        step_count_key: the episode step counter, read when ``manager_interval > 1``.
        manager_diagnostics: with ``fusion="local"`` (PPO), run the manager critic anyway
            and write its value (which ``V_hat`` does not use). ``False``: the manager
            is neither run nor written under ``"local"``. Other fusions always run it.

    Raises:
        ValueError: unknown ``fusion``, ``weight`` outside ``[0, 1]`` or
            ``manager_interval < 1``.

    Examples:
        >>> from tensordict import TensorDict
        >>> from tensordict.nn import TensorDictModule
        >>> worker = TensorDictModule(torch.nn.Linear(3, 1), ["obs"], ["worker_value"])
        >>> manager = TensorDictModule(torch.nn.Linear(5, 1), ["mobs"], ["manager_value"])
        >>> fused = FusedValue(worker, manager, fusion="max")
        >>> td = fused(TensorDict({"obs": torch.randn(4, 3), "mobs": torch.randn(4, 5)}, [4]))
        >>> bool((td["state_value"] == td["worker_value"].maximum(td["manager_value"])).all())
        True
    """

    def __init__(
        self,
        worker_value_network: TensorDictModule,
        manager_value_network: TensorDictModule,
        *,
        fusion: str = "max",
        weight: float = 0.5,
        manager_interval: int = 1,
        worker_value_key: NestedKey = keys.WORKER_VALUE,
        manager_value_key: NestedKey = keys.MANAGER_VALUE,
        value_key: NestedKey = keys.STATE_VALUE,
        manager_selected_key: NestedKey = keys.MANAGER_SELECTED,
        step_count_key: NestedKey = keys.STEP_COUNT,
        manager_diagnostics: bool = True,
    ) -> None:
        check_fusion(fusion, weight)
        check_manager_interval(manager_interval)
        super().__init__()
        self.worker_value_network = worker_value_network
        self.manager_value_network = manager_value_network
        self.fusion = fusion
        self.weight = float(weight)
        self.manager_interval = manager_interval
        self.worker_value_key = worker_value_key
        self.manager_value_key = manager_value_key
        self.value_key = value_key
        self.manager_selected_key = manager_selected_key
        self.step_count_key = step_count_key
        #: Whether the manager critic is run: always but under ``"local"`` fusion
        #: without ``manager_diagnostics``, where ``V_hat`` does not read it.
        self.runs_manager = fusion != "local" or manager_diagnostics
        in_keys = list(worker_value_network.in_keys)
        out_keys = [worker_value_key]
        if self.runs_manager:
            in_keys += manager_value_network.in_keys
            out_keys.append(manager_value_key)
        if manager_interval > 1:
            in_keys.append(step_count_key)
        self.in_keys = list(dict.fromkeys(in_keys))
        self.out_keys = [*out_keys, value_key, manager_selected_key]

    def evaluated_critics(self) -> list[tuple[TensorDictModule, NestedKey]]:
        """The critics this module runs (the manager only if :attr:`runs_manager`),
        each with the key it writes."""
        networks = [(self.worker_value_network, self.worker_value_key)]
        if self.runs_manager:
            networks.append((self.manager_value_network, self.manager_value_key))
        return networks

    def require_inputs(self, data: TensorDictBase, *, under: tuple[str, ...] = ()) -> None:
        """Raise a ``KeyError`` naming the first input of this module missing from ``data``.

        Args:
            data: the data about to be evaluated.
            under: where ``data`` sits in the caller's data (e.g. ``("next",)``), so
                that the message names the full key.
        """
        for network, key in self.evaluated_critics():
            for in_key in network.in_keys:
                require(data, in_key, f"an input of the critic writing {key!r}", under=under)
        if self.manager_interval > 1:
            require(data, self.step_count_key, "the episode step counter", under=under)

    def critic_values(self, data: TensorDictBase) -> tuple[Tensor, Tensor | None]:
        """Run the critics on ``data`` (writing their outputs into it).

        Returns:
            ``(V_w, V_m)``, each ``[*B, n_agents, 1]``; ``V_m`` is ``None`` where the
            manager is not run (:attr:`runs_manager`).

        Raises:
            KeyError: a critic did not write its output key.
            ValueError: the two values have different shapes.
        """
        outputs = []
        for network, key in self.evaluated_critics():
            value = network(data).get(key, None)
            if value is None:
                raise KeyError(
                    f"the critic did not write {key!r}; its out_keys are {network.out_keys}"
                )
            outputs.append(value)
        if not self.runs_manager:
            return outputs[0], None
        worker_value, manager_value = outputs
        if worker_value.shape != manager_value.shape:
            raise ValueError(
                f"worker value {self.worker_value_key!r} has shape {tuple(worker_value.shape)} "
                f"but manager value {self.manager_value_key!r} has shape "
                f"{tuple(manager_value.shape)}; both critics must output one value per agent, "
                "[*B, T, n_agents, 1]"
            )
        return worker_value, manager_value

    def fuse(
        self,
        data: TensorDictBase,
        worker_value: Tensor,
        manager_value: Tensor | None,
        *,
        under: tuple[str, ...] = (),
    ) -> tuple[Tensor, Tensor]:
        """Fuse two value tensors at the steps of ``data`` (temporal scaling included).

        With ``manager_interval = k > 1`` the manager is consulted only where the
        ``step_count`` of ``data`` is a multiple of ``k``; elsewhere ``V_hat = V_w``.
        The estimator fuses through here, and so does the loss for its explained variance.

        Args:
            data: the (root or ``"next"``) data the values belong to; read for the step
                counter only, and only when ``manager_interval > 1``.
            worker_value: ``V_w`` on that data, ``[*B, n_agents, 1]``.
            manager_value: ``V_m`` on that data, the same shape; ``None`` where the
                manager is not run (``"local"`` fusion reads ``V_w`` only).
            under: where ``data`` sits in the caller's data, for error messages.

        Returns:
            ``(fused_value, manager_share)``, as :func:`~rlhc.objectives.functional.fuse_values`.

        Raises:
            KeyError: ``manager_interval > 1`` and the step counter is missing.

        Examples:
            >>> from tensordict import TensorDict
            >>> worker = TensorDictModule(torch.nn.Linear(3, 1), ["obs"], ["worker_value"])
            >>> manager = TensorDictModule(torch.nn.Linear(5, 1), ["mobs"], ["manager_value"])
            >>> fusion = FusedValue(worker, manager, fusion="max", manager_interval=2)
            >>> data = TensorDict({"step_count": torch.tensor([[0], [1]])}, [2])
            >>> fused, share = fusion.fuse(data, torch.zeros(2, 3, 1), torch.ones(2, 3, 1))
            >>> fused[:, 0, 0]  # the manager is consulted at step 0 only
            tensor([1., 0.])
        """
        if manager_value is None:
            if self.fusion != "local":
                raise ValueError(f"fusion {self.fusion!r} needs the manager's value")
            return worker_value, torch.zeros_like(worker_value)
        consulted = None
        if self.manager_interval > 1:
            # Temporal scaling: the manager speaks at steps 0, k, 2k, ... of each episode.
            step_count = require(data, self.step_count_key, "the episode step counter", under=under)
            consulted = manager_consulted_mask(
                broadcast_to_value(step_count, worker_value, data.batch_dims, "step_count"),
                self.manager_interval,
            )
        return fuse_values(
            worker_value,
            manager_value,
            fusion=self.fusion,
            weight=self.weight,
            manager_consulted=consulted,
        )

    def forward(self, tensordict: TensorDictBase) -> TensorDictBase:
        """Write ``V_w``, ``V_m``, the fused ``V_hat`` and the manager's share.

        Args:
            tensordict: data holding the critics' inputs.

        Returns:
            ``tensordict``, updated in place.

        Raises:
            KeyError: an input is missing (the message names it).
            ValueError: the critics' values have different shapes.
        """
        self.require_inputs(tensordict)
        worker_value, manager_value = self.critic_values(tensordict)
        fused, share = self.fuse(tensordict, worker_value, manager_value)
        tensordict.set(self.value_key, fused)
        tensordict.set(self.manager_selected_key, share)
        return tensordict

    def extra_repr(self) -> str:
        return (
            f"fusion={self.fusion!r}, weight={self.weight}, "
            f"manager_interval={self.manager_interval}, runs_manager={self.runs_manager}"
        )


class HierarchicalValueEstimator(GAE):
    """Generalized advantage estimation on the fused value of a worker and a manager critic.

    RLHC (Cao & Lin, arXiv 1902.03079) computes the PPO advantage of every
    worker from ``V_hat = max(V_w(o_w), V_m(o_m))``, element-wise per agent and per
    step, used at ``t`` and at the bootstrap ``t + 1``. This estimator evaluates
    :class:`FusedValue` (both critics and their fusion) on the root and ``"next"``
    observations, then runs TorchRL's :class:`~torchrl.objectives.value.GAE` (of which
    it is a subclass, built with ``value_network=None`` so that GAE reads the fused
    values from the data) with its vectorised kernel. Truncated episodes bootstrap,
    terminated ones do not, and a done at one agent never leaks into another agent's
    trace.

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
        manager_diagnostics: with ``fusion="local"`` (PPO), run the manager critic
            anyway and write its value, as :class:`FusedValue`; ``False`` (the default)
            leaves it out there, and the loss then does not train it either.
        shifted: the data are trajectories (a collector's ``[*B, T]`` batch): the
            ``"next"`` observation of step ``t`` is the root observation of ``t + 1``
            wherever the episode goes on. The critics then run once on the root
            observations, and on ``"next"`` only where it differs or may differ
            (steps whose ``done`` is set: episode ends and cuts; the last step), as
            TorchRL's ``GAE(shifted=True)`` saves its second call. ``False`` (the
            default) evaluates every ``"next"`` observation: right for any data.

    The critics are borrowed, not owned (as TorchRL's ``GAE`` does with its value
    network): the loss and the trainer hold their parameters, so attaching the
    estimator to a loss lists no parameter twice, and its ``state_dict`` holds only
    ``gamma`` and ``lmbda``.

    Keys (all configurable with :meth:`set_keys`; nested under ``group`` by default):
    reads ``("next", reward|done|terminated)``, ``step_count`` and
    ``("next", step_count)`` (root, only when ``manager_interval > 1``); writes
    ``worker_value``, ``manager_value``, ``value`` (the fused ``V_hat``,
    ``"state_value"``), ``advantage``, ``value_target`` and ``manager_selected``
    (the share of ``V_hat`` taken from the manager critic: in ``"max"`` mode 1 where
    the manager's critic wins, so its mean is the share of steps it wins). The
    critics' values of the next observations are left under ``"next"`` too. The
    reward, done and terminated flags may be per agent (``[*B, T, n_g, 1]``) or
    shared by the agents (``[*B, T, 1]``).

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
        manager_diagnostics: bool = False,
        shifted: bool = False,
    ) -> None:
        check_fusion(fusion, weight)
        check_manager_interval(manager_interval)
        super().__init__(
            gamma=torch.as_tensor(gamma, dtype=torch.float32).clone(),
            lmbda=torch.as_tensor(lmbda, dtype=torch.float32).clone(),
            # GAE reads V_hat(s_t) and V_hat(s_{t+1}) from the data, where forward puts them.
            value_network=None,
            differentiable=differentiable,
            vectorized=True,
            skip_existing=skip_existing,
            time_dim=time_dim,
            shifted=shifted,
        )
        # A tuple, which torch.nn.Module does not register: the critics are borrowed.
        self._critics = (worker_value_network, manager_value_network)
        self.fusion = fusion
        self.weight = float(weight)
        self.manager_interval = manager_interval
        self.manager_diagnostics = manager_diagnostics
        self.group = group
        # (what it was built from, the FusedValue): a tuple, so not registered either.
        self._fused: tuple[tuple[object, ...], FusedValue] | None = None
        if group is not None:
            defaults = self.default_keys()
            self.set_keys(**{name: (group, getattr(defaults, name)) for name in self.GROUP_KEYS})

    @property
    def critics(self) -> tuple[TensorDictModule, TensorDictModule]:
        """``(worker_value_network, manager_value_network)``, borrowed, not registered.

        The estimator's ``parameters()`` and ``state_dict()`` do not list the critics'
        parameters (the loss and the trainer own them).
        """
        return self._critics

    @property
    def worker_value_network(self) -> TensorDictModule:
        """``V_w``, the worker critic (borrowed)."""
        return self.critics[0]

    @property
    def manager_value_network(self) -> TensorDictModule:
        """``V_m``, the manager critic (borrowed)."""
        return self.critics[1]

    @property
    def runs_manager(self) -> bool:
        """Whether the manager critic is evaluated (all but ``"local"`` fusion without
        ``manager_diagnostics``)."""
        return self.fusion != "local" or self.manager_diagnostics

    def fused_value(self) -> FusedValue:
        """The two critics and their fusion as one TensorDict module, on this estimator's keys.

        One per estimator: built at the first call and again only after the keys
        (:meth:`set_keys`) or the fusion settings changed; never registered as a
        submodule.

        Returns:
            A :class:`FusedValue` writing ``worker_value``, ``manager_value``, ``value``
            and ``manager_selected``; usable as the ``value_network`` of TorchRL's GAE.
        """
        tk = self.tensor_keys
        built_from = (
            tk.worker_value,
            tk.manager_value,
            tk.value,
            tk.manager_selected,
            tk.step_count,
            self.fusion,
            self.weight,
            self.manager_interval,
            self.manager_diagnostics,
        )
        if self._fused is None or self._fused[0] != built_from:
            fused_value = FusedValue(
                self.worker_value_network,
                self.manager_value_network,
                fusion=self.fusion,
                weight=self.weight,
                manager_interval=self.manager_interval,
                worker_value_key=tk.worker_value,
                manager_value_key=tk.manager_value,
                value_key=tk.value,
                manager_selected_key=tk.manager_selected,
                step_count_key=tk.step_count,
                manager_diagnostics=self.manager_diagnostics,
            )
            self._fused = (built_from, fused_value)
        return self._fused[1]

    @property
    def in_keys(self) -> list[NestedKey]:
        tk = self.tensor_keys
        observed = list(self.worker_value_network.in_keys)
        if self.runs_manager:
            observed += self.manager_value_network.in_keys
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
        critics = [tk.worker_value]
        if self.runs_manager:
            critics.append(tk.manager_value)
        return [tk.advantage, tk.value_target, tk.value, *critics, tk.manager_selected]

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
        fused_value = self.fused_value()
        next_td = require(tensordict, "next", "the step's next-state data")
        if not isinstance(next_td, TensorDictBase):
            raise TypeError(f"'next' must hold a TensorDict, got {type(next_td).__name__}")
        fused_value.require_inputs(tensordict)
        fused_value.require_inputs(next_td, under=("next",))
        signals = [
            (require(next_td, key, meaning, under=("next",)), name)
            for key, meaning, name in (
                (tk.reward, "the reward of step t", "reward"),
                (tk.done, "did the episode end after step t", "done"),
                (tk.terminated, "did it end without a future", "terminated"),
            )
        ]
        skip = (
            set_skip_existing(self.skip_existing)
            if self.skip_existing is not None
            else contextlib.nullcontext()
        )
        time_dim = resolve_time_dim(tensordict, time_dim, self.time_dim)
        with skip:
            with torch.set_grad_enabled(self.differentiable):
                fused_value(tensordict)
            # The bootstrap V_hat(s_{t+1}) never carries gradient (as in TorchRL's GAE).
            with torch.no_grad():
                if self.shifted:
                    next_values = self._shifted_next_values(tensordict, next_td, time_dim)
                else:
                    # A shallow copy keeps V_hat(s_{t+1}) out of the data.
                    next_values = fused_value(next_td.copy())
        # The critics' own values of the next observations, under "next".
        next_td.update(next_values.select(tk.worker_value, tk.manager_value, strict=False))

        value = tensordict.get(tk.value)
        reward, done, terminated = (
            broadcast_to_value(signal, value, tensordict.batch_dims, name)
            for signal, name in signals
        )
        # Stock GAE on exactly what it needs, per agent: the fused values at t and
        # t + 1, and the signals broadcast to the agents.
        gae_inputs = TensorDict(batch_size=tensordict.batch_size, device=tensordict.device)
        gae_inputs.set(tk.value, value)
        gae_inputs.set(("next", *as_tuple(tk.value)), next_values.get(tk.value))
        gae_inputs.set(("next", *as_tuple(tk.reward)), reward)
        gae_inputs.set(("next", *as_tuple(tk.done)), done.bool())
        gae_inputs.set(("next", *as_tuple(tk.terminated)), terminated.bool())
        super().forward(gae_inputs, time_dim=time_dim)
        tensordict.set(tk.advantage, gae_inputs.get(tk.advantage))
        tensordict.set(tk.value_target, gae_inputs.get(tk.value_target))
        return tensordict

    def _shifted_next_values(
        self, tensordict: TensorDictBase, next_td: TensorDictBase, time_dim: int
    ) -> TensorDictBase:
        """The fused values of the ``"next"`` observations, from the root's and a few more.

        Step ``t``'s next values are step ``t + 1``'s root values, except where
        ``"next"`` may hold another observation: where the episode ended or was cut
        after ``t`` (``done`` at any agent: a world resets as a whole) and at the last
        step. Only those observations are evaluated.
        """
        fused_value = self.fused_value()
        keys = fused_value.out_keys
        root = tensordict.select(*keys)
        next_values = root.apply(lambda value: value.detach().roll(-1, dims=time_dim))
        done = next_td.get(self.tensor_keys.done)
        world_done = done.reshape(*tensordict.batch_size, -1).any(-1)
        evaluate = world_done.clone()
        evaluate.select(time_dim, -1).fill_(True)
        inputs = next_td.select(*fused_value.in_keys, strict=False)[evaluate]
        evaluated = fused_value(inputs).select(*keys)
        for key in keys:
            values = next_values.get(key).clone()
            values[evaluate] = evaluated.get(key).to(values.dtype)
            next_values.set(key, values)
        return next_values

    def value_estimate(
        self,
        tensordict: TensorDictBase,
        params: TensorDictBase | None = None,
        target_params: TensorDictBase | None = None,
        time_dim: int | None = None,
        **kwargs: object,
    ) -> Tensor:
        """The lambda-return on ``V_hat`` (the critics' regression target).

        ``tensordict`` is left untouched (the estimate runs on a shallow copy).
        """
        out = self.forward(tensordict.copy(), time_dim=time_dim)
        return out.get(self.tensor_keys.value_target)

    def extra_repr(self) -> str:
        return (
            f"fusion={self.fusion!r}, weight={self.weight}, "
            f"manager_interval={self.manager_interval}, group={self.group!r}"
        )
