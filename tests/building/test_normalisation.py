"""Observation normalisation: a feature that stops varying does not turn NaN."""

from __future__ import annotations

import pytest
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


def _observations(step: int, batch: int = 6) -> TensorDict:
    """A batch of two nested observation keys, with a feature that stops varying."""
    generator = torch.Generator().manual_seed(step)
    worker = torch.randn(batch, 4, 5, generator=generator) * 3 + 1
    worker[..., 0] = 0.1167  # constant: its variance rounds around 0
    manager = torch.rand(batch, 4, 2, generator=generator)
    return TensorDict({"g": {"obs": worker, "manager_obs": manager}}, [batch])


@pytest.mark.parametrize("decay", [0.99999, 1.0])  # 1: cumulative averages
def test_the_fast_path_equals_torchrl_to_the_bit_where_torchrl_is_finite(decay: float) -> None:
    keys = [("g", "obs"), ("g", "manager_obs")]
    fast = SafeVecNorm(in_keys=keys, decay=decay, reduce_batch_dims=True)
    plain = VecNormV2(in_keys=keys, decay=decay, reduce_batch_dims=True)
    for step in range(40):
        # Steps update and normalise every key; partial resets (missing tolerance) may
        # carry only some of them.
        data = _observations(step)
        partial = step % 3 == 2
        if partial:
            data = data.exclude(("g", "manager_obs"))
        assert fast._per_key(data)  # the plain-tensor path, not VecNormV2's own
        # A reset normalises whichever keys it carries (VecNormV2's missing tolerance).
        call = "_reset" if partial else "_step"
        outputs = [getattr(norm, call)(data.clone(), data.clone()) for norm in (fast, plain)]
        for key in outputs[1].keys(True, True):
            ours, theirs = outputs[0][key], outputs[1][key]
            finite = torch.isfinite(theirs)
            assert torch.equal(ours[finite], theirs[finite]), (step, key)
            # Where TorchRL's scale is NaN (the constant feature), ours is 0.
            assert torch.isfinite(ours).all()
    for name in ("_loc", "_count"):
        assert (getattr(fast, name) == getattr(plain, name)).all()
    # The stored second moment differs only where it was raised to the squared mean.
    raised = fast._var != plain._var
    assert not raised[("g", "manager_obs")].any()


@pytest.mark.parametrize("reduce_batch_dims", [True, False])  # fast path, VecNormV2's own
def test_clip_bounds_the_normalised_values_and_changes_nothing_inside(
    reduce_batch_dims: bool,
) -> None:
    keys = [("g", "obs"), ("g", "manager_obs")]
    clipped = SafeVecNorm(
        in_keys=keys, decay=0.99999, reduce_batch_dims=reduce_batch_dims, clip=1.5
    )
    free = SafeVecNorm(in_keys=keys, decay=0.99999, reduce_batch_dims=reduce_batch_dims)
    for step in range(5):
        data = _observations(step)
        ours = clipped._step(data.clone(), data.clone())
        reference = free._step(data.clone(), data.clone())
        for key in keys:
            assert ours[key].abs().max() <= 1.5
            assert torch.equal(ours[key], reference[key].clamp(-1.5, 1.5))
        if reduce_batch_dims:  # (per-element statistics normalise one batch to ~0)
            assert (reference["g", "obs"].abs() > 1.5).any()  # the bound did bind
    with pytest.raises(ValueError, match="clip=0"):
        SafeVecNorm(in_keys=keys, clip=0)


def test_the_training_env_takes_the_decay_and_clip_settings() -> None:
    cfg = load_smoke("env=tennis", "algo.observation_decay=1.0", "algo.observation_clip=5")
    env = make_training_env(cfg, num_envs=2, seed=0)
    (norm,) = [t for t in env.transform if isinstance(t, SafeVecNorm)]
    assert (norm.decay, norm.clip) == (1.0, 5.0)
    rollout = env.rollout(20)
    assert rollout["next", "racket", "observation"].abs().max() <= 5.0
    env.close()
