"""Reading a group's sizes from TorchRL specs: the network factories take anything with
``full_observation_spec`` and ``full_action_spec``, so that networks can be built, and
tested, without a simulator.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

from torchrl.data import Composite, TensorSpec

from rlhc.envs.keys import ACTION, MANAGER_OBSERVATION, OBSERVATION


class HasSpecs(Protocol):
    """Anything exposing the two composite specs of a TorchRL env."""

    @property
    def full_observation_spec(self) -> Composite: ...

    @property
    def full_action_spec(self) -> Composite: ...


@dataclass(frozen=True)
class EnvSpecs:
    """The specs of an env without the env (tests, or networks built before the env).

    Attributes:
        full_observation_spec: holds ``(g, "observation")`` and ``(g, "manager_observation")``.
        full_action_spec: holds ``(g, "action")``.
    """

    full_observation_spec: Composite
    full_action_spec: Composite


def _leaf_spec(spec: Composite, key: tuple[str, str], what: str) -> TensorSpec:
    try:
        return spec[key]
    except KeyError:
        groups = sorted(k for k in spec if isinstance(spec[k], Composite))
        raise KeyError(f"{what} spec has no entry {key}; groups present: {groups}") from None


def observation_size(env: HasSpecs, group: str, *, manager: bool = False) -> tuple[int, int]:
    """``(n_g, d_w)`` of ``group``'s worker observation (``manager``: ``(n_g, d_m)``)."""
    leaf = MANAGER_OBSERVATION if manager else OBSERVATION
    spec = _leaf_spec(env.full_observation_spec, (group, leaf), "observation")
    if len(spec.shape) < 2:
        raise ValueError(f"({group!r}, {leaf!r}) must be [..., n_agents, d], got {spec.shape}")
    return int(spec.shape[-2]), int(spec.shape[-1])


def action_spec(env: HasSpecs, group: str) -> TensorSpec:
    """The action spec ``(group, "action")`` of ``env``."""
    return _leaf_spec(env.full_action_spec, (group, ACTION), "action")
