"""Soccer: the game's rules and contract, the PettingZoo and TorchRL views."""

from __future__ import annotations

import numpy as np
import pytest

from rlhc.envs import make_env, make_game
from rlhc.envs.soccer import SoccerGame, parallel_env
from rlhc.envs.soccer.game import STATE_SIZE
from rlhc.envs.soccer.physics import BALL

STRIKER_TIME, GOALIE_TIME = -0.001, 0.001


def idle(num_worlds: int) -> dict[str, np.ndarray]:
    """Strikers turn on the spot, goalies step forward: nobody goes anywhere fast."""
    return {
        "striker": np.full((num_worlds, 2), 2, dtype=np.int64),
        "goalie": np.zeros((num_worlds, 2), dtype=np.int64),
    }


def scene(game: SoccerGame, **spots: tuple[float, float]) -> tuple[np.ndarray, np.ndarray]:
    """Kick-off spots (no jitter) with some bodies moved; angles face the opponent goal."""
    a = game.geometry.half_length
    positions = np.array([[-4.0, 0.0], [4.0, 0.0], [-a + 1.2, 0.0], [a - 1.2, 0.0], [0.0, 0.0]])
    names = ["striker_0", "striker_1", "goalie_0", "goalie_1", "ball"]
    for name, spot in spots.items():
        positions[names.index(name)] = spot
    angles = np.array([0.0, np.pi, 0.0, np.pi, 0.0])
    return np.repeat(positions[None], game.num_worlds, 0), np.repeat(
        angles[None], game.num_worlds, 0
    )


@pytest.mark.parametrize("scorer", [0, 1])
def test_a_ball_pushed_into_a_goal_gives_the_table_rewards(scorer: int) -> None:
    game = SoccerGame(num_worlds=1, seed=0)
    a = game.geometry.half_length
    sign = 1.0 if scorer == 0 else -1.0
    # The scorer's striker 1.2 m behind the ball, 1 m before the goal it attacks; the
    # defending goalie stands aside.
    positions, angles = scene(
        game,
        **{
            f"striker_{scorer}": (sign * (a - 2.2), 0.0),
            "ball": (sign * (a - 1.0), 0.0),
            f"goalie_{1 - scorer}": (sign * (a - 1.0), sign * 3.5),
        },
    )
    game.place(positions, angles)
    actions = idle(1)
    actions["striker"][0, scorer] = 0  # forward: runs into the ball and kicks it
    for steps in range(1, 30):
        outcome = game.step(actions)
        assert game.step_count[0] == steps
        if outcome.terminated[0]:
            break
        assert outcome.scoring_team[0] == -1
        np.testing.assert_array_equal(outcome.rewards["striker"], np.float32([[STRIKER_TIME] * 2]))
        np.testing.assert_array_equal(outcome.rewards["goalie"], np.float32([[GOALIE_TIME] * 2]))
    else:
        pytest.fail("the pushed ball never entered the goal")
    assert steps < 15 and outcome.scoring_team[0] == scorer and not outcome.truncated[0]
    striker, goalie = np.zeros(2, np.float32), np.zeros(2, np.float32)
    striker[scorer], striker[1 - scorer] = 1.0, -0.1  # paper Table 2
    goalie[scorer], goalie[1 - scorer] = 0.1, -1.0
    np.testing.assert_allclose(
        outcome.rewards["striker"][0], striker + np.float32(STRIKER_TIME), rtol=0, atol=1e-7
    )
    np.testing.assert_allclose(
        outcome.rewards["goalie"][0], goalie + np.float32(GOALIE_TIME), rtol=0, atol=1e-7
    )
    np.testing.assert_array_equal(outcome.info["striker_sparse_reward"][0], striker)
    np.testing.assert_array_equal(outcome.info["goalie_sparse_reward"][0], goalie)
    np.testing.assert_array_equal(
        outcome.info["striker_time_reward"][0], np.float32([STRIKER_TIME] * 2)
    )


@pytest.mark.parametrize("facing", [0.6, -2.0])
def test_a_forward_touch_kicks_the_ball_along_the_facing(facing: float) -> None:
    game = SoccerGame(num_worlds=2, seed=0)
    direction = np.array([np.cos(facing), np.sin(facing)])
    touching = game.options.player_radius + game.options.ball_radius + 0.01
    positions, angles = scene(game, striker_0=(0.0, 0.0), ball=tuple(touching * direction))
    angles[:, 0] = facing
    game.place(positions, angles)
    actions = idle(2)
    actions["striker"][:, 0] = [0, 1]  # world 0: forward (kicks), world 1: backward
    game.step(actions)
    kicked, left_alone = game.physics.velocities[:, BALL]
    assert np.linalg.norm(kicked) >= game.options.kick_speed
    assert kicked @ direction / np.linalg.norm(kicked) > np.cos(np.deg2rad(5))
    assert np.linalg.norm(left_alone) < 0.1


def test_time_terms_are_options_and_max_cycles_truncates() -> None:
    game = SoccerGame(
        num_worlds=2, seed=0, max_cycles=5, striker_time_reward=0.0, goalie_time_reward=0.25
    )
    for step in range(1, 6):
        outcome = game.step(idle(2))
        assert np.all(outcome.rewards["striker"] == 0.0) and np.all(
            outcome.rewards["goalie"] == 0.25
        )
        assert not outcome.terminated.any()
        assert outcome.truncated.all() == (step == 5)
    np.testing.assert_array_equal(game.step_count, [5, 5])


def test_unknown_or_bad_options_fail_loudly() -> None:
    with pytest.raises(ValueError, match="max_cylces"):
        SoccerGame(num_worlds=1, max_cylces=10)
    with pytest.raises(ValueError, match="max_cycles"):
        SoccerGame(num_worlds=1, max_cycles=0)
    with pytest.raises(ValueError, match=r"tunnel|cross"):
        SoccerGame(num_worlds=1, ball_max_speed=100.0)
    with pytest.raises(ValueError, match="goal_width"):
        SoccerGame(num_worlds=1, goal_width=20.0)


def test_bad_actions_are_value_errors_naming_the_problem() -> None:
    game = SoccerGame(num_worlds=2, seed=0)
    good = idle(2)
    with pytest.raises(ValueError, match="striker"):
        game.step({**good, "striker": np.zeros((2, 3), np.int64)})
    with pytest.raises(ValueError, match=r"\[0, 3\]"):
        game.step({**good, "goalie": np.full((2, 2), 4)})  # goalies have no rotation
    with pytest.raises(ValueError, match="striker"):
        game.step({**good, "striker": np.full((2, 2), np.nan)})
    with pytest.raises(ValueError, match="keeper"):
        game.step({**good, "keeper": np.zeros((2, 2), np.int64)})
    with pytest.raises(ValueError, match="goalie"):
        game.step({"striker": good["striker"]})
    assert np.all(game.step_count == 0)  # nothing was stepped
    pz = parallel_env(seed=0)
    pz.reset(seed=0)
    with pytest.raises(ValueError, match="goalie_7"):
        pz.step({**dict.fromkeys(pz.agents, 0), "goalie_7": 0})
    with pytest.raises(ValueError, match=r"striker.*\[0, 5\]"):
        pz.step({**dict.fromkeys(pz.agents, 0), "striker_0": 6})


def test_partial_reset_touches_only_the_masked_pitches() -> None:
    game = SoccerGame(num_worlds=4, seed=0)
    rng = np.random.default_rng(0)
    for _ in range(20):
        game.step({"striker": rng.integers(0, 6, (4, 2)), "goalie": rng.integers(0, 4, (4, 2))})
    state_before = game.state()
    game.reset(np.array([True, False, True, False]))
    state_after = game.state()
    np.testing.assert_array_equal(state_after[[1, 3]], state_before[[1, 3]])
    np.testing.assert_array_equal(game.step_count, [0, 20, 0, 20])
    jitter = game.options.kickoff_jitter
    spot = -game.geometry.half_length / 2  # striker_0 kicks off halfway to its goal line
    for world in (0, 2):
        ball = state_after[world, 0:2]
        assert np.all(np.abs(ball) <= jitter / 2) and np.all(state_after[world, 2:4] == 0)
        striker_0 = state_after[world, 4:6]
        assert abs(striker_0[0] - spot) <= jitter and abs(striker_0[1]) <= jitter
    with pytest.raises(ValueError, match="mask"):
        game.reset(np.array([True, False]))


def test_seeding_reproduces_kickoffs_and_episodes() -> None:
    def run(seed: int) -> np.ndarray:
        game = make_game("soccer", num_envs=3, seed=seed)
        rng = np.random.default_rng(7)
        states = [game.state()]
        for _ in range(30):
            game.step({"striker": rng.integers(0, 6, (3, 2)), "goalie": rng.integers(0, 4, (3, 2))})
            states.append(game.state())
        game.seed(seed)
        game.reset()
        states.append(game.state())
        return np.stack(states)

    first, again, other = run(1), run(1), run(2)
    np.testing.assert_array_equal(first, again)
    np.testing.assert_array_equal(first[0], first[-1])  # re-seeding replays the kick-off
    assert not np.allclose(first[0], other[0])
    assert first.shape[-1] == STATE_SIZE == 28


def test_goalies_keep_facing_the_opponent_goal() -> None:
    game = SoccerGame(num_worlds=8, seed=0)
    rng = np.random.default_rng(0)
    for _ in range(100):
        game.step({"striker": rng.integers(0, 6, (8, 2)), "goalie": rng.integers(0, 4, (8, 2))})
    state = game.state()
    np.testing.assert_allclose(state[:, 4 + 6 * 2 + 4 : 4 + 6 * 2 + 6], [[1.0, 0.0]] * 8, atol=1e-9)
    np.testing.assert_allclose(
        state[:, 4 + 6 * 3 + 4 : 4 + 6 * 3 + 6], [[-1.0, 0.0]] * 8, atol=1e-9
    )


def test_pettingzoo_agents_spaces_and_infos() -> None:
    # PettingZoo's API, seed and render suites run on every registered game in
    # tests/envs/test_adapters.py.
    pz = parallel_env(seed=0)
    observations, infos = pz.reset(seed=3)
    assert pz.possible_agents == ["striker_0", "striker_1", "goalie_0", "goalie_1"]
    assert observations["striker_1"].shape == (112,)
    assert infos["goalie_0"]["manager_observation"].shape == (200,)
    assert [infos[agent]["team"] for agent in pz.possible_agents] == [0, 1, 0, 1]
    assert pz.action_space("striker_0").n == 6 and pz.action_space("goalie_1").n == 4


def test_render_draws_the_pitch() -> None:
    game = SoccerGame(num_worlds=2, seed=0)
    frame = game.render(1)
    assert frame.dtype == np.uint8 and frame.ndim == 3 and frame.shape[2] == 3
    with_rays = game.render(1, rays=True)
    assert with_rays.shape == frame.shape and np.any(with_rays != frame)
    with pytest.raises(ValueError, match="world"):
        game.render(2)


def test_torchrl_env_specs_and_partial_resets() -> None:
    import torch
    from torchrl.envs.utils import check_env_specs

    torchrl_env = make_env("soccer", num_envs=4, seed=0, max_cycles=7)
    check_env_specs(torchrl_env)
    rollout = torchrl_env.rollout(20, break_when_any_done=False)
    assert rollout["striker", "observation"].shape == (4, 20, 2, 112)
    assert rollout["goalie", "manager_observation"].shape == (4, 20, 2, 200)
    assert rollout["next", "goalie", "reward"].shape == (4, 20, 2, 1)
    assert torch.equal(rollout["striker", "team"][0, 0, :, 0], torch.tensor([0, 1]))
    # max_cycles=7: every pitch is truncated at steps 7 and 14 and restarted by TorchRL.
    truncated = rollout["next", "truncated"][..., 0]
    assert truncated[:, [6, 13]].all() and truncated.sum() == 8


def test_ball_stays_in_play_at_the_kickoff_of_every_world() -> None:
    game = SoccerGame(num_worlds=64, seed=0)
    positions = game.physics.positions
    assert game.geometry.contains(positions).all()
    assert np.all(np.abs(positions[:, BALL]) < 1.0)
