"""Sample efficiency: does a critic reach play sooner, not only end higher?

The paper claims that RLHC "speeds up learning". Finals (:mod:`reporting.markdown`) and
steps to one threshold (:func:`reporting.document.play_and_speed`) each look at one point
of the curve; this section reads the whole of it, for the game's play metric
(:data:`reporting.study.PLAY_METRIC`: tennis hits over the net per point, soccer goal
rate), the tennis policy's hits per point with itself where the runs measured it
(``play_freq``), and, where the runs logged periodic matches (``eval_freq``), the score
against the scripted team (wins + draws / 2 per match):

* the smoothed curve (EMA, as every curve of the report) at a quarter, half, three
  quarters and all of the budget, mean over seeds [95% t];
* the **mean over training**: the area under the raw curve divided by the steps it
  spans (trapezoids between logged rows, from the first row to the last), one number
  per seed; a critic that learns faster has the larger area at equal finals. RLHC's
  against PPO's (and the twin control's) with Welch's test, as the finals are.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import NamedTuple

import numpy as np

from rlhc.analysis.curves import Run

from .formatting import fmt_interval, positive_interval, share_interval, table
from .plan import Study
from .runs import StudyRun, complete_runs
from .statistics import Comparison, corrected, smoothed
from .study import PLAY_METRIC, SMOOTHING, comparisons_of, table_configs

#: Shares of the budget at which the curves are read.
MARKS = (0.25, 0.5, 0.75, 1.0)
#: ``metrics.csv`` columns of the periodic matches against the scripted team.
WIN_RATE, DRAW_RATE = "eval/win_rate", "eval/draw_rate"
#: The derived column of the match score (wins + draws / 2), added by :func:`score_curve`.
SCORE = "eval/score"
#: ``metrics.csv`` column of the live tennis policy's play with itself (``play_freq``):
#: unlike the training episodes' hits, which mix the league's opponents, one opponent.
SELF_PLAY = "play/hits_per_point"


class Measure(NamedTuple):
    """A curve this section reads: its column, its name in the text, whether a share."""

    column: str
    title: str
    share: bool


def score_curve(run: Run) -> Run:
    """``run`` with :data:`SCORE` = win rate + draw rate / 2, where both were logged.

    Examples:
        >>> import numpy as np
        >>> from pathlib import Path
        >>> run = Run(Path("r"), {"step": np.array([1.0, 2.0]),
        ...                       "eval/win_rate": np.array([0.5, np.nan]),
        ...                       "eval/draw_rate": np.array([0.2, np.nan])})
        >>> score_curve(run).columns["eval/score"].tolist()
        [0.6, nan]
    """
    if WIN_RATE not in run.columns or DRAW_RATE not in run.columns:
        return run
    columns = dict(run.columns)
    columns[SCORE] = run.columns[WIN_RATE] + run.columns[DRAW_RATE] / 2
    return Run(run.path, columns, run.config)


def mean_over_training(run: Run, column: str) -> float | None:
    """The area under the logged (unsmoothed) curve over the steps it spans, divided by
    them; the value itself for a single row; ``None`` if the column was never logged.

    Examples:
        >>> import numpy as np
        >>> from pathlib import Path
        >>> run = Run(Path("r"), {"step": np.array([0.0, 1.0, 3.0]),
        ...                       "hits": np.array([0.0, 2.0, 2.0])})
        >>> mean_over_training(run, "hits")  # (0 + 2) / 2 * 1 + 2 * 2, over 3 steps
        1.6666666666666667
    """
    if column not in run.columns:
        return None
    values = run.columns[column]
    logged = np.isfinite(values)
    steps, values = run.steps[logged], values[logged]
    if not steps.size:
        return None
    span = float(steps[-1] - steps[0])
    if span <= 0:
        return float(values.mean())
    area = np.sum((values[1:] + values[:-1]) / 2 * np.diff(steps))  # trapezoids
    return float(area / span)


def value_at(run: Run, column: str, step: float) -> float | None:
    """The smoothed curve at its last logged row at or before ``step`` (``None``: none)."""
    steps, curve = smoothed(run, column, SMOOTHING)
    before = np.flatnonzero(steps <= step)
    return float(curve[before[-1]]) if before.size else None


def measures(study: Study, runs: Sequence[StudyRun]) -> list[Measure]:
    """The study's play metric, the live policy's play with itself where a run measured
    it (``play_freq``), and the match score where a run logged matches."""
    play = PLAY_METRIC[study.env]
    found = [Measure(play.column, play.title, play.share)]
    if study.env == "tennis" and any(SELF_PLAY in run.curves().columns for run in runs):
        found.append(Measure(SELF_PLAY, "hits over the net per point with itself (play/)", False))
    if any(WIN_RATE in run.curves().columns for run in runs):
        found.append(Measure(SCORE, "score against the scripted team", True))
    return found


def efficiency_section(study: Study, runs: Sequence[StudyRun]) -> tuple[list[str], list[str]]:
    """The section's Markdown lines and the verdicts of its tests (one per pair, measure)."""
    table_runs = {
        name: members for name in table_configs(study) if (members := complete_runs(runs, name))
    }
    members = [run for group in table_runs.values() for run in group]
    if not members:
        return [], []
    lines = [
        "Sample efficiency: the smoothed curve at shares of the budget and the mean over "
        "training (area under the logged curve over the steps it spans: the larger, the "
        "sooner a team played), mean over seeds [95% t]:",
        "",
    ]
    verdicts: list[str] = []
    budget = study.max_steps
    curves_of = {
        name: [score_curve(run.curves()) for run in group] for name, group in table_runs.items()
    }
    for measure in measures(study, members):
        interval = share_interval if measure.share else positive_interval
        areas: dict[str, list[float]] = {}
        rows = []
        for name, curves in curves_of.items():
            cells = []
            for mark in MARKS:
                values = [
                    v
                    for c in curves
                    if (v := value_at(c, measure.column, mark * budget)) is not None
                ]
                cells.append(fmt_interval(interval(values), 3) if values else "—")
            areas[name] = [
                v for c in curves if (v := mean_over_training(c, measure.column)) is not None
            ]
            area = fmt_interval(interval(areas[name]), 3) if areas[name] else "—"
            rows.append([f"`{name}`", *cells, area])
        marks = [f"at {mark:.0%} ({mark * budget / 1e6:.2g} M)" for mark in MARKS]
        lines += [
            f"*{measure.title}*",
            "",
            *table(["config", *marks, "mean over training"], rows),
            "",
        ]
        comparisons = [
            Comparison(first, second, "team", tuple(areas[first]), tuple(areas[second]))
            for first, second in comparisons_of(study)
            if areas.get(first) and areas.get(second)
        ]
        verdicts += [
            c.verdict(f"mean {measure.title} over training") for c in corrected(comparisons)
        ]
    return lines, verdicts
