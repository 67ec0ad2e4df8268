"""Soccer under stress: a seeded fuzz of the batched game, and the scripted players."""

from __future__ import annotations

import numpy as np
import pytest

from rlhc.envs.soccer import SoccerGame
from rlhc.envs.soccer.physics import BALL
from rlhc.envs.soccer.scripted import goalie_actions, striker_actions

STRIKER_REWARDS = np.float32([0.0, 1.0, -0.1]) + np.float32(-0.001)
GOALIE_REWARDS = np.float32([0.0, 0.1, -1.0]) + np.float32(0.001)


def fuzz_actions(rng: np.random.Generator, block: int, num_worlds: int) -> dict[str, np.ndarray]:
    """Random actions, or every player repeating one action (runs into walls at top speed)."""
    if block % 3 == 0:
        return {
            "striker": rng.integers(0, 6, (num_worlds, 2)),
            "goalie": rng.integers(0, 4, (num_worlds, 2)),
        }
    return {
        "striker": np.full((num_worlds, 2), block % 6, dtype=np.int64),
        "goalie": np.full((num_worlds, 2), block % 4, dtype=np.int64),
    }


def run_fuzz(num_worlds: int, steps: int, seed: int) -> dict[str, float]:
    """Step with resets; assert the invariants at every step; return what was seen."""
    game = SoccerGame(num_worlds=num_worlds, seed=seed, max_cycles=300)
    geometry = game.geometry
    player_radius, ball_radius = game.options.player_radius, game.options.ball_radius
    rng = np.random.default_rng(seed)
    goals = 0
    deepest = 0.0  # how far a body's edge ever went into a wall
    for step in range(steps):
        if step % 50 == 0:
            actions = fuzz_actions(rng, step // 50, num_worlds)
            if step // 50 % 3 == 0:
                block_actions = actions
        if step // 50 % 3 == 0 and step % 50:
            actions = {name: rng.permuted(block_actions[name], axis=0) for name in block_actions}
        outcome = game.step(actions)
        for group, allowed in (("striker", STRIKER_REWARDS), ("goalie", GOALIE_REWARDS)):
            reward = outcome.rewards[group]
            assert np.all(np.isin(reward, allowed)), (
                f"unexpected {group} reward {np.unique(reward)}"
            )
        assert np.all((outcome.scoring_team >= 0) == outcome.terminated)
        for seen in game.observe().values():
            assert np.all(np.isfinite(seen.observation)) and np.all(
                np.isfinite(seen.manager_observation)
            )
            assert seen.observation.min() >= 0 and seen.observation.max() <= 1
        positions = game.physics.positions
        assert np.all(np.isfinite(positions)) and np.all(np.isfinite(game.physics.velocities))
        # Centres never cross a wall's face: nobody tunnels; players never enter a net.
        assert np.all(np.abs(positions[:, :4, 0]) < geometry.half_length)
        assert np.all(np.abs(positions[:, :4, 1]) < geometry.half_width)
        assert np.all(geometry.contains(positions[:, BALL]))
        x, y = np.abs(positions[..., 0]), np.abs(positions[..., 1])
        radius = np.array([player_radius] * 4 + [ball_radius])
        in_net = (x > geometry.half_length) & (y < geometry.goal_half_width)
        edge_x = np.where(
            in_net, x - geometry.half_length - geometry.goal_depth, x - geometry.half_length
        )
        deepest = max(
            deepest, float(np.max(edge_x + radius)), float(np.max(y - geometry.half_width + radius))
        )
        goals += int(outcome.terminated.sum())
        done = outcome.terminated | outcome.truncated
        if done.any():
            game.reset(done)
    return {"goals": goals, "deepest": deepest}


def test_fuzz_short() -> None:
    seen = run_fuzz(num_worlds=32, steps=300, seed=0)
    assert seen["deepest"] < 0.3


@pytest.mark.slow
def test_fuzz_100k_steps() -> None:
    """64 pitches x 1,600 steps = 102,400 pitch-steps."""
    seen = run_fuzz(num_worlds=64, steps=1600, seed=1)
    assert seen["goals"] > 0  # random play does score sometimes: the rewards were exercised
    assert seen["deepest"] < 0.3


def play(num_worlds: int, steps: int, team_1_goalie: str, seed: int = 0) -> np.ndarray:
    """Scripted team 0 against a team 1 whose striker idles; returns the first scorer."""
    game = SoccerGame(num_worlds=num_worlds, seed=seed, max_cycles=steps)
    scorer = np.full(num_worlds, -1)
    for step in range(steps):
        state = game.state()
        goalie_1 = (
            goalie_actions(state, 1, game.options)
            if team_1_goalie == "scripted"
            else np.full(num_worlds, step % 2)  # forward, backward, ...: stays put
        )
        outcome = game.step(
            {
                "striker": np.stack(
                    [striker_actions(state, 0, game.options), np.full(num_worlds, 2)], 1
                ),
                "goalie": np.stack([goalie_actions(state, 0, game.options), goalie_1], 1),
            }
        )
        first = (outcome.scoring_team >= 0) & (scorer < 0)
        scorer[first] = outcome.scoring_team[first]
        if np.all(scorer >= 0):
            break
    return scorer


def test_scripted_striker_scores_against_an_idle_team() -> None:
    """Within 500 steps (50 s) nearly every pitch sees a goal, never an own goal."""
    scorer = play(num_worlds=32, steps=500, team_1_goalie="idle")
    assert np.mean(scorer == 0) >= 0.85 and not np.any(scorer == 1), scorer


@pytest.mark.parametrize("team", [0, 1])
def test_scripted_goalie_guards_its_goal_line(team: int) -> None:
    """Cases in team 0's frame; team 1 gets the same scene rotated by 180°."""
    game = SoccerGame(num_worlds=4, seed=0)
    a = game.geometry.half_length
    ball = np.array([[-3.0, 2.0], [-3.0, -2.0], [0.0, 0.0], [-a + 2.0, 0.3]])
    goalie = np.array([[-a + 1.0, 0.0], [-a + 1.0, 0.0], [-a + 3.0, 0.0], [-a + 1.0, 0.3]])
    positions = np.zeros((4, 5, 2))
    positions[:, :4] = [[-4.0, 4.0], [4.0, 4.0], [-a + 1.0, 0.0], [a - 1.0, 0.0]]
    positions[:, 2 + team], positions[:, BALL] = goalie, ball
    positions[:, 3 - team] = [-a + 1.0, -4.0]  # the other goalie, out of the way
    angles = np.tile([0.0, np.pi, 0.0, np.pi, 0.0], (4, 1))
    if team == 1:
        positions = -positions
    game.place(positions, angles)
    actions = goalie_actions(game.state(), team, game.options)
    # side left (towards +y), side right, back to its line, step out to clear the ball
    np.testing.assert_array_equal(actions, [2, 3, 1, 0])
