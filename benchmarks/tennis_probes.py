"""The tennis learning probes side by side: how fast each one learns to hit over the net.

Reads the committed ``metrics.csv`` of every run of ``benchmarks/results/learning/tennis/``
whose preset starts with ``probe`` or ``long`` (and, as the reference, the paper preset's
PPO runs) and prints a Markdown table: hits over the net per training episode (a point,
both teams' hits; league runs count their scripted and past-self worlds too) at fixed
frame counts, each the mean of the logged rows within 125 K frames of the mark (a
single row, 18 K frames, is noisy), then the run's end: frames, and hits, KL and clip
fraction averaged over its last ten rows.
Nothing is trained or played: the table is a view of the committed curves
(``benchmarks/tennis_play.py`` measures the teams themselves).

Usage::

    python -m benchmarks.tennis_probes
    python -m benchmarks.tennis_probes --marks 0.5 1 2 3 --presets probe_gaussian long
"""

from __future__ import annotations

import argparse
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from rlhc.analysis.curves import METRICS_FILE, read_metrics

RESULTS = Path(__file__).resolve().parent / "results" / "learning" / "tennis"
HITS = "events/hits_over_net_per_episode"
#: Frames (millions) at which the curves are read: the paper's budget (3.6 M), then 10 M.
MARKS = (0.5, 1.0, 2.0, 3.5, 5.0, 7.0, 10.0)
#: Half-width of the window averaged at each mark (frames).
HALF_WINDOW = 125_000
#: Rows averaged at the end of a run (hits, KL and clip fraction).
LAST_ROWS = 10
#: Preset name prefixes read besides the paper preset.
PREFIXES = ("probe", "long")


def run_directories(presets: Sequence[str] | None) -> list[Path]:
    """Every probe and long run (or those of ``presets``), then the paper preset's PPO runs."""
    runs = sorted(run for prefix in PREFIXES for run in RESULTS.glob(f"{prefix}*/*/seed_*"))
    if presets:
        unknown = sorted(set(presets) - {run.parents[1].name for run in runs})
        if unknown:
            raise SystemExit(f"tennis_probes: error: no runs of preset(s) {unknown} in {RESULTS}")
        runs = [run for run in runs if run.parents[1].name in presets]
    return [run for run in runs if (run / METRICS_FILE).is_file()] + sorted(
        RESULTS.glob("paper/ppo/seed_*")
    )


def curve_row(run: Path, marks: Sequence[float]) -> str:
    """One table row: the run's hits at each mark, its last frames, hits, KL and clips."""
    columns = read_metrics(run / METRICS_FILE)
    frames, hits = columns["step"], columns[HITS]
    cells = []
    for mark in marks:
        near = np.abs(frames - mark * 1e6) <= HALF_WINDOW
        cells.append(f"{np.mean(hits[near]):.2f}" if near.any() else "")
    nan = np.full(len(frames), np.nan)
    kl = np.nanmean(columns.get("racket/kl_approx", nan)[-LAST_ROWS:])
    clip = np.nanmean(columns.get("racket/clip_fraction", nan)[-LAST_ROWS:])
    name = str(run.relative_to(RESULTS))
    return (
        f"| {name} | " + " | ".join(cells) + f" | {frames[-1] / 1e6:.2f} M | "
        f"{np.mean(hits[-LAST_ROWS:]):.2f} | {kl:.4f} | {clip:.3f} |"
    )


def table(runs: Sequence[Path], marks: Sequence[float]) -> str:
    """The Markdown table of :func:`curve_row` rows."""
    header = (
        "| run | "
        + " | ".join(f"{mark:g} M" for mark in marks)
        + " | last | hits (last 10) | KL (last 10) | clip (last 10) |"
    )
    rule = "|---|" + "---:|" * (len(marks) + 4)
    return "\n".join([header, rule, *(curve_row(run, marks) for run in runs)])


def main(argv: Sequence[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--marks", type=float, nargs="+", default=list(MARKS),
                        help="frames (millions) at which to read the curves")  # fmt: skip
    parser.add_argument("--presets", nargs="+", help="only these probe presets")
    args = parser.parse_args(argv)
    print(table(run_directories(args.presets), args.marks))


if __name__ == "__main__":
    main()
