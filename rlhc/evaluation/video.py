"""A match rendered to a GIF (Pillow) or an MP4 (imageio + ffmpeg), with a score overlay.

Frames come from the game's own ``render(world)``, with a strip below each: who plays
which side, the score and the step. The match is played by
:func:`~rlhc.evaluation.matches.play_matches`, so a video shows what an evaluation plays.
"""

from __future__ import annotations

import os
import re
from pathlib import Path
from typing import Any

import numpy as np
from PIL import Image, ImageDraw
from tensordict import TensorDictBase

from rlhc.evaluation.matches import (
    MatchResult,
    MatchRules,
    default_rules,
    make_match_env,
    play_matches,
)
from rlhc.evaluation.opponents import make_team_policy

FORMATS = (".gif", ".mp4")
STRIP_HEIGHT = 16
#: Team colours of the strip (the games draw team 0 blue-ish and team 1 red-ish).
TEAM_COLOURS = ((40, 90, 200), (200, 60, 40))


def overlay(frame: np.ndarray, left: str, right: str, step: int) -> np.ndarray:
    """``frame`` with a strip below it: ``left`` (team 0), ``right`` (team 1) and the step.

    Examples:
        >>> overlay(np.zeros((10, 200, 3), np.uint8), "a 1", "b 0", 7).shape
        (26, 200, 3)
    """
    height, width, _ = frame.shape
    image = Image.new("RGB", (width, height + STRIP_HEIGHT), (250, 250, 250))
    image.paste(Image.fromarray(frame), (0, 0))
    draw = ImageDraw.Draw(image)
    y = height + 2
    draw.text((4, y), left, fill=TEAM_COLOURS[0])
    step_text = f"step {step}"
    draw.text((width // 2 - 3 * len(step_text), y), step_text, fill=(60, 60, 60))
    draw.text((width - 4 - 6 * len(right), y), right, fill=TEAM_COLOURS[1])
    return np.asarray(image, dtype=np.uint8).copy()


def write_video(frames: list[np.ndarray], path: str | os.PathLike[str], fps: int) -> Path:
    """Write ``frames`` (``uint8 [H, W, 3]``) as a GIF or MP4 chosen by the suffix
    (:class:`ValueError` for another suffix, or no frames)."""
    target = Path(path)
    suffix = target.suffix.lower()
    if suffix not in FORMATS:
        raise ValueError(f"video {str(target)!r}: choose a suffix among {', '.join(FORMATS)}")
    if not frames:
        raise ValueError("no frames to write")
    target.parent.mkdir(parents=True, exist_ok=True)
    if suffix == ".gif":
        images = [Image.fromarray(frame) for frame in frames]
        # GIF delays are in centiseconds: round the per-frame duration to 10 ms.
        duration = max(20, round(1000 / fps / 10) * 10)
        images[0].save(target, save_all=True, append_images=images[1:], duration=duration, loop=0)
    else:
        import imageio.v2 as imageio

        # H.264 in yuv420p needs even sides: pad by one pixel when needed.
        height, width = frames[0].shape[:2]
        pad = ((0, height % 2), (0, width % 2), (0, 0))
        with imageio.get_writer(target, fps=fps, codec="libx264", macro_block_size=1) as writer:
            for frame in frames:
                writer.append_data(np.pad(frame, pad, mode="edge"))  # type: ignore[attr-defined]
    return target


def record_match(
    env_name: str,
    home: str,
    away: str,
    path: str | os.PathLike[str],
    *,
    home_side: int = 0,
    points_to_win: int | None = None,
    max_frames: int = 1500,
    fps: int | None = None,
    seed: int = 0,
    deterministic: bool = True,
    env_options: dict[str, Any] | None = None,
) -> tuple[Path, MatchResult, int]:
    """Play one match and write its video, of at most ``max_frames`` frames (the match is
    cut after ``max_frames - 1`` steps, a draw if still undecided).

    Args:
        env_name: a registered game, e.g. ``"tennis"``.
        home: a player spec (``random``, ``scripted`` or a checkpoint path); ``away`` likewise.
        path: the ``.gif`` or ``.mp4`` file to write.
        home_side: the team (0 or 1) the home player plays.
        points_to_win: match rule override (:func:`~rlhc.evaluation.matches.default_rules`).
        fps: frames per second (``None``: the game's ``render_fps``).
        deterministic: mode actions rather than samples.
        env_options: game options (e.g. ``max_cycles``).

    Returns:
        The file written, the match record and the number of frames.

    Examples:
        >>> import tempfile
        >>> out = Path(tempfile.mkdtemp()) / "match.gif"
        >>> written, result, frames = record_match("soccer", "scripted", "random", out, max_frames=4)
        >>> written == out, frames
        (True, 4)
    """
    if home_side not in (0, 1):
        raise ValueError(f"home_side must be 0 or 1, got {home_side}")
    if max_frames < 2:
        raise ValueError(f"max_frames must be >= 2, got {max_frames}")
    env = make_match_env(env_name, 1, seed, [home, away], env_options)
    game = env.game
    labels = [_label(away if team != home_side else home) for team in (0, 1)]
    full = default_rules(env_name, game.max_cycles, points_to_win)
    rules = MatchRules(full.points_to_win, min(max_frames - 1, full.max_steps))
    frames: list[np.ndarray] = []

    def capture(_: TensorDictBase, points: np.ndarray, steps: np.ndarray) -> None:
        left, right = int(points[0, 0]), int(points[0, 1])
        frame = game.render(0)
        frames.append(overlay(frame, f"{labels[0]} {left}", f"{right} {labels[1]}", int(steps[0])))

    result = play_matches(
        env,
        make_team_policy(home, env),
        make_team_policy(away, env),
        1,
        rules,
        deterministic=deterministic,
        swap_sides=False,
        first_side=home_side,
        names=(home, away),
        on_step=capture,
    )
    rate = fps if fps is not None else int(game.metadata.get("render_fps", 30))  # type: ignore[call-overload]
    return write_video(frames, path, rate), result, len(frames)


def file_label(spec: str) -> str:
    """:func:`_label` made safe for a file name (runs of other characters become ``-``).

    Examples:
        >>> file_label("outputs/soccer/ppo/2025-01-01_00-00-00/checkpoints/step_000000512.pt")
        '2025-01-01_00-00-00-step_000000512'
        >>> file_label("scripted")
        'scripted'
    """
    return re.sub(r"[^A-Za-z0-9._=+-]+", "-", _label(spec)).strip("-") or "player"


def _label(spec: str) -> str:
    """A short name for the strip: a built-in's name, else the run or file name."""
    path = Path(spec)
    if path.suffix != ".pt":
        return path.name
    return (
        f"{path.parent.parent.name}/{path.stem}" if path.parent.name == "checkpoints" else path.stem
    )
