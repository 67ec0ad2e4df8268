"""After a start that failed on a user error: remove what it created, and nothing else.

A job directory empty but for an empty job log, the empty directories above it, a sweep
directory holding nothing but its ``multirun.yaml``; a file with content is never removed.
"""

from __future__ import annotations

import os
from pathlib import Path

#: What Hydra writes into a multirun's sweep directory before its jobs start.
MULTIRUN_FILE = "multirun.yaml"

#: Sweep directories of this process's multirun jobs that failed on a user error.
_failed_sweeps: set[Path] = set()


def remove_if_unused(run_dir: Path, job_log: str) -> None:
    """Remove ``run_dir`` if it holds nothing, or nothing but an empty ``job_log``.

    Hydra creates a job's directory, and may open its log (``<job name>.log``), before
    the job starts: a job that fails before logging a line leaves just that.

    Examples:
        >>> import tempfile
        >>> run = Path(tempfile.mkdtemp())
        >>> (run / "metrics.csv").touch()
        >>> remove_if_unused(run, "run.log")
        >>> sorted(p.name for p in run.iterdir())
        ['metrics.csv']
        >>> (run / "metrics.csv").unlink()
        >>> remove_if_unused(run, "run.log")
        >>> run.exists()
        False
    """
    if not run_dir.is_dir():
        return
    log_file = run_dir / job_log
    if os.listdir(run_dir) == [job_log] and log_file.is_file() and log_file.stat().st_size == 0:
        log_file.unlink()
    try:
        run_dir.rmdir()
    except OSError:  # not empty: what it holds stays
        return


def remove_unused_sweep(sweep_dir: Path) -> None:
    """Remove a sweep directory that holds only the ``multirun.yaml`` its sweep wrote."""
    if not sweep_dir.is_dir() or set(os.listdir(sweep_dir)) - {MULTIRUN_FILE}:
        return
    (sweep_dir / MULTIRUN_FILE).unlink(missing_ok=True)
    sweep_dir.rmdir()
    remove_empty_parents(sweep_dir)


def remove_empty_parents(path: Path, top: Path | None = None) -> None:
    """Remove the now empty directories above ``path``, up to the working directory or
    ``top`` (neither ``path`` nor ``top`` is removed)."""
    cwd = Path.cwd()
    stop = Path(os.path.abspath(top)) if top is not None else cwd
    for parent in Path(os.path.abspath(path)).parents:
        if parent in (cwd, stop) or not parent.is_relative_to(cwd):
            return
        try:
            parent.rmdir()
        except OSError:  # not empty
            return


def remove_failed_job(run_dir: Path, job_log: str, sweep_dir: Path | None) -> None:
    """After a job's user error: remove its directory if unused, and the empty ones up to
    a multirun's ``sweep_dir``, which :func:`remove_failed_sweeps` removes if no job used it."""
    remove_if_unused(run_dir, job_log)
    if sweep_dir is not None:
        remove_empty_parents(run_dir, top=sweep_dir)
        _failed_sweeps.add(sweep_dir)


def remove_failed_sweeps() -> None:
    """Remove the sweep directories of failed jobs that hold only ``multirun.yaml``."""
    while _failed_sweeps:
        remove_unused_sweep(_failed_sweeps.pop())
