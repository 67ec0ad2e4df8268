"""``algo.rescore_log_prob``: PPO's ratio starts at 1 however saturated the TanhNormal."""

from __future__ import annotations

import pytest
import torch
from rlhc_synthetic import GROUP, make_batch, make_specs
from tensordict.nn import InteractionType, set_interaction_type

from rlhc.config.validation import check_parallel
from rlhc.errors import ConfigError
from rlhc.modules import NetworkConfig, make_actor, make_manager_critic, make_worker_critic
from rlhc.objectives import make_ppo_loss, rescore_log_prob

CFG = NetworkConfig(num_layers=2, hidden_size=16)
LOG_PROB = (GROUP, "action_log_prob")


def saturated_loss() -> torch.nn.Module:
    """A TanhNormal policy whose pre-tanh means sit at 8 (a trained tennis policy's
    saturated actions), small scales: where atanh of the stored action is off."""
    torch.manual_seed(0)
    specs = make_specs()
    actor = make_actor(specs, GROUP, CFG)
    *_, (_, weight), (_, bias) = actor.named_parameters()  # the head: (loc, scale) x 3
    assert bias.shape[-1] == 6
    with torch.no_grad():
        weight.zero_()
        bias.zero_()
        bias[..., :3] = 8.0  # the locs; the scales at their initial value
    return make_ppo_loss(
        actor=actor,
        worker_critic=make_worker_critic(specs, GROUP, CFG),
        manager_critic=make_manager_critic(specs, GROUP, CFG),
        group=GROUP,
    )


def collected(loss: torch.nn.Module) -> torch.Tensor:
    data = make_batch()
    with torch.no_grad(), set_interaction_type(InteractionType.RANDOM):
        loss.actor_network(data)
        loss.value_estimator(data)
    return data


def test_rescoring_makes_the_ratio_exactly_one_at_unchanged_weights() -> None:
    loss = saturated_loss()
    data = collected(loss)
    with torch.no_grad():
        before = loss(data.clone())
    # The stored log-probabilities are not the loss's: a KL and clipped ratios at
    # unchanged weights.
    assert before["kl_approx"].abs().item() > 0.01
    assert before["clip_fraction"].item() > 0.01
    rescore_log_prob(loss, data)
    with torch.no_grad():
        after = loss(data)
    assert after["kl_approx"].item() == 0.0
    assert after["clip_fraction"].item() == 0.0


def test_an_opponents_experiences_keep_their_stored_value() -> None:
    loss = saturated_loss()
    data = collected(loss)
    learner = torch.rand(data[LOG_PROB].shape, generator=torch.Generator().manual_seed(2)) < 0.5
    data.set((GROUP, "learner"), learner.unsqueeze(-1))
    data.set(LOG_PROB, torch.full_like(data[LOG_PROB], -123.0))
    rescore_log_prob(loss, data)
    assert (data[LOG_PROB][~learner] == -123.0).all()
    with torch.no_grad():
        scored = loss.actor_network.get_dist(data).log_prob(data[GROUP, "action"])
    assert torch.equal(data[LOG_PROB][learner], scored.reshape(learner.shape)[learner])


def test_a_pipeline_cannot_rescore_its_batches() -> None:
    check_parallel("pipeline", 2, "cpu", False, rescore_log_prob=False)
    check_parallel("data", 2, "cpu", False, rescore_log_prob=True)
    with pytest.raises(ConfigError, match=r"parallel=pipeline with algo\.rescore_log_prob=true"):
        check_parallel("pipeline", 2, "cpu", False, rescore_log_prob=True)
