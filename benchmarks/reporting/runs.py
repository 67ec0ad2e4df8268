"""The study's run directories: which exist, which are complete, what they recorded.

``benchmarks/reproduce.py`` writes each run to ``<results>/<study>/<config>/seed_<k>/``.
A run is complete when its ``checkpoints/latest.pt`` has reached the study's
``max_steps`` frames; unfinished runs are listed by the report and left out of every
statistic.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from rlhc.plotting import METRICS_FILE, Run, differing_keys, read_config, read_metrics

from .study import STUDIES


@dataclass
class StudyRun:
    """One run directory of the study and how far it got."""

    study: str
    config: str
    seed: int
    path: Path
    frames: int | None  # of ``checkpoints/latest.pt``; ``None``: no checkpoint yet
    max_steps: int

    @property
    def complete(self) -> bool:
        """Its latest checkpoint has reached the study's ``max_steps`` frames."""
        return self.frames is not None and self.frames >= self.max_steps

    @property
    def name(self) -> str:
        """``study/config``."""
        return f"{self.study}/{self.config}"

    def curves(self) -> Run:
        """Its metrics and config (only read for complete runs)."""
        return Run(self.path, read_metrics(self.path / METRICS_FILE), read_config(self.path))


def checkpoint_frames(run_dir: Path) -> int | None:
    """Frames of the run's latest checkpoint, ``None`` if it has none."""
    # Imported here: torch is only needed once runs are actually discovered.
    from rlhc.checkpoint import CHECKPOINT_DIR, LATEST, load_checkpoint

    latest = run_dir / CHECKPOINT_DIR / LATEST
    return int(load_checkpoint(latest)["frames"]) if latest.exists() else None


def discover(
    results: Path,
    studies: dict[str, tuple[dict[str, tuple[str, ...]], int, int]] = STUDIES,
    frames_of: Callable[[Path], int | None] = checkpoint_frames,
) -> list[StudyRun]:
    """Every ``<study>/<config>/seed_<k>`` directory under ``results``, in plan order.

    Args:
        results: the study's root (``benchmarks/results/reproduce`` by default).
        studies: the plan, as :data:`reproduce.STUDIES`.
        frames_of: frames trained by a run directory (tests pass a fake).

    Returns:
        One :class:`StudyRun` per seed directory, complete or not.
    """
    found = []
    for study, (configs, _, max_steps) in studies.items():
        for config in configs:
            seeds = sorted(
                int(p.name.removeprefix("seed_"))
                for p in (results / study / config).glob("seed_*")
                if p.is_dir() and p.name.removeprefix("seed_").isdigit()
            )
            for seed in seeds:
                path = results / study / config / f"seed_{seed}"
                found.append(StudyRun(study, config, seed, path, frames_of(path), max_steps))
    return found


def complete_runs(runs: Iterable[StudyRun], name: str) -> list[StudyRun]:
    """The complete runs of ``study/config``, by seed."""
    return sorted((r for r in runs if r.name == name and r.complete), key=lambda r: r.seed)


def wall_time(run: StudyRun) -> float:
    """The trainer's ``wall_time`` in the run's last ``metrics.csv`` row (``nan``: none)."""
    column = read_metrics(run.path / METRICS_FILE).get("wall_time")
    return float(column[-1]) if column is not None and column.size else math.nan


def shown(config: dict[str, Any], key: str) -> str:
    """A recorded config value, or *absent* (the key did not exist when the run started)."""
    return f"`{config[key]}`" if key in config else "absent"


def config_drift(runs: Sequence[StudyRun]) -> list[str]:
    """Config keys whose recorded values differ between seeds of one configuration.

    Such keys come from code that changed while the study ran (e.g. a new option);
    they are listed so that a reader can judge whether the seeds are comparable.
    """
    notes = []
    for name in dict.fromkeys(r.name for r in runs if r.complete):
        members = [r.curves() for r in complete_runs(runs, name)]
        for key in differing_keys(members):
            values = ", ".join(
                f"seed {r.config.get('seed')}: {shown(r.config, key)}" for r in members
            )
            notes.append(f"`{name}` — `{key}` differs between seeds ({values}).")
    return notes
