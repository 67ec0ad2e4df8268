"""Running observation normalisation whose scale cannot turn NaN, with an optional bound.

:class:`SafeVecNorm` is a TorchRL :class:`~torchrl.envs.Transform` that keeps, per
observation key, running first and second moments shared by the worlds of a batched
environment (one moving-average step per call, weighted as ``n`` single observations
would be) and normalises with them, as TorchRL's ``VecNormV2(reduce_batch_dims=True)``
does, with the same state dict. Two things differ:

* The variance is taken as ``max(E[x^2], E[x]^2) - E[x]^2``: for a feature that stops
  varying (a racket that no longer jumps) the two moments are equal up to float32
  rounding and ``VecNormV2``'s difference can come out negative, its square root NaN,
  and with it every action computed from that observation. Here the scale is then
  ``eps`` and the feature normalises to 0.
* ``clip`` bounds the normalised values to ``[-clip, clip]``, as ML-Agents 0.5 does (at 5).

The arithmetic runs key by key on plain tensors: the environment calls the transform
after every step and every partial reset, where TensorDict-wide operations would cost
more than the arithmetic.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import torch
from tensordict import NestedKey, TensorDict, TensorDictBase
from torchrl.data import Bounded, Composite, Unbounded
from torchrl.envs import Transform

#: Separator of the flattened keys of the state (``"loc" SEP "group" SEP "observation"``),
#: VecNormV2's: normalisers saved by either load into the other.
SEP = ".-|-."


class SafeVecNorm(Transform):
    """Running mean/std normalisation of ``in_keys``, in place, NaN-free, optionally bounded.

    Args:
        in_keys: the observation keys to normalise (written back to the same keys).
        decay: the weight kept by the running moments per observation; ``1.0`` keeps
            cumulative averages.
        eps: the smallest scale.
        clip: ``None``, or the bound of the normalised values.

    Raises:
        ValueError: ``decay`` outside ``(0, 1]`` or ``clip`` not ``None`` or ``> 0``.

    Examples:
        >>> from tensordict import TensorDict
        >>> norm = SafeVecNorm(in_keys=["x"], decay=1.0)
        >>> constant = TensorDict({"x": torch.full((4, 1), 0.1167)}, [4])
        >>> norm.normalise(norm.update(constant))["x"].flatten()  # VecNormV2: NaN
        tensor([0., 0., 0., 0.])
    """

    def __init__(
        self,
        in_keys: Sequence[NestedKey],
        *,
        decay: float = 0.9999,
        eps: float = 1e-4,
        clip: float | None = None,
    ) -> None:
        if not 0 < decay <= 1:
            raise ValueError(f"decay={decay}; allowed: a number in (0, 1]")
        if clip is not None and not clip > 0:
            raise ValueError(f"clip={clip}; allowed: None or a number > 0")
        super().__init__(in_keys=list(in_keys), out_keys=list(in_keys))
        self.decay = decay
        self.eps = eps
        self.clip = clip
        self.frozen = False
        self.register_buffer("initialized", torch.zeros((), dtype=torch.bool))
        #: ``loc`` (``E[x]``), ``var`` (``E[x^2]``) and ``count`` per key, once data came.
        self.moments: TensorDict | None = None
        #: ``(moments, key -> its tensors)``: see :meth:`_key_moments`.
        self._lookup: tuple[TensorDict, dict[NestedKey, tuple[torch.Tensor, ...]]] | None = None

    # --- TorchRL's transform hooks --------------------------------------------------
    def _step(self, tensordict: TensorDictBase, next_tensordict: TensorDictBase) -> TensorDictBase:
        return self.normalise(self.update(next_tensordict))

    def _reset(
        self, tensordict: TensorDictBase, tensordict_reset: TensorDictBase
    ) -> TensorDictBase:
        return self.normalise(self.update(tensordict_reset))

    def transform_observation_spec(self, observation_spec: Composite) -> Composite:
        for key in self.in_keys:
            spec = observation_spec.get(key, None)
            if isinstance(spec, Bounded):  # normalised values are not in the raw bounds
                observation_spec.set(
                    key, Unbounded(spec.shape, device=spec.device, dtype=spec.dtype)
                )
        return observation_spec

    # --- statistics ------------------------------------------------------------------
    def freeze(self) -> SafeVecNorm:
        """Stop updating the statistics (normalisation goes on)."""
        self.frozen = True
        return self

    def unfreeze(self) -> SafeVecNorm:
        """Update the statistics again."""
        self.frozen = False
        return self

    def update(self, data: TensorDictBase) -> TensorDictBase:
        """One moving-average step of the moments of every ``in_keys`` entry ``data``
        holds, over its batch dimensions (a partial reset may hold only some keys).

        Returns:
            ``data``.
        """
        batch = tuple(range(data.batch_dims))
        present = self._present(data)
        for key, value in present:
            if key not in self._key_moments():
                self._initialise(key, value, batch)
        if self.frozen or self.moments is None:
            return data
        n = data.numel()
        weight = 1 - self.decay**n
        moments = self._key_moments()
        for key, value in present:
            mean, second, seen = moments[key]
            seen.add_(n)
            step = n / seen if self.decay == 1.0 else weight
            batch_mean = value.mean(dim=batch) if batch else value
            batch_second = value.pow(2).mean(dim=batch) if batch else value.pow(2)
            mean.lerp_(batch_mean.to(mean.device), step)
            second.lerp_(batch_second.to(second.device), step)
        return data

    def normalise(self, data: TensorDictBase) -> TensorDictBase:
        """``data`` with every ``in_keys`` entry it holds normalised (and clipped), in place."""
        present = self._present(data)
        if self.moments is None or not present:
            return data
        moments = self._key_moments()
        for key, value in present:
            loc, scale = self._loc_scale(*moments[key])
            normalised = (value - loc.to(value.device)) / scale.to(value.device)
            if self.clip is not None:
                normalised = normalised.clamp(-self.clip, self.clip)
            data.set(key, normalised)
        return data

    @property
    def loc(self) -> TensorDictBase:
        """The mean of each key (bias-corrected under a decay)."""
        return self._affine()[0]

    @property
    def scale(self) -> TensorDictBase:
        """The standard deviation of each key, at least ``eps`` (bias-corrected)."""
        return self._affine()[1]

    def _affine(self) -> tuple[TensorDictBase, TensorDictBase]:
        if self.moments is None:
            raise RuntimeError("SafeVecNorm has seen no data yet: no statistics to read")
        loc, scale = TensorDict(), TensorDict()
        for key, moments in self._key_moments().items():
            key_loc, key_scale = self._loc_scale(*moments)
            loc.set(key, key_loc)
            scale.set(key, key_scale)
        return loc, scale

    def _loc_scale(
        self, mean: torch.Tensor, second: torch.Tensor, count: torch.Tensor
    ) -> tuple[torch.Tensor, torch.Tensor]:
        """The mean and the scale (at least ``eps``) of one key, bias-corrected under a decay."""
        variance = torch.maximum(second, mean.pow(2)) - mean.pow(2)
        if self.decay == 1.0:  # cumulative averages need no bias correction
            return mean, variance.sqrt().clamp_min(self.eps)
        correction = (1 - (count * math.log(self.decay)).exp()).to(mean.dtype)
        return mean / correction, (variance / correction).sqrt().clamp_min(self.eps)

    def _key_moments(self) -> dict[NestedKey, tuple[torch.Tensor, torch.Tensor, torch.Tensor]]:
        """``key -> (E[x], E[x^2], count)``: the tensors of :attr:`moments` themselves
        (updated in place), looked up once per :attr:`moments` object."""
        if self.moments is None:
            return {}
        if self._lookup is None or self._lookup[0] is not self.moments:
            moments = self.moments
            table = {
                key: tuple(moments.get((name, *_tuple(key))) for name in ("loc", "var", "count"))
                for key in moments["loc"].keys(True, True)
            }
            self._lookup = (moments, table)
        return self._lookup[1]  # type: ignore[return-value]

    def _present(self, data: TensorDictBase) -> list[tuple[NestedKey, torch.Tensor]]:
        """The ``(key, value)`` of the ``in_keys`` that ``data`` holds."""
        present = []
        for key in self.in_keys:
            value = data.get(key, None)
            if value is not None:
                present.append((key, value))
        return present

    def _initialise(self, key: NestedKey, value: torch.Tensor, batch: tuple[int, ...]) -> None:
        """Zero moments for ``key``, shaped as one observation of ``value``."""
        if self.moments is None:
            self.moments = TensorDict()
        shape, device = value.shape[len(batch) :], value.device
        dtype = value.dtype if value.dtype.is_floating_point else torch.get_default_dtype()
        for name in ("loc", "var"):
            self.moments.set((name, *_tuple(key)), torch.zeros(shape, dtype=dtype, device=device))
        self.moments.set(("count", *_tuple(key)), torch.zeros((), dtype=torch.int64, device=device))
        self._lookup = None
        self.initialized.fill_(True)

    # --- state dict (VecNormV2's layout) -----------------------------------------------
    def get_extra_state(self) -> dict[str, torch.Tensor]:
        if self.moments is None:
            return {}
        return self.moments.flatten_keys(SEP).to_dict()

    def set_extra_state(self, state: dict[str, Any]) -> None:
        if state:
            self.moments = TensorDict(state).unflatten_keys(SEP)

    def extra_repr(self) -> str:
        return f"keys={self.in_keys}, decay={self.decay}, eps={self.eps}, clip={self.clip}"


def _tuple(key: NestedKey) -> tuple[str, ...]:
    return (key,) if isinstance(key, str) else tuple(key)
