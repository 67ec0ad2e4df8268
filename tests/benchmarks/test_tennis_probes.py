"""``benchmarks/tennis_probes.py``: the curves' table read from a run's ``metrics.csv``."""

from __future__ import annotations

import csv
from pathlib import Path

import pytest

from benchmarks import tennis_probes


def write_run(run: Path, frames: list[int], hits: list[float]) -> Path:
    """A run directory whose ``metrics.csv`` holds these rows (KL 0.01, clip 0.1)."""
    run.mkdir(parents=True)
    with (run / "metrics.csv").open("w", newline="") as f:
        writer = csv.writer(f)
        writer.writerow(["step", tennis_probes.HITS, "racket/kl_approx", "racket/clip_fraction"])
        writer.writerows([step, hit, 0.01, 0.1] for step, hit in zip(frames, hits, strict=True))
    return run


def test_marks_average_the_rows_within_their_window(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    monkeypatch.setattr(tennis_probes, "RESULTS", tmp_path)
    # Rows every 100 K: the 1 M mark averages 0.9, 1.0 and 1.1 M; nothing is near 5 M.
    frames = list(range(100_000, 2_000_001, 100_000))
    hits = [float(k) for k in range(1, len(frames) + 1)]
    run = write_run(tmp_path / "long" / "ppo" / "seed_0", frames, hits)
    row = tennis_probes.curve_row(run, [1.0, 5.0]).split(" | ")
    assert row[0] == "| long/ppo/seed_0"
    assert row[1] == f"{(9 + 10 + 11) / 3:.2f}"
    assert row[2] == ""
    assert row[3] == "2.00 M"
    assert float(row[4]) == pytest.approx(sum(hits[-10:]) / 10, abs=0.005)
    assert row[5:7] == ["0.0100", "0.100 |"]


def test_unknown_presets_are_named(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    write_run(tmp_path / "probe_x" / "ppo" / "seed_0", [100_000], [1.0])
    monkeypatch.setattr(tennis_probes, "RESULTS", tmp_path)
    assert [run.parents[1].name for run in tennis_probes.run_directories(None)] == ["probe_x"]
    with pytest.raises(SystemExit, match="probe_y"):
        tennis_probes.run_directories(["probe_y"])
