"""Competition evaluation: head-to-head matches, Elo ratings, videos, cross-play.

| module | holds |
|---|---|
| :mod:`~rlhc.evaluation.stats` | Wilson and Student t intervals, Welch's t-test |
| :mod:`~rlhc.evaluation.elo` | Elo expected score and update, :class:`EloTable`, round robins |
| :mod:`~rlhc.evaluation.opponents` | team policies: ``random``, ``scripted``, checkpoints |
| :mod:`~rlhc.evaluation.matches` | batched matches between two teams, :func:`evaluate_against` |
| :mod:`~rlhc.evaluation.video` | a match rendered to GIF or MP4 with a score overlay |
| :mod:`~rlhc.evaluation.cross_play` | on another library's env of competing groups: each group of one run against the others of another |

The modules that need TorchRL are imported on first use, so that ``rlhc.plot`` starts quickly.

Examples:
    >>> from rlhc.evaluation import EloTable, wilson_interval
    >>> from rlhc.evaluation import evaluate_against  # imports rlhc.evaluation.matches now
    >>> evaluate_against.__module__
    'rlhc.evaluation.matches'
"""

from __future__ import annotations

import importlib
from typing import Any

from rlhc.evaluation.elo import EloTable, elo_update, expected_score, round_robin
from rlhc.evaluation.stats import t_interval, welch_t_test, wilson_interval

#: Lazily imported names -> their module.
_LAZY = {
    "CrossPlay": "rlhc.evaluation.cross_play",
    "cross_play": "rlhc.evaluation.cross_play",
    "MatchResult": "rlhc.evaluation.matches",
    "evaluate_against": "rlhc.evaluation.matches",
    "play_matches": "rlhc.evaluation.matches",
    "make_team_policy": "rlhc.evaluation.opponents",
    "record_match": "rlhc.evaluation.video",
}


def __getattr__(name: str) -> Any:
    if name in _LAZY:
        return getattr(importlib.import_module(_LAZY[name]), name)
    raise AttributeError(f"module 'rlhc.evaluation' has no attribute {name!r}")


__all__ = [
    "EloTable",
    "elo_update",
    "expected_score",
    "round_robin",
    "t_interval",
    "welch_t_test",
    "wilson_interval",
    *_LAZY,
]
