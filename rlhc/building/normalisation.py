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
The training configuration's path (running statistics shared by the worlds, decaying
or cumulative) is therefore computed key by key on plain tensors, in ``VecNormV2``'s
order of operations, so its results are equal to the bit; every other configuration is
left to ``VecNormV2``.

``clip`` bounds the normalised observations to ``[-clip, clip]``, as ML-Agents 0.5 does
(at 5); ``VecNormV2`` has no such bound.
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
    """``VecNormV2`` whose variance is clamped at 0, its output optionally bounded.

    Args:
        *args: ``VecNormV2``'s.
        clip: ``None``, or the bound of the normalised values (see the module docstring).
        **kwargs: ``VecNormV2``'s.

    Examples:
        >>> import torch
        >>> from tensordict import TensorDict
        >>> norm = SafeVecNorm(in_keys=["x"], decay=1.0)
        >>> loc = TensorDict({"x": torch.tensor([0.1167])}, [])
        >>> var = TensorDict({"x": torch.tensor([0.1167**2 - 1e-9])}, [])  # rounding
        >>> norm._norm(TensorDict({"x": torch.tensor([0.1167])}, []), loc, var, 1)["x"]
        tensor([0.])
    """

    def __init__(self, *args: Any, clip: float | None = None, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        if clip is not None and not clip > 0:
            raise ValueError(f"clip={clip}; allowed: None or a number > 0")
        self.clip = clip

    def _per_key(self, data: TensorDictBase) -> bool:
        """Whether ``data`` takes the plain-tensor path (the training configuration's)."""
        return (
            self.stateful
            and self.reduce_batch_dims
            and data.ndim > 0
            and not self._cast_int_to_float
            and self.out_keys[: len(self.in_keys)] == self.in_keys
        )

    def _stateful_update(self, data: Any) -> None:
        if self.frozen or not self._per_key(data):
            return super()._stateful_update(data)
        # VecNormV2's reduced-batch update: one moving-average step per call, weighted
        # as n single observations would be (1 - decay ** n; cumulative: n / count).
        n = data.numel()
        cumulative = self.decay == 1.0
        weight = 1 - self.decay**n
        batch_dims = tuple(range(data.ndim))
        loc, var, count = self._loc, self._var, self._count
        keys = list(data.keys(True, True))
        if not self.missing_tolerance:
            keys = list(loc.keys(True, True))
        for key in keys:
            value = data.get(key)
            seen = count.get(key).add_(n)
            step = n / seen if cumulative else weight
            mean = loc.get(key)
            second = var.get(key)
            mean.lerp_(value.mean(dim=batch_dims).to(mean.device), step)
            second.lerp_(value.pow(2).mean(dim=batch_dims).to(second.device), step)
        return None

    def _norm(self, data: Any, loc: Any, var: Any, count: Any) -> Any:
        if not (isinstance(data, TensorDictBase) and self._per_key(data)):
            safe = _second_moment_at_least_squared_mean(var, loc)
            normalised = super()._norm(data, loc, safe, count)
            if self.clip is None:
                return normalised
            return normalised.apply(lambda value: value.clamp(-self.clip, self.clip))
        log_decay = math.log(self.decay) if self.decay < 1.0 else None

        def normalise(key: NestedKey, value: torch.Tensor) -> torch.Tensor:
            mean, second = loc.get(key), var.get(key)
            variance = torch.maximum(second, mean.pow(2)) - mean.pow(2)
            if log_decay is None:  # cumulative averages need no bias correction
                normalised = (value - mean) / variance.sqrt().clamp_min(self.eps)
            else:
                bias_correction = (1 - (count.get(key) * log_decay).exp()).to(value.dtype)
                scale = (variance / bias_correction).sqrt().clamp_min(self.eps)
                normalised = (value - mean / bias_correction) / scale
            return normalised if self.clip is None else normalised.clamp(-self.clip, self.clip)

        return data.named_apply(normalise, nested_keys=True)

    def _get_loc_scale(self, loc_only: bool = False) -> tuple:
        if self._loc is not None and self._var is not None:
            # In place: the running second moment is never truly below the squared mean.
            self._var.update_(_second_moment_at_least_squared_mean(self._var, self._loc))
        return super()._get_loc_scale(loc_only)
