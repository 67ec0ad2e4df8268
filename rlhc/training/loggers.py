"""Metric logging: ``metrics.csv`` (a row per summary, a column per metric, ``step`` the
frames), TensorBoard and wandb. A resume continues each without a gap or a duplicate: the
CSV drops its rows past the checkpoint's step, TensorBoard hides its points past it
(``purge_step``, which TorchRL's ``TensorboardLogger`` does not pass on), wandb continues
the run whose id the run directory keeps.
"""

from __future__ import annotations

import csv
import logging
import math
import os
import secrets
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from rlhc.config.train_schema import LoggerConfig
from rlhc.config.validation import check_logger

METRICS_FILE = "metrics.csv"
TENSORBOARD_DIR = "tb"
#: The run directory's wandb run id (written at the first start, read on a resume).
WANDB_RUN_ID_FILE = "wandb_run_id"

log = logging.getLogger(__name__)


def wandb_mode(requested: str) -> str:
    """Resolve ``auto``: online only when an API key is configured (env var or netrc)."""
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
    """The id of the run directory's wandb run: on a ``resume`` the one kept in
    ``<run_dir>/wandb_run_id``, else (or if none is kept) a new one, written there.

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
    """The rows of ``metrics.csv``, but a last line without its newline (cut by a crash
    while it was written, its values maybe too), dropped with a warning.

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
    """Scalars to ``directory``, opened at the first point; on a resume from ``resume_step``
    frames, the later points are hidden."""

    def __init__(self, directory: Path, resume_step: int | None = None) -> None:
        self.directory = directory
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
        run_dir: the run's output directory; its name names the TensorBoard and wandb run.
        config: the resolved run config, recorded by wandb.
        resume_step: when resuming, the checkpoint's frame count.
    """

    def __init__(
        self,
        cfg: LoggerConfig,
        run_dir: Path,
        config: Mapping[str, Any] | None = None,
        resume_step: int | None = None,
    ) -> None:
        check_logger(cfg)
        run_dir.mkdir(parents=True, exist_ok=True)
        self.csv = CSVMetrics(run_dir / METRICS_FILE, resume_step)
        self.tensorboard: TensorBoardMetrics | None = None
        if "tensorboard" in cfg.backends:
            self.tensorboard = TensorBoardMetrics(
                run_dir / TENSORBOARD_DIR / run_dir.name, resume_step
            )
        self.wandb: Any = None
        if "wandb" in cfg.backends:
            mode = wandb_mode(cfg.wandb_mode)
            if mode != "disabled":
                from torchrl.record.loggers import WandbLogger

                self.wandb = WandbLogger(
                    exp_name=run_dir.name,
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
