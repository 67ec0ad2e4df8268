"""Observation normalisation whose scale cannot turn NaN, at the cost of a few tensor ops.

TorchRL's ``VecNormV2`` keeps running first and second moments and takes the variance as
their difference, ``E[x^2] - E[x]^2``. For a feature that stops varying (a racket that
no longer jumps: its height is the ground's at every decision) the two are equal up to
float32 rounding, the difference can come out negative, and its square root is NaN:
every observation of that feature, and every action computed from it, is NaN
(``long_actor_view_exact`` seed 1 at 7.6 M court-decisions, one racket slot's height).
:class:`SafeVecNorm` raises the second moment to at least the squared mean before
the scale is read, so the variance is never below 0 and the scale never below ``eps``;
elsewhere it normalises exactly as ``VecNormV2`` (same state dict, same numbers).

``VecNormV2`` does its arithmetic on whole TensorDicts (a dozen TensorDict operations
per call, each building a new container); the environment calls it after every step
and every partial reset, and in tennis, where points end every few decisions, that was
a fifth of a training loop's time (benchmarks/README "Observation normalisation").
The training configuration's path (running statistics shared by the worlds, decaying)
is therefore computed key by key on plain tensors, in ``VecNormV2``'s order of
operations, so its results are equal to the bit; every other configuration is left to
``VecNormV2``.
"""

from __future__ import annotations

import math
from typing import Any

import torch
from tensordict import NestedKey, TensorDictBase
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

    def _per_key(self, data: TensorDictBase) -> bool:
        """Whether ``data`` takes the plain-tensor path (the training configuration's)."""
        return (
            self.stateful
            and self.reduce_batch_dims
            and data.ndim > 0
            and self.decay < 1.0
            and not self._cast_int_to_float
            and self.out_keys[: len(self.in_keys)] == self.in_keys
        )

    def _stateful_update(self, data: Any) -> None:
        if self.frozen or not self._per_key(data):
            return super()._stateful_update(data)
        # VecNormV2's reduced-batch update: one moving-average step per call, weighted
        # as n single observations would be (1 - decay ** n).
        n = data.numel()
        weight = 1 - self.decay**n
        batch_dims = tuple(range(data.ndim))
        loc, var, count = self._loc, self._var, self._count
        keys = list(data.keys(True, True))
        if not self.missing_tolerance:
            keys = list(loc.keys(True, True))
        for key in keys:
            value = data.get(key)
            count.get(key).add_(n)
            mean = loc.get(key)
            second = var.get(key)
            mean.lerp_(value.mean(dim=batch_dims).to(mean.device), weight)
            second.lerp_(value.pow(2).mean(dim=batch_dims).to(second.device), weight)
        return None

    def _norm(self, data: Any, loc: Any, var: Any, count: Any) -> Any:
        if not (isinstance(data, TensorDictBase) and self._per_key(data)):
            return super()._norm(data, loc, _second_moment_at_least_squared_mean(var, loc), count)
        log_decay = math.log(self.decay)

        def normalise(key: NestedKey, value: torch.Tensor) -> torch.Tensor:
            mean, second = loc.get(key), var.get(key)
            bias_correction = (1 - (count.get(key) * log_decay).exp()).to(value.dtype)
            variance = torch.maximum(second, mean.pow(2)) - mean.pow(2)
            scale = (variance / bias_correction).sqrt().clamp_min(self.eps)
            return (value - mean / bias_correction) / scale

        return data.named_apply(normalise, nested_keys=True)

    def _get_loc_scale(self, loc_only: bool = False) -> tuple:
        if self._loc is not None and self._var is not None:
            # In place: the running second moment is never truly below the squared mean.
            self._var.update_(_second_moment_at_least_squared_mean(self._var, self._loc))
        return super()._get_loc_scale(loc_only)
