"""A functional reference of GAE on the fused value, for the estimator's tests.

:func:`generalized_advantage` wraps TorchRL's vectorised kernel with the agents moved
before time, :func:`hierarchical_gae` fuses the two critics first
(:func:`rlhc.objectives.fuse_values`). Both are checked against the plain loop of
``rlhc_synthetic.loop_gae`` and closed forms (``test_fusion_functional.py``), and
:class:`~rlhc.objectives.HierarchicalValueEstimator` must give what they give
(``test_value_estimator.py``). Imported as ``reference_gae`` (a unique name: the test
folders are not packages).
"""

from __future__ import annotations

from typing import NamedTuple

from torch import Tensor
from torchrl.objectives.value.functional import vec_generalized_advantage_estimate

from rlhc.objectives import fuse_values


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
        fusion: one of :data:`rlhc.objectives.FUSIONS`.
        weight: the manager's weight in ``"weighted"`` fusion.
        manager_consulted: where the manager is consulted at ``t`` (see
            :func:`rlhc.objectives.manager_consulted_mask`); ``None`` means everywhere.
        next_manager_consulted: the same at ``t + 1``.

    Returns:
        A :class:`HierarchicalAdvantage`.
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
