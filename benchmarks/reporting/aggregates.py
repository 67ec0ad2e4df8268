"""Aggregates over games, as rliable computes them (Agarwal et al. 2021).

A run's score is its final team's mean match score against the built-in teams (the mean
of its scores against ``scripted`` and ``random``, each wins + draws / 2 per match, from
the study's round robin, :mod:`reporting.standings`): one number in ``[0, 1]`` per run,
on the same scale in both games. A *task* is a study; per critic, the IQM of the scores
of every task pooled, with a stratified bootstrap interval
(:func:`rlhc.evaluation.stats.iqm_interval`), and for each compared pair the probability
that a run of the first beats a run of the second on a random task, with its interval
(:func:`rlhc.evaluation.stats.probability_of_improvement`). A pair is given a verdict
only if its runs are enough for one: a side with one run in a task has no spread to
resample, and with few runs even a complete separation is likely by chance (2 runs
against 2: p = 1/3; :func:`rlhc.evaluation.stats.separation_p_value`), while the
bootstrap interval of such a split is a single point.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

from rlhc.evaluation.stats import iqm_interval, probability_of_improvement, separation_p_value

from .formatting import table
from .plan import Study
from .runs import StudyRun
from .standings import BUILT_IN, built_in_scores, store_of
from .study import ALPHA, CRITICS
from .tournament import Series, load_series

#: Groups of tasks aggregated together: the paper's budget, and beyond it (where the two
#: games' presets differ in more than the budget, each game also alone).
TASK_GROUPS = {
    "the paper's budget": ("tennis_paper", "tennis_extended", "soccer_paper"),
    "beyond the paper's budget": ("soccer_best", "tennis_best"),
    "beyond the paper's budget, soccer alone": ("soccer_best",),
    "beyond the paper's budget, tennis alone": ("tennis_best",),
}


def run_scores(study: Study, runs: Sequence[StudyRun], config: str) -> list[float]:
    """Per complete run of ``study/config``: its mean score against the built-in teams.

    Runs missing a series against one of the built-in teams are left out.
    """
    series: list[Series] = load_series(store_of(study)) if store_of(study).is_file() else []
    by_opponent = [
        built_in_scores(series, runs, f"{study.name}/{config}", opponent) for opponent in BUILT_IN
    ]
    common = set.intersection(*(set(found.seeds) for found in by_opponent))
    return [
        sum(dict(zip(found.seeds, found.scores, strict=True))[seed] for found in by_opponent)
        / len(by_opponent)
        for seed in sorted(common)
    ]


def aggregates_section(
    plan: Mapping[str, Study], runs: Sequence[StudyRun]
) -> tuple[list[str], list[str]]:
    """IQM per critic and probability of improvement per pair, per task group; verdicts."""
    lines: list[str] = []
    verdicts: list[str] = []
    for group, names in TASK_GROUPS.items():
        tasks = [plan[name] for name in names if name in plan]
        scores = {
            (task.name, critic): run_scores(task, runs, critic)
            for task in tasks
            for critic in task.configs
        }
        iqm_rows = []
        for critic in CRITICS:
            per_task = [(t, s) for (t, c), s in scores.items() if c == critic and s]
            if not per_task:
                continue
            estimate = iqm_interval([s for _, s in per_task])
            iqm_rows.append(
                [
                    f"`{critic}`",
                    ", ".join(f"`{t}` ({len(s)})" for t, s in per_task),
                    f"{estimate.value:.3f} [{estimate.low:.3f}, {estimate.high:.3f}]",
                ]
            )
        poi_rows = []
        for first, second in ((a, b) for i, a in enumerate(CRITICS) for b in CRITICS[i + 1 :]):
            shared = [
                t.name
                for t in tasks
                if scores.get((t.name, first)) and scores.get((t.name, second))
            ]
            if not shared:
                continue
            estimate = probability_of_improvement(
                [scores[(t, first)] for t in shared], [scores[(t, second)] for t in shared]
            )
            cell = f"{estimate.value:.3f} [{estimate.low:.3f}, {estimate.high:.3f}]"
            sizes = [(len(scores[(t, first)]), len(scores[(t, second)])) for t in shared]
            floor = separation_p_value(sizes)
            if min(min(size) for size in sizes) < 2:
                cell += " (a side has 1 run in a task: no interval, no verdict)"
            elif floor > ALPHA:
                cell += (
                    f" (too few runs for a verdict: even a complete separation of them has"
                    f" p = {floor:.2f} > {ALPHA})"
                )
            else:
                verdicts.append(poi_verdict(group, first, second, shared, estimate))
            poi_rows.append(
                [f"P(`{first}` > `{second}`)", ", ".join(f"`{t}`" for t in shared), cell]
            )
        lines += [f"**{group}**", ""]
        if not iqm_rows:
            lines += ["No run with scores against both built-in teams yet.", ""]
            continue
        lines += [
            *table(
                ["critic", "tasks (runs)", "IQM of scores [95% stratified bootstrap]"], iqm_rows
            ),
            "",
            *table(["probability of improvement", "tasks", "value [95% CI]"], poi_rows),
            "",
        ]
    return lines, verdicts


def poi_verdict(group: str, first: str, second: str, tasks: Sequence[str], estimate: object) -> str:
    """A neutral sentence on a probability of improvement and its interval."""
    value, low, high = (float(getattr(estimate, k)) for k in ("value", "low", "high"))
    if low > 0.5:
        how = f"a run of `{first}` is more likely than not to outscore a run of `{second}`"
    elif high < 0.5:
        how = f"a run of `{first}` is less likely than not to outscore a run of `{second}`"
    else:
        how = f"`{first}` and `{second}` are not distinguishable"
    where = ", ".join(f"`{t}`" for t in tasks)
    return (
        f"{group.capitalize()} ({where}): {how} (P = {value:.3f}, 95% CI [{low:.3f}, {high:.3f}])."
    )
