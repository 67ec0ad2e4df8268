"""Hydra schema of ``python -m rlhc.evaluate`` (values live in ``conf/evaluate.yaml``)."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from hydra.core.config_store import ConfigStore
from omegaconf import MISSING

from rlhc.config.train_schema import register_configs
from rlhc.envs.keys import RANDOM, SCRIPTED

MODES = ("match", "elo", "showcase")


@dataclass
class VideoConfig:
    """Optional match videos (home on team 0): one per series or Elo pairing.

    Attributes:
        enabled: record them.
        format: ``gif`` (Pillow) or ``mp4`` (imageio + ffmpeg).
        max_frames: the match is cut after ``max_frames - 1`` steps.
        fps: frames per second (``None``: the game's ``render_fps``).
    """

    enabled: bool = False
    format: str = "gif"
    max_frames: int = 1500
    fps: int | None = None


@dataclass
class EvaluateConfig:
    """Head-to-head matches (``mode=match``), an Elo round robin (``mode=elo``) or a
    trained team's showcase (``mode=showcase``: :mod:`rlhc.analysis.showcase`).

    A *player* is ``random``, ``scripted``, a checkpoint file or a run directory (its
    ``checkpoints/latest.pt``).

    Attributes:
        mode: ``match``: ``home`` against ``away``; ``elo``: every pair of ``players``;
            ``showcase``: ``home`` against itself, the scripted and the random team, one
            point of it on video (whatever ``video.enabled``) and its run's curves.
        env: the game (group ``env``, as in ``rlhc.run``); ``env.num_envs`` worlds play at
            once (``None``: up to 32). A checkpoint's observation options override these.
        home: the home player (``mode=match``), the team shown (``mode=showcase``).
        away: the away player (``mode=match``).
        players: the players of the round robin (``mode=elo``).
        matches: matches per series (per pairing in ``mode=elo``, per opponent in
            ``mode=showcase``).
        deterministic: the policies' mode action; ``false``: sampled actions.
        swap_sides: alternate the home player's team between matches.
        points_to_win: first to this many points wins (``None``: the game's, tennis 5, soccer 1).
        max_match_steps: a match still undecided after this many steps is a draw
            (``None``: ``max_cycles × points_to_win``).
        k_factor: Elo K-factor.
        initial_rating: every player's Elo before the first match.
        video: record one match of the series (in ``mode=elo``, of each pairing).
        seed: seeds torch (random players, sampled actions) and the game.
        threads: torch intra-op threads.
    """

    mode: str = "match"
    env: Any = MISSING
    home: str = SCRIPTED
    away: str = RANDOM
    players: list[str] = field(default_factory=list)
    matches: int = 100
    deterministic: bool = True
    swap_sides: bool = True
    points_to_win: int | None = None
    max_match_steps: int | None = None
    k_factor: float = 32.0
    initial_rating: float = 1200.0
    video: VideoConfig = field(default_factory=VideoConfig)
    seed: int = 0
    threads: int = 1

    def num_envs(self) -> int:
        """Worlds played in parallel: ``env.num_envs``, else up to 32, never above ``matches``."""
        return min(self.env.num_envs or 32, self.matches)


def register_evaluate_configs() -> None:
    """Register the schema (and the ``env`` group's) so that ``conf/evaluate.yaml`` can name it."""
    register_configs()
    ConfigStore.instance().store(name="evaluate_schema", node=EvaluateConfig)
