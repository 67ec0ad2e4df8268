"""Does ``torch.compile`` speed up the PPO minibatch step? Eager against compiled, one run.

Builds the trainer of a preset, collects one batch, estimates its advantages, then times
passes over its minibatches (loss forward, backward, optimiser step, as
:meth:`rlhc.training.trainer.Trainer.update` does them) eagerly and under ``torch.compile``: the
first compiled minibatch (compile time) apart from the steady passes, and TorchDynamo's
counts of graphs, graph breaks and frames compiled. Nothing is kept of the training.

Usage::

    python -m benchmarks.compile_update --env soccer
    python -m benchmarks.compile_update --env tennis --cache-limit 64 --out /tmp/c.json
"""

from __future__ import annotations

import argparse
import json
import shlex
import sys
import tempfile
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import torch
import torch._dynamo
from tensordict import TensorDictBase
from torch._dynamo.utils import counters

from benchmarks.reporting.summary import code_version
from rlhc.config.train_schema import compose_config
from rlhc.training.trainer import Trainer

RESULTS = Path(__file__).resolve().parent / "results" / "compile_update.json"


def one_batch(trainer: Trainer) -> TensorDictBase:
    """One collected batch with its advantages, flattened to ``[frames]``."""
    batch = trainer.collect_batch()
    with torch.no_grad():
        for loss in trainer.losses.values():
            loss.value_estimator(batch)
    return batch.reshape(-1)


def timed_passes(
    step: Callable[[TensorDictBase], None], minibatches: Sequence[TensorDictBase], passes: int
) -> tuple[float, list[float]]:
    """The first minibatch's seconds, then seconds per minibatch of each following pass."""
    start = time.perf_counter()
    step(minibatches[0])
    first = time.perf_counter() - start
    rates = []
    for _ in range(passes):
        start = time.perf_counter()
        for minibatch in minibatches:
            step(minibatch)
        rates.append((time.perf_counter() - start) / len(minibatches))
    return first, rates


def measure(env: str, passes: int, cache_limit: int, overrides: Sequence[str]) -> dict[str, Any]:
    """Eager and compiled timings of one preset's minibatch step."""
    torch.manual_seed(0)
    cfg = compose_config(f"env={env}", "logger.backends=[csv]", "logger.progress=false",
                         "threads=1", *overrides)  # fmt: skip
    trainer = Trainer(cfg, Path(tempfile.mkdtemp(prefix="compile_update_")))
    flat = one_batch(trainer)
    share = trainer.layout.minibatch_frames
    order = torch.randperm(flat.numel())[: trainer.layout.minibatches * share]
    minibatches = [flat[index] for index in order.split(share)]

    def step(minibatch: TensorDictBase) -> None:
        trainer.backward(minibatch)
        trainer.optimizer.step()

    eager_first, eager = timed_passes(step, minibatches, passes)
    torch._dynamo.config.cache_size_limit = cache_limit
    counters.clear()
    compiled_first, compiled = timed_passes(torch.compile(step), minibatches, passes)
    return {
        "env": env,
        "overrides": list(overrides),
        "minibatches_per_pass": len(minibatches),
        "minibatch_frames": share,
        "eager_first_s": eager_first,
        "eager_s_per_minibatch": eager,
        "compiled_first_s": compiled_first,
        "compiled_s_per_minibatch": compiled,
        "cache_size_limit": cache_limit,
        "unique_graphs": counters["stats"]["unique_graphs"],
        "graph_breaks": sum(counters["graph_break"].values()),
        "frames_compiled": dict(counters["frames"]),
    }


def main(argv: Sequence[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--env", choices=("soccer", "tennis"), default="soccer")
    parser.add_argument("--passes", type=int, default=2, help="steady passes over the batch")
    parser.add_argument("--cache-limit", type=int, default=8,
                        help="torch._dynamo.config.cache_size_limit (torch's default: 8)")  # fmt: skip
    parser.add_argument("--overrides", nargs="*", default=[], help="Hydra overrides")
    parser.add_argument("--out", type=Path, default=RESULTS)
    argv = sys.argv[1:] if argv is None else list(argv)
    args = parser.parse_args(argv)
    if args.passes < 1:
        parser.error(f"--passes must be >= 1, got {args.passes}")
    result = measure(args.env, args.passes, args.cache_limit, args.overrides)
    result["code_version"] = code_version()
    result["torch"] = torch.__version__
    result["command"] = shlex.join(["python", "-m", "benchmarks.compile_update", *argv])
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(result, indent=2) + "\n")
    eager, compiled = min(result["eager_s_per_minibatch"]), min(result["compiled_s_per_minibatch"])
    print(
        f"{args.env}: eager {eager * 1e3:.1f} ms per minibatch; compiled {compiled * 1e3:.1f} ms "
        f"(first {result['compiled_first_s']:.1f} s), {result['unique_graphs']} graphs, "
        f"{result['graph_breaks']} graph breaks -> {args.out}"
    )


if __name__ == "__main__":
    main()
