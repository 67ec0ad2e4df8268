"""One training process per run directory: a second one is refused in one line, and a
lock left by a process that died is taken over with a warning."""

from __future__ import annotations

import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from cli_runs import run_in_process, run_subprocess, subprocess_env

from rlhc.storage.run_lock import LOCK_FILE

SMOKE = ["env=tennis", "experiment=smoke", "logger.backends=[csv]"]


def test_a_second_run_on_a_directory_in_use_is_refused(tmp_path: Path) -> None:
    first = subprocess.Popen(
        [sys.executable, "-m", "rlhc.run", *SMOKE, "algo.max_steps=100000000", "hydra.run.dir=run"],
        cwd=tmp_path,
        env=subprocess_env(),
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    try:
        deadline = time.monotonic() + 120
        while not (tmp_path / "run" / "checkpoints" / "latest.pt").exists():
            assert first.poll() is None and time.monotonic() < deadline
            time.sleep(0.5)
        second = run_subprocess(
            [*SMOKE, "algo.max_steps=100000000", "resume=run"], tmp_path, timeout=120
        )
        assert first.poll() is None  # still training
    finally:
        first.send_signal(signal.SIGTERM)
        first.wait(timeout=120)
    assert second.code == 2, second.stderr
    (line,) = second.stderr.splitlines()
    assert line.startswith(f"rlhc.run: error: run is in use by process {first.pid} ("), line
    assert not (tmp_path / "run" / LOCK_FILE).exists()  # released by the first at its stop


def test_a_lock_left_by_a_dead_process_is_taken_over_with_a_warning(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    dead = subprocess.Popen([sys.executable, "-c", "pass"])
    dead.wait()
    (tmp_path / "run").mkdir()
    (tmp_path / "run" / LOCK_FILE).write_text(f"{dead.pid}\n")
    outcome = run_in_process(
        [*SMOKE, "algo.max_steps=64", "hydra.run.dir=run"], tmp_path, monkeypatch, capsys
    )
    assert outcome.code == 0, outcome.stderr
    (warning,) = [line for line in outcome.stdout.splitlines() if LOCK_FILE in line]
    assert f"took over {LOCK_FILE} from process {dead.pid}" in warning, warning
    assert not (tmp_path / "run" / LOCK_FILE).exists()
