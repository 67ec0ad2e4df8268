"""The learning benchmark's report (``benchmarks/learning.py``): means, curves, table.

Each run entry of ``<env>_<preset>.json`` carries the match summaries of its final
checkpoint against the built-in teams (``vs_random``, ``vs_scripted``:
:meth:`rlhc.evaluation.matches.MatchResult.summary`) and its run directory, whose
``metrics.csv`` gives the learning curves.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from rlhc.plotting import METRICS_FILE, Run, aggregate, read_metrics

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


def plot_curves(
    run_dirs: dict[str, list[Path]], env: str, title: str, out: Path, smoothing: float = SMOOTHING
) -> Path:
    """Curves of :data:`CURVES` against frames: one line per critic, the mean over its
    seeds (each TensorBoard-smoothed), shaded by the 95% t interval across seeds.

    Args:
        run_dirs: critic -> its run directories (each holding ``metrics.csv``).
        env: the game (picks the panels).
        title: the figure's title.
        out: the PNG to write.
        smoothing: TensorBoard smoothing weight, in ``[0, 1)``.

    Returns:
        ``out``.
    """
    import matplotlib

    matplotlib.use("Agg")  # files only: never needs a display
    import matplotlib.pyplot as plt

    runs = {
        critic: [Run(path, read_metrics(path / METRICS_FILE)) for path in paths]
        for critic, paths in sorted(run_dirs.items())
    }
    panels = dict(CURVES[env])
    if env == "soccer":
        logged = sorted({name for group in runs.values() for r in group for name in r.columns})
        panels.update({name: name for name in logged if name.endswith("/cumulative_reward")})
    fig, axes = plt.subplots(1, len(panels), figsize=(4.6 * len(panels), 3.6), squeeze=False)
    for ax, (metric, label) in zip(axes.flat, panels.items(), strict=True):
        for critic, members in runs.items():
            curve = aggregate(members, metric, smoothing)
            if curve is None:
                continue
            seeds = f"{curve.runs} seed{'s' if curve.runs > 1 else ''}"
            (line,) = ax.plot(curve.steps, curve.mean, label=f"{critic} ({seeds})")
            if curve.runs > 1:
                ax.fill_between(
                    curve.steps, curve.low, curve.high, color=line.get_color(), alpha=0.2
                )
        if ax.lines:
            ax.legend(fontsize="small")
        else:  # e.g. soccer before its first episode ends
            ax.text(0.5, 0.5, "not logged", ha="center", va="center", transform=ax.transAxes)
        ax.set_title(label)
        ax.set_xlabel("frames (world-decisions)")
        ax.grid(alpha=0.3)
    fig.suptitle(f"{title} (smoothing {smoothing})")
    fig.tight_layout()
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=120)
    plt.close(fig)
    return out


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
