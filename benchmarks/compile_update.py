"""Does ``compile=true`` speed up the PPO minibatch step? Eager against compiled, one run.

Builds the trainer of a preset twice from the same seed, ``compile=false`` and
``compile=true`` (:mod:`rlhc.training.compilation`), collects one batch, estimates its
advantages, then steps both over the same minibatches as
:meth:`rlhc.training.trainer.Trainer.update` does (a fresh minibatch TensorDict each step;
loss, backward, gradient clip, optimiser step): the first compiled minibatch (compile
time) apart from the steady passes, the largest parameter difference after that first
step, and TorchDynamo's counts of graphs, graph breaks and frames compiled. Nothing is
kept of the training.

Usage::

    python -m benchmarks.compile_update --env soccer
    python -m benchmarks.compile_update --env tennis --overrides study=tennis_best resume=null
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
from torch import Tensor
from torch._dynamo.utils import counters

from benchmarks.reporting.summary import code_version
from rlhc.config.train_schema import compose_config
from rlhc.training.trainer import Trainer

RESULTS = Path(__file__).resolve().parent / "results" / "compile_update.json"


def one_batch(eager: Trainer, fast: Trainer) -> TensorDictBase:
    """One batch collected by ``eager`` with its advantages, flattened to ``[frames]`` as
    the update takes it. Both trainers' estimators run on it, as their updates would
    (the estimator builds its fused value on first use; the loss reads it): the same
    advantages, from the same weights."""
    batch = eager.collect_batch()
    with torch.no_grad():
        for trainer in (fast, eager):
            for loss in trainer.losses.values():
                loss.value_estimator(batch)
    return batch.exclude("next").reshape(-1)


def timed_passes(
    step: Callable[[TensorDictBase], object],
    flat: TensorDictBase,
    order: Tensor,
    share: int,
    passes: int,
) -> list[float]:
    """Seconds per minibatch of each pass over the minibatches of ``order``."""
    rates = []
    for _ in range(passes):
        start = time.perf_counter()
        for index in order.split(share):
            step(flat[index])
        rates.append((time.perf_counter() - start) / (len(order) // share))
    return rates


def measure(env: str, passes: int, cache_limit: int, overrides: Sequence[str]) -> dict[str, Any]:
    """Eager and compiled timings of one preset's minibatch step."""
    torch._dynamo.config.cache_size_limit = cache_limit

    def build(compile_: bool) -> Trainer:
        cfg = compose_config(f"env={env}", "logger.backends=[csv]", "logger.progress=false",
                             "threads=1", f"compile={str(compile_).lower()}", *overrides)  # fmt: skip
        return Trainer(cfg, Path(tempfile.mkdtemp(prefix="compile_update_")))

    eager, fast = build(False), build(True)
    flat = one_batch(eager, fast)
    share = eager.layout.minibatch_frames
    torch.manual_seed(0)
    order = torch.randperm(flat.numel())[: eager.layout.minibatches * share]
    # The same first step from the same weights: its time (the compiled one's holds the
    # compilation) and how far apart it leaves the two.
    counters.clear()
    first = {}
    for name, trainer in (("eager", eager), ("compiled", fast)):
        torch.manual_seed(1)  # the same draws where an entropy is estimated by sampling
        start = time.perf_counter()
        trainer.step(flat[order[:share]])
        first[name] = time.perf_counter() - start
    difference = max(
        (a - b).abs().max().item() for a, b in zip(eager.parameters, fast.parameters, strict=True)
    )
    eager_rates = timed_passes(eager.step, flat, order, share, passes)
    compiled_rates = timed_passes(fast.step, flat, order, share, passes)
    return {
        "env": env,
        "overrides": list(overrides),
        "minibatches_per_pass": len(order) // share,
        "minibatch_frames": share,
        "max_parameter_difference_after_one_step": difference,
        "eager_first_s": first["eager"],
        "eager_s_per_minibatch": eager_rates,
        "compiled_first_s": first["compiled"],
        "compiled_s_per_minibatch": compiled_rates,
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
        f"{result['graph_breaks']} graph breaks; parameters after one step differ by at most "
        f"{result['max_parameter_difference_after_one_step']:.1e} -> {args.out}"
    )


if __name__ == "__main__":
    main()
