"""A finished run's final team: the policy part of its last checkpoint, small enough to commit.

A match needs only :data:`TEAM_KEYS` of a checkpoint. A run that reaches its budget also
writes them to ``<run dir>/final_team.pt`` (checkpoint format), so a study's teams play
without their checkpoints, and a round robin versions a team by the file's hash.

Examples:
    A stand-in checkpoint without weights:

    >>> import tempfile
    >>> run = Path(tempfile.mkdtemp())
    >>> checkpoint = {"env": "tennis", "config": {}, "frames": 3_600_000, "actors": {},
    ...               "env_transform": {}, "optimizer": {}, "rng": {}}
    >>> save_team(run, checkpoint).name
    'final_team.pt'
    >>> state = load_team(run)
    >>> state["frames"], Path(state["path"]).name, "optimizer" in state
    (3600000, 'final_team.pt', False)
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from rlhc.storage.checkpoint import checkpoint_candidates, load_checkpoint, write_atomically

#: The file, directly in the run directory.
TEAM_FILE = "final_team.pt"
#: The checkpoint entries a policy is rebuilt from (:func:`rlhc.evaluation.policies.restore_policy`).
TEAM_KEYS = ("env", "config", "frames", "actors", "env_transform")


def team_state(state: Mapping[str, Any]) -> dict[str, Any]:
    """The :data:`TEAM_KEYS` of a checkpoint's ``state``.

    Raises:
        KeyError: ``state`` lacks some of them (all named).
    """
    missing = [key for key in TEAM_KEYS if key not in state]
    if missing:
        raise KeyError(
            f"a final team needs the checkpoint entries {missing}; it has {sorted(state)}"
        )
    return {key: state[key] for key in TEAM_KEYS}


def save_team(run_dir: str | os.PathLike[str], state: Mapping[str, Any]) -> Path:
    """Write ``<run_dir>/final_team.pt`` from a checkpoint's ``state`` (atomically); its path."""
    path = Path(run_dir) / TEAM_FILE
    write_atomically(path, team_state(state))
    return path


def export_team(run_dir: str | os.PathLike[str]) -> Path:
    """Write the final team of ``run_dir`` from its newest checkpoint that loads (for runs
    trained before the trainer wrote it); its path.

    Raises:
        FileNotFoundError: the directory holds no loadable checkpoint.
    """
    return save_team(run_dir, load_checkpoint(run_dir))


def team_file(path: str | os.PathLike[str]) -> Path | None:
    """The final-team file ``path`` names: itself (a file) or the run directory's one."""
    candidate = Path(path).expanduser()
    if candidate.is_file():
        return candidate
    file = candidate / TEAM_FILE
    return file if file.is_file() else None


def load_team(path: str | os.PathLike[str]) -> dict[str, Any]:
    """What plays for ``path``: a run directory's final team, else its newest checkpoint.

    Args:
        path: a run directory (an unfinished run plays from its newest checkpoint), or a
            final-team or checkpoint file.

    Returns:
        The stored state, with ``"path"``.

    Raises:
        FileNotFoundError: ``path`` does not exist, or is a directory with neither file.
        ValueError: the file is not a loadable rlhc checkpoint.
    """
    file = team_file(path)
    if file is not None:
        return load_checkpoint(file)
    try:
        return load_checkpoint(path)
    except FileNotFoundError as error:
        raise FileNotFoundError(f"no {TEAM_FILE} in {str(path)!r}, and {error}") from None


def has_team(path: str | os.PathLike[str]) -> bool:
    """Whether :func:`load_team` has something to load for ``path`` (nothing is loaded)."""
    return team_file(path) is not None or bool(checkpoint_candidates(path))
