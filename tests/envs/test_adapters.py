"""The generic adapters (TorchRL batched env, PettingZoo parallel env), run on tennis,
on every registered game (PettingZoo's API suites) and on a tiny discrete-action game
that stands in for soccer's groups."""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
import pytest
import torch
from pettingzoo.test import api_test, parallel_api_test, parallel_seed_test, render_test
from torchrl.envs.utils import check_env_specs

from rlhc.envs import game_spec, games, make_aec_env, make_env, make_game, make_parallel_env
from rlhc.envs.base import (
    BatchedGame,
    DiscreteAction,
    FrameOutcome,
    GroupObservation,
    GroupSpec,
)
from rlhc.envs.pettingzoo_adapter import BatchedGameParallelEnv
from rlhc.envs.tennis import parallel_env as tennis_parallel_env
from rlhc.envs.torchrl_adapter import BatchedGameEnv


class CountdownGame(BatchedGame):
    """Two groups with discrete actions; a world ends when action 1 is played by ``a_0``
    (terminated, team 0 scores) or after ``max_cycles`` decisions (truncated). Every frame
    adds 1 to the observed value and pays ``b`` its action."""

    name = "countdown"

    def __init__(
        self,
        num_worlds: int = 1,
        seed: int | None = None,
        max_cycles: int = 4,
        decision_interval: int = 1,
    ) -> None:
        super().__init__(
            num_worlds=num_worlds,
            max_cycles=max_cycles,
            seed=seed,
            decision_interval=decision_interval,
        )
        self.groups = (
            GroupSpec("a", ("a_0", "a_1"), 3, 5, DiscreteAction(2), (0, 1)),
            GroupSpec("b", ("b_0",), 2, 2, DiscreteAction(4), (1,)),
        )
        self.value = np.zeros(num_worlds)

    def reset(self, mask: np.ndarray | None = None) -> None:
        mask = np.ones(self.num_worlds, bool) if mask is None else mask
        self.value[mask] = self.rng.uniform(size=int(mask.sum()))
        self.step_count[mask] = 0

    def advance(self, actions: Mapping[str, np.ndarray]) -> FrameOutcome:
        self.value += 1
        terminated = actions["a"][:, 0] == 1
        return FrameOutcome(
            rewards={
                "a": np.stack([terminated, terminated], axis=1) * np.float32([1.0, -1.0]),
                "b": actions["b"].astype(np.float32),
            },
            terminated=terminated,
            scoring_team=np.where(terminated, 0, -1),
            info={"frames": np.ones(self.num_worlds, dtype=np.int64)},
        )

    def observe(self) -> dict[str, GroupObservation]:
        n = self.num_worlds
        column = self.value[:, None, None].astype(np.float32)
        return {
            "a": GroupObservation(np.broadcast_to(column, (n, 2, 3)).copy(), np.zeros((n, 2, 5), np.float32)),
            "b": GroupObservation(np.broadcast_to(column, (n, 1, 2)).copy(), np.zeros((n, 1, 2), np.float32)),
        }  # fmt: skip

    def state(self) -> np.ndarray:
        return self.value[:, None].astype(np.float32)

    def render(self, world: int = 0) -> np.ndarray:
        return np.zeros((4, 4, 3), np.uint8)


# --- TorchRL -------------------------------------------------------------------------------
@pytest.mark.parametrize("num_envs", [1, 3, 16])
@pytest.mark.parametrize("extended_obs", [False, True])
def test_tennis_env_specs(num_envs: int, extended_obs: bool) -> None:
    env = make_env("tennis", num_envs=num_envs, seed=0, extended_obs=extended_obs)
    check_env_specs(env)
    td = env.rollout(4, break_when_any_done=False)
    d_w, d_m = (12, 14) if extended_obs else (8, 10)
    assert td["racket", "observation"].shape == (num_envs, 4, 4, d_w)
    assert td["racket", "observation"].dtype == torch.float32
    assert td["racket", "manager_observation"].shape == (num_envs, 4, 4, d_m)
    assert td["racket", "team"][0, 0].flatten().tolist() == [0, 0, 1, 1]
    assert td["racket", "action"].shape == (num_envs, 4, 4, 3)
    for key in ("reward", "done", "terminated", "truncated"):
        assert td["next", "racket", key].shape == (num_envs, 4, 4, 1)
    for key in ("done", "terminated", "truncated", "step_count", "scoring_team"):
        assert td["next", key].shape == (num_envs, 4, 1)


def test_discrete_groups_get_categorical_actions() -> None:
    env = BatchedGameEnv(CountdownGame(num_worlds=5, seed=0))
    check_env_specs(env)
    assert env.full_action_spec["a", "action"].shape == (5, 2)
    assert env.full_action_spec["b", "action"].n == 4
    td = env.rollout(6, break_when_any_done=False)
    assert td["b", "action"].shape == (5, 6, 1)
    assert td["b", "action"].dtype == torch.int64


def test_step_count_and_dones_follow_episodes() -> None:
    env = BatchedGameEnv(CountdownGame(num_worlds=4, seed=0, max_cycles=3))
    td = env.reset()
    assert td["step_count"].flatten().tolist() == [0, 0, 0, 0]
    actions = torch.zeros(4, 2, dtype=torch.int64)
    actions[1, 0] = 1  # world 1 ends at once, the others are truncated at step 3
    td.set(("a", "action"), actions)
    td.set(("b", "action"), torch.zeros(4, 1, dtype=torch.int64))
    out = env.step(td)
    nxt = out["next"]
    assert nxt["terminated"].flatten().tolist() == [False, True, False, False]
    assert nxt["a", "terminated"][1].flatten().tolist() == [True, True]
    assert nxt["a", "reward"][1].flatten().tolist() == [1.0, -1.0]
    assert nxt["scoring_team"].flatten().tolist() == [-1, 0, -1, -1]
    assert nxt["step_count"].flatten().tolist() == [1, 1, 1, 1]

    def never_end(td):
        td.set(("a", "action"), torch.zeros(4, 2, dtype=torch.int64))
        return td.set(("b", "action"), torch.zeros(4, 1, dtype=torch.int64))

    td = env.rollout(7, policy=never_end, break_when_any_done=False)
    truncated = td["next", "truncated"][0].flatten().tolist()
    assert truncated == [False, False, True, False, False, True, False]
    assert not td["next", "terminated"].any()
    assert td["step_count"][0].flatten().tolist() == [0, 1, 2, 0, 1, 2, 0]


def test_partial_reset_through_the_reset_mask() -> None:
    env = make_env("tennis", num_envs=4, seed=0)
    td = env.rollout(5, break_when_any_done=False)[..., -1]["next"].clone()
    mask = torch.tensor([[True], [False], [True], [False]])
    td.set("_reset", mask)
    before = td["racket", "observation"].clone()
    after = env.reset(td)
    keep = ~mask.flatten()
    torch.testing.assert_close(after["racket", "observation"][keep], before[keep])
    assert after["step_count"].flatten().tolist() == [0, 5, 0, 5]
    assert not torch.allclose(after["racket", "observation"][~keep], before[~keep])
    np.testing.assert_array_equal(env.game.step_count, [0, 5, 0, 5])


def test_seeding_reproduces_rollouts() -> None:
    def rollout(seed: int) -> torch.Tensor:
        env = make_env("tennis", num_envs=3)
        env.set_seed(seed)
        torch.manual_seed(0)
        return env.rollout(30, break_when_any_done=False)["next", "racket", "observation"]

    torch.testing.assert_close(rollout(5), rollout(5))
    assert not torch.allclose(rollout(5), rollout(6))


@pytest.mark.parametrize(
    ("action", "match"),
    [(torch.zeros(2, 4, 2), "racket"), (torch.full((2, 4, 3), float("nan")), "racket")],
)
def test_bad_torchrl_actions_name_the_group(action: torch.Tensor, match: str) -> None:
    env = make_env("tennis", num_envs=2, seed=0)
    td = env.reset()
    td.set(("racket", "action"), action)
    with pytest.raises(ValueError, match=match):
        env.step(td)


def test_missing_action_names_the_group() -> None:
    env = make_env("tennis", num_envs=2, seed=0)
    with pytest.raises(ValueError, match="racket"):
        env.step(env.reset())


# --- PettingZoo ------------------------------------------------------------------------------
@pytest.mark.parametrize("game", games())
def test_pettingzoo_parallel_api(game: str) -> None:
    parallel_api_test(make_parallel_env(game, seed=0, max_cycles=200), num_cycles=600)


@pytest.mark.parametrize("game", games())
def test_pettingzoo_seed(game: str) -> None:
    parallel_seed_test(lambda: make_parallel_env(game, max_cycles=200))


@pytest.mark.parametrize("game", games())
def test_pettingzoo_render_and_aec_api(game: str) -> None:
    render_test(lambda render_mode=None: make_aec_env(game, render_mode=render_mode))
    api_test(make_aec_env(game, max_cycles=100), num_cycles=200)
    frame = make_parallel_env(game, render_mode="rgb_array").render()
    assert frame is not None and frame.dtype == np.uint8 and frame.shape[2] == 3
    assert frame.std() > 0  # something is drawn


@pytest.mark.parametrize("game", games())
def test_each_game_package_offers_its_pettingzoo_envs(game: str) -> None:
    import importlib

    package = importlib.import_module(game_spec(game).game.__module__.rpartition(".")[0])
    parallel = package.parallel_env(max_cycles=3)
    assert type(parallel.game) is game_spec(game).game and parallel.game.max_cycles == 3
    assert package.env().possible_agents == make_aec_env(game).possible_agents


def test_pettingzoo_infos_state_and_episode_end() -> None:
    env = tennis_parallel_env(max_cycles=3, extended_obs=True)
    observations, infos = env.reset(seed=1)
    assert observations["racket_3"].shape == (12,)
    assert infos["racket_3"]["manager_observation"].shape == (14,)
    assert infos["racket_3"]["team"] == 1
    assert env.state().shape == env.state_space.shape == (24,)
    zero = {agent: np.zeros(3, np.float32) for agent in env.agents}
    for step in range(3):
        _, rewards, terminations, truncations, _ = env.step(zero)
        assert set(rewards) == set(env.possible_agents)
        assert all(truncations.values()) == (step == 2)
        assert not any(terminations.values())
    assert env.agents == []
    with pytest.raises(ValueError, match="reset"):
        env.step(zero)


def test_pettingzoo_bad_agents_are_named() -> None:
    env = tennis_parallel_env()
    env.reset(seed=0)
    actions = {agent: np.zeros(3, np.float32) for agent in env.agents}
    with pytest.raises(ValueError, match="racket_9"):
        env.step({**actions, "racket_9": np.zeros(3)})
    with pytest.raises(ValueError, match="racket_2"):
        env.step({agent: a for agent, a in actions.items() if agent != "racket_2"})
    with pytest.raises(ValueError, match="racket_1"):
        env.step({**actions, "racket_1": np.zeros(2)})
    with pytest.raises(ValueError, match="racket_9"):
        env.action_space("racket_9")


def test_pettingzoo_wraps_discrete_games_and_one_world_only() -> None:
    env = BatchedGameParallelEnv(CountdownGame(seed=0))
    parallel_api_test(env, num_cycles=50)
    assert env.action_space("b_0").n == 4
    with pytest.raises(ValueError, match="one world"):
        BatchedGameParallelEnv(make_game("tennis", num_envs=2))


@pytest.mark.parametrize("game", games())
def test_torchrl_pettingzoo_wrapper_accepts_the_parallel_env(game: str) -> None:
    """Info keys are the same at reset and step, so TorchRL's wrapper sizes its specs
    (before, it failed on the first step). No point can end within 3 steps of a serve or
    kick-off, so ``scoring_team`` is -1 throughout: the check is that the key is carried."""
    from torchrl.envs import PettingZooWrapper

    pettingzoo_env = make_parallel_env(game, max_cycles=5)
    first = pettingzoo_env.game.groups[0]  # tennis: racket (10); soccer: striker (200)
    group, manager_size = first.name, first.manager_observation_size
    env = PettingZooWrapper(pettingzoo_env, use_mask=True)
    rollout = env.rollout(3)
    assert rollout[group, "info", "manager_observation"].shape[-1] == manager_size
    assert (rollout["next", group, "info", "scoring_team"] == -1).all()


# --- decisions of several frames -----------------------------------------------------------
def test_a_decision_sums_its_frames_and_stops_paying_once_a_world_ends() -> None:
    game = CountdownGame(num_worlds=2, seed=0, max_cycles=3, decision_interval=3)
    # World 0: a_0 plays 1, the episode ends on the decision's first frame;
    # world 1 plays on for all three frames.
    actions = {"a": np.array([[1, 0], [0, 0]]), "b": np.array([[2], [3]])}
    outcome = game.step(actions)
    np.testing.assert_array_equal(outcome.terminated, [True, False])
    np.testing.assert_array_equal(outcome.rewards["b"], [[2.0], [9.0]])
    np.testing.assert_array_equal(outcome.rewards["a"], [[1.0, -1.0], [0.0, 0.0]])
    np.testing.assert_array_equal(outcome.scoring_team, [0, -1])
    np.testing.assert_array_equal(outcome.info["frames"], [1, 3])
    np.testing.assert_array_equal(game.step_count, [1, 1])  # decisions, not frames
    game.reset(np.array([True, False]))
    for _ in range(2):
        outcome = game.step({"a": np.zeros((2, 2), int), "b": np.zeros((2, 1), int)})
    # max_cycles counts decisions: world 1 is truncated after its third.
    np.testing.assert_array_equal(outcome.truncated, [False, True])


@pytest.mark.parametrize("interval", [0, -1, 1.5, True])
def test_a_bad_decision_interval_is_refused(interval: object) -> None:
    with pytest.raises(ValueError, match="decision_interval"):
        CountdownGame(num_worlds=1, decision_interval=interval)  # type: ignore[arg-type]
