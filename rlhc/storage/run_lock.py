"""One training process per run directory: ``<run dir>/run.lock``.

Two processes training into one directory would interleave its ``metrics.csv`` and
checkpoints. The trainer holds an exclusive ``fcntl.flock`` on ``run.lock`` (naming its
pid): unlike a pid file, the kernel drops it however its process ends, so a file left by
a crash is taken over, and a reused pid cannot fool it. POSIX only.
"""

from __future__ import annotations

import fcntl
import logging
import os
from pathlib import Path

#: The lock file, directly in the run directory.
LOCK_FILE = "run.lock"

log = logging.getLogger(__name__)

#: The run directories this process holds (absolute path -> the lock file's descriptor).
_held: dict[str, int] = {}


class RunDirInUse(RuntimeError):
    """Another live process holds the run directory's lock (names it and what to do)."""


def lock_run_dir(run_dir: Path) -> None:
    """Hold ``run_dir``'s lock (creating it) until :func:`unlock_run_dirs` or the process ends.

    Raises:
        RunDirInUse: another process holds it.

    Examples:
        >>> import tempfile
        >>> run = Path(tempfile.mkdtemp())
        >>> lock_run_dir(run)
        >>> (run / LOCK_FILE).read_text() == f"{os.getpid()}\\n"
        True
        >>> unlock_run_dirs()
        >>> (run / LOCK_FILE).exists()
        False
    """
    key = os.path.abspath(run_dir)
    if key in _held:
        return
    os.makedirs(key, exist_ok=True)
    path = os.path.join(key, LOCK_FILE)
    while True:
        fd = os.open(path, os.O_RDWR | os.O_CREAT, 0o644)
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            holder = os.pread(fd, 32, 0).decode(errors="replace").strip() or "?"
            os.close(fd)
            raise RunDirInUse(
                f"{run_dir} is in use by process {holder} (it holds {LOCK_FILE}: one process "
                f"trains a run directory at a time; wait for it to end or stop it with kill "
                f"{holder}, or train elsewhere with hydra.run.dir=<new dir>)"
            ) from None
        try:  # the holder may have released (removed) the file between open and lock
            if os.path.samestat(os.stat(path), os.fstat(fd)):
                break
        except FileNotFoundError:
            pass
        os.close(fd)
    previous = os.pread(fd, 32, 0).decode(errors="replace").strip()
    if previous:
        log.warning(
            f"{run_dir}: took over {LOCK_FILE} from process {previous}, which ended without "
            "releasing it"
        )
    os.ftruncate(fd, 0)
    os.pwrite(fd, f"{os.getpid()}\n".encode(), 0)
    _held[key] = fd


def unlock_run_dirs() -> None:
    """Release every run directory this process holds, removing their lock files."""
    while _held:
        key, fd = _held.popitem()
        Path(key, LOCK_FILE).unlink(missing_ok=True)
        os.close(fd)
