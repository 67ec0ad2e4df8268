"""The study's run directories: which exist, which are complete, what they recorded.

Each run lives in ``<root>/<config>/seed_<k>/`` (``root``: its study config's
``hydra.sweep.dir``); ``python -m benchmarks.reproduce`` writes its ``summary.json``
(:mod:`reporting.summary`) after training, and ``--summaries-only`` for runs trained
otherwise (a multirun). A run is complete
when its summary says so; a run without a summary is still training (or was never
finished) and is left out of every statistic. Checkpoints are never read here.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from functools import cached_property
from pathlib import Path
from typing import Any

from rlhc.analysis.curves import METRICS_FILE, Run, differing_keys, read_config, read_metrics

from .plan import PlannedRun, Study
from .summary import RunSummary, read_summary


@dataclass(frozen=True)
class StudyRun:
    """One run directory of the study and its summary.

    Attributes:
        planned: the run as the plan describes it.
        path: its directory.
        summary: its ``summary.json``; ``None`` while it has none.
    """

    planned: PlannedRun
    path: Path
    summary: RunSummary | None

    @property
    def study(self) -> str:
        """The study's name."""
        return self.planned.study

    @property
    def config(self) -> str:
        """The configuration's name."""
        return self.planned.config

    @property
    def seed(self) -> int:
        """The run's seed."""
        return self.planned.seed

    @property
    def name(self) -> str:
        """``study/config``."""
        return self.planned.name

    @property
    def frames(self) -> int | None:
        """Frames trained as summarised; ``None`` without a summary or frames."""
        return self.summary.frames if self.summary is not None else None

    @property
    def complete(self) -> bool:
        """Its summary records a finished run."""
        return self.summary is not None and self.summary.completed

    @property
    def wall_time(self) -> float:
        """The summarised training wall time in seconds (``nan``: not recorded)."""
        if self.summary is None or self.summary.wall_time_s is None:
            return math.nan
        return self.summary.wall_time_s

    @cached_property
    def _curves(self) -> Run:
        return Run(self.path, read_metrics(self.path / METRICS_FILE), read_config(self.path))

    def curves(self) -> Run:
        """Its metrics and config, read once (only read for complete runs)."""
        return self._curves


def check_summary(planned: PlannedRun, summary: RunSummary | None, path: Path) -> None:
    """A summary must describe the run its directory holds.

    Raises:
        ValueError: its study, config, seed or budget is not the plan's.
    """
    if summary is None:
        return
    recorded = (summary.study, summary.config, summary.seed, summary.max_steps)
    expected = (planned.study, planned.config, planned.seed, planned.max_steps)
    if recorded != expected:
        raise ValueError(
            f"{path}: summary.json describes (study, config, seed, max_steps) = {recorded}, "
            f"the plan expects {expected}; re-write it with "
            "`python -m benchmarks.reproduce --summaries-only`"
        )


def discover(plan: Mapping[str, Study]) -> list[StudyRun]:
    """Every ``<root>/<config>/seed_<k>`` directory of the studies, in plan order.

    Args:
        plan: the studies (:func:`reporting.plan.studies`, or some of them).

    Returns:
        One :class:`StudyRun` per seed directory, complete or not (seeds beyond the
        plan's too).

    Raises:
        ValueError: a summary does not describe its directory's run.
    """
    found = []
    for study in plan.values():
        for config in study.configs:
            seeds = sorted(
                int(p.name.removeprefix("seed_"))
                for p in (study.root / config).glob("seed_*")
                if p.is_dir() and p.name.removeprefix("seed_").isdigit()
            )
            for seed in seeds:
                planned = PlannedRun(study.name, config, seed, study.max_steps, study.root)
                summary = read_summary(planned.run_dir)
                check_summary(planned, summary, planned.run_dir)
                found.append(StudyRun(planned, planned.run_dir, summary))
    return found


def seconds_per_frame(runs: Sequence[StudyRun]) -> float | None:
    """Measured training wall time per frame of the complete ``runs`` (mean over runs)."""
    rates = [
        r.wall_time / r.frames
        for r in runs
        if r.complete and r.frames and math.isfinite(r.wall_time)
    ]
    return sum(rates) / len(rates) if rates else None


def study_rate(plan: Mapping[str, Study], study: Study, runs: Sequence[StudyRun]) -> float | None:
    """Seconds per frame of ``study``'s complete runs, else of its game's in ``plan`` (on
    another library's env, of the same task's: another scenario runs at another rate;
    ``None``: no complete run of the game or task)."""
    rate = seconds_per_frame([r for r in runs if r.study == study.name])
    if rate is None:
        same = [r for r in runs if plan[r.study].environment == study.environment]
        rate = seconds_per_frame(same)
    return rate


def complete_runs(runs: Iterable[StudyRun], name: str) -> list[StudyRun]:
    """The complete runs of ``study/config``, by seed."""
    return sorted((r for r in runs if r.name == name and r.complete), key=lambda r: r.seed)


def shown(config: dict[str, Any], key: str) -> str:
    """A recorded config value, or *absent* (the key did not exist when the run started)."""
    return f"`{config[key]}`" if key in config else "absent"


def config_drift(runs: Sequence[StudyRun]) -> tuple[list[str], list[str]]:
    """Config keys whose recorded values differ between seeds of one configuration.

    Such keys come from code that changed while the study ran; they are reported so
    that a reader can judge whether the seeds are comparable.

    Returns:
        ``(notes, added)``: a note per key whose recorded values differ, and the keys
        that are only *absent* from some runs' configs while every run that records
        them holds one value (an option added while the study ran, at its default).
    """
    notes: list[str] = []
    added: set[str] = set()
    for name in dict.fromkeys(r.name for r in runs if r.complete):
        members = [r.curves() for r in complete_runs(runs, name)]
        for key in differing_keys(members):
            present = {repr(r.config[key]) for r in members if key in r.config}
            if len(present) == 1:
                added.add(key)
                continue
            values = ", ".join(
                f"seed {r.config.get('seed')}: {shown(r.config, key)}" for r in members
            )
            notes.append(f"`{name}` — `{key}` differs between seeds ({values}).")
    return notes, sorted(added)
