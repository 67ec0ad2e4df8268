"""The learning benchmark's report (``benchmarks/learning.py``): means, curves, table.

Each run entry of ``<env>_<preset>.json`` carries the match summaries of its final
checkpoint against the built-in teams (``vs_random``, ``vs_scripted``:
:meth:`rlhc.evaluation.matches.MatchResult.summary`) and its run directory, whose
``metrics.csv`` gives the learning curves.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from rlhc.analysis.curves import METRICS_FILE, Run, read_metrics

from .figures import draw_learning_curves
from .study import PLAY_METRIC

#: The built-in teams every final checkpoint plays.
OPPONENTS = ("random", "scripted")
#: Match rates averaged over seeds.
RATES = ("win_rate", "draw_rate", "loss_rate", "points_won_rate")
#: Per-point events of a summary (tennis) averaged over seeds, by side.
HITS = "hits_over_net_by_team_per_point"
#: env -> ``metrics.csv`` column -> panel title; soccer also gets every ``*/cumulative_reward``.
CURVES: dict[str, dict[str, str]] = {
    "tennis": {
        "events/hits_over_net_per_episode": "over-the-net hits per point",
        "episode_length": "episode length (decisions)",
    },
    "soccer": {
        "episode_terminated": "goal rate (share of episodes ending in a goal)",
        "episode_length": "episode length (decisions)",
    },
}
#: Periodic play measurements (``play_freq``) drawn where a run logged them.
PLAY_PANELS: dict[str, dict[str, str]] = {
    "tennis": {
        "play/hits_per_point_mode": "hits per point, mode actions (play/)",
        "play/sigma_near/move": "move scale near the ball (play/)",
        "play/toward_ball": "share of moves toward the ball (play/)",
    },
    "soccer": {
        "play/self_play/trained/goals_per_1000": "goals per 1,000 decisions, self-play (play/)",
        "play/vs_scripted/trained/goals_per_1000": "goals per 1,000 vs scripted (play/)",
    },
}
SMOOTHING = 0.8


def finite_mean(values: Sequence[float | None]) -> float:
    """The mean of the finite ``values`` (``nan`` if there are none).

    Examples:
        >>> finite_mean([0.5, float("nan"), 1.0])
        0.75
    """
    finite = [v for v in values if v is not None and math.isfinite(v)]
    return float(np.mean(finite)) if finite else math.nan


def means_over_seeds(runs: Sequence[dict[str, Any]]) -> dict[str, Any]:
    """Per critic: its seeds and, per opponent, the mean of each match rate over them.

    Means skip undefined values (``points_won_rate`` is ``nan`` when no point was played).
    Tennis adds ``hits_over_net_per_point_home`` and ``..._away``.
    """
    by_critic: dict[str, list[dict[str, Any]]] = {}
    for run in runs:
        by_critic.setdefault(run["critic"], []).append(run)
    means: dict[str, Any] = {}
    for critic, members in by_critic.items():
        means[critic] = {"seeds": [run["seed"] for run in members]}
        for opponent in OPPONENTS:
            summaries = [run[f"vs_{opponent}"] for run in members]
            rates = {key: finite_mean([s[key] for s in summaries]) for key in RATES}
            if all(HITS in s for s in summaries):
                for side in ("home", "away"):
                    rates[f"hits_over_net_per_point_{side}"] = finite_mean(
                        [s[HITS][side] for s in summaries]
                    )
            means[critic][f"vs_{opponent}"] = rates
    return means


def read_curves(run_dirs: Mapping[str, Sequence[Path]]) -> dict[str, list[Run]]:
    """Critic -> the metrics of its run directories (each holding ``metrics.csv``), by critic."""
    return {
        critic: [Run(path, read_metrics(path / METRICS_FILE)) for path in paths]
        for critic, paths in sorted(run_dirs.items())
    }


def panels_of(env: str, runs: Mapping[str, Sequence[Run]]) -> dict[str, str]:
    """The panels of a game (:data:`CURVES`); soccer adds every logged ``*/cumulative_reward``,
    and both games the :data:`PLAY_PANELS` some run logged (``play_freq``)."""
    panels = dict(CURVES[env])
    logged = sorted({name for group in runs.values() for r in group for name in r.columns})
    if env == "soccer":
        panels.update({name: name for name in logged if name.endswith("/cumulative_reward")})
    panels.update({name: label for name, label in PLAY_PANELS[env].items() if name in logged})
    return panels


def bounds_of(env: str) -> dict[str, tuple[float, float]]:
    """The values each bounded panel of a game can take: episode length and hits per
    point are counts (at least 0), the goal rate a share (in [0, 1]).

    Examples:
        >>> bounds_of("soccer")["episode_terminated"]
        (0.0, 1.0)
    """
    play = PLAY_METRIC[env]
    counts = dict.fromkeys(PLAY_PANELS[env], (0.0, math.inf))
    return {**counts, "play/toward_ball": (0.0, 1.0), "episode_length": (0.0, math.inf),
            play.column: play.bounds}  # fmt: skip


def plot_curves(
    run_dirs: Mapping[str, Sequence[Path]],
    env: str,
    title: str,
    out: Path,
    smoothing: float = SMOOTHING,
) -> Path:
    """Curves of :data:`CURVES` against frames: one line per critic, the mean over its
    seeds (each TensorBoard-smoothed), shaded by the 95% t interval across seeds.

    Reads the runs (:func:`read_curves`) and draws them
    (:func:`reporting.figures.draw_learning_curves`).

    Args:
        run_dirs: critic -> its run directories (each holding ``metrics.csv``).
        env: the game (picks the panels).
        title: the figure's title.
        out: the PNG to write.
        smoothing: TensorBoard smoothing weight, in ``[0, 1)``.

    Returns:
        ``out``.
    """
    runs = read_curves(run_dirs)
    return draw_learning_curves(runs, panels_of(env, runs), title, out, smoothing, bounds_of(env))


def _share(value: float, width: int = 5) -> str:
    return f"{value:>{width}.0%}" if math.isfinite(value) else f"{'-':>{width}}"


def _match_cells(rates: dict[str, Any]) -> str:
    """Win, draw, loss and points shares, then the trained side's hits per point."""
    hits = rates.get(HITS, {}).get("home", rates.get("hits_over_net_per_point_home", math.nan))
    shown_hits = f"{hits:>5.2f}" if math.isfinite(hits) else f"{'-':>5}"
    return " ".join(_share(rates[key]) for key in RATES) + f" {shown_hits}"


def table(runs: Sequence[dict[str, Any]], means: dict[str, Any]) -> list[str]:
    """The stdout table: one line per run, then one per critic with the means over seeds."""
    head = "  win  draw  loss   pts  hits"
    training = f"{'critic':<16}{'seed':>5}{'frames':>11}{'wall s':>8}{'frames/s':>10}"
    lines = [
        f"{'':<50} | {'vs random':^29} | {'vs scripted':^29}",
        f"{training} | {head} | {head}",
    ]
    for run in runs:
        wall = run["wall_time_s"] if run["wall_time_s"] is not None else math.nan
        lines.append(
            f"{run['critic']:<16}{run['seed']:>5}{run['frames']:>11,}{wall:>8.0f}"
            f"{run['train_frames_per_s_mean']:>10.0f} | {_match_cells(run['vs_random'])} | "
            f"{_match_cells(run['vs_scripted'])}"
        )
    for critic, critic_means in means.items():
        seeds = f"mean of {len(critic_means['seeds'])} seeds"
        lines.append(
            f"{critic:<16}{seeds:>34} | {_match_cells(critic_means['vs_random'])} | "
            f"{_match_cells(critic_means['vs_scripted'])}"
        )
    lines.append(
        "win/draw/loss: shares of matches; pts: share of points won (-: none played); "
        "hits: over-the-net hits per point by the trained side (tennis)"
    )
    return lines
