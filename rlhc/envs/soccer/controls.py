"""How the discrete actions move the players, and how a player kicks the ball.

Actions (paper Table 2), all relative to the player's facing:

======== ================================================================= =====
group    actions                                                           count
======== ================================================================= =====
striker  forward, backward, rotate left, rotate right, side left, side right  6
goalie   forward, backward, side left, side right                             4
======== ================================================================= =====

There is no no-op: the paper's table has none, and we follow it. A striker can hold
its position by rotating; a goalie, whose facing is fixed towards the opponent goal,
always moves (alternating forward and backward keeps it in place on average).

An action sets the velocity the player reaches within the first physics substep (like
Unity's ``AddForce(..., VelocityChange)``: responsive, no momentum to fight); collisions
during the step then push players around. Kicking is contact: a player that touches the ball
with the ball in front of it (within ±60° of its facing) and chooses *forward* adds
``kick_speed`` to the ball's velocity along its facing (Unity's soccer scales the kick
by the forward input in the same way). Any other contact is a plain physical collision.
"""

from __future__ import annotations

import numpy as np

from rlhc.envs.soccer.options import SoccerOptions
from rlhc.envs.soccer.physics import BALL, NUM_PLAYERS, facing_vectors

STRIKER_ACTIONS: tuple[str, ...] = (
    "forward",
    "backward",
    "rotate_left",
    "rotate_right",
    "side_left",
    "side_right",
)
GOALIE_ACTIONS: tuple[str, ...] = ("forward", "backward", "side_left", "side_right")
FORWARD = 0  # the same index in both groups

#: cosine of the half-angle of the kicking arc in front of a player.
_KICK_ARC_COS = 0.5
#: how close (beyond touching) the ball must be for a kick to count: a player whose
#: centre is within ``player_radius + ball_radius + KICK_REACH`` of the ball's touches it.
KICK_REACH = 0.05


def _motion_table(names: tuple[str, ...], options: SoccerOptions) -> np.ndarray:
    """``[len(names), 3]``: (forward speed, leftward speed, angular speed) per action."""
    motions = {
        "forward": (options.player_speed, 0.0, 0.0),
        "backward": (-options.player_speed, 0.0, 0.0),
        "rotate_left": (0.0, 0.0, options.rotation_speed),
        "rotate_right": (0.0, 0.0, -options.rotation_speed),
        "side_left": (0.0, options.side_speed, 0.0),
        "side_right": (0.0, -options.side_speed, 0.0),
    }
    return np.array([motions[name] for name in names])


class Controls:
    """Turns a step's actions into body velocities.

    Args:
        options: speeds, radii, kick strength, ball drag and cap.

    Examples:
        >>> controls = Controls(SoccerOptions())
        >>> controls.striker_motion.shape, controls.goalie_motion.shape
        ((6, 3), (4, 3))
    """

    def __init__(self, options: SoccerOptions) -> None:
        self.options = options
        self.striker_motion = _motion_table(STRIKER_ACTIONS, options)
        self.goalie_motion = _motion_table(GOALIE_ACTIONS, options)

    def velocities(
        self,
        striker_actions: np.ndarray,
        goalie_actions: np.ndarray,
        positions: np.ndarray,
        angles: np.ndarray,
        velocities: np.ndarray,
    ) -> tuple[np.ndarray, np.ndarray]:
        """The velocities every body should have, from this step's actions.

        Args:
            striker_actions: ``int [N, 2]`` (``striker_0``, ``striker_1``).
            goalie_actions: ``int [N, 2]`` (``goalie_0``, ``goalie_1``).
            positions: ``[N, 5, 2]`` current positions (body order).
            angles: ``[N, 5]`` current angles.
            velocities: ``[N, 5, 2]`` current velocities (the ball keeps its own).

        Returns:
            ``[N, 5, 2]`` velocities and ``[N, 5]`` angular velocities.
        """
        motion = np.concatenate(
            [self.striker_motion[striker_actions], self.goalie_motion[goalie_actions]], axis=1
        )  # [N, 4, 3], players in body order
        facing = facing_vectors(angles)
        left = np.stack([-facing[..., 1], facing[..., 0]], axis=-1)
        new_velocities = np.empty_like(velocities)
        new_velocities[:, :NUM_PLAYERS] = motion[..., 0:1] * facing + motion[..., 1:2] * left
        angular = np.zeros(angles.shape)
        angular[:, :NUM_PLAYERS] = motion[..., 2]

        options = self.options
        ball = velocities[:, BALL] * options.ball_drag
        to_ball = positions[:, BALL : BALL + 1] - positions[:, :NUM_PLAYERS]  # [N, 4, 2]
        distance = np.linalg.norm(to_ball, axis=-1)
        in_front = np.sum(to_ball * facing, axis=-1) > _KICK_ARC_COS * distance
        touching = distance <= options.player_radius + options.ball_radius + KICK_REACH
        kicking = (
            touching & in_front & (np.concatenate([striker_actions, goalie_actions], 1) == FORWARD)
        )
        ball = ball + options.kick_speed * np.sum(kicking[..., None] * facing, axis=1)
        speed = np.linalg.norm(ball, axis=-1, keepdims=True)
        ball *= np.minimum(1.0, options.ball_max_speed / np.maximum(speed, 1e-12))
        new_velocities[:, BALL] = ball
        return new_velocities, angular
