"""Ratings and scores of a study's final teams, from the stored series (no match played).

- :func:`ratings`: a Bradley-Terry fit on the Elo scale with a bootstrap interval;
- :func:`cross_score`: one set of teams against another (e.g. every RLHC seed against
  every PPO seed), with an interval that includes the spread between seeds;
- :func:`pair_records`: the record of every pair of two sets of teams (``None``: never met).

The series come from :mod:`reporting.tournament` (``round_robin.json``).

Examples:
    >>> series = [Series("scripted", "random", "scripted", "random", 10, 0, 9, 1, 0, "x")]
    >>> [(row.name, round(row.rating)) for row in ratings(series, resamples=0)]
    [('scripted', 400), ('random', 0)]
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from scipy import optimize, sparse, special
from scipy.sparse import csgraph

from rlhc.evaluation.stats import Estimate

from .tournament import Record, Series

#: Elo points per natural log-odds unit: P(i beats j) = 1 / (1 + 10^((R_j - R_i) / 400)).
ELO_PER_LOGIT = 400.0 / math.log(10.0)


@dataclass(frozen=True)
class Rating:
    """One team's row of the rating table.

    Attributes:
        name: the team.
        rating: its Elo-scale rating (the anchor's is fixed).
        low: lower bound of its bootstrap interval; ``high`` likewise.
        matches: matches it played.
        score: its mean score per match (a win 1, a draw 0.5).
    """

    name: str
    rating: float
    low: float
    high: float
    matches: int
    score: float


def fit_ratings(
    first: np.ndarray,
    second: np.ndarray,
    score: np.ndarray,
    matches: np.ndarray,
    anchor: int,
    start: np.ndarray | None = None,
) -> np.ndarray:
    """Bradley–Terry maximum likelihood in log-odds units, the ``anchor`` team at 0.

    Team ``first[e]`` scored ``score[e]`` of ``matches[e]`` against ``second[e]``;
    ``P(i beats j) = sigmoid(theta_i - theta_j)``, a draw counting half a win for each,
    so the log-likelihood is ``sum s log p + (n - s) log(1 - p)`` (concave). Solved by
    ``scipy.optimize.minimize`` (``trust-exact``: exact gradient and Hessian), then
    polished by Newton steps.

    Returns:
        ``theta [T]`` for the ``T = max(first, second) + 1`` teams.

    Raises:
        RuntimeError: the optimiser did not converge (its message is included).
    """
    teams = int(max(first.max(), second.max(), anchor)) + 1
    incidence = np.zeros((len(first), teams))
    incidence[np.arange(len(first)), first] += 1.0
    incidence[np.arange(len(first)), second] -= 1.0
    incidence = np.delete(incidence, anchor, axis=1)

    def objective(theta: np.ndarray) -> tuple[float, np.ndarray]:
        gap = incidence @ theta
        value = score @ np.logaddexp(0.0, -gap) + (matches - score) @ np.logaddexp(0.0, gap)
        return float(value), incidence.T @ (matches * special.expit(gap) - score)

    def hessian(theta: np.ndarray) -> np.ndarray:
        p = special.expit(incidence @ theta)
        return incidence.T @ ((matches * p * (1.0 - p))[:, None] * incidence)

    x0 = np.zeros(teams - 1) if start is None else np.delete(start, anchor)
    result = optimize.minimize(objective, x0, jac=True, hess=hessian, method="trust-exact")
    # Near the optimum the rounding of a large log-likelihood hides further progress
    # (the minimiser stops, or reports a loss of precision) long before the gradient
    # does: a few plain Newton steps finish the job; the gradient decides convergence.
    theta = result.x
    for _ in range(3):
        theta = theta - np.linalg.solve(hessian(theta), objective(theta)[1])
    if not np.abs(objective(theta)[1]).max() <= 1e-9 * matches.sum():
        raise RuntimeError(f"the Bradley-Terry fit did not converge: {result.message}")
    return np.insert(theta, anchor, 0.0)


def _check_connected(names: Sequence[str], first: np.ndarray, second: np.ndarray) -> None:
    """Raise unless every team is linked to the first (the anchor) by a chain of series."""
    graph = sparse.coo_array((np.ones(len(first)), (first, second)), shape=(len(names),) * 2)
    _, component = csgraph.connected_components(graph, directed=False)
    apart = [name for name, c in zip(names, component, strict=True) if c != component[0]]
    if apart:
        raise ValueError(
            f"teams {apart} share no chain of series with {names[0]!r}: ratings of "
            "unconnected groups cannot be put on one scale"
        )


def ratings(
    series: Sequence[Series],
    anchor: str = "random",
    anchor_rating: float = 0.0,
    resamples: int = 1000,
    seed: int = 0,
    *,
    virtual_draws: float = 1.0,
    confidence: float = 0.95,
) -> list[Rating]:
    """Elo-scale Bradley–Terry ratings of every team, with bootstrap intervals.

    The model is ``P(i beats j) = 1 / (1 + 10^((R_j - R_i) / 400))`` with a draw half a
    win for each side, fitted by maximum likelihood (:func:`fit_ratings`) over the
    series pooled per pair of teams. **Regularisation:** every pair that played gets
    ``virtual_draws`` extra drawn matches (BayesElo's prior), so an undefeated or
    winless team has a finite rating; it pulls the teams of a pair together by about
    the weight of one match among theirs (a 20-0 series is fitted as 20.5 of 21 points,
    a gap of 644 Elo). The anchor's rating is fixed at ``anchor_rating``; the others'
    are relative to it.

    **Intervals:** a parametric bootstrap: each series' wins, draws and losses are
    redrawn from a multinomial with its observed rates and as many matches, the
    ratings refitted, and the ``(1 ± confidence) / 2`` percentiles taken. A series won
    or lost entirely is redrawn identically (its rates are 0 and 1). The anchor's
    interval is its fixed rating.

    Args:
        series: the played series; every team must be linked to the anchor by series.
        anchor: the team whose rating is fixed (default the uniform random team).
        anchor_rating: its rating.
        resamples: bootstrap resamples; ``0`` gives intervals equal to the ratings.
        seed: the bootstrap generator's seed.
        virtual_draws: drawn matches added per pair (``> 0``).
        confidence: coverage of the intervals.

    Returns:
        One row per team, best first.

    Raises:
        ValueError: no series, an anchor that did not play, teams not linked to it,
            ``virtual_draws <= 0`` or ``resamples < 0``.
    """
    if virtual_draws <= 0 or resamples < 0:
        raise ValueError(f"virtual_draws={virtual_draws} (> 0), resamples={resamples} (>= 0)")
    names = list(dict.fromkeys(n for s in series for n in (s.home, s.away)))
    if anchor not in names:
        raise ValueError(f"anchor {anchor!r} played no series; teams: {names}")
    names.remove(anchor)
    names.insert(0, anchor)
    index = {name: i for i, name in enumerate(names)}
    # Series are pooled per unordered pair (first, second); home is first where sign.
    keys = [tuple(sorted((index[s.home], index[s.away]))) for s in series]
    ends = sorted(set(keys))
    pair = np.array([ends.index(key) for key in keys])
    sign = np.array([index[s.home] < index[s.away] for s in series])
    first, second = np.array(ends).T
    _check_connected(names, first, second)
    counts = np.array([[s.wins, s.draws, s.losses] for s in series], dtype=np.float64)
    played = counts.sum(axis=1)

    def solve(counts: np.ndarray, start: np.ndarray | None = None) -> np.ndarray:
        # The first team's score per series (a draw is half), summed per pair.
        won = np.where(sign, counts[:, 0], counts[:, 2]) + 0.5 * counts[:, 1]
        score = np.bincount(pair, won, len(ends)) + 0.5 * virtual_draws
        total = np.bincount(pair, played, len(ends)) + virtual_draws
        return fit_ratings(first, second, score, total, 0, start)

    theta = solve(counts)
    low = high = theta
    if resamples:
        rng = np.random.default_rng(seed)
        draws = np.stack(
            [
                rng.multinomial(int(n), c / n, size=resamples)
                for c, n in zip(counts, played, strict=True)
            ],
            axis=1,
        )  # [B, S, 3]
        fits = np.array([solve(d.astype(np.float64), theta) for d in draws])
        tail = 100.0 * (1.0 - confidence) / 2.0
        low, high = np.percentile(fits, [tail, 100.0 - tail], axis=0)
    rows = []
    for name, i in index.items():
        records = [s.record_of(name) for s in series if name in (s.home, s.away)]
        total = sum(records, Record(0, 0, 0))
        rating, bottom, top = (
            anchor_rating + ELO_PER_LOGIT * float(x[i]) for x in (theta, low, high)
        )
        rows.append(Rating(name, rating, bottom, top, total.matches, total.score))
    return sorted(rows, key=lambda row: -row.rating)


# --- one set of teams against another ------------------------------------------------
def pair_records(
    series: Sequence[Series],
    a_names: Sequence[str],
    b_names: Sequence[str],
    allow_missing: bool = False,
) -> list[list[Record | None]]:
    """``[i][j]``: the record of ``a_names[i]`` against ``b_names[j]`` (series pooled).

    Args:
        series: the played series.
        a_names: one side's teams; ``b_names`` the other's.
        allow_missing: a pairing without a series is ``None`` instead of an error (a
            team whose weights are lost cannot meet teams trained after it).

    Raises:
        ValueError: a name repeats or is on both sides, a side is empty, or (unless
            ``allow_missing``) a pairing has no series (every missing pairing is named).
    """
    if not a_names or not b_names or len({*a_names, *b_names}) != len(a_names) + len(b_names):
        raise ValueError(f"teams {list(a_names)} vs {list(b_names)}: need two non-empty, "
                         "disjoint sets, each name once")  # fmt: skip
    records = [[Record(0, 0, 0) for _ in b_names] for _ in a_names]
    for s in series:
        for i, a in enumerate(a_names):
            for j, b in enumerate(b_names):
                if {s.home, s.away} == {a, b}:
                    records[i][j] += s.record_of(a)
    missing = [f"{a} vs {b}" for i, a in enumerate(a_names) for j, b in enumerate(b_names)
               if not records[i][j].matches]  # fmt: skip
    if missing and not allow_missing:
        raise ValueError(f"no series for pairing(s) {missing}; play them with play_round_robin")
    return [[r if r.matches else None for r in row] for row in records]


def cross_score(
    series: Sequence[Series],
    a_names: Sequence[str],
    b_names: Sequence[str],
    resamples: int = 2000,
    seed: int = 0,
    confidence: float = 0.95,
    allow_missing: bool = False,
) -> Estimate:
    """Mean score of the teams ``a_names`` against the teams ``b_names``, with its interval.

    The estimate is the mean over all pairs ``(A_i, B_j)`` of ``A_i``'s score per match
    against ``B_j`` (a draw 0.5). The interval is a two-level percentile bootstrap: each
    resample draws A's seeds and B's seeds with replacement, and each pair's matches
    (its wins, draws and losses redrawn from a multinomial with its observed rates), so
    it includes the spread between seeds and not only between matches.

    With ``allow_missing``, pairs without a series are left out: the estimate is the
    mean over the pairs played, each resample's the mean over the played pairs it drew
    (a resample that drew none is discarded). That is unbiased when whether a pair was
    played does not depend on how the teams play (e.g. teams trained in different
    sessions, whose earlier weights were lost).

    Args:
        series: the played series (either team may have been home).
        a_names: the teams of one side, e.g. every ``hierarchical/seed_k``.
        b_names: the teams of the other, e.g. every ``ppo/seed_k``.
        resamples: bootstrap resamples (``0``: the interval is the estimate).
        seed: the bootstrap generator's seed.
        confidence: coverage of the interval.
        allow_missing: see above; otherwise a missing pair is an error.

    Raises:
        ValueError: as :func:`pair_records`; or no pair at all was played.

    Examples:
        >>> series = [Series("a", "b", "1", "1", 4, 0, 3, 0, 1, "x")]
        >>> cross_score(series, ["a"], ["b"]).value
        0.75
        >>> cross_score(series, ["a", "c"], ["b"], allow_missing=True).value
        0.75
    """
    records = pair_records(series, a_names, b_names, allow_missing)
    empty = Record(0, 0, 0)
    counts = np.array(
        [[[r.wins, r.draws, r.losses] for r in (x or empty for x in row)] for row in records]
    )
    played = counts.sum(axis=-1)
    mask = played > 0
    if not mask.any():
        raise ValueError(f"teams {list(a_names)} vs {list(b_names)}: no pair has played")
    safe = np.maximum(played, 1)
    scores = (counts[..., 0] + 0.5 * counts[..., 1]) / safe
    value = float(scores[mask].mean())
    if not resamples:
        return Estimate(value, value, value)
    rng = np.random.default_rng(seed)
    n_a, n_b = scores.shape
    redrawn = np.zeros((resamples, n_a, n_b))
    for i in range(n_a):
        for j in range(n_b):
            if not mask[i, j]:
                continue
            draws = rng.multinomial(played[i, j], counts[i, j] / played[i, j], size=resamples)
            redrawn[:, i, j] = (draws[:, 0] + 0.5 * draws[:, 1]) / played[i, j]
    rows = rng.integers(n_a, size=(resamples, n_a))
    columns = rng.integers(n_b, size=(resamples, n_b))
    pick = (np.arange(resamples)[:, None, None], rows[:, :, None], columns[:, None, :])
    picked, picked_mask = redrawn[pick], mask[rows[:, :, None], columns[:, None, :]]
    drawn = picked_mask.sum(axis=(1, 2))
    means = (picked * picked_mask).sum(axis=(1, 2))[drawn > 0] / drawn[drawn > 0]
    tail = 100.0 * (1.0 - confidence) / 2.0
    low, high = np.percentile(means, [tail, 100.0 - tail])
    return Estimate(value, float(low), float(high))
