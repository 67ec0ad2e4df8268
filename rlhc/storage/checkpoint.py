"""Checkpoints: everything needed to continue a run where it was saved.

A run directory holds ``checkpoints/step_<frames>.pt`` files and a ``latest.pt`` symlink
to the newest, each written atomically (a temporary file, ``fsync``, a rename), so a
kill at any instant leaves complete files. A kill between a save and the relink leaves
the link stale, so :func:`load_checkpoint` takes the first file of
:func:`checkpoint_candidates` that loads.

**Loading never runs code.** Checkpoints and final teams are shared, and unpickling can
run anything, so every file is read with torch's weights-only loader (tensors, numbers,
strings, containers and :data:`NUMPY_ARRAYS`); a file needing more is refused unread.

What a resume restores: [Training and resuming](../guide/training.md#stopping-and-resuming).
"""

from __future__ import annotations

import contextlib
import os
import random
import re
import secrets
import warnings
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
import torch

CHECKPOINT_DIR = "checkpoints"
LATEST = "latest.pt"
STEP_GLOB = "step_*.pt"
FORMAT_VERSION = 1
_STEP_NAME = re.compile(r"step_(\d+)\.pt")
#: The numpy arrays a checkpoint holds (numpy's random state, the league's opponents).
#: An array pickles as a call of ``_reconstruct``, whose module moved in numpy 2:
#: ``__reduce__`` names this numpy's.
NUMPY_ARRAYS: list[Any] = [
    np.ndarray,
    np.dtype,
    np.dtypes.UInt32DType,
    np.dtypes.Int64DType,
    np.zeros(0).__reduce__()[0],
]
#: The type or function a refused file needs, in torch's weights-only error message.
_REFUSED = re.compile(r"GLOBAL (\S+)|got <class '([^']+)'>")

#: Config sections a resume may not change: what the saved weights belong to.
FIXED_SECTIONS = ("env", "critic", "model")
#: Nor these keys: the normaliser's statistics are part of the policy's input.
FIXED_KEYS = ("algo.normalize_observations",)
#: Keys in those sections that may change: the worlds stepped at once change no update.
FREE_KEYS = ("env.num_envs",)


class ResumeError(ValueError):
    """A run cannot continue from a checkpoint (names the checkpoint and the reason)."""


def save_checkpoint(path: Path, state: dict[str, Any]) -> None:
    """Write ``state`` to ``path`` (``<run>/checkpoints/step_<frames>.pt``) atomically, then
    link the ``latest.pt`` beside it to it.

    Raises:
        ValueError: ``path`` is named ``latest.pt`` (the link, not a checkpoint).
    """
    if path.name == LATEST:
        raise ValueError(f"checkpoint path {str(path)!r}: {LATEST} is the link, name the file")
    directory = path.parent
    # write_atomically persists the new name before the link can point at it.
    write_atomically(path, state)
    link = _temporary(directory / LATEST)
    try:
        link.symlink_to(path.name)
        os.replace(link, directory / LATEST)
    finally:
        link.unlink(missing_ok=True)
    _fsync_directory(directory)


def write_atomically(path: Path, state: Mapping[str, Any]) -> None:
    """Write ``state`` (plus ``format_version``) to ``path``: complete, or not at all."""
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
    """A run directory's checkpoint files (resolved, nothing loaded), the one to resume first.

    Looked for in ``<run_dir>/checkpoints/``, then in ``run_dir`` itself. Within a
    directory: first ``step_*.pt`` files with more frames than ``latest.pt``'s target and
    written no earlier (killed before the relink), then that target, then the other
    ``step_*.pt`` files, most frames first. Trusting the link over frame counts keeps a run
    resumed from an earlier checkpoint on its new branch; the modification times keep a
    copied run directory on its newest file.
    """
    root = Path(run_dir).expanduser()
    ordered: list[Path] = []
    for folder in (root / CHECKPOINT_DIR, root):
        if folder.is_dir():
            ordered += _ordered_in(folder.resolve())
    return list(dict.fromkeys(ordered))


def _ordered_in(folder: Path) -> list[Path]:
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
    """Load a checkpoint written by :func:`save_checkpoint` (weights only).

    Args:
        path: a checkpoint file, or a run directory: its first checkpoint that loads, in
            the order of :func:`checkpoint_candidates` (those skipped named in a warning).

    Returns:
        The stored state, plus ``"path"``: the file that was loaded.

    Raises:
        FileNotFoundError: ``path`` does not exist, or is a directory holding no
            checkpoint that loads (why each file was rejected is named).
        ValueError: ``path`` is a file that is not a loadable rlhc checkpoint.

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


def _load_newest(run_dir: Path) -> dict[str, Any]:
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
    failed = f"; every file found failed to load: {'; '.join(skipped)}" if skipped else ""
    raise FileNotFoundError(
        f"no {'loadable ' if skipped else ''}checkpoint in run directory {str(run_dir)!r}: "
        f"looked for {CHECKPOINT_DIR}/{LATEST} and {CHECKPOINT_DIR}/{STEP_GLOB} "
        f"(or {LATEST} and {STEP_GLOB} directly inside it){failed}"
    )


def _read(file: Path) -> dict[str, Any]:
    """Load ``file`` weights only; a ``ValueError`` saying why if it is no checkpoint."""
    try:
        with torch.serialization.safe_globals(NUMPY_ARRAYS), warnings.catch_warnings():
            # A plain pickle's protocol draws a warning from torch before it is refused.
            warnings.filterwarnings("ignore", "Detected pickle protocol")
            state = torch.load(file, map_location="cpu", weights_only=True)
    except Exception as error:  # truncated or foreign files fail in many ways (zip, pickle, EOF)
        message = str(error)
        refused = _REFUSED.search(message)
        if refused:
            reason = (
                f"it carries {refused.group(1) or refused.group(2)}, which a checkpoint may "
                "not hold (only tensors, numbers, strings and containers are loaded, so that "
                "loading a file never runs code)"
            )
        else:  # the reason follows torch's preamble, if it wrote one
            found = message.split("WeightsUnpickler error:")[-1].strip().splitlines()
            reason = f"{type(error).__name__}: {(found or [''])[0]}"
        raise ValueError(reason) from error
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
        with contextlib.suppress(OSError):  # some filesystems refuse fsync on directories
            os.fsync(fd)
    finally:
        os.close(fd)


def run_dir_of(resume: str | os.PathLike[str]) -> Path | None:
    """The run directory of ``resume`` (a run directory, its ``checkpoints`` directory or a
    file in it), as given; ``None`` for a path that does not exist or is in no run.

    A resumed run writes into the run it continues: ``rlhc.run`` sets ``hydra.run.dir``
    from this unless given explicitly.

    Examples:
        >>> run_dir_of("outputs/tennis/hierarchical/2025-01-01_00-00-00/checkpoints/latest.pt")  # doctest: +SKIP
        PosixPath('outputs/tennis/hierarchical/2025-01-01_00-00-00')
    """
    path = Path(resume).expanduser()
    if path.is_dir():
        if (path / CHECKPOINT_DIR).is_dir():
            return path
        return path.parent if path.name == CHECKPOINT_DIR else None
    if path.is_file() and path.parent.name == CHECKPOINT_DIR:
        return path.parent.parent
    return None


def config_differences(stored: Mapping[str, Any], current: Mapping[str, Any]) -> list[str]:
    """The settings a resume may not change that differ, as ``key: stored -> current``.

    Compares :data:`FIXED_SECTIONS` (but :data:`FREE_KEYS`) and :data:`FIXED_KEYS` of two
    plain nested configs. A key only one side has (added or removed by a code change) is
    not compared: the weights' shapes are checked when they are loaded.

    Examples:
        >>> config_differences({"model": {"hidden_size": 32}, "env": {"num_envs": 4}},
        ...                    {"model": {"hidden_size": 64}, "env": {"num_envs": 8}})
        ['model.hidden_size: 32 -> 64']
    """
    old, new = flatten(stored), flatten(current)
    differing = []
    for key in sorted(old.keys() & new.keys()):
        fixed = key.split(".", 1)[0] in FIXED_SECTIONS or key in FIXED_KEYS
        if fixed and key not in FREE_KEYS and old[key] != new[key]:
            differing.append(f"{key}: {old[key]!r} -> {new[key]!r}")
    return differing


def flatten(config: Mapping[str, Any], prefix: str = "", sep: str = ".") -> dict[str, Any]:
    """``{"a": {"b": 1}} -> {"a.b": 1}``, keys joined by ``sep`` (lists are kept as values)."""
    flat: dict[str, Any] = {}
    for key, value in config.items():
        name = f"{prefix}{key}"
        if isinstance(value, Mapping):
            flat.update(flatten(value, f"{name}{sep}", sep))
        else:
            flat[name] = value
    return flat


def seed_everything(seed: int) -> None:
    """Seed python, numpy and torch (the game has its own generator, seeded by the env)."""
    random.seed(seed)
    np.random.seed(seed)
    torch.manual_seed(seed)


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
