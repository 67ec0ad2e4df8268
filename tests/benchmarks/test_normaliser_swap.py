"""``benchmarks/normaliser_swap.py``: a run's weights played under another checkpoint's statistics."""

from __future__ import annotations

import json
from pathlib import Path

from configs import load_smoke

from benchmarks import normaliser_swap
from rlhc.storage.checkpoint import CHECKPOINT_DIR
from rlhc.training.trainer import Trainer


def test_swapping_identical_statistics_changes_nothing_and_drift_is_measured(
    tmp_path: Path,
) -> None:
    run = tmp_path / "run"
    cfg = load_smoke("env=tennis", "algo.max_steps=512", "logger.backends=[csv]")
    Trainer(cfg, run).train()
    before, after = sorted(p.name for p in (run / CHECKPOINT_DIR).glob("step_*.pt"))
    out = tmp_path / "swap.json"
    arguments = ["--worlds", "2", "--decisions", "60", "--out", str(out)]
    assert normaliser_swap.main([str(run), before, after, *arguments]) == 0
    result = json.loads(out.read_text())
    assert result["checkpoints"] == {"before": 256, "after": 512}
    plays = result["teams"]
    assert set(plays) == {
        f"{w}_weights_{s}_normaliser" for w in ("before", "after") for s in ("before", "after")
    }
    # The statistics moved between the two checkpoints (the second update's observations).
    shifts = [abs(x) for row in result["drift"]["mean_shift_in_scales"] for x in row]
    assert max(shifts) > 0
    # A checkpoint against itself: each pair of plays is the same measurement.
    assert normaliser_swap.main([str(run), before, before, *arguments]) == 0
    same = json.loads(out.read_text())
    assert (
        same["teams"]["before_weights_before_normaliser"]
        == (same["teams"]["after_weights_after_normaliser"])
    )
    assert max(abs(x) for row in same["drift"]["mean_shift_in_scales"] for x in row) == 0
