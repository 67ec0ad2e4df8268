"""``mode=elo`` with ``video.enabled=true``: one video per pairing, named in the pairing rows."""

from __future__ import annotations

import csv
import json
from pathlib import Path

from hydra import compose, initialize_config_dir
from omegaconf import OmegaConf
from PIL import Image

from rlhc.config.evaluate_schema import EvaluateConfig, register_evaluate_configs
from rlhc.config.validation import validate_evaluate
from rlhc.evaluation.commands import VIDEO_DIR, run_elo

ROOT = Path(__file__).resolve().parents[2]
register_evaluate_configs()


def load(*overrides: str) -> EvaluateConfig:
    with initialize_config_dir(config_dir=str(ROOT / "conf"), version_base="1.3"):
        cfg = compose(config_name="evaluate", overrides=list(overrides))
    return OmegaConf.to_object(cfg)  # type: ignore[return-value]


def test_elo_records_one_video_per_pairing(checkpoints: dict[str, Path], tmp_path: Path) -> None:
    run = checkpoints["tennis"]
    cfg = load(
        "mode=elo",
        "env=tennis",
        f"players=[random,scripted,{run}]",
        "matches=2",
        "video.enabled=true",
        "video.max_frames=8",
    )
    validate_evaluate(cfg)
    run_elo(cfg, tmp_path)

    expected = [
        "0_random_vs_scripted.gif",
        f"1_random_vs_{run.name}.gif",
        f"2_scripted_vs_{run.name}.gif",
    ]
    assert sorted(p.name for p in (tmp_path / VIDEO_DIR).iterdir()) == expected
    for name in expected:
        with Image.open(tmp_path / VIDEO_DIR / name) as gif:
            assert 2 <= gif.n_frames <= 8
    pairings = json.loads((tmp_path / "elo.json").read_text())["pairings"]
    assert [(p["home"], p["away"], Path(p["video"]).name) for p in pairings] == [
        ("random", "scripted", expected[0]),
        ("random", str(run), expected[1]),
        ("scripted", str(run), expected[2]),
    ]
    with (tmp_path / "pairings.csv").open() as f:
        assert [Path(row["video"]).name for row in csv.DictReader(f)] == expected


def test_elo_without_video_writes_no_video(tmp_path: Path) -> None:
    run_elo(load("mode=elo", "env=tennis", "players=[random,scripted]", "matches=2"), tmp_path)
    assert not (tmp_path / VIDEO_DIR).exists()
    assert "video" not in json.loads((tmp_path / "elo.json").read_text())["pairings"][0]
