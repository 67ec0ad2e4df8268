"""The sections of ``RESULTS.md`` on the runs, their settings and their finals.

Each function returns the section's Markdown lines; :mod:`reporting.document` puts
them together. The matches' section is :func:`reporting.head_to_head.matches_section`.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from rlhc.evaluation.stats import t_interval

from .formatting import fmt, fmt_interval, fmt_reach, positive_interval, table
from .plan import TASK_KEYS, Study
from .runs import StudyRun, complete_runs, config_drift
from .statistics import Comparison, config_finals, corrected, fill_reach, finite, window_points
from .study import ALPHA, PLAY_METRIC, POWER, SMOOTHING, comparisons_of, groups_of, table_configs

#: Table 3 of the paper: recorded config key -> its row label.
SETTINGS = (
    ("algo.batch_size", "batch size"),
    ("algo.buffer_size", "buffer size"),
    ("algo.time_horizon", "time horizon"),
    ("algo.gamma", "gamma"),
    ("algo.lmbda", "lambda"),
    ("algo.max_steps", "max steps"),
    ("algo.normalize_observations", "normalise obs"),
    ("model.num_layers", "layers"),
    ("model.hidden_size", "hidden units"),
    ("algo.lr", "learning rate"),
    ("algo.entropy_coef", "beta (entropy)"),
    ("algo.clip_epsilon", "epsilon (clip)"),
    ("algo.epochs", "epochs"),
    ("logger.summary_freq", "summary freq"),
    ("env.num_envs", "worlds per env (null: buffer / horizon)"),
    ("threads", "torch threads per run"),
)


def runs_section(runs: Sequence[StudyRun], plan: Mapping[str, Study]) -> list[str]:
    """Which runs exist, which are complete, and their wall time (from their summaries)."""
    rows = []
    for name, study in plan.items():
        for config in study.configs:
            mine = [r for r in runs if r.study == name and r.config == config]
            done = [r for r in mine if r.complete]
            partial = [
                f"seed {r.seed} ({f'{r.frames:,} frames' if r.frames else 'no summary yet'})"
                for r in mine
                if not r.complete
            ]
            frames = sorted({r.frames for r in done if r.frames is not None})
            times = [r.wall_time for r in done]
            versions = dict.fromkeys(
                v[:7] for r in done if r.summary for v in (r.summary.code_versions or ())
            )
            rows.append(
                [
                    f"`{name}/{config}`",
                    f"`study={name} critic={config}`",
                    f"{study.max_steps:,}",
                    ", ".join(f"{f:,}" for f in frames) or "—",
                    f"{len(done)} of {len(study.seeds)}",
                    ", ".join(str(r.seed) for r in done) or "—",
                    "; ".join(partial) or "—",
                    fmt_interval(
                        positive_interval([t for t in times if math.isfinite(t)]), 0, fixed=True
                    ),
                    ", ".join(f"`{v}`" for v in versions) or "—",
                ]
            )
    header = [
        "config",
        "overrides",
        "max steps",
        "frames trained (complete runs)",
        "complete seeds",
        "seeds",
        "unfinished (excluded)",
        "wall time per run, s",
        "code versions (commits trained at)",
    ]
    total = sum(r.wall_time for r in runs if r.complete)
    return [
        *table(header, rows),
        "",
        f"Total training wall time of the {sum(r.complete for r in runs)} complete runs: "
        f"{total:,.0f} s ({total / 3600:.2f} h, summed over runs, which trained concurrently). "
        "Wall time is the trainer's `wall_time` in the last row of `metrics.csv` "
        "(collection + updates, carried across resumes).",
    ]


def environment_of(config: dict[str, Any]) -> str:
    """A recorded config's game, or another library's env with its task (whose settings
    differ from task to task): ``tennis``, ``vmas navigation``."""
    tasks = [config[f"env.{key}"] for key in TASK_KEYS.values() if f"env.{key}" in config]
    return " ".join([str(config.get("env.name")), *map(str, tasks)])


def settings_section(runs: Sequence[StudyRun]) -> list[str]:
    """Table 3 values as the complete runs' configs recorded them, per game (or task)."""
    by_env: dict[str, dict[str, Any]] = {}
    for run in runs:
        if run.complete:
            config = run.curves().config
            by_env.setdefault(environment_of(config), config)
    if not by_env:
        return ["No complete run yet."]
    games = sorted(by_env)
    rows = [[label] + [f"`{by_env[g].get(key)}`" for g in games] for key, label in SETTINGS]
    return table(["setting", *games], rows)


def drift_lines(runs: Sequence[StudyRun]) -> list[str]:
    """The notes of :func:`reporting.runs.config_drift`, or that there are none."""
    notes, added = config_drift(runs)
    lines = []
    if added:
        lines += [
            "Options added to the code while the study ran, absent from the configs of the "
            "runs that started earlier and recorded with one value by the others: "
            + ", ".join(f"`{key}`" for key in added)
            + ".",
            "",
        ]
    if not notes:
        return [*lines, "Otherwise every seed of a configuration recorded the same config.", ""]
    return [
        *lines,
        "Recorded configs that differ between seeds of one configuration (*absent*: the key "
        "did not exist when that run started):",
        "",
        *[f"- {note}" for note in notes],
        "",
    ]


def finals_note(nonnegative: str) -> str:
    """How a study's tables compute finals, intervals and steps to threshold.

    Args:
        nonnegative: what its tables show that cannot be negative (intervals clipped at 0).
    """
    return (
        "Finals: per run, the mean of the last 10% (by steps) of the smoothed curve; tables "
        "give the mean over seeds with its 95% t interval (clipped at 0 for what cannot be "
        f"negative: {nonnegative}; to [0, 1] for shares). Steps to threshold: mean [95% t] "
        "of the seeds that reached it."
    )


def speed_cells(members: Sequence[StudyRun]) -> list[str]:
    """A configuration's training speed over its complete runs, mean [95% t]: frames per
    second of training wall time, and env steps per second of collection alone."""
    speeds = [r.frames / r.wall_time for r in members if r.frames and r.wall_time > 0]
    env_rates = [
        float(np.nanmean(r.curves().columns["env_steps_per_s"]))
        for r in members
        if "env_steps_per_s" in r.curves().columns
    ]
    return [
        fmt_interval(positive_interval(speeds), 0, fixed=True),
        fmt_interval(positive_interval(env_rates), 0, fixed=True),
    ]


def finals_section(
    study: Study, runs: Sequence[StudyRun], fraction: float
) -> tuple[list[str], list[Comparison]]:
    """Per group: the finals table with steps to threshold; Welch's tests."""
    lines: list[str] = []
    comparisons: list[Comparison] = []
    for group in groups_of(study, runs):
        tables = [
            config_finals(name, complete_runs(runs, name), group) for name in table_configs(study)
        ]
        level = fill_reach(tables, runs, group, fraction)
        rows = [
            [
                f"`{c.name}`",
                str(len(c.seeds)),
                fmt_interval(t_interval(c.reward)),
                fmt_reach(c.reach),
                fmt_interval(positive_interval(finite(c.episode_length)), 3),
                fmt_interval(t_interval(finite(c.entropy)), 3),
            ]
            for c in tables
        ]
        header = [
            "config",
            "seeds",
            f"final `{group}/cumulative_reward`",
            "steps to threshold (mean of seeds that reached it)",
            "final episode length",
            f"final `{group}/entropy`",
        ]
        where = (
            f"threshold {fmt(level)} ({fraction:.0%} of the way from the mean initial value "
            "of all runs in this table to the best configuration's mean final value)"
            if level is not None
            else "no threshold: no configuration's mean final value is above the mean initial value"
        )
        lines += [f"**{group}** — {where}.", "", *table(header, rows), ""]
        by_name = {c.name: c for c in tables}
        for rlhc, ppo in comparisons_of(study):
            a, b = by_name[rlhc], by_name[ppo]
            comparisons.append(Comparison(rlhc, ppo, group, tuple(a.reward), tuple(b.reward)))
    comparisons = corrected(comparisons)
    tests = sum(c.testable for c in comparisons)
    rows = []
    for c in comparisons:
        result, detectable = c.test(), c.detectable()
        diff = (
            float(np.mean(c.rlhc_values) - np.mean(c.ppo_values))
            if c.rlhc_values and c.ppo_values
            else math.nan
        )
        rows.append(
            [
                f"`{c.rlhc}` vs `{c.ppo}`",
                c.group,
                f"{len(c.rlhc_values)} vs {len(c.ppo_values)}",
                fmt(diff),
                f"{result[0]:.3f}" if result else "—",
                f"{result[1]:.3g}" if result else "— (needs ≥ 2 seeds per side)",
                f"{c.family_p:.3g}" if c.family_p is not None else "—",
                fmt(detectable) if detectable is not None else "—",
            ]
        )
    lines += [
        "Welch's t-test (two-sided, unequal variances), first config vs second (the "
        "paper's critics pairwise: hierarchical, twin, PPO; for the extensions, each vs "
        "`tennis_paper`'s hierarchical and PPO). Samples: one value "
        "per completed seed — the mean of the last 10% (by steps) of that run's "
        f"TensorBoard-smoothed (EMA {SMOOTHING}) `<group>/cumulative_reward` curve. "
        + (
            f"Holm's p corrects for the {tests} test{'s' if tests != 1 else ''} of this "
            "table (a difference is claimed below only where it is under alpha); "
            "*detectable* is the smallest mean difference these seeds find with power "
            f"{POWER} at alpha {ALPHA} (Welch, from the measured spread; optimistic at 3 "
            "seeds a side)."
            if tests
            else "No test yet: each needs 2 complete seeds per side."
        ),
        "",
        *table(
            [
                "first vs second",
                "group",
                "seeds",
                "mean difference",
                "t",
                "p",
                "p (Holm)",
                "detectable",
            ],
            rows,
        ),
    ]
    return lines, comparisons


def game_note(study: Study, members: Sequence[StudyRun]) -> str:
    """What a game's figure and tables show, and why its returns do not say who plays."""
    return (
        f"The paper's four metrics and {PLAY_METRIC[study.env].title}, mean over complete "
        f"seeds with a 95% t band, EMA {SMOOTHING} smoothing. "
        + finals_note("steps, lengths, hits, goals, speeds")
        + f" Here the final window holds {window_points(members)} logged points per run. In "
        "self-play both teams are the same policy, so a group's cumulative reward says how "
        "the game's reward splits between roles and sides, not how well the team plays; the "
        "matches below measure that."
    )
