"""Per-seed finals of the learning curves, thresholds, and Welch's test of RLHC vs PPO.

A run's *final* value of a metric is the mean of the last 10% (by steps) of its
TensorBoard-smoothed curve (EMA 0.8, as ``python -m rlhc.plot``); a configuration's
finals are averaged over seeds with a 95% Student t interval
(:func:`rlhc.evaluation.stats.t_interval`) and compared with Welch's t-test
(:func:`rlhc.evaluation.stats.welch_t_test`), its p-values Holm-corrected over the
study's tests of one table (:func:`corrected`), each with the smallest difference its
seeds detect (:func:`rlhc.evaluation.stats.welch_detectable_difference`).
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, replace

import numpy as np

from rlhc.analysis.curves import Run, ema_smooth, final_values
from rlhc.evaluation.stats import holm, t_interval, welch_detectable_difference, welch_t_test

from .formatting import fmt
from .runs import StudyRun
from .study import ALPHA, FINAL_FRACTION, POWER, SMOOTHING, THRESHOLD_FRACTION


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

    The window is that of :func:`rlhc.analysis.curves.final_values`, applied to the smoothed curve.
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


def window_points(runs: Sequence[StudyRun], fraction: float = FINAL_FRACTION) -> str:
    """How many logged rows fall in the final window of each run (``a`` or ``a-b``)."""
    counts = set()
    for run in runs:
        steps = run.curves().steps
        counts.add(int((steps >= (1.0 - fraction) * steps.max()).sum()))
    low, high = min(counts), max(counts)
    return str(low) if low == high else f"{low}-{high}"


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
    """The finite ones of ``values`` (a metric some runs did not log is ``nan`` there)."""
    return [v for v in values if math.isfinite(v)]


def nan_if_none(value: float | None) -> float:
    """``nan`` for a metric that was not logged, so that per-seed lists stay aligned."""
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


@dataclass(frozen=True)
class Comparison:
    """Welch's test of one configuration's per-seed values against another's.

    ``family_p`` is the p-value Holm-corrected over the family the test belongs to
    (:func:`corrected`), ``family`` that family's size; a test alone is its own family.
    """

    rlhc: str
    ppo: str
    group: str
    rlhc_values: tuple[float, ...]
    ppo_values: tuple[float, ...]
    family_p: float | None = None
    family: int = 1

    @property
    def testable(self) -> bool:
        """Welch's test needs at least two values per side."""
        return len(self.rlhc_values) >= 2 and len(self.ppo_values) >= 2

    def test(self) -> tuple[float, float] | None:
        """``(t, p)`` of Welch's test, ``None`` if not :attr:`testable`."""
        return welch_t_test(self.rlhc_values, self.ppo_values) if self.testable else None

    def detectable(self) -> float | None:
        """The smallest difference these seeds detect at ``ALPHA`` with power 0.8."""
        if not self.testable:
            return None
        return welch_detectable_difference(self.rlhc_values, self.ppo_values, ALPHA, POWER)

    def verdict(self, what: str = "final cumulative reward") -> str:
        """A neutral sentence generated from the numbers, significance after Holm's."""
        a, b = t_interval(self.rlhc_values), t_interval(self.ppo_values)
        means = f"{fmt(a.mean)} (n={a.n}) vs {fmt(b.mean)} (n={b.n})"
        result = self.test()
        if result is None:
            return (
                f"`{self.rlhc}` vs `{self.ppo}`, {self.group} {what}: not testable yet — "
                f"Welch's test needs at least 2 completed seeds per side; {means}."
            )
        t, p = result
        family_p = p if self.family_p is None else self.family_p
        numbers = f"Welch t = {t:.2f}, p = {p:.3g}"
        if self.family > 1:
            numbers += f", Holm p = {family_p:.3g} over {self.family} tests"
        if family_p < ALPHA:
            direction = "higher" if t > 0 else "lower"
            return (
                f"`{self.rlhc}`'s {self.group} {what} is {direction} than `{self.ppo}`'s "
                f"({numbers}; {means})."
            )
        after = " after Holm's correction" if p < ALPHA else ""
        return (
            f"`{self.rlhc}`'s {self.group} {what} is not significantly different from "
            f"`{self.ppo}`'s{after} ({numbers}, alpha = {ALPHA}; {means}; detectable at "
            f"power {POWER}: {fmt(self.detectable())})."
        )


def corrected(comparisons: Sequence[Comparison]) -> list[Comparison]:
    """``comparisons`` with Holm's p over their testable members, one family."""
    p_values = {i: result[1] for i, c in enumerate(comparisons) if (result := c.test())}
    adjusted = dict(zip(p_values, holm(list(p_values.values())), strict=True))
    return [
        replace(c, family_p=adjusted[i], family=len(adjusted)) if i in adjusted else c
        for i, c in enumerate(comparisons)
    ]
