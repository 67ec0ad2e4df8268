"""The optimism control ``critic=twin``: max of two local critics, no broader view."""

from __future__ import annotations

from pathlib import Path

import pytest
import torch
from configs import load, load_smoke

from rlhc.building.builders import make_agents, make_training_env
from rlhc.envs import games
from rlhc.envs.keys import MANAGER_OBSERVATION, MANAGER_VALUE, OBSERVATION


@pytest.mark.parametrize("game", games())
def test_the_twin_critic_reads_the_workers_own_observation(game: str) -> None:
    cfg = load(f"env={game}", "critic=twin")
    env = make_training_env(cfg, num_envs=2, seed=0)
    _, losses = make_agents(cfg, env)
    data = env.reset()
    for group, loss in losses.items():
        estimator = loss.value_estimator
        worker, twin = estimator.worker_value_network, estimator.manager_value_network
        assert list(twin.in_keys) == [(group, OBSERVATION)] == list(worker.in_keys)
        # Two networks of the same shape, initialised independently.
        worker_weights = [p.detach() for p in worker.parameters()]
        twin_weights = [p.detach() for p in twin.parameters()]
        assert [w.shape for w in worker_weights] == [w.shape for w in twin_weights]
        assert any(not torch.equal(a, b) for a, b in zip(worker_weights, twin_weights, strict=True))
        # The manager's broader view does not reach it.
        with torch.no_grad():
            before = twin(data.clone())[group, MANAGER_VALUE]
            scrambled = data.clone()
            view = scrambled[group, MANAGER_OBSERVATION]
            scrambled[group, MANAGER_OBSERVATION] = torch.randn_like(view) * 10
            after = twin(scrambled)[group, MANAGER_VALUE]
        torch.testing.assert_close(before, after)


def test_rlhc_keeps_the_manager_view() -> None:
    cfg = load("env=soccer", "critic=hierarchical")
    _, losses = make_agents(cfg, make_training_env(cfg, num_envs=1, seed=0))
    for group, loss in losses.items():
        manager = loss.value_estimator.manager_value_network
        assert list(manager.in_keys) == [(group, MANAGER_OBSERVATION)]


def test_a_twin_run_trains(tmp_path: Path) -> None:
    from rlhc.training.trainer import Trainer

    metrics = Trainer(
        load_smoke("env=soccer", "critic=twin", "logger.backends=[csv]"), tmp_path
    ).train()
    assert metrics["frames"] == 512
    # The max picks the second critic on some experiences and the first on others.
    assert 0.0 < metrics["striker/manager_selected"] < 1.0
