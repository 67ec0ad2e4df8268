"""From ray hits to the worker and manager observation vectors.

Every agent casts 34 rays in one batch (14 worker rays, then 20 manager rays); this
module labels what each ray met *from the agent's point of view* and lays the labels
out as the paper's vectors:

============ ====== ========= ====== =========================================================
observation  rays   fan       range  per ray
============ ====== ========= ====== =========================================================
worker       14     180°      10 m   7 types one-hot, normalised distance (8) → 112
manager      20     270°      24 m   7 types one-hot, own half, hit flag, distance (10) → 200
============ ====== ========= ====== =========================================================

The 7 types: ball, own goal, opponent goal, wall, teammate, opponent striker,
opponent goalie. The manager's 8th type is *own half*: 1 when the hit point lies in
the agent's own half of the pitch, which, with the wider fan and longer range, gives
the team manager a broader view of where the play is. A ray that meets nothing within
range has all flags 0 and distance 1 (Unity's ray-sensor convention).

Everything is relative to the agent (its position, its facing, its team), so both teams
see the same geometry: team 1's view of a scene equals team 0's view of the scene
rotated by 180° about the centre spot, with the teams swapped (a test checks it).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rlhc.envs.soccer.physics import BALL, PLAYER_TEAM, PitchGeometry
from rlhc.envs.soccer.rays import GOAL_LEFT, GOAL_RIGHT, WALL, RayFan, RayHits, cast_rays

#: the object types, in one-hot order.
OBJECT_TYPES: tuple[str, ...] = (
    "ball",
    "own_goal",
    "opponent_goal",
    "wall",
    "teammate",
    "opponent_striker",
    "opponent_goalie",
)
NUM_TYPES = len(OBJECT_TYPES)
_NOTHING = NUM_TYPES  # label of a ray that met nothing within range

WORKER_RAYS, MANAGER_RAYS = 14, 20
WORKER_FEATURES = NUM_TYPES + 1  # one-hot + distance
MANAGER_FEATURES = NUM_TYPES + 3  # one-hot + own half + hit + distance
WORKER_SIZE = WORKER_RAYS * WORKER_FEATURES  # 112, paper Table 2
MANAGER_SIZE = MANAGER_RAYS * MANAGER_FEATURES  # 200, paper Table 2

#: the circles each player can see, as body indices, in slot order
#: (ball, teammate, opponent striker, opponent goalie).
VISIBLE_BODIES = np.array([[BALL, 2, 1, 3], [BALL, 3, 0, 2], [BALL, 0, 1, 3], [BALL, 1, 0, 2]])
_CIRCLE_TYPES = [0, 4, 5, 6]

# type_of_target[player, target]: what a ray target (circle slot, wall, left mouth,
# right mouth) is to that player. Team 0 defends the left goal (x < 0).
_TYPE_OF_TARGET = np.array(
    [[*_CIRCLE_TYPES, 3, 1, 2] if team == 0 else [*_CIRCLE_TYPES, 3, 2, 1] for team in PLAYER_TEAM],
    dtype=np.int64,
)
assert _TYPE_OF_TARGET.shape[1] == len(_CIRCLE_TYPES) + 1 + max(WALL, GOAL_LEFT, GOAL_RIGHT)

# Row t is the one-hot of type t; the last row (nothing hit) is all zeros.
_ONE_HOT = np.vstack([np.eye(NUM_TYPES), np.zeros((1, NUM_TYPES))]).astype(np.float32)
# +1 for team 0, -1 for team 1: ``x * sign < 0`` is the player's own half.
_TEAM_SIGN = np.where(PLAYER_TEAM == 0, 1.0, -1.0).astype(np.float32)


@dataclass(frozen=True)
class RaySensors:
    """The worker and manager ray fans of every player, cast together.

    Args:
        geometry: the pitch.
        ball_radius: radius of the ball.
        player_radius: radius of the players.
        worker_ray_length: range of the worker rays.
        manager_ray_length: range of the manager rays.
    """

    geometry: PitchGeometry
    ball_radius: float
    player_radius: float
    worker_ray_length: float
    manager_ray_length: float

    @property
    def worker_fan(self) -> RayFan:
        return RayFan.spread(WORKER_RAYS, 180.0, self.worker_ray_length)

    @property
    def manager_fan(self) -> RayFan:
        return RayFan.spread(MANAGER_RAYS, 270.0, self.manager_ray_length)

    def cast(self, positions: np.ndarray, angles: np.ndarray) -> RayHits:
        """All 34 rays of the 4 players, ``RayHits`` of shape ``[N, 4, 34]``.

        Args:
            positions: ``[N, 5, 2]`` body positions (players, then the ball).
            angles: ``[N, 5]`` body angles.
        """
        radii = np.full(VISIBLE_BODIES.shape[1], self.player_radius, dtype=np.float32)
        radii[0] = self.ball_radius
        return cast_rays(
            origins=positions[:, :4],
            facings=angles[:, :4],
            circle_centres=positions[:, VISIBLE_BODIES],
            circle_radii=radii,
            ray_angles=np.concatenate([self.worker_fan.angles, self.manager_fan.angles]),
            geometry=self.geometry,
        )

    def observe(self, positions: np.ndarray, angles: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Worker and manager observations of the 4 players.

        Args:
            positions: ``[N, 5, 2]`` body positions (players, then the ball).
            angles: ``[N, 5]`` body angles.

        Returns:
            ``float32 [N, 4, 112]`` worker and ``float32 [N, 4, 200]`` manager
            observations, players in body order.
        """
        hits = self.cast(positions, angles)
        num_worlds = positions.shape[0]
        types = _TYPE_OF_TARGET[np.arange(4)[:, None], hits.target]  # [N, 4, 34]
        worker = _encode(hits, types, slice(0, WORKER_RAYS), self.worker_ray_length, manager=False)
        manager = _encode(
            hits, types, slice(WORKER_RAYS, None), self.manager_ray_length, manager=True
        )
        in_own_half = hits.hit_x[..., WORKER_RAYS:] * _TEAM_SIGN[:, None] < 0
        manager[..., NUM_TYPES] = manager[..., NUM_TYPES + 1] * in_own_half  # hit flag x own half
        return worker.reshape(num_worlds, 4, WORKER_SIZE), manager.reshape(
            num_worlds, 4, MANAGER_SIZE
        )


def _encode(
    hits: RayHits, types: np.ndarray, rays: slice, length: float, manager: bool
) -> np.ndarray:
    """``[N, 4, R, F]``: one-hot types, (manager: own-half slot left 0, hit flag,) distance.

    Worker rays get ``F = 8`` (the paper's 7 types + distance); manager rays ``F = 10``.
    """
    distance = hits.distance[..., rays]
    hit = distance <= np.float32(length)
    label = np.where(hit, types[..., rays], _NOTHING)
    features = MANAGER_FEATURES if manager else WORKER_FEATURES
    out = np.zeros((*distance.shape, features), dtype=np.float32)
    out[..., :NUM_TYPES] = _ONE_HOT[label]
    if manager:
        out[..., NUM_TYPES + 1] = hit
    out[..., -1] = np.where(hit, distance / np.float32(length), np.float32(1.0))
    return out
