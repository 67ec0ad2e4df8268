"""The options of the soccer game, read once and checked loudly.

Every keyword the game accepts is a field of :class:`SoccerOptions`; a misspelt option
fails with the names it does not know (the VMAS habit), instead of being ignored.
Lengths are in metres, times in seconds, speeds in metres per second.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, fields
from typing import Any

#: thickness of the walls around the pitch and the nets (pymunk boxes; thick so that a
#: fast ball cannot tunnel through within one substep).
WALL_THICKNESS = 4.0


@dataclass(frozen=True)
class SoccerOptions:
    """Rules, pitch and physics of the 2 vs 2 soccer game.

    Attributes:
        max_cycles: decisions after which an episode is truncated.
        decision_interval: physics frames of ``step_seconds`` per decision, the action
            held in between (1: one 0.1 s frame per decision, the decision period of
            ML-Agents' SoccerTwos, 5 frames of 0.02 s).
        striker_time_reward: added to each striker's reward every decision (paper:
            -0.001, an incentive to score quickly).
        goalie_time_reward: added to each goalie's reward every decision (paper: +0.001,
            an incentive to keep the ball out for long).
        pitch_length: inner length of the pitch, goal line to goal line.
        pitch_width: inner width of the pitch, touch line to touch line.
        goal_width: width of the goal mouth, centred on each goal line.
        goal_depth: depth of the net box behind each goal line.
        step_seconds: simulated time per physics frame.
        physics_substeps: pymunk steps per frame (collision quality).
        player_radius: radius of every player's circle.
        ball_radius: radius of the ball.
        player_speed: speed of a forward or backward move.
        side_speed: speed of a sideways move.
        rotation_speed: angular speed of a striker's rotation, radians per second.
        kick_speed: velocity added to the ball, along the kicker's facing, when a player
            touching the ball (in front of it) chooses "forward".
        ball_max_speed: the ball's speed is capped here before each step (no tunnelling).
        ball_drag: fraction of the ball's velocity kept per step (rolling friction).
        worker_ray_length: range of the worker's 14 rays.
        manager_ray_length: range of the manager's 20 rays (longer: a broader view).
        kickoff_jitter: half-width of the uniform noise added to kick-off positions.
        kickoff_angle_jitter: half-width of the uniform noise on the strikers' facing.
    """

    max_cycles: int = 500
    decision_interval: int = 1
    striker_time_reward: float = -0.001
    goalie_time_reward: float = 0.001
    pitch_length: float = 16.0
    pitch_width: float = 10.0
    goal_width: float = 3.0
    goal_depth: float = 1.0
    step_seconds: float = 0.1
    physics_substeps: int = 2
    player_radius: float = 0.4
    ball_radius: float = 0.25
    player_speed: float = 3.0
    side_speed: float = 2.25
    rotation_speed: float = 3.0
    kick_speed: float = 5.0
    ball_max_speed: float = 8.0
    ball_drag: float = 0.95
    worker_ray_length: float = 10.0
    manager_ray_length: float = 24.0
    kickoff_jitter: float = 0.5
    kickoff_angle_jitter: float = 0.25

    def __post_init__(self) -> None:
        if isinstance(self.max_cycles, bool) or not isinstance(self.max_cycles, int):
            raise ValueError(f"max_cycles must be an integer, got {self.max_cycles!r}")
        if isinstance(self.physics_substeps, bool) or not isinstance(self.physics_substeps, int):
            raise ValueError(f"physics_substeps must be an integer, got {self.physics_substeps!r}")
        if (
            isinstance(self.decision_interval, bool)
            or not isinstance(self.decision_interval, int)
            or self.decision_interval < 1
        ):
            raise ValueError(
                f"decision_interval must be an integer >= 1, got {self.decision_interval!r}"
            )
        for spec in fields(self):
            value = getattr(self, spec.name)
            if not isinstance(value, int | float) or not math.isfinite(value):
                raise ValueError(f"option {spec.name!r} must be a finite number, got {value!r}")
        positive = [
            spec.name
            for spec in fields(self)
            if not spec.name.endswith("time_reward")
            and not spec.name.startswith("kickoff")
            and getattr(self, spec.name) <= 0
        ]
        if positive:
            raise ValueError(f"options {positive} must be > 0")
        if self.kickoff_jitter < 0 or self.kickoff_angle_jitter < 0:
            raise ValueError("kickoff_jitter and kickoff_angle_jitter must be >= 0")
        if not self.ball_drag <= 1.0:
            raise ValueError(f"ball_drag must lie in (0, 1], got {self.ball_drag}")
        if not 2 * self.ball_radius < self.goal_width < self.pitch_width:
            raise ValueError(
                f"goal_width must lie between the ball's diameter and pitch_width, "
                f"got {self.goal_width}"
            )
        if self.goal_depth <= 2 * self.ball_radius:
            raise ValueError(f"goal_depth must exceed the ball's diameter, got {self.goal_depth}")
        # Kick-off puts the goalie one metre in front of its goal line and the striker at
        # a quarter of the pitch: both must fit, jitter included.
        if self.pitch_width < 4 * (self.player_radius + self.kickoff_jitter):
            raise ValueError("pitch_width is too small for the players and kick-off jitter")
        if self.pitch_length < 8 * (self.player_radius + self.kickoff_jitter) + 4:
            raise ValueError("pitch_length is too small for the players and kick-off jitter")
        # Tunnelling guard (pymunk has no continuous collision detection): within one
        # substep the ball, even after a collision with a running player, must travel
        # less than a quarter of the wall's thickness, and a player less than half its
        # radius (the goal-mouth barrier that keeps players out of the nets is as deep
        # as the net only).
        substep = self.step_seconds / self.physics_substeps
        fastest_player = max(self.player_speed, self.side_speed)
        if (self.ball_max_speed + 2 * fastest_player) * substep >= WALL_THICKNESS / 4:
            raise ValueError(
                "ball_max_speed/player_speed too high for step_seconds/physics_substeps: "
                "the ball could cross a wall within one substep"
            )
        if fastest_player * substep >= self.player_radius / 2:
            raise ValueError(
                "player_speed/side_speed too high for step_seconds/physics_substeps: "
                "a player could cross the goal-mouth barrier within one substep"
            )

    @classmethod
    def from_options(cls, options: Mapping[str, Any]) -> SoccerOptions:
        """Build from keyword options, rejecting unknown names.

        Args:
            options: a subset of the field names with their values.

        Returns:
            The options, unset fields at their defaults.

        Raises:
            ValueError: an option this game does not know (named), or a bad value.

        Examples:
            >>> SoccerOptions.from_options({"max_cycles": 100}).max_cycles
            100
        """
        known = {spec.name for spec in fields(cls)}
        unknown = sorted(set(options) - known)
        if unknown:
            raise ValueError(f"unknown soccer option(s) {unknown}; known options: {sorted(known)}")
        return cls(**dict(options))
