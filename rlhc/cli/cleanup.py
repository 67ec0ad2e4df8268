"""After a start that failed on a user error: remove what it created, and nothing else.

Only what the failed start created is removed: a job directory empty but for an empty
job log, the empty directories above it, and a sweep directory holding nothing but the
``multirun.yaml`` its sweep wrote. A file with content is never removed, so a directory
that held anything before (a trained run's ``checkpoints/``, ``metrics.csv``, logs,
``.hydra/``) stays exactly as it was.
"""

from __future__ import annotations

import os
from pathlib import Path

#: What Hydra writes into a multirun's sweep directory before its jobs start.
MULTIRUN_FILE = "multirun.yaml"

#: Sweep directories of multirun jobs that failed on a user error (jobs run in this
#: process only): :func:`remove_failed_sweeps` removes those left holding only
#: Hydra's ``multirun.yaml``.
_failed_sweeps: set[Path] = set()


def remove_if_unused(run_dir: Path, job_log: str) -> None:
    """Remove ``run_dir`` if it holds nothing, or nothing but an empty ``job_log``.

    Hydra creates a job's directory before the job starts; its log opens at the first
    record (``delay: true``: ``conf/hydra/job_logging/rlhc.yaml``), or before the job
    under a logging config without it: a job that fails before logging a line leaves
    just that. (It writes no ``.hydra/`` for such a job: the ``rlhc.output_subdir``
    resolver; a single run fails before Hydra creates anything: the ``Preflight``
    callback, both in :mod:`rlhc.cli.hydra_hooks`.)

    Args:
        run_dir: the job's directory.
        job_log: the name of the log Hydra opened in it (``<job name>.log``).

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
    """Remove the now empty directories above ``path``, up to the working directory.

    Args:
        path: where to start (``path`` itself is not removed).
        top: a directory to stop at (not removed) before the working directory.
    """
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
    """After a job's user error: remove its directory if unused, and note its sweep.

    Args:
        run_dir: the job's directory.
        job_log: the name of the log Hydra opened in it.
        sweep_dir: a multirun job's sweep directory (``None``: a single run). Empty
            directories between the two are removed; the sweep directory itself is
            removed later, by :func:`remove_failed_sweeps`, if no job used it.
    """
    remove_if_unused(run_dir, job_log)
    if sweep_dir is not None:
        remove_empty_parents(run_dir, top=sweep_dir)
        _failed_sweeps.add(sweep_dir)


def remove_failed_sweeps() -> None:
    """Remove the sweep directories of failed jobs that hold only ``multirun.yaml``."""
    while _failed_sweeps:
        remove_unused_sweep(_failed_sweeps.pop())
