"""``resume=``: continues in the run's own directory, refuses changed networks, says what differs.

The in-process runs go through :func:`rlhc.run.cli` exactly as ``python -m rlhc.run``
would (Hydra, the ``rlhc.run_dir`` resolver, the preflight callback).
"""

from __future__ import annotations

import shutil
import time
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import torch
from cli_runs import (
    read_metrics,
    run_in_process,
    snapshot,
    steps,
    tensorboard_steps,
)
from hydra import compose, initialize_config_dir
from omegaconf import OmegaConf
from tensordict import TensorDictBase

from rlhc.cli import start
from rlhc.cli.hydra_hooks import run_directory
from rlhc.config.train_schema import TrainConfig, register_configs
from rlhc.storage.checkpoint import (
    CHECKPOINT_DIR,
    ResumeError,
    config_differences,
    load_checkpoint,
    run_dir_of,
)
from rlhc.training import training_state
from rlhc.training.trainer import Trainer

CONF = Path(__file__).resolve().parents[2] / "conf"
#: 64-frame updates (smoke: 256 experiences / 4 rackets), a summary and a checkpoint each.
SMOKE = ["env=tennis", "experiment=smoke", "logger.summary_freq=64", "checkpoint_freq=64"]
TIMING = ("env_steps_per_s", "train_frames_per_s", "wall_time")
register_configs()


def load(*overrides: str) -> TrainConfig:
    with initialize_config_dir(config_dir=str(CONF), version_base="1.3"):
        cfg = compose(config_name="train", overrides=[*SMOKE, *overrides])
    return OmegaConf.to_object(cfg)  # type: ignore[return-value]


def trained(run: Path, frames: int) -> Path:
    """A smoke run in ``run`` trained to ``frames``, a checkpoint every update."""
    Trainer(load(f"algo.max_steps={frames}"), run).train()
    return run


# --- where a resumed run writes ------------------------------------------------------
def test_run_dir_of_a_run_its_checkpoints_and_a_file_in_them(tmp_path: Path) -> None:
    run = trained(tmp_path / "run", 64)
    checkpoints = run / CHECKPOINT_DIR
    for given in (run, checkpoints, checkpoints / "latest.pt", checkpoints / "step_000000064.pt"):
        assert run_dir_of(given) == run
        assert run_directory(str(given), "outputs/new") == str(run)
    loose = tmp_path / "copied.pt"
    shutil.copy(checkpoints / "step_000000064.pt", loose)
    for elsewhere in (loose, tmp_path / "nowhere", tmp_path):
        assert run_dir_of(elsewhere) is None
        assert run_directory(str(elsewhere), "outputs/new") == "outputs/new"
    assert run_directory(None, "outputs/new") == "outputs/new"


def test_resume_of_a_run_directory_continues_in_it(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    first = run_in_process([*SMOKE, "algo.max_steps=128"], tmp_path, monkeypatch, capsys)
    assert first.code == 0, first.stderr
    runs = tmp_path / "outputs" / "tennis" / "hierarchical"
    (run,) = runs.iterdir()
    time.sleep(1.1)  # a new run would now get a directory of another name (seconds)
    resumed = run_in_process(
        [*SMOKE, "algo.max_steps=256", f"resume=outputs/tennis/hierarchical/{run.name}"],
        tmp_path,
        monkeypatch,
        capsys,
    )
    assert resumed.code == 0, resumed.stderr
    assert list(runs.iterdir()) == [run]
    assert steps(run) == [64, 128, 192, 256]
    assert [p.name for p in (run / "tb").iterdir()] == [run.name]  # one TensorBoard run
    assert tensorboard_steps(run) == [64, 128, 192, 256]
    last = resumed.stdout.strip().splitlines()[-1]
    assert last.endswith(f"results in outputs/tennis/hierarchical/{run.name}")
    log = (run / "run.log").read_text()
    assert log.count("results in") == 2  # appended to, not replaced


@pytest.mark.parametrize("multirun", [False, True], ids=["run", "multirun_job"])
def test_a_resume_loads_its_checkpoint_once(
    multirun: bool,
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> None:
    # A single run is checked by the Preflight callback, a multirun job by the
    # rlhc.output_subdir resolver (resume=auto); the job and the trainer reuse that load.
    run = trained(tmp_path / "sweep" / "job", 64)
    loads: list[str] = []

    def counted(path: str) -> dict[str, Any]:
        loads.append(str(path))
        return load_checkpoint(path)

    monkeypatch.setattr(start, "load_checkpoint", counted)
    monkeypatch.setattr(training_state, "load_checkpoint", counted)
    args = [*SMOKE, "algo.max_steps=128"]
    if multirun:
        args = ["-m", *args, "resume=auto", "hydra.sweep.dir=sweep", "hydra.sweep.subdir=job"]
    else:
        args = [*args, "resume=sweep/job"]
    resumed = run_in_process(args, tmp_path, monkeypatch, capsys)
    assert resumed.code == 0, resumed.stderr
    assert loads == ["sweep/job"]
    assert steps(run) == [64, 128]


def test_resume_of_an_earlier_checkpoint_drops_the_abandoned_branch(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    first = run_in_process(
        [*SMOKE, "algo.max_steps=256", "hydra.run.dir=run"], tmp_path, monkeypatch, capsys
    )
    assert first.code == 0, first.stderr
    run = tmp_path / "run"
    old = {int(r["step"]): r["racket/loss_objective"] for r in read_metrics(run)}
    resumed = run_in_process(
        [*SMOKE, "algo.max_steps=256", "resume=run/checkpoints/step_000000128.pt"],
        tmp_path,
        monkeypatch,
        capsys,
    )
    assert resumed.code == 0, resumed.stderr
    assert steps(run) == [64, 128, 192, 256]
    assert tensorboard_steps(run) == [64, 128, 192, 256]  # the old 192, 256 are purged
    new = {int(r["step"]): r["racket/loss_objective"] for r in read_metrics(run)}
    assert [new[s] == old[s] for s in (64, 128)] == [True, True]
    assert load_checkpoint(run)["frames"] == 256


def test_an_explicit_run_dir_wins_over_the_resumed_runs_own(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    run = trained(tmp_path / "run", 64)
    before = snapshot(run)
    outcome = run_in_process(
        [*SMOKE, "algo.max_steps=128", "resume=run", "hydra.run.dir=branch"],
        tmp_path,
        monkeypatch,
        capsys,
    )
    assert outcome.code == 0, outcome.stderr
    assert snapshot(run) == before
    assert steps(tmp_path / "branch") == [128]
    assert load_checkpoint(tmp_path / "branch")["frames"] == 128


def test_a_torn_last_line_of_metrics_is_dropped_with_a_warning(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    run = trained(tmp_path / "run", 128)
    metrics = run / "metrics.csv"
    text = metrics.read_text()
    last = text.rstrip("\n").rsplit("\n", 1)[1]
    torn = text[: len(text) - len(last) // 2 - 1]  # a crash while appending the last row
    metrics.write_text(torn)
    resumed = run_in_process(
        [*SMOKE, "algo.max_steps=192", "resume=run"], tmp_path, monkeypatch, capsys
    )
    assert resumed.code == 0, resumed.stderr
    (warning,) = [line for line in resumed.stdout.splitlines() if "torn" in line]
    assert "metrics.csv" in warning and "WARNING" in warning
    assert steps(run) == [64, 192]  # the torn row (128) is gone, the run continued
    rows = metrics.read_text().splitlines()
    assert all(len(row.split(",")) == len(rows[0].split(",")) for row in rows)


# --- what a resume may change --------------------------------------------------------
def test_config_differences_names_fixed_keys_only() -> None:
    stored = {
        "env": {"name": "tennis", "num_envs": 4, "extended_obs": False},
        "critic": {"fusion": "max"},
        "model": {"hidden_size": 32},
        "algo": {"max_steps": 512, "lr": 1e-3, "normalize_observations": True},
        "logger": {"summary_freq": 64},
        "checkpoint_freq": 64,
        "eval_freq": 0,
    }
    current = {
        "env": {"name": "tennis", "num_envs": 8, "extended_obs": True, "added_later": 1},
        "critic": {"fusion": "local"},
        "model": {"hidden_size": 64},
        "algo": {"max_steps": 1024, "lr": 3e-4, "normalize_observations": False},
        "logger": {"summary_freq": 128},
        "checkpoint_freq": 128,
        "eval_freq": 512,
    }
    assert config_differences(stored, current) == [
        "algo.normalize_observations: True -> False",
        "critic.fusion: 'max' -> 'local'",
        "env.extended_obs: False -> True",
        "model.hidden_size: 32 -> 64",
    ]


def test_resume_with_other_networks_env_or_critic_names_each_key(tmp_path: Path) -> None:
    run = trained(tmp_path / "run", 64)
    changed = load(
        "algo.max_steps=128",
        "critic=ppo",
        "model.hidden_size=16",
        "env.extended_obs=true",
        f"resume={run}",
    )
    with pytest.raises(ResumeError) as error:
        Trainer(changed, tmp_path / "other")
    message = str(error.value)
    for key in (
        "critic.fusion: 'max' -> 'local'",
        "model.hidden_size: 32 -> 16",
        "env.extended_obs",
    ):
        assert key in message
    assert "step_000000064.pt" in message
    with pytest.raises(ResumeError, match=r"env\.name: 'tennis' -> 'soccer'"):
        Trainer(load("env=soccer", f"resume={run}"), tmp_path / "other")


def test_a_refused_resume_writes_nothing(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    run = trained(tmp_path / "run", 64)
    before = snapshot(tmp_path)
    outcome = run_in_process(
        [*SMOKE, "algo.max_steps=128", "model.hidden_size=16", "resume=run"],
        tmp_path,
        monkeypatch,
        capsys,
    )
    assert outcome.code == 2
    (line,) = outcome.stderr.splitlines()
    assert (
        line.startswith("rlhc.run: error: resume='run'") and "model.hidden_size: 32 -> 16" in line
    )
    assert snapshot(tmp_path) == before  # not even .hydra/ of the run is rewritten
    assert run.is_dir()


def test_resume_may_change_budget_logging_evaluation_and_worlds(tmp_path: Path) -> None:
    run = trained(tmp_path / "run", 64)
    cfg = load(
        f"resume={run}",
        "algo.max_steps=192",
        "logger.summary_freq=128",
        "checkpoint_freq=128",
        "eval_freq=10000",
        "eval_matches=2",
        "env.num_envs=8",
        "algo.lr=1e-4",
    )
    Trainer(cfg, run).train()
    assert steps(run) == [64, 128, 192]
    assert load_checkpoint(run)["frames"] == 192


def test_resuming_a_finished_run_says_so_and_writes_nothing(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    trained(tmp_path / "run", 128)
    before = snapshot(tmp_path)
    for resume in ("run", "run/checkpoints/latest.pt"):
        outcome = run_in_process(
            [*SMOKE, "algo.max_steps=128", f"resume={resume}"], tmp_path, monkeypatch, capsys
        )
        assert outcome.code == 0, outcome.stderr
        assert "has trained 128 frames of algo.max_steps=128: the run is finished" in outcome.stdout
        assert snapshot(tmp_path) == before


# --- what a resume restores ----------------------------------------------------------
def assert_same(restored: object, saved: object, where: str = "") -> None:
    """Nested dicts, lists and tensors equal, exactly."""
    if isinstance(saved, dict):
        assert isinstance(restored, dict) and restored.keys() == saved.keys(), where
        for key, value in saved.items():
            assert_same(restored[key], value, f"{where}.{key}")
    elif isinstance(saved, (list, tuple)):
        assert isinstance(restored, (list, tuple)) and len(restored) == len(saved), where
        for index, (mine, theirs) in enumerate(zip(restored, saved, strict=True)):
            assert_same(mine, theirs, f"{where}[{index}]")
    elif isinstance(saved, (torch.Tensor, np.ndarray)):
        assert torch.equal(torch.as_tensor(restored), torch.as_tensor(saved)), where
    else:
        assert restored == saved, where


def test_a_resume_restores_the_saved_state_exactly(tmp_path: Path) -> None:
    run = trained(tmp_path / "run", 128)
    saved = load_checkpoint(run)
    state = Trainer(load("algo.max_steps=256", f"resume={run}"), run).state()
    for part in ("frames", "iteration", "wall_time", "actors", "losses", "optimizer"):
        assert_same(state[part], saved[part], part)
    for part in ("env_transform", "game_rng", "rng"):
        assert_same(state[part], saved[part], part)


def test_an_already_loaded_checkpoint_resumes_as_its_path_does(tmp_path: Path) -> None:
    run = trained(tmp_path / "run", 128)
    saved = load_checkpoint(run)
    by_path = Trainer(load("algo.max_steps=256", f"resume={run}"), run).state()
    given = Trainer(load("algo.max_steps=256"), run, resume_state=saved).state()
    for part in ("frames", "iteration", "wall_time", "actors", "losses", "optimizer"):
        assert_same(given[part], by_path[part], part)
    for part in ("env_transform", "game_rng", "rng"):
        assert_same(given[part], by_path[part], part)
    # Checked as a loaded path is: the settings its weights belong to may not change.
    with pytest.raises(ResumeError, match=r"model\.hidden_size: 32 -> 16"):
        Trainer(load("model.hidden_size=16"), tmp_path / "other", resume_state=saved)


def test_after_a_resume_every_world_starts_from_a_reset(tmp_path: Path) -> None:
    run = trained(tmp_path / "run", 128)
    first_steps: list[torch.Tensor] = []

    class Recording(Trainer):
        def update(self, batch: TensorDictBase) -> dict[str, float]:
            first_steps.append(batch["step_count"][:, 0].flatten().clone())
            return super().update(batch)

    Recording(load("algo.max_steps=192", f"resume={run}"), run).train()
    assert torch.equal(first_steps[0], torch.zeros_like(first_steps[0]))


def test_resuming_one_checkpoint_twice_gives_the_same_run(tmp_path: Path) -> None:
    run = trained(tmp_path / "run", 128)
    copies = [tmp_path / "a", tmp_path / "b"]
    finals = []
    for copy in copies:
        shutil.copytree(run, copy, symlinks=True)
        Trainer(load("algo.max_steps=256", f"resume={copy}"), copy).train()
        finals.append(load_checkpoint(copy))
    rows = [
        [{k: v for k, v in row.items() if k not in TIMING} for row in read_metrics(c)]
        for c in copies
    ]
    assert rows[0] == rows[1]
    for group, weights in finals[0]["actors"].items():
        for name, tensor in weights.items():
            assert torch.equal(tensor, finals[1]["actors"][group][name])
