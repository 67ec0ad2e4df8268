"""Metric logging: a tidy ``metrics.csv``, TensorBoard, TorchRL's wandb logger; progress lines.

``metrics.csv`` has one row per summary and one column per metric (plus ``step``, the
frame count). It is what ``rlhc.plot`` reads and what survives a resume: on resume,
rows past the checkpoint's step are dropped, so the curve continues without a gap or
a duplicate, and so is a torn last line (:func:`read_rows`). TensorBoard gets the same
treatment: a resumed run appends to the run's own ``tb/<name>/`` and hides the points
past the checkpoint's step (the event files' ``purge_step``, which torch's
``SummaryWriter`` takes and TorchRL's ``TensorboardLogger`` does not pass on). wandb
continues the same run too: its id is kept in the run directory's ``wandb_run_id``
file, written at the first start and passed back on every resume
(``wandb.init(id=…, resume="allow")``).

:class:`ProgressLines` writes a line to the ``logging`` module every tenth of the
budget; ``rlhc.run``'s Hydra logging sends it to stdout and the run's ``run.log``.
"""

from __future__ import annotations

import csv
import datetime
import logging
import math
import os
import re
import secrets
import time
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from rlhc.config.train_schema import LoggerConfig
from rlhc.config.validation import WANDB_MODES, check_logger
from rlhc.errors import ConfigError

METRICS_FILE = "metrics.csv"
TENSORBOARD_DIR = "tb"
#: The run directory's wandb run id (written at the first start, read on a resume).
WANDB_RUN_ID_FILE = "wandb_run_id"

log = logging.getLogger(__name__)


def wandb_mode(requested: str) -> str:
    """Resolve ``auto``: online only when an API key is configured (env var or netrc)."""
    if requested not in WANDB_MODES:
        raise ConfigError(f"logger.wandb_mode={requested!r}; allowed: {', '.join(WANDB_MODES)}")
    if requested != "auto":
        return requested
    if os.environ.get("WANDB_MODE"):
        return os.environ["WANDB_MODE"]
    netrc = Path.home() / ".netrc"
    has_key = bool(os.environ.get("WANDB_API_KEY")) or (
        netrc.is_file() and "api.wandb.ai" in netrc.read_text(errors="ignore")
    )
    return "online" if has_key else "offline"


def wandb_run_id(run_dir: Path, resume: bool) -> str:
    """The id of the run directory's wandb run: a new one, or on a resume the kept one.

    A fresh start writes a new id to ``<run_dir>/wandb_run_id``; a resume reads it back
    (and writes a new one if the run started without wandb), so that wandb continues
    the run the resumed one logged to, as ``metrics.csv`` and TensorBoard do.

    Args:
        run_dir: the run's directory.
        resume: whether this start continues a checkpoint of the run.

    Examples:
        >>> import tempfile
        >>> run = Path(tempfile.mkdtemp())
        >>> first = wandb_run_id(run, resume=False)
        >>> wandb_run_id(run, resume=True) == first != wandb_run_id(run, resume=False)
        True
    """
    path = run_dir / WANDB_RUN_ID_FILE
    if resume and path.is_file():
        kept = path.read_text().strip()
        if kept:
            return kept
    run_id = secrets.token_hex(4)  # wandb's own ids: 8 lowercase letters and digits
    path.write_text(run_id + "\n")
    return run_id


def recorded_frames(path: Path) -> int | None:
    """The frame count of ``metrics.csv``'s last row; ``None`` if it holds no row.

    Examples:
        >>> import tempfile
        >>> run = Path(tempfile.mkdtemp())
        >>> recorded_frames(run / METRICS_FILE) is None
        True
        >>> _ = (run / METRICS_FILE).write_text("step,loss\\n1000.0,0.5\\n2000.0,0.4\\n")
        >>> recorded_frames(run / METRICS_FILE)
        2000
    """
    if not path.is_file():
        return None
    steps = [row["step"] for row in read_rows(path) if row.get("step")]
    return int(float(steps[-1])) if steps else None


def read_rows(path: Path) -> list[dict[str, str]]:
    """The rows of ``metrics.csv``, without a torn last line.

    A row is appended whole, ending with a newline: a last line without one was cut by a
    crash while it was written (its values may be cut too). It is dropped with a warning.

    Examples:
        >>> import tempfile
        >>> path = Path(tempfile.mkdtemp()) / METRICS_FILE
        >>> _ = path.write_text("step,loss\\n1000.0,0.5\\n2000.0,0.4")
        >>> read_rows(path)
        [{'step': '1000.0', 'loss': '0.5'}]
    """
    lines = path.read_text().splitlines(keepends=True)
    if lines and not lines[-1].endswith("\n"):
        log.warning(
            f"{path}: dropped its torn last line {lines.pop()!r} (a crash while writing it)"
        )
    return list(csv.DictReader(lines))


class CSVMetrics:
    """Append-only wide CSV; the header grows when a new metric first appears."""

    def __init__(self, path: Path, resume_step: int | None = None) -> None:
        self.path = path
        self.rows: list[dict[str, float]] = []
        if resume_step is not None and path.is_file():
            self.rows = [
                {k: float(v) for k, v in row.items() if v != ""}
                for row in read_rows(path)
                if float(row["step"]) <= resume_step
            ]
        self.columns: list[str] = ["step"]
        for row in self.rows:
            self.columns += [k for k in row if k not in self.columns]
        self._rewrite()

    def log(self, step: int, metrics: Mapping[str, float]) -> None:
        row = {"step": float(step), **{k: float(v) for k, v in metrics.items()}}
        self.rows.append(row)
        new = [k for k in row if k not in self.columns]
        if new:
            self.columns += new
            self._rewrite()
            return
        with self.path.open("a", newline="") as f:
            csv.DictWriter(f, self.columns).writerow(row)

    def _rewrite(self) -> None:
        tmp = self.path.with_suffix(".tmp")
        with tmp.open("w", newline="") as f:
            writer = csv.DictWriter(f, self.columns)
            writer.writeheader()
            writer.writerows(self.rows)
        os.replace(tmp, self.path)


class TensorBoardMetrics:
    """Scalars to ``<log_dir>/<run_name>/``, the event file opened at the first point.

    Args:
        log_dir: the run's ``tb`` directory.
        run_name: the TensorBoard run (one per run directory, kept across resumes).
        resume_step: when resuming, the checkpoint's frame count: points logged past it
            by the earlier process are hidden (``purge_step``), as the CSV drops them.
    """

    def __init__(self, log_dir: Path, run_name: str, resume_step: int | None = None) -> None:
        self.directory = log_dir / run_name
        self.purge_step = None if resume_step is None else resume_step + 1
        self.writer: Any = None

    def log_scalar(self, name: str, value: float, step: int) -> None:
        if self.writer is None:
            from torch.utils.tensorboard import SummaryWriter

            self.writer = SummaryWriter(str(self.directory), purge_step=self.purge_step)
        self.writer.add_scalar(name, value, global_step=step)

    def close(self) -> None:
        if self.writer is not None:
            self.writer.close()


class MetricLogger:
    """Fans scalar metrics out to the configured backends.

    Args:
        cfg: the logger config.
        run_dir: the run's output directory.
        run_name: a name for TensorBoard / wandb.
        config: the resolved run config, recorded by wandb.
        resume_step: when resuming, the checkpoint's frame count (wandb then continues
            the run directory's wandb run: :func:`wandb_run_id`).
    """

    def __init__(
        self,
        cfg: LoggerConfig,
        run_dir: Path,
        run_name: str,
        config: Mapping[str, Any] | None = None,
        resume_step: int | None = None,
    ) -> None:
        check_logger(cfg)
        run_dir.mkdir(parents=True, exist_ok=True)
        self.csv = CSVMetrics(run_dir / METRICS_FILE, resume_step)
        self.tensorboard: TensorBoardMetrics | None = None
        if "tensorboard" in cfg.backends:
            self.tensorboard = TensorBoardMetrics(run_dir / TENSORBOARD_DIR, run_name, resume_step)
        self.wandb: Any = None
        if "wandb" in cfg.backends:
            mode = wandb_mode(cfg.wandb_mode)
            if mode != "disabled":
                from torchrl.record.loggers import WandbLogger

                self.wandb = WandbLogger(
                    exp_name=run_name,
                    offline=mode == "offline",
                    save_dir=str(run_dir),
                    id=wandb_run_id(run_dir, resume=resume_step is not None),
                    project=cfg.wandb_project,
                    config=dict(config or {}),
                    resume="allow",  # a new id starts a run, a kept one continues it
                )

    def log(self, step: int, metrics: Mapping[str, float]) -> None:
        """Log finite and non-finite values alike (a NaN in the CSV is a finding, not noise)."""
        self.csv.log(step, metrics)
        for backend in (self.tensorboard, self.wandb):
            if backend is None:
                continue
            for name, value in metrics.items():
                if not math.isnan(value):
                    backend.log_scalar(name, value, step=step)

    def close(self) -> None:
        if self.tensorboard is not None:
            self.tensorboard.close()
        if self.wandb is not None:
            self.wandb.experiment.finish()


#: Events of a game shown in progress lines: totals per episode, not per team.
_PER_TEAM = re.compile(r"_\d+_per_episode$")


class ProgressLines:
    """A progress line every tenth (``parts``) of the budget, for logs without a bar.

    Each line: frames trained of the budget, speeds since the previous line (frames per
    second of the whole loop, and of collection alone: ``env_steps_per_s``), the latest
    logged mean return of each group and the game's events per episode, elapsed time
    and an estimate of the time left.

    Args:
        budget: ``algo.max_steps``.
        frames: frames already trained (a resume starts from the checkpoint's).
        parts: lines per budget.

    Examples:
        >>> lines = ProgressLines(budget=1000, frames=0)
        >>> line = lines.update(100, collect_seconds=0.5, metrics={"racket/cumulative_reward": 0.1})
        >>> line.split(" | ")[0], line.split(" | ")[2]
        ('frames 100/1,000 (10%)', 'racket reward +0.100')
        >>> lines.update(150, collect_seconds=0.5, metrics={}) is None
        True
    """

    def __init__(self, budget: int, frames: int, parts: int = 10) -> None:
        self.budget = budget
        self.period = max(1, budget // parts)
        self.start = time.perf_counter()
        self.start_frames = frames
        self.frames = frames
        self.mark = (self.start, frames, 0.0)  # time, frames, collection seconds at the last line
        self.collect_seconds = 0.0

    def update(
        self, frames: int, collect_seconds: float, metrics: Mapping[str, float]
    ) -> str | None:
        """Account one update; the line to write if it crossed a tenth of the budget."""
        previous, self.frames = self.frames, frames
        self.collect_seconds += collect_seconds
        if previous // self.period == frames // self.period and frames < self.budget:
            return None
        now = time.perf_counter()
        since, since_frames, since_collect = self.mark
        self.mark = (now, frames, self.collect_seconds)
        new_frames = frames - since_frames
        speed = new_frames / max(now - since, 1e-9)
        env_speed = new_frames / max(self.collect_seconds - since_collect, 1e-9)
        overall = (frames - self.start_frames) / max(now - self.start, 1e-9)
        left = max(self.budget - frames, 0) / max(overall, 1e-9)
        parts = [
            f"frames {frames:,}/{self.budget:,} ({100 * frames / self.budget:.0f}%)",
            f"{speed:,.0f} frames/s (env {env_speed:,.0f} steps/s)",
        ]
        for name, value in metrics.items():
            if name.endswith("/cumulative_reward"):
                parts.append(f"{name.split('/')[0]} reward {value:+.3f}")
        for name, value in metrics.items():
            # The headline events only: per-team counts and how points ended (tennis'
            # ended_<how>) stay in metrics.csv.
            if name.startswith("events/") and not _PER_TEAM.search(name) and "/ended_" not in name:
                event = name.removeprefix("events/").removesuffix("_per_episode")
                parts.append(f"{event} {value:.2f}/episode")
        parts.append(f"elapsed {_duration(now - self.start)}, left ~{_duration(left)}")
        return " | ".join(parts)


def _duration(seconds: float) -> str:
    """``3725.2 -> '1:02:05'``."""
    return str(datetime.timedelta(seconds=round(seconds)))
