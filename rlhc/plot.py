"""Entry point: ``python -m rlhc.plot <run dirs…> [--out curves.png] [--smoothing 0.8]``.

Draws the paper's four curves (cumulative reward, episode length, entropy, value
estimate; per group for group metrics) of every run under the given paths, seeds of
one configuration averaged with a shaded 95% t interval, and prints each
configuration's last-10% value of every curve (mean ± t interval over its runs).

Examples:
    python -m rlhc.plot multirun/2025-01-01_00-00-00 --out docs/images/tennis.png
    python -m rlhc.plot outputs/tennis --group-by critic.fusion env.extended_obs
"""

from __future__ import annotations

import argparse
from collections.abc import Sequence

from rlhc.evaluation.stats import t_interval
from rlhc.plotting import (
    PAPER_METRICS,
    final_values,
    group_runs,
    load_runs,
    panel_metrics,
    plot_runs,
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
    args = parse_args(argv)
    out = plot_runs(args.runs, args.out, args.smoothing, args.group_by, args.metrics)
    print(f"wrote {out}")
    runs = load_runs(args.runs)
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
