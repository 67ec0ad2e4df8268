"""Observation normalisation: a feature that stops varying does not turn NaN."""

from __future__ import annotations

import torch
from configs import load_smoke
from tensordict import TensorDict
from torchrl.envs import VecNormV2

from rlhc.building.builders import make_training_env
from rlhc.building.normalisation import SafeVecNorm


def moments(x: float, rounding: float) -> tuple[TensorDict, TensorDict]:
    """Running moments of a constant feature, the second rounded below the squared first."""
    loc = TensorDict({"x": torch.tensor([x])}, [])
    var = TensorDict({"x": torch.tensor([x * x - rounding])}, [])
    return loc, var


def test_a_constant_feature_normalises_to_zero_not_nan() -> None:
    data = TensorDict({"x": torch.tensor([0.1167])}, [])
    loc, var = moments(0.1167, 1e-9)
    # TorchRL's own: the variance E[x^2] - E[x]^2 comes out negative, its root NaN.
    plain = VecNormV2(in_keys=["x"], decay=1.0)._norm(data, loc, var, 1)["x"]
    assert torch.isnan(plain).all()
    safe = SafeVecNorm(in_keys=["x"], decay=1.0)._norm(data, loc, var, 1)["x"]
    assert torch.equal(safe, torch.zeros(1))


def test_a_varying_feature_normalises_as_torchrl_does() -> None:
    torch.manual_seed(0)
    data = TensorDict({"x": torch.randn(5)}, [])
    loc = TensorDict({"x": torch.randn(5)}, [])
    var = TensorDict({"x": loc["x"] ** 2 + torch.rand(5) + 0.1}, [])
    plain = VecNormV2(in_keys=["x"], decay=1.0)._norm(data, loc, var, 1)["x"]
    safe = SafeVecNorm(in_keys=["x"], decay=1.0)._norm(data, loc, var, 1)["x"]
    assert torch.equal(plain, safe)


def test_the_training_env_normalises_with_it() -> None:
    env = make_training_env(load_smoke("env=tennis"), num_envs=2, seed=0)
    assert any(isinstance(t, SafeVecNorm) for t in env.transform)
    env.close()
