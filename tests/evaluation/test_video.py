"""Videos: one frame per step plus the kick-off, with the score strip below the game."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from rlhc.evaluation.video import STRIP_HEIGHT, overlay, record_match, write_video


def test_gif_of_a_short_match_has_expected_frames(tmp_path: Path) -> None:
    path, result, frames = record_match(
        "soccer", "scripted", "random", tmp_path / "match.gif", max_frames=20
    )
    # 19 steps at most (the cut), plus the frame after the reset.
    assert frames == 1 + int(result.steps[0]) <= 20
    with Image.open(path) as gif:
        assert gif.n_frames == frames
        assert gif.size[1] > STRIP_HEIGHT


def test_mp4_is_written(tmp_path: Path) -> None:
    pytest.importorskip("imageio_ffmpeg")
    import imageio.v3 as iio

    path, _, frames = record_match(
        "tennis", "scripted", "random", tmp_path / "rally.mp4", max_frames=12, home_side=1
    )
    assert iio.imread(path).shape[0] == frames == 12


def test_overlay_and_bad_suffix(tmp_path: Path) -> None:
    frame = np.full((30, 120, 3), 200, np.uint8)
    out = overlay(frame, "a 1", "0 b", 5)
    assert out.shape == (30 + STRIP_HEIGHT, 120, 3)
    np.testing.assert_array_equal(out[:30], frame)
    with pytest.raises(ValueError, match="suffix"):
        write_video([frame], tmp_path / "match.avi", fps=10)
