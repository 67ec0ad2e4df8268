"""Report of the RLHC-vs-PPO reproduction: ``docs/RESULTS.md`` from the study's runs.

Reads the runs that ``benchmarks/reproduce.py`` writes under
``benchmarks/results/reproduce/<study>/<config>/seed_<k>/`` and writes every number of
``docs/RESULTS.md`` (nothing in that file is typed by hand):

* which runs are complete (``checkpoints/latest.pt`` reached the study's ``max_steps``);
  unfinished runs are listed and left out of every statistic;
* per study and group metric: the final value of each run — the mean of the last 10%
  (by steps) of its TensorBoard-smoothed curve (EMA 0.8, as ``python -m rlhc.plot``) —
  averaged over seeds with a 95% Student t interval; steps to reach a threshold; the
  final episode length and entropy;
* Welch's t-test of RLHC against PPO on those per-seed final values;
* the paper's four curves per study (:func:`rlhc.plotting.plot_runs`), drawn into
  ``--images`` (default: ``images/`` next to ``--out``);
* head-to-head matches of the final RLHC team against the final PPO team (seed k vs
  seed k, sides swapped every match, deterministic actions) and of every final team
  against the scripted team, with 95% Wilson intervals.

This file is the command line; the work is done by the ``reporting`` package next to it.

Usage::

    python benchmarks/report.py                                  # 100 matches per pairing
    python benchmarks/report.py --matches 10 --out /tmp/RESULTS.md
    python benchmarks/report.py --matches 0                      # curves and tests only
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path

# ``reporting`` and ``reproduce`` live next to this script, which is not in a package.
sys.path.insert(0, str(Path(__file__).resolve().parent))
from reporting.document import build_report
from reporting.study import STUDIES, THRESHOLD_FRACTION
from reproduce import RESULTS

ROOT = Path(__file__).resolve().parents[1]


def parse_args(argv: Sequence[str] | None = None) -> argparse.Namespace:
    """The report's options; ``images`` defaults to ``images/`` next to ``out``."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--results", type=Path, default=RESULTS, help="the study's root")
    parser.add_argument(
        "--matches", type=int, default=100, help="matches per pairing (0: play none)"
    )
    parser.add_argument("--out", type=Path, default=ROOT / "docs" / "RESULTS.md")
    parser.add_argument(
        "--images",
        type=Path,
        default=None,
        help="folder of the curve figures (default: images/ next to --out, so a report "
        "written elsewhere never overwrites docs/images)",
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
    report = build_report(args)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(report)
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
