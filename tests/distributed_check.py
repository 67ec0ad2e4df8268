"""Run by ``tests/training/test_distributed.py`` under ``torchrun --nproc_per_node=2``.

Every rank holds the same minibatch (rank 0's, broadcast). Each computes the gradient a
single process computes on the whole minibatch, then the data-parallel gradient from its
half plus the all-reduce, then takes one optimiser step. Rank 0 writes, as JSON, the
largest gradient difference on any rank and the largest parameter difference between
the ranks after the step; then each rank runs a whole update on its own rollout and
rank 0 writes every rank's learning rate after it and its update's KL.

Usage: ``torchrun --standalone --nproc_per_node=2 tests/distributed_check.py OUT [overrides…]``
"""

from __future__ import annotations

import json
import sys
import tempfile
from pathlib import Path

import torch
import torch.distributed as dist
from configs import load_smoke
from torchrl.envs.utils import ExplorationType, set_exploration_type

from rlhc.objectives import cut_trajectories
from rlhc.training.distributed import broadcast_object, gather, setup, shutdown
from rlhc.training.strategies import SingleProcess
from rlhc.training.trainer import Trainer


def main(out: Path, overrides: list[str]) -> None:
    cfg = load_smoke(*overrides, "logger.backends=[csv]")
    processes = setup("data", "cpu", cfg.league.active)
    rank, size = processes.rank, processes.size
    with tempfile.TemporaryDirectory() as tmp:
        trainer = Trainer(cfg, Path(tmp), processes=processes)
        batch = None
        if rank == 0:
            with torch.no_grad():
                batch = trainer.env.rollout(
                    32, trainer.collection_policy, break_when_any_done=False
                )
        batch = broadcast_object(batch)
        cut_trajectories(batch, trainer.groups, trainer.layout.time_horizon)
        with torch.no_grad():
            for loss in trainer.losses.values():
                loss.value_estimator(batch)
        minibatch = batch.reshape(-1)[: 16 * size]

        data_parallel = trainer.strategy
        trainer.strategy = SingleProcess()  # one process, the whole minibatch
        trainer.backward(minibatch.clone())
        single = [p.grad.clone() for p in trainer.parameters]

        trainer.strategy = data_parallel  # this rank's half, then the all-reduce
        share = minibatch.shape[0] // size
        trainer.backward(minibatch[rank * share : (rank + 1) * share].clone())
        shared = [p.grad.clone() for p in trainer.parameters]
        gradient_error = max(
            (a - b).abs().max().item() for a, b in zip(single, shared, strict=True)
        )
        gradient_scale = max(a.abs().max().item() for a in single)

        trainer.optimizer.step()
        flat = torch.cat([p.detach().reshape(-1) for p in trainer.parameters])
        everyone = gather(flat)
        parameter_error = max((everyone[0] - other).abs().max().item() for other in everyone)
        errors = gather(gradient_error)

        # A whole update on each rank's own rollout (their KLs differ): with
        # algo.target_kl the rate adapted to it must stay the same on every rank.
        torch.manual_seed(1 + rank)
        with torch.no_grad(), set_exploration_type(ExplorationType.RANDOM):
            own = trainer.env.rollout(32, trainer.collection_policy, break_when_any_done=False)
        kl = trainer.update(own)[f"{trainer.groups[0]}/kl_approx"]
        rates = gather(trainer.optimizer.param_groups[0]["lr"])
        local_kls = gather(kl)
    if rank == 0:
        out.write_text(
            json.dumps(
                {
                    "gradient_error": max(errors),
                    "gradient_scale": gradient_scale,
                    "parameter_error": parameter_error,
                    "learning_rates": rates,
                    "update_kls": local_kls,
                    "processes": size,
                    "weights": minibatch.numel(),
                }
            )
        )
    dist.barrier()
    shutdown()


if __name__ == "__main__":
    main(Path(sys.argv[1]), sys.argv[2:])
