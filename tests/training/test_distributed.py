"""Training on several processes (``torchrun``): the same update, one run directory, resume.

The multi-process tests start real ``torchrun`` jobs of 2 gloo processes on the
loopback interface (``--standalone``).
"""

from __future__ import annotations

import csv
import json
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest
import torch.distributed as dist
from configs import ROOT, load_smoke

from rlhc.building.builders import ConfigError, Layout
from rlhc.cli.start import preflight
from rlhc.config.validation import PARALLEL_MODES as MODES
from rlhc.config.validation import check_parallel as check
from rlhc.storage.checkpoint import CHECKPOINT_DIR, load_checkpoint
from rlhc.training.distributed import Processes

TORCHRUN = [sys.executable, "-m", "torch.distributed.run", "--standalone", "--nproc_per_node=2"]


def run(command: list[str], cwd: Path) -> subprocess.CompletedProcess[str]:
    # This checkout's rlhc first: the environment may hold another one (an editable
    # install of another worktree).
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT), str(ROOT / "tests")])}
    done = subprocess.run(command, cwd=cwd, env=env, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr[-3000:]
    return done


def metrics(run_dir: Path) -> list[dict[str, str]]:
    with (run_dir / "metrics.csv").open() as file:
        return list(csv.DictReader(file))


@pytest.mark.parametrize(
    "overrides",
    [
        # TanhNormal's entropy is a Monte-Carlo estimate (random draws): without its
        # term, the tennis loss is a deterministic function of the minibatch.
        ["env=tennis", "algo.entropy_coef=0"],
        # League worlds: the opponents' experiences weigh 0, so each rank's share of the
        # weight differs and the denominator must be the whole minibatch's.
        ["env=soccer", "league=mixed"],
        # The learning rate adapted to the KL: one rate on every rank, though their own
        # updates' KLs differ (the rate follows their mean).
        [
            "env=tennis",
            "algo.entropy_coef=0",
            "algo.anneal_lr=false",
            "algo.lr=1e-2",
            "algo.target_kl=0.001",
        ],
    ],
    ids=["tennis", "soccer-league", "tennis-target-kl"],
)
def test_data_parallel_gradient_equals_one_process(tmp_path: Path, overrides: list[str]) -> None:
    out = tmp_path / "result.json"
    run([*TORCHRUN, str(ROOT / "tests" / "distributed_check.py"), str(out), *overrides], tmp_path)
    result = json.loads(out.read_text())
    assert result["processes"] == 2
    assert result["gradient_scale"] > 1e-3  # a real gradient, not zeros on both sides
    assert result["gradient_error"] <= 1e-6
    assert result["parameter_error"] == 0.0  # both ranks hold the same weights
    rates = result["learning_rates"]
    assert len(set(rates)) == 1  # one learning rate, whatever the ranks' own KLs
    if "algo.target_kl=0.001" in overrides:
        assert len(set(result["update_kls"])) == 2  # the ranks' KLs did differ
        assert rates[0] != load_smoke(*overrides).algo.lr  # and the rate was adapted


def test_data_parallel_run_writes_one_run_directory(tmp_path: Path) -> None:
    run(
        [*TORCHRUN, "-m", "rlhc.run", "env=soccer", "experiment=smoke", "logger.backends=[csv]"],
        tmp_path,
    )
    (run_dir,) = (tmp_path / "outputs" / "soccer" / "hierarchical").iterdir()
    rows = metrics(run_dir)
    # The budget counts both processes' worlds: 512 world-decisions in updates of 128
    # (256 experiences per group / 2 agents), 64 from each process's 2 worlds.
    assert [float(row["step"]) for row in rows] == [256.0, 512.0]
    assert [float(row["updates"]) for row in rows] == [2.0, 4.0]
    assert float(rows[-1]["striker/experiences"]) == 1024.0
    assert sorted(p.name for p in (run_dir / CHECKPOINT_DIR).glob("step_*.pt")) == [
        "step_000000256.pt",
        "step_000000512.pt",
    ]
    # Rank 1 wrote nothing of its own; rank 0 the final team at the end of the budget.
    assert {p.name for p in run_dir.iterdir()} == {
        ".hydra",
        "checkpoints",
        "final_team.pt",
        "metrics.csv",
        "run.log",
    }


def test_pipeline_resumes_a_single_process_run(tmp_path: Path) -> None:
    smoke = ["env=tennis", "experiment=smoke", "logger.backends=[csv]", "hydra.run.dir=run"]
    run([sys.executable, "-m", "rlhc.run", *smoke, "algo.max_steps=256"], tmp_path)
    run([*TORCHRUN, "-m", "rlhc.run", *smoke, "parallel=pipeline", "resume=run"], tmp_path)
    rows = metrics(tmp_path / "run")
    assert [float(row["step"]) for row in rows] == [256.0, 512.0]
    before, after = (
        load_checkpoint(tmp_path / "run" / CHECKPOINT_DIR / f"step_{n:09d}.pt") for n in (256, 512)
    )
    assert after["frames"] == 512
    # The collector's normaliser statistics reached the learner's checkpoint: they went
    # on counting from the resumed ones.
    assert normaliser_counts(after) > normaliser_counts(before) > 0


def normaliser_counts(state: dict) -> int:
    (extra,) = (v for k, v in state["env_transform"].items() if k.endswith("_extra_state"))
    return sum(int(v) for k, v in extra.items() if k.startswith("count"))


def test_processes_roles() -> None:
    single = Processes()
    assert single.learns and single.collects and single.shards == 1 and not single.active
    data = Processes(rank=1, size=4, mode="data")
    assert data.learns and data.collects and data.shards == 4 and not data.main
    learner = Processes(rank=0, size=2, mode="pipeline")
    collector = Processes(rank=1, size=2, mode="pipeline")
    assert learner.learns and not learner.collects and learner.shards == 1
    assert collector.collects and not collector.learns


# --- bad input: refused before training, naming the value and what is allowed -----------
@pytest.mark.parametrize(
    ("mode", "size", "league", "message"),
    [
        ("bogus", 2, False, f"parallel='bogus'; allowed: {', '.join(MODES)}"),
        ("pipeline", 3, False, "parallel=pipeline with 3 processes"),
        ("pipeline", 2, True, "parallel=pipeline with league.active"),
    ],
)
def test_check_refuses(mode: str, size: int, league: bool, message: str) -> None:
    with pytest.raises(ConfigError, match=re.escape(message)):
        check(mode, size, "cpu", league)


def test_missing_backend_is_refused(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(dist, "is_gloo_available", lambda: False)
    with pytest.raises(ConfigError, match=re.escape("needs torch.distributed's gloo backend")):
        check("data", 2, "cpu", False)
    check("data", 1, "cpu", False)  # one process needs no backend


def test_preflight_checks_the_split_over_processes(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("WORLD_SIZE", "3")
    # smoke soccer: 128 world-decisions per update in 4 worlds; 3 processes cannot share them.
    with pytest.raises(
        ConfigError, match=re.escape("env.num_envs=4 worlds do not split over 3 processes")
    ):
        preflight(load_smoke("env=soccer"))
    with pytest.raises(ConfigError, match="parallel=pipeline with 3 processes"):
        preflight(load_smoke("env=soccer", "parallel=pipeline"))
    monkeypatch.setenv("WORLD_SIZE", "2")
    preflight(load_smoke("env=soccer"))


def test_layout_splits_worlds_and_minibatches() -> None:
    table3 = dict(buffer_size=2000, batch_size=128, time_horizon=128, agents_per_world=2)
    one = Layout.build(**table3, num_envs=None)
    two = Layout.build(**table3, num_envs=None, shards=2)
    assert (one.num_envs, two.num_envs) == (8, 8)
    assert two.frames_per_batch == one.frames_per_batch == 1000
    assert two.minibatch_frames == 64 and two.minibatches == one.minibatches == 15
    with pytest.raises(ConfigError, match=r"algo.batch_size=2 \(1 world-decisions\) does not"):
        Layout.build(**{**table3, "batch_size": 2}, num_envs=None, shards=2)
    with pytest.raises(ConfigError, match="allowed: null or a multiple of 2"):
        Layout.build(**table3, num_envs=5, shards=2)
