"""How actions move the rackets: numpy kinematics of kinematic pymunk bodies.

A racket's action is three numbers in ``[-1, 1]`` (values outside are clipped by
:func:`rlhc.envs.base.validate_actions`), read in the racket's own team frame:

| index | meaning |
|---|---|
| 0 | horizontal speed: ``+1`` runs towards the net at ``racket_speed``, ``-1`` away |
| 1 | jump: a value above ``jump_threshold`` (0.5) takes off at ``value * jump_speed`` if the racket stands on the ground |
| 2 | paddle tilt: the paddle is set to ``value * max_tilt`` (``+`` faces the net) |

Rackets are kinematic (infinite mass): they push the ball but are never pushed,
so their motion is decided here, in closed form, and pymunk only carries it out.

The tilt is *set*, not steered: the paper's 8-value observation shows no paddle
angle, so an angle that lagged behind the action would be hidden state that no
policy reading the observation could know.
"""

from __future__ import annotations

import numpy as np

from rlhc.envs.tennis.observations import TEAM_SIGN
from rlhc.envs.tennis.physics import CourtGeometry

#: Physics frames per decision: ML-Agents' ``numberOfActionsBetweenDecisions`` default.
DECISION_INTERVAL = 5


def racket_bounds(geometry: CourtGeometry) -> tuple[np.ndarray, np.ndarray]:
    """Lowest and highest x of each racket's centre (``[4]`` each): its own half."""
    g = geometry
    far = g.wall_x - g.racket_wall_gap
    near = g.racket_net_gap
    low = np.array([-far, -far, near, near])
    high = np.array([-near, -near, far, far])
    return low, high


def drive_rackets(
    actions: np.ndarray,
    position: np.ndarray,
    jump_velocity: np.ndarray,
    geometry: CourtGeometry,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The velocities that carry out ``actions`` over one frame, the paddle angles, and
    the new jump speed.

    Args:
        actions: ``[N, 4, 3]`` in ``[-1, 1]``.
        position: ``[N, 4, 2]`` racket centres (court-local metres).
        jump_velocity: ``[N, 4]`` the rackets' vertical speed (ballistic while airborne).
        geometry: the court.

    Returns:
        ``(velocity [N, 4, 2], angle [N, 4], next_jump_velocity [N, 4])``: the velocity,
        constant over the frame, moves each racket exactly to its next in-bounds
        position; the angle (radians, absolute frame) is the paddle's for the frame.
    """
    g = geometry
    dt = g.dt
    low, high = racket_bounds(g)
    sign = TEAM_SIGN[None, :]
    x, y = position[..., 0], position[..., 1]
    next_x = np.clip(x + actions[..., 0] * sign * g.racket_speed * dt, low, high)

    grounded = y <= g.racket_ground_y + 1e-6
    # A dead zone, as in Unity's tennis (jump when the action exceeds 0.5): a policy
    # whose jump output hovers around 0 does not hop on every other decision.
    take_off = grounded & (actions[..., 1] > g.jump_threshold)
    vy = np.where(take_off, actions[..., 1] * g.jump_speed, jump_velocity) - g.gravity * dt
    next_y = y + vy * dt
    landed = next_y <= g.racket_ground_y
    next_y = np.where(landed, g.racket_ground_y, next_y)
    vy = np.where(landed, 0.0, vy)

    # Team A tilts its paddle towards the net (+x) by turning clockwise; B is mirrored.
    angle = -sign * actions[..., 2] * g.max_tilt

    velocity = np.stack([(next_x - x) / dt, (next_y - y) / dt], axis=-1)
    return velocity, angle, vy
