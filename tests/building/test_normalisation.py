"""Observation normalisation: TorchRL's VecNormV2 numbers, but a feature that stops
varying normalises to 0, not NaN, and the output can be bounded."""

from __future__ import annotations

import warnings

import pytest
import torch
from configs import load_smoke
from tensordict import TensorDict
from torchrl.envs import VecNormV2

from rlhc.building.builders import make_training_env
from rlhc.building.normalisation import SafeVecNorm

KEYS = [("g", "obs"), ("g", "manager_obs")]


def observations(step: int, batch: int = 6) -> TensorDict:
    """A batch of two nested observation keys, with a feature that stops varying."""
    generator = torch.Generator().manual_seed(step)
    worker = torch.randn(batch, 4, 5, generator=generator) * 3 + 1
    worker[..., 0] = 0.1167  # constant: its variance rounds around 0
    manager = torch.rand(batch, 4, 2, generator=generator)
    return TensorDict({"g": {"obs": worker, "manager_obs": manager}}, [batch])


def vecnorm(decay: float) -> VecNormV2:
    with warnings.catch_warnings():  # VecNormV2 calls batched data "experimental"
        warnings.simplefilter("ignore")
        return VecNormV2(in_keys=KEYS, decay=decay, reduce_batch_dims=True)


def test_a_constant_feature_normalises_to_zero_not_nan() -> None:
    constant = TensorDict({"x": torch.full((8, 1), 0.1167)}, [8])
    theirs = VecNormV2(in_keys=["x"], decay=1.0, reduce_batch_dims=True)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        plain = theirs._step(constant.clone(), constant.clone())["x"]
    ours = SafeVecNorm(["x"], decay=1.0)._step(constant.clone(), constant.clone())["x"]
    assert torch.isnan(plain).all()  # E[x^2] - E[x]^2 rounds below 0
    assert torch.equal(ours, torch.zeros_like(ours))


@pytest.mark.parametrize("decay", [0.99999, 1.0])  # 1: cumulative averages
def test_it_equals_torchrl_to_the_bit_where_torchrl_is_finite(decay: float) -> None:
    ours, theirs = SafeVecNorm(KEYS, decay=decay), vecnorm(decay)
    for step in range(40):
        data = observations(step)
        # A partial reset may carry only some keys: both normalise whichever it carries.
        partial = step % 3 == 2
        if partial:
            data = data.exclude(("g", "manager_obs"))
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            outputs = [
                norm._reset(data.clone(), data.clone())
                if partial
                else norm._step(data.clone(), data.clone())
                for norm in (ours, theirs)
            ]
        for key in outputs[1].keys(True, True):
            finite = torch.isfinite(outputs[1][key])
            assert torch.equal(outputs[0][key][finite], outputs[1][key][finite]), (step, key)
            assert torch.isfinite(outputs[0][key]).all()  # where TorchRL's is NaN, ours is 0
            assert (~finite).sum() < finite.sum()  # the comparison covers most values
    # The same running moments, in the same state-dict layout.
    mine, reference = ours.get_extra_state(), theirs.get_extra_state()
    assert mine.keys() == reference.keys()
    assert all(torch.equal(mine[k], reference[k]) for k in mine)


def test_a_vecnorm_state_dict_loads_and_gives_its_statistics() -> None:
    theirs = vecnorm(0.9999)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for step in range(5):
            theirs._step(observations(step), observations(step))
    ours = SafeVecNorm(KEYS, decay=0.9999)
    ours.load_state_dict(theirs.state_dict())
    varying = ("g", "manager_obs")
    assert torch.equal(ours.loc[varying], theirs.loc[varying])
    assert torch.equal(ours.scale[varying], theirs.scale[varying])
    frozen = ours.freeze().get_extra_state()
    ours.update(observations(9))
    assert all(torch.equal(v, ours.get_extra_state()[k]) for k, v in frozen.items())


def test_clip_bounds_the_normalised_values_and_changes_nothing_inside() -> None:
    clipped, free = SafeVecNorm(KEYS, decay=0.99999, clip=1.5), SafeVecNorm(KEYS, decay=0.99999)
    for step in range(5):
        data = observations(step)
        ours = clipped._step(data.clone(), data.clone())
        reference = free._step(data.clone(), data.clone())
        for key in KEYS:
            assert ours[key].abs().max() <= 1.5
            assert torch.equal(ours[key], reference[key].clamp(-1.5, 1.5))
        assert (reference["g", "obs"].abs() > 1.5).any()  # the bound did bind


@pytest.mark.parametrize(
    ("setting", "message"), [({"clip": 0}, "clip=0"), ({"decay": 1.5}, "decay=1.5")]
)
def test_a_bad_setting_is_named(setting: dict[str, float], message: str) -> None:
    with pytest.raises(ValueError, match=message):
        SafeVecNorm(KEYS, **setting)


def test_the_training_env_takes_the_decay_and_clip_settings() -> None:
    cfg = load_smoke("env=tennis", "algo.observation_decay=1.0", "algo.observation_clip=5")
    env = make_training_env(cfg, num_envs=2, seed=0)
    (norm,) = [t for t in env.transform if isinstance(t, SafeVecNorm)]
    assert (norm.decay, norm.clip) == (1.0, 5.0)
    rollout = env.rollout(20)
    assert rollout["next", "racket", "observation"].abs().max() <= 5.0
    assert torch.isfinite(rollout["next", "racket", "observation"]).all()
    env.close()
