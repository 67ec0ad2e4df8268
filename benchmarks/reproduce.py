"""Reproduce the paper's comparison: the studies of ``conf/study``, one process per run.

Each run of the plan (:func:`benchmarks.reporting.plan.plan`) trains as
``python -m rlhc.run study=<study> critic=<config> seed=<k>``, ``--jobs`` at a time (one
per core), in the directory its study config names (``<root>/<config>/seed_<k>/``); the
study config sets ``resume=auto``, so an unfinished run continues from its latest
checkpoint. After each process the run's ``summary.json``
(:mod:`benchmarks.reporting.summary`: frames, budget, overrides, code versions, complete
or not) is written; the report reads it. A complete run keeps its final team
(``final_team.pt``, :mod:`rlhc.storage.final_team`: written by the trainer, or here from its
last checkpoint if the trainer predates it), committed with the run so that the round
robin can pit it against runs trained later. A run whose summary says complete is skipped.
The same studies also run as Hydra multiruns (``python -m rlhc.run -m study=<name>``);
``--summaries-only`` then writes their summaries.

``--hours H`` starts a run only if it is expected to finish within ``H`` hours of the
command's start: its study's measured wall time per frame (of its game, or of its task on
another library's env, for a study without complete runs) times the frames it has left by
its summary (all of them for a run without one). A machine that is taken away at a
known time (a session, a cluster allocation) then ends with every run it started
complete, none half-trained. A run without any measured rate is not started under
``--hours``.

Usage (from the repository root)::

    python -m benchmarks.reproduce --jobs 2                          # every study
    python -m benchmarks.reproduce --study soccer_paper --seeds 3    # a part of it
    python -m benchmarks.reproduce --summaries-only                  # after a multirun
    python -m benchmarks.reproduce --jobs 2 --hours 2.5              # only what fits
    python -m benchmarks.report                                      # docs/RESULTS.md
"""

from __future__ import annotations

import argparse
import shlex
import subprocess
import sys
import time
from collections.abc import Mapping, Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass

from benchmarks.reporting.plan import ROOT, PlannedRun, plan, studies, study_names
from benchmarks.reporting.runs import discover, study_rate
from benchmarks.reporting.summary import (
    TRAIN_LOG,
    RunSummary,
    code_version,
    read_summary,
    summarise,
    write_summary,
)
from rlhc.storage.checkpoint import checkpoint_candidates
from rlhc.storage.final_team import export_team, team_file


def record(run: PlannedRun) -> RunSummary:
    """Write the run's ``summary.json`` and, if it is complete, make sure its final team
    is kept (exported from its newest checkpoint when missing); its summary."""
    summary = summarise(run, run.run_dir)
    write_summary(run.run_dir, summary)
    if summary.completed and team_file(run.run_dir) is None and checkpoint_candidates(run.run_dir):
        export_team(run.run_dir)
    return summary


def is_done(run: PlannedRun) -> bool:
    """Its summary records that it reached ``max_steps`` frames."""
    summary = read_summary(run.run_dir)
    return summary is not None and summary.completed


def command(run: PlannedRun) -> list[str]:
    """The training process of a run (its study config resumes it if it can)."""
    return [sys.executable, "-m", "rlhc.run", *run.overrides]


def expected_seconds(runs: Sequence[PlannedRun]) -> dict[PlannedRun, float | None]:
    """Per run: its study's measured seconds per frame times the frames it has left
    (``None``: no complete run of its game or task to measure a rate from)."""
    known = studies()
    found = discover(known)
    trained = {(r.study, r.config, r.seed): r.frames or 0 for r in found}
    expected: dict[PlannedRun, float | None] = {}
    for run in runs:
        rate = study_rate(known, known[run.study], found)
        left = max(run.max_steps - trained.get((run.study, run.config, run.seed), 0), 0)
        expected[run] = None if rate is None else rate * left
    return expected


@dataclass(frozen=True)
class Deadline:
    """Start a run only if it is expected to end within ``seconds`` of ``start``.

    Attributes:
        seconds: the time allowed from ``start`` (``time.monotonic()``).
        start: when the command started.
        expected: :func:`expected_seconds` of the runs.
    """

    seconds: float
    start: float
    expected: Mapping[PlannedRun, float | None]

    def refusal(self, run: PlannedRun) -> str | None:
        """Why ``run`` may not start now; ``None`` if it may."""
        left = self.seconds - (time.monotonic() - self.start)
        needs = self.expected.get(run)
        if needs is None:
            return "no measured rate of its game or task to estimate its time from"
        if needs > left:
            return (f"needs ~{needs / 60:.0f} min at its study's measured rate, "
                    f"{max(left, 0) / 60:.0f} min left of --hours")  # fmt: skip
        return None


def execute(
    run: PlannedRun, deadline: Deadline | None = None
) -> tuple[PlannedRun, int | None, float]:
    """Train one run, then write its summary; its exit code (``None``: not started,
    ``deadline`` refused it, as printed) and time."""
    if deadline is not None and (why := deadline.refusal(run)) is not None:
        print(f"{run.name}/seed_{run.seed}: not started: {why}", flush=True)
        return run, None, 0.0
    run.run_dir.mkdir(parents=True, exist_ok=True)
    start = time.perf_counter()
    with (run.run_dir / TRAIN_LOG).open("a") as log:
        shown = shlex.join(["python", *command(run)[1:]])  # as a user types it
        log.write(f"code version: {code_version()}\ncommand: {shown}\n")
        log.flush()
        code = subprocess.call(command(run), cwd=ROOT, stdout=log, stderr=subprocess.STDOUT)
    record(run)
    return run, code, time.perf_counter() - start


def write_summaries(runs: Sequence[PlannedRun]) -> int:
    """``summary.json`` of every run that has a directory, from its files (and the final
    team of a complete one, as :func:`record`); how many.

    A complete run that no longer keeps a checkpoint (a fresh clone) keeps its summary:
    its files now say less than when the summary was written (frames from the
    checkpoint, not from ``metrics.csv``).
    """
    written = 0
    for run in runs:
        if not run.run_dir.is_dir() or (is_done(run) and not checkpoint_candidates(run.run_dir)):
            continue
        record(run)
        written += 1
    return written


def parse_args(argv: Sequence[str] | None = None) -> argparse.Namespace:
    """The command line; errors name the bad value and what is allowed."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    names = study_names()
    parser.add_argument("--study", nargs="+", choices=names, default=names)
    parser.add_argument("--seeds", type=int, default=None, help="seeds per config (default: all)")
    parser.add_argument("--jobs", type=int, default=2, help="runs in parallel (one per core)")
    parser.add_argument(
        "--summaries-only",
        action="store_true",
        help="train nothing: (re)write summary.json of every existing run from its files "
        "(a complete run without checkpoints keeps its own)",
    )
    parser.add_argument(
        "--hours",
        type=float,
        default=None,
        help="start only runs expected to finish within this many hours (measured rates)",
    )
    args = parser.parse_args(argv)
    if args.seeds is not None and args.seeds < 1:
        parser.error(f"--seeds must be >= 1, got {args.seeds}")
    if args.jobs < 1:
        parser.error(f"--jobs must be >= 1, got {args.jobs}")
    if args.hours is not None and not args.hours > 0:
        parser.error(f"--hours must be > 0, got {args.hours}")
    return args


def main(argv: Sequence[str] | None = None) -> int:
    """Train the runs of the chosen studies that are not complete; the exit code."""
    args = parse_args(argv)
    runs = plan(args.study, args.seeds)
    if args.summaries_only:
        print(f"wrote {write_summaries(runs)} summaries", flush=True)
        return 0
    todo = [run for run in runs if not is_done(run)]
    print(f"{len(todo)} of {len(runs)} runs to train", flush=True)
    deadline = None
    if args.hours is not None:
        deadline = Deadline(args.hours * 3600, time.monotonic(), expected_seconds(todo))
    failures = 0
    with ThreadPoolExecutor(max_workers=args.jobs) as pool:
        for run, code, seconds in pool.map(lambda r: execute(r, deadline), todo):
            if code is None:
                continue  # not started: said when it was refused
            status = "ok" if code == 0 else f"FAILED ({code}, see {run.run_dir / TRAIN_LOG})"
            failures += code != 0
            print(f"{run.name}/seed_{run.seed}: {status} in {seconds:.0f} s", flush=True)
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
