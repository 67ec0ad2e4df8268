"""The continuous policy parametrisations (``model.action_dist``): entropy, log-probs, KL.

Closed forms where they exist (a Normal's entropy and log-density), and the property a
PPO update depends on: the log-probability the loss rebuilds from a stored action is
the one the actor wrote when it sampled it, so an update with a learning rate of 0
measures a KL of exactly 0.
"""

from __future__ import annotations

import dataclasses
import math
import sys
from pathlib import Path

import pytest
import torch
from tensordict import TensorDict
from tensordict.nn import InteractionType, set_interaction_type
from torch.testing import assert_close
from torchrl.modules import TanhNormal

from rlhc.modules import NetworkConfig, make_actor, make_manager_critic, make_worker_critic
from rlhc.modules.actors import PreTanhNormal, scored_policy
from rlhc.modules.schemas import ACTION_DISTRIBUTIONS
from rlhc.objectives import LOSS_KEYS, make_ppo_loss

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "objectives"))
from rlhc_synthetic import D_WORKER, GROUP, make_batch, make_specs

CFG = NetworkConfig(
    num_layers=2,
    hidden_size=16,
    action_dist="tanh_normal",
    initial_action_scale=0.5,
    head_init_scale=1.0,
)
GAUSSIAN = dataclasses.replace(
    CFG, action_dist="gaussian", initial_action_scale=1.0, head_init_scale=0.01, pre_clip_range=1.0
)


@pytest.fixture(autouse=True)
def sampling() -> object:
    """Actions drawn from the distribution, as the collector draws them (not the mode)."""
    with set_interaction_type(InteractionType.RANDOM):
        yield


def observations(n: int = 64, scale: float = 1.0) -> TensorDict:
    gen = torch.Generator().manual_seed(1)
    obs = scale * torch.randn(n, 4, D_WORKER, generator=gen)
    return TensorDict({(GROUP, "observation"): obs}, batch_size=[n])


def test_gaussian_starts_as_ml_agents_does() -> None:
    torch.manual_seed(0)
    actor = make_actor(make_specs(), GROUP, GAUSSIAN)
    with torch.no_grad():
        td = actor(observations())
    # A learned scale per action dimension, the same in every state and for every agent.
    assert_close(td[GROUP, "scale"], torch.ones_like(td[GROUP, "scale"]))
    # The mean head at 1 % of its usual initial weights: every mean starts near 0.
    reference = make_actor(make_specs(), GROUP, CFG)
    with torch.no_grad():
        wide = reference(observations())[GROUP, "loc"].abs().mean()
    assert td[GROUP, "loc"].abs().mean() < 0.05 * wide
    names = [name for name, _ in actor.named_parameters()]
    assert sum("state_independent_scale" in name for name in names) == 1


def test_gaussian_entropy_and_log_prob_are_the_closed_forms() -> None:
    torch.manual_seed(0)
    actor = make_actor(make_specs(), GROUP, dataclasses.replace(GAUSSIAN, initial_action_scale=0.3))
    with torch.no_grad():
        td = actor(observations())
        dist = actor.get_dist(td)
    loc, scale, action = td[GROUP, "loc"], td[GROUP, "scale"], td[GROUP, "action"]
    # Independent over the 3 action dimensions: sums of the 1-d closed forms.
    entropy = (0.5 * torch.log(2 * math.pi * math.e * scale**2)).sum(-1)
    assert_close(dist.entropy(), entropy)
    assert_close(
        dist.entropy()[0, 0],
        torch.tensor(3 * (0.5 * math.log(2 * math.pi * math.e) + math.log(0.3))),
    )
    density = (
        -((action - loc) ** 2) / (2 * scale**2) - torch.log(scale) - 0.5 * math.log(2 * math.pi)
    ).sum(-1)
    assert_close(td[GROUP, "action_log_prob"], density)


def test_gaussian_actions_are_not_squashed() -> None:
    # The env clips: the stored sample is the policy's own, outside [-1, 1] too.
    torch.manual_seed(0)
    actor = make_actor(make_specs(), GROUP, dataclasses.replace(GAUSSIAN, initial_action_scale=2.0))
    with torch.no_grad():
        action = actor(observations(256))[GROUP, "action"]
    assert action.abs().max() > 1.5


@pytest.mark.parametrize("action_dist", ACTION_DISTRIBUTIONS)
def test_stored_actions_score_as_they_were_sampled(action_dist: str) -> None:
    # Both score what they stored exactly: the Gaussian its sample, the TanhNormal its
    # pre-tanh draw (the squashed action is never rescored through atanh).
    torch.manual_seed(0)
    actor = make_actor(make_specs(), GROUP, dataclasses.replace(CFG, action_dist=action_dist))
    draw = scored_policy(actor)  # the actor, or tanh_normal's pre-tanh draw
    (sample,), (log_prob,) = draw.dist_sample_keys, draw.log_prob_keys
    with torch.no_grad():
        td = actor(observations(scale=5.0))
        rescored = draw.get_dist(td).log_prob(td[sample])
    assert action_dist == "gaussian" or td[GROUP, "action"].abs().max() <= 1.0  # squashed
    assert torch.equal(rescored, td[log_prob])


def test_the_exact_tanh_normal_scores_saturated_actions_as_drawn() -> None:
    # Where TorchRL's TanhNormal rescores an action through atanh thousands of nats off
    # (loc 12, scale 0.05), the pre-tanh draw scores exactly, and its ratio is TanhNormal's:
    # log pi'(a) - log pi(a) = log N'(u) - log N(u), the Jacobian cancelling.
    torch.manual_seed(0)
    loc, scale = torch.full((1000, 3), 12.0), torch.full((1000, 3), 0.05)
    plain = TanhNormal(loc, scale, low=-1.0, high=1.0)
    action, drawn = plain.sample_and_log_prob()
    assert (plain.log_prob(action) - drawn).abs().max() > 1000
    exact = PreTanhNormal(loc, scale)
    u = exact.sample()
    assert torch.equal(exact.log_prob(u), exact.log_prob(u.clone()))
    squashed = TanhNormal(loc, scale, low=-1.0, high=1.0)
    moved = PreTanhNormal(loc + 0.01, scale * 1.1)
    moved_squashed = TanhNormal(loc + 0.01, scale * 1.1, low=-1.0, high=1.0)
    # TanhNormal's own density of the same draw, had it kept u (its base is over u).
    assert_close(exact.log_prob(u), squashed.base_dist.log_prob(u))
    assert_close(
        moved.log_prob(u) - exact.log_prob(u),
        moved_squashed.base_dist.log_prob(u) - squashed.base_dist.log_prob(u),
    )
    # The squashed action's entropy: the Normal's less the expected log-Jacobian; far
    # into saturation it is very negative, near 0 it is the Normal's less ~log 1.
    saturated = PreTanhNormal(loc, scale).entropy()
    centred = PreTanhNormal(torch.zeros(1000, 3), torch.full((1000, 3), 0.05)).entropy()
    normal = torch.distributions.Normal(0.0, 0.05).entropy() * 3
    assert (saturated < normal - 50).all()
    assert_close(centred.mean(), normal, atol=0.02, rtol=0)


@pytest.mark.parametrize("action_dist", ACTION_DISTRIBUTIONS)
def test_an_update_with_zero_learning_rate_has_zero_kl(action_dist: str) -> None:
    torch.manual_seed(0)
    specs, cfg = make_specs(), dataclasses.replace(CFG, action_dist=action_dist)
    loss = make_ppo_loss(
        actor=make_actor(specs, GROUP, cfg),
        worker_critic=make_worker_critic(specs, GROUP, cfg),
        manager_critic=make_manager_critic(specs, GROUP, cfg),
        group=GROUP,
    )
    data = make_batch()
    with torch.no_grad():
        loss.actor_network(data)
        loss.value_estimator(data)
    optimizer = torch.optim.Adam(loss.parameters(), lr=0.0)
    for _ in range(3):
        out = loss(data)
        optimizer.zero_grad()
        sum(out[key] for key in LOSS_KEYS).backward()
        optimizer.step()
        assert out["kl_approx"].item() == 0.0
        assert out["clip_fraction"].item() == 0.0


@pytest.mark.parametrize("action_dist", ACTION_DISTRIBUTIONS)
def test_actor_state_round_trips(action_dist: str, tmp_path: Path) -> None:
    cfg = dataclasses.replace(CFG, action_dist=action_dist, initial_action_scale=0.7)
    torch.manual_seed(0)
    trained = make_actor(make_specs(), GROUP, cfg)
    with torch.no_grad():
        for parameter in trained.parameters():
            parameter.add_(0.1 * torch.randn_like(parameter))
    torch.save(trained.state_dict(), tmp_path / "actor.pt")
    torch.manual_seed(1)
    restored = make_actor(make_specs(), GROUP, cfg)
    restored.load_state_dict(torch.load(tmp_path / "actor.pt"))
    td = observations()
    with torch.no_grad():
        for key in ("loc", "scale"):
            assert torch.equal(trained(td.clone())[GROUP, key], restored(td.clone())[GROUP, key])


def test_bad_settings_name_the_value() -> None:
    with pytest.raises(ValueError, match=r"model.action_dist='beta'; allowed: gaussian"):
        NetworkConfig(action_dist="beta")
    with pytest.raises(ValueError, match=r"model.head_init_scale=0.0; allowed"):
        NetworkConfig(head_init_scale=0.0)
    with pytest.raises(ValueError, match=r"model.pre_clip_range=-1.0; allowed"):
        NetworkConfig(pre_clip_range=-1.0)


def test_the_training_config_reaches_the_networks() -> None:
    # Every network setting of the ``model`` section is passed on to the builders.
    from rlhc.building.builders import network_config
    from rlhc.config.train_schema import ModelConfig, TrainConfig

    model = ModelConfig(
        num_layers=1,
        hidden_size=8,
        activation="silu",
        action_dist="gaussian",
        initial_action_scale=0.7,
        head_init_scale=0.02,
        pre_clip_range=2.0,
    )
    built = network_config(TrainConfig(model=model))
    for field in dataclasses.fields(NetworkConfig):
        assert getattr(built, field.name) == getattr(model, field.name), field.name


def test_pre_clip_range_is_ml_agents_scaling() -> None:
    # ML-Agents 0.5 plays clip(u, -3, 3) / 3 with u ~ N(mu, 1): in action units a Normal
    # of scale 1/3 around mu / 3, whose samples are those of range 1 divided by 3.
    wide = dataclasses.replace(GAUSSIAN, pre_clip_range=1.0)
    ml_agents = dataclasses.replace(GAUSSIAN, pre_clip_range=3.0)
    torch.manual_seed(0)
    reference = make_actor(make_specs(), GROUP, wide)
    torch.manual_seed(0)
    scaled = make_actor(make_specs(), GROUP, ml_agents)
    td = observations()
    torch.manual_seed(5)
    with torch.no_grad():
        a = reference(td.clone())
    torch.manual_seed(5)
    with torch.no_grad():
        b = scaled(td.clone())
    assert_close(b[GROUP, "scale"], torch.full_like(b[GROUP, "scale"], 1 / 3))
    assert_close(b[GROUP, "loc"], a[GROUP, "loc"] / 3)
    assert_close(b[GROUP, "action"], a[GROUP, "action"] / 3)
    # The log-density of the same draw differs by the constant log 3 per dimension.
    assert_close(b[GROUP, "action_log_prob"], a[GROUP, "action_log_prob"] + 3 * math.log(3))
