"""``python -m rlhc.evaluate``: config validation, match files, an Elo table from real games."""

from __future__ import annotations

import csv
import json
import subprocess
import sys
from pathlib import Path

import pytest
from hydra import compose, initialize_config_dir
from omegaconf import OmegaConf

from rlhc.config.evaluate_schema import EvaluateConfig, register_evaluate_configs
from rlhc.config.validation import validate_evaluate
from rlhc.evaluation.commands import run_elo

ROOT = Path(__file__).resolve().parents[2]
register_evaluate_configs()


def load(*overrides: str) -> EvaluateConfig:
    with initialize_config_dir(config_dir=str(ROOT / "conf"), version_base="1.3"):
        cfg = compose(config_name="evaluate", overrides=list(overrides))
    return OmegaConf.to_object(cfg)  # type: ignore[return-value]


def test_config_composes_and_validates() -> None:
    cfg = load("env=tennis", "home=random", "matches=10", "env.num_envs=4")
    assert (cfg.env.name, cfg.home, cfg.num_envs()) == ("tennis", "random", 4)
    validate_evaluate(cfg)
    with pytest.raises(ValueError, match="mode"):
        validate_evaluate(load("mode=league"))
    with pytest.raises(ValueError, match="players"):
        validate_evaluate(load("mode=elo", "players=[scripted]"))


def test_cli_writes_results(tmp_path: Path) -> None:
    run = tmp_path / "eval"
    subprocess.run(
        [sys.executable, "-m", "rlhc.evaluate", "env=soccer", "home=scripted", "away=random",
         "matches=4", "env.max_cycles=100", f"hydra.run.dir={run}"],
        check=True, cwd=ROOT, capture_output=True,
    )  # fmt: skip
    summary = json.loads((run / "results.json").read_text())
    assert summary["matches"] == 4 and summary["env"] == "soccer"
    assert summary["wins"] + summary["draws"] + summary["losses"] == 4
    assert len(summary["win_rate_ci"]) == 2
    with (run / "matches.csv").open() as f:
        assert [int(row["home_side"]) for row in csv.DictReader(f)] == [0, 1, 0, 1]


def test_elo_of_the_stronger_player_rises(tmp_path: Path) -> None:
    cfg = load("mode=elo", "env=soccer", "players=[random,scripted]", "matches=8")
    table = run_elo(cfg, tmp_path)
    assert table.ratings["scripted"] > 1200.0 > table.ratings["random"]
    standings = json.loads((tmp_path / "elo.json").read_text())["standings"]
    assert standings[0]["player"] == "scripted"
