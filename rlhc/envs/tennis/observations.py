"""What a racket sees: positions and velocities in its own team's frame.

Both teams see the same geometry: team A (rackets 0, 1) plays on the left with the
net towards ``+x``; team B (rackets 2, 3) is mirrored about the net (``x`` and
``vx`` negated), so that for everyone the net lies towards ``+x`` and one shared
policy serves both sides.

Observations are scaled to O(1): lengths are divided by :data:`LENGTH_SCALE`
(the half court length, so the court spans ``x ∈ [-1, 1]``) and velocities by
:data:`VELOCITY_SCALE`.

| vector | size | contents (team frame, scaled) |
|---|---|---|
| worker | 8 | ball x, y, vx, vy; racket x, y, vx, vy |
| manager | 10 | the worker's 8 + ball minus racket (dx, dy) |
| worker, ``extended_obs`` | 12 | the 8 + teammate minus racket (dx, dy, dvx, dvy) |
| manager, ``extended_obs`` | 14 | the manager's 10 + teammate minus racket (dx, dy, dvx, dvy) |
"""

from __future__ import annotations

import numpy as np

#: Metres per observation unit (the half court length).
LENGTH_SCALE = 6.0
#: Metres per second per observation unit.
VELOCITY_SCALE = 10.0
#: ``+1`` for team A's rackets, ``-1`` for team B's: the x sign of each racket's frame.
TEAM_SIGN = np.array([1.0, 1.0, -1.0, -1.0])
#: Each racket's teammate.
TEAMMATE = np.array([1, 0, 3, 2])


def worker_size(extended_obs: bool) -> int:
    """Length of a worker observation (8, or 12 with ``extended_obs``)."""
    return 12 if extended_obs else 8


def manager_size(extended_obs: bool) -> int:
    """Length of a manager observation (10, or 14 with ``extended_obs``)."""
    return 14 if extended_obs else 10


def observe_rackets(
    ball_position: np.ndarray,
    ball_velocity: np.ndarray,
    racket_position: np.ndarray,
    racket_velocity: np.ndarray,
    extended_obs: bool = False,
) -> tuple[np.ndarray, np.ndarray]:
    """Worker and manager observations of the four rackets of every court.

    Args:
        ball_position: ``[N, 2]`` court-local metres.
        ball_velocity: ``[N, 2]`` m/s.
        racket_position: ``[N, 4, 2]`` court-local metres.
        racket_velocity: ``[N, 4, 2]`` m/s.
        extended_obs: add the teammate's relative position and velocity.

    Returns:
        ``(worker, manager)``: ``float32 [N, 4, d_w]`` and ``float32 [N, 4, d_m]``.

    Examples:
        >>> ball = np.array([[-3.0, 3.0]]); still = np.zeros((1, 2))
        >>> rackets = np.array([[[-3.0, 0.5], [-1.0, 0.5], [3.0, 0.5], [1.0, 0.5]]])
        >>> worker, manager = observe_rackets(ball, still, rackets, np.zeros((1, 4, 2)))
        >>> worker.shape, manager.shape
        ((1, 4, 8), (1, 4, 10))
        >>> float(worker[0, 0, 0]), float(worker[0, 2, 0])  # the ball is in A's half
        (-0.5, 0.5)
    """
    n = ball_position.shape[0]
    sign = TEAM_SIGN[None, :, None]
    flip = np.array([1.0, 0.0])[None, None, :]  # only x is mirrored
    mirror = 1.0 + (sign - 1.0) * flip  # (sign, 1) per racket
    ball_p = np.broadcast_to(ball_position[:, None, :], (n, 4, 2)) * mirror / LENGTH_SCALE
    ball_v = np.broadcast_to(ball_velocity[:, None, :], (n, 4, 2)) * mirror / VELOCITY_SCALE
    racket_p = racket_position * mirror / LENGTH_SCALE
    racket_v = racket_velocity * mirror / VELOCITY_SCALE
    parts = [ball_p, ball_v, racket_p, racket_v]
    teammate: list[np.ndarray] = []
    if extended_obs:
        # The teammate seen in this racket's frame (same team, so same mirror).
        teammate = [racket_p[:, TEAMMATE] - racket_p, racket_v[:, TEAMMATE] - racket_v]
    worker = np.concatenate(parts + teammate, axis=-1).astype(np.float32)
    manager = np.concatenate([*parts, ball_p - racket_p, *teammate], axis=-1).astype(np.float32)
    return worker, manager
