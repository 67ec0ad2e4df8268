"""Tennis play diagnostics: what they measure on an untrained team, and bad input."""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest

from rlhc.envs.tennis.rules import POINT_ENDINGS
from rlhc.evaluation.diagnostics.__main__ import main
from rlhc.evaluation.diagnostics.tennis import ACTION_NAMES, tennis_diagnostics
from rlhc.storage.final_team import load_team


def test_an_untrained_team_is_measured_in_both_modes(checkpoints: dict[str, Path]) -> None:
    state = load_team(str(checkpoints["tennis"]))
    result = tennis_diagnostics(state, worlds=4, decisions=200, seed=3)
    assert result["points"] > 0 and result["points_mode"] > 0
    assert result["hits_per_point"] >= 0 and result["hits_per_point_mode"] >= 0
    assert 0 < result["near_share"] < 1
    for key in ("sigma_near", "sigma_far", "saturated"):
        assert set(result[key]) == set(ACTION_NAMES)
    # An untrained TanhNormal: the scale of a zero network output (the smoke preset's)
    # everywhere, within the small outputs of fresh weights.
    for name in ACTION_NAMES:
        assert result["sigma_near"][name] == pytest.approx(result["sigma_far"][name], rel=0.2)
        assert 0 <= result["saturated"][name] <= 1
    assert 0 <= result["toward_ball"] <= 1 and 0 <= result["toward_ball_mode"] <= 1
    for key in ("ended", "ended_mode"):
        assert set(result[key]) == set(POINT_ENDINGS)
        # every point ended one way, but those cut by the end of the measurement
        assert 0.9 <= sum(result[key].values()) <= 1.0 + 1e-9
    # Seeded: the same numbers again.
    again = tennis_diagnostics(state, worlds=4, decisions=200, seed=3)
    assert json.dumps(again, sort_keys=True) == json.dumps(result, sort_keys=True)


def test_a_team_reading_the_manager_view_is_measured(manager_view_checkpoint: Path) -> None:
    state = load_team(str(manager_view_checkpoint))
    result = tennis_diagnostics(state, worlds=4, decisions=200, seed=3)
    assert result["points"] > 0 and math.isfinite(result["hits_per_point"])
    for name in ACTION_NAMES:  # a fresh net: the same scale near the ball and elsewhere
        assert result["sigma_near"][name] == pytest.approx(result["sigma_far"][name], rel=0.2)


def test_a_soccer_team_is_refused(checkpoints: dict[str, Path]) -> None:
    with pytest.raises(ValueError, match="needs a tennis team, got one of 'soccer'"):
        tennis_diagnostics(load_team(str(checkpoints["soccer"])), worlds=1, decisions=2)


def test_the_command_line(checkpoints: dict[str, Path], capsys: pytest.CaptureFixture) -> None:
    assert main([str(checkpoints["tennis"]), "--worlds", "2", "--decisions", "20"]) == 0
    printed = json.loads(capsys.readouterr().out)
    assert printed["worlds"] == 2 and not math.isnan(printed["hits_per_point_mode"])
    with pytest.raises(SystemExit) as stopped:
        main([str(checkpoints["tennis"] / "missing")])
    assert stopped.value.code == 2
    assert "rlhc.evaluation.diagnostics: error: " in capsys.readouterr().err
