"""Ray casts for every ray of every agent of every pitch at once, in numpy.

A Unity-style ray sensor, vectorised: each agent casts a fan of rays from its centre;
a ray stops at the first thing it meets. Two kinds of targets exist on a pitch:

* circles (the ball and the other three players): the classic ray–circle quadratic,
  solved in the agent's own frame so that the ray directions are constants;
* the pitch boundary: the walls' inner faces form the rectangle
  ``|x| <= half_length, |y| <= half_width`` and the goal mouths are the parts of the
  goal lines with ``|y| <= goal_half_width``. Agents never leave the rectangle
  (players cannot enter the nets), so a ray always leaves it through exactly one side:
  the slab method gives the exit distance in a handful of array operations, and the
  exit point says whether it is a wall or a mouth. The nets behind the mouths are
  never seen: a mouth is opaque to rays (as the goal object is in Unity), though not
  to the ball.

The result agrees with pymunk's ``Space.segment_query_first`` on the physics space
(tests check it on random scenes) at a fraction of the cost: one Python call per
pitch-step instead of one per ray.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rlhc.envs.soccer.physics import PitchGeometry

#: target codes after the circle slots: ``num_circles + WALL`` etc.
WALL, GOAL_LEFT, GOAL_RIGHT = 0, 1, 2

# Guards a division by a direction component that is exactly zero (the ray is parallel
# to that pair of walls: its exit distance through them must come out huge, not NaN).
_TINY = np.float32(1e-12)


@dataclass(frozen=True)
class RayFan:
    """A fan of rays around an agent's facing.

    Attributes:
        angles: ``float32 [R]`` ray directions relative to the facing, radians,
            increasing counter-clockwise (from the agent's right to its left).
        length: the range of every ray.
    """

    angles: np.ndarray
    length: float

    @classmethod
    def spread(cls, count: int, degrees: float, length: float) -> RayFan:
        """``count`` rays evenly spaced over ``degrees``, centred on the facing.

        Examples:
            >>> [round(float(angle), 4) for angle in RayFan.spread(3, 180.0, 5.0).angles]
            [-1.5708, 0.0, 1.5708]
        """
        half = np.deg2rad(degrees) / 2
        return cls(np.linspace(-half, half, count, dtype=np.float32), float(length))


@dataclass
class RayHits:
    """What each ray met first.

    Attributes:
        distance: ``float32 [N, A, R]`` distance from the agent's centre to the hit
            (rays are not clipped to a range here: every ray meets the boundary).
        target: ``int64 [N, A, R]``: ``c < C`` for circle slot ``c``, else
            ``C + WALL``, ``C + GOAL_LEFT`` (the mouth at ``-x``) or ``C + GOAL_RIGHT``.
        hit_x: ``float32 [N, A, R]`` pitch-local ``x`` of the hit point.
    """

    distance: np.ndarray
    target: np.ndarray
    hit_x: np.ndarray


def cast_rays(
    origins: np.ndarray,
    facings: np.ndarray,
    circle_centres: np.ndarray,
    circle_radii: np.ndarray,
    ray_angles: np.ndarray,
    geometry: PitchGeometry,
) -> RayHits:
    """Cast ``R`` rays from each of ``A`` agents in ``N`` pitches.

    Args:
        origins: ``[N, A, 2]`` agent centres, pitch-local; inside the pitch rectangle.
        facings: ``[N, A]`` agent facing angles.
        circle_centres: ``[N, A, C, 2]`` the circles agent ``a`` can see (not itself).
        circle_radii: ``[C]`` or ``[A, C]`` their radii.
        ray_angles: ``[R]`` ray directions relative to the facing.
        geometry: the pitch boundary.

    Returns:
        The first hit of every ray. A circle that contains the ray's origin is not hit
        (as in pymunk: an overlapping body is not "seen" from inside).

    Examples:
        >>> geometry = PitchGeometry(8.0, 5.0, 1.5, 1.0)
        >>> hits = cast_rays(
        ...     np.zeros((1, 1, 2)), np.zeros((1, 1)), np.array([[[[3.0, 0.0]]]]),
        ...     np.array([0.5]), np.array([0.0, np.pi / 2]), geometry,
        ... )
        >>> hits.distance.round(3).tolist(), hits.target.tolist()
        ([[[2.5, 5.0]]], [[[0, 1]]])
    """
    f32 = np.float32
    origins = origins.astype(f32, copy=False)
    cos_f = np.cos(facings).astype(f32)[..., None]  # [N, A, 1]
    sin_f = np.sin(facings).astype(f32)[..., None]
    cos_r = np.cos(ray_angles).astype(f32)  # [R]
    sin_r = np.sin(ray_angles).astype(f32)
    num_circles = circle_centres.shape[2]

    # Circles, in the agent's frame: the ray is (cos_r, sin_r) t, the circle centre is
    # (forward, left); solve |t d - c| = r for the smaller root t >= 0.
    relative = circle_centres.astype(f32, copy=False) - origins[:, :, None, :]
    forward = relative[..., 0] * cos_f + relative[..., 1] * sin_f  # [N, A, C]
    left = relative[..., 1] * cos_f - relative[..., 0] * sin_f
    radii = np.asarray(circle_radii, dtype=f32)
    offset = forward * forward + left * left - radii * radii  # |c|^2 - r^2, [N, A, C]
    along = forward[..., None] * cos_r + left[..., None] * sin_r  # [N, A, C, R]
    discriminant = along * along - offset[..., None]
    circle_t = along - np.sqrt(np.maximum(discriminant, f32(0.0)))
    circle_t[(discriminant < 0) | (circle_t < 0)] = np.inf
    nearest_circle = circle_t.argmin(axis=2)  # [N, A, R]
    nearest_circle_t = np.take_along_axis(circle_t, nearest_circle[:, :, None, :], axis=2)[:, :, 0]

    # Pitch boundary, world-aligned: direction = facing rotated by the ray angle.
    dx = cos_f * cos_r - sin_f * sin_r  # [N, A, R]
    dy = sin_f * cos_r + cos_f * sin_r
    ox, oy = origins[..., 0:1], origins[..., 1:2]
    sign_x = np.where(dx >= 0, f32(1.0), f32(-1.0))
    sign_y = np.where(dy >= 0, f32(1.0), f32(-1.0))
    exit_x = np.maximum(f32(geometry.half_length) - sign_x * ox, 0) / np.maximum(np.abs(dx), _TINY)
    exit_y = np.maximum(f32(geometry.half_width) - sign_y * oy, 0) / np.maximum(np.abs(dy), _TINY)
    through_end = exit_x < exit_y
    boundary_t = np.where(through_end, exit_x, exit_y)
    mouth = through_end & (np.abs(oy + boundary_t * dy) <= f32(geometry.goal_half_width))
    boundary_target = np.where(
        mouth,
        np.where(dx > 0, num_circles + GOAL_RIGHT, num_circles + GOAL_LEFT),
        num_circles + WALL,
    )

    circle_first = nearest_circle_t < boundary_t
    distance = np.where(circle_first, nearest_circle_t, boundary_t)
    target = np.where(circle_first, nearest_circle, boundary_target)
    return RayHits(distance=distance, target=target, hit_x=ox + distance * dx)
