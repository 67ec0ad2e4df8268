"""``model.shared_trunk``: the soccer actor and worker critic on one trunk, trained by both.

The trunk must be one set of ``Parameter`` objects held by the actor, the worker
critic, the PPO loss and the optimiser; both the clipped policy term and the critic
term must send it gradient; tennis (continuous actions) must refuse the option; and a
checkpoint must rebuild the same policy.
"""

from __future__ import annotations

import math
from pathlib import Path

import pytest
import torch
from configs import load_smoke
from tensordict import TensorDictBase
from tensordict.nn import TensorDictSequential
from torchrl.data import Bounded, Categorical, Composite, Unbounded
from torchrl.envs.utils import ExplorationType, set_exploration_type

from rlhc.building.builders import ConfigError, make_agents, make_training_env
from rlhc.building.flops import (
    FLOP_PER_MAC,
    FORWARD_BACKWARD,
    linear_macs,
    network_flops,
    training_flops,
)
from rlhc.envs import make_env
from rlhc.evaluation.policies import restore_policy
from rlhc.modules import EnvSpecs, NetworkConfig, make_actor, make_actor_value, make_worker_critic
from rlhc.objectives import LOSS_KEYS, HierarchicalPPOLoss
from rlhc.storage.checkpoint import load_checkpoint
from rlhc.training.trainer import Trainer

GROUPS = ("striker", "goalie")


def shared_soccer(*overrides: str) -> tuple[dict, dict[str, HierarchicalPPOLoss], TensorDictBase]:
    """Actors and losses of the soccer smoke config with a shared trunk, and a rollout
    of 4 worlds x 16 decisions with the advantage already estimated."""
    torch.manual_seed(0)
    cfg = load_smoke("env=soccer", "model.shared_trunk=true", *overrides)
    env = make_training_env(cfg, num_envs=4, seed=0)
    actors, losses = make_agents(cfg, env)
    with torch.no_grad():
        batch = env.rollout(16, TensorDictSequential(*actors.values()), break_when_any_done=False)
        for loss in losses.values():
            loss.value_estimator(batch)
    env.close()
    return actors, losses, batch


def trunk(module: torch.nn.Module) -> list[torch.nn.Parameter]:
    """The trunk parameters of a shared-trunk actor or worker critic (its first module)."""
    return list(module.module[0].parameters())  # type: ignore[index]


def test_actor_critic_loss_and_estimator_hold_the_same_trunk_parameters() -> None:
    actors, losses, _ = shared_soccer()
    for group in GROUPS:
        actor, loss = actors[group], losses[group]
        worker_critic = loss.value_estimator.worker_value_network
        shared = trunk(actor)
        assert shared and all(a is c for a, c in zip(shared, trunk(worker_critic), strict=True))
        critic_params = {id(p) for p in loss.critic_network_params.values(True, True)}
        actor_params = {id(p) for p in loss.actor_network_params.values(True, True)}
        # The loss keeps the shared tensors as the actor's Parameters (no detached copy).
        assert {id(p) for p in shared} <= critic_params & actor_params
        assert actor_params & critic_params == {id(p) for p in shared}  # heads stay apart
        manager = loss.value_estimator.manager_value_network
        assert not {id(p) for p in manager.parameters()} & actor_params
        assert len(list(loss.parameters())) == len({id(p) for p in loss.parameters()})


def test_policy_and_critic_terms_both_send_the_trunk_gradient() -> None:
    actors, losses, batch = shared_soccer()
    for group in GROUPS:
        out = losses[group](batch)
        shared = trunk(actors[group])
        policy_head = list(actors[group].module[1].parameters())
        for term in ("loss_objective", "loss_critic"):
            grads = torch.autograd.grad(out[term], shared, retain_graph=True)
            assert all(torch.isfinite(g).all() for g in grads), (group, term)
            assert all(g.abs().sum() > 0 for g in grads), (group, term)
        # ... and the critic term stops at the trunk: the policy head gets none of it.
        unused = torch.autograd.grad(
            out["loss_critic"], policy_head, retain_graph=True, allow_unused=True
        )
        assert all(g is None for g in unused)


def test_one_optimiser_step_moves_the_one_trunk_of_actor_and_critic() -> None:
    actors, losses, batch = shared_soccer()
    # As Trainer._parameters: every parameter of every loss, once.
    parameters = list({id(p): p for loss in losses.values() for p in loss.parameters()}.values())
    optimizer = torch.optim.Adam(parameters, lr=1e-3)
    before = {g: [p.detach().clone() for p in trunk(actors[g])] for g in GROUPS}
    total = sum(
        (losses[g](batch)[term].sum() for g in GROUPS for term in LOSS_KEYS), torch.zeros(())
    )
    optimizer.zero_grad()
    total.backward()
    optimizer.step()
    for group in GROUPS:
        critic = losses[group].value_estimator.worker_value_network
        for old, actor_p, critic_p in zip(
            before[group], trunk(actors[group]), trunk(critic), strict=True
        ):
            assert not torch.equal(old, actor_p)
            torch.testing.assert_close(actor_p, critic_p, rtol=0, atol=0)
        # Both operators compute the same features after the step.
        with torch.no_grad():
            features = actors[group](batch.clone())[group, "hidden"]
            torch.testing.assert_close(critic(batch.clone())[group, "hidden"], features)


def test_tennis_refuses_a_shared_trunk_naming_the_value(tmp_path: Path) -> None:
    cfg = load_smoke("env=tennis", "model.shared_trunk=true")
    with pytest.raises(ConfigError) as refused:
        Trainer(cfg, tmp_path)
    message = str(refused.value)
    assert "model.shared_trunk=true" in message and "'tennis'" in message
    assert "Bounded" in message and "allowed: false" in message
    assert not (tmp_path / "metrics.csv").exists()


def test_networks_refuse_a_shared_trunk_without_discrete_actions() -> None:
    obs = Composite(racket=Composite(observation=Unbounded((4, 8)), shape=(4,)))
    act = Composite(racket=Composite(action=Bounded(-1.0, 1.0, (4, 3)), shape=(4,)))
    cfg = NetworkConfig(hidden_size=8, shared_trunk=True)
    with pytest.raises(ValueError, match=r"'racket' has a Bounded\w* action spec"):
        make_actor_value(EnvSpecs(obs, act), "racket", cfg)
    with pytest.raises(ValueError, match="make_actor_value"):
        make_worker_critic(EnvSpecs(obs, act), "racket", cfg)


def test_default_networks_keep_their_parameter_names() -> None:
    """Checkpoints of separate networks (the default) still load."""
    obs = Composite(striker=Composite(observation=Unbounded((2, 8)), shape=(2,)))
    act = Composite(striker=Composite(action=Categorical(6, (2,)), shape=(2,)))
    names = list(make_actor(EnvSpecs(obs, act), "striker", NetworkConfig()).state_dict())
    assert names == [f"module.0.module.params.{i}.{p}" for i in (0, 2, 4) for p in ("weight", "bias")]  # fmt: skip


@pytest.fixture(scope="module")
def trained(tmp_path_factory: pytest.TempPathFactory) -> tuple[Trainer, Path]:
    """Two updates of the soccer smoke run with a shared trunk (a few seconds)."""
    run_dir = tmp_path_factory.mktemp("shared_trunk")
    cfg = load_smoke(
        "env=soccer", "model.shared_trunk=true", "algo.max_steps=512", "logger.backends=[csv]"
    )
    trainer = Trainer(cfg, run_dir)
    trainer.train()
    return trainer, run_dir


def test_two_updates_on_soccer_train_the_shared_trunk(trained: tuple[Trainer, Path]) -> None:
    trainer, run_dir = trained
    lines = (run_dir / "metrics.csv").read_text().splitlines()
    header, rows = lines[0].split(","), [line.split(",") for line in lines[1:]]
    assert len(rows) == 2
    for row in rows:
        values = {k: float(v) for k, v in zip(header, row, strict=True) if v}
        assert all(math.isfinite(v) for v in values.values()), values
        assert values["striker/loss_critic"] > 0 and values["goalie/entropy"] > 0
    ids = [id(p) for p in trainer.parameters]
    assert len(ids) == len(set(ids))
    for group in GROUPS:
        shared = {id(p) for p in trunk(trainer.actors[group])}
        assert shared <= set(ids)


def test_checkpoint_restores_the_shared_trunk_policy(trained: tuple[Trainer, Path]) -> None:
    trainer, run_dir = trained
    state = load_checkpoint(run_dir)
    assert state["config"]["model"]["shared_trunk"] is True
    env = make_env("soccer", num_envs=3, seed=1)
    policy = restore_policy(state, env)
    observations = env.reset()
    with set_exploration_type(ExplorationType.DETERMINISTIC), torch.no_grad():
        restored = policy(observations)
        for group in GROUPS:
            live = trainer.actors[group].eval()(observations.clone())
            torch.testing.assert_close(restored[group], live[group, "action"])
            again = policy.actors[group](observations.clone())
            torch.testing.assert_close(again[group, "logits"], live[group, "logits"])
    env.close()


def test_network_flops_counts_linear_layers_per_world_decision() -> None:
    for shared in ("false", "true"):
        cfg = load_smoke("env=soccer", f"model.shared_trunk={shared}", "model.num_layers=2")
        flops = network_flops(cfg)
        h = cfg.model.hidden_size
        env = make_env("soccer", num_envs=1, seed=0)
        for group in GROUPS:
            n, d_w = env.full_observation_spec[group, "observation"].shape[-2:]
            d_m = env.full_observation_spec[group, "manager_observation"].shape[-1]
            actions = env.full_action_spec[group, "action"].space.n
            per_agent = {
                "actor": d_w * h + h * h + h * actions,
                "worker_critic": d_w * h + h * h + h,
                "manager_critic": d_m * h + h * h + h,
            }
            counted = flops[group]
            assert counted.agents == n == 2
            for name, macs in per_agent.items():
                assert getattr(counted, name) == FLOP_PER_MAC * n * macs, (shared, name)
        cost = training_flops(cfg)
        actors = sum(f.actor for f in flops.values())
        critics = sum(f.critics for f in flops.values())
        assert cost.collection == actors
        # The estimator runs the critics once per observation.
        assert cost.update == critics + cfg.algo.epochs * FORWARD_BACKWARD * (actors + critics)
        env.close()
    # PPO leaves the manager critic out of the arithmetic, as out of the update.
    ppo = network_flops(load_smoke("env=soccer", "critic=ppo"))
    assert all(group.manager_critic == 0 < group.worker_critic for group in ppo.values())
    kept = network_flops(load_smoke("env=soccer", "critic=ppo", "critic.manager_diagnostics=true"))
    assert all(group.manager_critic > 0 for group in kept.values())
    assert linear_macs(torch.nn.Linear(3, 5)) == 15
