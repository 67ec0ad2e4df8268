"""Pure tensor maths of RLHC: fusing two critics, and GAE on the fused value.

Reinforcement Learning from Hierarchical Critics (Cao & Lin, arXiv 1902.03079)
trains every worker with PPO, but replaces the state value inside GAE by a *fused*
value built from two critics, per agent and per step:

    V_hat(s_t) = max(V_w(o_w,t), V_m(o_m,t))

where ``V_w`` is the worker's critic on its local observation and ``V_m`` the team
manager's critic on a broader one. ``V_hat`` is used both at ``t`` and at the
bootstrap ``t + 1`` of the TD error ``delta_t = r_t + gamma V_hat(s_{t+1}) - V_hat(s_t)``.
The same functions give the paper's baselines and extensions through ``fusion``:

| ``fusion`` | ``V_hat`` | manager share |
|---|---|---|
| ``"local"`` | ``V_w`` (plain PPO) | 0 |
| ``"manager"`` | ``V_m`` | 1 |
| ``"max"`` | ``max(V_w, V_m)`` (RLHC) | 1 where ``V_m > V_w`` else 0 |
| ``"mean"`` | ``(V_w + V_m) / 2`` | 0.5 |
| ``"weighted"`` | ``w V_m + (1 - w) V_w`` | ``w`` |

and temporal scaling (the manager consulted every ``k`` steps only) through a
``manager_consulted`` mask: where it is false, ``V_hat = V_w``.

Nothing here knows about TensorDicts or networks: everything is a tensor whose time
dimension is ``time_dim`` and whose trailing dimensions (agents, feature) are kept
independent. The advantage recursion itself is TorchRL's
:func:`~torchrl.objectives.value.functional.vec_generalized_advantage_estimate`.
"""

from __future__ import annotations

from typing import NamedTuple

import torch
from torch import Tensor
from torchrl.objectives.value.functional import vec_generalized_advantage_estimate

#: The fusion modes, in the order of the table above.
FUSIONS: tuple[str, ...] = ("local", "manager", "max", "mean", "weighted")


def check_fusion(fusion: str, weight: float) -> None:
    """Validate a fusion mode and its weight.

    Args:
        fusion: one of :data:`FUSIONS`.
        weight: the manager's weight ``w`` in ``"weighted"`` fusion; checked for every
            mode so that a bad config fails whatever the mode.

    Raises:
        ValueError: ``fusion`` is unknown, or ``weight`` is outside ``[0, 1]``.
    """
    if fusion not in FUSIONS:
        raise ValueError(f"unknown fusion {fusion!r}; choose one of {list(FUSIONS)}")
    if not 0.0 <= float(weight) <= 1.0:
        raise ValueError(f"weight must lie in [0, 1] (the manager's share), got {weight!r}")


def fuse_values(
    worker_value: Tensor,
    manager_value: Tensor,
    *,
    fusion: str,
    weight: float = 0.5,
    manager_consulted: Tensor | None = None,
) -> tuple[Tensor, Tensor]:
    """Fuse the worker's and the manager's values element-wise (per agent, per step).

    Args:
        worker_value: ``V_w``, any shape.
        manager_value: ``V_m``, the same shape as ``worker_value``.
        fusion: one of :data:`FUSIONS`.
        weight: the manager's weight ``w`` in ``"weighted"`` fusion, in ``[0, 1]``.
        manager_consulted: optional boolean mask broadcastable to the values; where it
            is false the manager is not consulted and ``V_hat = V_w`` (temporal scaling).

    Returns:
        ``(fused_value, manager_share)``: ``V_hat`` and, with the same shape and dtype,
        the share of ``V_hat`` that came from the manager critic (see the module table;
        0 wherever the manager was not consulted).

    Raises:
        ValueError: unknown ``fusion``, ``weight`` outside ``[0, 1]``, or the two values
            have different shapes.

    Examples:
        >>> worker = torch.tensor([1.0, 3.0])
        >>> manager = torch.tensor([2.0, 2.0])
        >>> fuse_values(worker, manager, fusion="max")
        (tensor([2., 3.]), tensor([1., 0.]))
        >>> fuse_values(worker, manager, fusion="weighted", weight=0.25)[0]
        tensor([1.2500, 2.7500])
    """
    check_fusion(fusion, weight)
    if worker_value.shape != manager_value.shape:
        raise ValueError(
            f"worker and manager values must have the same shape, got "
            f"{tuple(worker_value.shape)} (worker) and {tuple(manager_value.shape)} (manager)"
        )
    if fusion == "local":
        fused, share = worker_value, torch.zeros_like(worker_value)
    elif fusion == "manager":
        fused, share = manager_value, torch.ones_like(worker_value)
    elif fusion == "max":
        # A where (not torch.maximum) so that the gradient, if any, goes to the one
        # critic that was selected, and the share says which one; ties go to the worker.
        manager_wins = manager_value > worker_value
        fused = torch.where(manager_wins, manager_value, worker_value)
        share = manager_wins.to(worker_value.dtype)
    else:
        w = 0.5 if fusion == "mean" else float(weight)
        fused = w * manager_value + (1.0 - w) * worker_value
        share = torch.full_like(worker_value, w)
    if manager_consulted is not None:
        consulted = manager_consulted.to(torch.bool)
        fused = torch.where(consulted, fused, worker_value)
        share = torch.where(consulted, share, torch.zeros_like(share))
    return fused, share


def manager_consulted_mask(step_count: Tensor, manager_interval: int) -> Tensor:
    """Where the manager is consulted: ``step_count % k == 0`` (paper's temporal scaling).

    Args:
        step_count: integer steps taken in the episode before each observation.
        manager_interval: ``k >= 1``; ``k = 1`` consults the manager at every step.

    Returns:
        A boolean tensor shaped like ``step_count``.

    Raises:
        ValueError: ``manager_interval < 1``.

    Examples:
        >>> manager_consulted_mask(torch.arange(6), 5)
        tensor([ True, False, False, False, False,  True])
    """
    check_manager_interval(manager_interval)
    return step_count % manager_interval == 0


def check_manager_interval(manager_interval: int) -> None:
    """Raise ``ValueError`` unless ``manager_interval`` is an integer ``>= 1``."""
    if isinstance(manager_interval, bool) or not isinstance(manager_interval, int):
        raise ValueError(f"manager_interval must be an integer >= 1, got {manager_interval!r}")
    if manager_interval < 1:
        raise ValueError(f"manager_interval must be an integer >= 1, got {manager_interval!r}")


def generalized_advantage(
    gamma: float | Tensor,
    lmbda: float | Tensor,
    value: Tensor,
    next_value: Tensor,
    reward: Tensor,
    done: Tensor,
    terminated: Tensor,
    *,
    time_dim: int,
) -> tuple[Tensor, Tensor]:
    """GAE over ``time_dim`` with every other dimension independent.

    A thin shape-checking wrapper around TorchRL's vectorised GAE: ``done`` cuts the
    lambda-trace (a new episode starts at ``t + 1``), ``terminated`` removes the
    bootstrap ``gamma V(s_{t+1})``; a truncated step is done but not terminated, so it
    bootstraps from the value of its true final observation.

    Args:
        gamma: discount.
        lmbda: GAE lambda.
        value: ``V(s_t)``, shape ``[*B, T, *F]`` with time at ``time_dim``.
        next_value: ``V(s_{t+1})``, same shape.
        reward: ``r_t``, same shape.
        done: episode ended after step ``t`` (terminated or truncated), same shape.
        terminated: episode ended without a future after step ``t``, same shape.
        time_dim: the time dimension (negative counts from the end).

    Returns:
        ``(advantage, value_target)``, each shaped like ``value``; ``value_target =
        advantage + value`` is the lambda-return.

    Raises:
        ValueError: the five tensors do not share one shape.
    """
    shapes = {
        "value": value.shape,
        "next_value": next_value.shape,
        "reward": reward.shape,
        "done": done.shape,
        "terminated": terminated.shape,
    }
    if len(set(shapes.values())) != 1:
        listed = ", ".join(f"{name} {tuple(shape)}" for name, shape in shapes.items())
        raise ValueError(f"GAE inputs must share one shape, got {listed}")
    if value.ndim < 2:
        raise ValueError(
            f"GAE inputs need a time and a feature dim, got shape {tuple(value.shape)}"
        )
    time_dim = time_dim % value.ndim
    # TorchRL's kernel wants time at -2 with every leading dim a batch dim: moving
    # the agent (and feature) dims before time keeps agents independent, so that a
    # done at one agent never cuts another agent's trace.
    moved = [
        t.movedim(time_dim, -1).unsqueeze(-1)
        for t in (value, next_value, reward, done.bool(), terminated.bool())
    ]
    advantage, value_target = vec_generalized_advantage_estimate(
        gamma,
        lmbda,
        moved[0],
        moved[1],
        moved[2],
        done=moved[3],
        terminated=moved[4],
        time_dim=-2,
    )
    return (
        advantage.squeeze(-1).movedim(-1, time_dim),
        value_target.squeeze(-1).movedim(-1, time_dim),
    )


class HierarchicalAdvantage(NamedTuple):
    """What :func:`hierarchical_gae` returns; every field shaped like the values."""

    advantage: Tensor
    value_target: Tensor
    fused_value: Tensor
    next_fused_value: Tensor
    manager_share: Tensor


def hierarchical_gae(
    gamma: float | Tensor,
    lmbda: float | Tensor,
    *,
    worker_value: Tensor,
    manager_value: Tensor,
    next_worker_value: Tensor,
    next_manager_value: Tensor,
    reward: Tensor,
    done: Tensor,
    terminated: Tensor,
    time_dim: int,
    fusion: str = "max",
    weight: float = 0.5,
    manager_consulted: Tensor | None = None,
    next_manager_consulted: Tensor | None = None,
) -> HierarchicalAdvantage:
    """GAE on the fused value ``V_hat``, used at ``t`` and at the bootstrap ``t + 1``.

    Args:
        gamma: discount.
        lmbda: GAE lambda.
        worker_value: ``V_w(o_w,t)``, shape ``[*B, T, *F]`` (e.g. ``F = (n_agents, 1)``).
        manager_value: ``V_m(o_m,t)``, same shape.
        next_worker_value: ``V_w(o_w,t+1)``, same shape.
        next_manager_value: ``V_m(o_m,t+1)``, same shape.
        reward: ``r_t``, same shape.
        done: episode ended after step ``t``, same shape.
        terminated: episode ended without a future after step ``t``, same shape.
        time_dim: the time dimension.
        fusion: one of :data:`FUSIONS`.
        weight: the manager's weight in ``"weighted"`` fusion.
        manager_consulted: where the manager is consulted at ``t`` (see
            :func:`manager_consulted_mask`); ``None`` means everywhere.
        next_manager_consulted: the same at ``t + 1``.

    Returns:
        A :class:`HierarchicalAdvantage`.

    Examples:
        >>> shape = (1, 3, 1)  # one trajectory, three steps, one feature
        >>> out = hierarchical_gae(
        ...     1.0, 1.0,
        ...     worker_value=torch.zeros(shape), manager_value=torch.ones(shape),
        ...     next_worker_value=torch.zeros(shape), next_manager_value=torch.ones(shape),
        ...     reward=torch.ones(shape), done=torch.zeros(shape, dtype=torch.bool),
        ...     terminated=torch.zeros(shape, dtype=torch.bool), time_dim=1,
        ... )
        >>> out.advantage.flatten()  # delta_t = 1 + 1 - 1 = 1, summed over the future
        tensor([3., 2., 1.])
    """
    fused_value, manager_share = fuse_values(
        worker_value,
        manager_value,
        fusion=fusion,
        weight=weight,
        manager_consulted=manager_consulted,
    )
    next_fused_value, _ = fuse_values(
        next_worker_value,
        next_manager_value,
        fusion=fusion,
        weight=weight,
        manager_consulted=next_manager_consulted,
    )
    advantage, value_target = generalized_advantage(
        gamma,
        lmbda,
        fused_value,
        next_fused_value,
        reward,
        done,
        terminated,
        time_dim=time_dim,
    )
    return HierarchicalAdvantage(
        advantage, value_target, fused_value, next_fused_value, manager_share
    )
