"""``benchmarks/learning.py``: a tiny train-then-match run end to end, its JSON and figure."""

from __future__ import annotations

import json
import math
from pathlib import Path
from types import ModuleType

import numpy as np
import pytest

from benchmarks.reporting import figures
from benchmarks.reporting.learning import bounds_of, panels_of
from rlhc.analysis.curves import Curve, Run

#: ``experiment=smoke`` (tiny networks and buffers) with a budget of five summaries.
TINY = [
    *("--env", "tennis", "--preset", "paper", "--critic", "ppo", "--seeds", "0"),
    *("--max-steps", "1280", "--matches", "4", "--jobs", "1"),
    *("--extra-overrides", "experiment=smoke"),
]
RATES = ("win_rate", "draw_rate", "loss_rate")


@pytest.fixture
def learning() -> ModuleType:
    """``python -m benchmarks.learning`` as a module."""
    from benchmarks import learning

    return learning


def test_tiny_run_trains_evaluates_and_reports(
    learning: ModuleType, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert learning.main([*TINY, "--results", str(tmp_path)]) == 0
    document = json.loads((tmp_path / "tennis_paper_1280.json").read_text())
    assert (tmp_path / "tennis_paper_1280.png").stat().st_size > 0
    assert document["max_steps_override"] == 1280
    (run,) = document["runs"]
    assert (run["critic"], run["seed"], run["frames"], run["finished"]) == ("ppo", 0, 1280, True)
    assert "algo.max_steps=1280" in run["command"] and "experiment=smoke" in run["command"]
    assert run["wall_time_s"] > 0 and run["train_frames_per_s_mean"] > 0
    assert {
        "episode_length",
        "racket/cumulative_reward",
        "events/hits_over_net_per_episode",
    } <= set(run["final_metrics"])
    for opponent in ("random", "scripted"):
        summary = run[f"vs_{opponent}"]
        assert summary["away"] == opponent and summary["matches"] == 4
        assert all(0.0 <= summary[key] <= 1.0 for key in RATES)
        assert math.isclose(sum(summary[key] for key in RATES), 1.0)
        low, high = summary["win_rate_ci"]
        assert 0.0 <= low <= summary["win_rate"] <= high <= 1.0
        points = summary["points_won_rate"]
        assert math.isnan(points) or 0.0 <= points <= 1.0
        assert set(summary["hits_over_net_by_team_per_point"]) == {"home", "away"}
        means = document["means_over_seeds"]["ppo"][f"vs_{opponent}"]
        assert means["win_rate"] == summary["win_rate"]
        assert "hits_over_net_per_point_home" in means

    # A finished run is not trained again; seeded matches replay exactly.
    capsys.readouterr()
    assert learning.main([*TINY, "--results", str(tmp_path)]) == 0
    assert "0 of 1 runs to train" in capsys.readouterr().out
    again = json.loads((tmp_path / "tennis_paper_1280.json").read_text())["runs"]
    assert len(again) == 1
    assert again[0]["vs_random"] == run["vs_random"]
    assert again[0]["vs_scripted"] == run["vs_scripted"]


@pytest.mark.parametrize(
    ("arguments", "message"),
    [
        (["--matches", "3"], "--matches must be even"),
        (["--preset", "nonesuch"], "'nonesuch' is not a preset of tennis"),
        (["--extra-overrides", "seed=3"], "['seed=3'] set keys this script sets itself"),
        (["--max-steps", "0"], "--max-steps must be >= 1"),
    ],
)
def test_bad_arguments_are_named(
    learning: ModuleType, arguments: list[str], message: str, capsys: pytest.CaptureFixture[str]
) -> None:
    with pytest.raises(SystemExit):
        learning.parse_args(arguments)
    assert message in capsys.readouterr().err


def test_a_run_trained_with_other_overrides_is_refused(
    learning: ModuleType, tmp_path: Path
) -> None:
    args = learning.parse_args([*TINY, "--results", str(tmp_path)])
    (run,) = learning.plan(args)
    (run.run_dir / ".hydra").mkdir(parents=True)
    (run.run_dir / "checkpoints").mkdir()
    (run.run_dir / ".hydra" / "overrides.yaml").write_text("- env=tennis\n- critic=ppo\n")
    with pytest.raises(ValueError, match="was trained with overrides"):
        learning.check_overrides(run)


def test_the_learning_figure_clips_each_band_to_the_values_its_metric_can_take(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    # Two seeds of soccer: one never scores, one always does, with rewards of either
    # sign. The goal rate's t band reaches outside [0, 1]; a reward's has no bounds.
    steps = np.arange(1.0, 6.0)
    runs = {
        "ppo": [
            Run(
                tmp_path / f"seed_{k}",
                {
                    "step": steps,
                    "episode_terminated": np.full(5, float(k)),
                    "episode_length": np.full(5, 10.0 + 400.0 * k),
                    "striker/cumulative_reward": np.full(5, 2.0 * k - 1.0),
                },
            )
            for k in (0, 1)
        ]
    }
    drawn: dict[str, Curve | None] = {}
    aggregate = figures.aggregate

    def recorded(
        members: list[Run], metric: str, smoothing: float, bounds: tuple[float, float]
    ) -> Curve | None:
        drawn[metric] = aggregate(members, metric, smoothing, bounds=bounds)
        return drawn[metric]

    monkeypatch.setattr(figures, "aggregate", recorded)
    out = figures.draw_learning_curves(
        runs, panels_of("soccer", runs), "soccer", tmp_path / "curves.png", 0.0, bounds_of("soccer")
    )
    assert out.stat().st_size > 0
    goals, length, reward = (
        drawn[k] for k in ("episode_terminated", "episode_length", "striker/cumulative_reward")
    )
    assert goals is not None and length is not None and reward is not None
    np.testing.assert_array_equal(goals.low, np.zeros(5))
    np.testing.assert_array_equal(goals.high, np.ones(5))
    np.testing.assert_array_equal(goals.mean, np.full(5, 0.5))
    np.testing.assert_array_equal(length.low, np.zeros(5))
    assert np.all(length.high > 410.0)
    assert np.all(reward.low < -1.0) and np.all(reward.high > 1.0)


def test_play_panels_are_drawn_where_a_run_measured_play(tmp_path: Path) -> None:
    steps = np.arange(1, 5) * 100.0
    plain = Run(tmp_path / "a", {"step": steps, "episode_length": np.ones(4)})
    played = Run(
        tmp_path / "b",
        {"step": steps, "play/toward_ball": np.array([np.nan, 0.4, np.nan, 0.5])},
    )
    assert not any(name.startswith("play/") for name in panels_of("tennis", {"ppo": [plain]}))
    panels = panels_of("tennis", {"ppo": [plain], "twin": [played]})
    assert [name for name in panels if name.startswith("play/")] == ["play/toward_ball"]
    assert bounds_of("tennis")["play/toward_ball"] == (0.0, 1.0)
    out = figures.draw_learning_curves(
        {"ppo": [plain], "twin": [played]}, panels, "tennis", tmp_path / "c.png", 0.8,
        bounds_of("tennis"),
    )  # fmt: skip
    assert out.stat().st_size > 0
