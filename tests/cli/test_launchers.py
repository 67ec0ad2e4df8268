"""Sweeps through Hydra's cluster launchers, for real, on this machine.

The README's "Sweeps on a cluster" recipes use Hydra's submitit launcher (Slurm) and its
Ray launcher. Without a cluster, the same plugins run here: submitit's local executor
(each job its own process, as a Slurm array task would be) and a Ray instance started
for the sweep on loopback (``hydra/launcher=ray_local``, ``conf/hydra/launcher/``).
Each test runs a 2-job smoke sweep to completion (about 15-25 s on 2 cores) and checks
that both jobs wrote their metrics and a final checkpoint in their own directories.
They skip, saying why, when the ``cluster`` extra is not installed.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest
from cli_runs import steps, subprocess_env

from rlhc.storage.checkpoint import load_checkpoint

MISSING = "needs the cluster extra: pip install -e .[cluster]"
#: The 2-job sweep of both tests: seconds per job (512 frames, csv only).
SWEEP = ["experiment=smoke", "env=soccer", "seed=0,1", "logger.backends=[csv]"]
FRAMES = 512  # experiment=smoke's algo.max_steps
#: The job directories Hydra names (job number, then the sorted overrides).
JOBS = [f"{seed}_env-soccer_experiment-smoke_logger.backends-[csv]_seed-{seed}" for seed in (0, 1)]


def sweep(launcher: list[str], sweep_dir: Path, env: dict[str, str] | None = None) -> str:
    """``python -m rlhc.run -m <launcher> <SWEEP>`` into ``sweep_dir``; its output."""
    result = subprocess.run(
        [sys.executable, "-m", "rlhc.run", "-m", *launcher, *SWEEP, f"hydra.sweep.dir={sweep_dir}"],
        cwd=sweep_dir.parent,
        env={**subprocess_env(), **(env or {})},
        capture_output=True,
        text=True,
        timeout=300,
    )
    output = result.stdout + result.stderr
    assert result.returncode == 0, output[-3000:]
    return output


def assert_both_jobs_finished(sweep_dir: Path) -> None:
    jobs = sorted(p.name for p in sweep_dir.iterdir() if p.is_dir() and not p.name.startswith("."))
    assert jobs == JOBS
    seeds = set()
    for job in jobs:
        run_dir = sweep_dir / job
        assert steps(run_dir)[-1] == FRAMES  # metrics.csv, to the end of the budget
        state = load_checkpoint(run_dir)  # checkpoints/latest.pt
        assert state["frames"] == FRAMES
        seeds.add(state["config"]["seed"])
    assert seeds == {0, 1}


def test_submitit_local_sweep(tmp_path: Path) -> None:
    pytest.importorskip("hydra_plugins.hydra_submitit_launcher", reason=MISSING)
    sweep_dir = tmp_path / "sweep"
    output = sweep(["hydra/launcher=submitit_local"], sweep_dir)
    assert "Submitit 'local' sweep output dir" in output
    assert_both_jobs_finished(sweep_dir)
    # Each job ran as its own submitit job, which logged its successful end.
    logs = sorted((sweep_dir / ".submitit").glob("*/*_0_log.out"))
    assert len(logs) == 2
    assert all("Job completed successfully" in log.read_text() for log in logs)


def test_ray_launcher_sweep_on_a_local_loopback_instance(tmp_path: Path) -> None:
    pytest.importorskip("ray", reason=MISSING)
    pytest.importorskip("hydra_plugins.hydra_ray_launcher", reason=MISSING)
    sweep_dir = tmp_path / "sweep"
    # Ray's usage statistics would otherwise be reported over the network.
    output = sweep(
        ["hydra/launcher=ray_local", "hydra.launcher.ray.init.num_cpus=2"],
        sweep_dir,
        env={"RAY_USAGE_STATS_ENABLED": "0"},
    )
    assert "Ray Launcher is launching 2 jobs" in output
    assert "'address': 'local'" in output and "'_node_ip_address': '127.0.0.1'" in output
    assert "Started a local Ray instance" in output
    assert_both_jobs_finished(sweep_dir)
