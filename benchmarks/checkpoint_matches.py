"""Every checkpoint of a run against a built-in team: how its play changed with training.

A run's final team says where it ended, not whether it got there and stayed: a tennis
team may beat the scripted team at 2.5 M court-decisions and lose to it at 4.5 M. This
plays each ``<run>/checkpoints/step_*.pt`` of each run given, exactly as
``python -m rlhc.evaluate env=<env> home=<checkpoint> away=<opponent> matches=<n>``
(mode actions, sides swapped, the same seed for every checkpoint), and keeps the match
summaries in one JSON file. It is incremental: checkpoints already in ``--out`` (same
opponent, matches and seed) are not played again, so it can follow runs in progress
(``--follow``) and be started again after a kill.

Usage::

    python -m benchmarks.checkpoint_matches \\
        benchmarks/results/learning/tennis/probe_mlagents_league_view_norm/ppo/seed_1 \\
        benchmarks/results/learning/tennis/probe_mlagents_league_view_norm/ppo/seed_2 \\
        --out benchmarks/results/tennis_play/checkpoints_probe_mlagents_league_view_norm.json

Checkpoints are kept locally by the training runs (only final teams are committed);
the JSON is the committed record of them.
"""

from __future__ import annotations

import argparse
import json
import time
from collections.abc import Iterator, Sequence
from pathlib import Path
from typing import Any

import torch

from benchmarks.learning import match_summary
from benchmarks.reporting.summary import code_version
from rlhc.evaluation.opponents import BUILT_IN
from rlhc.storage.checkpoint import CHECKPOINT_DIR, STEP_GLOB, load_checkpoint, step_of

#: Summary entries kept per checkpoint (and every ``*_per_point`` entry).
KEPT = (
    "matches",
    "wins",
    "draws",
    "losses",
    "win_rate",
    "win_rate_ci",
    "points_won_rate",
    "points_won_rate_ci",
)


def checkpoints(run: Path) -> Iterator[tuple[int, Path]]:
    """``(frames, file)`` of a run's ``step_*.pt`` checkpoints, fewest frames first."""
    folder = run / CHECKPOINT_DIR
    if not folder.is_dir():
        raise FileNotFoundError(f"{run}: no {CHECKPOINT_DIR}/ directory (not a run directory?)")
    found = ((step_of(path), path) for path in folder.glob(STEP_GLOB))
    yield from sorted((frames, path) for frames, path in found if frames is not None)


def kept(summary: dict[str, Any]) -> dict[str, Any]:
    """The entries of a match summary that the record keeps."""
    return {
        key: value for key, value in summary.items() if key in KEPT or key.endswith("_per_point")
    }


def read_record(out: Path, settings: dict[str, Any]) -> dict[str, Any]:
    """The record in ``out`` if it was played with ``settings``, else an empty one.

    Raises:
        ValueError: ``out`` holds a record played with other settings (named), which
            this would mix with its own.
    """
    if not out.is_file():
        return {**settings, "runs": {}}
    record = json.loads(out.read_text())
    differing = {
        key: record.get(key) for key, value in settings.items() if record.get(key) != value
    }
    if differing:
        raise ValueError(
            f"{out} holds matches played with {differing}; this command plays "
            f"{ {key: settings[key] for key in differing} }: give another --out"
        )
    return record


def row(run: str, frames: int, summary: dict[str, Any]) -> str:
    low, high = summary["points_won_rate_ci"]
    return (
        f"{run}  {frames / 1e6:6.2f} M  won {summary['wins']:>3} of {summary['matches']}"
        f"  points {summary['points_won_rate']:6.1%} [{low:.1%}, {high:.1%}]"
    )


def play_new(runs: Sequence[Path], record: dict[str, Any], out: Path) -> int:
    """Play the checkpoints of ``runs`` not yet in ``record``; save after each. Returns their count."""
    played = 0
    for run in runs:
        entries = record["runs"].setdefault(str(run), {})
        for frames, path in checkpoints(run):
            if str(frames) in entries:
                continue
            env = load_checkpoint(path)["env"]
            summary = match_summary(
                path, env, record["opponent"], record["matches"], record["seed"]
            )
            entries[str(frames)] = kept(summary)
            print(row(str(run), frames, summary), flush=True)
            record["code_version"] = code_version()
            out.parent.mkdir(parents=True, exist_ok=True)
            out.write_text(json.dumps(record, indent=1, sort_keys=True) + "\n")
            played += 1
    return played


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("runs", type=Path, nargs="+", help="run directories")
    parser.add_argument("--out", type=Path, required=True, help="JSON file (read, then extended)")
    parser.add_argument("--opponent", default="scripted", choices=BUILT_IN)
    parser.add_argument("--matches", type=int, default=100)
    parser.add_argument("--seed", type=int, default=0, help="seed of the matches")
    parser.add_argument(
        "--follow",
        type=float,
        default=0.0,
        metavar="SECONDS",
        help="keep looking for new checkpoints every SECONDS (0: play what is there, stop)",
    )
    args = parser.parse_args(argv)
    if args.matches < 2:
        parser.error(f"--matches {args.matches}: allowed: at least 2 (half on each side)")
    torch.set_num_threads(1)
    settings = {"opponent": args.opponent, "matches": args.matches, "seed": args.seed}
    try:
        record = read_record(args.out, settings)
    except ValueError as error:
        parser.error(str(error))
    while True:
        play_new(args.runs, record, args.out)
        if not args.follow:
            return 0
        time.sleep(args.follow)


if __name__ == "__main__":
    raise SystemExit(main())
