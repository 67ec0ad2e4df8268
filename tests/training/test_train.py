"""End to end: every env × every critic trains for two iterations, resumes, sweeps."""

from __future__ import annotations

import csv
import math
import os
import subprocess
import sys
from pathlib import Path

import pytest
import torch
from configs import load_smoke as load
from configs import options

from rlhc.envs import game_spec, games
from rlhc.storage.checkpoint import load_checkpoint
from rlhc.training.trainer import Trainer

CRITICS = options("critic")
ENVS = games()
TIMING = ("env_steps_per_s", "train_frames_per_s", "wall_time")


def read_metrics(run_dir: Path) -> list[dict[str, float]]:
    with (run_dir / "metrics.csv").open(newline="") as f:
        return [{k: float(v) for k, v in row.items() if v != ""} for row in csv.DictReader(f)]


@pytest.mark.parametrize("critic", CRITICS)
@pytest.mark.parametrize("env", ENVS)
def test_two_iterations_write_logs_checkpoint_and_finite_metrics(
    env: str, critic: str, tmp_path: Path
) -> None:
    cfg = load(f"env={env}", f"critic={critic}", "algo.max_steps=512")
    Trainer(cfg, tmp_path).train()

    rows = read_metrics(tmp_path)
    assert [row["step"] for row in rows] == [256.0, 512.0]
    groups = game_spec(env).groups
    for row in rows:
        for group in groups:
            for metric in ("entropy", "state_value", "loss_objective", "kl_approx"):
                assert math.isfinite(row[f"{group}/{metric}"]), (group, metric, row)
        assert all(math.isfinite(v) for v in row.values()), row
    assert list((tmp_path / "tb").rglob("events.out.tfevents.*"))
    state = load_checkpoint(tmp_path)
    assert state["frames"] == 512
    assert state["env"] == env


def test_resume_continues_the_step_counter_and_the_curve(tmp_path: Path) -> None:
    first = load("env=tennis", "algo.max_steps=512", "checkpoint_freq=256")
    Trainer(first, tmp_path).train()
    assert load_checkpoint(tmp_path)["frames"] == 512

    resumed = load("env=tennis", "algo.max_steps=1024", f"resume={tmp_path}")
    trainer = Trainer(resumed, tmp_path)
    assert trainer.frames == 512
    trainer.train()
    assert [row["step"] for row in read_metrics(tmp_path)] == [256.0, 512.0, 768.0, 1024.0]
    assert load_checkpoint(tmp_path)["frames"] == 1024


def test_resume_rejects_a_checkpoint_of_the_other_env(tmp_path: Path) -> None:
    Trainer(load("env=tennis", "algo.max_steps=256"), tmp_path).train()
    with pytest.raises(ValueError, match="tennis"):
        Trainer(load("env=soccer", f"resume={tmp_path}"), tmp_path / "other")


def test_resume_from_a_missing_path_names_it(tmp_path: Path) -> None:
    missing = tmp_path / "nowhere"
    with pytest.raises(FileNotFoundError, match="nowhere"):
        Trainer(load("env=tennis", f"resume={missing}"), tmp_path)


def test_same_seed_gives_the_same_first_logged_values(tmp_path: Path) -> None:
    runs = []
    for name in ("a", "b"):
        torch.manual_seed(12345)  # a different global state before: the run must reseed
        Trainer(load("env=tennis", "algo.max_steps=512", "seed=7"), tmp_path / name).train()
        runs.append(read_metrics(tmp_path / name))
    strip = [[{k: v for k, v in r.items() if k not in TIMING} for r in run] for run in runs]
    assert strip[0] == strip[1]


def test_periodic_evaluation_logs_a_win_rate(tmp_path: Path) -> None:
    cfg = load("env=soccer", "algo.max_steps=512", "eval_freq=512", "eval_matches=4")
    Trainer(cfg, tmp_path).train()
    rows = read_metrics(tmp_path)
    assert "eval/win_rate" not in rows[0]
    assert 0.0 <= rows[1]["eval/win_rate"] <= 1.0
    assert rows[1]["eval/win_rate"] + rows[1]["eval/draw_rate"] <= 1.0


def test_periodic_play_measurement_logs_play_and_leaves_training_alone(tmp_path: Path) -> None:
    common = ("env=tennis", "algo.max_steps=512", "seed=7")
    Trainer(load(*common), tmp_path / "plain").train()
    # Measured after the first update of two: the second one must not notice.
    played = ("play_freq=256", "play_worlds=2", "play_decisions=40")
    Trainer(load(*common, *played), tmp_path / "played").train()
    plain, rows = read_metrics(tmp_path / "plain"), read_metrics(tmp_path / "played")
    assert [row["step"] for row in rows] == [256.0, 512.0]
    last = rows[0]
    assert last["play/hits_per_point"] >= 0.0 and 0.0 <= last["play/toward_ball"] <= 1.0
    for dimension in ("move", "jump", "tilt"):
        assert last[f"play/sigma_far/{dimension}"] > 0.0
        assert 0.0 <= last[f"play/saturated/{dimension}"] <= 1.0

    # Training itself is the same, row for row (the measurement restores the generators).
    def training(row: dict[str, float]) -> dict[str, float]:
        return {k: v for k, v in row.items() if k not in TIMING and not k.startswith("play/")}

    assert [training(row) for row in rows] == [training(row) for row in plain]


def test_a_period_crossed_between_rows_is_measured_at_the_next_row(tmp_path: Path) -> None:
    # Updates of 64 frames, a row every 128: play_freq=192 is crossed at 192 (no row
    # there) and at 384; each measurement lands in the first row after its crossing.
    cfg = load(
        "env=tennis", "algo.max_steps=512", "logger.summary_freq=128",
        "play_freq=192", "play_worlds=2", "play_decisions=20",
    )  # fmt: skip
    trainer = Trainer(cfg, tmp_path)
    assert trainer.layout.frames_per_batch == 64
    trainer.train()
    rows = read_metrics(tmp_path)
    assert [row["step"] for row in rows if "play/hits_per_point" in row] == [256.0, 384.0]


def run_cli(*args: str, cwd: Path) -> subprocess.CompletedProcess[str]:
    env = {**os.environ, "WANDB_MODE": "offline"}
    return subprocess.run(
        [sys.executable, "-m", "rlhc.run", *args],
        cwd=cwd,
        env=env,
        capture_output=True,
        text=True,
        timeout=300,
    )


def test_bad_override_fails_fast_with_a_readable_message(tmp_path: Path) -> None:
    result = run_cli("algo.lrr=0.1", cwd=tmp_path)
    assert result.returncode != 0
    assert "lrr" in result.stderr
    assert not (tmp_path / "outputs").exists() or not list((tmp_path / "outputs").rglob("*.csv"))


def test_multirun_of_two_jobs_gives_two_output_directories(tmp_path: Path) -> None:
    sweep = tmp_path / "sweep"
    result = run_cli(
        "-m",
        "env=tennis",
        "experiment=smoke",
        "algo.max_steps=256",
        "seed=0,1",
        f"hydra.sweep.dir={sweep}",
        cwd=tmp_path,
    )
    assert result.returncode == 0, result.stderr[-2000:]
    runs = sorted(p.parent for p in sweep.rglob("metrics.csv"))
    assert len(runs) == 2
    assert {p.name.split("_")[0] for p in runs} == {"0", "1"}
