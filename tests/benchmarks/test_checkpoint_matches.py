"""``benchmarks/checkpoint_matches.py``: every checkpoint of a run against a built-in team."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from cli_runs import run_in_process
from configs import load_smoke

from benchmarks import checkpoint_matches
from rlhc import evaluate
from rlhc.storage.checkpoint import CHECKPOINT_DIR
from rlhc.training.trainer import Trainer


@pytest.fixture(scope="module")
def run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A tennis smoke run with checkpoints at 256 and 512 court-decisions."""
    directory = tmp_path_factory.mktemp("checkpoint_matches") / "run"
    cfg = load_smoke("env=tennis", "algo.max_steps=512", "logger.backends=[csv]")
    Trainer(cfg, directory).train()
    return directory


def test_each_checkpoint_is_played_as_rlhc_evaluate_plays_it_and_only_once(
    run: Path,
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> None:
    out = tmp_path / "matches.json"
    assert checkpoint_matches.main([str(run), "--out", str(out), "--matches", "4"]) == 0
    record = json.loads(out.read_text())
    assert (record["opponent"], record["matches"], record["seed"]) == ("scripted", 4, 0)
    entries = record["runs"][str(run)]
    assert sorted(entries, key=int) == ["256", "512"]
    # The same matches as the command line's evaluation of that checkpoint.
    checkpoint = run / CHECKPOINT_DIR / "step_000000512.pt"
    args = ["env=tennis", f"home={checkpoint}", "away=scripted", "matches=4", "hydra.run.dir=eval"]
    outcome = run_in_process(args, tmp_path, monkeypatch, capsys, evaluate.cli)
    assert outcome.code == 0, outcome.stderr
    cli = json.loads((tmp_path / "eval" / "results.json").read_text())
    assert entries["512"] == checkpoint_matches.kept(cli)
    assert "lost_missed_per_point" in entries["512"]

    # Started again: nothing new to play, nothing played.
    def no_match(*args: object) -> None:
        raise AssertionError("a checkpoint already in the record was played again")

    monkeypatch.setattr(checkpoint_matches, "match_summary", no_match)
    assert checkpoint_matches.main([str(run), "--out", str(out), "--matches", "4"]) == 0
    assert json.loads(out.read_text()) == record


def test_a_record_of_other_matches_is_not_extended(
    run: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "matches.json"
    out.write_text(json.dumps({"opponent": "scripted", "matches": 100, "seed": 0, "runs": {}}))
    with pytest.raises(SystemExit) as stop:
        checkpoint_matches.main([str(run), "--out", str(out), "--matches", "4"])
    assert stop.value.code == 2
    error = capsys.readouterr().err
    assert "{'matches': 100}" in error and "{'matches': 4}" in error


def test_a_directory_without_checkpoints_is_named(tmp_path: Path) -> None:
    with pytest.raises(FileNotFoundError, match=str(tmp_path)):
        checkpoint_matches.main([str(tmp_path), "--out", str(tmp_path / "m.json")])
