"""Numbers, intervals and tables as the text of ``RESULTS.md``."""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Iterable, Sequence

from rlhc.evaluation.stats import MeanInterval, t_interval


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


def share_interval(values: Sequence[float]) -> MeanInterval:
    """The t interval of shares (scores, rates), clipped to ``[0, 1]`` where they live."""
    ci = t_interval(values)
    return dataclasses.replace(ci, low=max(ci.low, 0.0), high=min(ci.high, 1.0))


def positive_interval(values: Sequence[float]) -> MeanInterval:
    """The t interval of a quantity that cannot be negative (steps, lengths, rates, counts),
    its lower end clipped at 0 (with 2 or 3 seeds a t interval easily reaches below)."""
    ci = t_interval(values)
    return dataclasses.replace(ci, low=max(ci.low, 0.0))


def fmt_reach(reach: Sequence[float | None]) -> str:
    """Steps to a threshold of the seeds that reached it: mean [95% t, clipped at 0], and
    how many did.

    Seeds that never reached it are counted, not averaged (their steps are unknown).
    """
    hits = [r for r in reach if r is not None]
    if not reach:
        return "—"
    mean = fmt_interval(positive_interval(hits), 0, fixed=True) if hits else "—"
    return f"{mean} ({len(hits)}/{len(reach)} seeds)"


def table(header: Sequence[str], rows: Iterable[Sequence[str]]) -> list[str]:
    """A Markdown table."""
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(str(c) for c in row) + " |" for row in rows]
    return lines
