"""Hierarchical value estimation (RLHC) composed with TorchRL's PPO loss.

Examples:
    >>> from rlhc.objectives import HierarchicalValueEstimator, make_ppo_loss
"""

from __future__ import annotations

from rlhc.objectives.functional import (
    FUSIONS,
    HierarchicalAdvantage,
    fuse_values,
    generalized_advantage,
    hierarchical_gae,
    manager_consulted_mask,
)
from rlhc.objectives.ppo import LOSS_KEYS, HierarchicalPPOLoss, make_ppo_loss
from rlhc.objectives.value import HierarchicalValueEstimator

__all__ = [
    "FUSIONS",
    "LOSS_KEYS",
    "HierarchicalAdvantage",
    "HierarchicalPPOLoss",
    "HierarchicalValueEstimator",
    "fuse_values",
    "generalized_advantage",
    "hierarchical_gae",
    "make_ppo_loss",
    "manager_consulted_mask",
]
