"""Physics of N doubles tennis courts in one pymunk space.

Every court is a side view: ground at ``y = 0``, a net at ``x = 0``, walls at
``x = ±wall_x`` and a ceiling at ``ceiling_y``, all static; a dynamic ball under
gravity; four kinematic rackets (paddles) that the game drives in numpy.

All courts live in **one** :class:`pymunk.Space`, laid out side by side
``court_spacing`` metres apart so that they never interact, and the space is
stepped once per env step for all of them (with ``substeps`` physics sub-steps
so that the ball cannot tunnel through the net, the rackets or the floor).
Body state goes in and out in bulk through :mod:`pymunk.batch` into numpy
arrays: there is no per-court Python loop on the hot path. Contacts are reported
by pymunk collision callbacks, which only run when something touches (a few
times per rally), and are accumulated into per-court numpy arrays.

Coordinates in this module are court-local (the court origin subtracted), in
metres, seconds and radians.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pymunk
import pymunk.batch

#: pymunk collision types.
_BALL, _RACKET, _GROUND, _NET, _WALL = 1, 2, 3, 4, 5

#: What ended the rally in a court during a step (``TennisPhysics.first_contact``).
NO_CONTACT, GROUND_CONTACT, NET_CONTACT, WALL_CONTACT = 0, 1, 2, 3

_FIELDS = (
    pymunk.batch.BodyFields.POSITION
    | pymunk.batch.BodyFields.ANGLE
    | pymunk.batch.BodyFields.VELOCITY
    | pymunk.batch.BodyFields.ANGULAR_VELOCITY
)
#: Columns of one body in the batch buffer: x, y, angle, vx, vy, angular velocity.
_X, _Y, _ANGLE, _VX, _VY, _OMEGA = range(6)


@dataclass(frozen=True)
class CourtGeometry:
    """Sizes and physical constants of one court (SI units).

    Attributes:
        half_length: the court spans ``x ∈ [-half_length, half_length]``; a ball landing
            beyond is out.
        wall_x: the side walls (out of play) at ``±wall_x``.
        ceiling_y: height of the ceiling (out of play).
        net_height: height of the top of the net.
        net_radius: half thickness of the net.
        ball_radius: radius of the ball.
        racket_half_length: half length of a racket's paddle.
        racket_radius: half thickness of a paddle.
        racket_ground_y: height of a racket's centre when standing on the ground; high
            enough that even a fully tilted paddle leaves room for the ball beneath it.
        racket_net_gap: closest a racket's centre may come to the net.
        racket_wall_gap: closest a racket's centre may come to a wall.
        racket_speed: top horizontal speed of a racket.
        jump_speed: take-off speed of a full jump.
        jump_threshold: the jump action takes off only above this value.
        max_tilt: largest paddle tilt from horizontal (action ±1): 55°, as in Unity's
            tennis.
        gravity: downward acceleration of ball and rackets.
        ball_elasticity: restitution of the ball (multiplied with the other shape's).
        racket_elasticity: restitution of a paddle.
        max_ball_speed: the ball's speed is capped here after every step, which with
            ``substeps`` bounds its travel per physics step below the thinnest obstacle.
        dt: duration of one physics frame (a decision holds its action for
            ``decision_interval`` frames, see :class:`~rlhc.envs.tennis.game.TennisGame`).
        substeps: pymunk steps per frame.
        court_spacing: distance between neighbouring courts' origins in the space.
    """

    half_length: float = 6.0
    wall_x: float = 8.0
    ceiling_y: float = 10.0
    net_height: float = 1.0
    net_radius: float = 0.08
    ball_radius: float = 0.12
    racket_half_length: float = 0.4
    racket_radius: float = 0.06
    racket_ground_y: float = 0.7
    racket_net_gap: float = 0.8
    racket_wall_gap: float = 0.8
    racket_speed: float = 6.0
    jump_speed: float = 6.0
    jump_threshold: float = 0.5
    max_tilt: float = 0.96
    gravity: float = 9.81
    ball_elasticity: float = 1.0
    racket_elasticity: float = 0.85
    max_ball_speed: float = 15.0
    dt: float = 0.02
    substeps: int = 1
    court_spacing: float = 30.0


class TennisPhysics:
    """``num_courts`` courts in one pymunk space; numpy views of their bodies.

    The ball is simulated by pymunk; the rackets are kinematic bodies whose motion
    the caller decides (``racket_*`` arrays, court-local) before each :meth:`step`.

    Args:
        num_courts: how many courts.
        geometry: sizes and constants shared by all courts.

    Examples:
        >>> physics = TennisPhysics(2)
        >>> physics.ball_position[:] = [[-3.0, 3.0], [3.0, 3.0]]
        >>> physics.step()
        >>> bool(physics.ball_velocity[0, 1] < 0)  # falling
        True
    """

    def __init__(self, num_courts: int, geometry: CourtGeometry | None = None) -> None:
        self.geometry = geometry if geometry is not None else CourtGeometry()
        self.num_courts = num_courts
        g = self.geometry
        self.space = pymunk.Space()
        self.space.gravity = (0.0, -g.gravity)
        # pymunk's defaults assume pixels; in metres 10 cm of allowed overlap is far too much.
        self.space.collision_slop = 0.002
        self.space.iterations = 5
        # A spatial hash beats the default bounding-box tree by 3x here: the tree is
        # rebuilt around hundreds of kinematic rackets that move every step, while
        # the hash cells (2 m, ~160 per court) match the courts' small, fixed layout.
        self.space.use_spatial_hash(2.0, max(1000, 160 * num_courts))
        self.origin_x = np.arange(num_courts, dtype=np.float64) * g.court_spacing
        self._ball_world: dict[pymunk.Body, int] = {}
        self._racket_index: dict[pymunk.Shape, tuple[int, int]] = {}
        for world in range(num_courts):
            self._add_court(world)
        self._add_handlers()

        # Court-local state (the source of truth between steps).
        n = num_courts
        self.ball_position = np.zeros((n, 2))
        self.ball_velocity = np.zeros((n, 2))
        self.racket_position = np.zeros((n, 4, 2))
        self.racket_velocity = np.zeros((n, 4, 2))
        self.racket_angle = np.zeros((n, 4))
        self.racket_spin = np.zeros((n, 4))
        # Contacts during the last step.
        self.racket_touch = np.zeros((n, 4), dtype=bool)
        self.first_contact = np.zeros(n, dtype=np.int64)
        self.contact_x = np.zeros(n)

        # One row per body in pymunk's iteration order: per court ball + 4 rackets,
        # then the shared static body (its row stays zero).
        self._rows = np.zeros((5 * n + 1, 6))
        # Two buffers: the write buffer wraps ``_rows`` (no copy), the read buffer owns
        # its memory (pymunk appends into it, so it must never wrap a numpy array).
        self._write_buffer = pymunk.batch.Buffer()
        self._write_buffer.set_float_buf(self._rows.reshape(-1))
        self._read_buffer = pymunk.batch.Buffer()
        self._check_body_order()

    # --- construction ------------------------------------------------------------------
    def _add_court(self, world: int) -> None:
        g = self.geometry
        x0 = float(self.origin_x[world])
        static = self.space.static_body
        thick = 0.5  # floor and walls are thick so that nothing tunnels through them
        statics = [
            (pymunk.Segment(static, (x0 - g.wall_x - thick, -thick), (x0 + g.wall_x + thick, -thick), thick), _GROUND),
            (pymunk.Segment(static, (x0 - g.wall_x - thick, 0.0), (x0 - g.wall_x - thick, g.ceiling_y), thick), _WALL),
            (pymunk.Segment(static, (x0 + g.wall_x + thick, 0.0), (x0 + g.wall_x + thick, g.ceiling_y), thick), _WALL),
            (pymunk.Segment(static, (x0 - g.wall_x, g.ceiling_y + thick), (x0 + g.wall_x, g.ceiling_y + thick), thick), _WALL),
            (pymunk.Segment(static, (x0, 0.0), (x0, g.net_height - g.net_radius), g.net_radius), _NET),
        ]  # fmt: skip
        for shape, collision_type in statics:
            shape.collision_type = collision_type
            shape.elasticity = 0.5
            shape.friction = 0.3
            self.space.add(shape)

        # An infinite moment: the ball does not spin, so position and velocity are its state.
        ball = pymunk.Body(0.06, float("inf"))
        ball.position = (x0, 3.0)
        ball_shape = pymunk.Circle(ball, g.ball_radius)
        ball_shape.collision_type = _BALL
        ball_shape.elasticity = g.ball_elasticity
        ball_shape.friction = 0.2
        self.space.add(ball, ball_shape)
        self._ball_world[ball] = world

        for racket in range(4):
            team = racket // 2
            body = pymunk.Body(body_type=pymunk.Body.KINEMATIC)
            body.position = (x0, g.racket_ground_y)
            shape = pymunk.Segment(
                body, (-g.racket_half_length, 0.0), (g.racket_half_length, 0.0), g.racket_radius
            )
            shape.collision_type = _RACKET
            shape.elasticity = g.racket_elasticity
            shape.friction = 0.2
            # Teammates share a filter group so they never collide, even if rackets
            # were made dynamic; kinematic bodies already ignore each other.
            shape.filter = pymunk.ShapeFilter(group=1 + 2 * world + team)
            self.space.add(body, shape)
            self._racket_index[shape] = (world, racket)

    def _add_handlers(self) -> None:
        self.space.on_collision(_BALL, _RACKET, begin=self._on_racket)
        self.space.on_collision(_BALL, _GROUND, begin=self._on_boundary, data=GROUND_CONTACT)
        self.space.on_collision(_BALL, _NET, begin=self._on_boundary, data=NET_CONTACT)
        self.space.on_collision(_BALL, _WALL, begin=self._on_boundary, data=WALL_CONTACT)

    def _check_body_order(self) -> None:
        # set_space_bodies writes rows in the space's iteration order; make sure it is
        # ours (ball, racket 0..3 per court, then the static body).
        self._read_buffer.clear()
        pymunk.batch.get_space_bodies(
            self.space, pymunk.batch.BodyFields.BODY_ID, self._read_buffer
        )
        ids = np.frombuffer(self._read_buffer.int_buf(), dtype=np.uintp).copy()
        expected = [body.id for body in self.space.bodies] + [self.space.static_body.id]
        if len(ids) != len(self._rows) or list(ids) != expected:
            raise RuntimeError("unexpected pymunk body iteration order")

    # --- contacts ------------------------------------------------------------------------
    def _on_racket(self, arbiter: pymunk.Arbiter, space: pymunk.Space, data: object) -> None:
        for shape in arbiter.shapes:
            index = self._racket_index.get(shape)
            if index is not None:
                self.racket_touch[index] = True

    def _on_boundary(self, arbiter: pymunk.Arbiter, space: pymunk.Space, data: object) -> None:
        for body in arbiter.bodies:
            world = self._ball_world.get(body)
            # Only the first rally-ending contact of a step counts.
            if world is not None and self.first_contact[world] == NO_CONTACT:
                self.first_contact[world] = int(data)  # type: ignore[call-overload]
                self.contact_x[world] = body.position.x - self.origin_x[world]

    # --- stepping ------------------------------------------------------------------------
    def step(self) -> None:
        """Advance all courts by ``geometry.dt``.

        The rackets move with ``racket_velocity`` / ``racket_spin`` from their current
        pose; afterwards ``ball_*`` and ``racket_*`` hold the new state and
        ``racket_touch`` / ``first_contact`` / ``contact_x`` the contacts of this step.
        """
        g = self.geometry
        n = self.num_courts
        rows = self._rows
        ball_rows = rows[0 : 5 * n : 5]
        racket_rows = rows[: 5 * n].reshape(n, 5, 6)[:, 1:]
        ball_rows[:, _X] = self.ball_position[:, 0] + self.origin_x
        ball_rows[:, _Y] = self.ball_position[:, 1]
        ball_rows[:, _VX : _VY + 1] = self.ball_velocity
        ball_rows[:, _ANGLE] = 0.0
        ball_rows[:, _OMEGA] = 0.0
        racket_rows[..., _X] = self.racket_position[..., 0] + self.origin_x[:, None]
        racket_rows[..., _Y] = self.racket_position[..., 1]
        racket_rows[..., _ANGLE] = self.racket_angle
        racket_rows[..., _VX : _VY + 1] = self.racket_velocity
        racket_rows[..., _OMEGA] = self.racket_spin
        pymunk.batch.set_space_bodies(self.space, _FIELDS, self._write_buffer)

        self.racket_touch[:] = False
        self.first_contact[:] = NO_CONTACT
        sub_dt = g.dt / g.substeps
        for _ in range(g.substeps):
            self.space.step(sub_dt)

        self._read_buffer.clear()
        pymunk.batch.get_space_bodies(self.space, _FIELDS, self._read_buffer)
        out = np.frombuffer(self._read_buffer.float_buf(), dtype=np.float64).reshape(-1, 6)
        out_ball = out[0 : 5 * n : 5]
        self.ball_position[:, 0] = out_ball[:, _X] - self.origin_x
        self.ball_position[:, 1] = out_ball[:, _Y]
        velocity = out_ball[:, _VX : _VY + 1].copy()
        # A kinematic racket can squeeze the ball into a static surface (both have
        # infinite mass). Project it back inside the court box so nothing ever leaves.
        r = g.ball_radius
        limit_x = g.wall_x - r
        x, y = self.ball_position[:, 0], self.ball_position[:, 1]
        outside_x = np.abs(x) > limit_x
        velocity[outside_x, 0] = np.where(x[outside_x] > 0, -1.0, 1.0) * np.abs(
            velocity[outside_x, 0]
        )
        np.clip(x, -limit_x, limit_x, out=x)
        below, above = y < r, y > g.ceiling_y - r
        velocity[below, 1] = np.abs(velocity[below, 1])
        velocity[above, 1] = -np.abs(velocity[above, 1])
        np.clip(y, r, g.ceiling_y - r, out=y)
        # Cap the speed so that no physics sub-step carries the ball through the net.
        speed = np.sqrt(np.einsum("ij,ij->i", velocity, velocity))
        scale = np.minimum(1.0, g.max_ball_speed / np.maximum(speed, 1e-12))
        self.ball_velocity[:] = velocity * scale[:, None]
        out_rackets = out[: 5 * n].reshape(n, 5, 6)[:, 1:]
        self.racket_position[..., 0] = out_rackets[..., _X] - self.origin_x[:, None]
        self.racket_position[..., 1] = out_rackets[..., _Y]
        self.racket_angle[:] = out_rackets[..., _ANGLE]
