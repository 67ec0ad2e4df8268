"""Soccer under stress: a seeded fuzz of the batched game, and the scripted players."""

from __future__ import annotations

import numpy as np
import pytest

from rlhc.envs.soccer import SoccerGame
from rlhc.envs.soccer.physics import BALL
from rlhc.envs.soccer.scripted import goalie_actions, striker_actions

#: body order of a scene turned by 180° with the teams swapped.
HALF_TURN = [1, 0, 3, 2, BALL]
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


def overlap(centres: np.ndarray, boxes: np.ndarray, radius: float) -> np.ndarray:
    """How deep each circle ``[..., 2]`` of ``radius`` reaches into the nearest box ``[B, 4]``.

    Exact for axis-aligned boxes ``(x_min, y_min, x_max, y_max)``: the radius minus the
    signed distance from the centre to the box (negative inside it).
    """
    low, high = boxes[:, :2], boxes[:, 2:]
    point = centres[..., None, :]
    outside = np.linalg.norm(np.maximum(np.maximum(low - point, point - high), 0.0), axis=-1)
    inside = np.min(np.minimum(point - low, high - point), axis=-1)
    return radius - np.where(outside > 0, outside, -inside).min(axis=-1)


def run_fuzz(num_worlds: int, steps: int, seed: int) -> dict[str, float]:
    """Step with resets; assert the invariants at every step; return what was seen."""
    game = SoccerGame(num_worlds=num_worlds, seed=seed, max_cycles=300)
    geometry = game.geometry
    player_radius, ball_radius = game.options.player_radius, game.options.ball_radius
    # Players meet the walls and the goal-mouth barriers; the ball only the walls (a ball
    # crossing a goal line in the mouth is going into the net, not into a wall).
    walls = np.array(geometry.wall_boxes())
    a, g, d = geometry.half_length, geometry.goal_half_width, geometry.goal_depth
    barriers = np.concatenate([walls, [(a, -g, a + d, g), (-a - d, -g, -a, g)]])
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
        deepest = max(
            deepest,
            float(overlap(positions[:, :4], barriers, player_radius).max()),
            float(overlap(positions[:, BALL], walls, ball_radius).max()),
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


@pytest.mark.parametrize("team", [0, 1])
def test_scripted_striker_never_kicks_towards_its_own_goal(team: int) -> None:
    """Facing its own half with the ball just ahead, it side-steps away from the ball."""
    game = SoccerGame(num_worlds=2, seed=0)
    a = game.geometry.half_length
    touching = game.options.player_radius + game.options.ball_radius
    # Team 0's frame: striker_0 at the centre spot facing its own goal, the ball just
    # ahead and off-centre (to its right in world 0, to its left in world 1).
    positions = np.zeros((2, 5, 2))
    positions[:, :4] = [[0.0, 0.0], [4.0, 4.0], [-a + 1.0, 0.0], [a - 1.0, 0.0]]
    positions[:, BALL] = [[-touching - 0.1, 0.2], [-touching - 0.1, -0.2]]
    angles = np.tile([np.pi, np.pi, 0.0, np.pi, 0.0], (2, 1))
    if team == 1:  # the same scene turned by 180°, teams swapped
        positions, angles = -positions[:, HALF_TURN], angles[:, HALF_TURN] + np.pi
    game.place(positions, angles)
    np.testing.assert_array_equal(striker_actions(game.state(), team, game.options), [4, 5])


@pytest.mark.parametrize("team", [0, 1])
def test_scripted_goalie_meets_a_rolling_ball_on_its_path(team: int) -> None:
    """A ball rolling at the goal is met where its path crosses the goalie's line."""
    game = SoccerGame(num_worlds=2, seed=0)
    a = game.geometry.half_length
    positions = np.zeros((2, 5, 2))
    positions[:, :4] = [[-2.0, 4.0], [4.0, 4.0], [-a + 1.0, 0.0], [a - 1.0, 0.0]]
    positions[:, BALL] = [-a + 5.0, 2.0]
    angles = np.tile([0.0, np.pi, 0.0, np.pi, 0.0], (2, 1))
    sign = 1.0 if team == 0 else -1.0
    if team == 1:  # the same scene turned by 180°, teams swapped
        positions = -positions[:, HALF_TURN]
    game.place(positions, angles)
    # World 0: the ball rolls at the goal's centre line and below it (crossing y = -2);
    # world 1 lies still: the goalie narrows the angle (towards +y).
    for world, velocity in ((0, (-8.0, -8.0)), (1, (0.0, 0.0))):
        game.physics.bodies[world][BALL].velocity = tuple(sign * np.array(velocity))
    game.physics.read()
    np.testing.assert_array_equal(goalie_actions(game.state(), team, game.options), [3, 2])
