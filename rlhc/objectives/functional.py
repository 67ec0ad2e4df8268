"""Pure tensor maths of RLHC: fusing two critics per agent and per step.

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

Every function is element-wise on tensors of any shape; GAE on the fused value is
TorchRL's own, run by :class:`~rlhc.objectives.value.HierarchicalValueEstimator`.
"""

from __future__ import annotations

import torch
from torch import Tensor

#: The fusion modes, in the order of the table above.
FUSIONS: tuple[str, ...] = ("local", "manager", "max", "mean", "weighted")


def check_fusion(fusion: str, weight: float) -> None:
    """Raise ``ValueError`` unless ``fusion`` is one of :data:`FUSIONS` and ``weight``
    lies in ``[0, 1]`` (checked for every mode: a bad config fails whatever the mode)."""
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
        manager_consulted: boolean mask broadcastable to the values; where false,
            ``V_hat = V_w`` (temporal scaling).

    Returns:
        ``(fused_value, manager_share)``: ``V_hat`` and the share of it that came from
        the manager critic (the module table; 0 where the manager was not consulted).

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
    """Where the manager is consulted, ``step_count % k == 0`` (the paper's temporal
    scaling), for integer ``step_count`` (steps taken in the episode) and ``k >= 1``.

    Examples:
        >>> manager_consulted_mask(torch.arange(6), 5)
        tensor([ True, False, False, False, False,  True])
    """
    check_manager_interval(manager_interval)
    return step_count % manager_interval == 0


def check_manager_interval(manager_interval: int) -> None:
    """Raise ``ValueError`` unless ``manager_interval`` is an integer ``>= 1``."""
    integer = isinstance(manager_interval, int) and not isinstance(manager_interval, bool)
    if not integer or manager_interval < 1:
        raise ValueError(f"manager_interval must be an integer >= 1, got {manager_interval!r}")
