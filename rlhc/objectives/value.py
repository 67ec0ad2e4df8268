"""``HierarchicalValueEstimator``: TorchRL's GAE on the fused value of two critics.

:class:`FusedValue` runs the worker and the manager critic and writes their fused
value ``V_hat``; :class:`HierarchicalValueEstimator` evaluates it on the root and
``"next"`` observations and hands the fused values to TorchRL's stock
:class:`~torchrl.objectives.value.GAE`.
"""

from __future__ import annotations

import contextlib
from dataclasses import dataclass
from typing import Any

import torch
from tensordict import TensorDict, TensorDictBase, unravel_key
from tensordict.nn import TensorDictModule, TensorDictModuleBase, dispatch, set_skip_existing
from tensordict.utils import NestedKey
from torch import Tensor
from torchrl.objectives.value import GAE

from rlhc.envs import keys
from rlhc.objectives.functional import (
    check_fusion,
    check_manager_interval,
    fuse_values,
    manager_consulted_mask,
)


def _require(data: TensorDictBase, key: NestedKey, meaning: str, *, under: tuple = ()) -> Tensor:
    """``data[key]``, or a ``KeyError`` naming the key (prefixed by ``under``, where
    ``data`` sits in the caller's data), what it is and what is present."""
    value = data.get(key, None)
    if value is None:
        full_key = unravel_key((*under, key)) if under else key
        present = sorted(map(str, data.keys(include_nested=True, leaves_only=True)))
        raise KeyError(f"missing key {full_key!r} ({meaning}); present: {present}")
    return value


def _broadcast_to_value(signal: Tensor, value: Tensor, batch_dims: int, name: str) -> Tensor:
    """Expand a per-step signal to the per-agent value shape ``[*B, T, n_g, 1]``: one
    shared by the agents (``[*B, T, 1]``) gains the agent dims after the batch dims."""
    while signal.ndim < value.ndim:
        signal = signal.unsqueeze(batch_dims)
    try:
        return signal.expand(value.shape)
    except RuntimeError:
        raise ValueError(
            f"{name} of shape {tuple(signal.shape)} does not broadcast to the values' "
            f"shape {tuple(value.shape)}"
        ) from None


def _resolve_time_dim(data: TensorDictBase, time_dim: int | None, default: int | None) -> int:
    """The non-negative time dimension, as TorchRL's estimators choose it: ``time_dim``,
    else ``default``, else the batch dimension named ``"time"``, else the last one.

    Examples:
        >>> data = TensorDict({}, [2, 5])
        >>> _resolve_time_dim(data, None, None), _resolve_time_dim(data, -2, None)
        (1, 0)
        >>> _resolve_time_dim(data.refine_names("time", None), None, None)
        0
    """
    chosen = time_dim if time_dim is not None else default
    if chosen is None:
        names = list(data.names)
        chosen = names.index("time") if "time" in names else data.batch_dims - 1
    return chosen % data.batch_dims if chosen < 0 else chosen


class FusedValue(TensorDictModuleBase):
    """The RLHC value network: a worker critic, a manager critic and their fusion.

    Writes ``worker_value`` (``V_w``), ``manager_value`` (``V_m``), ``value`` (the fused
    ``V_hat``, per agent and per step) and ``manager_selected`` (the share of ``V_hat``
    taken from ``V_m``). A plain TensorDict module: it can serve as the
    ``value_network`` of TorchRL's :class:`~torchrl.objectives.value.GAE`.

    Args:
        worker_value_network: ``V_w``, writing ``worker_value_key``.
        manager_value_network: ``V_m``, writing ``manager_value_key``.

    Keyword Args:
        fusion: ``"local"``, ``"manager"``, ``"max"`` (RLHC), ``"mean"`` or ``"weighted"``.
        weight: the manager's weight ``w`` in ``"weighted"`` fusion.
        manager_interval: consult the manager only where ``step_count % k == 0`` (the
            paper's temporal scaling); elsewhere ``V_hat = V_w``.
        worker_value_key: where ``V_w`` is written.
        manager_value_key: where ``V_m`` is written.
        value_key: where the fused ``V_hat`` is written.
        manager_selected_key: where the share of ``V_hat`` taken from ``V_m`` is written.
        step_count_key: the episode step counter, read when ``manager_interval > 1``.
        manager_diagnostics: under ``"local"`` fusion, run the manager critic anyway
            (``V_hat`` does not read it); every other fusion runs it.
        worker_diagnostics: under ``"manager"`` fusion consulted at every step, run the
            worker critic anyway (``V_hat`` does not read it); every other fusion, and
            ``"manager"`` with ``manager_interval > 1``, runs it.

    Raises:
        ValueError: unknown ``fusion``, ``weight`` outside ``[0, 1]`` or
            ``manager_interval < 1``.

    Examples:
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
        worker_diagnostics: bool = True,
    ) -> None:
        check_fusion(fusion, weight)
        check_manager_interval(manager_interval)
        super().__init__()
        self.worker_value_network = worker_value_network
        self.manager_value_network = manager_value_network
        self.fusion = fusion
        self.weight = float(weight)
        self.manager_interval = manager_interval
        self.value_key = value_key
        self.manager_selected_key = manager_selected_key
        self.step_count_key = step_count_key
        #: Whether the manager critic runs: all but ``"local"`` without diagnostics.
        self.runs_manager = fusion != "local" or manager_diagnostics
        #: Whether the worker critic runs: all but ``"manager"`` at every step without
        #: diagnostics (where the manager is not consulted, ``V_hat = V_w``).
        self.runs_worker = fusion != "manager" or manager_interval > 1 or worker_diagnostics
        self.worker_value_key, self.manager_value_key = worker_value_key, manager_value_key
        #: The critics run, each with the key it writes.
        self.critics = []
        if self.runs_worker:
            self.critics.append((worker_value_network, worker_value_key))
        if self.runs_manager:
            self.critics.append((manager_value_network, manager_value_key))
        in_keys = [key for network, _ in self.critics for key in network.in_keys]
        if manager_interval > 1:
            in_keys.append(step_count_key)
        self.in_keys = list(dict.fromkeys(in_keys))
        self.out_keys = [key for _, key in self.critics] + [value_key, manager_selected_key]

    def require_inputs(self, data: TensorDictBase, *, under: tuple = ()) -> None:
        """Raise a ``KeyError`` naming the first input missing from ``data``, which sits
        at ``under`` (e.g. ``("next",)``) in the caller's data."""
        for network, key in self.critics:
            for in_key in network.in_keys:
                _require(data, in_key, f"an input of the critic writing {key!r}", under=under)
        if self.manager_interval > 1:
            _require(data, self.step_count_key, "the episode step counter", under=under)

    def fuse(
        self, data: TensorDictBase, worker_value: Tensor | None, manager_value: Tensor | None
    ) -> tuple[Tensor, Tensor]:
        """``(V_hat, manager_share)`` of two value tensors at the steps of ``data``, as
        :func:`~rlhc.objectives.functional.fuse_values`; ``(V_w, 0)`` where the manager is
        not run (``manager_value=None``), ``(V_m, 1)`` where the worker is not
        (``worker_value=None``). ``data`` is read for ``step_count`` only, when
        ``manager_interval > 1``.

        Examples:
            >>> worker = TensorDictModule(torch.nn.Linear(3, 1), ["obs"], ["worker_value"])
            >>> manager = TensorDictModule(torch.nn.Linear(5, 1), ["mobs"], ["manager_value"])
            >>> fusion = FusedValue(worker, manager, fusion="max", manager_interval=2)
            >>> data = TensorDict({"step_count": torch.tensor([[0], [1]])}, [2])
            >>> fused, share = fusion.fuse(data, torch.zeros(2, 3, 1), torch.ones(2, 3, 1))
            >>> fused[:, 0, 0]  # the manager is consulted at step 0 only
            tensor([1., 0.])
        """
        if manager_value is None:
            assert worker_value is not None, "fuse() needs at least one critic's values"
            return worker_value, torch.zeros_like(worker_value)
        if worker_value is None:
            return manager_value, torch.ones_like(manager_value)
        consulted = None
        if self.manager_interval > 1:
            step_count = _require(data, self.step_count_key, "the episode step counter")
            step_count = _broadcast_to_value(
                step_count, worker_value, data.batch_dims, "step_count"
            )
            consulted = manager_consulted_mask(step_count, self.manager_interval)
        return fuse_values(
            worker_value,
            manager_value,
            fusion=self.fusion,
            weight=self.weight,
            manager_consulted=consulted,
        )

    def forward(self, tensordict: TensorDictBase) -> TensorDictBase:
        """Write ``V_w``, ``V_m``, ``V_hat`` and the manager's share into ``tensordict``.

        Raises:
            KeyError: an input is missing (the message names it).
            ValueError: the critics' values have different shapes.
        """
        self.require_inputs(tensordict)
        values = {key: network(tensordict).get(key) for network, key in self.critics}
        fused, share = self.fuse(
            tensordict, values.get(self.worker_value_key), values.get(self.manager_value_key)
        )
        tensordict.set(self.value_key, fused)
        tensordict.set(self.manager_selected_key, share)
        return tensordict


class HierarchicalValueEstimator(GAE):
    """Generalized advantage estimation on the fused value of a worker and a manager critic.

    RLHC (Cao & Lin, arXiv 1902.03079) computes every worker's PPO advantage from
    ``V_hat = max(V_w(o_w), V_m(o_m))``, element-wise per agent and per step, at ``t``
    and at the bootstrap ``t + 1``. The estimator evaluates :class:`FusedValue` on the
    root and ``"next"`` observations, then runs TorchRL's stock ``GAE`` (its parent,
    built with ``value_network=None``) on the fused values: truncated episodes bootstrap,
    terminated ones do not, and a done at one agent never leaks into another's trace.
    ``fusion="local"`` is plain PPO, TorchRL's ``GAE`` on the worker critic.

    It does not hand :class:`FusedValue` to ``GAE`` as its ``value_network``: GAE keeps
    only the fused value (the critics' own values are logged), and GAE's
    ``shifted=True`` evaluates a fixed ``T + shifted_budget`` window, invalidating the
    samples after a mid-batch truncation (a time-horizon cut, ``max_cycles``) once the
    budget is spent. This estimator's ``shifted`` is exact.

    Keyword Args:
        worker_value_network: ``V_w``, writing ``(group, "worker_value")``.
        manager_value_network: ``V_m``, writing ``(group, "manager_value")``.
        gamma: discount.
        lmbda: GAE lambda.
        fusion: ``"local"``, ``"manager"``, ``"max"`` (RLHC), ``"mean"`` or ``"weighted"``.
        weight: the manager's weight ``w`` in ``"weighted"`` fusion, ``w V_m + (1 - w) V_w``.
        manager_interval: consult the manager every ``k >= 1`` steps (see :class:`FusedValue`).
        group: the agent group whose keys are used, e.g. ``"racket"``; ``None`` keeps
            TorchRL's un-nested default keys.
        differentiable: let gradients flow through ``V_hat(s_t)`` (never through the
            bootstrap); PPO leaves it ``False``.
        time_dim: the time dimension; by default the one named ``"time"``, else the last.
        skip_existing: forwarded to the critics, as in TorchRL's estimators.
        manager_diagnostics: under ``"local"`` fusion, run the manager critic anyway;
            by default PPO leaves it out, and the loss then does not train it.
        worker_diagnostics: under ``"manager"`` fusion (consulted at every step), run
            the worker critic anyway; by default it is left out and not trained.
        shifted: the data are a collector's trajectories (``"next"`` of step ``t`` is the
            root of ``t + 1`` unless an episode ended or was cut after ``t``): the critics
            run once on the root observations, and on ``"next"`` only after a ``done`` and
            at the last step. ``False`` evaluates every ``"next"`` observation.

    The critics are borrowed, not registered: the loss holds their parameters and the
    estimator's ``state_dict`` holds ``gamma`` and ``lmbda`` only.

    Keys (:meth:`set_keys`; nested under ``group``): reads ``("next", reward | done |
    terminated)``, per agent ``[*B, T, n_g, 1]`` or shared ``[*B, T, 1]``, and
    ``step_count`` (root, and under ``"next"``) when ``manager_interval > 1``; writes
    ``worker_value``, ``manager_value``, ``value`` (``V_hat``), ``manager_selected``,
    ``advantage`` and ``value_target``, and the critics' values under ``"next"``.

    Examples:
        >>> from torchrl.data import Composite, Unbounded
        >>> from rlhc.modules import (
        ...     EnvSpecs, NetworkConfig, make_manager_critic, make_worker_critic)
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
        """TorchRL's estimator keys (``steps_to_next_obs`` and ``sample_log_prob`` unused,
        kept for the loss's key forwarding), plus the two critics' outputs, the manager's
        share of ``V_hat`` and the episode step counter (root, shared by the agents)."""

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
        worker_diagnostics: bool = False,
        shifted: bool = False,
    ) -> None:
        super().__init__(
            gamma=torch.as_tensor(gamma, dtype=torch.float32).clone(),
            lmbda=torch.as_tensor(lmbda, dtype=torch.float32).clone(),
            value_network=None,  # GAE reads V_hat(s_t) and V_hat(s_{t+1}) from its input
            differentiable=differentiable,
            vectorized=True,
            skip_existing=skip_existing,
            time_dim=time_dim,
            shifted=shifted,
        )
        # Tuples, which torch.nn.Module does not register: the critics are borrowed.
        self._critics = (worker_value_network, manager_value_network)
        self._fused: tuple[dict[str, Any], FusedValue] | None = None
        self.fusion = fusion
        self.weight = float(weight)
        self.manager_interval = manager_interval
        self.manager_diagnostics = manager_diagnostics
        self.worker_diagnostics = worker_diagnostics
        self.group = group
        if group is not None:
            defaults = self.default_keys()
            self.set_keys(**{name: (group, getattr(defaults, name)) for name in self.GROUP_KEYS})
        self.fused_value()  # validates fusion, weight and manager_interval

    @property
    def critics(self) -> tuple[TensorDictModule, TensorDictModule]:
        """``(worker_value_network, manager_value_network)``, borrowed."""
        return self._critics

    @property
    def worker_value_network(self) -> TensorDictModule:
        return self._critics[0]

    @property
    def manager_value_network(self) -> TensorDictModule:
        return self._critics[1]

    @property
    def runs_manager(self) -> bool:
        """Whether the manager critic is evaluated (see :class:`FusedValue`)."""
        return self.fused_value().runs_manager

    @property
    def runs_worker(self) -> bool:
        """Whether the worker critic is evaluated (see :class:`FusedValue`)."""
        return self.fused_value().runs_worker

    def fused_value(self) -> FusedValue:
        """The critics and their fusion as one :class:`FusedValue` on this estimator's
        keys; rebuilt only after :meth:`set_keys` or a fusion setting changed."""
        tk = self.tensor_keys
        options: dict[str, Any] = {
            "fusion": self.fusion,
            "weight": self.weight,
            "manager_interval": self.manager_interval,
            "worker_value_key": tk.worker_value,
            "manager_value_key": tk.manager_value,
            "value_key": tk.value,
            "manager_selected_key": tk.manager_selected,
            "step_count_key": tk.step_count,
            "manager_diagnostics": self.manager_diagnostics,
            "worker_diagnostics": self.worker_diagnostics,
        }
        if self._fused is None or self._fused[0] != options:
            self._fused = (options, FusedValue(*self._critics, **options))
        return self._fused[1]

    @property
    def in_keys(self) -> list[NestedKey]:
        tk, observed = self.tensor_keys, self.fused_value().in_keys
        read_next = [*observed, tk.reward, tk.done, tk.terminated]
        return [*observed, *(unravel_key(("next", key)) for key in read_next)]

    @property
    def out_keys(self) -> list[NestedKey]:
        tk = self.tensor_keys
        return [tk.advantage, tk.value_target, *self.fused_value().out_keys]

    @dispatch
    def forward(
        self,
        tensordict: TensorDictBase,
        *,
        params: TensorDictBase | None = None,
        target_params: TensorDictBase | None = None,
        time_dim: int | None = None,
    ) -> TensorDictBase:
        """Write the critics' values, ``V_hat``, the advantage and the value target.

        Args:
            tensordict: data ``[*B, T]`` holding the critics' inputs at the root and under
                ``"next"``, and the ``"next"`` reward, done and terminated of the group.

        Keyword Args:
            params: accepted for :class:`~torchrl.objectives.ClipPPOLoss`, which passes
                its critic parameters; the critics run with their own, the same tensors.
            target_params: accepted for the same reason; PPO has no target critic.
            time_dim: overrides the constructor's ``time_dim``.

        Returns:
            ``tensordict``, updated in place.

        Raises:
            KeyError: an input is missing (the message names it).
            ValueError: the critics' values, or a signal, have incompatible shapes.
        """
        if tensordict.batch_dims < 1:
            raise RuntimeError(
                f"expected data of batch [*B, T], got batch_size {tuple(tensordict.batch_size)}"
            )
        tk, fused_value = self.tensor_keys, self.fused_value()
        next_td = tensordict.get("next")
        fused_value.require_inputs(tensordict)
        fused_value.require_inputs(next_td, under=("next",))
        signals = {
            name: _require(next_td, getattr(tk, name), meaning, under=("next",))
            for name, meaning in (
                ("reward", "the reward of step t"),
                ("done", "did the episode end after step t"),
                ("terminated", "did it end without a future"),
            )
        }
        time_dim = _resolve_time_dim(tensordict, time_dim, self.time_dim)
        skip = (
            set_skip_existing(self.skip_existing)
            if self.skip_existing is not None
            else contextlib.nullcontext()
        )
        with skip:
            with torch.set_grad_enabled(self.differentiable):
                fused_value(tensordict)
            with torch.no_grad():  # the bootstrap V_hat(s_{t+1}) never carries gradient
                if self.shifted:
                    next_values = self._shifted_next_values(tensordict, next_td, time_dim)
                else:  # on a shallow copy, which keeps V_hat(s_{t+1}) out of the data
                    next_values = fused_value(next_td.copy())
        next_td.update(next_values.select(tk.worker_value, tk.manager_value, strict=False))

        # Stock GAE on what it reads, per agent: V_hat at t and t + 1, and the signals.
        value = tensordict.get(tk.value)
        gae_inputs = TensorDict(batch_size=tensordict.batch_size, device=tensordict.device)
        gae_inputs.set(tk.value, value)
        gae_inputs.set(("next", tk.value), next_values.get(tk.value))
        for name, signal in signals.items():
            signal = _broadcast_to_value(signal, value, tensordict.batch_dims, name)
            gae_inputs.set(
                ("next", getattr(tk, name)), signal if name == "reward" else signal.bool()
            )
        super().forward(gae_inputs, time_dim=time_dim)
        tensordict.update(gae_inputs.select(tk.advantage, tk.value_target))
        return tensordict

    def _shifted_next_values(
        self, tensordict: TensorDictBase, next_td: TensorDictBase, time_dim: int
    ) -> TensorDictBase:
        """The fused values of the ``"next"`` observations: step ``t + 1``'s root values,
        except after a ``done`` at any agent (a world resets as a whole) and at the last
        step, where ``"next"`` may hold another observation and is evaluated."""
        fused_value = self.fused_value()
        written = fused_value.out_keys
        next_values = tensordict.select(*written).apply(
            lambda value: value.detach().roll(-1, dims=time_dim)
        )
        done = next_td.get(self.tensor_keys.done)
        evaluate = done.reshape(*tensordict.batch_size, -1).any(-1)
        evaluate.select(time_dim, -1).fill_(True)
        inputs = next_td.select(*fused_value.in_keys, strict=False)[evaluate]
        evaluated = fused_value(inputs)
        for key in written:
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
        """The lambda-return on ``V_hat`` (the critics' target); ``tensordict`` is left
        untouched (the estimate runs on a shallow copy)."""
        return self.forward(tensordict.copy(), time_dim=time_dim).get(self.tensor_keys.value_target)

    def extra_repr(self) -> str:
        return (
            f"fusion={self.fusion!r}, weight={self.weight}, "
            f"manager_interval={self.manager_interval}, group={self.group!r}"
        )
