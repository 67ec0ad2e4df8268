"""GroupPolicies draws what the actors draw, and the loss's terms are ClipPPOLoss's."""

from __future__ import annotations

import pytest
import torch
from tensordict import TensorDict
from torchrl.data import Bounded, Categorical, Composite, Unbounded
from torchrl.envs.utils import ExplorationType, set_exploration_type

from rlhc.modules import EnvSpecs, NetworkConfig, make_actor
from rlhc.modules.policies import GroupPolicies


def actor_and_data(kind: str) -> tuple[torch.nn.Module, TensorDict]:
    action = Categorical(5, (4,)) if kind == "categorical" else Bounded(-1.0, 1.0, (4, 3))
    specs = EnvSpecs(
        Composite(racket=Composite(observation=Unbounded((4, 8)), shape=(4,))),
        Composite(racket=Composite(action=action, shape=(4,))),
    )
    dist = "gaussian" if kind == "categorical" else kind
    actor = make_actor(specs, "racket", NetworkConfig(hidden_size=16, action_dist=dist))
    data = TensorDict({("racket", "observation"): torch.randn(5, 4, 8)}, [5])
    return actor, data


@pytest.mark.parametrize("kind", ["gaussian", "tanh_normal", "categorical"])
def test_draws_are_the_actors_own(kind: str) -> None:
    actor, data = actor_and_data(kind)
    policy = GroupPolicies({"racket": actor})
    with set_exploration_type(ExplorationType.RANDOM), torch.no_grad():
        torch.manual_seed(0)
        theirs = actor(data.clone())
        torch.manual_seed(0)
        ours = policy(data.clone())
    # Every key written is the actor's, equal to the bit; the parameters are not written.
    assert set(ours.keys(True, True)) < set(theirs.keys(True, True))
    assert set(policy.out_keys) == set(ours.keys(True, True)) - {("racket", "observation")}
    for key in ours.keys(True, True):
        assert torch.equal(ours[key], theirs[key]), key


def test_other_exploration_types_run_the_actors() -> None:
    actor, data = actor_and_data("gaussian")
    policy = GroupPolicies({"racket": actor})
    with set_exploration_type(ExplorationType.DETERMINISTIC), torch.no_grad():
        ours, theirs = policy(data.clone()), actor(data.clone())
    assert torch.equal(ours["racket", "action"], theirs["racket", "action"])
    assert ("racket", "loc") in ours.keys(True, True)
