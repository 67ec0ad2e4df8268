"""Checkpoints survive a kill at any instant: atomic writes, resolution past broken files."""

from __future__ import annotations

import os
import pickletools
import random
import signal
import subprocess
import sys
import textwrap
import time
import zipfile
from pathlib import Path

import pytest
import torch

from rlhc.storage import checkpoint
from rlhc.storage.checkpoint import (
    CHECKPOINT_DIR,
    LATEST,
    checkpoint_candidates,
    load_checkpoint,
    save_checkpoint,
)

ROOT = Path(__file__).resolve().parents[2]


def step_file(run: Path, frames: int) -> Path:
    return run / CHECKPOINT_DIR / f"step_{frames:09d}.pt"


def save(run: Path, frames: int) -> Path:
    path = step_file(run, frames)
    save_checkpoint(path, {"frames": frames, "weights": torch.arange(frames, dtype=torch.float32)})
    return path


def set_mtime(path: Path, seconds: float) -> None:
    os.utime(path, (seconds, seconds), follow_symlinks=False)


def truncate(path: Path) -> None:
    data = path.read_bytes()
    path.write_bytes(data[: len(data) // 2])


def link_latest(run: Path, target_name: str) -> None:
    latest = run / CHECKPOINT_DIR / LATEST
    latest.unlink(missing_ok=True)
    latest.symlink_to(target_name)


def visible_files(run: Path) -> list[str]:
    return sorted(p.name for p in (run / CHECKPOINT_DIR).iterdir())


def test_save_links_latest_and_leaves_no_temporary_file(tmp_path: Path) -> None:
    save(tmp_path, 256)
    newest = save(tmp_path, 512)
    latest = tmp_path / CHECKPOINT_DIR / LATEST
    assert latest.is_symlink() and os.readlink(latest) == newest.name
    assert visible_files(tmp_path) == [LATEST, "step_000000256.pt", "step_000000512.pt"]
    state = load_checkpoint(tmp_path)
    assert state["frames"] == 512 and state["path"] == str(newest.resolve())
    assert torch.equal(state["weights"], torch.arange(512, dtype=torch.float32))


def test_a_save_that_fails_midway_keeps_the_previous_checkpoint(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    save(tmp_path, 256)

    def write_half_then_die(obj: object, f: object) -> None:
        f.write(b"PK\x03\x04 half a zip")  # type: ignore[attr-defined]
        raise KeyboardInterrupt  # as abrupt as Python lets a test be

    monkeypatch.setattr(checkpoint.torch, "save", write_half_then_die)
    with pytest.raises(KeyboardInterrupt):
        save(tmp_path, 512)
    assert visible_files(tmp_path) == [LATEST, "step_000000256.pt"]
    assert load_checkpoint(tmp_path)["frames"] == 256


def test_step_file_without_latest_is_found(tmp_path: Path) -> None:
    # Killed after the first step file was renamed into place, before latest.pt existed.
    save(tmp_path, 256)
    (tmp_path / CHECKPOINT_DIR / LATEST).unlink()
    assert load_checkpoint(tmp_path)["frames"] == 256


def test_stale_latest_link_yields_to_a_newer_step_file(tmp_path: Path) -> None:
    # Killed after step 512 was written, before latest.pt was relinked from step 256.
    save(tmp_path, 256)
    save(tmp_path, 512)
    link_latest(tmp_path, "step_000000256.pt")
    set_mtime(step_file(tmp_path, 256), 1_000)
    set_mtime(step_file(tmp_path, 512), 2_000)
    assert load_checkpoint(tmp_path)["frames"] == 512


def test_dangling_latest_link_falls_back_to_the_newest_step_file(tmp_path: Path) -> None:
    save(tmp_path, 256)
    save(tmp_path, 512)
    link_latest(tmp_path, "step_000000768.pt")
    assert load_checkpoint(tmp_path)["frames"] == 512


def test_truncated_newest_step_file_is_skipped_with_a_warning(tmp_path: Path) -> None:
    save(tmp_path, 256)
    save(tmp_path, 512)
    save(tmp_path, 768)
    truncate(step_file(tmp_path, 768))
    truncate(step_file(tmp_path, 512))
    with pytest.warns(RuntimeWarning, match=r"step_000000768\.pt.*step_000000512\.pt") as caught:
        state = load_checkpoint(tmp_path)
    assert state["frames"] == 256
    assert len(caught) == 1


def test_a_branch_resumed_in_place_follows_latest_not_the_largest_step(tmp_path: Path) -> None:
    # Trained to 1024, then resumed from step 512 into the same directory and saved 768.
    for frames in (512, 1024, 768):
        save(tmp_path, frames)
    set_mtime(step_file(tmp_path, 512), 1_000)
    set_mtime(step_file(tmp_path, 1024), 2_000)
    set_mtime(step_file(tmp_path, 768), 3_000)
    assert load_checkpoint(tmp_path)["frames"] == 768


def test_a_copied_run_with_shuffled_times_keeps_its_newest_file(tmp_path: Path) -> None:
    for frames in (256, 512, 768):
        save(tmp_path, frames)
    set_mtime(step_file(tmp_path, 768), 1_000)  # copied first
    set_mtime(step_file(tmp_path, 256), 3_000)
    set_mtime(step_file(tmp_path, 512), 2_000)
    assert [checkpoint.step_of(p) for p in checkpoint_candidates(tmp_path)] == [768, 512, 256]
    assert load_checkpoint(tmp_path)["frames"] == 768


def test_a_checkpoints_directory_is_accepted_directly(tmp_path: Path) -> None:
    save(tmp_path, 256)
    assert load_checkpoint(tmp_path / CHECKPOINT_DIR)["frames"] == 256


def test_nothing_loadable_names_the_directory_and_what_was_looked_for(tmp_path: Path) -> None:
    (tmp_path / CHECKPOINT_DIR).mkdir()
    with pytest.raises(FileNotFoundError, match=r"no checkpoint in run directory .*step_\*\.pt"):
        load_checkpoint(tmp_path)

    save(tmp_path, 256)
    truncate(step_file(tmp_path, 256))
    with pytest.raises(FileNotFoundError) as error:
        load_checkpoint(tmp_path)
    message = str(error.value)
    assert str(tmp_path) in message and "latest.pt" in message and "step_*.pt" in message
    assert "step_000000256.pt" in message and "\n" not in message


def test_a_truncated_file_given_directly_is_named(tmp_path: Path) -> None:
    path = save(tmp_path, 256)
    truncate(path)
    with pytest.raises(ValueError, match=r"step_000000256\.pt.*not a loadable rlhc checkpoint"):
        load_checkpoint(path)
    with pytest.raises(FileNotFoundError, match="nowhere"):
        load_checkpoint(tmp_path / "nowhere.pt")


def test_a_foreign_file_is_not_a_checkpoint(tmp_path: Path) -> None:
    path = step_file(tmp_path, 256)
    path.parent.mkdir(parents=True)
    torch.save({"frames": 256}, path)  # no format_version
    with pytest.raises(ValueError, match="format 1"):
        load_checkpoint(path)


def pickled_globals(path: Path) -> set[str]:
    """Every ``module.name`` that a ``torch.save`` file's pickle names (read, not loaded)."""
    with zipfile.ZipFile(path) as archive:
        data = archive.read(next(n for n in archive.namelist() if n.endswith("data.pkl")))
    names = set()
    for opcode, arg, _ in pickletools.genops(data):
        # torch.save pickles with protocol 2: classes are GLOBAL opcodes, "module name".
        assert opcode.name != "STACK_GLOBAL", f"{path}: protocol 4+, read its names otherwise"
        if opcode.name == "GLOBAL":
            names.add(str(arg).replace(" ", "."))
    return names


def test_committed_teams_and_checkpoints_pickle_no_rlhc_class() -> None:
    """The committed ``.pt`` files (loaded with ``weights_only=False``) name torch's,
    numpy's and the standard library's classes only, none of rlhc's: moving or renaming
    a module of rlhc cannot break loading them."""
    files = sorted((ROOT / "benchmarks" / "results").rglob("*.pt"))
    assert files
    named = {name for path in files for name in pickled_globals(path)}
    assert "torch._utils._rebuild_tensor_v2" in named
    assert not [name for name in named if name.split(".")[0] == "rlhc"], sorted(named)


def test_saving_onto_the_link_name_is_refused(tmp_path: Path) -> None:
    with pytest.raises(ValueError, match=r"latest\.pt"):
        save_checkpoint(tmp_path / CHECKPOINT_DIR / LATEST, {"frames": 0})


# --- real kills -----------------------------------------------------------------------
SAVE_LOOP = textwrap.dedent(
    """
    import sys
    from pathlib import Path
    import torch
    from rlhc.storage.checkpoint import save_checkpoint

    run = Path(sys.argv[1])
    weights = torch.zeros(2_000_000)  # 8 MB: a save takes long enough to be killed inside
    for i in range(1, 10_000):
        save_checkpoint(run / "checkpoints" / f"step_{256 * i:09d}.pt",
                        {"frames": 256 * i, "weights": weights})
    """
)


def wait_for_first_checkpoint(process: subprocess.Popen[bytes], run: Path, timeout: float) -> None:
    deadline = time.monotonic() + timeout
    while not list((run / CHECKPOINT_DIR).glob("step_*.pt")):
        if process.poll() is not None:
            raise AssertionError(f"the process ended (code {process.returncode}) before saving")
        if time.monotonic() > deadline:
            process.kill()
            raise AssertionError(f"no checkpoint in {run} after {timeout} s")
        time.sleep(0.005)


def kill_and_check(command: list[str], run: Path, delay: float) -> int:
    """Start ``command``, SIGKILL it ``delay`` s after its first checkpoint, check ``run``."""
    env = {**os.environ, "WANDB_MODE": "offline"}
    process = subprocess.Popen(
        command, cwd=ROOT, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL
    )
    try:
        wait_for_first_checkpoint(process, run, timeout=60.0)
        time.sleep(delay)
    finally:
        process.send_signal(signal.SIGKILL)
        process.wait()
    state = load_checkpoint(run)
    steps = [checkpoint.step_of(p) for p in (run / CHECKPOINT_DIR).glob("step_*.pt")]
    # Writes are atomic: every visible step file is complete, and the newest is chosen.
    assert state["frames"] == max(s for s in steps if s is not None)
    for path in (run / CHECKPOINT_DIR).glob("step_*.pt"):
        assert load_checkpoint(path)["frames"] == checkpoint.step_of(path)
    return int(state["frames"])


def test_a_save_loop_killed_at_random_instants_leaves_a_loadable_checkpoint(
    tmp_path: Path,
) -> None:
    # A kill right after the first file appears often lands before latest.pt exists;
    # later ones mostly land inside a write (8 MB per save).
    rng = random.Random(0)
    delays = [0.0, 0.0, rng.uniform(0.0, 0.5), rng.uniform(0.0, 0.5)]
    for attempt, delay in enumerate(delays):
        run = tmp_path / f"run{attempt}"
        kill_and_check([sys.executable, "-c", SAVE_LOOP, str(run)], run, delay)


@pytest.mark.slow
def test_a_training_run_killed_at_random_instants_leaves_a_loadable_checkpoint(
    tmp_path: Path,
) -> None:
    rng = random.Random(0)
    for attempt, delay in enumerate([0.0, rng.uniform(0.0, 1.5), rng.uniform(0.0, 1.5)]):
        run = tmp_path / f"run{attempt}"
        command = [
            sys.executable,
            "-m",
            "rlhc.run",
            "env=tennis",
            "experiment=smoke",
            f"hydra.run.dir={run}",
            "checkpoint_freq=256",
            "algo.max_steps=1000000",
        ]
        frames = kill_and_check(command, run, delay)
        assert frames >= 256
