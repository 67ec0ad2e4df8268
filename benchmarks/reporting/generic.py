"""A study on another library's env (VMAS, PettingZoo): what it trains on, its section's text.

Such an env has no scripted team and no rules of play, so a configuration is compared by
each group's return alone: the finals and Welch's tests of :mod:`reporting.markdown`, as
in a game, on ``<group>/cumulative_reward`` (its groups are those the runs logged,
:func:`reporting.study.groups_of`). Its section has no play metric, it plays no round
robin, and it is left out of the aggregates over games (:mod:`reporting.aggregates`),
whose score is a match score.
"""

from __future__ import annotations

import json
import os
from collections.abc import Sequence

from rlhc.evaluation.stats import t_interval

from ..cross_play import FILE, advantages, per_seed, read_rows
from .formatting import fmt_interval, table
from .markdown import finals_note, speed_cells
from .plan import ROOT, Study
from .runs import StudyRun, complete_runs
from .statistics import window_points
from .study import SMOOTHING, table_configs


def task_lines(study: Study) -> list[str]:
    """The env, task and options the study trains on, its frames, and why it has no matches.

    Raises:
        ValueError: ``study`` is a game's (it has no task).
    """
    task = study.task
    if task is None:
        raise ValueError(f"{study.name} trains on a game, not on another library's env")
    kwargs = ", ".join(f"{key}: {json.dumps(value)}" for key, value in task.kwargs)
    cycles = "" if task.max_cycles is None else f" `env.max_cycles={task.max_cycles}`"
    return [
        f"Environment: `env={study.env}` `env.{task.key}={task.name}` "
        f"`env.kwargs={{{kwargs}}}`{cycles}; {study.max_steps:,} frames per run.",
        "",
        "The env has no scripted team: no play metric and no matches, and the study is left "
        "out of the aggregates over games.",
    ]


def returns_note(members: Sequence[StudyRun], groups: Sequence[str]) -> str:
    """What the study's figure and tables show: the groups' returns, and how finals are made;
    with several ``groups``, that each group's return is measured against the others'
    learners of the same run."""
    return (
        f"The paper's four metrics, mean over complete seeds with a 95% t band, EMA "
        f"{SMOOTHING} smoothing; a group's cumulative reward is an episode's return averaged "
        "over the group's agents and over the episodes that ended since the previous row, "
        "the number the critics are compared by. "
        + finals_note("steps, lengths, speeds")
        + f" Here the final window holds {window_points(members)} logged points per run."
        + (contest_note(groups) if len(groups) > 1 else "")
    )


def contest_note(groups: Sequence[str]) -> str:
    """Why a group's return, with several groups, does not rank its critic alone."""
    names = ", ".join(f"`{group}`" for group in groups)
    return (
        f" Its groups ({names}) all learn with the run's critic, each against the others: "
        "where their rewards oppose, a configuration's return for one group is the outcome "
        "of a contest between two learners of that configuration, so a difference between "
        "configurations compares two contests, not one group's learner against a fixed "
        "opponent. The cross-play below compares the learners."
    )


def cross_play_lines(study: Study) -> list[str]:
    """The study's cross-play (``<root>/cross_play.csv``, :mod:`benchmarks.cross_play`):
    each group's advantage per pair of configurations, mean over seeds [95% t]."""
    command = f"python -m benchmarks.cross_play {os.path.relpath(study.root, ROOT)}"
    values = [
        v
        for v in advantages(read_rows(study.root / FILE))
        if {v.first, v.second} <= set(study.configs)
    ]
    if not values:
        return [f"**Cross-play** — not played yet: `{command}` plays it (from the final teams)."]
    rows = []
    for (group, first, second), seeds in sorted(per_seed(values).items()):
        interval = t_interval(seeds)
        verdict = "no difference shown"
        if interval.n < 2:
            verdict = "— (needs ≥ 2 seeds)"
        elif interval.low > 0:
            verdict = f"`{first}`'s {group} better"
        elif interval.high < 0:
            verdict = f"`{second}`'s {group} better"
        cells = [f"`{first}` vs `{second}`", group, str(interval.n), fmt_interval(interval)]
        rows.append([*cells, verdict])
    episodes = sorted({row["episodes"] for row in read_rows(study.root / FILE)})
    return [
        f"**Cross-play** (`{command}`): at each seed both configurations finished, every "
        "lineup of their final teams (each group played by either) plays the same "
        f"{'/'.join(episodes)} episodes with mode actions; a group's *advantage* is how much "
        "more it returns when the first configuration plays it than when the second does, "
        "against the same opponents (the mean over the opponents' two assignments). Mean "
        "over seeds [95% t]; a verdict where the interval excludes 0:",
        "",
        *table(["pair", "group", "seeds", "advantage", "verdict"], rows),
    ]


def speed_table(study: Study, runs: Sequence[StudyRun]) -> list[str]:
    """Training speed per configuration, mean over seeds [95% t]."""
    rows = [
        [f"`{name}`", *speed_cells(members)]
        for name in table_configs(study)
        if (members := complete_runs(runs, name))
    ]
    return [
        "Training speed: frames per second of training wall time (collection + updates) and "
        "env steps per second of collection alone (one env step = one frame = one decision "
        "of one world, all its agents). Mean over seeds [95% t]:",
        "",
        *table(["config", "frames/s (training)", "env steps/s (collection)"], rows),
    ]
