"""Report of the RLHC-vs-PPO reproduction: ``docs/RESULTS.md`` from the study's runs.

Reads the runs that ``python -m benchmarks.reproduce`` writes under
``benchmarks/results/reproduce/<study>/<config>/seed_<k>/`` (never their checkpoints,
except to play matches) and writes every number of ``docs/RESULTS.md``:

* which runs are complete (their ``summary.json``); unfinished runs are listed and left
  out of every statistic;
* per study and group metric: the final value of each run — the mean of the last 10%
  (by steps) of its TensorBoard-smoothed curve (EMA 0.8, as ``python -m rlhc.plot``) —
  averaged over seeds with a 95% Student t interval; steps to reach a threshold; the
  final episode length and entropy;
* Welch's t-test of RLHC against PPO on those per-seed final values;
* the paper's four curves per study (:func:`rlhc.plotting.plot_runs`), drawn into
  ``--images`` (default: ``images/`` next to ``--out``);
* head-to-head matches of the final RLHC team against the final PPO team (seed k vs
  seed k, sides swapped every match, deterministic actions) and of every final team
  against the scripted team, with 95% Wilson intervals. They need the checkpoints; with
  ``--matches 0`` the previous report's matches are kept if the runs are unchanged.

The hand-written interpretation of the previous ``--out`` is kept. This module is the
command line; the work is done by :mod:`benchmarks.reporting`.

Usage (from the repository root)::

    python -m benchmarks.report --matches 0                      # from the committed files
    python -m benchmarks.report                                  # 100 matches per pairing
    python -m benchmarks.report --matches 10 --out /tmp/RESULTS.md
"""

from __future__ import annotations

import argparse
from collections.abc import Sequence
from pathlib import Path

from benchmarks.reporting.document import build_report
from benchmarks.reporting.plan import RESULTS, STUDIES
from benchmarks.reporting.study import THRESHOLD_FRACTION

ROOT = Path(__file__).resolve().parents[1]


def parse_args(argv: Sequence[str] | None = None) -> argparse.Namespace:
    """The report's options; ``images`` defaults to ``images/`` next to ``out``."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--results", type=Path, default=RESULTS, help="the study's root")
    parser.add_argument(
        "--matches",
        type=int,
        default=100,
        help="matches per pairing (0: play none, keep the previous report's if the runs "
        "are unchanged)",
    )
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
    parser.add_argument("--study", nargs="+", choices=list(STUDIES), default=list(STUDIES))
    parser.add_argument(
        "--threshold-fraction",
        type=float,
        default=THRESHOLD_FRACTION,
        help="steps-to-threshold level, as a share of the way from initial to best final",
    )
    args = parser.parse_args(argv)
    if args.images is None:
        args.images = args.out.parent / "images"
    return args


def main(argv: Sequence[str] | None = None) -> None:
    """Write the report to ``--out`` (and its figures to ``--images``)."""
    import warnings

    import torch

    warnings.filterwarnings("ignore", message="Support of VecNormV2")
    torch.set_num_threads(1)
    args = parse_args(argv)
    previous = args.out.read_text() if args.out.is_file() else None
    report = build_report(args, previous)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(report)
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
