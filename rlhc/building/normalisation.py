"""Observation normalisation whose scale cannot turn NaN.

TorchRL's ``VecNormV2`` keeps running first and second moments and takes the variance as
their difference, ``E[x^2] - E[x]^2``. For a feature that stops varying (a racket that
no longer jumps: its height is the ground's at every decision) the two are equal up to
float32 rounding, the difference can come out negative, and its square root is NaN:
every observation of that feature, and every action computed from it, is NaN
(``long_actor_view_exact`` seed 1 at 7.6 M court-decisions, one racket slot's height).
:class:`SafeVecNorm` raises the second moment to at least the squared mean before
TorchRL reads the scale, so the variance is never below 0 and the scale never below
``eps``; elsewhere it normalises exactly as ``VecNormV2`` (same state dict).
"""

from __future__ import annotations

from typing import Any

import torch
from tensordict import TensorDictBase
from torchrl.envs import VecNormV2


def _second_moment_at_least_squared_mean(
    var: TensorDictBase, loc: TensorDictBase
) -> TensorDictBase:
    return var.apply(lambda second, mean: torch.maximum(second, mean.pow(2)), loc)


class SafeVecNorm(VecNormV2):
    """``VecNormV2`` whose variance is clamped at 0 (see the module docstring).

    Examples:
        >>> import torch
        >>> from tensordict import TensorDict
        >>> norm = SafeVecNorm(in_keys=["x"], decay=1.0)
        >>> loc = TensorDict({"x": torch.tensor([0.1167])}, [])
        >>> var = TensorDict({"x": torch.tensor([0.1167**2 - 1e-9])}, [])  # rounding
        >>> norm._norm(TensorDict({"x": torch.tensor([0.1167])}, []), loc, var, 1)["x"]
        tensor([0.])
    """

    def _norm(self, data: Any, loc: Any, var: Any, count: Any) -> Any:
        return super()._norm(data, loc, _second_moment_at_least_squared_mean(var, loc), count)

    def _get_loc_scale(self, loc_only: bool = False) -> tuple:
        if self._loc is not None and self._var is not None:
            # In place: the running second moment is never truly below the squared mean.
            self._var.update_(_second_moment_at_least_squared_mean(self._var, self._loc))
        return super()._get_loc_scale(loc_only)
