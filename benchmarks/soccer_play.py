"""Soccer play diagnostics of several trained teams against the scripted team, side by side.

Runs :func:`rlhc.evaluation.diagnostics.soccer_diagnostics` on each team (a run
directory — its ``final_team.pt`` or newest checkpoint —, a checkpoint, or a final-team
file) and, as the reference, the scripted team against itself
(:func:`~rlhc.evaluation.diagnostics.soccer.scripted_diagnostics`); writes ``--out``
(JSON, one entry per team, with the command that rebuilds it) and prints a Markdown
table: per 1,000 pitch-decisions the goals, shots and shots on target of each side
(trained / scripted), how the trained team's shots on target end, the ball's share of
time in the scripted team's half, the strikers' distance to the ball, the goalies'
distance from their goal, and touches per episode.

Usage::

    python -m benchmarks.soccer_play benchmarks/results/learning/soccer/best/*/seed_[01] \\
        --no-self-play --out benchmarks/results/soccer_play/best.json
    python -m benchmarks.soccer_play --report benchmarks/results/soccer_play/best.json
"""

from __future__ import annotations

import argparse
import json
import shlex
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import torch

from benchmarks.reporting.summary import code_version
from rlhc.evaluation.diagnostics.soccer import scripted_diagnostics, soccer_diagnostics
from rlhc.storage.final_team import load_team

#: (column title, Markdown alignment) of the table, the self-play column last.
COLUMNS = (
    ("team", "---"),
    ("episodes ending in a goal", "---:"),
    ("goals /1k (T / S)", "---"),
    ("shots /1k", "---"),
    ("T's shots by its goalie", "---:"),
    ("on target /1k", "---"),
    ("T's on target: goal / saved / blocked / missed", "---"),
    ("ball in S's half", "---:"),
    ("striker-ball m", "---"),
    ("goalie-goal m", "---"),
    ("touches /episode (striker + goalie)", "---"),
    ("self-play goals /1k", "---:"),
)


def header(self_play: bool) -> str:
    """The table's two header lines (with the self-play column or without)."""
    columns = COLUMNS if self_play else COLUMNS[:-1]
    titles = "| " + " | ".join(title for title, _ in columns) + " |"
    return titles + "\n|" + "|".join(align for _, align in columns) + "|"


def _pair(first: dict[str, Any], second: dict[str, Any], key: str, digits: int = 2) -> str:
    return f"{first[key]:.{digits}f} / {second[key]:.{digits}f}"


def _touches(team: dict[str, Any]) -> str:
    return f"{team['striker_touches_per_episode']:.1f} + {team['goalie_touches_per_episode']:.1f}"


def cells(name: str, play: dict[str, Any], first: str, second: str) -> list[str]:
    """A play's table cells but self-play's: its sides ``first`` / ``second``."""
    a, b = play[first], play[second]
    outcomes = a["on_target_outcomes"]
    return [
        name,
        f"{play['goal_share']:.2f}",
        _pair(a, b, "goals_per_1000"),
        _pair(a, b, "shots_per_1000", 1),
        f"{a['goalie_shot_share']:.2f}",
        _pair(a, b, "shots_on_target_per_1000", 1),
        " / ".join(f"{outcomes[k]:.2f}" for k in ("goal", "saved", "blocked", "missed")),
        f"{a['ball_in_opponent_half']:.2f}",
        _pair(a, b, "striker_ball_distance", 1),
        _pair(a, b, "goalie_goal_distance", 1),
        f"{_touches(a)} / {_touches(b)}",
    ]


def team_row(name: str, result: dict[str, Any]) -> str:
    """The Markdown row of a trained team (trained / scripted; self-play if measured)."""
    row = cells(name, result["vs_scripted"], "trained", "scripted")
    if "self_play" in result:
        row.append(f"{result['self_play']['trained']['goals_per_1000']:.2f}")
    return "| " + " | ".join(row) + " |"


def table(payload: dict[str, Any]) -> str:
    """The Markdown table of a written ``--out`` file (the scripted reference first)."""
    teams = payload["teams"]
    self_play = any("self_play" in result for result in teams.values())
    reference = cells(
        "scripted (team 0 / team 1)",
        payload["scripted"]["scripted_vs_scripted"],
        "team_0",
        "team_1",
    )
    lines = [header(self_play), "| " + " | ".join(reference + [""] * self_play) + " |"]
    lines += [team_row("/".join(Path(team).parts[-3:]), result) for team, result in teams.items()]
    return "\n".join(lines)


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("teams", nargs="*", help="run directories, checkpoints or team files")
    parser.add_argument("--out", type=Path, help="JSON file to write")
    parser.add_argument("--report", type=Path, help="only print the table of a written --out")
    parser.add_argument("--worlds", type=int, default=32)
    parser.add_argument("--decisions", type=int, default=1000)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument(
        "--no-self-play", action="store_true", help="play the scripted team only (half the time)"
    )
    args = parser.parse_args(argv)
    if args.report is not None:
        print(table(json.loads(args.report.read_text())))
        return 0
    if not args.teams or args.out is None:
        parser.error("give teams and --out (or --report FILE)")
    torch.set_num_threads(1)
    play = {"worlds": args.worlds, "decisions": args.decisions, "seed": args.seed}
    scripted = scripted_diagnostics(**play)
    teams: dict[str, Any] = {}
    for team in args.teams:
        state = load_team(team)
        result = soccer_diagnostics(state, self_play=not args.no_self_play, **play)
        result["frames"] = int(state.get("frames", 0))
        result["source"] = Path(state["path"]).name
        teams[team] = result
        print(team_row("/".join(Path(team).parts[-3:]), result), flush=True)
    command = shlex.join(["python", "-m", "benchmarks.soccer_play", *sys.argv[1:]])
    payload = {
        "command": command,
        "code_version": code_version(),
        "scripted": scripted,
        "teams": teams,
    }
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(payload, indent=2) + "\n")
    print(table(payload))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
