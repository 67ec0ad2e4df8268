"""Checkpoints: everything needed to continue a run exactly where it was saved.

A run directory holds ``checkpoints/step_<frames>.pt`` files and a ``latest.pt``
symlink to the newest. Both survive a kill at any instant:

- every file is written to a hidden temporary file in the same directory, flushed to
  disk (``fsync``) and renamed over its final name (``os.replace``, atomic on POSIX),
  so a ``step_*.pt`` file is either absent or complete, and ``latest.pt`` always names
  a file that was complete when it was linked;
- a run directory is not resolved through ``latest.pt`` alone: a kill between writing
  ``step_N.pt`` and relinking ``latest.pt`` leaves the link stale (or missing, after
  the first save), and a crash of the machine can still truncate a file.
  :func:`checkpoint_candidates` orders a run's files newest first and
  :func:`load_checkpoint` takes the first one that loads, warning about those skipped.

Temporary files left behind by a kill (``.step_<frames>.pt.<pid>.<hex>.tmp``) are never
read.
"""

from __future__ import annotations

import os
import random
import re
import secrets
import warnings
from pathlib import Path
from typing import Any

import numpy as np
import torch

CHECKPOINT_DIR = "checkpoints"
LATEST = "latest.pt"
STEP_GLOB = "step_*.pt"
FORMAT_VERSION = 1
_STEP_NAME = re.compile(r"step_(\d+)\.pt")


def save_checkpoint(path: Path, state: dict[str, Any]) -> None:
    """Write ``state`` to ``path`` atomically and point ``latest.pt`` at it.

    Args:
        path: the checkpoint file, by convention ``<run>/checkpoints/step_<frames>.pt``;
            ``latest.pt`` is linked next to it.
        state: what to store (``format_version`` is added).

    Raises:
        ValueError: ``path`` is named ``latest.pt`` (the link, not a checkpoint).
    """
    if path.name == LATEST:
        raise ValueError(f"checkpoint path {str(path)!r}: {LATEST} is the link, name the file")
    directory = path.parent
    directory.mkdir(parents=True, exist_ok=True)
    tmp = _temporary(path)
    try:
        with tmp.open("xb") as f:
            torch.save({"format_version": FORMAT_VERSION, **state}, f)
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
    finally:
        tmp.unlink(missing_ok=True)
    # Persist the new name before the link can point at it.
    _fsync_directory(directory)
    link = _temporary(directory / LATEST)
    try:
        link.symlink_to(path.name)
        os.replace(link, directory / LATEST)
    finally:
        link.unlink(missing_ok=True)
    _fsync_directory(directory)


def step_of(path: Path) -> int | None:
    """The frame count in a ``step_<frames>.pt`` name, ``None`` for any other name.

    Examples:
        >>> step_of(Path("checkpoints/step_000000512.pt"))
        512
        >>> step_of(Path("checkpoints/latest.pt")) is None
        True
    """
    match = _STEP_NAME.fullmatch(path.name)
    return int(match.group(1)) if match else None


def checkpoint_candidates(run_dir: str | os.PathLike[str]) -> list[Path]:
    """A run directory's checkpoint files, the one to resume from first.

    Files are looked for in ``<run_dir>/checkpoints/`` and then in ``run_dir`` itself
    (for a ``checkpoints`` directory given directly). Within a directory the order is

    1. ``step_*.pt`` files with more frames than ``latest.pt``'s target and written no
       earlier than it (saved, then killed before ``latest.pt`` was relinked), most
       frames first;
    2. ``latest.pt``'s target (skipped if the link dangles);
    3. the other ``step_*.pt`` files, most frames first.

    Trusting the link over frame counts keeps a run resumed from an earlier checkpoint
    into its own directory on its new branch; the modification times keep a copied
    run directory (fresh times in any order) on its newest file.

    Args:
        run_dir: a run directory (or its ``checkpoints`` directory).

    Returns:
        Resolved paths, without duplicates; empty if there are none. Nothing is loaded.
    """
    root = Path(run_dir).expanduser()
    ordered: list[Path] = []
    for folder in (root / CHECKPOINT_DIR, root):
        if folder.is_dir():
            ordered += _ordered_in(folder.resolve())
    return list(dict.fromkeys(ordered))


def _ordered_in(folder: Path) -> list[Path]:
    """:func:`checkpoint_candidates` of one directory (already resolved)."""
    steps = sorted(
        (p for p in folder.glob(STEP_GLOB) if step_of(p) is not None and p.is_file()),
        key=lambda p: step_of(p) or 0,
        reverse=True,
    )
    latest = folder / LATEST
    if not latest.is_file():  # absent, or a dangling link
        return steps
    target = latest.resolve()
    target_step = step_of(target)
    if target_step is None:  # a plain latest.pt (e.g. copied with cp -L): newest known
        return [target, *(p for p in steps if p != target)]
    linked_at = target.stat().st_mtime_ns
    newer = [
        p for p in steps if (step_of(p) or 0) > target_step and p.stat().st_mtime_ns >= linked_at
    ]
    rest = [p for p in steps if p != target and p not in newer]
    return [*newer, target, *rest]


def load_checkpoint(path: str | os.PathLike[str]) -> dict[str, Any]:
    """Load a checkpoint written by :func:`save_checkpoint`.

    Args:
        path: a checkpoint file, or a run directory: its newest checkpoint that loads
            (order of :func:`checkpoint_candidates`). Files skipped on the way (e.g.
            truncated) are named in one warning.

    Returns:
        The stored state, plus ``"path"``: the file that was loaded.

    Raises:
        FileNotFoundError: ``path`` does not exist, or is a directory holding no
            checkpoint that loads; the message names the directory, what was looked
            for and why each file found was rejected.
        ValueError: ``path`` is a file that is not a loadable rlhc checkpoint (named,
            with the reason).

    Examples:
        >>> state = load_checkpoint("outputs/soccer/hierarchical/<time>")  # doctest: +SKIP
        >>> state["frames"], state["path"]  # doctest: +SKIP
        (500000, '.../checkpoints/step_000500000.pt')
    """
    candidate = Path(path).expanduser()
    if candidate.is_dir():
        return _load_newest(candidate)
    if not candidate.is_file():
        raise FileNotFoundError(
            f"checkpoint {str(candidate)!r} does not exist (give a .pt file or a run directory)"
        )
    file = candidate.resolve()
    try:
        return _read(file)
    except ValueError as error:
        raise ValueError(f"{str(file)!r} is not a loadable rlhc checkpoint: {error}") from error


def resolve_checkpoint(path: str | os.PathLike[str]) -> Path:
    """The file :func:`load_checkpoint` loads for ``path`` (it is loaded to check).

    Raises:
        FileNotFoundError: as :func:`load_checkpoint`.
        ValueError: as :func:`load_checkpoint`.
    """
    return Path(load_checkpoint(path)["path"])


def _load_newest(run_dir: Path) -> dict[str, Any]:
    """The first loadable file of :func:`checkpoint_candidates`, warning about skipped ones."""
    skipped: list[str] = []
    for file in checkpoint_candidates(run_dir):
        try:
            state = _read(file)
        except ValueError as error:
            skipped.append(f"{file.name} ({error})")
            continue
        if skipped:
            warnings.warn(
                f"run directory {str(run_dir)!r}: skipped unloadable checkpoint(s) "
                f"{'; '.join(skipped)}; loaded {file.name}",
                RuntimeWarning,
                stacklevel=3,
            )
        return state
    looked_for = (
        f"looked for {CHECKPOINT_DIR}/{LATEST} and {CHECKPOINT_DIR}/{STEP_GLOB} "
        f"(or {LATEST} and {STEP_GLOB} directly inside it)"
    )
    if skipped:
        raise FileNotFoundError(
            f"no loadable checkpoint in run directory {str(run_dir)!r}: {looked_for}; "
            f"every file found failed to load: {'; '.join(skipped)}"
        )
    raise FileNotFoundError(f"no checkpoint in run directory {str(run_dir)!r}: {looked_for}")


def _read(file: Path) -> dict[str, Any]:
    """Load ``file``; a ``ValueError`` whose message is the reason if it is no checkpoint."""
    try:
        state = torch.load(file, map_location="cpu", weights_only=False)
    except Exception as error:  # truncated or foreign files fail in many ways (zip, pickle, EOF)
        first_line = (str(error).splitlines() or [""])[0]
        raise ValueError(f"{type(error).__name__}: {first_line}") from error
    if not isinstance(state, dict) or state.get("format_version") != FORMAT_VERSION:
        raise ValueError(f"not an rlhc checkpoint of format {FORMAT_VERSION}")
    state["path"] = str(file)
    return state


def _temporary(path: Path) -> Path:
    """A fresh hidden name next to ``path``; never matches ``step_*.pt`` or ``latest.pt``."""
    return path.with_name(f".{path.name}.{os.getpid()}.{secrets.token_hex(4)}.tmp")


def _fsync_directory(directory: Path) -> None:
    """Flush a directory's entries (renames) to disk; a no-op where directories cannot be opened."""
    try:
        fd = os.open(directory, os.O_RDONLY)
    except OSError:  # e.g. Windows
        return
    try:
        os.fsync(fd)
    except OSError:  # some filesystems refuse fsync on directories
        pass
    finally:
        os.close(fd)


def rng_states() -> dict[str, Any]:
    """The global random states of python, numpy and torch."""
    return {
        "python": random.getstate(),
        "numpy": np.random.get_state(),
        "torch": torch.get_rng_state(),
    }


def set_rng_states(states: dict[str, Any]) -> None:
    """Restore what :func:`rng_states` returned."""
    random.setstate(states["python"])
    np.random.set_state(states["numpy"])
    torch.set_rng_state(states["torch"])
