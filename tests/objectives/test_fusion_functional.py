"""The pure tensor maths: fusion modes, the manager mask; the reference GAE against a plain loop."""

from __future__ import annotations

import pytest
import torch
from reference_gae import generalized_advantage, hierarchical_gae
from rlhc_synthetic import loop_gae
from torch.testing import assert_close

from rlhc.objectives import FUSIONS, fuse_values, manager_consulted_mask

WORKER = torch.tensor([1.0, 3.0, -2.0, 0.5])
MANAGER = torch.tensor([2.0, 2.0, -1.0, 0.5])


@pytest.mark.parametrize(
    ("fusion", "expected", "share"),
    [
        ("local", [1.0, 3.0, -2.0, 0.5], [0.0, 0.0, 0.0, 0.0]),
        ("manager", [2.0, 2.0, -1.0, 0.5], [1.0, 1.0, 1.0, 1.0]),
        # element-wise max; the tie (0.5, 0.5) goes to the worker
        ("max", [2.0, 3.0, -1.0, 0.5], [1.0, 0.0, 1.0, 0.0]),
        ("mean", [1.5, 2.5, -1.5, 0.5], [0.5, 0.5, 0.5, 0.5]),
        # 0.25 * V_m + 0.75 * V_w
        ("weighted", [1.25, 2.75, -1.75, 0.5], [0.25, 0.25, 0.25, 0.25]),
    ],
)
def test_fuse_values_modes(fusion: str, expected: list[float], share: list[float]) -> None:
    fused, manager_share = fuse_values(WORKER, MANAGER, fusion=fusion, weight=0.25)
    assert_close(fused, torch.tensor(expected), rtol=0, atol=0)
    assert_close(manager_share, torch.tensor(share), rtol=0, atol=0)


@pytest.mark.parametrize("fusion", FUSIONS)
def test_unconsulted_manager_leaves_the_worker_value(fusion: str) -> None:
    consulted = torch.tensor([True, False, True, False])
    fused, share = fuse_values(
        WORKER, MANAGER, fusion=fusion, weight=0.25, manager_consulted=consulted
    )
    assert_close(fused[~consulted], WORKER[~consulted], rtol=0, atol=0)
    assert (share[~consulted] == 0).all()
    full, _ = fuse_values(WORKER, MANAGER, fusion=fusion, weight=0.25)
    assert_close(fused[consulted], full[consulted], rtol=0, atol=0)


def test_max_gradient_goes_to_the_selected_critic() -> None:
    worker = WORKER.clone().requires_grad_()
    manager = MANAGER.clone().requires_grad_()
    fused, share = fuse_values(worker, manager, fusion="max")
    fused.sum().backward()
    assert_close(manager.grad, share)
    assert_close(worker.grad, 1 - share)


def test_manager_consulted_mask_every_k_steps() -> None:
    steps = torch.arange(11)
    assert manager_consulted_mask(steps, 1).all()
    assert manager_consulted_mask(steps, 5).nonzero().flatten().tolist() == [0, 5, 10]


@pytest.mark.parametrize("bad", [0, -3, 2.5, True, "5"])
def test_manager_interval_must_be_a_positive_integer(bad: object) -> None:
    with pytest.raises(ValueError, match=r"manager_interval must be an integer >= 1"):
        manager_consulted_mask(torch.arange(3), bad)  # type: ignore[arg-type]


def test_unknown_fusion_names_the_choices() -> None:
    with pytest.raises(ValueError, match=r"unknown fusion 'maximum'.*'local'.*'weighted'"):
        fuse_values(WORKER, MANAGER, fusion="maximum")


@pytest.mark.parametrize("weight", [-0.1, 1.5])
def test_weight_outside_unit_interval(weight: float) -> None:
    with pytest.raises(ValueError, match=r"weight must lie in \[0, 1\]"):
        fuse_values(WORKER, MANAGER, fusion="weighted", weight=weight)


def test_mismatched_value_shapes_name_both() -> None:
    with pytest.raises(ValueError, match=r"\(4,\) \(worker\) and \(4, 1\) \(manager\)"):
        fuse_values(WORKER, MANAGER[:, None], fusion="max")


def test_gae_input_shapes_must_agree() -> None:
    value = torch.zeros(2, 5, 3, 1)
    flags = torch.zeros(2, 5, 3, 1, dtype=torch.bool)
    with pytest.raises(ValueError, match=r"reward \(2, 5, 1\)"):
        generalized_advantage(
            0.9, 0.9, value, value, torch.zeros(2, 5, 1), flags, flags, time_dim=1
        )


@pytest.mark.parametrize(
    ("batch", "time_dim"),
    [((3,), 1), ((2, 3), 2), ((), 0)],
    ids=["[N,T,n,1]", "[B,N,T,n,1]", "[T,n,1]"],
)
def test_gae_matches_plain_loop_with_agents_after_time(
    batch: tuple[int, ...], time_dim: int
) -> None:
    gen = torch.Generator().manual_seed(1)
    shape = (*batch, 9, 4, 1)
    value, next_value, reward = (torch.randn(shape, generator=gen) for _ in range(3))
    terminated = torch.rand(shape, generator=gen) < 0.15
    done = terminated | (torch.rand(shape, generator=gen) < 0.15)
    advantage, value_target = generalized_advantage(
        0.97, 0.9, value, next_value, reward, done, terminated, time_dim=time_dim
    )
    expected = loop_gae(0.97, 0.9, value, next_value, reward, done, terminated, time_dim)
    assert_close(advantage, expected)
    assert_close(value_target, expected + value)


def test_hierarchical_max_matches_plain_loop() -> None:
    gen = torch.Generator().manual_seed(2)
    shape = (2, 3, 11, 4, 1)  # two batch dims, time, agents, feature
    values = [torch.randn(shape, generator=gen) for _ in range(5)]
    worker, manager, next_worker, next_manager, reward = values
    terminated = torch.rand(shape, generator=gen) < 0.1
    done = terminated | (torch.rand(shape, generator=gen) < 0.1)
    out = hierarchical_gae(
        0.99,
        0.95,
        worker_value=worker,
        manager_value=manager,
        next_worker_value=next_worker,
        next_manager_value=next_manager,
        reward=reward,
        done=done,
        terminated=terminated,
        time_dim=2,
        fusion="max",
    )
    # The reference fuses with Python's max, one element at a time.
    fused = torch.tensor(
        [max(w, m) for w, m in zip(worker.flatten(), manager.flatten(), strict=True)]
    )
    next_fused = torch.tensor(
        [max(w, m) for w, m in zip(next_worker.flatten(), next_manager.flatten(), strict=True)]
    )
    fused, next_fused = fused.reshape(shape), next_fused.reshape(shape)
    expected = loop_gae(0.99, 0.95, fused, next_fused, reward, done, terminated, 2)
    assert_close(out.fused_value, fused, rtol=0, atol=0)
    assert_close(out.next_fused_value, next_fused, rtol=0, atol=0)
    assert_close(out.advantage, expected)
    assert_close(out.value_target, expected + fused)
    assert_close(out.manager_share, (manager > worker).float(), rtol=0, atol=0)


def test_done_at_one_agent_does_not_cut_another() -> None:
    # Two agents with identical data, except that agent 0's episode ends at t=1.
    shape = (1, 4, 2, 1)
    value = torch.zeros(shape)
    reward = torch.ones(shape)
    done = torch.zeros(shape, dtype=torch.bool)
    done[0, 1, 0] = True
    out = hierarchical_gae(
        1.0,
        1.0,
        worker_value=value,
        manager_value=value,
        next_worker_value=value,
        next_manager_value=value,
        reward=reward,
        done=done,
        terminated=done,
        time_dim=1,
    )
    # gamma = lambda = 1, V = 0: the advantage is the sum of rewards left in the episode.
    assert out.advantage[0, :, 0, 0].tolist() == [2.0, 1.0, 2.0, 1.0]
    assert out.advantage[0, :, 1, 0].tolist() == [4.0, 3.0, 2.0, 1.0]
