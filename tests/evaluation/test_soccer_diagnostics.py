"""Soccer play diagnostics: hand-made shots whose counts are known, the half-turn
symmetry of the measurement, touches against pymunk's own contacts, the scripted team
against itself, an untrained team, and bad input."""

from __future__ import annotations

import json
import math
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pymunk
import pytest
import torch

from rlhc.envs import make_env
from rlhc.envs.soccer.controls import KICK_REACH
from rlhc.envs.soccer.game import SoccerGame
from rlhc.envs.soccer.scripted import scripted_actions
from rlhc.evaluation.diagnostics import DIAGNOSTICS, diagnose
from rlhc.evaluation.diagnostics.__main__ import main
from rlhc.evaluation.diagnostics.soccer import (
    ACTION_NAMES,
    record_play,
    soccer_diagnostics,
    summarise_play,
)
from rlhc.evaluation.diagnostics.soccer_events import (
    SHOT_OUTCOMES,
    PlayRecord,
    count_events,
    in_touch,
)
from rlhc.evaluation.teams import ScriptedPolicy
from rlhc.storage.final_team import load_team

FORWARD, BACKWARD, ROTATE_LEFT = 0, 1, 2
Plan = Callable[[int], tuple[np.ndarray, np.ndarray]]


def play_scene(
    positions: list[list[list[float]]], angles: list[list[float]], plan: Plan, decisions: int
) -> tuple[SoccerGame, PlayRecord]:
    """Place the bodies, then play ``plan(t) -> (striker, goalie actions)`` (no resets)."""
    game = SoccerGame(num_worlds=len(positions), seed=0)
    game.place(np.asarray(positions), np.asarray(angles))
    before, after, scoring, ended, strikers, goalies = [], [], [], [], [], []
    for t in range(decisions):
        striker, goalie = plan(t)
        before.append(game.state())
        outcome = game.step({"striker": striker, "goalie": goalie})
        after.append(game.state())
        scoring.append(outcome.scoring_team)
        ended.append(outcome.terminated | outcome.truncated)
        strikers.append(striker)
        goalies.append(goalie)
    record = PlayRecord(
        before=np.stack(before),
        after=np.stack(after),
        scoring_team=np.stack(scoring),
        ended=np.stack(ended),
        actions={"striker": np.stack(strikers), "goalie": np.stack(goalies)},
    )
    return game, record


def test_kicks_at_goal_are_shots_known_in_advance() -> None:
    # Three pitches: striker_0 a few cm out of touch behind the ball, facing the open
    # goal at +x (the opponent goalie stands aside); the same scene turned by 180° for
    # team 1; and striker_0 kicking at 40°, wide of the 6 m mouth from 5 m out. Each
    # striker runs forward twice (touch, then kick) and backs off.
    gap = 0.67 + 0.59 + KICK_REACH + 0.04
    wide = np.deg2rad(40.0)
    positions = [
        [[5 - gap, 0], [-5, 4], [-9, 0], [8.5, -4.3], [5, 0]],
        [[5, -4], [-5 + gap, 0], [-8.5, 4.3], [9, 0], [-5, 0]],
        [[5 - gap * np.cos(wide), -gap * np.sin(wide)], [-5, 4], [-9, 0], [8.5, -4.3], [5, 0]],
    ]
    angles = [[0, np.pi, 0, np.pi, 0], [0, np.pi, 0, np.pi, 0], [wide, np.pi, 0, np.pi, 0]]

    def plan(t: int) -> tuple[np.ndarray, np.ndarray]:
        run = FORWARD if t < 2 else BACKWARD
        striker = np.array([[run, ROTATE_LEFT], [ROTATE_LEFT, run], [run, ROTATE_LEFT]])
        return striker, np.full((3, 2), BACKWARD)

    game, record = play_scene(positions, angles, plan, decisions=6)
    assert record.scoring_team[-1].tolist() == [0, 1, -1]  # the two straight kicks score
    counts = count_events(record, game.options)
    assert counts["goals"].tolist() == [[1, 0], [0, 1], [0, 0]]
    assert counts["striker_touches"].tolist() == [[1, 0], [0, 1], [1, 0]]
    assert counts["shots"].tolist() == [[1, 0], [0, 1], [1, 0]]
    assert counts["shots_on_target"].tolist() == [[1, 0], [0, 1], [0, 0]]
    assert counts["on_target_goal"].tolist() == [[1, 0], [0, 1], [0, 0]]
    for outcome in SHOT_OUTCOMES[1:]:
        assert not counts[f"on_target_{outcome}"].any(), outcome
    assert counts["goalie_touches"].sum() == 0
    assert counts["ball_in_opponent_half"].tolist() == [[6, 0], [0, 6], [6, 0]]


def half_turn(record: PlayRecord) -> PlayRecord:
    """The record of the same play turned by 180° about the centre spot, teams swapped."""

    def turn(states: np.ndarray) -> np.ndarray:
        ball, players = -states[..., :4], -states[..., 4:].reshape(*states.shape[:-1], 4, 6)
        swapped = players[..., [1, 0, 3, 2], :]
        return np.concatenate([ball, swapped.reshape(*states.shape[:-1], 24)], axis=-1)

    scoring = np.where(record.scoring_team >= 0, 1 - record.scoring_team, -1)
    actions = {group: taken[..., ::-1].copy() for group, taken in record.actions.items()}
    return PlayRecord(turn(record.before), turn(record.after), scoring, record.ended, actions)


def scripted_record(worlds: int, decisions: int, seed: int) -> tuple[SoccerGame, PlayRecord]:
    env = make_env("soccer", num_envs=worlds, seed=seed)
    scripted = ScriptedPolicy(env)
    record = record_play(env, scripted, scripted, torch.zeros(worlds, dtype=torch.int64), decisions)
    assert isinstance(env.game, SoccerGame)
    return env.game, record


def test_the_measurement_is_symmetric_under_the_half_turn() -> None:
    game, record = scripted_record(worlds=4, decisions=200, seed=5)
    counts, turned = (
        count_events(record, game.options),
        count_events(half_turn(record), game.options),
    )
    for key, value in counts.items():
        expected = value[:, ::-1] if value.ndim == 2 else value
        np.testing.assert_allclose(turned[key], expected, rtol=1e-6, err_msg=key)
    assert counts["striker_touches"].sum() > 0


def test_touches_agree_with_pymunk_contacts() -> None:
    # pymunk's own ball-player contacts, recorded with a collision handler, against
    # the touches read from the states (the module's definition).
    worlds, decisions = 8, 250
    game = SoccerGame(num_worlds=worlds, seed=3)
    contact = np.zeros((worlds, 4), dtype=bool)
    for shape, (_, tag) in game.physics.shape_tags.items():
        if tag == "ball":
            shape.collision_type = 1

    def touched(arbiter: pymunk.Arbiter, space: pymunk.Space, data: object) -> None:
        for shape in arbiter.shapes:
            world, tag = game.physics.shape_tags[shape]
            if tag.startswith("player_"):
                contact[world, int(tag.removeprefix("player_"))] = True

    game.physics.space.on_collision(1, None, post_solve=touched)
    rng = np.random.default_rng(0)
    before, after, exact, ended = [], [], [], []
    for _ in range(decisions):
        state = game.state()
        actions = scripted_actions(state, game.options)
        noisy = rng.random((worlds, 2)) < 0.2  # varied play, not only the scripted lines
        actions["striker"] = np.where(noisy, rng.integers(0, 6, (worlds, 2)), actions["striker"])
        contact[:] = False
        outcome = game.step(actions)
        before.append(state)
        after.append(game.state())
        exact.append(contact.copy())
        ended.append(outcome.terminated | outcome.truncated)
        game.reset(ended[-1])
    seen_before, seen_after = (
        in_touch(np.stack(before), game.options),
        in_touch(np.stack(after), game.options),
    )
    touches = seen_after & ~seen_before
    contacts = np.stack(exact)
    started = contacts.copy()
    started[1:] &= ~(contacts[:-1] & ~np.stack(ended)[:-1, :, None])

    def matched(events: np.ndarray, reference: np.ndarray) -> float:
        hits = [reference[max(t - 1, 0) : t + 2, k, p].any() for t, k, p in np.argwhere(events)]
        return float(np.mean(hits))

    assert touches.sum() > 100
    assert matched(touches, contacts) >= 0.85  # a touch seen is a contact (±1 decision)
    assert matched(started, seen_before | seen_after) >= 0.85  # a contact is seen in touch
    assert abs(int(touches.sum()) - int(started.sum())) <= 0.15 * started.sum()


def test_the_scripted_team_shoots_alike_on_both_sides() -> None:
    env = make_env("soccer", num_envs=8, seed=0)
    scripted = ScriptedPolicy(env)
    record = record_play(env, scripted, scripted, torch.zeros(8, dtype=torch.int64), 300)
    sides = {"team_0": [np.zeros(8, dtype=np.int64)], "team_1": [np.ones(8, dtype=np.int64)]}
    result = summarise_play(record, env.game.options, sides)
    teams = result["team_0"], result["team_1"]
    for team in teams:
        assert team["shots"] > 0 and team["shots_on_target"] > 0
        assert team["shots_on_target"] <= team["shots"]
        assert team["striker_touches_per_episode"] > 0
    shots = [team["shots"] for team in teams]
    assert abs(shots[0] - shots[1]) <= 3 * math.sqrt(sum(shots))  # Poisson noise
    half = teams[0]["ball_in_opponent_half"] + teams[1]["ball_in_opponent_half"]
    assert half == pytest.approx(1.0, abs=0.01)  # the ball is in one half or the other


def check_team(metrics: dict, pitch_diagonal: float) -> None:
    for key in ("goals_per_1000", "shots_per_1000", "shots_on_target_per_1000"):
        assert metrics[key] >= 0
    assert metrics["shots_on_target"] <= metrics["shots"]
    assert 0 <= metrics["ball_in_opponent_half"] <= 1
    assert 0 < metrics["striker_ball_distance"] < pitch_diagonal
    assert 0 < metrics["goalie_goal_distance"] < pitch_diagonal
    assert metrics["striker_touches_per_episode"] >= 0
    outcomes = metrics["on_target_outcomes"]
    assert set(outcomes) == set(SHOT_OUTCOMES)
    if metrics["shots_on_target"]:
        assert sum(outcomes.values()) == pytest.approx(1.0)
    for group, names in ACTION_NAMES.items():
        shares = metrics[f"{group}_actions"]
        assert list(shares) == list(names) and sum(shares.values()) == pytest.approx(1.0)


def test_an_untrained_team_against_scripted_and_itself(checkpoints: dict[str, Path]) -> None:
    state = load_team(str(checkpoints["soccer"]))
    result = soccer_diagnostics(state, worlds=4, decisions=150, seed=2)
    assert (result["worlds"], result["decisions"], result["seed"]) == (4, 150, 2)
    assert set(result["vs_scripted"]) >= {"trained", "scripted", "episodes", "goal_share"}
    # 150 decisions < max_cycles (600): no episode is sure to end within the play.
    assert result["vs_scripted"]["complete_episodes"] == 0
    assert math.isnan(result["vs_scripted"]["goal_share"])
    assert set(result["self_play"]) >= {"trained", "episodes", "goal_share"}
    diagonal = math.hypot(20.0, 10.0)
    for play, teams in (("vs_scripted", ("trained", "scripted")), ("self_play", ("trained",))):
        assert result[play]["episodes"] >= 4
        for team in teams:
            check_team(result[play][team], diagonal)
    # Seeded: the same numbers again; and through the registry.
    again = DIAGNOSTICS["soccer"](state, worlds=4, decisions=150, seed=2)
    assert json.dumps(again, sort_keys=True) == json.dumps(result, sort_keys=True)
    only = diagnose(state, worlds=2, decisions=10, seed=2)
    assert set(only) >= {"vs_scripted", "self_play"}


def test_a_tennis_team_and_bad_records_are_refused(checkpoints: dict[str, Path]) -> None:
    with pytest.raises(ValueError, match="needs a soccer team, got one of 'tennis'"):
        soccer_diagnostics(load_team(str(checkpoints["tennis"])), worlds=1, decisions=2)
    tennis = make_env("tennis", num_envs=1, seed=0)
    with pytest.raises(ValueError, match="need a soccer env, got a 'tennis' one"):
        record_play(tennis, ScriptedPolicy(tennis), ScriptedPolicy(tennis), torch.zeros(1), 1)
    with pytest.raises(ValueError, match="bad shapes"):
        PlayRecord(
            before=np.zeros((3, 2, 28)),
            after=np.zeros((3, 2, 27)),
            scoring_team=np.zeros((3, 2), dtype=np.int64),
            ended=np.zeros((3, 2), dtype=bool),
            actions={},
        )


def test_the_command_line(checkpoints: dict[str, Path], capsys: pytest.CaptureFixture) -> None:
    assert main([str(checkpoints["soccer"]), "--worlds", "2", "--decisions", "20"]) == 0
    printed = json.loads(capsys.readouterr().out)
    assert printed["worlds"] == 2 and printed["vs_scripted"]["episodes"] >= 2
