"""Cross-play (rlhc/evaluation/cross_play.py): each group of one run against the others of
another, on the tiny PettingZoo env whose rewards make every group's return its own."""

from __future__ import annotations

from pathlib import Path

import pytest
import torch
from configs import TINY_RUN, load, train_tiny

from rlhc.config.validation import validate
from rlhc.evaluation.cross_play import cross_play, lineups
from rlhc.training.trainer import Trainer


@pytest.fixture(scope="module")
def runs(tmp_path_factory: pytest.TempPathFactory) -> tuple[str, str]:
    """Two runs of different critics and seeds (so different actors), normalised
    observations in one of them."""
    root = tmp_path_factory.mktemp("runs")
    first = train_tiny(root / "ppo", "critic=ppo", "seed=0", "algo.normalize_observations=true")
    second = train_tiny(root / "hierarchical", "critic=hierarchical", "seed=1")
    return str(first), str(second)


def test_every_lineup_plays_the_same_number_of_episodes(runs: tuple[str, str]) -> None:
    result = cross_play(runs, episodes=5, num_envs=2)
    assert result.groups == ("blue", "red")
    assert list(result.returns) == lineups(result.groups, 2) == [(0, 0), (0, 1), (1, 0), (1, 1)]
    for returns in result.returns.values():
        # 5 episodes over 2 worlds: 3 each; the tiny env's episodes last 8 steps.
        assert {group: len(values) for group, values in returns.items()} == {"blue": 6, "red": 6}
    assert [set(row) for row in result.rows()] == [
        {"blue_run", "red_run", "blue_return", "red_return"}
    ] * 4


def test_a_groups_return_is_its_own_runs_where_its_rewards_are_its_own(
    runs: tuple[str, str],
) -> None:
    """In the tiny env an agent's reward and observations depend on its own actions alone:
    a group plays the same episodes whoever plays the other group."""
    result = cross_play(runs, episodes=4, num_envs=2)
    for first in (0, 1):
        assert torch.equal(result.returns[(first, 0)]["blue"], result.returns[(first, 1)]["blue"])
        assert torch.equal(result.returns[(0, first)]["red"], result.returns[(1, first)]["red"])
    for group, (ours, theirs) in {"blue": ((0, 0), (1, 0)), "red": ((0, 0), (0, 1))}.items():
        expected = result.mean(ours, group) - result.mean(theirs, group)
        assert result.group_advantage(group, 0, 1) == pytest.approx(expected)
        assert result.group_advantage(group, 1, 0) == pytest.approx(-expected)
    with pytest.raises(ValueError, match=r"group 'green'; allowed: one of \['blue', 'red'\]"):
        result.group_advantage("green", 0, 1)
    # The two runs' teams differ (else the checks above could not fail).
    assert result.mean((0, 0), "blue") != result.mean((1, 1), "blue")


def test_a_run_against_itself_is_every_lineup_and_sampling_follows_the_seed(
    runs: tuple[str, str],
) -> None:
    same = cross_play([runs[0], runs[0]], episodes=2, num_envs=2)
    first = same.returns[(0, 0)]
    assert all(
        torch.equal(returns[g], first[g]) for returns in same.returns.values() for g in first
    )
    assert same.group_advantage("red", 0, 1) == 0.0
    torch.manual_seed(0)
    sampled = cross_play(runs, episodes=2, num_envs=2, deterministic=False)
    torch.manual_seed(0)
    again = cross_play(runs, episodes=2, num_envs=2, deterministic=False)
    assert sampled.rows() == again.rows()


def test_runs_on_different_envs_or_a_game_are_refused(
    runs: tuple[str, str], tmp_path: Path
) -> None:
    longer = train_tiny(tmp_path / "longer", "env.kwargs={episode: 5}")
    with pytest.raises(
        ValueError, match=r"different environments .*options that differ: \['kwargs'\]"
    ):
        cross_play([runs[0], str(longer)], episodes=1)
    with pytest.raises(ValueError, match="a run or more, got none"):
        cross_play([])
    with pytest.raises(ValueError, match="episodes must be >= 1, got 0"):
        cross_play(runs, episodes=0)


def test_a_game_plays_matches_not_cross_play(runs: tuple[str, str], tmp_path: Path) -> None:
    cfg = load(*TINY_RUN[2:], "env=tennis", "critic=ppo")
    validate(cfg)
    Trainer(cfg, tmp_path / "tennis").train()
    with pytest.raises(ValueError, match="trained on the game 'tennis': cross-play is for"):
        cross_play([str(tmp_path / "tennis"), runs[0]])
