"""What the report compares in each study: groups, compared pairs, smoothing, windows.

The configurations, seeds and frames per run are the plan's
(:func:`reporting.plan.studies`, read from ``conf/study``); this module adds what only
the report needs.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from itertools import combinations
from typing import NamedTuple

from .plan import Study
from .runs import StudyRun

SMOOTHING = 0.8  # TensorBoard's EMA weight, as ``python -m rlhc.plot``
FINAL_FRACTION = 0.1  # the last 10% of each curve, by steps
THRESHOLD_FRACTION = 0.5  # share of the way from the initial to the best final reward
ALPHA = 0.05
#: The power at which a study states the smallest difference its seeds detect.
POWER = 0.8
#: game -> its group metrics' groups.
GROUPS = {"tennis": ("racket",), "soccer": ("striker", "goalie")}


class PlayMetric(NamedTuple):
    """The ``metrics.csv`` column that says whether a game's teams play."""

    column: str
    title: str
    share: bool  # a share of episodes, in [0, 1] (its intervals are clipped to it)

    @property
    def bounds(self) -> tuple[float, float]:
        """The values the metric can take: a share lies in [0, 1], a count in [0, inf)."""
        return (0.0, 1.0) if self.share else (0.0, math.inf)


#: game -> its play metric.
PLAY_METRIC = {
    "tennis": PlayMetric("events/hits_over_net_per_episode", "hits over the net per point", False),
    "soccer": PlayMetric(
        "episode_terminated", "goal rate (share of episodes ending in a goal)", True
    ),
}
#: The paper's critic, its baseline, and the optimism control, in comparison order:
#: each pair (first, second) present in a study is tested, first against second.
CRITICS = ("hierarchical", "twin", "ppo")
#: Studies whose tables also hold configs of another study (``study/config``): the
#: extensions are compared with the paper's tennis critics.
BORROWED = {"tennis_extensions": ("tennis_paper/hierarchical", "tennis_paper/ppo")}


def groups_of(study: Study, runs: Sequence[StudyRun]) -> tuple[str, ...]:
    """The groups of a study's group metrics: a game's (:data:`GROUPS`); on another
    library's env, whose groups depend on its task, those whose return its complete runs
    logged (``<group>/cumulative_reward``), by name.
    """
    if study.task is None:
        return GROUPS[study.env]
    logged = {c for r in runs if r.study == study.name and r.complete for c in r.curves().columns}
    suffix = "/cumulative_reward"
    return tuple(sorted(c.removesuffix(suffix) for c in logged if c.endswith(suffix)))


def lenders(names: Iterable[str]) -> set[str]:
    """The studies whose configs the studies ``names`` borrow.

    Examples:
        >>> sorted(lenders(["tennis_extensions", "soccer_paper"]))
        ['tennis_paper']
    """
    return {b.partition("/")[0] for name in names for b in BORROWED.get(name, ())}


def table_configs(study: Study) -> list[str]:
    """``study/config`` names in a study's tables (its own, then the borrowed ones)."""
    own = [f"{study.name}/{c}" for c in study.configs]
    return own + list(BORROWED.get(study.name, ()))


def comparisons_of(study: Study) -> list[tuple[str, str]]:
    """``(first, second)`` ``study/config`` pairs tested in a study.

    The paper's critics pairwise (RLHC vs twin vs PPO, whichever the study trains); an
    extension study tests each of its configs against the borrowed ones.
    """
    if study.name in BORROWED:
        borrowed = BORROWED[study.name]
        return [(f"{study.name}/{c}", other) for c in study.configs for other in borrowed]
    present = [c for c in CRITICS if c in study.configs]
    return [(f"{study.name}/{a}", f"{study.name}/{b}") for a, b in combinations(present, 2)]
