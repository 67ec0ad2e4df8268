"""Entry point: ``python -m rlhc.plot <run dirs…> [--out curves.png] [--smoothing 0.8]``.

Draws the paper's four curves of every run under the given paths, seeds of one
configuration averaged with a shaded 95% t interval, and prints each configuration's
last-10% value of every curve. Paths that hold no run (a multirun's ``multirun.yaml``)
are skipped with a warning, so a shell glob works; a user error prints
``rlhc.plot: error: <one line>`` and exits 2, writing nothing (:mod:`rlhc.cli.report`).

Examples:
    python -m rlhc.plot multirun/2025-01-01_00-00-00 --out docs/images/tennis.png
    python -m rlhc.plot multirun/2025-01-01_00-00-00/* --out curves.png
    python -m rlhc.plot outputs/tennis --group-by critic.fusion env.extended_obs
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from typing import NoReturn

from rlhc.analysis.curves import (
    METRICS_FILE,
    PAPER_METRICS,
    final_values,
    group_runs,
    load_runs,
    panel_metrics,
    split_run_paths,
)
from rlhc.analysis.drawing import plot_groups
from rlhc.cli.report import UsageError, user_errors_in_one_line
from rlhc.evaluation.stats import t_interval

PROGRAM = "rlhc.plot"


class ArgumentParser(argparse.ArgumentParser):
    """argparse's parser, its errors raised as :class:`UsageError` (reported in one line)."""

    def error(self, message: str) -> NoReturn:
        raise UsageError(f"{message} (usage: python -m {PROGRAM} --help)")


def fraction(low_open: bool, text: str) -> float:
    """``text`` as a number in ``[0, 1)`` (``low_open=False``) or ``(0, 1]`` (``True``).

    Examples:
        >>> fraction(False, "0.8")
        0.8
        >>> fraction(True, "0")
        Traceback (most recent call last):
        ...
        argparse.ArgumentTypeError: 0 is not a number in (0, 1]
    """
    allowed = "(0, 1]" if low_open else "[0, 1)"
    try:
        value = float(text)
    except ValueError:
        value = float("nan")
    inside = 0.0 < value <= 1.0 if low_open else 0.0 <= value < 1.0
    if not inside:
        raise argparse.ArgumentTypeError(f"{text} is not a number in {allowed}")
    return value


def parse_args(argv: Sequence[str] | None = None) -> argparse.Namespace:
    """The command line of ``python -m rlhc.plot`` (:class:`UsageError` if argparse refuses it)."""
    parser = ArgumentParser(prog=f"python -m {PROGRAM}", description=__doc__.split("\n")[0])
    parser.add_argument(
        "runs", nargs="+", help="run directories, multirun directories or metrics.csv files"
    )
    parser.add_argument(
        "--out", default="curves.png", help="image file to write (default: curves.png)"
    )
    parser.add_argument(
        "--smoothing",
        type=lambda text: fraction(False, text),
        default=0.8,
        help="TensorBoard EMA weight in [0, 1) (default: 0.8)",
    )
    parser.add_argument(
        "--group-by",
        nargs="*",
        default=None,
        metavar="KEY",
        help="config keys defining a configuration (default: the keys that differ, seed excluded)",
    )
    parser.add_argument(
        "--metrics",
        nargs="*",
        default=list(PAPER_METRICS),
        metavar="LEAF",
        help="metric leaves to draw (default: the paper's four)",
    )
    parser.add_argument(
        "--final-fraction",
        type=lambda text: fraction(True, text),
        default=0.1,
        help="share of each curve averaged for the printed final values (default: 0.1)",
    )
    return parser.parse_args(argv)


def main(argv: Sequence[str] | None = None) -> None:
    """Plot and print; :class:`UsageError` for a missing path, no run, an unreadable
    ``metrics.csv``, none of ``--metrics`` logged, or a bad argument."""
    args = parse_args(argv)
    try:
        run_dirs, not_runs = split_run_paths(args.runs)
    except FileNotFoundError as error:
        raise UsageError(str(error)) from None
    if not_runs:
        print(
            f"{PROGRAM}: warning: skipping {len(not_runs)} path(s) with no {METRICS_FILE} "
            f"at or under them (not run directories): {', '.join(map(str, not_runs))}",
            file=sys.stderr,
        )
    if not run_dirs:
        raise UsageError(
            f"no run directory (one holding {METRICS_FILE}) at or under {', '.join(args.runs)}"
        )
    try:
        runs = load_runs(run_dirs)
    except ValueError as error:  # a metrics.csv without rows or unreadable
        raise UsageError(str(error)) from None
    if not panel_metrics(runs, args.metrics):
        raise UsageError(
            f"none of the runs logged any of --metrics {' '.join(args.metrics)} "
            f"(at or under {', '.join(args.runs)})"
        )
    groups = group_runs(runs, args.group_by)
    titles = {leaf: PAPER_METRICS.get(leaf, leaf) for leaf in args.metrics}
    out = plot_groups(groups, args.out, args.smoothing, titles)
    print(f"wrote {out}")
    print(
        f"\nmean of the last {args.final_fraction:.0%} of each curve (± 95% t interval over runs):"
    )
    for metric in panel_metrics(runs, args.metrics):
        print(f"  {metric}")
        for label, members in groups.items():
            ci = t_interval(list(final_values(members, metric, args.final_fraction).values()))
            if ci.n:
                print(f"    {label:<40} {ci.mean:+.4f}  [{ci.low:+.4f}, {ci.high:+.4f}]  n={ci.n}")


def cli(argv: Sequence[str] | None = None) -> None:
    """``python -m rlhc.plot``: :func:`main`, user errors in one line (exit 2)."""
    with user_errors_in_one_line(PROGRAM, (UsageError,)):
        main(argv)


if __name__ == "__main__":
    cli()
