"""The one MLP every network of a group is made of (actor, worker critic, manager critic)."""

from __future__ import annotations

import torch
from torch import nn
from torchrl.modules import MLP

from rlhc.modules.schemas import NetworkConfig


class GroupMLP(nn.Module):
    """TorchRL's ``MLP`` applied to every agent of a group with the same weights.

    What ``MultiAgentMLP(centralized=False, share_params=True)`` computes, with the same
    parameter names (``params.0.weight``, ...), so that checkpoints of either load into
    the other; but faster, called directly, without ``MultiAgentMLP``'s swap of its
    parameters into a stateless copy of the network on every call.

    ``n_inputs`` and ``n_outputs`` are per agent; the input's agent dim is checked
    against ``n_agents``. With ``shared_input`` every agent's input is the same (a view of
    the whole world, as a centralised critic reads): the network runs on the first agent's
    and its output is expanded to the others, which equals running it on each, values and
    gradients, at ``1 / n_agents`` of the arithmetic (TorchRL's ``MultiAgentMLP`` does the
    same when centralised with shared parameters). The caller guarantees the equality.

    Examples:
        >>> mlp = GroupMLP(8, 3, 2, depth=1, num_cells=16, activation_class=nn.Tanh)
        >>> mlp(torch.randn(5, 2, 8)).shape
        torch.Size([5, 2, 3])
    """

    def __init__(
        self,
        n_inputs: int,
        n_outputs: int,
        n_agents: int,
        *,
        depth: int,
        num_cells: int,
        activation_class: type[nn.Module],
        activate_last_layer: bool = False,
        shared_input: bool = False,
    ) -> None:
        super().__init__()
        self.n_agents = n_agents
        self.shared_input = shared_input
        # Named as MultiAgentMLP names its weights: one state dict for both.
        self.params = MLP(
            in_features=n_inputs,
            out_features=n_outputs,
            depth=depth,
            num_cells=num_cells,
            activation_class=activation_class,
            activate_last_layer=activate_last_layer,
        )

    @property
    def head(self) -> nn.Linear:
        """The output layer."""
        return self.params[-2 if self.params.activate_last_layer else -1]

    def forward(self, inputs: torch.Tensor) -> torch.Tensor:
        if inputs.ndim < 2 or inputs.shape[-2] != self.n_agents:
            raise ValueError(
                f"GroupMLP of {self.n_agents} agents expects inputs [*B, {self.n_agents}, "
                f"features], got shape {tuple(inputs.shape)}"
            )
        if self.shared_input:
            output = self.params(inputs[..., :1, :])
            return output.expand(*inputs.shape[:-1], output.shape[-1])
        return self.params(inputs)


def group_mlp(
    n_inputs: int, n_outputs: int, n_agents: int, cfg: NetworkConfig, *, shared_input: bool = False
) -> GroupMLP:
    """One MLP applied to every agent of a group with the same weights.

    Shared weights are symmetric self-play (each agent sees the world in its own team's
    frame), and one matmul for all agents makes an update about twice as fast as a loop.
    ``shared_input``: every agent reads the same input, run once (see :class:`GroupMLP`).
    """
    return GroupMLP(
        n_inputs,
        n_outputs,
        n_agents,
        depth=cfg.num_layers,
        num_cells=cfg.hidden_size,
        activation_class=cfg.activation_class,
        shared_input=shared_input,
    )
