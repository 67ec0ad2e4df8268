"""How the processes of a run share it: one strategy, chosen once (:func:`make_strategy`).

The loop of :class:`~rlhc.training.trainer.Trainer` is the same on every process; where its
batches come from and what is combined across processes (:mod:`rlhc.training.distributed`)
is a strategy's, behind the hooks the loop calls. A pipeline's collecting process runs
:meth:`Pipeline.serve` instead of the loop.
"""

from __future__ import annotations

import math
import time
from collections.abc import Generator, Mapping, Sequence
from typing import Any

import numpy as np
import torch
from tensordict import TensorDictBase
from tensordict.nn import TensorDictModuleBase
from torchrl.collectors import Collector
from torchrl.envs import TransformedEnv

from rlhc.building.builders import Layout
from rlhc.storage.checkpoint import seed_everything
from rlhc.training import distributed
from rlhc.training.distributed import Processes, WeightChannel
from rlhc.training.interrupt import StopSignals
from rlhc.training.training_state import game_rng_state


class SingleProcess:
    """One process collects and updates; the base of the other strategies.

    Examples:
        >>> strategy = SingleProcess()
        >>> strategy.learns, strategy.shards, strategy.gather(3)
        (True, 1, [3])
    """

    def __init__(self, processes: Processes | None = None) -> None:
        self.processes = processes if processes is not None else Processes()

    # --- roles and shares -------------------------------------------------------------
    @property
    def learns(self) -> bool:
        """Whether this process runs the training loop (else :meth:`serve`)."""
        return self.processes.learns

    @property
    def main(self) -> bool:
        """Whether this process logs, evaluates and writes checkpoints."""
        return self.processes.main

    @property
    def shards(self) -> int:
        """Into how many shares the worlds and every minibatch are split."""
        return self.processes.shards

    def local_worlds(self, layout: Layout) -> int:
        """The worlds this process steps."""
        return layout.num_envs // self.shards

    def process_seed(self, seed: int) -> int:
        """``seed`` on rank 0 (one process is unchanged), a seed derived from it elsewhere."""
        if self.processes.rank == 0:
            return seed
        return int(np.random.SeedSequence([seed, self.processes.rank]).generate_state(1)[0])

    @property
    def restores_game_rng(self) -> bool:
        """Whether a resume gives this process's game the stored generator (rank 0's)."""
        return self.main

    # --- start ------------------------------------------------------------------------
    def share(self, value: Any) -> Any:
        """Rank 0's ``value`` on every process (e.g. the checkpoint to resume)."""
        return distributed.broadcast_object(value) if self.processes.active else value

    def synchronise(self, parameters: Sequence[torch.Tensor], seed: int) -> None:
        """Before training: every process takes rank 0's ``parameters``, then seeds its
        own global generators with ``seed`` (its actions and minibatches are its own)."""
        if self.processes.active:
            distributed.broadcast_parameters(parameters)
            seed_everything(seed)

    # --- the loop -----------------------------------------------------------------------
    def batches(
        self,
        env: TransformedEnv,
        policy: TensorDictModuleBase,
        layout: Layout,
        frames: int,
        device: torch.device,
    ) -> Generator[TensorDictBase, None, None]:
        """This process's ``[worlds, decisions]`` share of each update's batch, on
        ``device`` (the policy's), until ``frames`` more world-decisions of every process."""
        local = layout.frames_per_batch // self.shards
        collector = Collector(
            env,
            policy,
            env_device=env.device,
            policy_device=device,
            storing_device=device,
            frames_per_batch=local,
            total_frames=math.ceil(frames / layout.frames_per_batch) * local,
            # The policy is stateless (no recurrent state to initialise), and nothing
            # reads trajectory ids (the estimator reads the done flags).
            auto_register_policy_transforms=False,
            track_traj_ids=False,
        )
        try:
            yield from collector
        finally:
            collector.shutdown()

    def after_collection(self, env: TransformedEnv) -> None:
        """After each collection, before the update: combine what the processes saw."""

    def reduce_sum(self, tensor: torch.Tensor) -> torch.Tensor:
        """``tensor`` summed over the processes sharing a minibatch (in place; returned)."""
        return tensor

    def reduce_gradients(self, parameters: Sequence[torch.nn.Parameter]) -> None:
        """After a minibatch's backward pass: sum the gradients over the processes."""

    def gather(self, value: Any) -> list[Any]:
        """``value`` of every process, in rank order."""
        return [value]

    def env_steps_per_s(self, frames: int, seconds: float) -> float:
        """The collection's speed, from this process's ``frames`` in ``seconds``."""
        return frames / seconds

    def stop_requested(self, received: bool) -> bool:
        """Whether to stop, given whether this process received a stop signal."""
        return received

    def after_update(self, actor_parameters: Sequence[torch.Tensor], go_on: bool) -> None:
        """After each update (and its summary and checkpoint); ``go_on``: not the last."""

    def game_rng_state(self, env: TransformedEnv) -> Mapping[str, Any] | None:
        """The generator state of the game that collects (what a checkpoint stores)."""
        return game_rng_state(env)

    def serve(
        self,
        env: TransformedEnv,
        policy: TensorDictModuleBase,
        layout: Layout,
        actor_parameters: Sequence[torch.Tensor],
    ) -> None:
        """What a process that does not learn runs instead of the loop."""
        raise RuntimeError(f"{type(self).__name__}: every process learns; none serves batches")


class DataParallel(SingleProcess):
    """Each process collects its share of the worlds and computes its share of every
    minibatch; gradients, statistics and (``merge_normaliser``) normalisers are combined."""

    def __init__(self, processes: Processes, *, merge_normaliser: bool) -> None:
        super().__init__(processes)
        self.merge_normaliser = merge_normaliser

    def after_collection(self, env: TransformedEnv) -> None:
        if self.merge_normaliser:
            # Each process saw 1/N of the worlds: average the statistics.
            env.transform.load_state_dict(
                distributed.average_floating_state(env.transform.state_dict())
            )

    def reduce_sum(self, tensor: torch.Tensor) -> torch.Tensor:
        return distributed.all_reduce_sum(tensor)

    def reduce_gradients(self, parameters: Sequence[torch.nn.Parameter]) -> None:
        distributed.all_reduce_gradients(parameters)

    def gather(self, value: Any) -> list[Any]:
        return distributed.gather(value)

    def stop_requested(self, received: bool) -> bool:
        # Another process's signal stops this one too.
        return distributed.any_process(received)


class Pipeline(SingleProcess):
    """Rank 1 collects every world (:meth:`serve`) while rank 0 trains on its batches, with
    the normaliser statistics and game generator that come with them."""

    def __init__(self, processes: Processes) -> None:
        super().__init__(processes)
        #: What the collector sent with the last batch (speed, normaliser, generator).
        self.extras: dict[str, Any] = {}
        self.channel: WeightChannel | None = None

    def local_worlds(self, layout: Layout) -> int:
        # The learner steps no world: one, for its specs and normaliser statistics.
        return layout.num_envs if self.processes.collects else 1

    @property
    def restores_game_rng(self) -> bool:
        return True

    def batches(
        self,
        env: TransformedEnv,
        policy: TensorDictModuleBase,
        layout: Layout,
        frames: int,
        device: torch.device,
    ) -> Generator[TensorDictBase, None, None]:
        # Several processes train on CPU (rlhc.config.validation.check_device).
        while True:
            batch, self.extras = distributed.receive_batch()
            # The collector's normaliser statistics, for the update and the checkpoints.
            env.transform.load_state_dict(self.extras["env_transform"])
            yield batch

    def env_steps_per_s(self, frames: int, seconds: float) -> float:
        # The learner waited; the collector collected.
        return self.extras.get("env_steps_per_s", frames / seconds)

    def after_update(self, actor_parameters: Sequence[torch.Tensor], go_on: bool) -> None:
        """Send the new weights; when stopping, take the batch still in flight."""
        if self.channel is None:
            self.channel = WeightChannel(actor_parameters)
        self.channel.send(go_on)
        if not go_on:
            distributed.receive_batch()  # collected with the last weights; nobody trains on it
            self.channel.wait()

    def game_rng_state(self, env: TransformedEnv) -> Mapping[str, Any] | None:
        return self.extras.get("game_rng")

    def serve(
        self,
        env: TransformedEnv,
        policy: TensorDictModuleBase,
        layout: Layout,
        actor_parameters: Sequence[torch.Tensor],
    ) -> None:
        """Collect, send, load the new weights, until the learner says stop (the stop
        signals are the learner's). Batch ``k + 1`` is collected while the learner trains
        on batch ``k``, with the weights from before that update."""
        channel = WeightChannel(actor_parameters)
        collector = Collector(
            env,
            policy,
            frames_per_batch=layout.frames_per_batch,
            total_frames=-1,
            auto_register_policy_transforms=False,
            track_traj_ids=False,
        )
        with StopSignals():
            try:
                start = time.perf_counter()
                for index, batch in enumerate(collector):
                    extras = {
                        "env_steps_per_s": batch.numel() / (time.perf_counter() - start),
                        "env_transform": env.transform.state_dict(),
                        "game_rng": game_rng_state(env),
                    }
                    distributed.send_batch(batch, extras)
                    if index >= 1 and not channel.receive():
                        break
                    start = time.perf_counter()
            finally:
                collector.shutdown()


def make_strategy(processes: Processes, *, normalize_observations: bool) -> SingleProcess:
    """The strategy of this process's place in the run.

    Args:
        processes: from :func:`rlhc.training.distributed.setup` (``Processes()``: one process).
        normalize_observations: whether data-parallel processes average the observation
            normaliser's statistics.

    Examples:
        >>> from rlhc.training.distributed import Processes
        >>> type(make_strategy(Processes(), normalize_observations=True)).__name__
        'SingleProcess'
        >>> type(make_strategy(Processes(0, 2, "pipeline"), normalize_observations=True)).__name__
        'Pipeline'
    """
    if processes.data_parallel:
        return DataParallel(processes, merge_normaliser=normalize_observations)
    if processes.pipeline:
        return Pipeline(processes)
    return SingleProcess(processes)
