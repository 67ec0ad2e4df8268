"""Confidence intervals and tests for match results and learning curves.

* Win rates are binomial proportions. Their interval is **Wilson's score interval**
  (Wilson, 1927): unlike the normal ("Wald") interval it stays inside [0, 1] and keeps
  close to its nominal coverage for small samples and for rates near 0 or 1 — exactly
  the regime of a strong policy against a weak one.
* Means over seeds use the **Student t** interval (few seeds, unknown variance).
* Two configurations are compared with **Welch's t-test** (unequal variances), on
  per-run values such as :func:`rlhc.runs.final_values`.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from statistics import NormalDist

import numpy as np
from scipy import stats as scipy_stats


def _z(confidence: float) -> float:
    if not 0.0 < confidence < 1.0:
        raise ValueError(f"confidence must lie in (0, 1), got {confidence}")
    return NormalDist().inv_cdf(0.5 + confidence / 2.0)


def wilson_interval(successes: float, trials: int, confidence: float = 0.95) -> tuple[float, float]:
    """Wilson score interval of a binomial proportion ``successes / trials``.

    Args:
        successes: number of successes, ``0 <= successes <= trials`` (a half-integer is
            accepted, e.g. wins plus half the draws).
        trials: number of trials; with ``0`` the interval is the whole ``[0, 1]``.
        confidence: two-sided confidence level.

    Returns:
        ``(low, high)``, both in ``[0, 1]``.

    Examples:
        >>> low, high = wilson_interval(50, 100)
        >>> round(low, 4), round(high, 4)
        (0.4038, 0.5962)
    """
    if trials < 0 or not 0 <= successes <= trials:
        raise ValueError(f"need 0 <= successes <= trials, got {successes} of {trials}")
    if trials == 0:
        return 0.0, 1.0
    z = _z(confidence)
    p = successes / trials
    denominator = 1.0 + z * z / trials
    centre = (p + z * z / (2 * trials)) / denominator
    half = z * math.sqrt(p * (1 - p) / trials + z * z / (4 * trials * trials)) / denominator
    # At 0 or ``trials`` successes the bound is exactly 0 or 1; rounding must not move it.
    low = 0.0 if successes == 0 else max(0.0, centre - half)
    high = 1.0 if successes == trials else min(1.0, centre + half)
    return low, high


@dataclass(frozen=True)
class MeanInterval:
    """A sample mean with its two-sided Student t confidence interval.

    Attributes:
        mean: the sample mean (``nan`` for an empty sample).
        low: lower bound (equal to ``mean`` for a single value: no spread is known).
        high: upper bound.
        n: sample size.
    """

    mean: float
    low: float
    high: float
    n: int


def t_interval(values: Sequence[float] | np.ndarray, confidence: float = 0.95) -> MeanInterval:
    """Mean and Student t interval of ``values`` (e.g. one number per seed).

    Examples:
        >>> ci = t_interval([1.0, 2.0, 3.0])
        >>> round(ci.mean, 3), round(ci.low, 3), round(ci.high, 3)
        (2.0, -0.484, 4.484)
    """
    sample = np.asarray(values, dtype=np.float64)
    n = int(sample.size)
    if n == 0:
        return MeanInterval(math.nan, math.nan, math.nan, 0)
    mean = float(sample.mean())
    if n == 1:
        return MeanInterval(mean, mean, mean, 1)
    half = float(t_half_width(float(sample.std(ddof=1)), n, confidence))
    return MeanInterval(mean, mean - half, mean + half, n)


def t_half_width(std: float | np.ndarray, n: int, confidence: float = 0.95) -> float | np.ndarray:
    """Half-width ``t_{n-1} · std / sqrt(n)`` of the t interval (vectorised over ``std``).

    Args:
        std: sample standard deviation(s) with ``ddof=1``.
        n: sample size, ``>= 2``.
        confidence: two-sided confidence level.
    """
    if n < 2:
        raise ValueError(f"a t interval needs at least 2 values, got {n}")
    _z(confidence)  # validates the level
    quantile = float(scipy_stats.t.ppf(0.5 + confidence / 2.0, df=n - 1))
    return quantile * std / math.sqrt(n)


def welch_t_test(
    a: Sequence[float] | np.ndarray, b: Sequence[float] | np.ndarray
) -> tuple[float, float]:
    """Welch's two-sided t-test of equal means with unequal variances.

    Args:
        a: per-run values of one configuration (at least 2).
        b: per-run values of the other (at least 2).

    Returns:
        ``(t, p_value)``; ``t > 0`` when ``a`` has the larger mean.

    Examples:
        >>> t, p = welch_t_test([1.0, 1.1, 0.9], [2.0, 2.2, 1.8])
        >>> t < 0 and p < 0.01
        True
    """
    first, second = np.asarray(a, dtype=np.float64), np.asarray(b, dtype=np.float64)
    if first.size < 2 or second.size < 2:
        raise ValueError(
            f"Welch's test needs >= 2 values per side, got {first.size} and {second.size}"
        )
    result = scipy_stats.ttest_ind(first, second, equal_var=False)
    return float(result.statistic), float(result.pvalue)
