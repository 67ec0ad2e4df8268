"""``rlhc.plot``: smoothing like TensorBoard, seeds grouped by config, a PNG written."""

from __future__ import annotations

import csv
import subprocess
import sys
from pathlib import Path

import matplotlib
import numpy as np
import pytest
from PIL import Image

from rlhc import plot
from rlhc.analysis.curves import (
    Run,
    aggregate,
    ema_smooth,
    final_values,
    group_runs,
    load_runs,
)
from rlhc.analysis.drawing import PNG_COLOURS, compact_png, plot_groups

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # after the backend is chosen


def write_run(
    root: Path, name: str, fusion: str, seed: int, offset: float, groups: tuple[str, ...]
) -> Path:
    """A tiny run directory: metrics.csv plus a Hydra config record."""
    run = root / name
    (run / ".hydra").mkdir(parents=True)
    (run / ".hydra" / "config.yaml").write_text(
        f"env:\n  name: soccer\ncritic:\n  fusion: {fusion}\nseed: {seed}\n"
        f"logger:\n  summary_freq: 1000\n"
    )
    columns = ["step", "episode_length"]
    for group in groups:
        columns += [f"{group}/{leaf}" for leaf in ("cumulative_reward", "entropy", "state_value")]
    with (run / "metrics.csv").open("w", newline="") as f:
        writer = csv.writer(f)
        writer.writerow(columns)
        for i in range(1, 11):
            writer.writerow(
                [1000 * i] + [offset + 0.1 * i + 0.01 * k for k in range(len(columns) - 1)]
            )
    return run


@pytest.fixture
def runs(tmp_path: Path) -> Path:
    groups = ("striker", "goalie")
    write_run(tmp_path, "0_ppo_s0", "local", 0, 0.0, groups)
    write_run(tmp_path, "1_ppo_s1", "local", 1, 0.2, groups)
    write_run(tmp_path, "2_rlhc_s0", "max", 0, 1.0, groups)
    return tmp_path


def test_ema_matches_tensorboard_formula() -> None:
    values = np.array([1.0, 3.0, np.nan, 2.0])
    w = 0.6
    m1 = (1 - w) * 1.0
    m2 = w * m1 + (1 - w) * 3.0
    m3 = w * m2 + (1 - w) * 2.0
    expected = [m1 / (1 - w), m2 / (1 - w**2), np.nan, m3 / (1 - w**3)]
    np.testing.assert_allclose(ema_smooth(values, w), expected)
    np.testing.assert_array_equal(ema_smooth(values, 0.0)[[0, 1, 3]], values[[0, 1, 3]])


def test_seeds_are_grouped_and_averaged(runs: Path) -> None:
    groups = group_runs(load_runs([runs]))
    assert sorted(groups) == ["fusion=local", "fusion=max"]
    assert len(groups["fusion=local"]) == 2
    curve = aggregate(groups["fusion=local"], "episode_length", smoothing=0.0)
    assert curve is not None and curve.runs == 2
    np.testing.assert_allclose(curve.mean, 0.1 + 0.1 * np.arange(1, 11))
    assert np.all(curve.low < curve.mean) and np.all(curve.high > curve.mean)


def test_the_band_is_clipped_to_the_values_the_metric_can_take() -> None:
    steps = np.arange(1.0, 6.0)
    # Two seeds of a share: one never scores, one always does. Their t band reaches
    # far outside [0, 1]; the mean (0.5) stays where it is.
    runs = [Run(Path(f"s{k}"), {"step": steps, "rate": np.full(5, float(k))}) for k in (0, 1)]
    free = aggregate(runs, "rate", smoothing=0.0)
    share = aggregate(runs, "rate", smoothing=0.0, bounds=(0.0, 1.0))
    assert free is not None and share is not None
    assert np.all(free.low < 0.0) and np.all(free.high > 1.0)
    np.testing.assert_array_equal(share.low, np.zeros(5))
    np.testing.assert_array_equal(share.high, np.ones(5))
    np.testing.assert_array_equal(share.mean, free.mean)


def test_final_values_are_last_tenth(runs: Path) -> None:
    loaded = load_runs([runs / "2_rlhc_s0"])
    # steps 1000..10000: the last 10% is step >= 9000, values 1.9 and 2.0.
    assert list(final_values(loaded, "episode_length").values()) == [pytest.approx(1.95)]
    ppo = group_runs(load_runs([runs]))["fusion=local"]
    assert list(final_values(ppo, "episode_length").values()) == [
        pytest.approx(0.95),
        pytest.approx(1.15),
    ]


def test_plot_writes_png(runs: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "figures" / "curves.png"
    plot.main([str(runs), "--out", str(out), "--smoothing", "0.8"])
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    printed = capsys.readouterr().out
    assert "striker/cumulative_reward" in printed and "fusion=max" in printed


def test_a_png_is_written_as_a_palette_image_and_other_formats_as_drawn(
    runs: Path, tmp_path: Path
) -> None:
    groups = group_runs(load_runs([runs]))
    png = plot_groups(groups, out=tmp_path / "curves.png")
    with Image.open(png) as image:
        assert image.mode == "P"
        drawn = np.asarray(image.convert("RGB"))
    assert 16 < len(np.unique(drawn.reshape(-1, 3), axis=0)) <= PNG_COLOURS  # lines, not one colour
    svg = plot_groups(groups, out=tmp_path / "curves.svg")
    assert svg.read_text().lstrip().startswith("<?xml")


def test_compact_png_keeps_a_curve_figure_close_to_as_drawn(tmp_path: Path) -> None:
    fig, ax = plt.subplots(figsize=(4, 3))
    steps = np.linspace(0, 1, 200)
    for shift, colour in ((0.0, "tab:blue"), (0.3, "tab:orange"), (0.6, "tab:green")):
        ax.plot(steps, np.sin(8 * steps) + shift, color=colour, label=colour)
        ax.fill_between(steps, np.sin(8 * steps) + shift - 0.2, np.sin(8 * steps) + shift + 0.2, color=colour, alpha=0.2)  # fmt: skip
    ax.legend()
    ax.set_title("critic: cumulative reward")
    fig.savefig(tmp_path / "rgba.png", dpi=100)
    plt.close(fig)
    compact_png(tmp_path / "rgba.png", tmp_path / "palette.png")
    with Image.open(tmp_path / "rgba.png") as rgba, Image.open(tmp_path / "palette.png") as palette:
        assert palette.mode == "P"
        before = np.asarray(rgba.convert("RGB")).astype(int)
        after = np.asarray(palette.convert("RGB")).astype(int)
    error = np.abs(before - after).max(axis=-1)  # per pixel, of 255
    assert error.mean() < 1.0 and np.percentile(error, 99) <= 16
    assert (tmp_path / "palette.png").stat().st_size < 0.6 * (tmp_path / "rgba.png").stat().st_size


def test_missing_run_is_named(tmp_path: Path) -> None:
    missing = tmp_path / "nope"
    with pytest.raises(FileNotFoundError, match="nope"):
        load_runs([missing])


@pytest.mark.slow
def test_plot_of_a_real_smoke_run(tmp_path: Path) -> None:
    run = tmp_path / "smoke"
    subprocess.run(
        [
            sys.executable,
            "-m",
            "rlhc.run",
            "env=tennis",
            "experiment=smoke",
            f"hydra.run.dir={run}",
        ],
        check=True,
    )
    out = tmp_path / "smoke.png"
    plot.main([str(run), "--out", str(out)])
    assert out.stat().st_size > 0


def test_runs_of_two_games_are_labelled_by_game(tmp_path: Path) -> None:
    write_run(tmp_path, "soccer_run", "max", 0, 0.0, ("striker",))
    tennis = write_run(tmp_path, "tennis_run", "max", 0, 0.0, ("racket",))
    config = (tennis / ".hydra" / "config.yaml").read_text().replace("soccer", "tennis")
    (tennis / ".hydra" / "config.yaml").write_text(config + "algo:\n  lr: 0.0003\n")
    assert sorted(group_runs(load_runs([tmp_path]))) == ["name=soccer", "name=tennis"]
