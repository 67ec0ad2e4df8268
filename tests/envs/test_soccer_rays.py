"""Soccer perception: the numpy ray cast against pymunk, observation layout, mirror symmetry."""

from __future__ import annotations

import numpy as np
import pymunk
import pytest

from rlhc.envs.soccer import SoccerGame
from rlhc.envs.soccer.observations import (
    MANAGER_FEATURES,
    NUM_TYPES,
    OBJECT_TYPES,
    VISIBLE_BODIES,
    WORKER_FEATURES,
    WORKER_RAYS,
)
from rlhc.envs.soccer.physics import BALL
from rlhc.envs.soccer.rays import GOAL_LEFT, GOAL_RIGHT, WALL

NUM_CIRCLES = VISIBLE_BODIES.shape[1]


def random_scene(game: SoccerGame, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """Players anywhere on the pitch (overlaps allowed), the ball on the pitch or in a net."""
    geometry, radius = game.geometry, game.options.player_radius
    n = game.num_worlds
    positions = np.empty((n, 5, 2))
    positions[:, :4, 0] = rng.uniform(-1, 1, (n, 4)) * (geometry.half_length - radius)
    positions[:, :4, 1] = rng.uniform(-1, 1, (n, 4)) * (geometry.half_width - radius)
    positions[:, BALL, 0] = rng.uniform(-1, 1, n) * (geometry.half_length + geometry.goal_depth / 2)
    positions[:, BALL, 1] = rng.uniform(-1, 1, n) * geometry.goal_half_width
    angles = rng.uniform(-np.pi, np.pi, (n, 5))
    return positions, angles


def pymunk_targets(game: SoccerGame, world: int, agent: int, angles: np.ndarray, length: float):
    """Target codes and distances of ``segment_query_first`` for the rays of one agent."""
    physics = game.physics
    origin = physics.positions[world, agent] + physics.world_offset[world]
    own_shape = next(
        shape for shape, tag in physics.shape_tags.items() if tag == (world, f"player_{agent}")
    )
    skip_self = pymunk.ShapeFilter(group=own_shape.filter.group)
    slot_of_body = {int(body): slot for slot, body in enumerate(VISIBLE_BODIES[agent])}
    codes, distances = [], []
    for angle in physics.angles[world, agent] + angles:
        end = origin + length * np.array([np.cos(angle), np.sin(angle)])
        info = physics.space.segment_query_first(tuple(origin), tuple(end), 0.0, skip_self)
        assert info is not None and info.shape is not own_shape
        hit_world, tag = physics.shape_tags[info.shape]
        assert hit_world == world
        if tag == "ball":
            code = slot_of_body[BALL]
        elif tag.startswith("player_"):
            code = slot_of_body[int(tag.split("_")[1])]
        else:
            code = NUM_CIRCLES + {"wall": WALL, "goal_0": GOAL_LEFT, "goal_1": GOAL_RIGHT}[tag]
        codes.append(code)
        distances.append(info.alpha * length)
    return np.array(codes), np.array(distances)


def grazing(
    game: SoccerGame, world: int, agent: int, angles: np.ndarray, tolerance: float
) -> np.ndarray:
    """Rays passing within ``tolerance`` of a circle's edge or of a goal post / corner.

    There float32 (numpy) and float64 (pymunk) may honestly disagree on what is hit.
    """
    physics, geometry = game.physics, game.geometry
    origin = physics.positions[world, agent]
    directions = physics.angles[world, agent] + angles
    unit = np.stack([np.cos(directions), np.sin(directions)], axis=-1)
    near = np.zeros(len(angles), dtype=bool)
    for slot, body in enumerate(VISIBLE_BODIES[agent]):
        radius = game.options.ball_radius if slot == 0 else game.options.player_radius
        relative = physics.positions[world, body] - origin
        along = unit @ relative
        across = np.abs(unit[:, 0] * relative[1] - unit[:, 1] * relative[0])
        near |= (along > 0) & (np.abs(across - radius) < tolerance)
        near |= abs(np.linalg.norm(relative) - radius) < tolerance  # origin on the edge
    a, b, g = geometry.half_length, geometry.half_width, geometry.goal_half_width
    for corner in [(sx * a, sy * y) for sx in (-1, 1) for sy in (-1, 1) for y in (b, g)]:
        relative = np.array(corner) - origin
        across = np.abs(unit[:, 0] * relative[1] - unit[:, 1] * relative[0])
        near |= ((unit @ relative) > 0) & (across < tolerance)
    return near


def test_numpy_ray_cast_matches_pymunk_segment_query_first() -> None:
    game = SoccerGame(num_worlds=6, seed=0)
    rng = np.random.default_rng(1)
    fans = (game.sensors.worker_fan, game.sensors.manager_fan)
    angles = np.concatenate([fan.angles for fan in fans])
    length = 100.0  # every ray reaches the boundary in pymunk too
    checked = circle_hits = goal_hits = 0
    for _ in range(5):
        game.place(*random_scene(game, rng))
        hits = game.sensors.cast(game.physics.positions, game.physics.angles)
        for world in range(game.num_worlds):
            for agent in range(4):
                codes, distances = pymunk_targets(game, world, agent, angles, length)
                keep = ~grazing(game, world, agent, angles, tolerance=1e-3)
                np.testing.assert_array_equal(hits.target[:, world, agent][keep], codes[keep])
                np.testing.assert_allclose(
                    hits.distance[:, world, agent][keep], distances[keep], rtol=1e-4, atol=1e-4
                )
                checked += keep.sum()
                circle_hits += (codes[keep] < NUM_CIRCLES).sum()
                goal_hits += (codes[keep] > NUM_CIRCLES + WALL).sum()
    # The scenes must exercise every kind of target, not only walls.
    assert checked > 0.95 * 5 * game.num_worlds * 4 * len(angles)
    assert circle_hits > 100 and goal_hits > 20


def test_observation_layout_and_sizes() -> None:
    game = SoccerGame(num_worlds=3, seed=0)
    assert [spec.observation_size for spec in game.groups] == [112, 112]
    assert [spec.manager_observation_size for spec in game.groups] == [200, 200]
    assert NUM_TYPES == 7
    observations = game.observe()
    for spec in game.groups:
        seen = observations[spec.name]
        assert seen.observation.shape == (3, 2, 112) and seen.observation.dtype == np.float32
        assert seen.manager_observation.shape == (3, 2, 200)
        assert seen.observation.flags.c_contiguous and seen.manager_observation.flags.c_contiguous
        worker = seen.observation.reshape(3, 2, WORKER_RAYS, WORKER_FEATURES)
        manager = seen.manager_observation.reshape(3, 2, -1, MANAGER_FEATURES)
        # One type at most per ray; a hit ray has a distance < 1, a missed one exactly 1.
        worker_hit = worker[..., :NUM_TYPES].sum(-1)
        assert set(np.unique(worker_hit)) <= {0.0, 1.0}
        assert np.all(worker[..., -1][worker_hit == 1] < 1.0)
        assert np.all(worker[..., -1][worker_hit == 0] == 1.0)
        manager_hit = manager[..., NUM_TYPES + 1]
        np.testing.assert_array_equal(manager[..., :NUM_TYPES].sum(-1), manager_hit)
        assert np.all(manager[..., NUM_TYPES] <= manager_hit)  # own half only when hit
        # With a 30 m range on a 20 x 10 pitch every manager ray hits something.
        assert np.all(manager_hit == 1)


def test_rays_see_what_the_geometry_says() -> None:
    """Hand-made scene: a ray of striker_0 passes through the ball, goalie_0 sees a wall."""
    game = SoccerGame(num_worlds=1, seed=0)
    # 14 rays over 180°: ray 6 points 6.92° right of the facing; from (-4, 0) it passes
    # through (-2, -0.2427), the ball's centre within 3 mm.
    game.place(
        np.array([[[-4.0, 0.0], [4.0, 3.0], [-6.8, 0.0], [6.8, 0.0], [-2.0, -0.24]]]),
        np.array([[0.0, np.pi, 0.0, np.pi, 0.0]]),
    )
    worker = game.observe()["striker"].observation[0, 0].reshape(WORKER_RAYS, WORKER_FEATURES)
    assert worker[6, OBJECT_TYPES.index("ball")] == 1.0
    # Through the centre (2.0147 m away), so the ball's surface is one radius nearer.
    np.testing.assert_allclose(
        worker[6, -1] * game.options.worker_ray_length,
        np.hypot(2.0, 0.2427) - game.options.ball_radius,
        atol=0.01,
    )
    goalie_view = game.observe()["goalie"].observation[0, 0].reshape(WORKER_RAYS, WORKER_FEATURES)
    assert goalie_view[0, OBJECT_TYPES.index("wall")] == 1.0  # its right: a touch line 5 m away
    np.testing.assert_allclose(goalie_view[0, -1] * game.options.worker_ray_length, 5.0, atol=1e-4)
    # goalie_0's manager: its rearmost rays (±135°) end in its own half, its forward rays
    # (±7°, a clear path) in the mouth of the opponent goal, 6.8 m past the centre spot.
    game.place(
        np.array([[[-4.0, 3.0], [4.0, 3.0], [-6.8, 0.0], [6.8, 4.0], [0.0, -3.0]]]),
        np.array([[0.0, np.pi, 0.0, np.pi, 0.0]]),
    )
    manager = game.observe()["goalie"].manager_observation[0, 0].reshape(-1, MANAGER_FEATURES)
    own_half, hit = manager[:, NUM_TYPES], manager[:, NUM_TYPES + 1]
    assert hit.all() and own_half[0] == own_half[-1] == 1.0 and own_half[9] == own_half[10] == 0.0
    reach = game.geometry.half_length + 6.8
    assert (reach * np.tan(np.deg2rad(135 / 19))) < game.geometry.goal_half_width
    assert manager[9, OBJECT_TYPES.index("opponent_goal")] == 1.0
    np.testing.assert_allclose(
        manager[9, -1] * game.options.manager_ray_length,
        reach / np.cos(np.deg2rad(135 / 19)),
        atol=1e-3,
    )


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_mirror_symmetry_between_teams(seed: int) -> None:
    """Rotating the scene by 180° and swapping the teams swaps the teams' observations."""
    game = SoccerGame(num_worlds=16, seed=seed)
    positions, angles = random_scene(game, np.random.default_rng(seed))
    game.place(positions, angles)
    before = {
        name: (o.observation.copy(), o.manager_observation.copy())
        for name, o in game.observe().items()
    }
    swap = [1, 0, 3, 2, BALL]  # striker_0 <-> striker_1, goalie_0 <-> goalie_1
    game.place(-positions[:, swap], angles[:, swap] + np.pi)
    after = game.observe()
    for name, (worker, manager) in before.items():
        np.testing.assert_allclose(after[name].observation[:, ::-1], worker, atol=2e-4)
        np.testing.assert_allclose(after[name].manager_observation[:, ::-1], manager, atol=2e-4)
