"""The one MLP every network of a group is made of (actor, worker critic, manager critic)."""

from __future__ import annotations

from torchrl.modules import MultiAgentMLP

from rlhc.modules.schemas import NetworkConfig


def group_mlp(n_inputs: int, n_outputs: int, n_agents: int, cfg: NetworkConfig) -> MultiAgentMLP:
    """One MLP applied to every agent of a group with the same weights.

    ``share_params=True`` is symmetric self-play (both teams, all agents of a group
    share a network, each agent seeing the world in its own team's frame);
    ``centralized=False`` keeps each agent's input its own. Batching the agents into
    one matmul is also what makes a PPO update about twice as fast as a loop over
    agents on a 2-core CPU.

    Args:
        n_inputs: per-agent input size.
        n_outputs: per-agent output size.
        n_agents: agents in the group.
        cfg: depth, width and activation.

    Returns:
        A ``MultiAgentMLP`` mapping ``[*B, n_agents, n_inputs]`` to ``[*B, n_agents, n_outputs]``.
    """
    return MultiAgentMLP(
        n_agent_inputs=n_inputs,
        n_agent_outputs=n_outputs,
        n_agents=n_agents,
        centralized=False,
        share_params=True,
        depth=cfg.num_layers,
        num_cells=cfg.hidden_size,
        activation_class=cfg.activation_class,
    )
