"""The learning core on real rollouts of the games (tennis: continuous; soccer: discrete)."""

from __future__ import annotations

import pytest
import torch
from tensordict import TensorDictBase
from tensordict.nn import TensorDictSequential
from torch.testing import assert_close
from torchrl.data import Composite

from rlhc.envs import games
from rlhc.modules import NetworkConfig, make_actor, make_manager_critic, make_worker_critic
from rlhc.objectives import LOSS_KEYS, HierarchicalPPOLoss, make_ppo_loss

GAMMA = 0.9


def make_losses(env: object, fusion: str) -> dict[str, HierarchicalPPOLoss]:
    cfg = NetworkConfig(hidden_size=32)
    groups = [key for key, spec in env.full_action_spec.items() if isinstance(spec, Composite)]  # type: ignore[attr-defined]
    torch.manual_seed(0)
    return {
        group: make_ppo_loss(
            actor=make_actor(env, group, cfg),  # type: ignore[arg-type]
            worker_critic=make_worker_critic(env, group, cfg),  # type: ignore[arg-type]
            manager_critic=make_manager_critic(env, group, cfg),  # type: ignore[arg-type]
            group=group,
            gamma=GAMMA,
            fusion=fusion,
            manager_interval=3,
        )
        for group in groups
    }


def rollout(name: str, fusion: str) -> tuple[TensorDictBase, dict[str, HierarchicalPPOLoss]]:
    envs = pytest.importorskip("rlhc.envs")
    try:
        env = envs.make_env(name, num_envs=4, seed=0, max_cycles=10)
    except (ImportError, NotImplementedError) as error:  # the game is not written yet
        pytest.skip(f"{name} env unavailable: {error}")
    losses = make_losses(env, fusion)
    policy = TensorDictSequential(*(loss.actor_network for loss in losses.values()))
    with torch.no_grad():
        data = env.rollout(25, policy, break_when_any_done=False)
    return data, losses


@pytest.mark.parametrize("name", games())
def test_estimate_and_update_on_a_rollout(name: str) -> None:
    data, losses = rollout(name, fusion="max")
    # max_cycles = 10 over 25 steps: every world is truncated at least twice.
    assert data["next", "truncated"].any()
    for group, loss in losses.items():
        with torch.no_grad():
            loss.value_estimator(data)
        n_agents = data[group, "observation"].shape[-2]
        for leaf in ("advantage", "value_target", "state_value", "manager_selected"):
            value = data[group, leaf]
            assert value.shape == (4, 25, n_agents, 1), (group, leaf)
            assert value.isfinite().all(), (group, leaf)
        share = data[group, "manager_selected"]
        assert ((share == 0) | (share == 1)).all()
        # manager_interval = 3: the manager is never consulted off the 3-step grid.
        off_grid = (data["step_count"] % 3 != 0).unsqueeze(-2).expand_as(share)
        assert (share[off_grid] == 0).all()

    optimiser = torch.optim.Adam([p for loss in losses.values() for p in loss.parameters()])
    flat = data.reshape(-1)
    total = sum(sum(out[k] for k in LOSS_KEYS) for out in (loss(flat) for loss in losses.values()))
    optimiser.zero_grad()
    total.backward()  # type: ignore[union-attr]
    optimiser.step()


def test_real_episode_ends_bootstrap_as_specified() -> None:
    # Where an agent's episode ends, the trace is cut, so A_t is one TD error:
    # terminated: A_t = r_t - V_hat(s_t); truncated: A_t = r_t + gamma V_hat(s_{t+1}) - V_hat(s_t).
    data, losses = rollout("tennis", fusion="local")
    loss = losses["racket"]
    with torch.no_grad():
        loss.value_estimator(data)
    nxt = data["next", "racket"]
    value, next_value = data["racket", "state_value"], nxt["worker_value"]
    reward, terminated, truncated = nxt["reward"], nxt["terminated"], nxt["truncated"]
    advantage = data["racket", "advantage"]
    assert truncated.any()
    assert_close(advantage[truncated], (reward + GAMMA * next_value - value)[truncated])
    if terminated.any():  # a point was won within the rollout
        assert_close(advantage[terminated], (reward - value)[terminated])
