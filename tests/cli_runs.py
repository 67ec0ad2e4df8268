"""Running ``python -m rlhc.run`` from tests: in this process (fast) or as a subprocess.

In-process runs call :func:`rlhc.run.cli` (or another entry point's ``cli``) with a
patched ``sys.argv`` and working directory, then undo what Hydra leaves behind (its
global instance, the root logger's handlers and level, ``HYDRA_FULL_ERROR``), so tests
stay independent. A subprocess is
needed where the process itself is the subject (signals, exit codes as a shell sees
them, shell globs).
"""

from __future__ import annotations

import contextlib
import csv
import logging
import os
import subprocess
import sys
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path

import pytest
from hydra.core.global_hydra import GlobalHydra

from rlhc import run

ROOT = Path(__file__).resolve().parents[1]


@dataclass
class Outcome:
    """How a command ended: exit code and what it wrote."""

    code: int
    stdout: str
    stderr: str


@contextlib.contextmanager
def hydra_cleanup() -> Iterator[None]:
    """Restore what a Hydra application changes in its process."""
    root = logging.getLogger()
    handlers, level = root.handlers[:], root.level
    full_error = os.environ.get("HYDRA_FULL_ERROR")
    try:
        yield
    finally:
        for handler in root.handlers:
            if handler not in handlers:
                handler.close()
        root.handlers[:] = handlers
        root.setLevel(level)
        GlobalHydra.instance().clear()
        if full_error is None:
            os.environ.pop("HYDRA_FULL_ERROR", None)
        else:
            os.environ["HYDRA_FULL_ERROR"] = full_error


def run_in_process(
    args: list[str],
    cwd: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
    entry: Callable[[], None] = run.cli,
) -> Outcome:
    """``python -m rlhc.run <args>`` (or another Hydra ``entry``) in this process, from ``cwd``."""
    monkeypatch.chdir(cwd)
    monkeypatch.setattr(sys, "argv", [f"{entry.__module__.replace('.', '/')}.py", *args])
    capsys.readouterr()
    code = 0
    with hydra_cleanup():
        try:
            entry()
        except SystemExit as stop:
            code = stop.code if isinstance(stop.code, int) else 1
    captured = capsys.readouterr()
    return Outcome(code, captured.out, captured.err)


def subprocess_env() -> dict[str, str]:
    """The environment of a child run: offline, no terminal tricks, no inherited debug."""
    env = {**os.environ, "WANDB_MODE": "offline"}
    env.pop("HYDRA_FULL_ERROR", None)
    return env


def run_subprocess(
    args: list[str], cwd: Path, timeout: float = 300, module: str = "rlhc.run"
) -> Outcome:
    """``python -m rlhc.run <args>`` (or another ``module``) as a child process, from ``cwd``."""
    result = subprocess.run(
        [sys.executable, "-m", module, *args],
        cwd=cwd,
        env=subprocess_env(),
        capture_output=True,
        text=True,
        timeout=timeout,
    )
    return Outcome(result.returncode, result.stdout, result.stderr)


def read_metrics(run_dir: Path) -> list[dict[str, float]]:
    with (run_dir / "metrics.csv").open(newline="") as f:
        return [{k: float(v) for k, v in row.items() if v != ""} for row in csv.DictReader(f)]


def steps(run_dir: Path) -> list[int]:
    return [int(row["step"]) for row in read_metrics(run_dir)]


def tensorboard_steps(run_dir: Path, tag: str = "frames") -> list[int]:
    """The steps TensorBoard shows for ``tag`` (after purges) in the run's one TB run."""
    from tensorboard.backend.event_processing.event_accumulator import EventAccumulator

    (tb_run,) = (run_dir / "tb").iterdir()
    accumulator = EventAccumulator(str(tb_run))
    accumulator.Reload()
    return [event.step for event in accumulator.Scalars(tag)]


def only_child(directory: Path) -> Path:
    """The one entry of ``directory`` (a run directory Hydra named)."""
    (child,) = directory.iterdir()
    return child


def snapshot(directory: Path) -> dict[str, tuple[int, int]]:
    """Every file under ``directory`` with its size and modification time."""
    return {
        str(p.relative_to(directory)): (p.lstat().st_size, p.lstat().st_mtime_ns)
        for p in sorted(directory.rglob("*"))
    }
