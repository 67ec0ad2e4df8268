"""All pitches in one pymunk space, read and written in bulk.

The ``N`` pitches of a batch live in a single :class:`pymunk.Space`, laid out along the
x axis far enough apart that they never touch, and are stepped by one ``space.step``
call: the per-world Python loop that dominated a "one space per world" design is gone.
Positions, angles and velocities of the ``5 N`` dynamic bodies move between pymunk and
numpy through :mod:`pymunk.batch` (one C loop each way per step).

Coordinates handed out by this module are *pitch-local*: the centre spot of every pitch
is ``(0, 0)``, team 0 defends the goal at ``x = -pitch_length / 2`` and attacks ``+x``.

Body order (fixed, shared by all modules of the game):

====== ============ ==========
index  body         team
====== ============ ==========
0      ``striker_0``  0
1      ``striker_1``  1
2      ``goalie_0``   0
3      ``goalie_1``   1
4      ball           —
====== ============ ==========
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pymunk
import pymunk.batch

from rlhc.envs.soccer.options import WALL_THICKNESS, SoccerOptions

#: players in body order, then the ball.
PLAYER_NAMES: tuple[str, ...] = ("striker_0", "striker_1", "goalie_0", "goalie_1")
NUM_PLAYERS = 4
BALL = 4
BODIES_PER_WORLD = 5
#: team of each player, in body order.
PLAYER_TEAM = np.array([0, 1, 0, 1], dtype=np.int64)
#: whether each player is a striker (may rotate) or a goalie (facing fixed).
PLAYER_IS_STRIKER = np.array([True, True, False, False])
#: facing angle of each team at kick-off, and the sign that turns team 0's frame into the team's.
TEAM_HEADING = np.where(PLAYER_TEAM == 0, 0.0, np.pi)
TEAM_SIGN = np.where(PLAYER_TEAM == 0, 1.0, -1.0)


def facing_vectors(angles: np.ndarray) -> np.ndarray:
    """``[N, 4, 2]`` unit facing of the players, exactly opposite between the teams.

    Team 1's facing is minus the vector of its angle measured from π: ``(cos π, sin π)``
    is ``(-1, 1.2e-16)``, which would add a sideways 3.7e-16 m/s to every forward move
    of team 1 and break the half-turn symmetry of the game (and, through a knife-edge
    test in the scripted striker, make the two sides play different matches).

    Args:
        angles: ``[N, 5]`` body angles (players in body order, then the ball).
    """
    local = angles[:, :NUM_PLAYERS] - TEAM_HEADING
    return TEAM_SIGN[:, None] * np.stack([np.cos(local), np.sin(local)], axis=-1)


# Collision categories: the goal-mouth barrier (a box filling the net, its face on the
# goal line) stops players (a goalie may not hide in the net) but lets the ball through.
# It is a deep box, not a line: a player pushing into a line every step ends up through it.
_PLAYER, _BALL, _WALL, _MOUTH = 0b0001, 0b0010, 0b0100, 0b1000
_ALL = 0xFFFFFFFF

_FIELDS = (
    pymunk.batch.BodyFields.POSITION
    | pymunk.batch.BodyFields.ANGLE
    | pymunk.batch.BodyFields.VELOCITY
    | pymunk.batch.BodyFields.ANGULAR_VELOCITY
)
# pymunk's batch layout per body follows the flag order: angular velocity, then force.
_CONTROL_FIELDS = pymunk.batch.BodyFields.ANGULAR_VELOCITY | pymunk.batch.BodyFields.FORCE
#: body masses in body order (players, ball); the ball is light, so it flies off a kick.
MASSES = np.array([2.0, 2.0, 2.0, 2.0, 0.45])


@dataclass(frozen=True)
class PitchGeometry:
    """The shape of one pitch, pitch-local coordinates.

    Attributes:
        half_length: ``x`` of the goal lines (the inner faces of the end walls).
        half_width: ``y`` of the touch lines (the inner faces of the side walls).
        goal_half_width: the goal mouths span ``|y| <= goal_half_width``.
        goal_depth: the nets extend from ``half_length`` to ``half_length + goal_depth``.
    """

    half_length: float
    half_width: float
    goal_half_width: float
    goal_depth: float

    @classmethod
    def from_options(cls, options: SoccerOptions) -> PitchGeometry:
        """The geometry described by the game options."""
        return cls(
            half_length=options.pitch_length / 2,
            half_width=options.pitch_width / 2,
            goal_half_width=options.goal_width / 2,
            goal_depth=options.goal_depth,
        )

    def wall_boxes(self) -> list[tuple[float, float, float, float]]:
        """The solid walls as boxes ``(x_min, y_min, x_max, y_max)``.

        Their inner faces are exactly the lines the ray caster uses: ``y = ±half_width``,
        ``x = ±half_length`` outside the mouths, and the three faces of each net.
        """
        a, b, g, d, t = (
            self.half_length,
            self.half_width,
            self.goal_half_width,
            self.goal_depth,
            WALL_THICKNESS,
        )
        outer = a + d + t
        boxes = [(-outer, b, outer, b + t), (-outer, -b - t, outer, -b)]
        for sign in (-1.0, 1.0):
            near, far = sorted((sign * a, sign * outer))
            back_near, back_far = sorted((sign * (a + d), sign * outer))
            boxes.append((near, g, far, b))  # end wall beside the mouth, net side
            boxes.append((near, -b, far, -g))
            boxes.append((back_near, -g, back_far, g))  # back of the net
        return boxes

    def contains(self, points: np.ndarray, margin: float = 0.0) -> np.ndarray:
        """Whether points ``[..., 2]`` lie on the pitch or in a net, ``margin`` allowed."""
        x, y = np.abs(points[..., 0]), np.abs(points[..., 1])
        on_pitch = (x <= self.half_length + margin) & (y <= self.half_width + margin)
        in_net = (x <= self.half_length + self.goal_depth + margin) & (
            y <= self.goal_half_width + margin
        )
        return on_pitch | in_net


class SoccerPhysics:
    """The bodies of ``num_worlds`` pitches, stepped together.

    Args:
        num_worlds: number of pitches.
        options: the game options (pitch size, radii, speeds, substeps).

    Attributes:
        positions: ``float64 [N, 5, 2]`` pitch-local positions (body order above).
        angles: ``float64 [N, 5]`` facing angles (radians, ``0`` is ``+x``).
        velocities: ``float64 [N, 5, 2]``.
        world_offset: ``float64 [N, 2]`` where each pitch's centre spot is in the space.

    Examples:
        >>> physics = SoccerPhysics(2, SoccerOptions())
        >>> physics.positions.shape
        (2, 5, 2)
    """

    def __init__(self, num_worlds: int, options: SoccerOptions) -> None:
        self.num_worlds = num_worlds
        self.options = options
        self.geometry = PitchGeometry.from_options(options)
        self.space = pymunk.Space()
        # 100: a converged contact solve, so the result does not depend on pymunk's fixed
        # solving order. At 10, a ball squeezed between two players resolved 5e-2 m/s
        # differently in the half-turned scene, and matches diverged by team.
        self.space.iterations = 100
        # A spatial hash beats pymunk's default tree by ~7x at 256 pitches: the bodies
        # are few per pitch and all about the same size (5 m cells measured fastest).
        self.space.use_spatial_hash(5.0, 10 * BODIES_PER_WORLD * num_worlds + 1000)
        spacing = 2 * (self.geometry.half_length + self.geometry.goal_depth) + 4 * WALL_THICKNESS
        self.world_offset = np.zeros((num_worlds, 2))
        self.world_offset[:, 0] = np.arange(num_worlds) * (spacing + 10.0)
        #: shape -> (world, tag); tags: "wall", "goal_<team that defends it>",
        #: "player_<body index>", "ball". Used by tests and the ray-cast cross-check.
        self.shape_tags: dict[pymunk.Shape, tuple[int, str]] = {}
        self.bodies: list[list[pymunk.Body]] = []  # [world][body index]
        self._build()
        self._rows = self._count_rows()
        self._io = np.zeros((self._rows, 6))
        self._write_buffer = pymunk.batch.Buffer()
        self._read_buffer = pymunk.batch.Buffer()
        self.positions = np.zeros((num_worlds, BODIES_PER_WORLD, 2))
        self.angles = np.zeros((num_worlds, BODIES_PER_WORLD))
        self.velocities = np.zeros((num_worlds, BODIES_PER_WORLD, 2))
        self.read()
        # Every body was created at its pitch's centre spot: reading them back at (0, 0)
        # pitch-local proves that the bulk order is (world, body) as assumed.
        if not np.allclose(self.positions, 0.0):
            raise RuntimeError("pymunk's body order is not the order the bodies were added in")

    # --- construction ---------------------------------------------------------------
    def _build(self) -> None:
        options, geometry = self.options, self.geometry
        static = self.space.static_body
        for world in range(self.num_worlds):
            ox, oy = self.world_offset[world]
            for x0, y0, x1, y1 in geometry.wall_boxes():
                box = pymunk.Poly(
                    static,
                    [
                        (ox + x0, oy + y0),
                        (ox + x1, oy + y0),
                        (ox + x1, oy + y1),
                        (ox + x0, oy + y1),
                    ],
                )
                box.elasticity, box.friction = 0.6, 0.2
                box.filter = pymunk.ShapeFilter(categories=_WALL, mask=_ALL)
                self.space.add(box)
                self.shape_tags[box] = (world, "wall")
            for team, sign in ((0, -1.0), (1, 1.0)):
                near, far = sorted(
                    (
                        sign * geometry.half_length,
                        sign * (geometry.half_length + geometry.goal_depth),
                    )
                )
                low, high = oy - geometry.goal_half_width, oy + geometry.goal_half_width
                mouth = pymunk.Poly(
                    static, [(ox + near, low), (ox + far, low), (ox + far, high), (ox + near, high)]
                )
                mouth.elasticity, mouth.friction = 0.0, 0.0
                mouth.filter = pymunk.ShapeFilter(categories=_MOUTH, mask=_PLAYER)
                self.space.add(mouth)
                self.shape_tags[mouth] = (world, f"goal_{team}")
            self.bodies.append([])
            for index in range(BODIES_PER_WORLD):
                is_ball = index == BALL
                mass = float(MASSES[index])
                # Infinite moments: players turn only by their actions, the ball's spin
                # is irrelevant to the game.
                body = pymunk.Body(mass, float("inf"))
                body.position = (ox, oy)
                radius = options.ball_radius if is_ball else options.player_radius
                circle = pymunk.Circle(body, radius)
                circle.elasticity = 0.7 if is_ball else 0.2
                circle.friction = 0.05 if is_ball else 0.3
                category = _BALL if is_ball else _PLAYER
                # A group of its own: a query from the body's centre can skip the body.
                group = 1 + world * BODIES_PER_WORLD + index
                circle.filter = pymunk.ShapeFilter(group=group, categories=category, mask=_ALL)
                self.space.add(body, circle)
                self.bodies[world].append(body)
                self.shape_tags[circle] = (world, "ball" if is_ball else f"player_{index}")

    def _count_rows(self) -> int:
        buffer = pymunk.batch.Buffer()
        pymunk.batch.get_space_bodies(self.space, _FIELDS, buffer)
        rows = len(np.frombuffer(buffer.float_buf(), dtype=np.float64)) // 6
        # pymunk iterates dynamic bodies first, in the order they were added, then the
        # static body; the bulk writes below rely on it.
        if rows < BODIES_PER_WORLD * self.num_worlds:
            raise RuntimeError(
                f"pymunk reported {rows} bodies, expected at least {5 * self.num_worlds}"
            )
        return rows

    # --- bulk transfer --------------------------------------------------------------
    def read(self) -> None:
        """Copy every body's position, angle and velocity out of pymunk."""
        self._read_buffer.clear()
        pymunk.batch.get_space_bodies(self.space, _FIELDS, self._read_buffer)
        flat = np.frombuffer(self._read_buffer.float_buf(), dtype=np.float64)
        self._io[:] = flat.reshape(self._rows, 6)
        bodies = self._io[: BODIES_PER_WORLD * self.num_worlds].reshape(
            self.num_worlds, BODIES_PER_WORLD, 6
        )
        self.positions[:] = bodies[..., 0:2] - self.world_offset[:, None, :]
        self.angles[:] = bodies[..., 2]
        self.velocities[:] = bodies[..., 3:5]

    def drive(self, velocities: np.ndarray, angular_velocities: np.ndarray) -> None:
        """Steer every body to velocity ``[N, 5, 2]`` within the first substep of the next step.

        The change is applied as a force, not by setting the velocity: pymunk moves the
        bodies *before* it solves contacts within a substep, so a velocity written into
        a wall would first carry a player into it (0.15 m per step at full speed, a
        lasting overlap when it keeps pushing); a force is integrated after contact
        detection, and the contact solver removes its push into the wall.

        Args:
            velocities: ``[N, 5, 2]`` the velocities wanted.
            angular_velocities: ``[N, 5]`` set directly (the moments are infinite).
        """
        substep = self.options.step_seconds / self.options.physics_substeps
        rows = np.zeros((self._rows, 3))
        bodies = rows[: BODIES_PER_WORLD * self.num_worlds].reshape(
            self.num_worlds, BODIES_PER_WORLD, 3
        )
        bodies[..., 0] = angular_velocities
        bodies[..., 1:3] = MASSES[:, None] * (velocities - self.velocities) / substep
        self._write_buffer.set_float_buf(rows.reshape(-1))
        pymunk.batch.set_space_bodies(self.space, _CONTROL_FIELDS, self._write_buffer)

    def teleport(self, mask: np.ndarray, positions: np.ndarray, angles: np.ndarray) -> None:
        """Place the bodies of the worlds in ``mask`` at rest; other worlds are untouched.

        Args:
            mask: ``bool [N]``.
            positions: ``[N, 5, 2]`` pitch-local (only the masked rows are used).
            angles: ``[N, 5]`` (only the masked rows are used).
        """
        rows = self._io.copy()  # current state of every body (static body included)
        rows[:, 5] = 0.0
        bodies = rows[: BODIES_PER_WORLD * self.num_worlds].reshape(
            self.num_worlds, BODIES_PER_WORLD, 6
        )
        bodies[mask, :, 0:2] = positions[mask] + self.world_offset[mask, None, :]
        bodies[mask, :, 2] = angles[mask]
        bodies[mask, :, 3:5] = 0.0
        self._write_buffer.set_float_buf(rows.reshape(-1))
        pymunk.batch.set_space_bodies(self.space, _FIELDS, self._write_buffer)
        # pymunk refreshes shape positions only when stepping; do it now for the moved
        # bodies so that queries (segment_query_first, …) see the new scene at once.
        for world in np.flatnonzero(mask):
            for body in self.bodies[world]:
                self.space.reindex_shapes_for_body(body)
        self.read()

    def step(self) -> None:
        """Advance all pitches by ``step_seconds`` and read the result back."""
        substep = self.options.step_seconds / self.options.physics_substeps
        for _ in range(self.options.physics_substeps):
            self.space.step(substep)
        self.read()
