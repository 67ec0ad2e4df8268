"""What a finished run of the study records about itself: ``summary.json``.

``benchmarks/reproduce.py`` writes the file after each training process (and
``--summaries-only`` writes it for runs trained earlier); ``benchmarks/report.py`` reads
it, never a checkpoint, to know which runs are complete and what they trained. Its
fields are :class:`RunSummary`'s; values that could not be recovered are ``null`` and
:attr:`RunSummary.notes` says why.
"""

from __future__ import annotations

import dataclasses
import json
import math
import re
import subprocess
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from omegaconf import OmegaConf

from rlhc.analysis.curves import METRICS_FILE, read_metrics
from rlhc.training.loggers import recorded_frames

from .plan import PlannedRun

SUMMARY_FILE = "summary.json"
#: The training log ``benchmarks/reproduce.py`` appends each process's output to.
TRAIN_LOG = "train.log"
#: Hydra's record of the command-line overrides of the run.
OVERRIDES_FILE = Path(".hydra") / "overrides.yaml"
#: The line ``benchmarks/reproduce.py`` writes to the training log before each process.
CODE_VERSION_LINE = re.compile(r"^code version: (\S+)", re.MULTILINE)


@dataclass(frozen=True)
class RunSummary:
    """One run of the study as ``summary.json`` records it.

    Attributes:
        study: the study's name.
        config: the configuration's name.
        seed: the run's seed.
        max_steps: the budget, in frames.
        frames: frames trained (one frame = one step of one world, i.e. env steps;
            ``null``: nothing trained yet).
        frames_from: where :attr:`frames` was read (``checkpoints/latest.pt``, or the
            last ``step`` of ``metrics.csv`` when no checkpoint is kept).
        updates: PPO updates done (the last ``iteration`` in ``metrics.csv``).
        wall_time_s: the trainer's ``wall_time`` in the last row of ``metrics.csv``
            (collection + updates, carried across resumes).
        overrides: the run's Hydra overrides as ``.hydra/overrides.yaml`` recorded them
            (its resolved config is ``.hydra/config.yaml``).
        code_versions: every git commit a training process of the run started at, in
            order (``+dirty``: uncommitted changes); ``null``: not recorded.
        completed: :attr:`frames` reached :attr:`max_steps`.
        notes: why a value is ``null`` or where it was recovered from.
    """

    study: str
    config: str
    seed: int
    max_steps: int
    frames: int | None
    frames_from: str | None
    updates: int | None
    wall_time_s: float | None
    overrides: tuple[str, ...] | None
    code_versions: tuple[str, ...] | None
    completed: bool
    notes: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        expected = self.frames is not None and self.frames >= self.max_steps
        if self.completed != expected:
            raise ValueError(
                f"summary of {self.name} seed {self.seed}: completed={self.completed} but "
                f"frames={self.frames} of max_steps={self.max_steps}"
            )

    @property
    def name(self) -> str:
        """``study/config``."""
        return f"{self.study}/{self.config}"

    def to_json(self) -> str:
        """The file's text (keys in field order, two-space indent)."""
        return json.dumps(dataclasses.asdict(self), indent=2) + "\n"

    @classmethod
    def from_json(cls, text: str, source: str = "summary") -> RunSummary:
        """Parse :meth:`to_json`'s text.

        Raises:
            ValueError: not a JSON object with exactly :class:`RunSummary`'s fields, or
                inconsistent values (named with ``source``).
        """
        data = json.loads(text)
        names = [f.name for f in dataclasses.fields(cls)]
        if not isinstance(data, dict) or set(data) != set(names):
            keys = sorted(data) if isinstance(data, dict) else type(data).__name__
            raise ValueError(f"{source}: expected the keys {names}, found {keys}")
        for key in ("overrides", "code_versions", "notes"):
            if data[key] is not None:
                data[key] = tuple(data[key])
        return cls(**data)


def summary_path(run_dir: Path) -> Path:
    """Where a run directory keeps its summary."""
    return run_dir / SUMMARY_FILE


def read_summary(run_dir: Path) -> RunSummary | None:
    """The run's summary, ``None`` if it has none yet (still training, or never run)."""
    path = summary_path(run_dir)
    if not path.is_file():
        return None
    return RunSummary.from_json(path.read_text(), str(path))


def write_summary(run_dir: Path, summary: RunSummary) -> Path:
    """Write ``summary.json`` into ``run_dir``; returns its path."""
    path = summary_path(run_dir)
    path.write_text(summary.to_json())
    return path


def code_version(root: Path | None = None) -> str:
    """The git commit of the checkout (``+dirty`` with uncommitted changes to the code).

    Args:
        root: the checkout (default: this repository).
    """
    root = root or Path(__file__).resolve().parents[2]
    try:
        commit = subprocess.check_output(["git", "rev-parse", "HEAD"], cwd=root, text=True)
        dirty = subprocess.check_output(
            ["git", "status", "--porcelain", "--untracked-files=no", "rlhc", "conf"],
            cwd=root,
            text=True,
        )
    except (OSError, subprocess.CalledProcessError):
        return "unknown (not a git checkout)"
    return commit.strip() + ("+dirty" if dirty.strip() else "")


def logged_code_versions(run_dir: Path) -> tuple[str, ...] | None:
    """The ``code version:`` lines of the run's training log, in order, without repeats."""
    log = run_dir / TRAIN_LOG
    found = CODE_VERSION_LINE.findall(log.read_text()) if log.is_file() else []
    return tuple(dict.fromkeys(found)) or None


def recorded_overrides(run_dir: Path) -> tuple[str, ...] | None:
    """Hydra's ``.hydra/overrides.yaml`` of the run, ``None`` if absent."""
    path = run_dir / OVERRIDES_FILE
    if not path.is_file():
        return None
    recorded = OmegaConf.to_container(OmegaConf.load(path))
    return tuple(str(o) for o in recorded) if isinstance(recorded, list) else None


def _last(columns: dict[str, Any], name: str) -> float | None:
    """The last finite value of a ``metrics.csv`` column (``None``: none)."""
    column = columns.get(name)
    if column is None:
        return None
    finite = [float(v) for v in column if math.isfinite(v)]
    return finite[-1] if finite else None


def checkpoint_frames(run_dir: Path) -> int | None:
    """Frames of the run's latest checkpoint, ``None`` if it keeps none."""
    # Imported here: torch is only needed when a checkpoint exists.
    from rlhc.storage.checkpoint import CHECKPOINT_DIR, LATEST, load_checkpoint

    latest = run_dir / CHECKPOINT_DIR / LATEST
    return int(load_checkpoint(latest)["frames"]) if latest.exists() else None


def summarise(run: PlannedRun, run_dir: Path) -> RunSummary:
    """The summary of a run from its files.

    Frames come from the latest checkpoint; where none is kept (the committed study keeps
    only ``metrics.csv``, ``.hydra/`` and ``train.log``) from the last logged ``step`` of
    ``metrics.csv``, which the trainer writes after every update, and the notes say so.

    Args:
        run: the planned run (study, config, seed, budget).
        run_dir: its directory.
    """
    notes: list[str] = []
    metrics = run_dir / METRICS_FILE
    # A run that has just started has a metrics.csv with no row yet.
    columns = read_metrics(metrics) if recorded_frames(metrics) is not None else {}
    frames = checkpoint_frames(run_dir)
    frames_from: str | None = "checkpoints/latest.pt"
    if frames is None:
        last_step = _last(columns, "step")
        frames, frames_from = (None, None) if last_step is None else (int(last_step), None)
        if frames is not None:
            frames_from = f"{METRICS_FILE} (last step)"
            notes.append(f"no checkpoint kept: frames are the last step logged in {METRICS_FILE}")
        else:
            notes.append(f"no checkpoint and no row in {METRICS_FILE}: nothing trained yet")
    updates = _last(columns, "iteration")
    versions = logged_code_versions(run_dir)
    if versions is None:
        notes.append(f"{TRAIN_LOG} records no code version: the commit trained is unknown")
    overrides = recorded_overrides(run_dir)
    if overrides is None:
        notes.append(f"no {OVERRIDES_FILE}: the run's overrides are unknown")
    return RunSummary(
        study=run.study,
        config=run.config,
        seed=run.seed,
        max_steps=run.max_steps,
        frames=frames,
        frames_from=frames_from,
        updates=None if updates is None else int(updates),
        wall_time_s=_last(columns, "wall_time"),
        overrides=overrides,
        code_versions=versions,
        completed=frames is not None and frames >= run.max_steps,
        notes=tuple(notes),
    )
