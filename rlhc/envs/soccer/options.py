"""The options of the soccer game, read once and checked loudly.

Every keyword the game accepts is a field of :class:`SoccerOptions`; a misspelt option
fails with the names it does not know (the VMAS habit), instead of being ignored.
Lengths are in metres, times in seconds, speeds in metres per second.

The defaults are calibrated against the SoccerTwos scene of Unity ML-Agents, the soccer
the RLHC paper ran (ML-Agents 0.5): its proportions, not its metres (``L`` is the length
between the goal lines, ``W`` the width). Sources, all in ``Unity-Technologies/ml-agents``:
[P] ``unity-environment/Assets/ML-Agents/Examples/Soccer/Prefabs/SoccerFieldTwos.prefab``
@629a4922 (0.3/0.4; the same field is kept as ``UnitySDK/.../Prefabs/SoccerFieldTwos_old.prefab``
@540523db, 0.6 era); [S] ``unity-environment/.../Soccer/Scenes/SoccerTwos.unity`` @5dc55f45;
[A] ``unity-environment/.../Soccer/Scripts/AgentSoccer.cs`` @137d88b0 and, later,
``UnitySDK/.../Soccer/Scripts/AgentSoccer.cs`` @02f2fc41; [D]
``unity-environment/ProjectSettings/DynamicsManager.asset`` @10c7f315. The 0.5 tag itself
is not in the stored history: these are the versions on either side of it.

=============== ======================================================= ===== ============
option          SoccerTwos                                              src   default
=============== ======================================================= ===== ============
pitch_length    29.8 m between the goal boxes' faces (field box 30 m)   P     20 m
pitch_width     15.3 m between the side walls: L / W = 1.95             P     10 m (2.0)
goal_width      9.0 m between the side nets (goal box 9.3 m): 0.59 W   P     6 m (0.6 W)
goal_depth      goal box 1.5-1.6 m deep: 0.05 L                        P     2 m (0.1 L)
player_radius   sphere 0.5 x largest scale 2 = 1.0 m: 0.034 L           P     0.67 m
ball_radius     sphere 0.11 x scale 8 = 0.88 m: 0.030 L                 P     0.59 m
player_speed    2 m/s VelocityChange each 0.02 s frame, drag 3 /s:      S A P 6 m/s
                ~2 / (3 x 0.02) = 33 m/s, ~1 L/s (derived, not stored)        (0.3 L/s)
side_speed      1.0 x forward [A@137d88b0], 0.75 x [A@02f2fc41]         A     0.75 x
rotation_speed  Rotate(deltaTime x 100 deg) per frame: 100 deg/s        A     1.745 rad/s
kick_speed      2000 N x 1 frame = 40 N s on a 4 kg ball: 10 m/s,       A P   6.7 m/s
                0.34 L/s (at first contact, along centre -> contact)
ball_drag       drag 0.1 /s + angular drag 1 /s, rolling solid sphere:  P     0.965
                ~0.36 /s, 0.965 per 0.1 s (derived)
ball_max_speed  none                                                    --    13 m/s
max_cycles      maxStep 3000 frames / 5 per decision = 600 (60 s)       P     600
decision        every 5 frames of 0.02 s = 0.1 s                        P     1 x 0.1 s
substeps        PhysX steps every 0.02 s                                P     3 (1/30 s)
ray lengths     20 m = 0.67 L (7 angles x 2 heights, 112 values)        A     13.4 m; 30 m
=============== ======================================================= ===== ============

Kept from before (no SoccerTwos number, or one we do not follow): masses (players 50 kg,
ball 4 kg there; see ``physics.MASSES``), the kick-off, the rewards
and time terms (paper Table 2; the scene's code pays -1/3000 and +1/3000 per frame, its
docs -0.001 and +0.001), the kick along the facing (SoccerTwos pushes along the line of
centres), a goal when the whole ball is over the line (SoccerTwos: when it touches the goal
box), and no zones: SoccerTwos has invisible walls at 9 m (goalies only) and 10.5 m
(strikers only) from the centre [P, D], so its strikers never enter a goal area. The
player speed stops at 0.3 L/s: faster players sink deeper than 0.3 m into the walls with
three physics substeps (SoccerTwos' ~1 L/s would need ~7); the net is 2 m deep so that a
shot is seen wholly over the line before it bounces back out.
``benchmarks/soccer_calibration.py`` measures what the calibration changed.
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
            ML-Agents' SoccerTwos, 5 frames of 0.02 s). Five frames of 0.02 s here score
            more (random play 0.49 of episodes instead of 0.33), mostly because a kick is
            checked once per frame (SoccerTwos kicks at any physics step), at ~1.7x the
            cost per decision.
        striker_time_reward: added to each striker's reward every decision (paper:
            -0.001, an incentive to score quickly).
        goalie_time_reward: added to each goalie's reward every decision (paper: +0.001,
            an incentive to keep the ball out for long).
        pitch_length: inner length of the pitch, goal line to goal line.
        pitch_width: inner width of the pitch, touch line to touch line.
        goal_width: width of the goal mouth, centred on each goal line.
        goal_depth: depth of the net box behind each goal line; deep enough beyond the
            ball's diameter that a shot is seen wholly over the line at the end of a frame
            before it bounces back out (at 1.2 m, 2 cm more than the ball, it was not).
        step_seconds: simulated time per physics frame.
        physics_substeps: pymunk steps per frame (collision quality: at the default
            speeds, 3 keeps every body's overlap with a wall under 0.3 m).
        player_radius: radius of every player's circle.
        ball_radius: radius of the ball.
        player_speed: speed of a forward or backward move.
        side_speed: speed of a sideways move.
        rotation_speed: angular speed of a striker's rotation, radians per second.
        kick_speed: velocity added to the ball, along the kicker's facing, when a player
            touching the ball (in front of it) chooses "forward".
        ball_max_speed: the ball's speed is capped here before each step (no tunnelling).
        ball_drag: fraction of the ball's velocity kept per frame (rolling friction).
        worker_ray_length: range of the worker's 14 rays.
        manager_ray_length: range of the manager's 20 rays (longer: a broader view).
        kickoff_jitter: half-width of the uniform noise added to kick-off positions.
        kickoff_angle_jitter: half-width of the uniform noise on the strikers' facing.
    """

    max_cycles: int = 600
    decision_interval: int = 1
    striker_time_reward: float = -0.001
    goalie_time_reward: float = 0.001
    pitch_length: float = 20.0
    pitch_width: float = 10.0
    goal_width: float = 6.0
    goal_depth: float = 2.0
    step_seconds: float = 0.1
    physics_substeps: int = 3
    player_radius: float = 0.67
    ball_radius: float = 0.59
    player_speed: float = 6.0
    side_speed: float = 4.5
    rotation_speed: float = 1.745
    kick_speed: float = 6.7
    ball_max_speed: float = 13.0
    ball_drag: float = 0.965
    worker_ray_length: float = 13.4
    manager_ray_length: float = 30.0
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
