"""The two critics of RLHC: the worker's own ``V_w(o_w)`` and the manager's ``V_m(o_m)``:
the same shared-weights MLP over a group's agents, reading different observations.
"""

from __future__ import annotations

from tensordict.nn import TensorDictModule

from rlhc.envs.keys import MANAGER_OBSERVATION, MANAGER_VALUE, OBSERVATION, WORKER_VALUE
from rlhc.modules.mlp import group_mlp
from rlhc.modules.schemas import NetworkConfig
from rlhc.modules.specs import HasSpecs, observation_size


def make_worker_critic(env: HasSpecs, group: str, cfg: NetworkConfig) -> TensorDictModule:
    """``V_w``: reads ``(group, "observation")``, writes ``(group, "worker_value")``.

    A ``TensorDictModule`` mapping ``[*B, n_g, d_w]`` to ``[*B, n_g, 1]``; ``env`` may be
    an :class:`~rlhc.modules.specs.EnvSpecs`.

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
    env: HasSpecs,
    group: str,
    cfg: NetworkConfig,
    *,
    manager_view: bool = True,
    shared_view: bool = False,
) -> TensorDictModule:
    """``V_m``: reads ``(group, "manager_observation")``, writes ``(group, "manager_value")``.

    Args:
        env: an env (or :class:`~rlhc.modules.specs.EnvSpecs`).
        group: the agent group, e.g. ``"racket"``.
        cfg: the MLP shape.
        manager_view: ``False`` builds the *twin* control instead: a second, independent
            critic on the worker's own ``(group, "observation")``, whose max with the
            worker critic is as optimistic as RLHC's, without the broader view.
        shared_view: every agent of the group has the same manager observation (a view
            of the whole world: ``env.manager_view=world`` or ``state``): the critic runs
            once per world and its value is every agent's, as a MAPPO critic does.

    Returns:
        A ``TensorDictModule`` mapping ``[*B, n_g, d_m]`` to ``[*B, n_g, 1]`` (as
        :func:`make_worker_critic`'s example, with ``manager_observation``).
    """
    n_agents, n_inputs = observation_size(env, group, manager=manager_view)
    return TensorDictModule(
        group_mlp(n_inputs, 1, n_agents, cfg, shared_input=manager_view and shared_view),
        in_keys=[(group, MANAGER_OBSERVATION if manager_view else OBSERVATION)],
        out_keys=[(group, MANAGER_VALUE)],
    )
