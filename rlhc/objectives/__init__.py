"""Hierarchical value estimation (RLHC) composed with TorchRL's PPO loss.

Built on TorchRL's public API only (``tests/test_public_api.py`` checks it):
:class:`FusedValue` is the two critics and their fusion as one TensorDict module,
:class:`HierarchicalValueEstimator` is TorchRL's ``GAE`` on its output, and
:class:`HierarchicalPPOLoss` is ``ClipPPOLoss`` with its critic hook trained on both.

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
from rlhc.objectives.value import FusedValue, HierarchicalValueEstimator, fuse_at_steps

__all__ = [
    "FUSIONS",
    "LOSS_KEYS",
    "FusedValue",
    "HierarchicalAdvantage",
    "HierarchicalPPOLoss",
    "HierarchicalValueEstimator",
    "fuse_at_steps",
    "fuse_values",
    "generalized_advantage",
    "hierarchical_gae",
    "make_ppo_loss",
    "manager_consulted_mask",
]
