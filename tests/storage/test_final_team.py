"""A finished run keeps its final team: the policy part of its last checkpoint.

The file must be written only at the end of the budget, hold what a policy is rebuilt
from and nothing a resume needs, play without the checkpoints next to it, and never be
taken for a checkpoint by a resume.
"""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest
import torch
from configs import load_smoke as load

from rlhc.envs import make_env
from rlhc.evaluation.opponents import make_team_policy
from rlhc.storage.checkpoint import CHECKPOINT_DIR, checkpoint_candidates, load_checkpoint
from rlhc.storage.final_team import (
    TEAM_FILE,
    TEAM_KEYS,
    export_team,
    has_team,
    load_team,
    team_state,
)
from rlhc.training.trainer import Trainer


@pytest.fixture(scope="module")
def finished(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A tennis smoke run trained to its budget (checkpoints at 256 and 512 frames)."""
    run = tmp_path_factory.mktemp("run")
    Trainer(load("env=tennis", "algo.max_steps=512", "checkpoint_freq=256"), run).train()
    return run


def test_the_end_of_the_budget_writes_the_final_team(finished: Path) -> None:
    team = torch.load(finished / TEAM_FILE, weights_only=True)
    assert sorted(team) == sorted([*TEAM_KEYS, "format_version"])
    last = load_checkpoint(finished)
    assert team["frames"] == last["frames"] == 512
    for group, weights in last["actors"].items():
        for name, tensor in weights.items():
            assert torch.equal(team["actors"][group][name], tensor), (group, name)
    # Smaller than the checkpoint: no critics, optimiser or random states.
    assert (finished / TEAM_FILE).stat().st_size < 0.5 * Path(last["path"]).stat().st_size


def test_an_unfinished_run_has_no_final_team(tmp_path: Path) -> None:
    trainer = Trainer(load("env=tennis", "algo.max_steps=512", "checkpoint_freq=256"), tmp_path)
    trainer.save()  # a periodic checkpoint before the budget is reached
    assert not (tmp_path / TEAM_FILE).exists()
    assert has_team(tmp_path)  # it still plays, from its checkpoint


def test_the_final_team_plays_without_the_checkpoints(finished: Path, tmp_path: Path) -> None:
    kept = tmp_path / "clone"
    shutil.copytree(finished, kept)
    shutil.rmtree(kept / CHECKPOINT_DIR)  # as on a fresh clone: checkpoints are not committed
    assert has_team(kept) and not checkpoint_candidates(kept)
    assert Path(load_team(kept)["path"]).name == TEAM_FILE
    env = make_env("tennis", num_envs=2, seed=0)
    try:
        actions = make_team_policy(str(kept), env)(env.reset())["racket"]
        from_checkpoint = make_team_policy(str(finished / CHECKPOINT_DIR), env)(env.reset())
    finally:
        env.close()
    assert actions.shape == (2, 4, 3) and torch.isfinite(actions).all()
    assert from_checkpoint["racket"].shape == actions.shape


def test_a_resume_never_reads_the_final_team(finished: Path, tmp_path: Path) -> None:
    kept = tmp_path / "clone"
    shutil.copytree(finished, kept)
    shutil.rmtree(kept / CHECKPOINT_DIR)
    assert TEAM_FILE not in [p.name for p in checkpoint_candidates(finished)]
    with pytest.raises(FileNotFoundError, match="no checkpoint in run directory"):
        load_checkpoint(kept)


def test_export_rebuilds_the_file_from_the_newest_checkpoint(
    finished: Path, tmp_path: Path
) -> None:
    copy = tmp_path / "copy"
    shutil.copytree(finished, copy)
    (copy / TEAM_FILE).unlink()
    assert export_team(copy) == copy / TEAM_FILE
    exported, written = load_team(copy), load_team(finished)
    assert exported["frames"] == written["frames"]
    assert exported["config"] == written["config"]


def test_missing_entries_and_empty_directories_are_named(tmp_path: Path) -> None:
    with pytest.raises(KeyError, match="env_transform"):
        team_state({"env": "tennis", "config": {}, "frames": 0, "actors": {}})
    assert not has_team(tmp_path)
    with pytest.raises(FileNotFoundError, match=f"no {TEAM_FILE} in .*no checkpoint"):
        load_team(tmp_path)
