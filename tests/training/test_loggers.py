"""Metric logging across a resume: wandb continues the run directory's own wandb run."""

from __future__ import annotations

from pathlib import Path

import pytest
from cli_runs import run_in_process

from rlhc.training.loggers import WANDB_RUN_ID_FILE

SMOKE = ["env=tennis", "experiment=smoke", "logger=wandb", "logger.wandb_mode=offline"]


def offline_run_ids(run_dir: Path) -> list[str]:
    """The ids of the offline wandb runs in ``run_dir`` (``offline-run-<time>-<id>``), by time."""
    return [p.name.rsplit("-", 1)[-1] for p in sorted((run_dir / "wandb").glob("offline-run-*"))]


def test_a_resume_continues_the_same_wandb_run(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.setenv("WANDB_MODE", "offline")
    first = run_in_process(
        [*SMOKE, "algo.max_steps=64", "hydra.run.dir=run"], tmp_path, monkeypatch, capsys
    )
    assert first.code == 0, first.stderr
    run = tmp_path / "run"
    run_id = (run / WANDB_RUN_ID_FILE).read_text().strip()
    assert offline_run_ids(run) == [run_id]
    resumed = run_in_process(
        [*SMOKE, "algo.max_steps=128", "resume=run"], tmp_path, monkeypatch, capsys
    )
    assert resumed.code == 0, resumed.stderr
    assert (run / WANDB_RUN_ID_FILE).read_text().strip() == run_id
    assert set(offline_run_ids(run)) == {run_id}  # every start logged to the one run
