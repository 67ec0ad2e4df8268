"""The report's figures: drawing only; the runs they show are read by the caller.

``RESULTS.md``'s curves per study are :func:`rlhc.analysis.drawing.plot_groups`'s (the paper's
four metrics plus whether the teams play); ``benchmarks/learning.py``'s panels per game
are :func:`draw_learning_curves`'s.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from pathlib import Path

from rlhc.analysis.curves import PAPER_METRICS, Run, aggregate
from rlhc.analysis.drawing import plot_groups, save_figure

from .runs import StudyRun
from .study import PLAY_METRIC, SMOOTHING


def draw_study_curves(env: str, members: Sequence[StudyRun], out: Path) -> Path:
    """A study's curves, one line per configuration (mean over seeds, 95% t band).

    Args:
        env: the game (adds its play metric: hits per point, goal rate).
        members: the complete runs to draw, each labelled ``study/config``.
        out: the PNG to write.

    Returns:
        ``out``.
    """
    play = PLAY_METRIC[env]
    leaf = play.column.rpartition("/")[2]
    metrics = {**PAPER_METRICS, leaf: play.title}
    bounds = {"episode_length": (0.0, math.inf), leaf: play.bounds}
    groups: dict[str, list[Run]] = {}
    for run in members:
        groups.setdefault(run.name, []).append(run.curves())
    return plot_groups(groups, out, SMOOTHING, metrics, columns=3, bounds=bounds)


def draw_learning_curves(
    runs: Mapping[str, Sequence[Run]],
    panels: Mapping[str, str],
    title: str,
    out: Path,
    smoothing: float,
    bounds: Mapping[str, tuple[float, float]] | None = None,
) -> Path:
    """One panel per metric, one line per critic: the mean over its seeds (each
    TensorBoard-smoothed), shaded by the 95% t interval across seeds.

    Args:
        runs: critic -> its runs (metrics read).
        panels: ``metrics.csv`` column -> panel title.
        title: the figure's title.
        out: the PNG to write.
        smoothing: TensorBoard smoothing weight, in ``[0, 1)``.
        bounds: ``metrics.csv`` column -> the values it can take; its band is clipped
            there (:func:`rlhc.analysis.curves.aggregate`), the mean is not. Others are unbounded.

    Returns:
        ``out``.
    """
    import matplotlib

    matplotlib.use("Agg")  # files only: never needs a display
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, len(panels), figsize=(4.6 * len(panels), 3.6), squeeze=False)
    for ax, (metric, label) in zip(axes.flat, panels.items(), strict=True):
        for critic, members in runs.items():
            limits = (bounds or {}).get(metric, (-math.inf, math.inf))
            curve = aggregate(members, metric, smoothing, bounds=limits)
            if curve is None:
                continue
            seeds = f"{curve.runs} seed{'s' if curve.runs > 1 else ''}"
            (line,) = ax.plot(curve.steps, curve.mean, label=f"{critic} ({seeds})")
            if curve.runs > 1:
                ax.fill_between(
                    curve.steps, curve.low, curve.high, color=line.get_color(), alpha=0.2
                )
        if ax.lines:
            ax.legend(fontsize="small")
        else:  # e.g. soccer before its first episode ends
            ax.text(0.5, 0.5, "not logged", ha="center", va="center", transform=ax.transAxes)
        ax.set_title(label)
        ax.set_xlabel("frames (world-decisions)")
        ax.grid(alpha=0.3)
    fig.suptitle(f"{title} (smoothing {smoothing})")
    fig.tight_layout()
    out.parent.mkdir(parents=True, exist_ok=True)
    save_figure(fig, out)
    plt.close(fig)
    return out
