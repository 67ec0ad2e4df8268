"""The network configuration schema (registered in Hydra by the trainer)."""

from __future__ import annotations

from dataclasses import dataclass

from torch import nn

#: Activation names accepted in a config, mapped to their ``torch.nn`` classes.
ACTIVATIONS: dict[str, type[nn.Module]] = {
    "tanh": nn.Tanh,
    "relu": nn.ReLU,
    "elu": nn.ELU,
    "gelu": nn.GELU,
    "silu": nn.SiLU,
}


@dataclass
class NetworkConfig:
    """Shape of every MLP (actor, worker critic, manager critic) of one group.

    Plain types only, so that Hydra can validate yaml files against it. The paper's
    defaults (Table 3) are 2 x 128 for tennis and 2 x 256 for soccer; tanh is the usual
    PPO choice for small MLPs and what TorchRL's multi-agent examples use.

    Attributes:
        num_layers: hidden layers per MLP (``>= 1``).
        hidden_size: units per hidden layer (``>= 1``).
        activation: one of :data:`ACTIVATIONS` (``silu`` is ML-Agents 0.5's swish).
        initial_action_scale: continuous actors: the Normal scale (before the tanh
            squashing) for a zero scale output, i.e. at initialisation (``> 0``).
        shared_trunk: discrete actors only: the actor and the worker critic share their
            ``num_layers`` hidden layers (one trunk, a logits head and a value head, as
            ML-Agents 0.5's discrete PPO), built together by
            :func:`~rlhc.modules.make_actor_value`. The manager critic stays separate.

    Examples:
        >>> from rlhc.modules import NetworkConfig
        >>> NetworkConfig(hidden_size=256).activation_class
        <class 'torch.nn.modules.activation.Tanh'>
    """

    num_layers: int = 2
    hidden_size: int = 128
    activation: str = "tanh"
    initial_action_scale: float = 1.0
    shared_trunk: bool = False

    def __post_init__(self) -> None:
        if self.num_layers < 1:
            raise ValueError(f"num_layers must be >= 1, got {self.num_layers}")
        if self.hidden_size < 1:
            raise ValueError(f"hidden_size must be >= 1, got {self.hidden_size}")
        if not self.initial_action_scale > 0 or self.initial_action_scale == float("inf"):
            raise ValueError(
                f"initial_action_scale must be a finite number > 0, got {self.initial_action_scale}"
            )
        if self.activation not in ACTIVATIONS:
            raise ValueError(
                f"unknown activation {self.activation!r}; choose one of {sorted(ACTIVATIONS)}"
            )

    @property
    def activation_class(self) -> type[nn.Module]:
        """The ``torch.nn`` class named by :attr:`activation`."""
        return ACTIVATIONS[self.activation]
