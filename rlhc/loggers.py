"""Metric logging: a tidy ``metrics.csv`` plus TorchRL's TensorBoard and wandb loggers.

``metrics.csv`` has one row per summary and one column per metric (plus ``step``, the
frame count). It is what ``rlhc.plot`` reads and what survives a resume: on resume,
rows past the checkpoint's step are dropped, so the curve continues without a gap or
a duplicate.
"""

from __future__ import annotations

import csv
import math
import os
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from rlhc.config import LoggerConfig

METRICS_FILE = "metrics.csv"
BACKENDS = ("csv", "tensorboard", "wandb")
WANDB_MODES = ("auto", "online", "offline", "disabled")


def wandb_mode(requested: str) -> str:
    """Resolve ``auto``: online only when an API key is configured (env var or netrc)."""
    if requested not in WANDB_MODES:
        raise ValueError(f"logger.wandb_mode={requested!r}; allowed: {', '.join(WANDB_MODES)}")
    if requested != "auto":
        return requested
    if os.environ.get("WANDB_MODE"):
        return os.environ["WANDB_MODE"]
    netrc = Path.home() / ".netrc"
    has_key = bool(os.environ.get("WANDB_API_KEY")) or (
        netrc.is_file() and "api.wandb.ai" in netrc.read_text(errors="ignore")
    )
    return "online" if has_key else "offline"


class CSVMetrics:
    """Append-only wide CSV; the header grows when a new metric first appears."""

    def __init__(self, path: Path, resume_step: int | None = None) -> None:
        self.path = path
        self.rows: list[dict[str, float]] = []
        if resume_step is not None and path.is_file():
            with path.open(newline="") as f:
                self.rows = [
                    {k: float(v) for k, v in row.items() if v != ""}
                    for row in csv.DictReader(f)
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


class MetricLogger:
    """Fans scalar metrics out to the configured backends.

    Args:
        cfg: the logger config.
        run_dir: the run's output directory.
        run_name: a name for TensorBoard / wandb.
        config: the resolved run config, recorded by wandb.
        resume_step: when resuming, the checkpoint's frame count.
    """

    def __init__(
        self,
        cfg: LoggerConfig,
        run_dir: Path,
        run_name: str,
        config: Mapping[str, Any] | None = None,
        resume_step: int | None = None,
    ) -> None:
        unknown = [b for b in cfg.backends if b not in BACKENDS]
        if unknown:
            raise ValueError(f"logger.backends has {unknown}; allowed: {', '.join(BACKENDS)}")
        run_dir.mkdir(parents=True, exist_ok=True)
        self.csv = CSVMetrics(run_dir / METRICS_FILE, resume_step)
        self.backends: list[Any] = []
        if "tensorboard" in cfg.backends:
            from torchrl.record.loggers import TensorboardLogger

            self.backends.append(TensorboardLogger(exp_name=run_name, log_dir=str(run_dir / "tb")))
        if "wandb" in cfg.backends:
            mode = wandb_mode(cfg.wandb_mode)
            if mode != "disabled":
                from torchrl.record.loggers import WandbLogger

                wandb_logger = WandbLogger(
                    exp_name=run_name,
                    offline=mode == "offline",
                    save_dir=str(run_dir),
                    project=cfg.wandb_project,
                    config=dict(config or {}),
                )
                self.backends.append(wandb_logger)

    def log(self, step: int, metrics: Mapping[str, float]) -> None:
        """Log finite and non-finite values alike (a NaN in the CSV is a finding, not noise)."""
        self.csv.log(step, metrics)
        for backend in self.backends:
            for name, value in metrics.items():
                if not math.isnan(value):
                    backend.log_scalar(name, value, step=step)

    def close(self) -> None:
        for backend in self.backends:
            experiment = getattr(backend, "experiment", None)
            for method in ("flush", "close", "finish"):
                if hasattr(experiment, method):
                    getattr(experiment, method)()
                    break
