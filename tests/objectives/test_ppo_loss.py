"""The two-critic ``ClipPPOLoss``: outputs, gradients, and a short PPO update."""

from __future__ import annotations

from collections.abc import Callable

import pytest
import torch
from rlhc_synthetic import D_WORKER, GROUP, make_batch, make_specs
from tensordict import TensorDict
from torch.testing import assert_close

from rlhc.modules import NetworkConfig, make_actor, make_manager_critic, make_worker_critic
from rlhc.objectives import (
    LOSS_KEYS,
    HierarchicalPPOLoss,
    HierarchicalValueEstimator,
    make_ppo_loss,
)
from rlhc.objectives.ppo import explained_variance
from rlhc.objectives.weighting import learner_weight, policy_diagnostics

DIAGNOSTICS = (
    "loss_worker_critic",
    "loss_manager_critic",
    "entropy",
    "kl_approx",
    "clip_fraction",
    "explained_variance",
    "explained_variance_worker",
    "explained_variance_manager",
)


def build_loss(networks: Callable, **kwargs: object) -> HierarchicalPPOLoss:
    actor, worker, manager = networks()
    return make_ppo_loss(
        actor=actor, worker_critic=worker, manager_critic=manager, group=GROUP, **kwargs
    )


def collected(loss: HierarchicalPPOLoss, **batch_kwargs: object) -> TensorDict:
    """Synthetic data with actions and log-probs from the loss's own actor."""
    data = make_batch(**batch_kwargs)
    with torch.no_grad():
        loss.actor_network(data)
    return data


def test_output_keys(networks: Callable) -> None:
    loss = build_loss(networks)
    out = loss(collected(loss))
    for key in (*LOSS_KEYS, *DIAGNOSTICS):
        assert key in out, key
        assert out[key].shape == (), key
    assert set(loss.out_keys) >= {*LOSS_KEYS, *DIAGNOSTICS}


def test_critic_loss_is_the_sum_of_both_terms(networks: Callable) -> None:
    loss = build_loss(networks, critic_coef=0.5, loss_critic_type="l2")
    data = collected(loss)
    out = loss(data)
    assert_close(out["loss_critic"], out["loss_worker_critic"] + out["loss_manager_critic"])
    # Recompute by hand: 0.5 * mean((target - V)^2) for each critic.
    loss.value_estimator(data)
    target = data[GROUP, "value_target"]
    with torch.no_grad():
        worker = loss.value_estimator.worker_value_network(data.clone())[GROUP, "worker_value"]
        manager = loss.value_estimator.manager_value_network(data.clone())[GROUP, "manager_value"]
    assert_close(out["loss_worker_critic"], 0.5 * (target - worker).pow(2).mean())
    assert_close(out["loss_manager_critic"], 0.5 * (target - manager).pow(2).mean())
    fused = torch.maximum(worker, manager)
    explained = 1 - (target - fused).var(correction=0) / target.var(correction=0)
    assert_close(out["explained_variance"], explained)
    for key, value in (("worker", worker), ("manager", manager)):
        by_hand = 1 - (target - value).var(correction=0) / target.var(correction=0)
        assert_close(out[f"explained_variance_{key}"], by_hand)
    assert not torch.equal(out["explained_variance_worker"], out["explained_variance_manager"])
    # ClipPPOLoss's own hook gives the same (unreduced) sum.
    unreduced, _, hook_explained = loss.loss_critic(data)
    assert_close(unreduced.mean(), out["loss_critic"])
    assert_close(hook_explained, explained)


def test_only_the_loss_terms_carry_gradient(networks: Callable) -> None:
    loss = build_loss(networks)
    out = loss(collected(loss))
    for key in LOSS_KEYS:
        assert out[key].requires_grad, key
    for key in DIAGNOSTICS:
        assert not out[key].requires_grad, key


def test_loss_does_not_write_into_the_callers_data(networks: Callable) -> None:
    loss = build_loss(networks)
    data = collected(loss)
    before = set(data.keys(True, True))
    loss(data)
    assert set(data.keys(True, True)) == before


def test_both_critics_learn_even_when_the_manager_always_wins(networks: Callable) -> None:
    loss = build_loss(networks, fusion="max")
    manager = loss.value_estimator.manager_value_network
    with torch.no_grad():  # push V_m far above V_w: the manager wins every max
        last_bias = [p for name, p in manager.named_parameters() if name.endswith("bias")][-1]
        last_bias.add_(100.0)
    data = collected(loss)
    loss.value_estimator(data)
    assert (data[GROUP, "manager_selected"] == 1).all()
    out = loss(data)
    out["loss_critic"].backward()
    for critic in (loss.value_estimator.worker_value_network, manager):
        for name, param in critic.named_parameters():
            assert param.grad is not None and param.grad.abs().sum() > 0, name


def test_policy_gets_no_gradient_through_the_fused_value(networks: Callable) -> None:
    loss = build_loss(networks)
    data = collected(loss)
    loss.value_estimator(data)
    assert not data[GROUP, "advantage"].requires_grad
    out = loss(data)
    (out["loss_objective"] + out["loss_entropy"]).backward()
    estimator = loss.value_estimator
    for critic in (estimator.worker_value_network, estimator.manager_value_network):
        assert all(p.grad is None for p in critic.parameters())
    assert all(p.grad is not None for p in loss.actor_network.parameters())


def test_parameters_are_the_networks_own_and_listed_once(networks: Callable) -> None:
    actor, worker, manager = networks()
    loss = make_ppo_loss(actor=actor, worker_critic=worker, manager_critic=manager, group=GROUP)
    expected = {*actor.parameters(), *worker.parameters(), *manager.parameters()}
    params = list(loss.parameters())
    assert {id(p) for p in params} == {id(p) for p in expected}
    assert len(params) == len(expected)


def test_short_ppo_update_lowers_both_critic_losses(networks: Callable) -> None:
    loss = build_loss(networks, fusion="max")
    data = collected(loss, batch=(8,), steps=16, seed=4, p_terminated=0.5)
    # A learnable problem: short episodes, a reward read off the worker observation, and
    # a manager that sees what the worker sees plus more (as in tennis, d_m = d_w + 2).
    data["next", GROUP, "reward"] = 2.0 * data[GROUP, "observation"][..., :1]
    for root in (data, data["next"]):
        root[GROUP, "manager_observation"][..., :D_WORKER] = root[GROUP, "observation"]
    with torch.no_grad():
        loss.value_estimator(data)  # targets fixed for the update, as in PPO
    flat = data.reshape(-1)
    optimiser = torch.optim.Adam(loss.parameters(), lr=3e-3)
    first = loss(flat)
    for _ in range(40):
        out = loss(flat)
        optimiser.zero_grad()
        sum(out[key] for key in LOSS_KEYS).backward()
        optimiser.step()
    last = loss(flat)
    for key in ("loss_worker_critic", "loss_manager_critic"):
        assert last[key] < 0.8 * first[key], (key, first[key].item(), last[key].item())


def test_attaching_an_estimator_with_make_value_estimator(networks: Callable) -> None:
    actor, worker, manager = networks()
    loss = HierarchicalPPOLoss(actor, worker, manager)
    loss.set_keys(
        reward=(GROUP, "reward"),
        done=(GROUP, "done"),
        terminated=(GROUP, "terminated"),
        advantage=(GROUP, "advantage"),
        value_target=(GROUP, "value_target"),
        value=(GROUP, "state_value"),
        worker_value=(GROUP, "worker_value"),
        manager_value=(GROUP, "manager_value"),
    )
    estimator = HierarchicalValueEstimator(
        worker_value_network=worker, manager_value_network=manager, gamma=0.9, lmbda=0.9
    )
    assert loss.make_value_estimator(estimator) is loss  # keys are forwarded from the loss
    assert loss.value_estimator is estimator
    assert estimator.tensor_keys.reward == (GROUP, "reward")
    assert estimator.tensor_keys.worker_value == (GROUP, "worker_value")
    out = loss(collected(loss))
    assert out["loss_critic"].isfinite()


def test_manager_interval_loss_runs_on_minibatches(networks: Callable) -> None:
    # The trainer estimates on [N, T] data, then scores flat minibatches.
    loss = build_loss(networks, fusion="max", manager_interval=5)
    data = collected(loss)
    with torch.no_grad():
        loss.value_estimator(data)
    out = loss(data.reshape(-1)[:10])
    assert out["loss_critic"].isfinite()


def test_discrete_group() -> None:
    specs = make_specs(group="striker", n_agents=2, discrete=6)
    cfg = NetworkConfig(hidden_size=16)
    loss = make_ppo_loss(
        actor=make_actor(specs, "striker", cfg),
        worker_critic=make_worker_critic(specs, "striker", cfg),
        manager_critic=make_manager_critic(specs, "striker", cfg),
        group="striker",
    )
    data = make_batch(group="striker", n_agents=2)
    with torch.no_grad():
        loss.actor_network(data)
    assert data["striker", "action"].dtype == torch.int64
    out = loss(data)
    sum(out[key] for key in LOSS_KEYS).backward()
    assert out["entropy"] > 0


@pytest.mark.parametrize("bad", [0.0, -1.0])
def test_critic_coefficient_must_be_positive(networks: Callable, bad: float) -> None:
    with pytest.raises(ValueError, match="critic_coeff must be > 0"):
        build_loss(networks, critic_coef=bad)


def test_value_clipping_is_refused(networks: Callable) -> None:
    actor, worker, manager = networks()
    with pytest.raises(ValueError, match="clip_value is not supported"):
        HierarchicalPPOLoss(actor, worker, manager, clip_value=0.2)


# --- TorchRL's public hooks -------------------------------------------------------------


def test_an_exploding_ratio_is_capped_rather_than_infinite(networks: Callable) -> None:
    # A TanhNormal action at its bound was scored about -1000 nats when collected; one
    # step can move its log-probability by hundreds, and exp(log ratio) overflows.
    for cap in (None, 100.0):
        loss = build_loss(networks, max_importance_ratio=cap)
        data = collected(loss)
        loss.value_estimator(data)
        keys = loss.tensor_keys
        stale = data[keys.sample_log_prob].clone()
        stale.view(-1)[0] -= 300.0  # the collected log-probability of one experience
        data.set(keys.sample_log_prob, stale)
        data.set(keys.advantage, -data[keys.advantage].abs())  # every experience bad
        out = loss(data)
        grads = torch.autograd.grad(
            out["loss_objective"], list(loss.actor_network_params.values(True, True))
        )
        finite = torch.isfinite(out["loss_objective"]) and all(
            torch.isfinite(g).all() for g in grads
        )
        assert finite == (cap is not None), cap
    # A setting, not state: checkpoints keep their keys either way.
    assert "max_importance_ratio" not in loss.state_dict()
    assert float(loss.max_importance_ratio) == 100.0


def test_state_dict_keys_are_stable(networks: Callable) -> None:
    # Checkpoints hold loss.state_dict(): the estimator adds gamma and lambda only.
    loss = build_loss(networks)
    names = list(loss.state_dict())
    assert [n for n in names if n.startswith("_value_estimator.")] == [
        "_value_estimator.gamma",
        "_value_estimator.lmbda",
    ]
    assert any(n.startswith("critic_network_params.") for n in names)
    assert any(n.startswith("actor_network_params.") for n in names)
    assert {"critic_coeff", "entropy_coeff", "clip_epsilon"} <= set(names)
    rebuilt = build_loss(networks)
    rebuilt.load_state_dict(loss.state_dict(), strict=True)


@pytest.mark.parametrize("reduction", ["none", "sum", "mean"])
def test_reductions_of_the_critic_terms(networks: Callable, reduction: str) -> None:
    loss = build_loss(networks)
    data = collected(loss)
    with torch.no_grad():
        loss.value_estimator(data)
    flat = data.reshape(-1)
    loss.reduction = reduction
    out = loss(flat)
    expected_shape = (flat.numel(), 4) if reduction == "none" else ()
    for key in ("loss_critic", "loss_worker_critic", "loss_manager_critic", "loss_objective"):
        assert out[key].shape == expected_shape, (key, out[key].shape)
    assert_close(out["loss_critic"], out["loss_worker_critic"] + out["loss_manager_critic"])
    loss.reduction = "mean"
    mean = loss(flat)
    totals = {"none": flat.numel() * 4, "sum": flat.numel() * 4, "mean": 1}
    for key in ("loss_critic", "loss_worker_critic", "loss_manager_critic"):
        assert_close(out[key].sum() / totals[reduction], mean[key])


def test_make_value_estimator_builds_a_hierarchical_one(networks: Callable) -> None:
    actor, worker, manager = networks()
    loss = HierarchicalPPOLoss(actor, worker, manager)
    loss.make_value_estimator(gamma=0.9, fusion="mean")
    estimator = loss.value_estimator
    assert isinstance(estimator, HierarchicalValueEstimator)
    assert estimator.fusion == "mean" and float(estimator.gamma) == pytest.approx(0.9)
    assert estimator.critics == (worker, manager)
    # TorchRL's default (built on first use) is a hierarchical estimator too.
    fresh = HierarchicalPPOLoss(*networks())
    assert isinstance(fresh.value_estimator, HierarchicalValueEstimator)


def test_other_estimators_are_refused(networks: Callable) -> None:
    from torchrl.objectives import ValueEstimators

    loss = build_loss(networks)
    with pytest.raises(ValueError, match="needs both critics' values"):
        loss.make_value_estimator(ValueEstimators.TD0)


def test_keys_set_after_attaching_reach_the_estimator(networks: Callable) -> None:
    loss = build_loss(networks)
    loss.set_keys(worker_value=(GROUP, "v_w"), advantage=(GROUP, "adv"))
    assert loss.value_estimator.tensor_keys.worker_value == (GROUP, "v_w")
    assert loss.value_estimator.tensor_keys.advantage == (GROUP, "adv")


def test_separate_losses_is_refused(networks: Callable) -> None:
    actor, worker, manager = networks()
    with pytest.raises(ValueError, match="separate_losses is not supported"):
        HierarchicalPPOLoss(actor, worker, manager, separate_losses=True)


#: fusion -> the critic its V_hat does not read: (its module index, its name, the switch
#: that trains it anyway).
LEFT_OUT = {
    "local": (1, "manager", "manager_diagnostics"),
    "manager": (0, "worker", "worker_diagnostics"),
}


@pytest.mark.parametrize("fusion", sorted(LEFT_OUT))
def test_the_critic_a_fusion_ignores_is_neither_run_nor_trained_unless_asked(
    networks: Callable, fusion: str
) -> None:
    # PPO ("local") and the centralised critic ("manager"): the actor's and the other
    # critic's gradients are those of the loss that trains both critics (the switch
    # on); the left-out critic gets none, and none of its terms is reported.
    index, name, switch = LEFT_OUT[fusion]
    lean = build_loss(networks, fusion=fusion)
    kept = build_loss(networks, fusion=fusion, **{switch: True})
    data = collected(lean)
    grads = []
    for loss in (lean, kept):
        torch.manual_seed(1)  # the same samples of the TanhNormal's entropy estimate
        out = loss(data.clone())
        sum(out[key] for key in LOSS_KEYS).backward()
        grads.append({name: p.grad for name, p in loss.named_parameters()})
    for key in (f"loss_{name}_critic", f"explained_variance_{name}"):
        assert key not in lean(data.clone())
        assert key in kept(data.clone())
    # The fused value is the remaining critic's: so is the explained variance.
    out = lean(data.clone())
    remaining = "manager" if name == "worker" else "worker"
    assert_close(out["explained_variance"], out[f"explained_variance_{remaining}"])
    left_out = [key for key in grads[0] if f"critic_network_params.module.{index}." in key]
    assert left_out and all(grads[0][key] is None for key in left_out)
    assert all(grads[1][key] is not None for key in left_out)
    for key, grad in grads[0].items():
        if key not in left_out:
            assert_close(grad, grads[1][key], rtol=0, atol=1e-6, msg=key)


def test_weighted_explained_variance_is_that_of_the_weighted_elements() -> None:
    gen = torch.Generator().manual_seed(0)
    target, value = torch.randn(2, 50, 4, 1, generator=gen).unbind(0)
    weight = (torch.rand(50, 4, 1, generator=gen) < 0.5).float()
    kept = weight.bool()
    assert_close(
        explained_variance(target, value, weight),
        explained_variance(target[kept], value[kept]),
    )
    assert_close(
        explained_variance(target, value, torch.ones_like(weight)),
        explained_variance(target, value),
    )


def moved_policy_loss(
    discrete: int | None, **kwargs: object
) -> tuple[HierarchicalPPOLoss, TensorDict]:
    """A per-sample loss and its estimated data (flat), the policy moved since collection."""
    specs = make_specs(discrete=discrete)
    cfg = NetworkConfig(hidden_size=16)
    torch.manual_seed(0)
    loss = make_ppo_loss(
        actor=make_actor(specs, GROUP, cfg),
        worker_critic=make_worker_critic(specs, GROUP, cfg),
        manager_critic=make_manager_critic(specs, GROUP, cfg),
        group=GROUP,
        reduction="none",
        normalize_advantage=False,
        **kwargs,  # type: ignore[arg-type]
    )
    data = collected(loss)
    with torch.no_grad():
        loss.value_estimator(data)
        for parameter in loss.actor_network.parameters():
            parameter.add_(0.2 * torch.randn_like(parameter))
    return loss, data.reshape(-1)


@pytest.mark.parametrize("discrete", [None, 6])
def test_policy_diagnostics_are_torchrls_where_every_experience_is_the_learners(
    discrete: int | None,
) -> None:
    # On data the learner chose throughout, the recomputed KL and clip fraction are
    # ClipPPOLoss's own (and the analytic entropy too); the policy has moved since the
    # data was collected, so neither is trivially 0.
    loss, flat = moved_policy_loss(discrete, clip_epsilon=0.05)
    flat[GROUP, "learner"] = torch.ones(*flat[GROUP, "advantage"].shape, dtype=torch.bool)
    weight = learner_weight(flat, (GROUP, "learner"), flat[GROUP, "advantage"])
    ours = policy_diagnostics(loss, loss.terms(flat.clone()), weight)
    theirs = loss(flat)
    assert theirs["kl_approx"].abs() > 1e-3 and 0 < theirs["clip_fraction"] < 1
    assert_close(ours["kl_approx"], theirs["kl_approx"])
    assert_close(ours["clip_fraction"], theirs["clip_fraction"])
    if discrete is not None:
        assert_close(ours["entropy"], theirs["entropy"])


@pytest.mark.parametrize("discrete", [None, 6])
@pytest.mark.parametrize("fusion", ["local", "manager", "max", "mean"])
@pytest.mark.parametrize("max_importance_ratio", [None, 1.5])
def test_terms_are_forwards_values_and_gradients(
    discrete: int | None, fusion: str, max_importance_ratio: float | None
) -> None:
    # The trainer's path (terms) against ClipPPOLoss.forward: every output it writes and
    # every parameter's gradient, equal to 1e-6, on a policy moved since collection.
    loss, flat = moved_policy_loss(
        discrete, fusion=fusion, max_importance_ratio=max_importance_ratio
    )
    theirs, ours = loss(flat.clone()), loss.terms(flat.clone()).values
    assert set(ours) == set(theirs.keys()) - {"ESS", "max_ratio", "mean_ratio"}
    for key, value in ours.items():
        assert_close(value, theirs[key], atol=1e-6, rtol=1e-6)
    parameters = list(loss.parameters())

    def gradients(out: object) -> list[torch.Tensor | None]:
        total = sum(out[k].sum() for k in ("loss_objective", "loss_critic", "loss_entropy"))  # type: ignore[index]
        return list(torch.autograd.grad(total, parameters, allow_unused=True))

    for a, b in zip(
        gradients(loss.terms(flat.clone()).values), gradients(loss(flat.clone())), strict=True
    ):
        assert (a is None) == (b is None)
        if a is not None:
            assert_close(a, b, atol=1e-6, rtol=1e-6)


def test_terms_refuse_a_loss_that_standardises(networks: Callable) -> None:
    loss = build_loss(networks, normalize_advantage=True)
    with pytest.raises(ValueError, match="normalize_advantage=False"):
        loss.terms(collected(loss))
