"""Tennis play diagnostics: what they measure on an untrained team, and bad input."""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest
import torch
from tensordict import TensorDictBase

from rlhc.envs.tennis.rules import POINT_ENDINGS
from rlhc.evaluation.diagnostics.__main__ import main
from rlhc.evaluation.diagnostics.tennis import (
    ACTION_NAMES,
    PROBE_X,
    tennis_diagnostics,
    tracking_probe,
)
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


def constant_move(move: float):
    """A team whose every racket moves by ``move``, wherever the ball is."""

    def team(td: TensorDictBase) -> dict[str, torch.Tensor]:
        n = td.batch_size[0]
        return {"racket": torch.tensor([move, 0.0, 0.0]).expand(n, 4, 3)}

    return team


def chaser(td: TensorDictBase) -> dict[str, torch.Tensor]:
    """A team that runs at full speed towards the ball (raw worker observations)."""
    observation = td["racket", "observation"]
    move = torch.sign(observation[..., 0] - observation[..., 4])
    return {"racket": torch.stack([move, torch.zeros_like(move), torch.zeros_like(move)], -1)}


def test_the_tracking_probe_tells_a_chaser_from_a_routine() -> None:
    chasing = tracking_probe(chaser)
    assert chasing["toward"] == 1.0 and chasing["gain"] > 0.3
    # The ball's offset on the grid's diagonal is 0: no move either way.
    assert all(chasing["move"][k][k] == 0.0 for k in range(len(PROBE_X)))
    routine = tracking_probe(constant_move(0.4))
    assert routine["gain"] == pytest.approx(0.0, abs=1e-6)
    # Towards the ball only where the ball is ahead of the racket: half the far points.
    assert routine["toward"] == 0.5
    backwards = tracking_probe(lambda td: {k: -v for k, v in chaser(td).items()})
    assert backwards["toward"] == 0.0 and backwards["gain"] == pytest.approx(-chasing["gain"])


def test_the_tracking_probe_reads_a_trained_team(
    checkpoints: dict[str, Path], manager_view_checkpoint: Path
) -> None:
    from benchmarks.tennis_play import team_tracking

    for run in (checkpoints["tennis"], manager_view_checkpoint):
        probe = team_tracking(load_team(str(run)))
        move = probe["move"]
        assert len(move) == len(move[0]) == len(PROBE_X)
        assert all(-1.0 <= m <= 1.0 for line in move for m in line)
        assert 0.0 <= probe["toward"] <= 1.0


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
