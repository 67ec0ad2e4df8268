"""The numpy contract every game implements: N worlds stepped in lockstep.

A game (tennis, soccer) is written once, as a :class:`BatchedGame` that simulates
``num_worlds`` independent courts or pitches with numpy arrays in and out. The two
adapters are then generic:

* :mod:`rlhc.envs.torchrl_adapter` turns a game into a TorchRL ``EnvBase`` with
  ``batch_size=[num_worlds]`` (the training path: no per-world Python round-trip);
* :mod:`rlhc.envs.pettingzoo_adapter` turns a one-world game into a PettingZoo
  ``ParallelEnv`` (for users, for the PettingZoo API tests and for rendering).

A *decision* (one :meth:`BatchedGame.step`) holds every agent's action for
``decision_interval`` physics frames, as ML-Agents' ``numberOfActionsBetweenDecisions``
does (its example scenes: 5 frames of 0.02 s). Rewards are summed over the frames;
``step_count`` and ``max_cycles`` count decisions.

Shapes use ``N`` for worlds and ``n_g`` for the number of agents in group ``g``.
Agents are named ``<group>_<i>``; within a group, index ``i`` is the agent's
position in :attr:`GroupSpec.agents`.

This module imports numpy only: the simulation layer never imports torch.
"""

from __future__ import annotations

import abc
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np


@dataclass(frozen=True)
class ContinuousAction:
    """A box action ``[size]`` in ``[low, high]``; values outside are clipped."""

    size: int
    low: float = -1.0
    high: float = 1.0


@dataclass(frozen=True)
class DiscreteAction:
    """A categorical action in ``{0, …, n - 1}``; anything else is an error."""

    n: int


ActionSpace = ContinuousAction | DiscreteAction


@dataclass(frozen=True)
class GroupSpec:
    """One group of agents that share a policy (and a TensorDict sub-dict).

    Attributes:
        name: the group name, e.g. ``"racket"``; agents are ``f"{name}_{i}"``.
        agents: the agent names in index order.
        observation_size: ``d_w``, the worker observation length.
        manager_observation_size: ``d_m``, the manager observation length.
        action: the action space of one agent.
        teams: the team (0 or 1) of each agent, in index order.
    """

    name: str
    agents: tuple[str, ...]
    observation_size: int
    manager_observation_size: int
    action: ActionSpace
    teams: tuple[int, ...]

    @property
    def num_agents(self) -> int:
        return len(self.agents)


@dataclass
class GroupObservation:
    """What the agents of one group see, for all worlds.

    Attributes:
        observation: ``float32 [N, n_g, d_w]``, in each agent's own team frame.
        manager_observation: ``float32 [N, n_g, d_m]``, the team manager's view of the agent.
    """

    observation: np.ndarray
    manager_observation: np.ndarray


@dataclass
class FrameOutcome:
    """The result of one physics frame of all worlds (:meth:`BatchedGame.advance`).

    Attributes:
        rewards: per group, ``float32 [N, n_g]``.
        terminated: ``bool [N]``: the point/goal ended the episode on this frame.
        scoring_team: ``int64 [N]``: the team that won the point/goal, -1 if none.
        info: extra per-world arrays for logging, each ``[N, ...]``; summed over the
            frames of a decision (a boolean event becomes a count).
    """

    rewards: dict[str, np.ndarray]
    terminated: np.ndarray
    scoring_team: np.ndarray
    info: dict[str, np.ndarray] = field(default_factory=dict)


@dataclass
class StepOutcome:
    """The result of one lockstep decision of all worlds.

    Attributes:
        rewards: per group, ``float32 [N, n_g]``.
        terminated: ``bool [N]``: the point/goal ended the episode (no bootstrap).
        truncated: ``bool [N]``: ``max_cycles`` decisions reached without termination
            (bootstrap).
        scoring_team: ``int64 [N]``: the team that won the point/goal this step, -1 if none.
        info: extra per-world arrays for logging (e.g. dense reward parts, events), each
            ``[N, ...]``, summed over the decision's frames.
    """

    rewards: dict[str, np.ndarray]
    terminated: np.ndarray
    truncated: np.ndarray
    scoring_team: np.ndarray
    info: dict[str, np.ndarray] = field(default_factory=dict)


class BatchedGame(abc.ABC):
    """``num_worlds`` independent worlds of one game, stepped in lockstep.

    Subclasses set :attr:`name` and :attr:`groups` and implement the abstract methods;
    :meth:`advance` simulates one physics frame, and :meth:`step` (one decision) holds
    the actions for ``decision_interval`` frames. A finished world is *not* reset
    automatically: the caller (an adapter) resets the worlds it wants with
    ``reset(mask=...)``; stepping a finished world is allowed and simply continues its
    simulation (adapters never rely on it).

    Args:
        num_worlds: how many worlds to simulate (``N >= 1``).
        max_cycles: decisions after which an episode is truncated.
        seed: seed of the game's ``numpy.random.Generator`` (``None``: from entropy).
        decision_interval: physics frames per decision (``>= 1``), the action held in
            between.
    """

    name: ClassVar[str]
    groups: tuple[GroupSpec, ...]
    #: The :attr:`StepOutcome.info` entries that adapters publish (per-world shape each,
    #: e.g. ``{"hits_over_net": ()}``): events a trainer counts, such as hits or goals.
    published_info: ClassVar[dict[str, tuple[int, ...]]] = {}
    metadata: ClassVar[dict[str, object]] = {"render_modes": ["rgb_array"], "render_fps": 30}

    def __init__(
        self,
        num_worlds: int,
        max_cycles: int,
        seed: int | None = None,
        decision_interval: int = 1,
    ) -> None:
        for name, value in (
            ("num_worlds", num_worlds),
            ("max_cycles", max_cycles),
            ("decision_interval", decision_interval),
        ):
            if isinstance(value, bool) or not isinstance(value, int | np.integer) or value < 1:
                raise ValueError(f"{name} must be an integer >= 1, got {value!r}")
        self.num_worlds = int(num_worlds)
        self.max_cycles = int(max_cycles)
        self.decision_interval = int(decision_interval)
        self.rng = np.random.default_rng(seed)
        self.step_count = np.zeros(self.num_worlds, dtype=np.int64)

    # --- identity -------------------------------------------------------------------
    @property
    def agents(self) -> tuple[str, ...]:
        """All agent names, group by group."""
        return tuple(agent for group in self.groups for agent in group.agents)

    def group(self, name: str) -> GroupSpec:
        """The :class:`GroupSpec` called ``name``; ``KeyError`` naming the known groups."""
        for spec in self.groups:
            if spec.name == name:
                return spec
        known = ", ".join(spec.name for spec in self.groups)
        raise KeyError(f"unknown group {name!r}; this game has: {known}")

    def seed(self, seed: int | None) -> None:
        """Re-seed the game's random generator (serve speeds, kick-off jitter, …)."""
        self.rng = np.random.default_rng(seed)

    # --- dynamics -------------------------------------------------------------------
    @abc.abstractmethod
    def reset(self, mask: np.ndarray | None = None) -> None:
        """Start a new episode in the worlds where ``mask`` (``bool [N]``) is true (all if None).

        Resets ``step_count`` of those worlds to 0.
        """

    def step(self, actions: Mapping[str, np.ndarray]) -> StepOutcome:
        """Advance every world one decision: ``decision_interval`` frames of ``actions``.

        A world whose episode ends on a frame takes no reward, score or info from the
        decision's later frames (its simulation runs on until the caller resets it).

        Args:
            actions: per group, ``float [N, n_g, size]`` (continuous) or ``int [N, n_g]``
                (discrete). Validated by :func:`validate_actions`.

        Returns:
            The rewards and episode ends of this decision; ``step_count`` is incremented.
        """
        checked = validate_actions(self.groups, actions, self.num_worlds)
        n = self.num_worlds
        rewards = {g.name: np.zeros((n, g.num_agents), dtype=np.float32) for g in self.groups}
        ended = np.zeros(n, dtype=bool)
        scoring = np.full(n, -1, dtype=np.int64)
        info: dict[str, np.ndarray] = {}
        for _ in range(self.decision_interval):
            frame = self.advance(checked)
            live = ~ended
            for name, reward in frame.rewards.items():
                rewards[name] += np.where(live[:, None], reward, 0.0).astype(np.float32)
            for name, value in frame.info.items():
                mask = live.reshape((n,) + (1,) * (np.ndim(value) - 1))
                info[name] = info.get(name, 0) + np.where(mask, value, 0)
            scoring = np.where(live & frame.terminated, frame.scoring_team, scoring)
            ended |= frame.terminated
            if ended.all():
                break
        self.step_count += 1
        truncated = (self.step_count >= self.max_cycles) & ~ended
        return StepOutcome(
            rewards=rewards,
            terminated=ended,
            truncated=truncated,
            scoring_team=scoring,
            info=info,
        )

    @abc.abstractmethod
    def advance(self, actions: Mapping[str, np.ndarray]) -> FrameOutcome:
        """Advance every world one physics frame with ``actions`` (already validated).

        Args:
            actions: per group, the output of :func:`validate_actions`.

        Returns:
            The rewards and episode ends of this frame (``step_count`` is not touched).
        """

    @abc.abstractmethod
    def observe(self) -> dict[str, GroupObservation]:
        """The current observations of every group, for all worlds."""

    @abc.abstractmethod
    def state(self) -> np.ndarray:
        """The full state of every world, ``float32 [N, d_state]`` (absolute frame)."""

    @abc.abstractmethod
    def render(self, world: int = 0) -> np.ndarray:
        """An RGB picture of one world, ``uint8 [H, W, 3]``."""


def validate_actions(
    groups: tuple[GroupSpec, ...], actions: Mapping[str, np.ndarray], num_worlds: int
) -> dict[str, np.ndarray]:
    """Check a batch of actions against the groups and return them ready to apply.

    Continuous actions are clipped to their bounds (documented behaviour: policies such
    as a Gaussian may sample outside); discrete ones must lie in range.

    Raises:
        ValueError: an unknown or missing group, a wrong shape, NaN/inf, or a discrete
            action out of range. The message names the group and the bad value.
    """
    known = {spec.name: spec for spec in groups}
    unknown = sorted(set(actions) - set(known))
    if unknown:
        raise ValueError(f"unknown group(s) {unknown} in actions; expected {sorted(known)}")
    checked: dict[str, np.ndarray] = {}
    for name, spec in known.items():
        if name not in actions:
            raise ValueError(f"missing actions for group {name!r}; expected {sorted(known)}")
        action = np.asarray(actions[name])
        if isinstance(spec.action, ContinuousAction):
            expected: tuple[int, ...] = (num_worlds, spec.num_agents, spec.action.size)
            if action.shape != expected:
                raise ValueError(
                    f"actions for group {name!r} have shape {action.shape}; expected {expected}"
                )
            if not np.all(np.isfinite(action)):
                raise ValueError(f"actions for group {name!r} contain NaN or inf: {action}")
            checked[name] = np.clip(action, spec.action.low, spec.action.high).astype(
                np.float64, copy=False
            )
        else:
            expected = (num_worlds, spec.num_agents)
            if action.shape != expected:
                raise ValueError(
                    f"actions for group {name!r} have shape {action.shape}; expected {expected}"
                )
            if not np.issubdtype(action.dtype, np.integer) and (
                not np.all(np.isfinite(action)) or np.any(action != np.round(action))
            ):
                raise ValueError(
                    f"discrete actions for group {name!r} must be integers, got {action}"
                )
            bad = (action < 0) | (action >= spec.action.n)
            if np.any(bad):
                raise ValueError(
                    f"discrete actions for group {name!r} must lie in [0, {spec.action.n - 1}], "
                    f"got {action[bad].tolist()}"
                )
            checked[name] = action.astype(np.int64, copy=False)
    return checked
