"""Intervals against published values and simulated coverage."""

from __future__ import annotations

import numpy as np
import pytest

from rlhc.evaluation.stats import (
    holm,
    t_interval,
    welch_detectable_difference,
    welch_t_test,
    wilson_interval,
)


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


def test_holm_hand_computed_and_order_kept() -> None:
    # Sorted 0.01, 0.03, 0.04: 3 x 0.01 = 0.03, 2 x 0.03 = 0.06, max(0.06, 1 x 0.04) = 0.06.
    assert holm([0.04, 0.01, 0.03]) == pytest.approx([0.06, 0.03, 0.06])
    assert holm([0.5, 0.9]) == [1.0, 1.0]  # capped at 1
    assert holm([0.02]) == [0.02]  # one test is its own family
    assert holm([]) == []


def test_holm_keeps_the_family_wise_error_rate() -> None:
    # Ten true null hypotheses: uniform p-values. Uncorrected, some p < 0.05 in ~40 % of
    # families; Holm-corrected, in at most 5 %.
    p_values = np.random.default_rng(0).uniform(size=(4000, 10))
    raw = (p_values < 0.05).any(axis=1).mean()
    corrected = np.mean([min(holm(list(row))) < 0.05 for row in p_values])
    assert raw > 0.35 and corrected <= 0.055


def test_detectable_difference_has_the_stated_power() -> None:
    # Seeds of spread 1, 10 a side; a shift by the detectable difference is found by
    # Welch's test at alpha 0.05 in about 80 % of repetitions, half of it far less often.
    n = 10
    rng = np.random.default_rng(1)
    base = rng.normal(size=n)
    base = (base - base.mean()) / base.std(ddof=1)
    difference = welch_detectable_difference(base, base)
    assert difference == pytest.approx(1.3247, abs=1e-3)

    def power(shift: float) -> float:
        first = rng.normal(size=(4000, n))
        second = rng.normal(loc=shift, size=(4000, n))
        p_values = [welch_t_test(a, b)[1] for a, b in zip(first, second, strict=True)]
        return float(np.mean(np.asarray(p_values) < 0.05))

    assert 0.76 <= power(difference) <= 0.84
    assert power(difference / 2) < 0.4
    assert welch_detectable_difference(base, base, power=0.9) > difference
    assert welch_detectable_difference([1.0, 1.0], [2.0, 2.0]) == 0.0
    with pytest.raises(ValueError, match=">= 2 values"):
        welch_detectable_difference([1.0], [2.0, 3.0])
    with pytest.raises(ValueError, match="power"):
        welch_detectable_difference(base, base, power=1.0)
