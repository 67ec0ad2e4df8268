"""One run on several processes: ``torchrun --nproc_per_node=N -m rlhc.run …``.

:func:`setup` joins the processes ``torchrun`` started (gloo on CPU, NCCL on CUDA); plain
``python -m rlhc.run`` is one process and never touches this module. Both modes keep the
update of one process ([Performance](../guide/performance.md#several-processes)):

- ``parallel=data``: every rank steps ``num_envs / N`` worlds and computes ``1/N`` of every
  minibatch; gradients and the advantage and weight statistics are summed over the
  ranks, so each holds exactly the single-process update.
- ``parallel=pipeline`` (``N = 2``): rank 1 collects batch ``k + 1`` while rank 0 trains on
  batch ``k``, so the behaviour policy is one update behind. PPO's ratio stays the right
  importance weight: it divides by the log-probabilities stored with each action.
"""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import torch
import torch.distributed as dist
from tensordict import TensorDictBase

from rlhc.config.validation import backend, check_parallel

#: Rank 0 of a pipeline updates; rank 1 collects.
LEARNER_RANK = 0
COLLECTOR_RANK = 1


@dataclass(frozen=True)
class Processes:
    """Which process this is, among how many, sharing the run how.

    Attributes:
        rank: this process's rank (0 logs and checkpoints).
        size: processes in the run.
        mode: ``data`` or ``pipeline``.

    Examples:
        >>> Processes().collects, Processes().learns, Processes().shards
        (True, True, 1)
        >>> learner = Processes(rank=0, size=2, mode="pipeline")
        >>> learner.collects, learner.learns, learner.shards
        (False, True, 1)
    """

    rank: int = 0
    size: int = 1
    mode: str = "data"

    @property
    def main(self) -> bool:
        """Whether this process logs, evaluates and writes checkpoints."""
        return self.rank == 0

    @property
    def active(self) -> bool:
        """Whether there is more than one process."""
        return self.size > 1

    @property
    def data_parallel(self) -> bool:
        return self.active and self.mode == "data"

    @property
    def pipeline(self) -> bool:
        return self.active and self.mode == "pipeline"

    @property
    def collects(self) -> bool:
        """Whether this process steps worlds."""
        return not self.pipeline or self.rank != LEARNER_RANK

    @property
    def learns(self) -> bool:
        """Whether this process runs the PPO update."""
        return not self.pipeline or self.rank == LEARNER_RANK

    @property
    def shards(self) -> int:
        """Into how many shares the worlds and every minibatch are split."""
        return self.size if self.data_parallel else 1


def launched_size() -> int:
    """``WORLD_SIZE`` as ``torchrun`` sets it (1 when started without it)."""
    return int(os.environ.get("WORLD_SIZE", "1"))


def launched_rank() -> int:
    """``RANK`` as ``torchrun`` sets it (0 when started without it)."""
    return int(os.environ.get("RANK", "0"))


def setup(mode: str, device: str, league_active: bool) -> Processes:
    """Join the processes ``torchrun`` started (a no-op for one process).

    Raises:
        ConfigError: see :func:`rlhc.config.validation.check_parallel`.
    """
    size = launched_size()
    check_parallel(mode, size, device, league_active)
    if size <= 1:
        return Processes(mode=mode)
    if not dist.is_initialized():
        dist.init_process_group(backend(device))
    return Processes(rank=dist.get_rank(), size=dist.get_world_size(), mode=mode)


def shutdown() -> None:
    """Leave the process group (when one was joined)."""
    if dist.is_available() and dist.is_initialized():
        dist.destroy_process_group()


# --- data-parallel collectives --------------------------------------------------------
def all_reduce_sum(tensor: torch.Tensor) -> torch.Tensor:
    """``tensor`` summed over the processes, in place (returned for chaining)."""
    dist.all_reduce(tensor, op=dist.ReduceOp.SUM)
    return tensor


def all_reduce_gradients(parameters: Sequence[torch.nn.Parameter]) -> None:
    """Sum every parameter's gradient over the processes in one all-reduce (a parameter
    without a gradient contributes zeros)."""
    grads = [p.grad if p.grad is not None else torch.zeros_like(p) for p in parameters]
    flat = _flat(grads)
    dist.all_reduce(flat, op=dist.ReduceOp.SUM)
    for parameter, chunk in zip(parameters, flat.split([g.numel() for g in grads]), strict=True):
        parameter.grad = chunk.view_as(parameter)


def broadcast_parameters(parameters: Sequence[torch.Tensor], src: int = 0) -> None:
    """Overwrite every process's ``parameters`` with those of rank ``src``."""
    flat = _flat(parameters)
    dist.broadcast(flat, src=src)
    _load_flat(parameters, flat)


def _flat(tensors: Sequence[torch.Tensor]) -> torch.Tensor:
    """``tensors`` in one flat buffer: one collective rather than one per tensor."""
    return torch.cat([t.detach().reshape(-1) for t in tensors])


@torch.no_grad()
def _load_flat(parameters: Sequence[torch.Tensor], flat: torch.Tensor) -> None:
    """Copy a :func:`_flat` buffer back into ``parameters``."""
    for parameter, chunk in zip(
        parameters, flat.split([p.numel() for p in parameters]), strict=True
    ):
        parameter.copy_(chunk.view_as(parameter))


def average_floating_state(state: Mapping[str, Any]) -> dict[str, Any]:
    """A copy of a nested state dict with every floating tensor averaged over processes
    (integer entries, counts and flags, are equal everywhere)."""
    merged: dict[str, Any] = {}
    for key, value in state.items():
        if isinstance(value, Mapping):
            merged[key] = average_floating_state(value)
        elif isinstance(value, torch.Tensor) and value.is_floating_point():
            merged[key] = all_reduce_sum(value.clone()) / dist.get_world_size()
        else:
            merged[key] = value
    return merged


def gather(value: Any) -> list[Any]:
    """``value`` of every process, in rank order (any picklable object)."""
    values: list[Any] = [None] * dist.get_world_size()
    dist.all_gather_object(values, value)
    return values


def any_process(flag: bool) -> bool:
    """Whether ``flag`` is set on any process (e.g. a stop signal received by one)."""
    tensor = torch.tensor([float(flag)])
    dist.all_reduce(tensor, op=dist.ReduceOp.MAX)
    return bool(tensor.item())


def broadcast_object(value: Any, src: int = 0) -> Any:
    """Rank ``src``'s ``value`` on every process."""
    box = [value]
    dist.broadcast_object_list(box, src=src)
    return box[0]


# --- the pipeline ---------------------------------------------------------------------
def send_batch(batch: TensorDictBase, extra: Mapping[str, Any], dst: int = LEARNER_RANK) -> None:
    """Send a collected batch and what the learner keeps with it (normaliser, RNG)."""
    dist.send_object_list([batch, dict(extra)], dst=dst)


def receive_batch(src: int = COLLECTOR_RANK) -> tuple[TensorDictBase, dict[str, Any]]:
    """The next batch of :func:`send_batch` and its extras."""
    box: list[Any] = [None, None]
    dist.recv_object_list(box, src=src)
    return box[0], box[1]


class WeightChannel:
    """The actors' weights and whether to go on, one flat tensor sent from the learner to the
    collector after each update; the send does not wait (the collector is busy sending the
    next batch, which the learner receives right after)."""

    def __init__(self, parameters: Sequence[torch.Tensor]) -> None:
        self.parameters = list(parameters)
        self._pending: Any = None

    def send(self, go_on: bool, dst: int = COLLECTOR_RANK) -> None:
        """Learner: post the current weights and whether to continue."""
        self.wait()
        self._buffer = torch.cat([_flat(self.parameters), torch.tensor([float(go_on)])])
        self._pending = dist.isend(self._buffer, dst=dst)

    def wait(self) -> None:
        """Learner: wait until the last weights left (before reusing their buffer)."""
        if self._pending is not None:
            self._pending.wait()
            self._pending = None

    def receive(self, src: int = LEARNER_RANK) -> bool:
        """Collector: load the learner's weights into ``parameters``; whether to go on."""
        buffer = torch.empty(sum(p.numel() for p in self.parameters) + 1)
        dist.recv(buffer, src=src)
        _load_flat(self.parameters, buffer[:-1])
        return bool(buffer[-1].item())
