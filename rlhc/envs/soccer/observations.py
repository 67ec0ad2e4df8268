"""From ray hits to the worker and manager observation vectors.

Every agent casts 34 rays in one batch (14 worker rays, then 20 manager rays); this
module labels what each ray met *from the agent's point of view* and lays the labels
out as the paper's vectors:

============ ====== ========= ====== =========================================================
observation  rays   fan       range  per ray
============ ====== ========= ====== =========================================================
worker       14     180°      13.4 m 7 types one-hot, normalised distance (8) → 112
manager      20     270°      30 m   7 types one-hot, own half, hit flag, distance (10) → 200
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

import functools
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

WORKER_RAYS, MANAGER_RAYS = 14, 20
WORKER_FEATURES = NUM_TYPES + 1  # one-hot + distance
MANAGER_FEATURES = NUM_TYPES + 3  # one-hot + own half + hit + distance
WORKER_SIZE = WORKER_RAYS * WORKER_FEATURES  # 112, paper Table 2
MANAGER_SIZE = MANAGER_RAYS * MANAGER_FEATURES  # 200, paper Table 2

#: the circles each player can see, as body indices, in slot order
#: (ball, teammate, opponent striker, opponent goalie).
VISIBLE_BODIES = np.array([[BALL, 2, 1, 3], [BALL, 3, 0, 2], [BALL, 0, 1, 3], [BALL, 1, 0, 2]])
_CIRCLE_TYPES = [0, 4, 5, 6]
_NUM_TARGETS = len(_CIRCLE_TYPES) + 3  # circle slots, then wall, left mouth, right mouth

# type_of_target[player, target]: what a ray target is to that player. Team 0 defends
# the left goal (x < 0).
_TYPE_OF_TARGET = np.array(
    [[*_CIRCLE_TYPES, 3, 1, 2] if team == 0 else [*_CIRCLE_TYPES, 3, 2, 1] for team in PLAYER_TEAM],
    dtype=np.int64,
)
assert (
    _TYPE_OF_TARGET.shape[1]
    == _NUM_TARGETS
    == len(_CIRCLE_TYPES) + 1 + max(WALL, GOAL_LEFT, GOAL_RIGHT)
)
_PLAYER_ROW = (np.arange(4) * _NUM_TARGETS).astype(np.int16)
_TEAM_SIGN = np.where(PLAYER_TEAM == 0, 1.0, -1.0).astype(np.float32)  # x * sign < 0: own half


def _feature_tables() -> tuple[np.ndarray, np.ndarray]:
    """Every ray's features but its distance, looked up in one gather.

    Worker row ``(player * T + target) * 2 + hit`` holds the one-hot type (zeros when
    nothing is hit) and a 0 where the distance goes; manager row ``row_w * 2 + own_half``
    holds one-hot type, own half, hit flag, 0.
    """
    worker = np.zeros((4, _NUM_TARGETS, 2, WORKER_FEATURES), dtype=np.float32)
    manager = np.zeros((4, _NUM_TARGETS, 2, 2, MANAGER_FEATURES), dtype=np.float32)
    for player in range(4):
        for target in range(_NUM_TARGETS):
            kind = _TYPE_OF_TARGET[player, target]
            worker[player, target, 1, kind] = 1.0
            manager[player, target, 1, :, kind] = 1.0
            manager[player, target, 1, 1, NUM_TYPES] = 1.0  # own half (only when hit)
            manager[player, target, 1, :, NUM_TYPES + 1] = 1.0  # hit flag
    return worker.reshape(-1, WORKER_FEATURES), manager.reshape(-1, MANAGER_FEATURES)


_WORKER_TABLE, _MANAGER_TABLE = _feature_tables()


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

    @functools.cached_property
    def worker_fan(self) -> RayFan:
        return RayFan(WORKER_RAYS, 180.0, self.worker_ray_length)

    @functools.cached_property
    def manager_fan(self) -> RayFan:
        return RayFan(MANAGER_RAYS, 270.0, self.manager_ray_length)

    @functools.cached_property
    def _ray_lengths(self) -> np.ndarray:
        """``float32 [34, 1, 1]``: the range of every ray, worker rays first."""
        lengths = [self.worker_ray_length] * WORKER_RAYS + [self.manager_ray_length] * MANAGER_RAYS
        return np.array(lengths, dtype=np.float32)[:, None, None]

    @functools.cached_property
    def _circle_radii(self) -> np.ndarray:
        """``float32 [4]``: radii of the circle slots (ball, then three players)."""
        radii = np.full(VISIBLE_BODIES.shape[1], self.player_radius, dtype=np.float32)
        radii[0] = self.ball_radius
        return radii

    def cast(self, positions: np.ndarray, angles: np.ndarray) -> RayHits:
        """All 34 rays of the 4 players (worker rays first), ``[34, N, 4]`` ray-major.

        Args:
            positions: ``[N, 5, 2]`` body positions (players, then the ball).
            angles: ``[N, 5]`` body angles.
        """
        return cast_rays(
            origins=positions[:, :4],
            facings=angles[:, :4],
            circle_centres=positions[:, VISIBLE_BODIES],
            circle_radii=self._circle_radii,
            fans=(self.worker_fan, self.manager_fan),
            geometry=self.geometry,
        )

    def observe(self, positions: np.ndarray, angles: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Worker and manager observations of the 4 players, role-major.

        Args:
            positions: ``[N, 5, 2]`` body positions (players, then the ball).
            angles: ``[N, 5]`` body angles.

        Returns:
            ``float32 [2, N, 2, 112]`` worker and ``float32 [2, N, 2, 200]`` manager
            observations, indexed ``[role (striker, goalie), world, team]``: each
            group's block is contiguous, ready for the TensorDict without a copy.
        """
        hits = self.cast(positions, angles)
        num_worlds = positions.shape[0]
        lengths = self._ray_lengths
        hit = hits.distance <= lengths  # [R, N, 4]
        rows = hits.target.astype(np.int16)
        rows += _PLAYER_ROW
        rows *= 2
        rows += hit.view(np.int8)
        # Unity's convention: a ray that meets nothing reports distance 1.
        distance = np.minimum(hits.distance / lengths, np.float32(1.0))
        in_own_half = hits.hit_x[WORKER_RAYS:] * _TEAM_SIGN < 0
        manager_rows = rows[WORKER_RAYS:] * 2
        manager_rows += in_own_half.view(np.int8)
        worker = _gather(_WORKER_TABLE, rows[:WORKER_RAYS], distance[:WORKER_RAYS])
        manager = _gather(_MANAGER_TABLE, manager_rows, distance[WORKER_RAYS:])
        return worker.reshape(2, num_worlds, 2, WORKER_SIZE), manager.reshape(
            2, num_worlds, 2, MANAGER_SIZE
        )


def _role_major(ray_major: np.ndarray) -> np.ndarray:
    """``[R, N, 4] -> [2 roles, N, 2 teams, R]`` (a view; players are role * 2 + team)."""
    rays, num_worlds = ray_major.shape[:2]
    return ray_major.reshape(rays, num_worlds, 2, 2).transpose(2, 1, 3, 0)


def _gather(table: np.ndarray, rows: np.ndarray, distance: np.ndarray) -> np.ndarray:
    """``[2, N, 2, R, F]``: the table rows of every ray, distance in the last column."""
    out = np.take(table, _role_major(rows), axis=0)
    out[..., -1] = _role_major(distance)
    return out
