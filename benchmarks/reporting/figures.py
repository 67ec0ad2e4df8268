"""The report's figures: drawing only; the runs they show are read by the caller.

``RESULTS.md``'s curves per study are :func:`rlhc.analysis.drawing.plot_groups`'s (the paper's
four metrics plus, in a game, whether the teams play).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path

from rlhc.analysis.curves import PAPER_METRICS, Run
from rlhc.analysis.drawing import plot_groups

from .runs import StudyRun
from .study import PLAY_METRIC, SMOOTHING


def draw_study_curves(env: str, members: Sequence[StudyRun], out: Path) -> Path:
    """A study's curves, one line per configuration (mean over seeds, 95% t band).

    Args:
        env: the game (adds its play metric: hits per point, goal rate) or another
            library's env (the paper's metrics alone).
        members: the complete runs to draw, each labelled ``study/config``.
        out: the PNG to write.

    Returns:
        ``out``.
    """
    metrics = dict(PAPER_METRICS)
    bounds = {"episode_length": (0.0, math.inf)}
    play = PLAY_METRIC.get(env)
    if play is not None:
        leaf = play.column.rpartition("/")[2]
        metrics[leaf] = play.title
        bounds[leaf] = play.bounds
    groups: dict[str, list[Run]] = {}
    for run in members:
        groups.setdefault(run.name, []).append(run.curves())
    return plot_groups(groups, out, SMOOTHING, metrics, columns=3, bounds=bounds)
