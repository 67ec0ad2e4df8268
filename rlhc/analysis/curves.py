"""Reading runs: ``metrics.csv`` and configs, seed grouping, smoothed curves, final values.

Each run directory holds a ``metrics.csv`` (one row per summary, ``step`` = frames) and
its config (``.hydra/config.yaml``, or its checkpoint's). Runs are found and read
(:func:`load_runs`), grouped by the config keys that differ between them, seeds aside
(:func:`group_runs`), smoothed and averaged with a 95% t interval (:func:`aggregate`);
:func:`final_values` gives the numbers a reproduction compares.

Examples:
    Two seeds of PPO (``critic.fusion=local``) and one of RLHC:

    >>> steps = np.array([64.0, 128.0])
    >>> runs = [
    ...     Run(Path(f"{fusion}_{seed}"), {"step": steps}, {"critic.fusion": fusion, "seed": seed})
    ...     for fusion, seed in (("local", 0), ("local", 1), ("max", 0))
    ... ]
    >>> {label: [run.path.name for run in members] for label, members in group_runs(runs).items()}
    {'fusion=local': ['local_0', 'local_1'], 'fusion=max': ['max_0']}
"""

from __future__ import annotations

import csv
import math
import os
from collections import defaultdict
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from omegaconf import OmegaConf

from rlhc.evaluation.stats import t_half_width
from rlhc.storage.checkpoint import flatten

METRICS_FILE = "metrics.csv"
HYDRA_CONFIG = Path(".hydra") / "config.yaml"
#: The paper's four curves: metric leaf -> axis title. Group metrics are ``<g>/<leaf>``.
PAPER_METRICS: dict[str, str] = {
    "cumulative_reward": "cumulative reward",
    "episode_length": "episode length",
    "entropy": "entropy",
    "state_value": "value estimate",
}
#: Config keys that never distinguish configurations (seeds are what gets averaged).
IGNORED_KEYS = (
    "seed",
    "resume",
    "device",
    "threads",
    "checkpoint_freq",
    "eval_freq",
    "eval_matches",
)
IGNORED_PREFIXES = ("logger.",)
#: Label keys when all runs share one configuration.
FALLBACK_LABEL_KEYS = ("env.name", "critic.fusion")


@dataclass
class Run:
    """One training run's logged metrics and config.

    Attributes:
        path: the run directory.
        columns: metric name -> values, one per ``metrics.csv`` row (``nan`` if absent).
        config: the flattened config (``"critic.fusion" -> "max"``), empty if unknown.
    """

    path: Path
    columns: dict[str, np.ndarray]
    config: dict[str, Any] = field(default_factory=dict)

    @property
    def steps(self) -> np.ndarray:
        return self.columns["step"]


def split_run_paths(
    paths: Iterable[str | os.PathLike[str]],
) -> tuple[list[Path], list[Path]]:
    """The run directories (holding ``metrics.csv``) at or under ``paths``, and the paths with none.

    A path is a run directory, a directory with runs below it (a multirun) or a
    ``metrics.csv`` file; any other path (a multirun's ``multirun.yaml``) holds no run.

    Returns ``(runs, not_runs)``: run directories sorted without duplicates, and the paths
    holding no run in the order given; :class:`FileNotFoundError` names a missing path.
    """
    found: list[Path] = []
    not_runs: list[Path] = []
    for raw in paths:
        path = Path(raw).expanduser()
        if path.is_file() and path.name == METRICS_FILE:
            found.append(path.parent)
            continue
        if not path.exists():
            raise FileNotFoundError(f"run path {str(path)!r} does not exist")
        runs = sorted(p.parent for p in path.rglob(METRICS_FILE)) if path.is_dir() else []
        found.extend(runs)
        if not runs:
            not_runs.append(path)
    return sorted(dict.fromkeys(found)), not_runs


def read_metrics(path: Path) -> dict[str, np.ndarray]:
    """The columns of a ``metrics.csv`` as float arrays (empty cells are ``nan``)."""
    with path.open(newline="") as f:
        rows = list(csv.DictReader(f))
    if not rows or "step" not in rows[0]:
        raise ValueError(f"{str(path)!r} has no rows or no 'step' column")
    names = list(rows[0])
    return {
        name: np.array([float(row[name]) if row.get(name) else math.nan for row in rows])
        for name in names
    }


def read_config(run_dir: Path) -> dict[str, Any]:
    """The run's flattened config: Hydra's record, else the latest checkpoint's, else ``{}``."""
    hydra_file = run_dir / HYDRA_CONFIG
    if hydra_file.is_file():
        container = OmegaConf.to_container(OmegaConf.load(hydra_file), resolve=False)
        return (
            flatten({str(k): v for k, v in container.items()})
            if isinstance(container, dict)
            else {}
        )
    from rlhc.storage.checkpoint import load_checkpoint  # torch is only needed on this path

    try:
        return flatten(load_checkpoint(run_dir).get("config", {}))
    except (FileNotFoundError, ValueError):
        return {}


def load_runs(paths: Iterable[str | os.PathLike[str]]) -> list[Run]:
    """Every run at or under ``paths`` (:func:`split_run_paths`), metrics and config read.

    Raises:
        FileNotFoundError: a path does not exist, or holds no ``metrics.csv`` at all.
    """
    runs, not_runs = split_run_paths(paths)
    if not_runs:
        raise FileNotFoundError(f"no {METRICS_FILE} at or under {str(not_runs[0])!r}")
    return [Run(run, read_metrics(run / METRICS_FILE), read_config(run)) for run in runs]


def ema_smooth(values: Sequence[float] | np.ndarray, weight: float = 0.8) -> np.ndarray:
    """TensorBoard's smoothing: a debiased exponential moving average.

    ``m_i = w·m_{i-1} + (1 - w)·x_i`` from ``m_{-1} = 0``, reported as ``m_i / (1 - w^k)``,
    ``k`` the finite values so far (so the curve does not start at 0). Non-finite values
    are skipped and stay ``nan``; ``weight`` ``w`` lies in ``[0, 1)`` (0: no smoothing).

    Examples:
        >>> ema_smooth([1.0, 1.0, 1.0], 0.9).tolist()
        [1.0, 1.0, 1.0]
        >>> [round(float(v), 4) for v in ema_smooth([0.0, 1.0], 0.5)]
        [0.0, 0.6667]
    """
    if not 0.0 <= weight < 1.0:
        raise ValueError(f"smoothing weight must lie in [0, 1), got {weight}")
    raw = np.asarray(values, dtype=np.float64)
    smoothed = np.full_like(raw, math.nan)
    last, count = 0.0, 0
    for i, value in enumerate(raw):
        if not math.isfinite(value):
            continue
        last = weight * last + (1.0 - weight) * value
        count += 1
        smoothed[i] = last / (1.0 - weight**count)
    return smoothed


def group_runs(runs: Sequence[Run], group_by: Sequence[str] | None = None) -> dict[str, list[Run]]:
    """Runs grouped by configuration: ``label -> runs``, labels in first-seen order.

    ``group_by`` names the config keys that define a configuration (e.g.
    ``["critic.fusion", "env.extended_obs"]``; ``None``: :func:`differing_keys`). A run
    without a known config is its own group, labelled by its directory name.
    """
    keys = list(group_by) if group_by is not None else differing_keys(runs)
    if not keys:
        keys = [k for k in FALLBACK_LABEL_KEYS if any(k in run.config for run in runs)]
    groups: dict[str, list[Run]] = defaultdict(list)
    for run in runs:
        if not run.config:
            groups[run.path.name].append(run)
            continue
        label = ", ".join(f"{k.rsplit('.', 1)[-1]}={run.config.get(k)}" for k in keys)
        groups[label or "runs"].append(run)
    return dict(groups)


def differing_keys(runs: Sequence[Run]) -> list[str]:
    """Config keys whose values differ between runs (seeds and bookkeeping excluded).

    Across games only ``env.name`` is reported (they differ in every Table 3 value), plus
    what varies inside a game.
    """
    by_env: dict[Any, list[Run]] = defaultdict(list)
    for run in runs:
        by_env[run.config.get("env.name")].append(run)
    if len(by_env) > 1:
        inside = {key for members in by_env.values() for key in differing_keys(members)}
        return ["env.name", *sorted(inside)]
    configured = [run.config for run in runs if run.config]
    names = sorted({k for config in configured for k in config})
    return [
        name
        for name in names
        if name not in IGNORED_KEYS
        and not name.startswith(IGNORED_PREFIXES)
        and len({repr(config.get(name)) for config in configured}) > 1
    ]


@dataclass(frozen=True)
class Curve:
    """A group's mean curve over seeds with its 95% t interval (equal to the mean for one run)."""

    steps: np.ndarray
    mean: np.ndarray
    low: np.ndarray
    high: np.ndarray
    runs: int


def aggregate(
    runs: Sequence[Run],
    metric: str,
    smoothing: float = 0.8,
    confidence: float = 0.95,
    bounds: tuple[float, float] = (-math.inf, math.inf),
) -> Curve | None:
    """Smooth each run's ``metric``, align the runs on common steps, and average them.

    The steps are the union of the runs' steps up to the shortest run's end, where each
    run is interpolated. The t band is clipped to ``bounds``, the values ``metric`` can
    take (e.g. a share's ``(0, 1)``). ``None`` if no run logged ``metric``.
    """
    series = []
    for run in runs:
        if metric not in run.columns:
            continue
        smoothed = ema_smooth(run.columns[metric], smoothing)
        finite = np.isfinite(smoothed)
        if finite.any():
            series.append((run.steps[finite], smoothed[finite]))
    if not series:
        return None
    end = min(steps[-1] for steps, _ in series)
    grid = np.unique(np.concatenate([steps[steps <= end] for steps, _ in series]))
    values = np.stack([np.interp(grid, steps, curve) for steps, curve in series])
    mean = values.mean(axis=0)
    if len(series) < 2:
        return Curve(grid, mean, mean, mean, 1)
    half = np.asarray(t_half_width(values.std(axis=0, ddof=1), len(series), confidence))
    low, high = np.clip(mean - half, *bounds), np.clip(mean + half, *bounds)
    return Curve(grid, mean, low, high, len(series))


def panel_metrics(runs: Sequence[Run], leaves: Iterable[str] = PAPER_METRICS) -> list[str]:
    """The logged columns of the paper's metrics: ``episode_length`` and ``<g>/<leaf>``."""
    columns = {name for run in runs for name in run.columns}
    panels = []
    for leaf in leaves:
        panels += sorted(c for c in columns if c == leaf or c.endswith(f"/{leaf}"))
    return panels


def final_values(runs: Sequence[Run], metric: str, fraction: float = 0.1) -> dict[Path, float]:
    """Per run, the mean raw (unsmoothed) value of ``metric`` where
    ``step >= (1 - fraction) · last_step``; runs that never logged ``metric`` are left out.

    Examples:
        >>> run = Run(Path("r"), {"step": np.arange(1.0, 11.0), "m": np.arange(10.0)})
        >>> final_values([run], "m", fraction=0.2)
        {PosixPath('r'): 8.0}
    """
    if not 0.0 < fraction <= 1.0:
        raise ValueError(f"fraction must lie in (0, 1], got {fraction}")
    values: dict[Path, float] = {}
    for run in runs:
        if metric not in run.columns:
            continue
        column, steps = run.columns[metric], run.steps
        window = (steps >= (1.0 - fraction) * steps.max()) & np.isfinite(column)
        if window.any():
            values[run.path] = float(column[window].mean())
    return values
