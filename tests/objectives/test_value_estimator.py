"""``HierarchicalValueEstimator`` on TensorDicts: TorchRL parity, loops, closed forms."""

from __future__ import annotations

import re
from collections.abc import Callable

import pytest
import torch
from reference_gae import hierarchical_gae
from rlhc_synthetic import GROUP, constant_critic, loop_gae, make_batch
from tensordict import TensorDict
from tensordict.nn import TensorDictModule
from torch.testing import assert_close
from torchrl.objectives.value import GAE, MultiAgentGAE

from rlhc.objectives import FUSIONS, HierarchicalValueEstimator


def estimator(worker: TensorDictModule, manager: TensorDictModule, **kwargs: object):
    options: dict = {"gamma": 0.99, "lmbda": 0.95, "group": GROUP, **kwargs}
    return HierarchicalValueEstimator(
        worker_value_network=worker, manager_value_network=manager, **options
    )


def torchrl_gae(cls: type[GAE], worker: TensorDictModule, **keys: object) -> GAE:
    gae = cls(gamma=0.99, lmbda=0.95, value_network=worker)
    gae.set_keys(
        value=(GROUP, "worker_value"),
        advantage=(GROUP, "torchrl_advantage"),
        value_target=(GROUP, "torchrl_value_target"),
        **keys,
    )
    return gae


@pytest.mark.parametrize("batch", [(3,), (2, 3)], ids=["[N,T]", "[B,N,T]"])
def test_local_fusion_equals_torchrl_gae(networks: Callable, batch: tuple[int, ...]) -> None:
    _, worker, manager = networks()
    data = make_batch(batch=batch)
    estimator(worker, manager, fusion="local")(data)
    gae = torchrl_gae(
        GAE,
        worker,
        reward=(GROUP, "reward"),
        done=(GROUP, "done"),
        terminated=(GROUP, "terminated"),
    )
    gae(data)
    assert_close(data[GROUP, "advantage"], data[GROUP, "torchrl_advantage"])
    assert_close(data[GROUP, "value_target"], data[GROUP, "torchrl_value_target"])
    assert_close(data[GROUP, "state_value"], data[GROUP, "worker_value"], rtol=0, atol=0)


def test_local_fusion_equals_multiagent_gae_with_team_signals(networks: Callable) -> None:
    # Team-shared reward and ends of episodes ([N, T, 1]), broadcast over the agents.
    _, worker, manager = networks()
    data = make_batch()
    for leaf in ("reward", "done", "terminated"):
        data["next", leaf] = data["next", GROUP, leaf][..., 0, :]
        del data["next", GROUP, leaf]
    ours = estimator(worker, manager, fusion="local")
    ours.set_keys(reward="reward", done="done", terminated="terminated")
    ours(data)
    torchrl_gae(MultiAgentGAE, worker)(data)
    assert_close(data[GROUP, "advantage"], data[GROUP, "torchrl_advantage"])
    assert_close(data[GROUP, "value_target"], data[GROUP, "torchrl_value_target"])


def test_max_fusion_matches_plain_loop(networks: Callable) -> None:
    _, worker, manager = networks()
    data = make_batch(batch=(2, 3), steps=9, p_terminated=0.2, p_truncated=0.2, seed=3)
    estimator(worker, manager, fusion="max")(data)
    with torch.no_grad():
        nxt = data["next"]
        worker(nxt)
        manager(nxt)
    value = torch.maximum(data[GROUP, "worker_value"], data[GROUP, "manager_value"])
    next_value = torch.maximum(nxt[GROUP, "worker_value"], nxt[GROUP, "manager_value"])
    expected = loop_gae(
        0.99,
        0.95,
        value,
        next_value,
        nxt[GROUP, "reward"],
        nxt[GROUP, "done"],
        nxt[GROUP, "terminated"],
        time_dim=2,
    )
    assert_close(data[GROUP, "state_value"], value, rtol=0, atol=0)
    assert_close(data[GROUP, "advantage"], expected)
    assert_close(data[GROUP, "value_target"], expected + value)
    manager_wins = data[GROUP, "manager_value"] > data[GROUP, "worker_value"]
    assert_close(data[GROUP, "manager_selected"], manager_wins.float(), rtol=0, atol=0)
    # Random critics: each wins somewhere, so the max really mixes the two.
    assert 0 < manager_wins.float().mean() < 1


@pytest.mark.parametrize("interval", [1, 3])
@pytest.mark.parametrize("fusion", FUSIONS)
def test_the_estimator_equals_the_functional_reference(
    networks: Callable, fusion: str, interval: int
) -> None:
    # The reference (tests/objectives/reference_gae.py) fuses and runs GAE on plain
    # tensors; it is itself checked against the plain loop and closed forms.
    _, worker, manager = networks()
    data = make_batch(batch=(2, 3), steps=9, p_terminated=0.2, p_truncated=0.2, seed=4)
    # The diagnostics: "local" writes V_m too, "manager" V_w, which the reference reads.
    estimator(
        worker, manager, fusion=fusion, weight=0.3, manager_interval=interval,
        manager_diagnostics=True, worker_diagnostics=True,
    )(data)  # fmt: skip
    nxt = data["next"]

    def consulted(step_count: torch.Tensor) -> torch.Tensor:
        return (step_count % interval == 0).unsqueeze(-2).expand_as(data[GROUP, "worker_value"])

    reference = hierarchical_gae(
        0.99,
        0.95,
        worker_value=data[GROUP, "worker_value"],
        manager_value=data[GROUP, "manager_value"],
        next_worker_value=nxt[GROUP, "worker_value"],
        next_manager_value=nxt[GROUP, "manager_value"],
        reward=nxt[GROUP, "reward"],
        done=nxt[GROUP, "done"],
        terminated=nxt[GROUP, "terminated"],
        time_dim=2,
        fusion=fusion,
        weight=0.3,
        manager_consulted=consulted(data["step_count"]),
        next_manager_consulted=consulted(nxt["step_count"]),
    )
    assert_close(data[GROUP, "state_value"], reference.fused_value, rtol=0, atol=0)
    assert_close(data[GROUP, "manager_selected"], reference.manager_share, rtol=0, atol=0)
    assert_close(data[GROUP, "advantage"], reference.advantage)
    assert_close(data[GROUP, "value_target"], reference.value_target)


def toy(
    *,
    steps: int = 4,
    terminated_at: dict[int, int] | None = None,
    truncated_at: dict[int, int] | None = None,
) -> TensorDict:
    """One world, ``steps`` steps, 3 agents, rewards ``[1, 0, 2, 0]`` for every agent.

    ``terminated_at`` / ``truncated_at`` map an agent to the step after which its
    episode ends. ``step_count`` runs 0, 1, 2, ... (next: 1, 2, 3, ...).
    """
    shape = (1, steps, 3)
    flags = {"terminated": terminated_at or {}, "truncated": truncated_at or {}}
    ends = {}
    for name, at in flags.items():
        ends[name] = torch.zeros(*shape, 1, dtype=torch.bool)
        for agent, step in at.items():
            ends[name][0, step, agent] = True
    reward = torch.tensor([1.0, 0.0, 2.0, 0.0])[:steps].reshape(1, steps, 1, 1).expand(*shape, 1)
    step_count = torch.arange(steps).reshape(1, steps, 1)
    return TensorDict(
        {
            GROUP: {
                "observation": torch.zeros(*shape, 2),
                "manager_observation": torch.zeros(*shape, 2),
            },
            "step_count": step_count,
            "next": {
                GROUP: {
                    "observation": torch.zeros(*shape, 2),
                    "manager_observation": torch.zeros(*shape, 2),
                    "reward": reward.clone(),
                    "done": ends["terminated"] | ends["truncated"],
                    **ends,
                },
                "step_count": step_count + 1,
            },
        },
        batch_size=(1, steps),
    )


def toy_estimator(**kwargs: object) -> HierarchicalValueEstimator:
    # V_w = 1 and V_m = 2 everywhere; gamma = lambda = 0.5, so gamma * lambda = 0.25.
    return HierarchicalValueEstimator(
        worker_value_network=constant_critic(1.0, manager=False),
        manager_value_network=constant_critic(2.0, manager=True),
        gamma=0.5,
        lmbda=0.5,
        group=GROUP,
        **kwargs,
    )


# With a constant fused value c: delta_t = r_t + 0.5 c - c = r_t - c / 2, r = [1, 0, 2, 0],
# A_3 = delta_3 and A_t = delta_t + 0.25 A_{t+1}.
#   local    c = 1    : delta = [.5, -.5, 1.5, -.5]   -> A = [.4609375, -.15625, 1.375, -.5]
#   manager  c = 2    : delta = [0, -1, 1, -1]         -> A = [-.203125, -.8125, .75, -1]
#   max      c = 2    : as manager (V_m = 2 > V_w = 1 everywhere)
#   mean     c = 1.5  : delta = [.25, -.75, 1.25, -.75] -> A = [.12890625, -.484375, 1.0625, -.75]
#   weighted c = 1.25 : (w = .25: .25 * 2 + .75 * 1)
#                       delta = [.375, -.625, 1.375, -.625]
#                                                   -> A = [.294921875, -.3203125, 1.21875, -.625]
CLOSED_FORM = {
    "local": (1.0, [0.4609375, -0.15625, 1.375, -0.5], 0.0),
    "manager": (2.0, [-0.203125, -0.8125, 0.75, -1.0], 1.0),
    "max": (2.0, [-0.203125, -0.8125, 0.75, -1.0], 1.0),
    "mean": (1.5, [0.12890625, -0.484375, 1.0625, -0.75], 0.5),
    "weighted": (1.25, [0.294921875, -0.3203125, 1.21875, -0.625], 0.25),
}


@pytest.mark.parametrize("fusion", FUSIONS)
def test_closed_form_every_fusion(fusion: str) -> None:
    fused, advantage, share = CLOSED_FORM[fusion]
    data = toy_estimator(fusion=fusion, weight=0.25)(toy())
    expected = torch.tensor(advantage).reshape(1, 4, 1, 1).expand(1, 4, 3, 1)
    assert_close(data[GROUP, "advantage"], expected, rtol=0, atol=0)
    assert_close(data[GROUP, "value_target"], expected + fused, rtol=0, atol=0)
    assert (data[GROUP, "state_value"] == fused).all()
    assert (data[GROUP, "manager_selected"] == share).all()


# manager_interval = k, fusion = max: V_hat(s_t) = 2 where step_count % k == 0, else 1.
#   k = 2: V_hat(s_0..s_4) = [2, 1, 2, 1, 2]
#          delta = [1 + .5 - 2, 0 + 1 - 1, 2 + .5 - 2, 0 + 1 - 1] = [-.5, 0, .5, 0]
#          A_3 = 0, A_2 = .5, A_1 = .125, A_0 = -.5 + .25 * .125 = -.46875
#   k = 3: V_hat(s_0..s_4) = [2, 1, 1, 2, 1]
#          delta = [1 + .5 - 2, 0 + .5 - 1, 2 + 1 - 1, 0 + .5 - 2] = [-.5, -.5, 2, -1.5]
#          A_3 = -1.5, A_2 = 2 - .375 = 1.625, A_1 = -.5 + .40625 = -.09375,
#          A_0 = -.5 - .0234375 = -.5234375
@pytest.mark.parametrize(
    ("interval", "fused", "advantage"),
    [
        (2, [2.0, 1.0, 2.0, 1.0], [-0.46875, 0.125, 0.5, 0.0]),
        (3, [2.0, 1.0, 1.0, 2.0], [-0.5234375, -0.09375, 1.625, -1.5]),
    ],
)
def test_closed_form_manager_interval(
    interval: int, fused: list[float], advantage: list[float]
) -> None:
    data = toy_estimator(fusion="max", manager_interval=interval)(toy())
    as_agents = lambda values: torch.tensor(values).reshape(1, 4, 1, 1).expand(1, 4, 3, 1)  # noqa: E731
    assert_close(data[GROUP, "state_value"], as_agents(fused), rtol=0, atol=0)
    assert_close(data[GROUP, "advantage"], as_agents(advantage), rtol=0, atol=0)
    consulted = [1.0 if v == 2.0 else 0.0 for v in fused]
    assert_close(data[GROUP, "manager_selected"], as_agents(consulted), rtol=0, atol=0)


def test_closed_form_termination_truncation_per_agent() -> None:
    # fusion = local (V = 1), gamma = lambda = .5. Agent 0's episode terminates after
    # t = 1, agent 1's is truncated after t = 1, agent 2's goes on.
    #   agent 0: delta_1 = 0 - 1 = -1 (no bootstrap), trace cut at t = 1:
    #            A = [.5 + .25 * -1, -1, 1.375, -.5] = [.25, -1, 1.375, -.5]
    #   agent 1: delta_1 = 0 + .5 * 1 - 1 = -.5 (bootstraps), trace cut at t = 1:
    #            A = [.5 + .25 * -.5, -.5, 1.375, -.5] = [.375, -.5, 1.375, -.5]
    #   agent 2: the constant-c = 1 answer above: [.4609375, -.15625, 1.375, -.5]
    data = toy_estimator(fusion="local")(toy(terminated_at={0: 1}, truncated_at={1: 1}))
    expected = torch.tensor(
        [
            [0.25, 0.375, 0.4609375],
            [-1.0, -0.5, -0.15625],
            [1.375, 1.375, 1.375],
            [-0.5, -0.5, -0.5],
        ]
    ).reshape(1, 4, 3, 1)
    assert_close(data[GROUP, "advantage"], expected, rtol=0, atol=0)


def test_every_key_is_configurable(networks: Callable) -> None:
    _, worker, manager = networks()
    data = make_batch()
    data["next", GROUP, "score"] = data["next", GROUP].pop("reward")
    est = estimator(worker, manager)
    est.set_keys(reward=(GROUP, "score"), advantage=(GROUP, "adv"), manager_selected="share")
    est(data)
    assert (GROUP, "adv") in data.keys(True) and "share" in data
    assert est.tensor_keys.value_target == (GROUP, "value_target")
    with pytest.raises(KeyError, match="not an accepted tensordict key"):
        est.set_keys(rewards=(GROUP, "reward"))


def test_in_and_out_keys(networks: Callable) -> None:
    _, worker, manager = networks()
    est = estimator(worker, manager, manager_interval=5)
    assert set(est.in_keys) >= {
        (GROUP, "observation"),
        ("next", GROUP, "manager_observation"),
        ("next", GROUP, "reward"),
        "step_count",
        ("next", "step_count"),
    }
    assert set(est.out_keys) == {
        (GROUP, leaf)
        for leaf in (
            "advantage",
            "value_target",
            "state_value",
            "worker_value",
            "manager_value",
            "manager_selected",
        )
    }


def test_value_estimate_leaves_the_data_untouched(networks: Callable) -> None:
    _, worker, manager = networks()
    data = make_batch()
    before = set(data.keys(True, True))
    target = estimator(worker, manager).value_estimate(data)
    assert set(data.keys(True, True)) == before
    estimator(worker, manager)(data)
    assert_close(target, data[GROUP, "value_target"])


def test_estimates_carry_no_gradient(networks: Callable) -> None:
    _, worker, manager = networks()
    data = estimator(worker, manager)(make_batch())
    for leaf in ("advantage", "value_target", "state_value", "worker_value", "manager_value"):
        assert not data[GROUP, leaf].requires_grad, leaf


def test_differentiable_estimator_sends_the_max_gradient_to_both_critics(
    networks: Callable,
) -> None:
    _, worker, manager = networks()
    data = make_batch(seed=5)
    estimator(worker, manager, differentiable=True)(data)
    data[GROUP, "state_value"].sum().backward()
    for critic in (worker, manager):
        assert all(p.grad is not None and p.grad.abs().sum() > 0 for p in critic.parameters())


# --- bad input -------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("missing", "message"),
    [
        (("next", GROUP, "reward"), r"missing key \('next', 'racket', 'reward'\) \(the reward"),
        (("next", GROUP, "terminated"), r"missing key \('next', 'racket', 'terminated'\)"),
        (
            ("next", GROUP, "manager_observation"),
            r"missing key \('next', 'racket', 'manager_observation'\) \(an input of the critic",
        ),
        (("next", "step_count"), r"missing key \('next', 'step_count'\)"),
        ((GROUP, "observation"), r"missing key \('racket', 'observation'\)"),
        ("step_count", r"missing key 'step_count' \(the episode step counter\)"),
    ],
)
def test_missing_keys_are_named(networks: Callable, missing: tuple, message: str) -> None:
    _, worker, manager = networks()
    data = make_batch()
    del data[missing]
    with pytest.raises(KeyError) as error:
        estimator(worker, manager, manager_interval=5)(data)
    assert re.search(message, error.value.args[0]), error.value.args[0]


def test_mismatched_critic_shapes(networks: Callable) -> None:
    _, worker, _ = networks()
    two_heads = TensorDictModule(
        lambda obs: obs[..., :2],
        in_keys=[(GROUP, "manager_observation")],
        out_keys=[(GROUP, "manager_value")],
    )
    with pytest.raises(
        ValueError, match=r"\(3, 7, 4, 1\) \(worker\) and \(3, 7, 4, 2\) \(manager\)"
    ):
        estimator(worker, two_heads)(make_batch())


def test_reward_that_does_not_broadcast(networks: Callable) -> None:
    _, worker, manager = networks()
    data = make_batch()
    data["next", GROUP, "reward"] = torch.zeros(3, 7, 4, 2)
    with pytest.raises(ValueError, match=r"reward of shape \(3, 7, 4, 2\)"):
        estimator(worker, manager)(data)


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"fusion": "maximum"}, r"unknown fusion 'maximum'; choose one of \['local'"),
        ({"manager_interval": 0}, r"manager_interval must be an integer >= 1, got 0"),
        ({"fusion": "weighted", "weight": 1.2}, r"weight must lie in \[0, 1\].*got 1.2"),
    ],
)
def test_bad_constructor_arguments(networks: Callable, kwargs: dict, message: str) -> None:
    _, worker, manager = networks()
    with pytest.raises(ValueError, match=message):
        estimator(worker, manager, **kwargs)


# --- built from TorchRL's public pieces ------------------------------------------------


@pytest.mark.parametrize("interval", [1, 3])
@pytest.mark.parametrize("deactivate_vmap", [False, True], ids=["vmap", "loop"])
def test_fused_value_is_a_value_network_for_torchrl_gae(
    networks: Callable, interval: int, deactivate_vmap: bool
) -> None:
    # The estimator's FusedValue, handed to TorchRL's stock GAE, gives the same estimate.
    _, worker, manager = networks()
    est = estimator(worker, manager, fusion="max", manager_interval=interval)
    data = est(make_batch())
    gae = GAE(
        gamma=0.99,
        lmbda=0.95,
        value_network=est.fused_value(),
        vectorized=True,
        deactivate_vmap=deactivate_vmap,
    )
    gae.set_keys(
        value=(GROUP, "state_value"),
        advantage=(GROUP, "torchrl_advantage"),
        value_target=(GROUP, "torchrl_value_target"),
        reward=(GROUP, "reward"),
        done=(GROUP, "done"),
        terminated=(GROUP, "terminated"),
    )
    stock = gae(make_batch())
    assert_close(stock[GROUP, "torchrl_advantage"], data[GROUP, "advantage"], rtol=0, atol=0)
    assert_close(stock[GROUP, "torchrl_value_target"], data[GROUP, "value_target"], rtol=0, atol=0)


def test_estimator_is_torchrl_gae_and_owns_no_critic(networks: Callable) -> None:
    _, worker, manager = networks()
    est = estimator(worker, manager)
    assert isinstance(est, GAE)
    assert est.critics == (worker, manager)
    assert list(est.state_dict()) == ["gamma", "lmbda"]
    assert list(est.parameters()) == []


def test_time_dim_named_time(networks: Callable) -> None:
    # [T, N] data with its time dim named: the same estimate as the [N, T] layout.
    _, worker, manager = networks()
    data = make_batch()
    estimator(worker, manager)(data)
    transposed = make_batch().transpose(0, 1)
    transposed.refine_names("time", None)
    estimator(worker, manager)(transposed)
    assert_close(transposed[GROUP, "advantage"].transpose(0, 1), data[GROUP, "advantage"])


def as_trajectories(data: TensorDict) -> TensorDict:
    """``data`` made a collector's batch: wherever no agent's episode ended after step
    ``t``, the root observation (and step counter) of ``t + 1`` is ``t``'s next one."""
    *batch, steps = data.shape
    done = data["next", GROUP, "done"].flatten(-2).any(-1)  # [*B, T]: a world resets whole
    for t in range(steps - 1):
        goes_on = ~done[..., t]
        for key in ((GROUP, "observation"), (GROUP, "manager_observation"), ("step_count",)):
            root, following = data.get(key), data.get(("next", *key))
            root.select(len(batch), t + 1)[goes_on] = following.select(len(batch), t)[goes_on]
    return data


class RowCounter(torch.nn.Module):
    """Wraps a network and counts the rows it evaluates."""

    def __init__(self, network: torch.nn.Module) -> None:
        super().__init__()
        self.network, self.rows = network, 0

    def forward(self, obs: torch.Tensor) -> torch.Tensor:
        self.rows += obs[..., 0, 0].numel()
        return self.network(obs)


@pytest.mark.parametrize("fusion", FUSIONS)
@pytest.mark.parametrize("batch", [(3,), (2, 3)], ids=["[N,T]", "[B,N,T]"])
def test_shifted_estimate_equals_two_passes_on_trajectories(
    networks: Callable, fusion: str, batch: tuple[int, ...]
) -> None:
    # The single-pass estimate (critics on the root observations, then only on the
    # "next" ones after an end, a cut or the last step) equals evaluating both.
    _, worker, manager = networks()
    data = as_trajectories(
        make_batch(batch=batch, steps=11, p_terminated=0.1, p_truncated=0.1, seed=4)
    )
    options = {"fusion": fusion, "manager_interval": 2, "manager_diagnostics": True}
    shifted, full = data.clone(), data.clone()
    estimator(worker, manager, shifted=True, **options)(shifted)
    estimator(worker, manager, **options)(full)
    for key in ("advantage", "value_target", "state_value", "manager_selected"):
        assert_close(shifted[GROUP, key], full[GROUP, key], rtol=0, atol=1e-6)
    for key in ("worker_value", "manager_value"):
        assert_close(shifted["next", GROUP, key], full["next", GROUP, key], rtol=0, atol=1e-6)


def test_shifted_estimate_evaluates_next_only_after_ends_and_at_the_last_step(
    networks: Callable,
) -> None:
    _, worker, manager = networks()
    data = as_trajectories(make_batch(batch=(3,), steps=11, seed=5))
    counter = RowCounter(worker.module)
    counted = TensorDictModule(counter, in_keys=worker.in_keys, out_keys=worker.out_keys)
    estimator(counted, manager, shifted=True)(data)
    worlds, steps = data.shape
    ends = int(data["next", GROUP, "done"].flatten(-2).any(-1)[:, :-1].sum())
    assert 0 < ends < worlds * (steps - 1)
    assert counter.rows == worlds * steps + ends + worlds


#: fusion -> the critic its V_hat does not read: (index in (worker, manager), the value
#: it writes, its observation, the switch that runs it anyway).
LEFT_OUT = {
    "local": (1, "manager_value", "manager_observation", "manager_diagnostics"),
    "manager": (0, "worker_value", "observation", "worker_diagnostics"),
}


@pytest.mark.parametrize("shifted", [False, True])
@pytest.mark.parametrize("fusion", sorted(LEFT_OUT))
def test_the_critic_a_fusion_ignores_is_left_out_unless_asked(
    networks: Callable, fusion: str, shifted: bool
) -> None:
    # PPO's V_hat is V_w, the centralised critic's V_m: without diagnostics the other
    # critic is not run and its value not written; the estimate is the same either way.
    index, value_key, observation_key, switch = LEFT_OUT[fusion]
    _, *critics = networks()
    counter = RowCounter(critics[index].module)
    critics[index] = TensorDictModule(
        counter, in_keys=critics[index].in_keys, out_keys=critics[index].out_keys
    )
    data = as_trajectories(make_batch(batch=(3,), steps=11, seed=6))
    without, with_both = data.clone(), data.clone()
    lean = estimator(*critics, fusion=fusion, shifted=shifted)
    lean(without)
    assert counter.rows == 0
    assert (GROUP, value_key) not in without.keys(include_nested=True)
    assert (GROUP, value_key) not in lean.out_keys
    assert (GROUP, observation_key) not in lean.in_keys
    estimator(*critics, fusion=fusion, shifted=shifted, **{switch: True})(with_both)
    assert counter.rows > 0
    for key in ("advantage", "value_target", "state_value", "manager_selected"):
        assert_close(without[GROUP, key], with_both[GROUP, key], rtol=0, atol=0)


def test_manager_fusion_runs_the_worker_between_consultations(networks: Callable) -> None:
    # With manager_interval > 1, V_hat = V_w where the manager is not consulted.
    _, worker, manager = networks()
    fused = estimator(worker, manager, fusion="manager", manager_interval=2).fused_value()
    assert fused.runs_worker
    assert (GROUP, "worker_value") in fused.out_keys
