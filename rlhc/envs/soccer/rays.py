"""Ray casts for every ray of every agent of every pitch at once, in numpy.

A Unity-style ray sensor, vectorised: each agent casts fans of rays from its centre;
a ray stops at the first thing it meets. Two kinds of targets exist on a pitch:

* the pitch boundary: the walls' inner faces form the rectangle
  ``|x| <= half_length, |y| <= half_width`` and the goal mouths are the parts of the
  goal lines with ``|y| <= goal_half_width``. Agents never leave the rectangle
  (players cannot enter the nets), so every ray leaves it through exactly one side:
  the slab method gives the exit distance in a handful of array operations per ray,
  and the exit point says whether it is a wall or a mouth. The nets behind the mouths
  are never seen: a mouth is opaque to rays (as the goal object is in Unity), though
  not to the ball.
* circles (the ball and the other three players): most rays miss most circles, so
  they are handled sparsely. A circle at bearing ``β`` and distance ``d`` covers the
  directions ``|α - β| <= asin(r / d)``; with evenly spaced fans that is a range of
  ray indices, computed per (agent, circle) pair. Only those rays solve the ray–circle
  quadratic, and ``np.minimum.at`` keeps the nearest hit of each ray.

So the cost is a few dense operations per ray plus work proportional to the number of
(agent, circle) pairs and actual hits. The result agrees with pymunk's
``Space.segment_query_first`` on the physics space (a test checks it on random scenes);
pymunk needs one Python call per ray.
"""

from __future__ import annotations

import functools
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from rlhc.envs.soccer.physics import PitchGeometry

#: target codes after the circle slots: ``num_circles + WALL`` etc.
WALL, GOAL_LEFT, GOAL_RIGHT = 0, 1, 2

_WRAPS = np.array([-2 * np.pi, 0.0, 2 * np.pi])  # a circle's arc may straddle ±180°


@dataclass(frozen=True)
class RayFan:
    """``count`` rays evenly spaced over ``degrees``, centred on the agent's facing.

    Attributes:
        count: number of rays (>= 2).
        degrees: the angle between the first and the last ray.
        length: the range of every ray.
    """

    count: int
    degrees: float
    length: float

    def __post_init__(self) -> None:
        if self.count < 2 or not 0 < self.degrees < 360 or self.length <= 0:
            raise ValueError(f"bad ray fan {self}")

    @property
    def first(self) -> float:
        """Direction of the first (rightmost) ray relative to the facing, radians."""
        return -np.deg2rad(self.degrees) / 2

    @property
    def spacing(self) -> float:
        """Angle between neighbouring rays, radians."""
        return float(np.deg2rad(self.degrees) / (self.count - 1))

    @property
    def angles(self) -> np.ndarray:
        """``float64 [count]`` ray directions relative to the facing, right to left.

        Examples:
            >>> RayFan(3, 180.0, 5.0).angles.round(4).tolist()
            [-1.5708, 0.0, 1.5708]
        """
        return self.first + self.spacing * np.arange(self.count)


@dataclass
class RayHits:
    """What each ray met first, ray-major (``[R, N, A]``: the fast layout for the maths).

    Attributes:
        distance: ``float32 [R, N, A]`` distance from the agent's centre to the hit
            (rays are not clipped to a range here: every ray meets the boundary).
        target: ``int8 [R, N, A]``: ``c < C`` for circle slot ``c``, else
            ``C + WALL``, ``C + GOAL_LEFT`` (the mouth at ``-x``) or ``C + GOAL_RIGHT``.
        hit_x: ``float32 [R, N, A]`` pitch-local ``x`` of the hit point.
    """

    distance: np.ndarray
    target: np.ndarray
    hit_x: np.ndarray


@dataclass(frozen=True)
class _FanLayout:
    """Per-fan constants of a set of fans, computed once (tiny arrays, but many of them).

    Rows of the ``[F * 3, 1]`` arrays are (fan, wrap) combinations.
    """

    angles: np.ndarray  # [R] float64
    cos: np.ndarray  # [R] float64
    sin: np.ndarray  # [R] float64
    cos32: np.ndarray  # [R, 1, 1] float32, for ray-major broadcasting
    sin32: np.ndarray  # [R, 1, 1] float32
    first: np.ndarray  # [F * 3, 1]
    spacing: np.ndarray  # [F * 3, 1]
    last_index: np.ndarray  # [F * 3, 1] int64
    ray_offset: np.ndarray  # [F * 3] int64
    wrap: np.ndarray  # [F * 3, 1]


@functools.lru_cache(maxsize=16)
def _fan_layout(fans: tuple[RayFan, ...]) -> _FanLayout:
    angles = np.concatenate([fan.angles for fan in fans])
    wraps = len(_WRAPS)
    return _FanLayout(
        angles=angles,
        cos=np.cos(angles),
        sin=np.sin(angles),
        cos32=np.cos(angles).astype(np.float32)[:, None, None],
        sin32=np.sin(angles).astype(np.float32)[:, None, None],
        first=np.repeat([fan.first for fan in fans], wraps)[:, None],
        spacing=np.repeat([fan.spacing for fan in fans], wraps)[:, None],
        last_index=np.repeat([fan.count - 1 for fan in fans], wraps)[:, None],
        ray_offset=np.repeat(np.cumsum([0] + [fan.count for fan in fans])[:-1], wraps),
        wrap=np.tile(_WRAPS, len(fans))[:, None],
    )


def cast_rays(
    origins: np.ndarray,
    facings: np.ndarray,
    circle_centres: np.ndarray,
    circle_radii: np.ndarray,
    fans: Sequence[RayFan],
    geometry: PitchGeometry,
) -> RayHits:
    """Cast the rays of ``fans`` (concatenated, ``R`` in all) from ``A`` agents in ``N`` pitches.

    Args:
        origins: ``[N, A, 2]`` agent centres, pitch-local; inside the pitch rectangle.
        facings: ``[N, A]`` agent facing angles.
        circle_centres: ``[N, A, C, 2]`` the circles agent ``a`` can see (not itself).
        circle_radii: ``[C]`` their radii.
        fans: the ray fans; ray ``r`` of the result is fan by fan, right to left.
        geometry: the pitch boundary.

    Returns:
        The first hit of every ray, ``[R, N, A]``. A circle that contains the ray's
        origin (an overlapping body) is hit by every ray at distance 0, as in pymunk.

    Examples:
        >>> geometry = PitchGeometry(8.0, 5.0, 1.5, 1.0)
        >>> hits = cast_rays(
        ...     np.zeros((1, 1, 2)), np.zeros((1, 1)), np.array([[[[3.0, 0.0]]]]),
        ...     np.array([0.5]), [RayFan(3, 180.0, 10.0)], geometry,
        ... )
        >>> hits.distance.ravel().round(3).tolist(), hits.target.ravel().tolist()
        ([5.0, 2.5, 5.0], [1, 0, 1])
    """
    f32 = np.float32
    num_worlds, num_agents = facings.shape
    num_circles = circle_centres.shape[2]
    layout = _fan_layout(tuple(fans))

    # Boundary, dense and ray-major ([R, N, A]: numpy broadcasting is slow when the
    # innermost axis is short, and R = 34 is short). Through each pair of parallel walls
    # the exit distance is the larger of the two signed distances (the origin lies
    # between them); a zero direction component gives +inf, as it should.
    origins32 = origins.astype(f32)
    ox, oy = origins32[..., 0], origins32[..., 1]
    cos_f, sin_f = np.cos(facings).astype(f32), np.sin(facings).astype(f32)
    cos_r, sin_r = layout.cos32, layout.sin32
    dx = cos_f * cos_r - sin_f * sin_r
    dy = sin_f * cos_r + cos_f * sin_r
    a, b = f32(geometry.half_length), f32(geometry.half_width)
    with np.errstate(divide="ignore", invalid="ignore"):
        inverse_x, inverse_y = 1 / dx, 1 / dy
    exit_x = np.maximum((a - ox) * inverse_x, (-a - ox) * inverse_x)
    exit_y = np.maximum((b - oy) * inverse_y, (-b - oy) * inverse_y)
    distance = np.minimum(exit_x, exit_y)
    hit_y = distance * dy
    hit_y += oy
    # Bool views as int8 keep the target arithmetic cheap (no casts, no np.where).
    mouth = (np.abs(hit_y) <= f32(geometry.goal_half_width)) & (exit_x < exit_y)
    goal_minus_wall = (dx > 0).view(np.int8) + np.int8(GOAL_LEFT - WALL)
    target = mouth.view(np.int8) * goal_minus_wall
    target += np.int8(num_circles + WALL)

    # Circles, sparse: per (circle, world, agent) pair, in the agent's frame.
    relative = circle_centres - origins[:, :, None, :]  # [N, A, C, 2], float64
    cos_64, sin_64 = np.cos(facings)[..., None], np.sin(facings)[..., None]
    forward = (relative[..., 0] * cos_64 + relative[..., 1] * sin_64).transpose(2, 0, 1).ravel()
    left = (relative[..., 1] * cos_64 - relative[..., 0] * sin_64).transpose(2, 0, 1).ravel()
    radii = np.repeat(np.asarray(circle_radii, dtype=np.float64), num_worlds * num_agents)
    flat, circle_t, slot = _circle_hits(forward, left, radii, layout, num_worlds * num_agents)
    circle_t = circle_t.astype(f32)
    distance = distance.reshape(-1)
    np.minimum.at(distance, flat, circle_t)
    first = circle_t <= distance[flat]
    target = target.reshape(-1)
    target[flat[first]] = slot[first]

    shape = (len(layout.angles), num_worlds, num_agents)
    distance, target = distance.reshape(shape), target.reshape(shape)
    hit_x = distance * dx
    hit_x += ox
    return RayHits(distance=distance, target=target, hit_x=hit_x)


def _circle_hits(
    forward: np.ndarray, left: np.ndarray, radii: np.ndarray, layout: _FanLayout, agents: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Every (ray, circle) intersection, sparse.

    Args:
        forward: ``[C * agents]`` circle centres ahead of each agent, pairs circle-major.
        left: ``[C * agents]`` circle centres to the left of each agent.
        radii: ``[C * agents]`` the circles' radii.
        layout: the fans' constants (rays numbered fan by fan).
        agents: ``N * A``, the number of ray origins.

    Returns:
        ``flat`` (``ray * agents + agent``), the distance ``t`` and the circle slot of
        each intersection.
    """
    pairs = forward.size
    offset = forward * forward + left * left - radii * radii  # |c|^2 - r^2
    # From inside a circle every ray hits it at distance 0 (pymunk's convention): give
    # such a circle the whole turn as its arc.
    # The angles only pick ray indices: float32 is precise enough and much faster.
    covered = np.minimum(radii * radii / np.maximum(offset + radii * radii, 1e-12), 1.0)
    half_arc = np.where(
        offset > 0, np.arcsin(np.sqrt(covered.astype(np.float32))), np.float32(np.pi)
    )
    bearing = np.arctan2(left.astype(np.float32), forward.astype(np.float32))

    # Ranges of ray indices [low, high] per (fan, wrap, pair).
    centre = bearing + (layout.wrap - layout.first)  # [F * 3, pairs]
    low = np.maximum(np.ceil((centre - half_arc) / layout.spacing), 0).astype(np.int64)
    high = np.minimum(np.floor((centre + half_arc) / layout.spacing), layout.last_index).astype(
        np.int64
    )
    hits_per_range = np.maximum(high - low + 1, 0).ravel()

    ranges = np.repeat(np.arange(hits_per_range.size), hits_per_range)
    starts = np.cumsum(hits_per_range) - hits_per_range
    index_in_fan = low.ravel()[ranges] + (np.arange(ranges.size) - starts[ranges])
    pair = ranges % pairs
    ray = layout.ray_offset[ranges // pairs] + index_in_fan
    along = forward[pair] * layout.cos[ray] + left[pair] * layout.sin[ray]
    # Rounding at the edge of an arc can make a grazing ray's discriminant slightly
    # negative: clamp it (the ray touches the circle). From inside, t < 0: clamp to 0.
    t = np.maximum(along - np.sqrt(np.maximum(along * along - offset[pair], 0.0)), 0.0)
    return ray * agents + pair % agents, t, (pair // agents).astype(np.int8)
