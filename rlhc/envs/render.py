"""Small drawing helpers shared by the games' ``render`` (Pillow, no screen needed).

A :class:`Canvas` maps a rectangle of the world (metres, ``y`` up) onto an image
(pixels, ``y`` down) and draws circles, segments, rectangles and a text overlay
in world units; :meth:`Canvas.to_array` returns the ``uint8 [H, W, 3]`` frame that
``render_mode="rgb_array"`` expects.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from PIL import Image, ImageDraw

Color = tuple[int, int, int]


class Canvas:
    """An RGB image showing the world rectangle ``[x_min, x_max] × [y_min, y_max]``.

    Args:
        x_range: ``(x_min, x_max)`` in metres.
        y_range: ``(y_min, y_max)`` in metres.
        pixels_per_metre: the scale (the same on both axes).
        background: the fill colour.

    Examples:
        >>> canvas = Canvas((-1.0, 1.0), (0.0, 1.0), pixels_per_metre=10)
        >>> canvas.circle((0.0, 0.5), 0.2, (255, 0, 0))
        >>> canvas.to_array().shape
        (10, 20, 3)
    """

    def __init__(
        self,
        x_range: tuple[float, float],
        y_range: tuple[float, float],
        pixels_per_metre: float = 40.0,
        background: Color = (255, 255, 255),
    ) -> None:
        self.x_min, x_max = x_range
        y_min, self.y_max = y_range
        self.scale = float(pixels_per_metre)
        self.width = round((x_max - self.x_min) * self.scale)
        self.height = round((self.y_max - y_min) * self.scale)
        self.image = Image.new("RGB", (self.width, self.height), background)
        self.draw = ImageDraw.Draw(self.image)

    def to_pixels(self, point: Sequence[float]) -> tuple[float, float]:
        """Pixel coordinates of the world point ``(x, y)``."""
        return (
            (float(point[0]) - self.x_min) * self.scale,
            (self.y_max - float(point[1])) * self.scale,
        )

    def circle(self, centre: Sequence[float], radius: float, fill: Color) -> None:
        """A filled disc of ``radius`` metres."""
        x, y = self.to_pixels(centre)
        r = max(radius * self.scale, 1.0)
        self.draw.ellipse((x - r, y - r, x + r, y + r), fill=fill)

    def segment(
        self, start: Sequence[float], end: Sequence[float], fill: Color, width: float = 0.05
    ) -> None:
        """A line from ``start`` to ``end``, ``width`` metres thick."""
        self.draw.line(
            (self.to_pixels(start), self.to_pixels(end)),
            fill=fill,
            width=max(round(width * self.scale), 1),
        )

    def rectangle(self, corner: Sequence[float], opposite: Sequence[float], fill: Color) -> None:
        """A filled axis-aligned rectangle between two opposite corners."""
        (x0, y0), (x1, y1) = self.to_pixels(corner), self.to_pixels(opposite)
        self.draw.rectangle((min(x0, x1), min(y0, y1), max(x0, x1), max(y0, y1)), fill=fill)

    def text(self, line: str, fill: Color = (0, 0, 0), position: tuple[int, int] = (4, 4)) -> None:
        """A text overlay (e.g. score and step) at a pixel position."""
        self.draw.text(position, line, fill=fill)

    def to_array(self) -> np.ndarray:
        """The frame, ``uint8 [H, W, 3]``."""
        return np.asarray(self.image, dtype=np.uint8).copy()
