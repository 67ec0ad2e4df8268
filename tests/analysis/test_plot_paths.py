"""``rlhc.plot`` arguments: a shell glob over a multirun works; non-runs are skipped, named once."""

from __future__ import annotations

import csv
import shlex
import subprocess
import sys
from pathlib import Path

import pytest

from rlhc import plot
from rlhc.analysis.curves import load_runs, split_run_paths

ROOT = Path(__file__).resolve().parents[2]
PNG = b"\x89PNG\r\n\x1a\n"


def write_run(run: Path, seed: int) -> Path:
    """A run directory as ``rlhc.run`` leaves it: metrics.csv plus Hydra's config record."""
    (run / ".hydra").mkdir(parents=True)
    (run / ".hydra" / "config.yaml").write_text(
        f"env:\n  name: tennis\ncritic:\n  fusion: max\nseed: {seed}\n"
    )
    with (run / "metrics.csv").open("w", newline="") as f:
        writer = csv.writer(f)
        writer.writerow(["step", "episode_length", "racket/cumulative_reward"])
        for i in range(1, 6):
            writer.writerow([256 * i, 10.0 + i + seed, 0.1 * i])
    return run


@pytest.fixture
def sweep(tmp_path: Path) -> Path:
    """A Hydra multirun directory: two jobs, ``multirun.yaml`` and a directory of no run."""
    root = tmp_path / "multirun" / "2025-01-01_00-00-00"
    write_run(root / "0_seed=0", 0)
    write_run(root / "1_seed=1", 1)
    (root / "multirun.yaml").write_text("hydra:\n  mode: MULTIRUN\n")
    (root / "notes").mkdir()
    return root


def test_split_run_paths_separates_runs_from_other_paths(sweep: Path) -> None:
    paths = sorted(sweep.glob("*"))
    runs, not_runs = split_run_paths(paths)
    assert runs == [sweep / "0_seed=0", sweep / "1_seed=1"]
    assert not_runs == [sweep / "multirun.yaml", sweep / "notes"]
    assert split_run_paths([sweep / "0_seed=0" / "metrics.csv"]) == ([sweep / "0_seed=0"], [])


def test_load_runs_stays_strict_for_library_callers(sweep: Path) -> None:
    with pytest.raises(FileNotFoundError, match=r"multirun\.yaml"):
        load_runs([sweep / "0_seed=0", sweep / "multirun.yaml"])


def test_a_glob_over_a_multirun_plots_with_one_warning_line(
    sweep: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "curves.png"
    plot.main([*map(str, sorted(sweep.glob("*"))), "--out", str(out)])
    assert out.read_bytes()[:8] == PNG
    captured = capsys.readouterr()
    warning = captured.err.splitlines()
    assert len(warning) == 1
    assert "warning" in warning[0] and "2 path(s)" in warning[0]
    assert str(sweep / "multirun.yaml") in warning[0] and str(sweep / "notes") in warning[0]
    assert "n=2" in captured.out  # both seeds were plotted as one configuration


def test_the_command_as_written_in_a_shell_exits_0(sweep: Path, tmp_path: Path) -> None:
    out = tmp_path / "curves.png"
    python, glob = shlex.quote(sys.executable), f"{shlex.quote(str(sweep))}/*"
    command = f"{python} -m rlhc.plot {glob} --out {shlex.quote(str(out))}"
    result = subprocess.run(command, shell=True, cwd=ROOT, capture_output=True, text=True)
    assert result.returncode == 0, result.stderr
    assert out.read_bytes()[:8] == PNG
    assert "multirun.yaml" in result.stderr


def test_no_run_directory_left_fails_with_one_line(
    sweep: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "curves.png"
    with pytest.raises(plot.UsageError) as error:
        plot.main([str(sweep / "multirun.yaml"), str(sweep / "notes"), "--out", str(out)])
    message = str(error.value)
    assert "no run directory" in message and "metrics.csv" in message
    assert str(sweep / "multirun.yaml") in message and "\n" not in message
    assert not out.exists()
    assert len(capsys.readouterr().err.splitlines()) == 1  # the warning, before the error


def test_a_path_that_does_not_exist_is_an_error_not_a_skip(sweep: Path, tmp_path: Path) -> None:
    with pytest.raises(plot.UsageError, match="typo") as error:
        plot.main([str(sweep / "0_seed=0"), str(sweep / "typo"), "--out", str(tmp_path / "c.png")])
    assert "\n" not in str(error.value)
