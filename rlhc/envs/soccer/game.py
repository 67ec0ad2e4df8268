"""2 vs 2 soccer: a striker and a goalie per team, ray perception, N pitches batched.

A top-down pitch (20 m × 10 m by default) closed by walls, a 6 m goal in each end with a
2 m deep net, a ball and four round players with a facing direction, simulated by
pymunk. Team 0 defends the goal at ``-x``, team 1 the goal at ``+x``. The proportions are
those of ML-Agents' SoccerTwos (sources in :mod:`rlhc.envs.soccer.options`).

=================== ========================================================================
agents              ``striker_0``, ``striker_1``, ``goalie_0``, ``goalie_1`` (index = team)
groups              ``striker`` (2), ``goalie`` (2); ``teams = (0, 1)``
striker action      ``Discrete(6)``: forward, backward, rotate left, rotate right, side left,
                    side right (paper Table 2; no no-op, as in the paper)
goalie action       ``Discrete(4)``: forward, backward, side left, side right (facing fixed)
worker observation  ``float32 [112]``: 14 rays over 180° ahead, range 13.4 m ×
                    (7 types one-hot + normalised distance)
manager observation ``float32 [200]``: 20 rays over 270°, range 30 m ×
                    (7 types one-hot + own half + hit flag + normalised distance)
ray types           ball, own goal, opponent goal, wall, teammate, opponent striker,
                    opponent goalie
striker reward      +1 its team scores, -0.1 its team concedes, -0.001 every step
goalie reward       +0.1 its team scores, -1 its team concedes, +0.001 every step
reward parts        ``StepOutcome.info``: ``striker_sparse_reward``, ``striker_time_reward``,
                    ``goalie_sparse_reward``, ``goalie_time_reward`` (``[N, 2]`` each)
termination         a goal (``StepOutcome.scoring_team`` says whose)
truncation          ``max_cycles`` decisions (default 600: SoccerTwos' 3,000 frames / 5)
decision            the action held for ``decision_interval`` frames of 0.1 s (default 1)
state               ``float32 [28]``: ball (x, y, vx, vy), then per player in agent order
                    (x, y, vx, vy, cos θ, sin θ); absolute pitch frame
=================== ========================================================================

Observations are egocentric (the agent's position, facing and team), so team 1 sees the
pitch as team 0 does after a 180° rotation about the centre spot: one network plays both
sides. All options are fields of :class:`~rlhc.envs.soccer.options.SoccerOptions`.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any, ClassVar

import numpy as np

from rlhc.envs.base import (
    BatchedGame,
    DiscreteAction,
    FrameOutcome,
    GroupObservation,
    GroupSpec,
)
from rlhc.envs.soccer.controls import GOALIE_ACTIONS, STRIKER_ACTIONS, Controls
from rlhc.envs.soccer.observations import MANAGER_SIZE, WORKER_SIZE, RaySensors
from rlhc.envs.soccer.options import SoccerOptions
from rlhc.envs.soccer.physics import (
    BALL,
    NUM_PLAYERS,
    PLAYER_NAMES,
    PitchGeometry,
    SoccerPhysics,
    facing_vectors,
)
from rlhc.envs.soccer.render import render_pitch
from rlhc.envs.soccer.rules import ROLE_BODIES, kickoff, rewards, scoring_team

#: length of :meth:`SoccerGame.state`.
STATE_SIZE = 4 + 6 * NUM_PLAYERS


class SoccerGame(BatchedGame):
    """``num_worlds`` soccer pitches stepped in lockstep (all in one pymunk space).

    Args:
        num_worlds: number of pitches.
        seed: seed of the kick-off jitter.
        **options: fields of :class:`~rlhc.envs.soccer.options.SoccerOptions`, e.g.
            ``max_cycles=1000`` or ``striker_time_reward=0.0``; an unknown name is a
            ``ValueError`` that names it.

    Examples:
        >>> game = SoccerGame(num_worlds=4, seed=0)
        >>> outcome = game.step({
        ...     "striker": np.zeros((4, 2), dtype=np.int64),
        ...     "goalie": np.zeros((4, 2), dtype=np.int64),
        ... })
        >>> game.observe()["striker"].observation.shape
        (4, 2, 112)
        >>> outcome.rewards["goalie"].shape
        (4, 2)
    """

    name: ClassVar[str] = "soccer"
    groups = (
        GroupSpec(
            name="striker",
            agents=PLAYER_NAMES[0:2],
            observation_size=WORKER_SIZE,
            manager_observation_size=MANAGER_SIZE,
            action=DiscreteAction(len(STRIKER_ACTIONS)),
            teams=(0, 1),
        ),
        GroupSpec(
            name="goalie",
            agents=PLAYER_NAMES[2:4],
            observation_size=WORKER_SIZE,
            manager_observation_size=MANAGER_SIZE,
            action=DiscreteAction(len(GOALIE_ACTIONS)),
            teams=(0, 1),
        ),
    )

    def __init__(self, num_worlds: int, seed: int | None = None, **options: Any) -> None:
        self.options = SoccerOptions.from_options(options)
        super().__init__(
            num_worlds=num_worlds,
            max_cycles=self.options.max_cycles,
            seed=seed,
            decision_interval=self.options.decision_interval,
        )
        self.geometry = PitchGeometry.from_options(self.options)
        self.physics = SoccerPhysics(self.num_worlds, self.options)
        self.controls = Controls(self.options)
        self.sensors = RaySensors(
            geometry=self.geometry,
            ball_radius=self.options.ball_radius,
            player_radius=self.options.player_radius,
            worker_ray_length=self.options.worker_ray_length,
            manager_ray_length=self.options.manager_ray_length,
        )
        self._observations: dict[str, GroupObservation] | None = None
        self.reset()

    # --- dynamics -------------------------------------------------------------------
    def reset(self, mask: np.ndarray | None = None) -> None:
        """Kick off again in the pitches where ``mask`` is true (all if ``None``)."""
        if mask is None:
            mask = np.ones(self.num_worlds, dtype=bool)
        mask = np.asarray(mask)
        if mask.shape != (self.num_worlds,) or mask.dtype != np.bool_:
            raise ValueError(
                f"reset mask must be bool [{self.num_worlds}], got {mask.dtype} {mask.shape}"
            )
        count = int(mask.sum())
        if count == 0:
            return
        positions = np.zeros((self.num_worlds, 5, 2))
        angles = np.zeros((self.num_worlds, 5))
        positions[mask], angles[mask] = kickoff(self.rng, count, self.options, self.geometry)
        self.physics.teleport(mask, positions, angles)
        self.step_count[mask] = 0
        self._observations = None

    def place(
        self, positions: np.ndarray, angles: np.ndarray, mask: np.ndarray | None = None
    ) -> None:
        """Put the bodies of the pitches in ``mask`` (all if ``None``) at rest at given spots.

        For tests, demos and hand-made situations; ``step_count`` is left alone.

        Args:
            positions: ``[N, 5, 2]`` pitch-local positions, body order (``striker_0``,
                ``striker_1``, ``goalie_0``, ``goalie_1``, ball).
            angles: ``[N, 5]`` facing angles (a goalie's should stay 0 for team 0, π for
                team 1: goalies cannot turn).
            mask: ``bool [N]``.

        Raises:
            ValueError: wrong shapes, non-finite values, or a player outside the pitch.
        """
        positions, angles = (
            np.asarray(positions, dtype=np.float64),
            np.asarray(angles, dtype=np.float64),
        )
        if positions.shape != (self.num_worlds, 5, 2) or angles.shape != (self.num_worlds, 5):
            raise ValueError(
                f"place expects positions [{self.num_worlds}, 5, 2] and angles [{self.num_worlds}, 5], "
                f"got {positions.shape} and {angles.shape}"
            )
        if not (np.all(np.isfinite(positions)) and np.all(np.isfinite(angles))):
            raise ValueError("place: positions and angles must be finite")
        mask = (
            np.ones(self.num_worlds, dtype=bool) if mask is None else np.asarray(mask, dtype=bool)
        )
        inside = self.geometry.contains(positions[mask][:, :NUM_PLAYERS]) & (
            np.abs(positions[mask][:, :NUM_PLAYERS, 0]) < self.geometry.half_length
        )
        if not np.all(inside):
            raise ValueError("place: players must be on the pitch (not in a net or a wall)")
        self.physics.teleport(mask, positions, angles)
        self._observations = None

    def advance(self, actions: Mapping[str, np.ndarray]) -> FrameOutcome:
        """Advance every pitch one frame; see the module docstring for the rules."""
        checked = actions
        physics = self.physics
        velocities, angular = self.controls.velocities(
            checked["striker"],
            checked["goalie"],
            physics.positions,
            physics.angles,
            physics.velocities,
        )
        physics.drive(velocities, angular)
        physics.step()
        self._observations = None

        scoring = scoring_team(physics.positions[:, BALL], self.geometry, self.options.ball_radius)
        parts = rewards(scoring, self.options, time_share=1.0 / self.decision_interval)
        info = {f"{role}_sparse_reward": parts.sparse[role] for role in ROLE_BODIES}
        info.update({f"{role}_time_reward": parts.time[role] for role in ROLE_BODIES})
        return FrameOutcome(
            rewards=parts.total, terminated=scoring >= 0, scoring_team=scoring, info=info
        )

    # --- views ----------------------------------------------------------------------
    def observe(self) -> dict[str, GroupObservation]:
        """Worker and manager ray observations of both groups (cached until the next step)."""
        if self._observations is None:
            worker, manager = self.sensors.observe(self.physics.positions, self.physics.angles)
            self._observations = {
                role: GroupObservation(
                    observation=worker[index], manager_observation=manager[index]
                )
                for index, role in enumerate(ROLE_BODIES)
            }
        return self._observations

    def state(self) -> np.ndarray:
        """``float32 [N, 28]``: ball (x, y, vx, vy), then per player (x, y, vx, vy, cos, sin)."""
        physics = self.physics
        ball = np.concatenate([physics.positions[:, BALL], physics.velocities[:, BALL]], axis=-1)
        players = np.concatenate(
            [
                physics.positions[:, :NUM_PLAYERS],
                physics.velocities[:, :NUM_PLAYERS],
                facing_vectors(physics.angles),
            ],
            axis=-1,
        )
        return np.concatenate([ball, players.reshape(self.num_worlds, -1)], axis=-1).astype(
            np.float32
        )

    def render(self, world: int = 0, *, rays: bool = False) -> np.ndarray:
        """``uint8 [H, W, 3]`` picture of pitch ``world``; ``rays=True`` overlays the worker rays."""
        if not 0 <= world < self.num_worlds:
            raise ValueError(f"world must lie in [0, {self.num_worlds - 1}], got {world}")
        return render_pitch(self, world, rays=rays)
