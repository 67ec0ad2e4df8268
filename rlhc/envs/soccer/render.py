"""A top-down picture of one pitch, drawn with the shared Pillow :class:`Canvas`.

The picture needs the pitch, the bodies, the sensors and the step counters, not the
game: this module reads a :class:`PitchView` (which
:class:`~rlhc.envs.soccer.game.SoccerGame` is) and does not import the game module,
which imports this one.
"""

from __future__ import annotations

import itertools
from typing import Protocol

import numpy as np

from rlhc.envs.render import Canvas, Color
from rlhc.envs.soccer.observations import RaySensors
from rlhc.envs.soccer.options import SoccerOptions
from rlhc.envs.soccer.physics import (
    BALL,
    NUM_PLAYERS,
    PLAYER_IS_STRIKER,
    PLAYER_TEAM,
    PitchGeometry,
    SoccerPhysics,
)

GRASS: Color = (46, 139, 60)
LINES: Color = (235, 245, 235)
WALL: Color = (90, 90, 90)
NET: Color = (200, 200, 200)
TEAM_COLORS: tuple[Color, Color] = ((40, 90, 220), (220, 50, 50))
GOALIE_TRIM: Color = (250, 220, 40)
BALL_COLOR: Color = (255, 255, 255)
RAY_COLOR: Color = (255, 255, 160)

_MARGIN = 0.6  # metres of wall shown around the pitch


class PitchView(Protocol):
    """What :func:`render_pitch` reads of a soccer game."""

    @property
    def geometry(self) -> PitchGeometry:
        """The pitch's sizes."""

    @property
    def physics(self) -> SoccerPhysics:
        """The bodies of every pitch."""

    @property
    def options(self) -> SoccerOptions:
        """The game options (radii)."""

    @property
    def sensors(self) -> RaySensors:
        """The players' ray sensors (for ``rays=True``)."""

    @property
    def step_count(self) -> np.ndarray:
        """``int64 [N]`` decisions of each pitch's episode."""


def render_pitch(
    game: PitchView, world: int, rays: bool = False, pixels_per_metre: float = 32.0
) -> np.ndarray:
    """Draw pitch ``world`` of ``game``.

    Args:
        game: the game (a :class:`PitchView`).
        world: which pitch.
        rays: overlay each player's worker rays, cut at their first hit.
        pixels_per_metre: the scale.

    Returns:
        ``uint8 [H, W, 3]``; goalies wear a yellow ring, facing is a white tick.
    """
    geometry = game.geometry
    a, b, g, d = (
        geometry.half_length,
        geometry.half_width,
        geometry.goal_half_width,
        geometry.goal_depth,
    )
    x_extent, y_extent = a + d + _MARGIN, b + _MARGIN
    canvas = Canvas((-x_extent, x_extent), (-y_extent, y_extent), pixels_per_metre, background=WALL)
    canvas.rectangle((-a, -b), (a, b), GRASS)
    for sign in (-1.0, 1.0):
        canvas.rectangle((sign * a, -g), (sign * (a + d), g), NET)
        canvas.segment((sign * a, -g), (sign * a, g), TEAM_COLORS[0 if sign < 0 else 1], width=0.1)
    canvas.segment((0.0, -b), (0.0, b), LINES)
    ring = np.linspace(0, 2 * np.pi, 41)
    circle = np.stack([1.5 * np.cos(ring), 1.5 * np.sin(ring)], axis=-1)
    for start, end in itertools.pairwise(circle):
        canvas.segment(start, end, LINES)

    positions = game.physics.positions[world]
    angles = game.physics.angles[world]
    radius = game.options.player_radius
    if rays:
        hits = game.sensors.cast(positions[None], angles[None])
        fan = game.sensors.worker_fan
        for player in range(NUM_PLAYERS):
            for k, angle in enumerate(fan.angles):
                length = min(float(hits.distance[k, 0, player]), fan.length)
                direction = angles[player] + angle
                end = positions[player] + length * np.array([np.cos(direction), np.sin(direction)])
                canvas.segment(positions[player], end, RAY_COLOR, width=0.02)
    for player in range(NUM_PLAYERS):
        centre = positions[player]
        if not PLAYER_IS_STRIKER[player]:
            canvas.circle(centre, radius + 0.08, GOALIE_TRIM)
        canvas.circle(centre, radius, TEAM_COLORS[PLAYER_TEAM[player]])
        tip = centre + radius * np.array([np.cos(angles[player]), np.sin(angles[player])])
        canvas.segment(centre, tip, BALL_COLOR, width=0.08)
    canvas.circle(positions[BALL], game.options.ball_radius, BALL_COLOR)
    canvas.text(f"step {int(game.step_count[world])}", fill=LINES)
    return canvas.to_array()
