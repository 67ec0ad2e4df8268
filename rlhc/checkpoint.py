"""Checkpoints: everything needed to continue a run exactly where it was saved.

A checkpoint is one ``torch.save`` file written atomically (temporary file, then
``os.replace``), so a kill during a save leaves the previous checkpoint intact.
"""

from __future__ import annotations

import os
import random
from pathlib import Path
from typing import Any

import numpy as np
import torch

CHECKPOINT_DIR = "checkpoints"
LATEST = "latest.pt"
FORMAT_VERSION = 1


def save_checkpoint(path: Path, state: dict[str, Any]) -> None:
    """Write ``state`` to ``path`` atomically and point ``latest.pt`` at it."""
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(path.name + ".tmp")
    torch.save({"format_version": FORMAT_VERSION, **state}, tmp)
    os.replace(tmp, path)
    latest = path.parent / LATEST
    latest_tmp = path.parent / (LATEST + ".tmp")
    latest_tmp.unlink(missing_ok=True)
    latest_tmp.symlink_to(path.name)
    os.replace(latest_tmp, latest)


def resolve_checkpoint(path: str | os.PathLike[str]) -> Path:
    """A checkpoint file from a file path or a run directory (its latest checkpoint).

    Raises:
        FileNotFoundError: naming the path and what was looked for.
    """
    candidate = Path(path).expanduser()
    if candidate.is_dir():
        for option in (candidate / CHECKPOINT_DIR / LATEST, candidate / LATEST):
            if option.exists():
                return option.resolve()
        raise FileNotFoundError(
            f"no checkpoint in run directory {str(candidate)!r}: expected "
            f"{CHECKPOINT_DIR}/{LATEST} inside it"
        )
    if not candidate.is_file():
        raise FileNotFoundError(
            f"checkpoint {str(candidate)!r} does not exist (give a .pt file or a run directory)"
        )
    return candidate.resolve()


def load_checkpoint(path: str | os.PathLike[str]) -> dict[str, Any]:
    """Load a checkpoint written by :func:`save_checkpoint` (file or run directory)."""
    file = resolve_checkpoint(path)
    state = torch.load(file, map_location="cpu", weights_only=False)
    if not isinstance(state, dict) or state.get("format_version") != FORMAT_VERSION:
        raise ValueError(f"{str(file)!r} is not an rlhc checkpoint (format {FORMAT_VERSION})")
    state["path"] = str(file)
    return state


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
