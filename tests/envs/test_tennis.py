"""The tennis game: sizes, frames, rules, episode ends, resets, seeding, robustness."""

from __future__ import annotations

import numpy as np
import pytest

from rlhc.envs import make_env, make_game
from rlhc.envs.tennis import ScriptedTennisPolicy, TennisGame
from rlhc.envs.tennis.game import STATE_SIZE
from rlhc.envs.tennis.observations import LENGTH_SCALE, VELOCITY_SCALE
from rlhc.envs.tennis.physics import NET_CONTACT
from rlhc.envs.tennis.rules import POINT_ENDINGS

MIRROR_RACKETS = [2, 3, 0, 1]


def make_state(ball, rackets, ball_velocity=(0.0, 0.0)) -> np.ndarray:
    """One court's state vector from SI values: ball (x, y), rackets [(x, y), …] at rest."""
    state = np.zeros((1, STATE_SIZE))
    state[0, 0:2] = np.asarray(ball) / LENGTH_SCALE
    state[0, 2:4] = np.asarray(ball_velocity) / VELOCITY_SCALE
    for i, position in enumerate(rackets):
        state[0, 4 + 5 * i : 6 + 5 * i] = np.asarray(position) / LENGTH_SCALE
    return state


def mirror_state(state: np.ndarray) -> np.ndarray:
    """The same court seen from the other side: x, vx and angles negated, teams swapped."""
    mirrored = state.copy()
    mirrored[:, [0, 2]] *= -1
    rackets = state[:, 4:].reshape(-1, 4, 5)[:, MIRROR_RACKETS].copy()
    rackets[..., [0, 2, 4]] *= -1
    mirrored[:, 4:] = rackets.reshape(len(state), -1)
    return mirrored


def zeros(game: TennisGame) -> dict[str, np.ndarray]:
    return {"racket": np.zeros((game.num_worlds, 4, 3))}


@pytest.mark.parametrize(("extended_obs", "worker", "manager"), [(False, 8, 10), (True, 12, 14)])
def test_observation_sizes_are_pinned(extended_obs: bool, worker: int, manager: int) -> None:
    game = TennisGame(num_worlds=3, seed=0, extended_obs=extended_obs)
    spec = game.group("racket")
    observed = game.observe()["racket"]
    assert (spec.observation_size, spec.manager_observation_size) == (worker, manager)
    assert observed.observation.shape == (3, 4, worker)
    assert observed.manager_observation.shape == (3, 4, manager)
    assert observed.observation.dtype == np.float32
    assert game.state().shape == (3, STATE_SIZE)


@pytest.mark.parametrize("extended_obs", [False, True])
def test_mirrored_court_gives_opposite_rackets_the_same_observation(extended_obs: bool) -> None:
    game = TennisGame(num_worlds=2, seed=3, extended_obs=extended_obs)
    rng = np.random.default_rng(0)
    for _ in range(7):
        game.step({"racket": rng.uniform(-1, 1, (2, 4, 3))})
    state = game.state()[:1]
    game.set_state(np.concatenate([state, mirror_state(state)]))
    observed = game.observe()["racket"]
    for seen in (observed.observation, observed.manager_observation):
        np.testing.assert_allclose(seen[1], seen[0, MIRROR_RACKETS], atol=1e-6)
    # Not trivially symmetric: the two teams do see different things in court 0.
    assert not np.allclose(observed.observation[0, 0], observed.observation[0, 2])


def test_mirrored_court_evolves_mirrored() -> None:
    game = TennisGame(num_worlds=2, seed=0)
    state = make_state((-3.0, 3.0), [(-4, 0.7), (-1.8, 0.7), (2.5, 0.7), (1.5, 0.7)], (1.0, 2.0))
    game.set_state(np.concatenate([state, mirror_state(state)]))
    rng = np.random.default_rng(1)
    for _ in range(15):
        action = rng.uniform(-1, 1, (1, 4, 3))
        # Team-frame actions: the mirrored court's racket k acts like racket MIRROR[k].
        game.step({"racket": np.concatenate([action, action[:, MIRROR_RACKETS]])})
    np.testing.assert_allclose(game.state()[1], mirror_state(game.state()[:1])[0], atol=1e-5)


def test_scripted_hit_over_the_net_pays_the_hitter() -> None:
    game = TennisGame(num_worlds=1, seed=0)
    game.set_state(make_state((-3.0, 3.0), [(-4, 0.7), (-1.8, 0.7), (4, 0.7), (1.8, 0.7)]))
    policy = ScriptedTennisPolicy()
    for _ in range(150):
        outcome = game.step({"racket": policy(game.observe()["racket"].observation)})
        last_toucher = int(game.rally.last_hitter[0])
        if outcome.info["hits_over_net"][0]:
            break
        assert not outcome.terminated[0], "the scripted team failed to play the ball over"
        np.testing.assert_array_equal(outcome.rewards["racket"], 0.0)
    else:
        pytest.fail("the ball never crossed the net")
    assert last_toucher in (0, 1)  # team A returned it
    expected = np.zeros(4, dtype=np.float32)
    expected[last_toucher] = 0.1
    np.testing.assert_array_equal(outcome.rewards["racket"][0], expected)
    assert game.physics.ball_position[0, 0] > 0
    assert not outcome.terminated[0]


@pytest.mark.parametrize(
    ("fault_penalty", "expected"),
    [("team", [-0.1, -0.1, 0.0, 0.0]), ("nearest", [0.0, -0.1, 0.0, 0.0])],
)
def test_missed_ball_penalises_the_team_of_that_half_and_ends_the_point(
    fault_penalty: str, expected: list[float]
) -> None:
    game = TennisGame(num_worlds=1, seed=0, fault_penalty=fault_penalty)
    # The ball drops at x = -2.0: racket_1 (at -3.2) is nearer than racket_0 (at -5).
    game.set_state(make_state((-2.0, 3.0), [(-5, 0.7), (-3.2, 0.7), (4, 0.7), (1.8, 0.7)]))
    for _ in range(100):
        outcome = game.step(zeros(game))
        if outcome.terminated[0]:
            break
        np.testing.assert_array_equal(outcome.rewards["racket"], 0.0)
    else:
        pytest.fail("the ball never landed")
    assert game.step_count[0] > 3  # it fell for a while first
    np.testing.assert_allclose(outcome.rewards["racket"][0], expected)
    assert outcome.scoring_team[0] == 1
    assert not outcome.truncated[0]
    # Nobody touched it: the serve was missed.
    assert [how for how in POINT_ENDINGS if outcome.info[f"ended_{how}"][0]] == ["serve_missed"]


@pytest.mark.parametrize(
    ("fault_penalty", "expected"),
    [("team", [-0.1, -0.1, 0.0, 0.0]), ("nearest", [0.0, -0.1, 0.0, 0.0])],
)
def test_ball_into_the_net_is_a_fault_of_the_team_that_had_it(
    fault_penalty: str, expected: list[float]
) -> None:
    game = TennisGame(num_worlds=1, seed=0, fault_penalty=fault_penalty)
    state = make_state((-1.5, 0.6), [(-5, 0.7), (-3.2, 0.7), (4, 0.7), (1.8, 0.7)], (6.0, 0.0))
    game.set_state(state)
    outcome = game.step(zeros(game))
    for _ in range(10):
        if outcome.terminated[0]:
            break
        outcome = game.step(zeros(game))
    assert outcome.terminated[0]
    assert game.physics.ball_position[0, 0] < 0  # it bounced back off the net
    # Nobody hit it since the (team 0) serve: team 0 pays (with "nearest": its racket
    # nearest to the ball).
    np.testing.assert_allclose(outcome.rewards["racket"][0], expected)
    assert outcome.scoring_team[0] == 1
    assert [how for how in POINT_ENDINGS if outcome.info[f"ended_{how}"][0]] == ["net"]


def test_every_ended_point_says_how_once_and_nothing_else_does() -> None:
    game = TennisGame(num_worlds=64, seed=1)
    rng = np.random.default_rng(1)
    seen = dict.fromkeys(POINT_ENDINGS, 0)
    for _ in range(300):
        outcome = game.step({"racket": rng.uniform(-1, 1, (64, 4, 3))})
        flags = np.stack([outcome.info[f"ended_{how}"] for how in POINT_ENDINGS], axis=-1)
        np.testing.assert_array_equal(flags.sum(-1), outcome.terminated.astype(int))
        for how, count in zip(POINT_ENDINGS, flags.sum(0), strict=True):
            seen[how] += int(count)
        game.reset(outcome.terminated | outcome.truncated)
    # Random rackets miss serves, hit into the net, out, into the walls.
    assert all(count > 0 for how, count in seen.items() if how != "missed"), seen


def test_max_cycles_truncates_without_terminating() -> None:
    game = TennisGame(num_worlds=4, seed=0, max_cycles=5)
    for step in range(1, 6):
        outcome = game.step(zeros(game))
        assert not outcome.terminated.any()  # a serve takes longer than 5 steps to land
        assert outcome.truncated.all() == (step == 5)
        assert not outcome.truncated.any() or step == 5


def test_partial_reset_leaves_other_courts_untouched() -> None:
    game = TennisGame(num_worlds=4, seed=0)
    rng = np.random.default_rng(0)
    for _ in range(10):
        game.step({"racket": rng.uniform(-1, 1, (4, 4, 3))})
    before = game.state()
    counts = game.step_count.copy()
    mask = np.array([True, False, True, False])
    game.reset(mask)
    after = game.state()
    np.testing.assert_array_equal(after[~mask], before[~mask])
    np.testing.assert_array_equal(game.step_count, np.where(mask, 0, counts))
    assert not np.allclose(after[mask], before[mask])
    # Reset courts start a serve: rackets at rest on the ground, at home.
    np.testing.assert_allclose(
        game.physics.racket_position[mask][..., 1], game.geometry.racket_ground_y
    )
    np.testing.assert_allclose(game.physics.racket_velocity[mask], 0.0)


def test_serve_alternates_between_the_teams() -> None:
    game = TennisGame(num_worlds=8, seed=0)
    sides = [np.sign(game.physics.ball_position[:, 0])]
    for _ in range(3):
        game.reset()
        sides.append(np.sign(game.physics.ball_position[:, 0]))
    sides_array = np.array(sides)
    assert (sides_array[1:] == -sides_array[:-1]).all()
    assert len(np.unique(sides_array[0])) == 2  # the first server is drawn per court


def test_seeding_reproduces_and_distinguishes_episodes() -> None:
    def trajectory(seed: int) -> np.ndarray:
        game = TennisGame(num_worlds=3, seed=seed)
        rng = np.random.default_rng(42)
        states = []
        for _ in range(60):
            outcome = game.step({"racket": rng.uniform(-1, 1, (3, 4, 3))})
            game.reset(outcome.terminated | outcome.truncated)
            states.append(game.state())
        return np.array(states)

    np.testing.assert_array_equal(trajectory(1), trajectory(1))
    assert not np.array_equal(trajectory(1), trajectory(2))


@pytest.mark.parametrize(
    ("actions", "match"),
    [
        ({"racket": np.zeros((2, 4, 2))}, "racket"),
        ({"racket": np.zeros((2, 3, 3))}, "racket"),
        ({"racket": np.full((2, 4, 3), np.nan)}, "racket"),
        ({"racket": np.zeros((2, 4, 3)), "bogus_group": np.zeros(1)}, "bogus_group"),
        ({}, "racket"),
    ],
)
def test_bad_actions_raise_value_errors_naming_the_group(actions, match: str) -> None:
    game = TennisGame(num_worlds=2, seed=0)
    with pytest.raises(ValueError, match=match):
        game.step(actions)


def test_unknown_option_is_named() -> None:
    with pytest.raises(ValueError, match="bogus_option"):
        make_game("tennis", num_envs=2, bogus_option=1)
    with pytest.raises(ValueError, match="bogus_option"):
        make_env("tennis", num_envs=2, bogus_option=1)


def test_out_of_range_actions_are_clipped() -> None:
    clipped, extreme = TennisGame(num_worlds=1, seed=5), TennisGame(num_worlds=1, seed=5)
    # Saturated entries only, so that 5x the action clips back to the same action.
    action = np.array([[[1.0, 1.0, -1.0], [-1.0, 1.0, 1.0], [-1.0, 1.0, 1.0], [1.0, 0.0, -1.0]]])
    for _ in range(20):
        clipped.step({"racket": action})
        extreme.step({"racket": action * 5.0})
    np.testing.assert_array_equal(clipped.state(), extreme.state())


def test_two_scripted_teams_keep_rallies_going() -> None:
    game = TennisGame(num_worlds=32, seed=0, max_cycles=1000)
    policy = ScriptedTennisPolicy()
    crossings = np.zeros(32)
    points: list[float] = []
    lengths: list[int] = []
    for _ in range(800):
        outcome = game.step({"racket": policy(game.observe()["racket"].observation)})
        crossings += outcome.info["hits_over_net"]
        ended = outcome.terminated | outcome.truncated
        if ended.any():
            points += crossings[ended].tolist()
            lengths += game.step_count[ended].tolist()
            crossings[ended] = 0
            game.reset(ended)
    mean_crossings = float(np.mean(points))
    print(
        f"scripted rallies: {len(points)} points, mean {mean_crossings:.1f} shots over the "
        f"net, mean length {np.mean(lengths):.0f} steps"
    )
    assert len(points) >= 20
    assert mean_crossings >= 4.0


def test_fuzz_random_and_extreme_actions_keep_the_world_sound() -> None:
    """64 courts × 1,600 frames of random, ±1 and ±5 actions: no NaN, no escape, legal rewards.

    One frame per decision, so that every physics frame is checked.
    """
    num_worlds, steps = 64, 1600
    game = TennisGame(num_worlds=num_worlds, seed=123, max_cycles=400, decision_interval=1)
    g = game.geometry
    rng = np.random.default_rng(123)
    p = game.physics
    for _ in range(steps):
        kind = rng.integers(0, 3)
        if kind == 0:
            action = rng.uniform(-1, 1, (num_worlds, 4, 3))
        elif kind == 1:
            action = rng.choice([-1.0, 1.0], (num_worlds, 4, 3))
        else:
            action = rng.choice([-5.0, 5.0, 0.0], (num_worlds, 4, 3))
        previous = p.ball_position.copy()
        outcome = game.step({"racket": action})
        observed = game.observe()["racket"]
        assert np.isfinite(observed.observation).all()
        assert np.isfinite(observed.manager_observation).all()
        rewards = outcome.rewards["racket"]
        assert np.isfinite(rewards).all()
        # Every reward is a sum of table entries (+0.1, -0.1) on one step.
        tenths = rewards * 10
        np.testing.assert_allclose(tenths, np.round(tenths), atol=1e-5)
        assert np.abs(tenths).max() <= 2 + 1e-5
        ball = p.ball_position
        assert (np.abs(ball[:, 0]) <= g.wall_x).all()
        assert (ball[:, 1] >= 0.0).all() and (ball[:, 1] <= g.ceiling_y).all()
        # No tunnelling through the net: a crossing below its top is a ball driven into
        # the net (at up to 15 m/s it may sink in by a few cm), which ends the point on a
        # net contact with the ball still inside the net, never through it.
        crossed = np.sign(previous[:, 0]) != np.sign(ball[:, 0])
        fraction = -previous[:, 0] / np.where(crossed, ball[:, 0] - previous[:, 0], 1.0)
        height = previous[:, 1] + fraction * (ball[:, 1] - previous[:, 1])
        low = crossed & (height < g.net_height)
        assert (p.first_contact[low] == NET_CONTACT).all()
        assert outcome.terminated[low].all()
        assert (np.abs(ball[low, 0]) < g.net_radius + g.ball_radius).all()
        rackets = p.racket_position
        assert (np.abs(rackets[..., 0]) <= g.wall_x - g.racket_wall_gap + 1e-9).all()
        assert (np.abs(rackets[..., 0]) >= g.racket_net_gap - 1e-9).all()
        assert (rackets[..., 1] >= g.racket_ground_y - 1e-9).all()
        game.reset(outcome.terminated | outcome.truncated)


def test_jump_takes_off_only_above_the_threshold() -> None:
    game = TennisGame(num_worlds=1, seed=0, decision_interval=1)
    g = game.geometry
    for value, jumps in ((0.4, False), (g.jump_threshold, False), (0.6, True)):
        game.reset()
        action = np.zeros((1, 4, 3))
        action[0, 0, 1] = value
        game.step({"racket": action})
        lifted = game.physics.racket_position[0, 0, 1] > g.racket_ground_y
        assert lifted == jumps, value
        if jumps:
            # Take-off at value * jump_speed, then one frame of gravity.
            expected = value * g.jump_speed - g.gravity * g.dt
            assert game.physics.racket_velocity[0, 0, 1] == pytest.approx(expected)


def test_tilt_sets_the_paddle_angle_within_one_frame() -> None:
    """The angle is not hidden state: it follows the current action, whatever it was."""
    game = TennisGame(num_worlds=1, seed=0, decision_interval=1)
    g = game.geometry
    for tilt in (1.0, -1.0, 0.25):
        action = np.zeros((1, 4, 3))
        action[..., 2] = tilt
        game.step({"racket": action})
        # Team A tilts towards +x by turning clockwise; team B is mirrored.
        expected = tilt * g.max_tilt * np.array([-1.0, -1.0, 1.0, 1.0])
        np.testing.assert_allclose(game.physics.racket_angle[0], expected, atol=1e-9)


def test_a_decision_holds_the_action_for_its_frames() -> None:
    """One decision of k frames = k one-frame decisions with the same action."""
    held = TennisGame(num_worlds=3, seed=4, decision_interval=5)
    framed = TennisGame(num_worlds=3, seed=4, decision_interval=1)
    rng = np.random.default_rng(0)
    compared = 0
    for _ in range(6):
        action = rng.uniform(-1, 1, (3, 4, 3))
        outcome = held.step({"racket": action})
        rewards = np.zeros((3, 4), dtype=np.float32)
        for _ in range(5):
            frame = framed.step({"racket": action})
            rewards += frame.rewards["racket"]
            if (frame.terminated | outcome.terminated).any():
                break
        if outcome.terminated.any():
            break
        np.testing.assert_allclose(held.state(), framed.state(), atol=1e-9)
        np.testing.assert_allclose(outcome.rewards["racket"], rewards, atol=1e-7)
        compared += 1
    assert compared >= 3
    np.testing.assert_array_equal(held.step_count * 5, framed.step_count)
