"""The network schema: the training config's ``model`` section extends it.

:class:`rlhc.config.train_schema.ModelConfig` is this schema with the shape left to a preset, so the
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

#: Policy parametrisations of continuous actions (``model.action_dist``); discrete
#: actions are always a ``Categorical`` over the network's logits.
#:
#: - ``gaussian`` (default): the policy of ML-Agents 0.5, the trainer the paper used. A
#:   Normal whose log scale is a learned parameter per action dimension, independent of
#:   the state; no squashing: the env clips the sample to the bounds, the stored action
#:   is the sample itself (scored exactly) and the entropy is analytic. ML-Agents draws
#:   ``u ~ N(mu, sigma)`` with ``sigma = 1`` at first and plays ``clip(u, -3, 3) / 3``:
#:   here ``pre_clip_range=3`` (the same distribution in action units: ``loc = mu / 3``,
#:   ``scale = sigma / 3``).
#: - ``tanh_normal``: a Normal with a per-state scale whose sample ``u`` is squashed into
#:   the bounds by tanh. ``u`` is stored next to the action and scored by the loss, so
#:   PPO's ratio is exact at any saturation (the tanh's Jacobian cancels in it); the
#:   entropy is the Normal's closed form plus a one-sample estimate of the squashing's
#:   log-Jacobian.
ACTION_DISTRIBUTIONS: tuple[str, ...] = ("gaussian", "tanh_normal")

#: What the actor reads (``model.actor_view``): ``worker``, the worker observation
#: ``(g, "observation")`` (the paper's policy); ``manager``, the manager observation
#: ``(g, "manager_observation")``, which holds the worker's and more (tennis: the ball
#: relative to the racket, a difference the worker view leaves the network to learn).
ACTOR_VIEWS: tuple[str, ...] = ("worker", "manager")


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
        action_dist: continuous actions: the policy's parametrisation, one of
            :data:`ACTION_DISTRIBUTIONS`. Ignored by discrete actions.
        initial_action_scale: continuous actions: the policy's scale at initialisation
            (``> 0``): for ``gaussian`` the initial value of the learned scale in units of
            ``pre_clip_range`` (ML-Agents 0.5: 1), for ``tanh_normal`` the pre-tanh scale
            of a zero network output.
        head_init_scale: continuous actions: the policy head's initial weights are
            multiplied by this (``> 0``; ML-Agents 0.5 initialises its mean head at
            0.01, so every action starts near 0).
        pre_clip_range: ``gaussian`` only: the network's mean and
            ``initial_action_scale`` are in units where the action bounds are
            ``±pre_clip_range``; the action is the sample divided by it (``> 0``;
            ML-Agents 0.5: 3, so its initial scale of 1 is a third of the action range;
            1: the network works in action units).
        actor_view: the observation the actor reads, one of :data:`ACTOR_VIEWS`
            (``worker``: the paper's; ``manager``: the manager critic's view, in tennis
            the worker's 8 values and the ball relative to the racket). The critics
            keep theirs (``critic.manager_view``).

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
        # The one check of these settings (rlhc.config.validation checks the rest of a config).
        # A value still MISSING ("???": a schema filled in later by Hydra) is not checked.
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
