"""A picture of one tennis court (side view), drawn with :mod:`rlhc.envs.render`.

The picture needs the court, the bodies and the step counters, not the game: this
module reads a :class:`CourtView` (which :class:`~rlhc.envs.tennis.game.TennisGame`
is) and does not import the game module, which imports this one.
"""

from __future__ import annotations

from typing import Protocol

import numpy as np

from rlhc.envs.render import Canvas
from rlhc.envs.tennis.physics import CourtGeometry, TennisPhysics

_TEAM_COLOURS = ((40, 90, 200), (200, 60, 40))
_COURT = (90, 160, 90)
_OUT = (170, 200, 170)


class CourtView(Protocol):
    """What :func:`render_court` reads of a tennis game."""

    @property
    def geometry(self) -> CourtGeometry:
        """The court's sizes."""

    @property
    def physics(self) -> TennisPhysics:
        """The ball and rackets of every court."""

    @property
    def step_count(self) -> np.ndarray:
        """``int64 [N]`` decisions of each court's episode."""


def render_court(game: CourtView, world: int = 0, pixels_per_metre: float = 40.0) -> np.ndarray:
    """An RGB frame ``uint8 [H, W, 3]`` of court ``world``.

    Args:
        game: the tennis game (a :class:`CourtView`).
        world: which court.
        pixels_per_metre: image scale (40 gives 640 × 240 pixels).

    Returns:
        The frame: court in green, out area paler, net, ball, paddles in team colours.
    """
    g = game.geometry
    p = game.physics
    canvas = Canvas((-g.wall_x, g.wall_x), (-0.3, 5.7), pixels_per_metre, (235, 240, 250))
    canvas.rectangle((-g.wall_x, -0.3), (g.wall_x, 0.0), _OUT)
    canvas.rectangle((-g.half_length, -0.3), (g.half_length, 0.0), _COURT)
    canvas.segment((0.0, 0.0), (0.0, g.net_height), (60, 60, 60), 2 * g.net_radius)
    for racket in range(4):
        x, y = p.racket_position[world, racket]
        angle = p.racket_angle[world, racket]
        half = g.racket_half_length * np.array([np.cos(angle), np.sin(angle)])
        canvas.segment(
            (x - half[0], y - half[1]),
            (x + half[0], y + half[1]),
            _TEAM_COLOURS[racket // 2],
            2 * g.racket_radius,
        )
    canvas.circle(p.ball_position[world], g.ball_radius, (230, 200, 20))
    canvas.text(f"step {int(game.step_count[world])}")
    return canvas.to_array()
