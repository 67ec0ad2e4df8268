"""The two critics of RLHC: the worker's own ``V_w(o_w)`` and the manager's ``V_m(o_m)``.

Both are the same shared-weights MLP over a group's agents; they differ only in what
they read (the worker's local observation, or the broader view the team manager has
of that agent) and where they write (in RLHC the manager criticises, it does
not act).
"""

from __future__ import annotations

from tensordict.nn import TensorDictModule

from rlhc.envs.keys import MANAGER_OBSERVATION, MANAGER_VALUE, OBSERVATION, WORKER_VALUE
from rlhc.modules.mlp import group_mlp
from rlhc.modules.schemas import NetworkConfig
from rlhc.modules.specs import HasSpecs, observation_size


def make_worker_critic(env: HasSpecs, group: str, cfg: NetworkConfig) -> TensorDictModule:
    """``V_w``: reads ``(group, "observation")``, writes ``(group, "worker_value")``.

    Args:
        env: an env (or :class:`~rlhc.modules.specs.EnvSpecs`).
        group: the agent group, e.g. ``"racket"``.
        cfg: the MLP shape.

    Returns:
        A ``TensorDictModule`` mapping ``[*B, n_g, d_w]`` to ``[*B, n_g, 1]``.

    Examples:
        >>> import torch
        >>> from tensordict import TensorDict
        >>> from torchrl.data import Composite, Unbounded
        >>> from rlhc.modules import EnvSpecs, NetworkConfig, make_worker_critic
        >>> obs = Composite(racket=Composite(observation=Unbounded((4, 8)), shape=(4,)))
        >>> critic = make_worker_critic(EnvSpecs(obs, Composite()), "racket", NetworkConfig())
        >>> td = TensorDict({("racket", "observation"): torch.randn(5, 4, 8)}, [5])
        >>> critic(td)["racket", "worker_value"].shape
        torch.Size([5, 4, 1])
    """
    n_agents, n_inputs = observation_size(env, group)
    return TensorDictModule(
        group_mlp(n_inputs, 1, n_agents, cfg),
        in_keys=[(group, OBSERVATION)],
        out_keys=[(group, WORKER_VALUE)],
    )


def make_manager_critic(
    env: HasSpecs, group: str, cfg: NetworkConfig, *, manager_view: bool = True
) -> TensorDictModule:
    """``V_m``: reads ``(group, "manager_observation")``, writes ``(group, "manager_value")``.

    Args:
        env: an env (or :class:`~rlhc.modules.specs.EnvSpecs`).
        group: the agent group, e.g. ``"racket"``.
        cfg: the MLP shape.
        manager_view: ``False`` builds the *twin* control instead: a second critic on
            the worker's own ``(group, "observation")``, initialised independently of
            the worker critic, still writing ``(group, "manager_value")``. Its max with
            the worker critic is as optimistic as RLHC's max, without the broader view.

    Returns:
        A ``TensorDictModule`` mapping ``[*B, n_g, d_m]`` to ``[*B, n_g, 1]``.

    Examples:
        >>> import torch
        >>> from tensordict import TensorDict
        >>> from torchrl.data import Composite, Unbounded
        >>> from rlhc.modules import EnvSpecs, NetworkConfig, make_manager_critic
        >>> obs = Composite(
        ...     racket=Composite(manager_observation=Unbounded((4, 10)), shape=(4,))
        ... )
        >>> critic = make_manager_critic(EnvSpecs(obs, Composite()), "racket", NetworkConfig())
        >>> td = TensorDict({("racket", "manager_observation"): torch.randn(5, 4, 10)}, [5])
        >>> critic(td)["racket", "manager_value"].shape
        torch.Size([5, 4, 1])
    """
    n_agents, n_inputs = observation_size(env, group, manager=manager_view)
    return TensorDictModule(
        group_mlp(n_inputs, 1, n_agents, cfg),
        in_keys=[(group, MANAGER_OBSERVATION if manager_view else OBSERVATION)],
        out_keys=[(group, MANAGER_VALUE)],
    )
