"""Report of the RLHC-vs-PPO reproduction: ``docs/RESULTS.md`` from the studies' runs.

Reads the runs of the studies in ``conf/study`` (each run's ``summary.json``,
``metrics.csv``, ``.hydra/config.yaml``; each study's ``round_robin.json``) and writes
every number of ``docs/RESULTS.md``:

* the plan and its compute (core-hours per study from measured training rates); which
  runs are complete (unfinished runs are listed and left out of every statistic);
* per study and group metric: the final value of each run — the mean of the last 10%
  (by steps) of its TensorBoard-smoothed curve (EMA 0.8, as ``python -m rlhc.plot``) —
  averaged over seeds with a 95% Student t interval; steps to reach a threshold with
  its interval; hits per point (tennis) or goal rate (soccer); training speed;
* Welch's t-test between the compared critics (RLHC, twin, PPO) on those finals;
* the paper's four curves plus the play metric per study, drawn into ``--images``
  (default: ``images/`` next to ``--out``);
* a round robin per study of every final team, the scripted and the random team:
  ratings, scores against the built-in teams per seed, head-to-head with intervals that
  include the spread between seeds (:mod:`benchmarks.reporting.standings`);
* rliable-style aggregates over games (:mod:`benchmarks.reporting.aggregates`).

Matches need the runs' checkpoints: ``--matches N`` (default 20) first plays the missing
pairings into the studies' ``round_robin.json``; ``--matches 0`` plays none and reports
the committed series. The hand-written interpretation of the previous ``--out`` is kept.
This module is the command line; the work is done by :mod:`benchmarks.reporting`.

Usage (from the repository root)::

    python -m benchmarks.report --matches 0                      # from the committed files
    python -m benchmarks.report                                  # plays missing pairings
    python -m benchmarks.report --study soccer_paper --out /tmp/RESULTS.md
"""

from __future__ import annotations

import argparse
from collections.abc import Sequence
from pathlib import Path

from benchmarks.reporting.document import build_report
from benchmarks.reporting.plan import study_names
from benchmarks.reporting.study import THRESHOLD_FRACTION

ROOT = Path(__file__).resolve().parents[1]


def parse_args(argv: Sequence[str] | None = None) -> argparse.Namespace:
    """The report's options; ``images`` defaults to ``images/`` next to ``out``."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument(
        "--matches",
        type=int,
        default=20,
        help="matches per pairing to play where a study's round robin lacks one (even; 0: "
        "play none, report the committed series)",
    )
    parser.add_argument("--match-seed", type=int, default=0, help="seed of the matches")
    parser.add_argument("--out", type=Path, default=ROOT / "docs" / "RESULTS.md")
    parser.add_argument(
        "--images",
        type=Path,
        default=None,
        help="folder of the curve figures (default: images/ next to --out, so a report "
        "written elsewhere never overwrites docs/images)",
    )
    parser.add_argument(
        "--figures",
        action=argparse.BooleanOptionalAction,
        default=True,
        help="draw the curve figures (--no-figures: only link them)",
    )
    names = study_names()
    parser.add_argument("--study", nargs="+", choices=names, default=names)
    parser.add_argument(
        "--threshold-fraction",
        type=float,
        default=THRESHOLD_FRACTION,
        help="steps-to-threshold level, as a share of the way from initial to best final",
    )
    args = parser.parse_args(argv)
    if args.matches < 0 or args.matches % 2:
        parser.error(f"--matches must be 0 or a positive even number, got {args.matches}")
    if not 0.0 < args.threshold_fraction <= 1.0:
        parser.error(f"--threshold-fraction must lie in (0, 1], got {args.threshold_fraction}")
    if args.images is None:
        args.images = args.out.parent / "images"
    return args


def main(argv: Sequence[str] | None = None) -> None:
    """Write the report to ``--out`` (and its figures to ``--images``)."""
    import warnings

    import torch

    warnings.filterwarnings("ignore", message="Support of (Safe)?VecNorm")
    torch.set_num_threads(1)
    args = parse_args(argv)
    previous = args.out.read_text() if args.out.is_file() else None
    report = build_report(args, previous)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(report)
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
