"""Reproduce the paper's comparison: RLHC vs PPO on tennis and soccer (+ extensions).

Runs every run of the plan (:data:`benchmarks.reporting.plan.STUDIES`) as a separate
``python -m rlhc.run`` process, ``--jobs`` at a time (one per core), each in
``benchmarks/results/reproduce/<study>/<config>/seed_<k>/``. After each process it
writes the run's ``summary.json`` (:mod:`benchmarks.reporting.summary`: frames, budget,
overrides, code versions, complete or not), which the report reads. A run whose summary
says complete is skipped; an unfinished run resumes from its latest checkpoint.

Usage (from the repository root)::

    python -m benchmarks.reproduce --jobs 2                 # the whole study (~11 M frames)
    python -m benchmarks.reproduce --study tennis --seeds 2 # a part of it
    python -m benchmarks.reproduce --summaries-only         # summary.json of trained runs
    python -m benchmarks.report --matches 0                 # docs/RESULTS.md from the runs
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import time
from collections.abc import Sequence
from concurrent.futures import ThreadPoolExecutor

from benchmarks.reporting.plan import RESULTS, STUDIES, PlannedRun, plan
from benchmarks.reporting.summary import (
    TRAIN_LOG,
    code_version,
    read_summary,
    summarise,
    write_summary,
)
from rlhc.checkpoint import CHECKPOINT_DIR, LATEST


def is_done(run: PlannedRun) -> bool:
    """Its summary records that it reached ``max_steps`` frames."""
    summary = read_summary(run.run_dir(RESULTS))
    return summary is not None and summary.completed


def command(run: PlannedRun) -> list[str]:
    """The training process of a run (resuming it if it keeps a checkpoint)."""
    run_dir = run.run_dir(RESULTS)
    words = [
        sys.executable,
        "-m",
        "rlhc.run",
        *run.overrides,
        f"seed={run.seed}",
        f"algo.max_steps={run.max_steps}",
        "logger.backends=[csv]",
        "logger.progress=false",
        f"hydra.run.dir={run_dir}",
    ]
    if (run_dir / CHECKPOINT_DIR / LATEST).exists():
        words.append(f"resume={run_dir}")
    return words


def execute(run: PlannedRun) -> tuple[PlannedRun, int, float]:
    """Train one run, then write its summary; returns its exit code and time."""
    run_dir = run.run_dir(RESULTS)
    run_dir.mkdir(parents=True, exist_ok=True)
    start = time.perf_counter()
    with (run_dir / TRAIN_LOG).open("a") as log:
        log.write(f"code version: {code_version()}\n")
        log.flush()
        code = subprocess.call(command(run), stdout=log, stderr=subprocess.STDOUT)
    write_summary(run_dir, summarise(run, run_dir))
    return run, code, time.perf_counter() - start


def write_summaries(runs: Sequence[PlannedRun]) -> int:
    """``summary.json`` of every run that has a directory, from its files; how many."""
    written = 0
    for run in runs:
        run_dir = run.run_dir(RESULTS)
        if run_dir.is_dir():
            write_summary(run_dir, summarise(run, run_dir))
            written += 1
    return written


def main(argv: Sequence[str] | None = None) -> None:
    """Train the runs of the chosen studies that are not complete."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--study", nargs="+", choices=sorted(STUDIES), default=list(STUDIES))
    parser.add_argument(
        "--seeds", type=int, default=None, help="seeds per config (default: study's)"
    )
    parser.add_argument("--jobs", type=int, default=2, help="runs in parallel (one per core)")
    parser.add_argument(
        "--summaries-only",
        action="store_true",
        help="train nothing: (re)write summary.json of every existing run from its files",
    )
    args = parser.parse_args(argv)

    runs = plan(args.study, args.seeds)
    if args.summaries_only:
        print(f"wrote {write_summaries(runs)} summaries", flush=True)
        return
    todo = [run for run in runs if not is_done(run)]
    print(f"{len(todo)} runs to do", flush=True)
    failures = 0
    with ThreadPoolExecutor(max_workers=args.jobs) as pool:
        for run, code, seconds in pool.map(execute, todo):
            log = run.run_dir(RESULTS) / TRAIN_LOG
            status = "ok" if code == 0 else f"FAILED ({code}, see {log})"
            failures += code != 0
            print(f"{run.name}/seed_{run.seed}: {status} in {seconds:.0f} s", flush=True)
    sys.exit(1 if failures else 0)


if __name__ == "__main__":
    main()
