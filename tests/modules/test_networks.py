"""Actors and critics built from specs: shapes, bounds, shared weights, bad input."""

from __future__ import annotations

import dataclasses

import pytest
import torch
from tensordict import TensorDict
from torch import nn
from torchrl.data import Bounded, Categorical, Composite, OneHot, Unbounded
from torchrl.modules import MultiAgentMLP

from rlhc.errors import ConfigError
from rlhc.modules import (
    EnvSpecs,
    NetworkConfig,
    make_actor,
    make_manager_critic,
    make_worker_critic,
)
from rlhc.modules.mlp import GroupMLP

CFG = NetworkConfig(num_layers=2, hidden_size=16)
N_WORLDS, STEPS = 5, 3


def specs(group: str, n_agents: int, action: object, d_w: int = 8, d_m: int = 10) -> EnvSpecs:
    """Specs with the env's batch dim ``[N_WORLDS]``, as a TorchRL env reports them."""
    obs = Composite(
        {
            group: Composite(
                observation=Unbounded((N_WORLDS, n_agents, d_w)),
                manager_observation=Unbounded((N_WORLDS, n_agents, d_m)),
                shape=(N_WORLDS, n_agents),
            )
        },
        shape=(N_WORLDS,),
    )
    act = Composite(
        {group: Composite(action=action, shape=(N_WORLDS, n_agents))}, shape=(N_WORLDS,)
    )
    return EnvSpecs(obs, act)


TENNIS = specs("racket", 4, Bounded(-1.0, 1.0, (N_WORLDS, 4, 3)))
STRIKER = specs("striker", 2, Categorical(6, (N_WORLDS, 2)), d_w=112, d_m=200)


def observations(group: str, n_agents: int, d_w: int = 8, d_m: int = 10) -> TensorDict:
    return TensorDict(
        {
            group: {
                "observation": 3 * torch.randn(N_WORLDS, STEPS, n_agents, d_w),
                "manager_observation": torch.randn(N_WORLDS, STEPS, n_agents, d_m),
            }
        },
        batch_size=(N_WORLDS, STEPS),
    )


def test_continuous_actor_shapes_and_bounds() -> None:
    actor = make_actor(TENNIS, "racket", CFG)
    td = actor(observations("racket", 4))
    action = td["racket", "action"]
    assert action.shape == (N_WORLDS, STEPS, 4, 3)
    assert td["racket", "action_log_prob"].shape == (N_WORLDS, STEPS, 4)
    assert action.abs().max() <= 1.0
    assert td["racket", "action_log_prob"].isfinite().all()


def test_continuous_actor_respects_asymmetric_bounds() -> None:
    low = torch.tensor([-2.0, 0.0, -0.5])
    high = torch.tensor([0.5, 1.0, 0.5])
    spec = Bounded(low.expand(N_WORLDS, 4, 3), high.expand(N_WORLDS, 4, 3), (N_WORLDS, 4, 3))
    # A squashing policy with a unit initial scale so that samples reach far
    # into the box, and a fixed seed: the check below looks at the sampled extremes.
    torch.manual_seed(0)
    wide = dataclasses.replace(CFG, action_dist="tanh_normal", initial_action_scale=1.0)
    actor = make_actor(specs("racket", 4, spec), "racket", wide)
    with torch.no_grad():
        action = actor(observations("racket", 4).expand(20, N_WORLDS, STEPS).clone())[
            "racket", "action"
        ]
    assert (action >= low).all() and (action <= high).all()
    # The squashing really spans the box, not [-1, 1] rescaled to part of it.
    assert (action.amin(dim=(0, 1, 2, 3)) < low + 0.5 * (high - low)).all()


def test_discrete_actor_matches_the_categorical_spec() -> None:
    actor = make_actor(STRIKER, "striker", CFG)
    td = actor(observations("striker", 2, 112, 200))
    action = td["striker", "action"]
    assert action.shape == (N_WORLDS, STEPS, 2)
    assert action.dtype == torch.int64
    assert ((action >= 0) & (action < 6)).all()
    assert td["striker", "logits"].shape == (N_WORLDS, STEPS, 2, 6)
    assert td["striker", "action_log_prob"].shape == (N_WORLDS, STEPS, 2)
    assert STRIKER.full_action_spec["striker", "action"].is_in(action[:, 0])


@pytest.mark.parametrize(
    ("make", "leaf", "d_w", "d_m"),
    [(make_worker_critic, "worker_value", 8, 10), (make_manager_critic, "manager_value", 8, 10)],
)
def test_critic_shapes(make: object, leaf: str, d_w: int, d_m: int) -> None:
    critic = make(TENNIS, "racket", CFG)  # type: ignore[operator]
    td = critic(observations("racket", 4, d_w, d_m))
    assert td["racket", leaf].shape == (N_WORLDS, STEPS, 4, 1)


def test_critics_read_their_own_observation() -> None:
    worker = make_worker_critic(TENNIS, "racket", CFG)
    manager = make_manager_critic(TENNIS, "racket", CFG)
    assert worker.in_keys == [("racket", "observation")]
    assert manager.in_keys == [("racket", "manager_observation")]


BUILDERS = {"actor": make_actor, "worker": make_worker_critic, "manager": make_manager_critic}


@pytest.mark.parametrize("name", BUILDERS)
def test_one_set_of_weights_whatever_the_number_of_agents(name: str) -> None:
    def n_params(n_agents: int) -> int:
        env = specs("racket", n_agents, Bounded(-1.0, 1.0, (N_WORLDS, n_agents, 3)))
        return sum(p.numel() for p in BUILDERS[name](env, "racket", CFG).parameters())

    assert n_params(2) == n_params(4) == n_params(7)


@pytest.mark.parametrize("name", BUILDERS)
def test_agents_are_interchangeable(name: str) -> None:
    # Shared weights: swapping two agents' inputs swaps their outputs.
    module = BUILDERS[name](TENNIS, "racket", CFG)
    key = {"actor": ("racket", "loc"), "worker": ("racket", "worker_value")}.get(
        name, ("racket", "manager_value")
    )
    order = [3, 1, 2, 0]
    td = observations("racket", 4)
    swapped = td.clone()
    for leaf in ("observation", "manager_observation"):
        swapped["racket", leaf] = td["racket", leaf][..., order, :]
    with torch.no_grad():
        first = module(td)[key]
        second = module(swapped)[key]
    torch.testing.assert_close(second, first[..., order, :])


def test_network_config_validation() -> None:
    assert NetworkConfig().activation_class is torch.nn.Tanh
    # The one error type of a bad setting, naming the key, the value and what is allowed.
    with pytest.raises(ConfigError, match=r"model\.activation='swish'; allowed: tanh, relu"):
        NetworkConfig(activation="swish")
    with pytest.raises(ConfigError, match=r"model\.num_layers=0; allowed: an integer >= 1"):
        NetworkConfig(num_layers=0)
    with pytest.raises(ConfigError, match=r"model\.hidden_size=0; allowed: an integer >= 1"):
        NetworkConfig(hidden_size=0)


def test_actor_view_chooses_the_observation_the_actor_reads() -> None:
    td = observations("racket", 4)
    worker = make_actor(TENNIS, "racket", CFG)
    manager = make_actor(TENNIS, "racket", dataclasses.replace(CFG, actor_view="manager"))
    assert worker.in_keys == [("racket", "observation")]
    assert manager.in_keys == [("racket", "manager_observation")]
    first = next(m for m in manager.modules() if isinstance(m, torch.nn.Linear))
    assert first.in_features == 10  # the manager's view, not the worker's 8
    with torch.no_grad():
        out = manager(td.exclude(("racket", "observation")))
    assert out["racket", "action"].shape == (N_WORLDS, STEPS, 4, 3)
    with pytest.raises(ConfigError, match=r"model\.actor_view='critic'; allowed: worker, manager"):
        NetworkConfig(actor_view="critic")


def test_config_sets_depth_and_width() -> None:
    critic = make_worker_critic(TENNIS, "racket", NetworkConfig(num_layers=3, hidden_size=32))
    linears = [m for m in critic.modules() if isinstance(m, torch.nn.Linear)]
    assert [lin.out_features for lin in linears] == [32, 32, 32, 1]


def test_unknown_group_names_the_groups() -> None:
    with pytest.raises(KeyError, match=r"no entry \('goalie', 'observation'\).*\['racket'\]"):
        make_worker_critic(TENNIS, "goalie", CFG)


def test_unsupported_action_spec() -> None:
    one_hot = specs("striker", 2, OneHot(6, (N_WORLDS, 2, 6)))
    with pytest.raises(TypeError, match=r"is OneHot.*expected Bounded"):
        make_actor(one_hot, "striker", CFG)


@pytest.mark.parametrize("activate_last_layer", [False, True])
def test_group_mlp_is_torchrls_shared_multi_agent_mlp_under_the_same_names(
    activate_last_layer: bool,
) -> None:
    # Checkpoints written with MultiAgentMLP(share_params=True) load into a GroupMLP,
    # and the two compute the same function of the same weights.
    shape = {"depth": 2, "num_cells": 16, "activation_class": nn.Tanh}
    torch.manual_seed(0)
    reference = MultiAgentMLP(
        n_agent_inputs=8,
        n_agent_outputs=3,
        n_agents=2,
        centralized=False,
        share_params=True,
        activate_last_layer=activate_last_layer,
        **shape,
    )
    torch.manual_seed(0)
    group = GroupMLP(8, 3, 2, activate_last_layer=activate_last_layer, **shape)
    state = reference.state_dict()
    assert list(group.state_dict()) == list(state)
    # The same draws from the same seed: runs seeded before and after are equal.
    assert all(torch.equal(group.state_dict()[k], v) for k, v in state.items())
    with torch.no_grad():
        for parameter in group.parameters():
            parameter.add_(1.0)
    group.load_state_dict(state)
    inputs = torch.randn(5, 3, 2, 8)
    torch.testing.assert_close(group(inputs), reference(inputs), rtol=0, atol=0)
    assert group.head is group.params[-2 if activate_last_layer else -1]
    assert group.head.out_features == 3


def test_group_mlp_names_a_wrong_agent_count() -> None:
    mlp = GroupMLP(8, 3, 2, depth=1, num_cells=4, activation_class=nn.Tanh)
    with pytest.raises(ValueError, match=r"2 agents.*\(5, 3, 8\)"):
        mlp(torch.randn(5, 3, 8))


def test_a_group_mlp_on_a_shared_input_is_torchrls_centralised_critic() -> None:
    # On the world view (every agent reads the group's observations in index order),
    # the shared-input GroupMLP runs once per world and equals MultiAgentMLP(centralized,
    # share_params), the critic of TorchRL's and BenchMARL's MAPPO, weights for weights.
    shape = {"depth": 2, "num_cells": 16, "activation_class": nn.Tanh}
    torch.manual_seed(0)
    reference = MultiAgentMLP(
        n_agent_inputs=8, n_agent_outputs=1, n_agents=3, centralized=True, share_params=True,
        **shape,
    )  # fmt: skip
    shared = GroupMLP(24, 1, 3, shared_input=True, **shape)
    shared.load_state_dict(reference.state_dict())
    observations = torch.randn(5, 3, 8)
    world = observations.flatten(-2).unsqueeze(-2).expand(5, 3, 24)
    torch.testing.assert_close(shared(world), reference(observations), rtol=0, atol=1e-6)


def test_a_shared_input_gives_the_values_and_gradients_of_running_each_agent() -> None:
    shape = {"depth": 2, "num_cells": 16, "activation_class": nn.Tanh}
    each = GroupMLP(24, 1, 3, **shape)
    once = GroupMLP(24, 1, 3, shared_input=True, **shape)
    once.load_state_dict(each.state_dict())
    world = torch.randn(5, 1, 24).expand(5, 3, 24)
    target = torch.randn(5, 3, 1)  # per-agent targets: the agents' terms still differ
    gradients = []
    for mlp in (each, once):
        value = mlp(world)
        ((value - target) ** 2).mean().backward()
        gradients.append([p.grad for p in mlp.parameters()])
        torch.testing.assert_close(value, each(world), rtol=0, atol=0)
    for a, b in zip(*gradients, strict=True):
        torch.testing.assert_close(a, b, rtol=1e-6, atol=1e-6)
