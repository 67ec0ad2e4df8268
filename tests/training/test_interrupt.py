"""SIGINT / SIGTERM during training: finish the update, checkpoint, say how to resume, exit 130 / 143."""

from __future__ import annotations

import os
import shlex
import signal
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path

import pytest
from cli_runs import ROOT, run_in_process, steps, subprocess_env
from hydra import compose, initialize_config_dir
from omegaconf import OmegaConf
from tensordict import TensorDictBase
from tensordict.nn import TensorDictModuleBase, TensorDictSequential

from rlhc.config.train_schema import TrainConfig, register_configs
from rlhc.storage.checkpoint import CHECKPOINT_DIR, load_checkpoint, step_of
from rlhc.training.interrupt import StopSignals, TrainingInterrupted
from rlhc.training.trainer import Trainer

SMOKE = ["env=tennis", "experiment=smoke", "logger.summary_freq=64", "checkpoint_freq=64"]
register_configs()


def load(*overrides: str) -> TrainConfig:
    with initialize_config_dir(config_dir=str(ROOT / "conf"), version_base="1.3"):
        cfg = compose(config_name="train", overrides=[*SMOKE, *overrides])
    return OmegaConf.to_object(cfg)  # type: ignore[return-value]


def test_stop_signals_records_the_first_signal_and_restores_the_handlers() -> None:
    before = {s: signal.getsignal(s) for s in (signal.SIGINT, signal.SIGTERM)}
    with StopSignals() as stop:
        assert stop.received is None
        os.kill(os.getpid(), signal.SIGTERM)  # handled: the process goes on
        time.sleep(0.01)
        assert stop.received == signal.SIGTERM
        # After the first signal the previous handlers are back: a second one acts.
        assert {s: signal.getsignal(s) for s in before} == before
    assert {s: signal.getsignal(s) for s in before} == before


@pytest.fixture
def terminal_signals() -> Iterator[None]:
    """SIGINT and SIGTERM handled as in a terminal, for the test's duration.

    A shell's background job (``&``, ``nohup``) starts with SIGINT ignored, and
    :class:`StopSignals` rightly leaves an ignored signal ignored.
    """
    previous = {s: signal.getsignal(s) for s in (signal.SIGINT, signal.SIGTERM)}
    defaults = {signal.SIGINT: signal.default_int_handler, signal.SIGTERM: signal.SIG_DFL}
    for signum, handler in previous.items():
        if handler is signal.SIG_IGN:
            signal.signal(signum, defaults[signum])
    yield
    for signum, handler in previous.items():
        signal.signal(signum, handler)


@pytest.mark.parametrize(("signum", "code"), [(signal.SIGINT, 130), (signal.SIGTERM, 143)])
@pytest.mark.usefixtures("terminal_signals")
def test_a_signal_finishes_the_update_saves_and_raises(
    signum: int, code: int, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    handlers = {s: signal.getsignal(s) for s in (signal.SIGINT, signal.SIGTERM)}
    trainer = Trainer(load("algo.max_steps=1024"), tmp_path)
    save = trainer.save

    def save_then_get_signalled() -> Path:
        path = save()
        if trainer.frames == 128:
            os.kill(os.getpid(), signum)  # as Ctrl-C or kill, inside the loop
        return path

    monkeypatch.setattr(trainer, "save", save_then_get_signalled)
    with pytest.raises(TrainingInterrupted) as stop:
        trainer.train()
    assert (stop.value.signum, stop.value.exit_code, stop.value.frames) == (signum, code, 128)
    # The checkpoint of that very update is the one named, not a second copy.
    assert stop.value.checkpoint.name == "step_000000128.pt"
    assert load_checkpoint(tmp_path)["frames"] == 128
    assert steps(tmp_path) == [64, 128]
    assert {s: signal.getsignal(s) for s in handlers} == handlers


class SignalOnCall(TensorDictModuleBase):
    """A no-op policy step that sends ``signum`` to this process at its ``at``-th call."""

    def __init__(self, signum: int, at: int) -> None:
        super().__init__()
        self.in_keys: list[str] = []
        self.out_keys: list[str] = []
        self.signum, self.at, self.calls = signum, at, 0

    def forward(self, tensordict: TensorDictBase) -> TensorDictBase:
        self.calls += 1
        if self.calls == self.at:
            os.kill(os.getpid(), self.signum)
        return tensordict


def test_a_signal_during_collection_finishes_that_collection_and_its_update(
    tmp_path: Path,
) -> None:
    trainer = Trainer(load("algo.max_steps=1024"), tmp_path)
    # 4 worlds x 16 decisions per 64-frame batch: call 20 is inside the second collection.
    trainer.collection_policy = TensorDictSequential(
        SignalOnCall(signal.SIGTERM, at=20), trainer.collection_policy
    )
    with pytest.raises(TrainingInterrupted) as stop:
        trainer.train()
    assert stop.value.frames == trainer.frames == 128
    assert stop.value.checkpoint.name == "step_000000128.pt"
    assert steps(tmp_path) == [64, 128]


def wait_for_a_checkpoint(process: subprocess.Popen[str], run: Path, timeout: float) -> None:
    deadline = time.monotonic() + timeout
    while not list((run / CHECKPOINT_DIR).glob("step_*.pt")):
        if process.poll() is not None:
            raise AssertionError(f"ended with {process.returncode} before a checkpoint")
        if time.monotonic() > deadline:
            process.kill()
            raise AssertionError(f"no checkpoint in {run} after {timeout} s")
        time.sleep(0.01)


@pytest.mark.parametrize(
    ("name", "code"),
    [("SIGINT", 130), pytest.param("SIGTERM", 143, marks=pytest.mark.slow)],  # ~9 s each
)
def test_a_signalled_run_checkpoints_says_how_to_resume_and_exits(
    name: str,
    code: int,
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> None:
    run = tmp_path / "run"
    process = subprocess.Popen(
        [sys.executable, "-m", "rlhc.run", *SMOKE, "algo.max_steps=100000000", "hydra.run.dir=run"],
        cwd=tmp_path,
        env=subprocess_env(),
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        # A runner may start children with SIGINT ignored (as a shell's background jobs).
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
    )
    try:
        wait_for_a_checkpoint(process, run, timeout=120)
        process.send_signal(getattr(signal, name))
        stdout, stderr = process.communicate(timeout=60)
    finally:
        process.kill()
    assert process.returncode == code, stderr
    assert "Traceback" not in stderr and "Error" not in stderr, stderr
    (line,) = [line for line in stdout.splitlines() if "stopped at" in line]
    frames = load_checkpoint(run)["frames"]
    checkpoint = run / CHECKPOINT_DIR / f"step_{frames:09d}.pt"
    assert f"{name}: stopped at {frames:,} frames of 100,000,000" in line
    assert f"checkpoint {checkpoint.relative_to(tmp_path)};" in line
    command = shlex.split(line.split("resume with: ", 1)[1])
    assert command[:3] == [sys.executable, "-m", "rlhc.run"]
    assert command[3:] == [*SMOKE, "algo.max_steps=100000000", "resume=run"]
    assert step_of(checkpoint) == frames and frames % 64 == 0

    # The printed command continues the run in its directory (with a reachable budget).
    args = [a if not a.startswith("algo.max_steps=") else f"algo.max_steps={frames + 64}" for a in command[3:]]  # fmt: skip
    resumed = run_in_process(args, tmp_path, monkeypatch, capsys)
    assert resumed.code == 0, resumed.stderr
    assert load_checkpoint(run)["frames"] == frames + 64
    assert steps(run) == list(range(64, frames + 65, 64))
