"""Report of the RLHC-vs-PPO reproduction: ``docs/RESULTS.md`` from the study's runs.

Reads the runs that ``benchmarks/reproduce.py`` writes under
``benchmarks/results/reproduce/<study>/<config>/seed_<k>/`` and writes every number of
``docs/RESULTS.md`` (nothing in that file is typed by hand):

* which runs are complete (``checkpoints/latest.pt`` reached the study's ``max_steps``);
  unfinished runs are listed and left out of every statistic;
* per study and group metric: the final value of each run — the mean of the last 10%
  (by steps) of its TensorBoard-smoothed curve (EMA 0.8, as ``python -m rlhc.plot``) —
  averaged over seeds with a 95% Student t interval; steps to reach a threshold; the
  final episode length and entropy;
* Welch's t-test of RLHC against PPO on those per-seed final values;
* the paper's four curves per study (:func:`rlhc.plotting.plot_runs`);
* head-to-head matches of the final RLHC team against the final PPO team (seed k vs
  seed k, sides swapped every match, deterministic actions) and of every final team
  against the scripted team, with 95% Wilson intervals.

Usage::

    python benchmarks/report.py                                  # 100 matches per pairing
    python benchmarks/report.py --matches 10 --out /tmp/RESULTS.md
    python benchmarks/report.py --matches 0                      # curves and tests only
"""

from __future__ import annotations

import argparse
import math
import os
import platform
import subprocess
import sys
import time
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass
from importlib import metadata
from pathlib import Path

import numpy as np

from rlhc.evaluation.stats import MeanInterval, t_interval, welch_t_test, wilson_interval
from rlhc.plotting import METRICS_FILE, Run, ema_smooth, final_values, read_config, read_metrics

sys.path.insert(0, str(Path(__file__).resolve().parent))
from reproduce import RESULTS, STUDIES  # a sibling script, not a package

ROOT = Path(__file__).resolve().parents[1]
SMOOTHING = 0.8  # TensorBoard's EMA weight, as ``python -m rlhc.plot``
FINAL_FRACTION = 0.1  # the last 10% of each curve, by steps
THRESHOLD_FRACTION = 0.5  # share of the way from the initial to the best final reward
ALPHA = 0.05
#: study -> its group metrics' groups.
GROUPS = {"tennis": ("racket",), "soccer": ("striker", "goalie")}
#: study -> (RLHC config, PPO config) pairs compared by Welch's test and by matches.
PAIRS: dict[str, list[tuple[str, str]]] = {
    "tennis": [("hierarchical", "ppo"), ("hierarchical_extended", "ppo_extended")],
    "soccer": [("hierarchical", "ppo")],
}
#: Studies whose tables also hold configs of another study (``study/config``).
BORROWED = {"tennis_extensions": ("tennis/ppo", "tennis/hierarchical")}
#: Config keys that tell a study's configurations apart (plot labels and groups).
GROUP_BY = {
    "tennis": ("critic.fusion", "env.extended_obs"),
    "soccer": ("critic.fusion",),
    "tennis_extensions": ("critic.fusion", "critic.manager_interval"),
}
VERSIONED = ("torch", "torchrl", "tensordict", "pymunk", "pettingzoo", "numpy")


# --------------------------------------------------------------------------- runs


@dataclass
class StudyRun:
    """One run directory of the study and how far it got."""

    study: str
    config: str
    seed: int
    path: Path
    frames: int | None  # of ``checkpoints/latest.pt``; ``None``: no checkpoint yet
    max_steps: int

    @property
    def complete(self) -> bool:
        return self.frames is not None and self.frames >= self.max_steps

    @property
    def name(self) -> str:
        return f"{self.study}/{self.config}"

    def curves(self) -> Run:
        """Its metrics and config (only read for complete runs)."""
        return Run(self.path, read_metrics(self.path / METRICS_FILE), read_config(self.path))


def checkpoint_frames(run_dir: Path) -> int | None:
    """Frames of the run's latest checkpoint, ``None`` if it has none."""
    from rlhc.checkpoint import CHECKPOINT_DIR, LATEST, load_checkpoint

    latest = run_dir / CHECKPOINT_DIR / LATEST
    return int(load_checkpoint(latest)["frames"]) if latest.exists() else None


def discover(
    results: Path,
    studies: dict[str, tuple[dict[str, tuple[str, ...]], int, int]] = STUDIES,
    frames_of: Callable[[Path], int | None] = checkpoint_frames,
) -> list[StudyRun]:
    """Every ``<study>/<config>/seed_<k>`` directory under ``results``, in plan order."""
    found = []
    for study, (configs, _, max_steps) in studies.items():
        for config in configs:
            seeds = sorted(
                int(p.name.removeprefix("seed_"))
                for p in (results / study / config).glob("seed_*")
                if p.is_dir() and p.name.removeprefix("seed_").isdigit()
            )
            for seed in seeds:
                path = results / study / config / f"seed_{seed}"
                found.append(StudyRun(study, config, seed, path, frames_of(path), max_steps))
    return found


def complete_runs(runs: Iterable[StudyRun], name: str) -> list[StudyRun]:
    """The complete runs of ``study/config``, by seed."""
    return sorted((r for r in runs if r.name == name and r.complete), key=lambda r: r.seed)


# --------------------------------------------------------------------------- curves


def smoothed(run: Run, metric: str, smoothing: float = SMOOTHING) -> tuple[np.ndarray, np.ndarray]:
    """``(steps, smoothed values)`` of ``metric`` where it is finite (empty if not logged)."""
    if metric not in run.columns:
        return np.empty(0), np.empty(0)
    curve = ema_smooth(run.columns[metric], smoothing)
    finite = np.isfinite(curve)
    return run.steps[finite], curve[finite]


def smoothed_final(
    run: Run, metric: str, smoothing: float = SMOOTHING, fraction: float = FINAL_FRACTION
) -> float | None:
    """Mean of the smoothed curve over its last ``fraction`` of steps (``None``: not logged).

    The window is that of :func:`rlhc.plotting.final_values`, applied to the smoothed curve.
    """
    steps, curve = smoothed(run, metric, smoothing)
    if not steps.size:
        return None
    values = final_values([Run(run.path, {"step": steps, metric: curve})], metric, fraction)
    return values.get(run.path)


def initial_value(run: Run, metric: str) -> float | None:
    """The first logged value (the smoothed curve starts there)."""
    _, curve = smoothed(run, metric)
    return float(curve[0]) if curve.size else None


def threshold(initial: float, best_final: float, fraction: float = THRESHOLD_FRACTION) -> float:
    """The level ``fraction`` of the way from ``initial`` to ``best_final``."""
    return initial + fraction * (best_final - initial)


def steps_to_reach(steps: np.ndarray, curve: np.ndarray, level: float) -> float | None:
    """First step where the (smoothed) curve is ``>= level``; ``None`` if never."""
    reached = np.flatnonzero(curve >= level)
    return float(steps[reached[0]]) if reached.size else None


@dataclass
class ConfigFinals:
    """One configuration's per-seed numbers for one group metric."""

    name: str
    seeds: list[int]
    reward: list[float]  # smoothed last-10% cumulative reward per seed
    initial: list[float]
    reach: list[float | None]  # steps to the threshold per seed (filled later)
    episode_length: list[float]
    entropy: list[float]


def finite(values: Iterable[float]) -> list[float]:
    return [v for v in values if math.isfinite(v)]


def nan_if_none(value: float | None) -> float:
    return math.nan if value is None else value


def config_finals(name: str, runs: Sequence[StudyRun], group: str) -> ConfigFinals:
    """Per-seed finals of ``group`` for the complete ``runs`` of one configuration."""
    finals = ConfigFinals(name, [], [], [], [], [], [])
    for run in runs:
        curves = run.curves()
        reward = smoothed_final(curves, f"{group}/cumulative_reward")
        if reward is None:
            continue
        finals.seeds.append(run.seed)
        finals.reward.append(reward)
        finals.initial.append(nan_if_none(initial_value(curves, f"{group}/cumulative_reward")))
        finals.episode_length.append(nan_if_none(smoothed_final(curves, "episode_length")))
        finals.entropy.append(nan_if_none(smoothed_final(curves, f"{group}/entropy")))
    return finals


def fill_reach(
    table: Sequence[ConfigFinals], runs: Sequence[StudyRun], group: str, fraction: float
) -> float | None:
    """Steps to the table's threshold for every seed; returns the threshold used.

    The threshold is ``fraction`` of the way from the mean initial reward of all runs in
    the table to the best configuration's mean final reward; ``None`` (and no steps) if
    no configuration ended above the initial value.
    """
    initials = [v for c in table for v in c.initial if math.isfinite(v)]
    finals = [float(np.mean(c.reward)) for c in table if c.reward]
    if not initials or not finals or max(finals) <= float(np.mean(initials)):
        for config in table:
            config.reach = [None] * len(config.seeds)
        return None
    level = threshold(float(np.mean(initials)), max(finals), fraction)
    by_name: dict[tuple[str, int], StudyRun] = {(r.name, r.seed): r for r in runs}
    for config in table:
        config.reach = []
        for seed in config.seeds:
            steps, curve = smoothed(
                by_name[(config.name, seed)].curves(), f"{group}/cumulative_reward"
            )
            config.reach.append(steps_to_reach(steps, curve, level))
    return level


# --------------------------------------------------------------------------- statistics


@dataclass(frozen=True)
class Comparison:
    """Welch's test of RLHC's per-seed final values against PPO's."""

    rlhc: str
    ppo: str
    group: str
    rlhc_values: tuple[float, ...]
    ppo_values: tuple[float, ...]

    @property
    def testable(self) -> bool:
        return len(self.rlhc_values) >= 2 and len(self.ppo_values) >= 2

    def test(self) -> tuple[float, float] | None:
        return welch_t_test(self.rlhc_values, self.ppo_values) if self.testable else None

    def verdict(self, what: str = "final cumulative reward") -> str:
        """A neutral sentence generated from the numbers."""
        a, b = t_interval(self.rlhc_values), t_interval(self.ppo_values)
        means = f"{fmt(a.mean)} (n={a.n}) vs {fmt(b.mean)} (n={b.n})"
        result = self.test()
        if result is None:
            return (
                f"`{self.rlhc}` vs `{self.ppo}`, {self.group} {what}: not testable yet — "
                f"Welch's test needs at least 2 completed seeds per side; {means}."
            )
        t, p = result
        if p < ALPHA:
            direction = "higher" if t > 0 else "lower"
            return (
                f"`{self.rlhc}`'s {self.group} {what} is {direction} than `{self.ppo}`'s "
                f"(Welch t = {t:.2f}, p = {p:.3g}; {means})."
            )
        return (
            f"`{self.rlhc}`'s {self.group} {what} is not significantly different from "
            f"`{self.ppo}`'s (Welch t = {t:.2f}, p = {p:.3g}, alpha = {ALPHA}; {means})."
        )


@dataclass(frozen=True)
class Record:
    """Wins, draws and losses of one side over a number of matches."""

    wins: int
    draws: int
    losses: int

    @property
    def matches(self) -> int:
        return self.wins + self.draws + self.losses

    @property
    def score(self) -> float:
        """Wins plus half the draws, per match (0.5: even)."""
        return (self.wins + 0.5 * self.draws) / self.matches if self.matches else math.nan

    def rate(self, count: float) -> str:
        """``rate [low, high]`` with the 95% Wilson interval."""
        if not self.matches:
            return "—"
        low, high = wilson_interval(count, self.matches)
        return f"{count / self.matches:.1%} [{low:.1%}, {high:.1%}]"

    def __add__(self, other: Record) -> Record:
        return Record(self.wins + other.wins, self.draws + other.draws, self.losses + other.losses)


def record_of(outcomes: np.ndarray) -> Record:
    """From :attr:`MatchResult.outcomes` (+1 win, 0 draw, -1 loss of the home side)."""
    return Record(int((outcomes > 0).sum()), int((outcomes == 0).sum()), int((outcomes < 0).sum()))


def pooled(records: Iterable[Record]) -> Record:
    return sum(records, Record(0, 0, 0))


def match_verdict(label: str, record: Record) -> str:
    """A neutral sentence on a pooled head-to-head record of RLHC."""
    if not record.matches:
        return f"{label}: no matches played yet."
    low, high = wilson_interval(record.wins + 0.5 * record.draws, record.matches)
    if low > 0.5:
        how = "RLHC scores higher than PPO"
    elif high < 0.5:
        how = "RLHC scores lower than PPO"
    else:
        how = "RLHC's score is not distinguishable from an even 0.5"
    return (
        f"{label}: {how} in head-to-head play (score {record.score:.3f}, 95% Wilson "
        f"[{low:.3f}, {high:.3f}] over {record.matches} matches; wins {record.rate(record.wins)}, "
        f"draws {record.rate(record.draws)}, losses {record.rate(record.losses)})."
    )


# --------------------------------------------------------------------------- formatting


def fmt(value: float | None, digits: int = 4, fixed: bool = False) -> str:
    """``digits`` decimals (significant digits for tiny values unless ``fixed``)."""
    if value is None or not math.isfinite(value):
        return "—"
    if fixed:
        return f"{value:,.{digits}f}"
    return f"{value:.{digits}g}" if abs(value) < 1e-3 and value != 0 else f"{value:.{digits}f}"


def fmt_interval(ci: MeanInterval, digits: int = 4, fixed: bool = False) -> str:
    """``mean [low, high]`` (a single value has no interval)."""
    if ci.n == 0:
        return "—"
    if ci.n == 1:
        return f"{fmt(ci.mean, digits, fixed)} (n=1, no interval)"
    low, high = fmt(ci.low, digits, fixed), fmt(ci.high, digits, fixed)
    return f"{fmt(ci.mean, digits, fixed)} [{low}, {high}]"


def fmt_reach(reach: Sequence[float | None]) -> str:
    hits = [r for r in reach if r is not None]
    if not reach:
        return "—"
    mean = f"{np.mean(hits):,.0f}" if hits else "—"
    return f"{mean} ({len(hits)}/{len(reach)} seeds)"


def table(header: Sequence[str], rows: Iterable[Sequence[str]]) -> list[str]:
    """A Markdown table."""
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(str(c) for c in row) + " |" for row in rows]
    return lines


# --------------------------------------------------------------------------- matches


def play_series(env_name: str, home: str, away: str, matches: int, seed: int) -> Record:
    """``matches`` matches of ``home`` against ``away`` (sides swapped every match)."""
    from rlhc.evaluation.matches import default_rules, make_match_env, play_matches
    from rlhc.evaluation.opponents import make_team_policy

    torch_seed(seed)
    env = make_match_env(env_name, min(32, matches), seed, [home, away])
    rules = default_rules(env_name, env.game.max_cycles)
    result = play_matches(
        env, make_team_policy(home, env), make_team_policy(away, env), matches, rules
    )
    env.close()
    return record_of(result.outcomes)


def torch_seed(seed: int) -> None:
    import torch

    torch.manual_seed(seed)
    np.random.seed(seed)


# --------------------------------------------------------------------------- sections


def study_env(study: str) -> str:
    """The game of a study (from its configs' ``env=`` override)."""
    overrides = next(iter(STUDIES[study][0].values()))
    return next(o.split("=", 1)[1] for o in overrides if o.startswith("env="))


def table_configs(study: str) -> list[str]:
    """``study/config`` names in a study's tables (its own, then the borrowed ones)."""
    return [f"{study}/{c}" for c in STUDIES[study][0]] + list(BORROWED.get(study, ()))


def comparisons_of(study: str) -> list[tuple[str, str]]:
    """(RLHC, PPO) ``study/config`` pairs tested in a study."""
    if study in PAIRS:
        return [(f"{study}/{a}", f"{study}/{b}") for a, b in PAIRS[study]]
    borrowed = BORROWED.get(study, ())
    return [(f"{study}/{c}", other) for c in STUDIES[study][0] for other in borrowed]


def runs_section(runs: Sequence[StudyRun], studies: Sequence[str]) -> list[str]:
    """Which runs exist, which are complete, and their wall time."""
    rows = []
    for study in studies:
        configs, planned, max_steps = STUDIES[study]
        for config, overrides in configs.items():
            mine = [r for r in runs if r.study == study and r.config == config]
            done = [r for r in mine if r.complete]
            partial = [
                f"seed {r.seed} ({f'{r.frames:,} frames' if r.frames else 'no checkpoint yet'})"
                for r in mine
                if not r.complete
            ]
            frames = sorted({r.frames for r in done if r.frames is not None})
            times = [wall_time(r) for r in done]
            rows.append(
                [
                    f"`{study}/{config}`",
                    "`" + " ".join(overrides) + "`",
                    f"{max_steps:,}",
                    ", ".join(f"{f:,}" for f in frames) or "—",
                    f"{len(done)} of {planned}",
                    ", ".join(str(r.seed) for r in done) or "—",
                    "; ".join(partial) or "—",
                    fmt_interval(t_interval([t for t in times if math.isfinite(t)]), 0, fixed=True),
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
    ]
    total = sum(wall_time(r) for r in runs if r.complete)
    return [
        *table(header, rows),
        "",
        f"Total training wall time of the {sum(r.complete for r in runs)} complete runs: "
        f"{total:,.0f} s ({total / 3600:.2f} h, summed over runs, which trained concurrently). "
        "Wall time is the trainer's `wall_time` in the last row of `metrics.csv` "
        "(collection + updates, carried across resumes).",
    ]


def wall_time(run: StudyRun) -> float:
    column = read_metrics(run.path / METRICS_FILE).get("wall_time")
    return float(column[-1]) if column is not None and column.size else math.nan


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


def shown(config: dict, key: str) -> str:
    """A recorded config value, or *absent* (the key did not exist when the run started)."""
    return f"`{config[key]}`" if key in config else "absent"


def config_drift(runs: Sequence[StudyRun]) -> list[str]:
    """Config keys whose recorded values differ between seeds of one configuration.

    Such keys come from code that changed while the study ran (e.g. a new option);
    they are listed so that a reader can judge whether the seeds are comparable.
    """
    from rlhc.plotting import differing_keys

    notes = []
    for name in dict.fromkeys(r.name for r in runs if r.complete):
        members = [r.curves() for r in complete_runs(runs, name)]
        for key in differing_keys(members):
            values = ", ".join(
                f"seed {r.config.get('seed')}: {shown(r.config, key)}" for r in members
            )
            notes.append(f"`{name}` — `{key}` differs between seeds ({values}).")
    return notes


def drift_lines(runs: Sequence[StudyRun]) -> list[str]:
    notes = config_drift(runs)
    if not notes:
        return ["Every seed of a configuration recorded the same config (seed aside).", ""]
    return [
        "Recorded configs that differ between seeds of one configuration (the code changed "
        "while the study ran; *absent*: the key did not exist when that run started):",
        "",
        *[f"- {note}" for note in notes],
        "",
    ]


def settings_section(runs: Sequence[StudyRun]) -> list[str]:
    """Table 3 values as the complete runs' configs recorded them, per game."""
    by_env: dict[str, dict] = {}
    for run in runs:
        if run.complete:
            config = run.curves().config
            by_env.setdefault(str(config.get("env.name")), config)
    if not by_env:
        return ["No complete run yet."]
    games = sorted(by_env)
    rows = [[label] + [f"`{by_env[g].get(key)}`" for g in games] for key, label in SETTINGS]
    return table(["setting", *games], rows)


def speed_verdict(rlhc: ConfigFinals, ppo: ConfigFinals, group: str, level: float | None) -> str:
    """A neutral sentence on the steps each configuration took to reach the threshold."""
    if level is None:
        return f"`{rlhc.name}` vs `{ppo.name}`, {group}: no steps-to-threshold (no threshold)."
    return (
        f"`{rlhc.name}` vs `{ppo.name}`, {group} steps to reach {fmt(level)}: "
        f"{fmt_reach(rlhc.reach)} vs {fmt_reach(ppo.reach)} (no test; descriptive)."
    )


def finals_section(
    study: str, runs: Sequence[StudyRun], fraction: float
) -> tuple[list[str], list[Comparison], list[str]]:
    """Per group: the finals table, Welch's tests and steps-to-threshold sentences."""
    lines: list[str] = []
    comparisons: list[Comparison] = []
    speed: list[str] = []
    for group in GROUPS[study_env(study)]:
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
                fmt_interval(t_interval(finite(c.episode_length)), 3),
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
            speed.append(speed_verdict(a, b, group, level))
    rows = []
    for c in comparisons:
        result = c.test()
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
            ]
        )
    lines += [
        "Welch's t-test (two-sided, unequal variances), first config vs second (RLHC vs PPO; "
        "for the extensions, each extension vs tennis PPO and RLHC). Samples: one value "
        "per completed seed — the mean of the last 10% (by steps) of that run's "
        f"TensorBoard-smoothed (EMA {SMOOTHING}) `<group>/cumulative_reward` curve.",
        "",
        *table(["first vs second", "group", "seeds", "mean difference", "t", "p"], rows),
    ]
    return lines, comparisons, speed


def matches_section(
    runs: Sequence[StudyRun], studies: Sequence[str], matches: int
) -> tuple[list[str], list[str]]:
    """Head-to-head and against-scripted tables; also the head-to-head verdicts."""
    if matches <= 0:
        return ["Not played (`--matches 0`)."], []
    lines: list[str] = []
    verdicts: list[str] = []
    head_rows, pair_rows = [], []
    for study in studies:
        for rlhc, ppo in PAIRS.get(study, []):
            a = {r.seed: r for r in complete_runs(runs, f"{study}/{rlhc}")}
            b = {r.seed: r for r in complete_runs(runs, f"{study}/{ppo}")}
            records = []
            for seed in sorted(set(a) & set(b)):
                record = play_series(
                    study_env(study), str(a[seed].path), str(b[seed].path), matches, seed
                )
                records.append(record)
                pair_rows.append(
                    [
                        f"`{study}/{rlhc}` vs `{study}/{ppo}`",
                        str(seed),
                        f"{record.wins}/{record.draws}/{record.losses}",
                        record.rate(record.wins),
                        record.rate(record.draws),
                        record.rate(record.losses),
                    ]
                )
            total = pooled(records)
            label = f"`{study}/{rlhc}` vs `{study}/{ppo}`"
            head_rows.append(
                [
                    label,
                    str(len(records)),
                    str(total.matches),
                    total.rate(total.wins),
                    total.rate(total.draws),
                    total.rate(total.losses),
                    fmt(total.score, 3),
                ]
            )
            verdicts.append(match_verdict(label, total))
    rate_header = ["RLHC wins", "draws", "RLHC losses"]
    lines += [
        f"Final RLHC team vs final PPO team of the same seed, {matches} matches per seed pair, "
        "sides swapped every match, deterministic (mode) actions; rates with 95% Wilson "
        "intervals. The pooled interval treats every match as an independent trial, so it "
        "does not include the spread between seeds.",
        "",
        *table(["pairing", "seed pairs", "matches", *rate_header, "score"], head_rows),
        "",
        "Per seed pair (wins/draws/losses of RLHC):",
        "",
        *table(["pairing", "seed", "W/D/L", *rate_header], pair_rows),
        "",
    ]
    scripted_rows = []
    for study in studies:
        for config in STUDIES[study][0]:
            members = complete_runs(runs, f"{study}/{config}")
            records = [
                play_series(study_env(study), str(r.path), "scripted", matches, r.seed)
                for r in members
            ]
            if not records:
                continue
            total = pooled(records)
            scripted_rows.append(
                [
                    f"`{study}/{config}`",
                    str(len(records)),
                    ", ".join(f"{r.wins / r.matches:.0%}" for r in records),
                    total.rate(total.wins),
                    total.rate(total.draws),
                    total.rate(total.losses),
                ]
            )
    lines += [
        f"Every final team against the scripted team ({matches} matches per run, sides "
        "swapped every match):",
        "",
        *table(
            ["config", "runs", "win rate per seed", "wins (pooled)", "draws", "losses"],
            scripted_rows,
        ),
    ]
    return lines, verdicts


def versions() -> list[str]:
    found = [f"python {platform.python_version()}"]
    for name in VERSIONED:
        try:
            found.append(f"{name} {metadata.version(name)}")
        except metadata.PackageNotFoundError:
            found.append(f"{name} (not installed)")
    return found


def machine() -> list[str]:
    model = "unknown CPU"
    cpuinfo = Path("/proc/cpuinfo")
    if cpuinfo.exists():
        for line in cpuinfo.read_text().splitlines():
            if line.startswith("model name"):
                model = line.split(":", 1)[1].strip()
                break
    try:
        uptime = subprocess.run(["uptime"], capture_output=True, text=True).stdout.strip()
    except OSError:
        uptime = "unavailable"
    return [
        f"{platform.system()} {platform.release()}, {os.cpu_count()} CPUs ({model})",
        f"`uptime` when this report was generated: `{uptime}`",
    ]


# --------------------------------------------------------------------------- report


def window_points(runs: Sequence[StudyRun], fraction: float = FINAL_FRACTION) -> str:
    """How many logged rows fall in the final window of each run (``a`` or ``a-b``)."""
    counts = set()
    for run in runs:
        steps = run.curves().steps
        counts.add(int((steps >= (1.0 - fraction) * steps.max()).sum()))
    low, high = min(counts), max(counts)
    return str(low) if low == high else f"{low}-{high}"


def build_report(args: argparse.Namespace) -> str:
    started = time.perf_counter()
    runs = discover(args.results)
    studies = [s for s in STUDIES if s in args.study]
    planned = sum(STUDIES[s][1] * len(STUDIES[s][0]) for s in studies)
    done = sum(r.complete for r in runs if r.study in studies)
    status = (
        "complete"
        if done == planned
        else f"**partial** — {done} of {planned} planned runs complete; the rest are "
        "missing or still training and are left out of every number below"
    )
    out_dir = args.out.resolve().parent
    lines = [
        "# Reproduction: RLHC vs PPO",
        "",
        "<!-- Generated by benchmarks/report.py: do not edit by hand (except the "
        "interpretation section). -->",
        "",
        f"Status: {status}.",
        "",
        "## What was run",
        "",
        "Each run is a separate `python -m rlhc.run` process (torch threads: see the "
        "settings table); `reproduce.py --jobs` of them train at once. A run counts as "
        "complete when its "
        "`checkpoints/latest.pt` has reached the study's `max_steps` frames (one frame = "
        "one step of one world).",
        "",
        *runs_section(runs, studies),
        "",
        "Table 3 settings as recorded in the complete runs' configs:",
        "",
        *settings_section([r for r in runs if r.study in studies]),
        "",
        *drift_lines([r for r in runs if r.study in studies]),
        "## Commands",
        "",
        "```bash",
        "python benchmarks/reproduce.py --jobs 2 --study "
        + " ".join(studies)
        + "   # trains the runs (resumable; re-run to continue)",
        command_line(args),
        "```",
        "",
        "## Environment",
        "",
        "- " + ", ".join(versions()),
        *[f"- {line}" for line in machine()],
        "",
    ]
    verdicts: list[str] = []
    for study in studies:
        members = [r for r in runs if r.complete and r.name in table_configs(study)]
        lines += [f"## Study `{study}` ({study_env(study)})", ""]
        if not any(r.study == study for r in members):
            lines += ["No complete run yet.", ""]
            continue
        image = ROOT / "docs" / "images" / f"results_{study}.png"
        from rlhc.plotting import plot_runs

        plot_runs([r.path for r in members], image, SMOOTHING, GROUP_BY[study])
        link = os.path.relpath(image, out_dir)
        section, comparisons, speed = finals_section(study, runs, args.threshold_fraction)
        verdicts += [c.verdict() for c in comparisons] + speed
        lines += [
            f"![{study} curves]({link})",
            "",
            f"The paper's four metrics, mean over complete seeds with a 95% t band, "
            f"EMA {SMOOTHING} smoothing. Finals: per run, the mean of the last 10% (by steps) "
            "of the smoothed curve; tables give the mean over seeds with its 95% t interval. "
            f"Here that window holds {window_points(members)} logged points per run.",
            "",
            *section,
            "",
        ]
    match_lines, match_verdicts = matches_section(runs, studies, args.matches)
    lines += ["## Head-to-head matches", "", *match_lines, ""]
    lines += [
        "## Does the paper's claim reproduce?",
        "",
        "The paper reports that RLHC reaches a higher cumulative reward than PPO, faster. "
        "Generated from the numbers above (alpha = 0.05):",
        "",
        *[f"- {v}" for v in verdicts + match_verdicts],
        "",
    ]
    if done < planned:
        lines += [
            f"These statements rest on {done} of {planned} planned runs; they are provisional.",
            "",
        ]
    lines += [
        "## Interpretation",
        "",
        "<!-- INTERPRETATION: hand-written by the lead after the numbers exist. -->",
        "",
        "*(to be written)*",
        "",
        "---",
        f"Report generated in {time.perf_counter() - started:.0f} s by `{command_line(args)}`.",
        "",
    ]
    return "\n".join(lines)


def command_line(args: argparse.Namespace) -> str:
    """The report command that reproduces this report (default results and output)."""
    command = f"python benchmarks/report.py --matches {args.matches}"
    if args.study != list(STUDIES):
        command += " --study " + " ".join(args.study)
    if args.threshold_fraction != THRESHOLD_FRACTION:
        command += f" --threshold-fraction {args.threshold_fraction}"
    return command


def parse_args(argv: Sequence[str] | None = None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--results", type=Path, default=RESULTS, help="the study's root")
    parser.add_argument(
        "--matches", type=int, default=100, help="matches per pairing (0: play none)"
    )
    parser.add_argument("--out", type=Path, default=ROOT / "docs" / "RESULTS.md")
    parser.add_argument("--study", nargs="+", choices=list(STUDIES), default=list(STUDIES))
    parser.add_argument(
        "--threshold-fraction",
        type=float,
        default=THRESHOLD_FRACTION,
        help="steps-to-threshold level, as a share of the way from initial to best final",
    )
    return parser.parse_args(argv)


def main(argv: Sequence[str] | None = None) -> None:
    import warnings

    import torch

    warnings.filterwarnings("ignore", message="Support of VecNormV2")
    torch.set_num_threads(1)
    args = parse_args(argv)
    report = build_report(args)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(report)
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
