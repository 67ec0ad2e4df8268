"""The network schema, which the training config's ``model`` section extends
(:class:`rlhc.config.train_schema.ModelConfig`): one definition and one check of every
network setting.
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

#: Policy parametrisations of continuous actions (``model.action_dist``; discrete actions
#: are a ``Categorical`` over logits): ``gaussian``, ML-Agents 0.5's state-free Gaussian,
#: unsquashed; ``tanh_normal``, a tanh-squashed Normal (:mod:`rlhc.modules.actors`).
ACTION_DISTRIBUTIONS: tuple[str, ...] = ("gaussian", "tanh_normal")

#: What the actor reads (``model.actor_view``): the worker observation (the paper's
#: policy) or the manager observation, which holds the worker's and more.
ACTOR_VIEWS: tuple[str, ...] = ("worker", "manager")


@dataclass
class NetworkConfig:
    """Shape of every MLP (actor, worker critic, manager critic) of one group.

    Plain types only, so that Hydra can validate yaml files against it.

    Attributes:
        num_layers: hidden layers per MLP (``>= 1``).
        hidden_size: units per hidden layer (``>= 1``).
        activation: one of :data:`ACTIVATIONS` (``silu`` is ML-Agents 0.5's swish).
        action_dist: continuous actions: the policy's parametrisation, one of
            :data:`ACTION_DISTRIBUTIONS`.
        initial_action_scale: continuous actions: the policy's initial scale (``gaussian``:
            in units of ``pre_clip_range``; ``tanh_normal``: pre-tanh, at a zero output).
        head_init_scale: continuous actions: a factor on the policy head's initial weights,
            so that every action starts near 0 (ML-Agents 0.5: 0.01).
        pre_clip_range: ``gaussian`` only: the action bounds in the network's units, the
            action being the sample divided by it (ML-Agents 0.5: 3).
        actor_view: the observation the actor reads, one of :data:`ACTOR_VIEWS` (the
            critics keep theirs).

    Examples:
        >>> from rlhc.modules import NetworkConfig
        >>> NetworkConfig(hidden_size=256).activation_class
        <class 'torch.nn.modules.activation.Tanh'>
    """

    num_layers: int = 2
    hidden_size: int = 128
    activation: str = "tanh"
    action_dist: str = "gaussian"
    initial_action_scale: float = 1.0
    head_init_scale: float = 0.01
    pre_clip_range: float = 3.0
    actor_view: str = "worker"

    def __post_init__(self) -> None:
        # The one check of these settings; a value still MISSING (filled in by Hydra) is not.
        if _given(self.num_layers) and self.num_layers < 1:
            raise allowed("model.num_layers", self.num_layers, "an integer >= 1")
        if _given(self.hidden_size) and self.hidden_size < 1:
            raise allowed("model.hidden_size", self.hidden_size, "an integer >= 1")
        scale = self.initial_action_scale
        if _given(scale) and not (math.isfinite(scale) and scale > 0):
            raise allowed("model.initial_action_scale", scale, "a finite number in (0, inf)")
        for name in ("head_init_scale", "pre_clip_range"):
            value = getattr(self, name)
            if _given(value) and not (math.isfinite(value) and value > 0):
                raise allowed(f"model.{name}", value, "a finite number in (0, inf)")
        if _given(self.action_dist) and self.action_dist not in ACTION_DISTRIBUTIONS:
            raise allowed("model.action_dist", self.action_dist, ", ".join(ACTION_DISTRIBUTIONS))
        if _given(self.activation) and self.activation not in ACTIVATIONS:
            raise allowed("model.activation", self.activation, ", ".join(ACTIVATIONS))
        if _given(self.actor_view) and self.actor_view not in ACTOR_VIEWS:
            raise allowed("model.actor_view", self.actor_view, ", ".join(ACTOR_VIEWS))

    @property
    def activation_class(self) -> type[nn.Module]:
        """The ``torch.nn`` class named by :attr:`activation`."""
        return ACTIVATIONS[self.activation]


def _given(value: Any) -> bool:
    """Whether a schema field holds a value (not OmegaConf's ``MISSING``)."""
    return value != MISSING
