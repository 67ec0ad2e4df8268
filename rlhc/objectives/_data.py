"""Reading collected data with errors that name what is missing or misshapen."""

from __future__ import annotations

from tensordict import TensorDictBase
from tensordict.utils import NestedKey
from torch import Tensor


def as_tuple(key: NestedKey) -> tuple[str, ...]:
    """``"a"`` -> ``("a",)``; ``("a", "b")`` -> ``("a", "b")``."""
    return (key,) if isinstance(key, str) else tuple(key)


def require(
    data: TensorDictBase, key: NestedKey, meaning: str, *, under: tuple[str, ...] = ()
) -> Tensor:
    """``data[key]``, or a ``KeyError`` naming the key, what it is and what is present.

    Args:
        data: the (sub-)TensorDict to read.
        key: the key to read.
        meaning: what the entry is, for the message.
        under: where ``data`` sits in the caller's TensorDict (e.g. ``("next",)``),
            so that the message names the full key.

    Returns:
        The entry.
    """
    value = data.get(key, None)
    if value is None:
        full_key = (*under, *as_tuple(key)) if under else key
        present = sorted(map(str, data.keys(include_nested=True, leaves_only=True)))
        raise KeyError(f"missing key {full_key!r} ({meaning}); present: {present}")
    return value


def broadcast_to_value(signal: Tensor, value: Tensor, batch_dims: int, name: str) -> Tensor:
    """Expand a per-step signal to the per-agent value shape ``[*B, T, n_g, 1]``.

    Signals shared by the agents (``[*B, T, 1]``, e.g. the root ``step_count`` or a
    team reward) gain the agent dims right after the batch dims; per-agent ones pass.

    Raises:
        ValueError: the signal does not broadcast (the message names it).
    """
    while signal.ndim < value.ndim:
        signal = signal.unsqueeze(batch_dims)
    try:
        return signal.expand(value.shape)
    except RuntimeError:
        raise ValueError(
            f"{name} of shape {tuple(signal.shape)} does not broadcast to the values' "
            f"shape {tuple(value.shape)}"
        ) from None


def resolve_time_dim(data: TensorDictBase, time_dim: int | None, default: int | None) -> int:
    """The non-negative time dimension of ``data``, as TorchRL's value estimators choose it.

    Args:
        data: the batch, of batch size ``[*B, T]``.
        time_dim: the caller's choice, if any (negative counts from the end).
        default: the estimator's own choice, used when ``time_dim`` is ``None``.

    Returns:
        ``time_dim``, else ``default``, else the batch dimension named ``"time"``, else
        the last batch dimension; made non-negative.

    Examples:
        >>> import torch
        >>> from tensordict import TensorDict
        >>> data = TensorDict({}, [2, 5])
        >>> resolve_time_dim(data, None, None), resolve_time_dim(data, -2, None)
        (1, 0)
        >>> resolve_time_dim(data.refine_names("time", None), None, None)
        0
    """
    chosen = time_dim if time_dim is not None else default
    if chosen is None:
        names = list(data.names)
        chosen = names.index("time") if "time" in names else data.batch_dims - 1
    return chosen % data.batch_dims if chosen < 0 else chosen
