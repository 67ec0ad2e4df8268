"""``python -m rlhc.evaluation.returns RUN [RUN ...]``: returns, cross-play, a video
(:mod:`rlhc.evaluation.returns`)."""

from __future__ import annotations

import argparse
import json
from collections.abc import Sequence
from pathlib import Path

import torch

from rlhc.cli.report import user_errors_in_one_line
from rlhc.evaluation.cross_play import cross_play
from rlhc.evaluation.returns import format_summary, record_episode, summary
from rlhc.evaluation.video import FORMATS

PROGRAM = "python -m rlhc.evaluation.returns"


def parse_args(argv: Sequence[str] | None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(
        prog=PROGRAM,
        description="Trained teams on another library's env: returns, cross-play, a video.",
    )
    parser.add_argument("runs", nargs="+", help="run directories, checkpoints or final teams")
    parser.add_argument("--episodes", type=int, default=100, help="episodes per lineup")
    parser.add_argument("--worlds", type=int, default=10, help="worlds stepped as one batch")
    parser.add_argument("--seed", type=int, default=0, help="the environment's seed")
    parser.add_argument(
        "--sampled", action="store_true", help="sample actions (default: the mode action)"
    )
    parser.add_argument("--out", type=Path, help="write the summary as JSON here")
    parser.add_argument(
        "--video", type=Path, help="record one episode of the first run here (.gif or .mp4)"
    )
    parser.add_argument("--max-frames", type=int, default=500, help="frames of the video")
    parser.add_argument("--fps", type=int, default=10, help="frames per second of the video")
    return parser.parse_args(argv)


def check_args(args: argparse.Namespace) -> None:
    """Refuse bad values before anything plays (:class:`ValueError`, one line)."""
    repeated = sorted({run for run in args.runs if args.runs.count(run) > 1})
    if repeated:
        raise ValueError(f"runs {repeated} given twice; allowed: each run once")
    for option in ("episodes", "worlds", "fps"):
        if getattr(args, option) < 1:
            raise ValueError(f"--{option} {getattr(args, option)}; allowed: >= 1")
    if args.video is not None:
        if args.video.suffix.lower() not in FORMATS:
            raise ValueError(
                f"--video {str(args.video)!r}; allowed: a file ending in {', '.join(FORMATS)}"
            )
        if args.max_frames < 2:
            raise ValueError(f"--max-frames {args.max_frames}; allowed: >= 2")


def main(argv: Sequence[str] | None = None) -> int:
    """Print (and with ``--out`` write) the runs' returns; a user error exits 2 in one line."""
    args = parse_args(argv)
    torch.set_num_threads(1)
    with user_errors_in_one_line(PROGRAM, (FileNotFoundError, ValueError)):
        check_args(args)
        result = cross_play(
            args.runs,
            args.episodes,
            num_envs=args.worlds,
            seed=args.seed,
            deterministic=not args.sampled,
        )
        report = summary(
            result, episodes=args.episodes, seed=args.seed, deterministic=not args.sampled
        )
        print(format_summary(report))
        if args.video is not None:
            written, frames = record_episode(
                args.runs[0],
                args.video,
                seed=args.seed,
                deterministic=not args.sampled,
                max_frames=args.max_frames,
                fps=args.fps,
            )
            report["video"] = str(written)
            print(f"video: {written} ({frames} frames)")
        if args.out is not None:
            args.out.parent.mkdir(parents=True, exist_ok=True)
            args.out.write_text(json.dumps(report, indent=2) + "\n")
            print(f"summary: {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
