"""Synthetic data following the TensorDict contract, and a plain-loop GAE reference.

Imported by the tests of this folder as ``rlhc_synthetic`` (a unique name: the test
folders are not packages).
"""

from __future__ import annotations

import torch
from tensordict import TensorDict
from tensordict.nn import TensorDictModule
from torchrl.data import Bounded, Categorical, Composite, Unbounded

from rlhc.modules import EnvSpecs

GROUP = "racket"
D_WORKER, D_MANAGER = 8, 10


def make_specs(*, n_agents: int = 4, group: str = GROUP, discrete: int | None = None) -> EnvSpecs:
    """Specs of one group: continuous 3-d actions in [-1, 1], or ``discrete`` choices."""
    observation = Composite(
        {
            group: Composite(
                observation=Unbounded((n_agents, D_WORKER)),
                manager_observation=Unbounded((n_agents, D_MANAGER)),
                shape=(n_agents,),
            )
        }
    )
    action = (
        Bounded(-1.0, 1.0, (n_agents, 3))
        if discrete is None
        else Categorical(discrete, (n_agents,))
    )
    return EnvSpecs(observation, Composite({group: Composite(action=action, shape=(n_agents,))}))


def make_batch(
    *,
    batch: tuple[int, ...] = (3,),
    steps: int = 7,
    n_agents: int = 4,
    group: str = GROUP,
    p_terminated: float = 0.15,
    p_truncated: float = 0.15,
    seed: int = 0,
) -> TensorDict:
    """Random collected data ``[*batch, steps]`` with per-agent ends of episodes."""
    gen = torch.Generator().manual_seed(seed)
    shape = (*batch, steps, n_agents)

    def randn(*trailing: int) -> torch.Tensor:
        return torch.randn(*shape, *trailing, generator=gen)

    terminated = torch.rand(*shape, 1, generator=gen) < p_terminated
    truncated = (torch.rand(*shape, 1, generator=gen) < p_truncated) & ~terminated
    step_count = torch.randint(0, 20, (*batch, steps, 1), generator=gen)
    return TensorDict(
        {
            group: {"observation": randn(D_WORKER), "manager_observation": randn(D_MANAGER)},
            "step_count": step_count,
            "next": {
                group: {
                    "observation": randn(D_WORKER),
                    "manager_observation": randn(D_MANAGER),
                    "reward": randn(1),
                    "terminated": terminated,
                    "truncated": truncated,
                    "done": terminated | truncated,
                },
                "step_count": step_count + 1,
            },
        },
        batch_size=(*batch, steps),
    )


def constant_critic(value: float, *, manager: bool, group: str = GROUP) -> TensorDictModule:
    """A critic that answers ``value`` for every agent and step (closed-form toys)."""
    in_leaf = "manager_observation" if manager else "observation"
    out_leaf = "manager_value" if manager else "worker_value"
    return TensorDictModule(
        lambda obs: torch.full_like(obs[..., :1], value),
        in_keys=[(group, in_leaf)],
        out_keys=[(group, out_leaf)],
    )


def loop_gae(
    gamma: float,
    lmbda: float,
    value: torch.Tensor,
    next_value: torch.Tensor,
    reward: torch.Tensor,
    done: torch.Tensor,
    terminated: torch.Tensor,
    time_dim: int,
) -> torch.Tensor:
    """GAE written as the textbook backward loop, one trajectory at a time.

    ``A_t = delta_t + gamma * lmbda * (1 - done_t) * A_{t+1}`` with
    ``delta_t = r_t + gamma * (1 - terminated_t) * V(s_{t+1}) - V(s_t)``.
    """
    tensors = [t.movedim(time_dim, -1).double() for t in (value, next_value, reward)]
    flags = [t.movedim(time_dim, -1).double() for t in (done, terminated)]
    value, next_value, reward = (t.reshape(-1, t.shape[-1]) for t in tensors)
    done, terminated = (t.reshape(-1, t.shape[-1]) for t in flags)
    advantage = torch.zeros_like(value)
    for row in range(value.shape[0]):
        running = 0.0
        for t in reversed(range(value.shape[1])):
            delta = (
                reward[row, t]
                + gamma * (1 - terminated[row, t]) * next_value[row, t]
                - value[row, t]
            )
            running = delta + gamma * lmbda * (1 - done[row, t]) * running
            advantage[row, t] = running
    moved_shape = tensors[0].shape
    return advantage.reshape(moved_shape).movedim(-1, time_dim).float()
