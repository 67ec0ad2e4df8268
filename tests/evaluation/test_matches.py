"""Matches: fair coins stay fair, scripted beats random, sides swap exactly, routing."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import torch
from tensordict import TensorDict

from rlhc.envs import make_env
from rlhc.evaluation.matches import (
    MatchRules,
    default_rules,
    evaluate_against,
    play_matches,
    route_actions,
)
from rlhc.evaluation.opponents import make_team_policy
from rlhc.evaluation.stats import wilson_interval
from rlhc.storage.checkpoint import save_checkpoint


def series(
    env_name: str, home: str, away: str, matches: int, rules: MatchRules | None = None, **kw
):
    torch.manual_seed(0)
    env = make_env(env_name, num_envs=min(matches, 32), seed=0, **kw.pop("env_options", {}))
    rules = rules or default_rules(env_name, env.game.max_cycles)
    return play_matches(
        env, make_team_policy(home, env), make_team_policy(away, env), matches, rules, **kw
    )


def test_random_teams_are_even() -> None:
    # Tennis: random rackets rarely return the serve, so every match is decided.
    result = series("tennis", "random", "random", 64)
    wins, losses = int((result.outcomes > 0).sum()), int((result.outcomes < 0).sum())
    low, high = wilson_interval(wins, wins + losses)
    assert wins + losses >= 60
    assert low <= 0.5 <= high


def test_scripted_beats_random_at_soccer_on_both_sides() -> None:
    result = series("soccer", "scripted", "random", 32)
    summary = result.summary()
    assert summary["losses"] == 0
    assert summary["win_rate_ci"][0] > 0.6
    for side in (0, 1):
        assert (result.outcomes[result.home_side == side] > 0).mean() > 0.6
    assert set(result.home_side.tolist()) == {0, 1}
    assert (result.home_side == 0).sum() == 16


def test_swapping_home_and_away_swaps_results_exactly() -> None:
    # Match i puts home on team i % 2. Exchanging the players and starting home on
    # team 1 gives every match the same team line-up, so the same game, seeded alike:
    # the results must be mirror images, match by match.
    rules = MatchRules(points_to_win=1, max_steps=200)
    options = {"env_options": {"max_cycles": 200}}
    first = series("soccer", "scripted", "random", 12, rules, **options)
    second = series("soccer", "random", "scripted", 12, rules, first_side=1, **options)
    np.testing.assert_array_equal(first.home_side, 1 - second.home_side)
    np.testing.assert_array_equal(first.home_points, second.away_points)
    np.testing.assert_array_equal(first.away_points, second.home_points)
    np.testing.assert_array_equal(first.steps, second.steps)
    assert (first.outcomes != 0).any()


def test_same_policy_on_both_sides_is_label_free() -> None:
    # With one deterministic policy on both teams, which team is called "home" cannot
    # change the games: swapped and unswapped series play identical matches, and only
    # the point of view of the odd matches flips.
    rules = MatchRules(points_to_win=1, max_steps=400)
    swapped = series("tennis", "scripted", "scripted", 8, rules)
    fixed = series("tennis", "scripted", "scripted", 8, rules, swap_sides=False)
    odd = swapped.home_side == 1
    np.testing.assert_array_equal(swapped.steps, fixed.steps)
    np.testing.assert_array_equal(swapped.home_points[~odd], fixed.home_points[~odd])
    np.testing.assert_array_equal(swapped.home_points[odd], fixed.away_points[odd])
    np.testing.assert_array_equal(swapped.away_points[odd], fixed.home_points[odd])
    assert (swapped.outcomes != 0).any()


def test_route_takes_each_agent_from_its_teams_policy() -> None:
    team = torch.tensor([0, 1, 0, 1]).view(1, 4, 1).expand(3, 4, 1)
    td = TensorDict({("g", "team"): team}, [3])
    home = {"g": torch.full((3, 4, 2), 1.0)}
    away = {"g": torch.full((3, 4, 2), 2.0)}
    route_actions(td, home, away, torch.tensor([0, 1, 0]))
    expected = torch.tensor([[1.0, 2.0, 1.0, 2.0], [2.0, 1.0, 2.0, 1.0], [1.0, 2.0, 1.0, 2.0]])
    torch.testing.assert_close(td["g", "action"][..., 0], expected)
    discrete = {"g": torch.ones(3, 4, dtype=torch.int64)}
    route_actions(
        td, discrete, {"g": torch.zeros(3, 4, dtype=torch.int64)}, torch.tensor([1, 1, 0])
    )
    assert td["g", "action"][0].tolist() == [0, 1, 0, 1]


def test_tennis_match_is_first_to_points() -> None:
    result = series("tennis", "scripted", "random", 8, MatchRules(points_to_win=3, max_steps=5000))
    assert result.home_points.tolist() == [3] * 8
    assert (result.away_points < 3).all()


def test_checkpoint_plays_and_evaluate_against(checkpoints: dict[str, Path]) -> None:
    env = make_env("tennis", num_envs=4, seed=0)
    policy = make_team_policy(str(checkpoints["tennis"]), env)
    assert policy.loc is not None  # tennis normalises observations: the stats are applied
    summary = evaluate_against(policy, "random", env, matches=4, max_steps=300)
    assert summary["matches"] == 4 and summary["home"] == "policy"
    assert (summary["away"], summary["wins"] + summary["draws"] + summary["losses"]) == (
        "random",
        4,
    )


def test_checkpoint_of_another_game_or_missing_path_is_named(
    checkpoints: dict[str, Path], tmp_path: Path
) -> None:
    env = make_env("soccer", num_envs=2, seed=0)
    with pytest.raises(ValueError, match=r"trained on 'tennis'.*plays 'soccer'"):
        make_team_policy(str(checkpoints["tennis"]), env)
    missing = tmp_path / "no_such_run"
    with pytest.raises(FileNotFoundError, match="no_such_run"):
        make_team_policy(str(missing), env)
    empty = tmp_path / "empty_run"
    empty.mkdir()
    with pytest.raises(FileNotFoundError, match="empty_run"):
        make_team_policy(str(empty), env)
    not_ours = tmp_path / "other.pt"
    torch.save({"weights": 1}, not_ours)
    with pytest.raises(ValueError, match=r"other\.pt"):
        make_team_policy(str(not_ours), env)


def test_checkpoints_with_different_observations_cannot_meet(tmp_path: Path) -> None:
    for name, extended in (("plain", False), ("extended", True)):
        env_cfg = {"name": "tennis", "num_envs": 4, "max_cycles": None, "extended_obs": extended}
        save_checkpoint(
            tmp_path / name / "checkpoints" / "step.pt",
            {"env": "tennis", "config": {"env": env_cfg}},
        )
    from rlhc.evaluation.opponents import player_options

    with pytest.raises(ValueError, match="extended_obs"):
        player_options([str(tmp_path / "plain"), str(tmp_path / "extended")], "tennis")


@pytest.mark.parametrize("view", ["worker", "manager", "clipped"])
def test_restored_policy_sees_what_the_trained_actor_saw(
    view: str, checkpoints: dict[str, Path], request: pytest.FixtureRequest
) -> None:
    from torchrl.envs.utils import ExplorationType, set_exploration_type

    from rlhc.building.builders import make_training_env
    from rlhc.building.normalisation import SafeVecNorm
    from rlhc.evaluation.policies import checkpoint_config, restore_policy
    from rlhc.storage.checkpoint import load_checkpoint

    fixtures = {"manager": "manager_view_checkpoint", "clipped": "clipped_checkpoint"}
    run = checkpoints["tennis"] if view == "worker" else request.getfixturevalue(fixtures[view])
    key = "manager_observation" if view == "manager" else "observation"
    state = load_checkpoint(run)
    training_env = make_training_env(checkpoint_config(state), num_envs=3, seed=1)
    training_env.transform.load_state_dict(state["env_transform"])
    next(t for t in training_env.transform if isinstance(t, SafeVecNorm)).freeze()
    normalised = training_env.reset()
    game = training_env.base_env.game.observe()["racket"]  # the same state, raw
    raw = game.manager_observation if view == "manager" else game.observation
    policy = restore_policy(state, make_env("tennis", num_envs=3, seed=1))
    assert policy.actors["racket"].in_keys == [("racket", key)]
    assert policy.loc is not None and policy.scale is not None
    expected = (torch.from_numpy(raw) - policy.loc["racket"]) / policy.scale["racket"]
    if view == "clipped":
        assert policy.clip == 0.5 and expected.abs().max() > 0.5  # the clip binds
        expected = expected.clamp(-0.5, 0.5)
    torch.testing.assert_close(normalised["racket", key], expected)
    raw_td = TensorDict({("racket", key): torch.from_numpy(raw)}, [3])
    with set_exploration_type(ExplorationType.DETERMINISTIC), torch.no_grad():
        trained = policy.actors["racket"](normalised.clone())["racket", "action"]
        torch.testing.assert_close(policy(raw_td)["racket"], trained)


def test_tennis_summaries_count_hits_over_the_net_per_point_by_side() -> None:
    from rlhc.evaluation.matches import evaluate_against
    from rlhc.evaluation.opponents import make_team_policy

    torch.manual_seed(0)  # the random team samples from torch's generator: order-free
    env = make_env("tennis", num_envs=4, seed=0)
    rally = evaluate_against(make_team_policy("scripted", env), "scripted", env, 4)
    hits = rally["hits_over_net_by_team_per_point"]
    # Two scripted teams keep the ball going: several shots each per point.
    assert hits["home"] >= 3.0 and hits["away"] >= 3.0
    one_sided = evaluate_against(make_team_policy("scripted", env), "random", env, 4)
    assert one_sided["hits_over_net_by_team_per_point"]["away"] < 0.2
    low, high = one_sided["points_won_rate_ci"]
    assert one_sided["points_won_rate"] > 0.8
    assert low <= one_sided["points_won_rate"] <= high and low < 1.0


def test_tennis_summaries_charge_each_lost_point_to_its_ending() -> None:
    from rlhc.envs.tennis.rules import POINT_ENDINGS
    from rlhc.evaluation.matches import evaluate_against
    from rlhc.evaluation.opponents import make_team_policy

    torch.manual_seed(0)
    env = make_env("tennis", num_envs=4, seed=0)
    summary = evaluate_against(make_team_policy("scripted", env), "random", env, 4)
    lost = {
        side: {how: summary[f"lost_{how}_per_point"][side] for how in POINT_ENDINGS}
        for side in ("home", "away")
    }
    # Every decided point is lost by one side in exactly one way (truncated rallies
    # score nothing and are charged to no one).
    won = summary["points_won_rate"]
    assert sum(lost["away"].values()) == pytest.approx(won)
    assert sum(lost["home"].values()) == pytest.approx(1.0 - won)
    # The random team serves into nothing and lets the scripted team's shots drop.
    assert lost["away"]["serve_missed"] + lost["away"]["missed"] > 0.5
    assert lost["home"]["serve_missed"] < 0.05
