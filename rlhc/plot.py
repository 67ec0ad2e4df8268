"""Entry point: ``python -m rlhc.plot <run dirs…> [--out curves.png] [--smoothing 0.8]``.

Draws the paper's four curves (cumulative reward, episode length, entropy, value
estimate; per group for group metrics) of every run under the given paths, seeds of
one configuration averaged with a shaded 95% t interval, and prints each
configuration's last-10% value of every curve (mean ± t interval over its runs).

Arguments that hold no run (a multirun's ``multirun.yaml``, a directory without
``metrics.csv``) are skipped with one warning line, so a shell glob works as written.

Examples:
    python -m rlhc.plot multirun/2025-01-01_00-00-00 --out docs/images/tennis.png
    python -m rlhc.plot multirun/2025-01-01_00-00-00/* --out curves.png
    python -m rlhc.plot outputs/tennis --group-by critic.fusion env.extended_obs
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence

from rlhc.evaluation.stats import t_interval
from rlhc.plotting import plot_runs
from rlhc.runs import (
    METRICS_FILE,
    PAPER_METRICS,
    final_values,
    group_runs,
    load_runs,
    panel_metrics,
    split_run_paths,
)


def parse_args(argv: Sequence[str] | None = None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(prog="python -m rlhc.plot", description=__doc__.split("\n")[0])
    parser.add_argument(
        "runs", nargs="+", help="run directories, multirun directories or metrics.csv files"
    )
    parser.add_argument(
        "--out", default="curves.png", help="image file to write (default: curves.png)"
    )
    parser.add_argument(
        "--smoothing",
        type=float,
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
        type=float,
        default=0.1,
        help="share of each curve averaged for the printed final values (default: 0.1)",
    )
    return parser.parse_args(argv)


def main(argv: Sequence[str] | None = None) -> None:
    """Plot and print; paths holding no run (e.g. ``multirun.yaml``) are skipped with a warning.

    Raises:
        SystemExit: a path does not exist, or no run directory remains (one line).
    """
    args = parse_args(argv)
    try:
        run_dirs, not_runs = split_run_paths(args.runs)
    except FileNotFoundError as error:
        raise SystemExit(f"rlhc.plot: error: {error}") from None
    if not_runs:
        print(
            f"rlhc.plot: warning: skipping {len(not_runs)} path(s) with no {METRICS_FILE} "
            f"at or under them (not run directories): {', '.join(map(str, not_runs))}",
            file=sys.stderr,
        )
    if not run_dirs:
        raise SystemExit(
            f"rlhc.plot: error: no run directory (one holding {METRICS_FILE}) at or under "
            f"{', '.join(args.runs)}"
        )
    titles = {leaf: PAPER_METRICS.get(leaf, leaf) for leaf in args.metrics}
    out = plot_runs(run_dirs, args.out, args.smoothing, args.group_by, titles)
    print(f"wrote {out}")
    runs = load_runs(run_dirs)
    groups = group_runs(runs, args.group_by)
    print(
        f"\nmean of the last {args.final_fraction:.0%} of each curve (± 95% t interval over runs):"
    )
    for metric in panel_metrics(runs, args.metrics):
        print(f"  {metric}")
        for label, members in groups.items():
            ci = t_interval(list(final_values(members, metric, args.final_fraction).values()))
            if ci.n:
                print(f"    {label:<40} {ci.mean:+.4f}  [{ci.low:+.4f}, {ci.high:+.4f}]  n={ci.n}")


if __name__ == "__main__":
    main()
