"""``benchmarks/log_prob_check.py``: stored against rescored log-probabilities of a run."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from configs import load_smoke

from benchmarks import log_prob_check
from rlhc.training.trainer import Trainer


def test_a_rescored_batch_scores_exactly_as_stored(tmp_path: Path) -> None:
    run = tmp_path / "run"
    overrides = ["env=tennis", "experiment=smoke", "algo.max_steps=256"]
    Trainer(load_smoke("env=tennis", "algo.max_steps=256", "logger.backends=[csv]"), run).train()
    (run / ".hydra").mkdir()
    (run / ".hydra" / "overrides.yaml").write_text("".join(f"- {o}\n" for o in overrides))
    out = tmp_path / "check.json"
    assert log_prob_check.main([str(run), "--rescored", "--out", str(out)]) == 0
    result = json.loads(out.read_text())
    assert result["frames"] == 256 and result["rescored"]
    racket = result["groups"]["racket"]
    assert racket["experiences"] > 0
    assert racket["max_abs_difference"] == 0.0 and racket["kl_approx"] == 0.0


def test_a_directory_without_a_run_is_refused(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    with pytest.raises(SystemExit) as stopped:
        log_prob_check.main([str(tmp_path)])
    assert stopped.value.code == 2
    assert "holds no .hydra/overrides.yaml: not a run directory" in capsys.readouterr().err
