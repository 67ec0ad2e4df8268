"""Networks: actors, worker critics and manager critics, built from env specs.

Examples:
    >>> from rlhc.modules import NetworkConfig, make_actor, make_worker_critic
"""

from __future__ import annotations

from rlhc.modules.actors import actor_observation_key, make_actor
from rlhc.modules.critics import make_manager_critic, make_worker_critic
from rlhc.modules.schemas import ACTIVATIONS, NetworkConfig
from rlhc.modules.specs import EnvSpecs, HasSpecs

__all__ = [
    "ACTIVATIONS",
    "EnvSpecs",
    "HasSpecs",
    "NetworkConfig",
    "actor_observation_key",
    "make_actor",
    "make_manager_critic",
    "make_worker_critic",
]
