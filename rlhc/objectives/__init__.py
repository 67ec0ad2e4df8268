"""Hierarchical value estimation (RLHC) composed with TorchRL's PPO loss.

:class:`FusedValue` is the two critics and their fusion as one TensorDict module,
:class:`HierarchicalValueEstimator` TorchRL's ``GAE`` on its output, and
:class:`HierarchicalPPOLoss` ``ClipPPOLoss`` with its critic hook trained on both;
:func:`learner_weighted_loss` reduces a loss's per-sample terms under the learner
weight (a league world's opponents weigh 0).

Examples:
    >>> from rlhc.objectives import HierarchicalValueEstimator, make_ppo_loss
"""

from __future__ import annotations

from rlhc.objectives.functional import FUSIONS, fuse_values, manager_consulted_mask
from rlhc.objectives.ppo import LOSS_KEYS, HierarchicalPPOLoss, make_ppo_loss
from rlhc.objectives.trajectories import cut_trajectories
from rlhc.objectives.value import FusedValue, HierarchicalValueEstimator
from rlhc.objectives.weighting import WeightedLoss, learner_weighted_loss

__all__ = [
    "FUSIONS",
    "LOSS_KEYS",
    "FusedValue",
    "HierarchicalPPOLoss",
    "HierarchicalValueEstimator",
    "WeightedLoss",
    "cut_trajectories",
    "fuse_values",
    "learner_weighted_loss",
    "make_ppo_loss",
    "manager_consulted_mask",
]
