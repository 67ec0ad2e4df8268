"""The game registry: every registered game is complete and consistent, unknown names
are refused with the list of the registered ones, and a game registers once."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
import yaml

from rlhc.envs import GAMES, game_spec, games, make_env, make_game
from rlhc.envs.base import validate_actions
from rlhc.envs.registry import register_game
from rlhc.envs.schemas import EnvConfig

CONF = Path(__file__).resolve().parents[2] / "conf" / "env"
UNKNOWN = r"unknown env 'curling'; choose one of \['soccer', 'tennis'\]"


def test_the_two_games_are_registered() -> None:
    assert games() == ("soccer", "tennis")
    assert sorted(GAMES) == list(games()) and len(GAMES) == 2
    assert GAMES["tennis"] is game_spec("tennis") and "curling" not in GAMES


@pytest.mark.parametrize("name", games())
def test_a_spec_matches_its_game_schema_and_config_file(name: str) -> None:
    spec = game_spec(name)
    game = make_game(name, num_envs=2, seed=0)
    assert type(game) is spec.game and game.name == name
    assert tuple(group.name for group in game.groups) == spec.groups
    assert issubclass(spec.env_config, EnvConfig) and spec.env_config().name == name
    config = yaml.safe_load((CONF / f"{name}.yaml").read_text())
    assert config["name"] == name and config["defaults"] == [f"{name}_schema"]
    assert spec.points_to_win >= 1


@pytest.mark.parametrize("name", games())
def test_the_scripted_team_plays_every_agent_of_every_world(name: str) -> None:
    game = make_game(name, num_envs=3, seed=0)
    for _ in range(5):
        actions = game_spec(name).scripted(game)
        assert sorted(actions) == sorted(game_spec(name).groups)
        validate_actions(game.groups, actions, game.num_worlds)  # raises if malformed
        game.step(actions)


def test_a_scripted_team_refuses_another_game() -> None:
    with pytest.raises(TypeError, match="TennisGame, got SoccerGame"):
        game_spec("tennis").scripted(make_game("soccer"))


def test_unknown_names_are_refused_with_the_registered_games() -> None:
    with pytest.raises(ValueError, match=UNKNOWN):
        game_spec("curling")
    with pytest.raises(ValueError, match=UNKNOWN):
        make_env("curling")


def test_a_game_registers_once() -> None:
    spec = game_spec("soccer")
    assert register_game(spec) is spec  # the same spec again: nothing changes
    with pytest.raises(ValueError, match="'soccer' is already registered"):
        register_game(replace(spec, points_to_win=3))
    assert game_spec("soccer").points_to_win == 1


@pytest.mark.parametrize(
    ("change", "match"),
    [
        ({"name": "squash"}, "named 'soccer'"),
        ({"env_config": EnvConfig}, "name=.*MISSING|name='\\?\\?\\?'"),
        ({"groups": ()}, "no groups"),
        ({"points_to_win": 0}, "points_to_win=0; allowed: >= 1"),
    ],
)
def test_an_inconsistent_spec_is_refused(change: dict[str, object], match: str) -> None:
    with pytest.raises(ValueError, match=match):
        replace(game_spec("soccer"), **change)  # type: ignore[arg-type]


def test_match_rules_come_from_the_registry() -> None:
    from rlhc.evaluation.matches import MatchRules, default_rules

    assert default_rules("tennis", 400) == MatchRules(points_to_win=5, max_steps=2000)
    assert default_rules("soccer", 600) == MatchRules(points_to_win=1, max_steps=600)
    with pytest.raises(ValueError, match=UNKNOWN):
        default_rules("curling", 10)


def test_actions_of_the_scripted_policy_equal_the_registry_team() -> None:
    from rlhc.evaluation.teams import ScriptedPolicy

    for name in games():
        env = make_env(name, num_envs=2, seed=0)
        actions = ScriptedPolicy(env)(env.reset())
        expected = game_spec(name).scripted(env.game)  # type: ignore[arg-type]
        for group in game_spec(name).groups:
            np.testing.assert_array_equal(actions[group].numpy(), expected[group])
