"""Intervals against published values and simulated coverage."""

from __future__ import annotations

import numpy as np
import pytest

from rlhc.evaluation.stats import t_interval, welch_t_test, wilson_interval


def test_wilson_known_values() -> None:
    # Newcombe (1998), Table I: 81/263 -> 0.2553 to 0.3662 (95%, Wilson).
    low, high = wilson_interval(81, 263)
    assert low == pytest.approx(0.2553, abs=1e-4)
    assert high == pytest.approx(0.3662, abs=1e-4)
    # 0 of 10 does not collapse to a point (Wald would give [0, 0]).
    low, high = wilson_interval(0, 10)
    assert low == 0.0
    assert high == pytest.approx(0.2775, abs=1e-4)
    assert wilson_interval(0, 0) == (0.0, 1.0)


def test_wilson_coverage_near_nominal() -> None:
    rng = np.random.default_rng(0)
    p, n = 0.3, 40
    hits = sum(
        low <= p <= high
        for low, high in (wilson_interval(int(k), n) for k in rng.binomial(n, p, 2000))
    )
    assert 0.92 <= hits / 2000 <= 0.98


def test_t_interval_hand_computed() -> None:
    # mean 2, s = 1, n = 3: t_{0.975, 2} = 4.302653, half = 4.302653 / sqrt(3).
    ci = t_interval([1.0, 2.0, 3.0])
    assert ci.mean == 2.0
    assert ci.high - ci.mean == pytest.approx(4.302653 / np.sqrt(3.0), abs=1e-5)
    single = t_interval([5.0])
    assert (single.low, single.high, single.n) == (5.0, 5.0, 1)


def test_welch_detects_a_shift() -> None:
    t, p = welch_t_test([1.0, 1.2, 0.9, 1.1], [2.0, 2.1, 1.8, 2.3])
    assert t < 0 and p < 1e-3
    with pytest.raises(ValueError, match="Welch"):
        welch_t_test([1.0], [2.0, 3.0])
