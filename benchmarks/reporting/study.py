"""What the report compares in the study: groups, compared pairs, smoothing, windows.

The configurations, seeds and frames per run are the plan's
(:data:`reporting.plan.STUDIES`); this module adds what only the report needs.
"""

from __future__ import annotations

from .plan import STUDIES

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


def study_env(study: str) -> str:
    """The game of a study (from its configs' ``env=`` override)."""
    return STUDIES[study].env


def table_configs(study: str) -> list[str]:
    """``study/config`` names in a study's tables (its own, then the borrowed ones)."""
    return [f"{study}/{c}" for c in STUDIES[study].configs] + list(BORROWED.get(study, ()))


def comparisons_of(study: str) -> list[tuple[str, str]]:
    """(RLHC, PPO) ``study/config`` pairs tested in a study."""
    if study in PAIRS:
        return [(f"{study}/{a}", f"{study}/{b}") for a, b in PAIRS[study]]
    borrowed = BORROWED.get(study, ())
    return [(f"{study}/{c}", other) for c in STUDIES[study].configs for other in borrowed]
