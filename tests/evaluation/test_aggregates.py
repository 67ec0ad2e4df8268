"""Aggregates over tasks and seeds: IQM, stratified bootstrap, probability of improvement."""

from __future__ import annotations

import numpy as np
import pytest

from rlhc.evaluation.stats import (
    iqm_interval,
    probability_of_improvement,
    separation_p_value,
)


def test_iqm_is_the_mean_of_the_middle_half() -> None:
    values = np.arange(8.0)  # the middle half: 2, 3, 4, 5
    assert iqm_interval([values]).value == 3.5
    assert iqm_interval([[1.0, 1.0, 1.0, 1000.0]]).value == 1.0  # an outlier does not move it
    with pytest.raises(ValueError, match="at least one score"):
        iqm_interval([[]])


def test_the_iqm_interval_is_reproducible_and_narrows_with_seeds() -> None:
    rng = np.random.default_rng(1)
    few = [rng.normal(0.5, 0.1, 5), rng.normal(0.6, 0.1, 5)]
    many = [rng.normal(0.5, 0.1, 50), rng.normal(0.6, 0.1, 50)]
    first, again = iqm_interval(few, seed=3), iqm_interval(few, seed=3)
    assert first == again
    assert first.low <= first.value <= first.high
    narrow = iqm_interval(many)
    assert narrow.high - narrow.low < first.high - first.low
    # One run per task: no spread to resample.
    single = iqm_interval([[0.2], [0.4]])
    assert single.low == single.value == single.high == pytest.approx(0.3)


def test_the_bootstrap_is_stratified_by_task() -> None:
    # Task A always scores 0, task B always 1: any resample keeps 2 runs of each, so the
    # pooled IQM cannot move (an unstratified resample could draw four 0s).
    estimate = iqm_interval([[0.0, 0.0], [1.0, 1.0]])
    assert (estimate.low, estimate.value, estimate.high) == (0.5, 0.5, 0.5)


def test_probability_of_improvement() -> None:
    better, worse = [[2.0, 3.0, 4.0], [5.0, 6.0]], [[0.0, 1.0, 1.5], [1.0, 2.0]]
    assert probability_of_improvement(better, worse).value == 1.0
    assert probability_of_improvement(worse, better).value == 0.0
    same = probability_of_improvement([[1.0, 2.0, 3.0]], [[1.0, 2.0, 3.0]])
    assert same.value == 0.5 and same.low < 0.5 < same.high
    rng = np.random.default_rng(0)
    x = [rng.normal(size=6) for _ in range(3)]
    y = [rng.normal(size=6) for _ in range(3)]
    forward, backward = probability_of_improvement(x, y), probability_of_improvement(y, x)
    assert forward.value + backward.value == pytest.approx(1.0)
    assert forward.low <= forward.value <= forward.high


def test_probability_of_improvement_refuses_mismatched_tasks() -> None:
    with pytest.raises(ValueError, match="X has 2 tasks and Y 1"):
        probability_of_improvement([[1.0], [2.0]], [[1.0]])
    with pytest.raises(ValueError, match="at least one score"):
        probability_of_improvement([[1.0], []], [[1.0], [2.0]])


def test_a_task_with_one_run_is_held_fixed_in_the_bootstrap() -> None:
    # A study with one seed beside one with five (a study just begun): the single run is
    # in every resample; only the five are resampled.
    five, one = [0.2, 0.4, 0.5, 0.6, 0.8], [0.9]
    iqm = iqm_interval([five, one])
    assert iqm.low < iqm.value < iqm.high
    assert iqm.high - iqm.low < iqm_interval([five]).high - iqm_interval([five]).low + 0.2
    improvement = probability_of_improvement([five, one], [[0.5, 0.5], [0.1]])
    assert improvement.value == pytest.approx((0.5 + 1.0) / 2)
    assert improvement.low <= improvement.value <= improvement.high
    # Where the resampled tasks cannot vary, every resample is the full sample: the
    # interval is the estimate itself, the single run's value included (dropping it from
    # the resamples would move the interval to 0.5 in both cases).
    fixed = iqm_interval([[0.5, 0.5], [0.9]])
    assert fixed.low == pytest.approx(fixed.value) == pytest.approx(fixed.high)
    assert fixed.value == pytest.approx((0.5 + 0.5 + 0.9) / 3)
    fixed = probability_of_improvement([[0.5] * 3, [0.9]], [[0.5] * 3, [0.1]])
    assert (fixed.low, fixed.value, fixed.high) == pytest.approx((0.75, 0.75, 0.75))


def test_the_separation_p_value_is_the_chance_of_a_complete_split() -> None:
    # 2 runs against 2: 6 orderings of the labels, one split each way.
    assert separation_p_value([(2, 2)]) == pytest.approx(2 / 6)
    assert separation_p_value([(3, 3)]) == pytest.approx(2 / 20)  # still above 0.05
    assert separation_p_value([(4, 4)]) == pytest.approx(2 / 70)  # the first below it
    assert separation_p_value([(1, 1)]) == 1.0  # capped: a probability
    # Independent tasks multiply: two tasks of 2 against 2 reach 2 / 36.
    assert separation_p_value([(2, 2), (2, 2)]) == pytest.approx(2 / 36)
    with pytest.raises(ValueError, match=r"at least one run on each side, got sizes \[\(3, 0\)\]"):
        separation_p_value([(3, 0)])
    with pytest.raises(ValueError, match="got sizes \\[\\]"):
        separation_p_value([])
