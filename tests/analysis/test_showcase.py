"""``python -m rlhc.evaluate mode=showcase``: headlines from real matches, a point on video,
the run's curves."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest
from configs import load_smoke
from hydra import compose, initialize_config_dir
from omegaconf import OmegaConf
from PIL import Image

from rlhc.analysis.showcase import CURVES_FILE, SHOWCASE_FILE, run_showcase
from rlhc.config.evaluate_schema import EvaluateConfig, register_evaluate_configs

ROOT = Path(__file__).resolve().parents[2]
register_evaluate_configs()


def load(*overrides: str) -> EvaluateConfig:
    with initialize_config_dir(config_dir=str(ROOT / "conf"), version_base="1.3"):
        cfg = compose(config_name="evaluate", overrides=["mode=showcase", *overrides])
    return OmegaConf.to_object(cfg)  # type: ignore[return-value]


@pytest.fixture(scope="module")
def tennis_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Run directory of a one-update tennis run (its final team and metrics.csv)."""
    from rlhc.training.trainer import Trainer

    run_dir = tmp_path_factory.mktemp("tennis_run")
    Trainer(
        load_smoke("env=tennis", "algo.max_steps=256", "logger.backends=[csv]"), run_dir
    ).train()
    return run_dir


def test_a_trained_run_gets_its_headlines_video_and_curves(
    tennis_run: Path, tmp_path: Path
) -> None:
    run_dir = tennis_run
    cfg = load("env=tennis", f"home={run_dir}", "matches=4", "video.max_frames=6")
    result = run_showcase(cfg, tmp_path)
    saved = json.loads((tmp_path / SHOWCASE_FILE).read_text())
    assert saved["headlines"] == result["headlines"]
    headlines = result["headlines"]
    # The play diagnostics of the team with itself, as training's play/ logs them.
    assert headlines["hits_per_point"] == result["play"]["hits_per_point"] >= 0.0
    for team in ("scripted", "random"):
        summary = result["series"][team]
        assert (summary["home"], summary["away"], summary["matches"]) == (str(run_dir), team, 4)
        assert headlines[f"points_won_vs_{team}"] == summary["points_won_rate"]
        low, high = headlines[f"points_won_vs_{team}_low"], headlines[f"points_won_vs_{team}_high"]
        assert 0.0 <= low <= headlines[f"points_won_vs_{team}"] <= high <= 1.0
    with Image.open(result["files"]["video"]) as gif:
        assert gif.n_frames == 6  # one point, cut at video.max_frames
    assert Path(result["files"]["curves"]) == tmp_path / CURVES_FILE
    with Image.open(tmp_path / CURVES_FILE) as curves:
        assert curves.width > 0


def test_a_built_in_team_has_no_play_diagnostics_or_curves(tmp_path: Path) -> None:
    cfg = load("env=soccer", "home=scripted", "matches=2", "env.max_cycles=50",
               "video.max_frames=3")  # fmt: skip
    result = run_showcase(cfg, tmp_path)
    assert result["play"] == {} and "curves" not in result["files"]
    expected = {
        f"{name}_vs_{team}{end}"
        for team in ("scripted", "random")
        for name, end in (("points_won", ""), ("points_won", "_low"), ("points_won", "_high"),
                          ("win_rate", ""))
    }  # fmt: skip
    assert set(result["headlines"]) == expected


def test_cli_prints_the_headlines_and_where_the_files_are(tmp_path: Path) -> None:
    out = tmp_path / "showcase"
    done = subprocess.run(
        [sys.executable, "-m", "rlhc.evaluate", "mode=showcase", "env=soccer", "home=scripted",
         "matches=2", "env.max_cycles=50", "video.max_frames=3", f"hydra.run.dir={out}"],
        check=True, cwd=ROOT, capture_output=True, text=True,
    )  # fmt: skip
    assert "vs random:" in done.stdout and f"results: {out / SHOWCASE_FILE}" in done.stdout
    assert (out / "point.gif").is_file()
