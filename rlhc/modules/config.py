"""The network schema: the training config's ``model`` section extends it.

:class:`rlhc.config.ModelConfig` is this schema plus the recurrent options, so the
networks and the config share one definition of every network setting (and of its
check: :meth:`NetworkConfig.__post_init__`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from omegaconf import MISSING
from torch import nn

from rlhc.errors import allowed

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
        initial_action_scale: continuous actions: the policy's scale (before the tanh
            squashing) when the network's scale output is 0, i.e. at initialisation
            (``> 0``). 0.5 by measurement (see the README): the shot window is narrow,
            and a scale of 1 buries the policy's aim in noise.
        shared_trunk: discrete actions (soccer) only: the actor and the worker critic
            of a group share their hidden layers, with a policy head and a value head
            on top (ML-Agents 0.5's discrete PPO network, which the paper's soccer
            brains used), built together by :func:`~rlhc.modules.make_actor_value`;
            the manager critic stays a separate network. Tennis (continuous actions)
            refuses it. Default false: sharing saves no compute here (each of TorchRL's
            two operators runs the trunk: the same FLOP per world-decision, and the
            same update time within noise, by measurement), every preset and result
            of this project used separate networks, and its learning effect rests on
            one seed so far (soccer PPO, 2 processes: 27-59-14 against the scripted
            team, separate networks 4-50-46; one-process separate-network seeds
            30-64-6 and 49-41-10; README "Do trained teams play?").

    Examples:
        >>> from rlhc.modules import NetworkConfig
        >>> NetworkConfig(hidden_size=256).activation_class
        <class 'torch.nn.modules.activation.Tanh'>
    """

    num_layers: int = 2
    hidden_size: int = 128
    activation: str = "tanh"
    initial_action_scale: float = 0.5
    shared_trunk: bool = False

    def __post_init__(self) -> None:
        # The one check of these settings (rlhc.validation checks the rest of a config).
        # A value still MISSING ("???": a schema filled in later by Hydra) is not checked.
        if _given(self.num_layers) and self.num_layers < 1:
            raise allowed("model.num_layers", self.num_layers, "an integer >= 1")
        if _given(self.hidden_size) and self.hidden_size < 1:
            raise allowed("model.hidden_size", self.hidden_size, "an integer >= 1")
        scale = self.initial_action_scale
        if _given(scale) and not (math.isfinite(scale) and scale > 0):
            raise allowed("model.initial_action_scale", scale, "a finite number in (0, inf)")
        if _given(self.activation) and self.activation not in ACTIVATIONS:
            raise allowed("model.activation", self.activation, ", ".join(ACTIVATIONS))

    @property
    def activation_class(self) -> type[nn.Module]:
        """The ``torch.nn`` class named by :attr:`activation`."""
        return ACTIVATIONS[self.activation]


def _given(value: Any) -> bool:
    """Whether a schema field holds a value (not OmegaConf's ``MISSING``)."""
    return value != MISSING
