"""Tennis play diagnostics of several trained teams, side by side.

Runs :func:`rlhc.evaluation.diagnostics.tennis_diagnostics` on each team (a run
directory — its ``final_team.pt`` or newest checkpoint —, a checkpoint, or a final-team
file) and writes ``--out`` (JSON, one entry per team, with the command that rebuilds it)
and prints a Markdown table: hits over the net per point sampled and with mode actions,
the policy's scale near the ball and elsewhere (move / jump / tilt), the share of
saturated actions and of moves toward a ball in the racket's half, and the
:func:`~rlhc.evaluation.diagnostics.tennis.tracking_probe` (does the racket run to a
falling ball? the gain of its move on the ball's offset, and how often it moves towards
it), with the scripted team's probe as the reference.

Usage::

    python -m benchmarks.tennis_play benchmarks/results/learning/tennis/paper/*/seed_[34] \\
        --out benchmarks/results/tennis_play_paper.json
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
from rlhc.envs import make_env
from rlhc.envs.tennis.rules import POINT_ENDINGS
from rlhc.envs.tennis.scripted import ScriptedTennisPolicy
from rlhc.evaluation.diagnostics.tennis import ACTION_NAMES, tennis_diagnostics, tracking_probe
from rlhc.evaluation.policies import observation_options, restore_policy
from rlhc.storage.final_team import load_team

ROOT = Path(__file__).resolve().parents[1]


def row(name: str, result: dict[str, Any]) -> str:
    """One Markdown table row of a team's diagnostics."""

    def triple(values: dict[str, float]) -> str:
        return " / ".join(f"{values[n]:.2f}" for n in ACTION_NAMES)

    return (
        f"| {name} | {result['hits_per_point']:.2f} | {result['hits_per_point_mode']:.2f} "
        f"| {triple(result['sigma_near'])} | {triple(result['sigma_far'])} "
        f"| {triple(result['saturated'])} | {result['toward_ball']:.2f} "
        f"| {result['toward_ball_mode']:.2f} | {endings(result['ended'])} "
        f"| {endings(result['ended_mode'])} | {tracking(result['tracking'])} |"
    )


def tracking(probe: dict[str, Any]) -> str:
    """The tracking probe's gain (per metre) and share of moves towards the ball."""
    return f"{probe['gain']:.2f} / {probe['toward']:.2f}"


def team_tracking(state: dict[str, Any]) -> dict[str, Any]:
    """:func:`tracking_probe` of a trained team, through its frozen normaliser."""
    options = observation_options(state)
    env = make_env("tennis", num_envs=1, seed=0, **options)
    policy = restore_policy(state, env)
    env.close()
    return tracking_probe(policy, extended_obs=bool(options.get("extended_obs", False)))


def scripted_tracking() -> dict[str, Any]:
    """:func:`tracking_probe` of the built-in scripted team (the reference row)."""
    scripted = ScriptedTennisPolicy()

    def team(td: Any) -> dict[str, torch.Tensor]:
        return {"racket": torch.from_numpy(scripted(td["racket", "observation"].numpy()))}

    return tracking_probe(team)


def endings(shares: dict[str, float]) -> str:
    """Shares of points by how they ended, in :data:`POINT_ENDINGS`' order."""
    return " / ".join(f"{shares[how]:.2f}" for how in POINT_ENDINGS)


HEADER = (
    "| team | hits/point | hits/point (mode) | scale near ball (move/jump/tilt) "
    "| scale elsewhere | saturated | toward ball | toward ball (mode) "
    f"| points ended ({' / '.join(POINT_ENDINGS)}) | the same (mode) "
    "| falling ball: gain / toward |\n"
    "|---|---:|---:|---|---|---|---:|---:|---|---|---|"
)


def team_arguments(description: str, worlds: int, decisions: int) -> argparse.ArgumentParser:
    """The command line of a script that measures tennis teams in self-play."""
    parser = argparse.ArgumentParser(description=description)
    parser.add_argument("teams", nargs="+", help="run directories, checkpoints or team files")
    parser.add_argument("--out", type=Path, required=True, help="JSON file to write")
    parser.add_argument("--worlds", type=int, default=worlds)
    parser.add_argument("--decisions", type=int, default=decisions)
    parser.add_argument("--seed", type=int, default=0)
    return parser


def write_results(out: Path, module: str, teams: dict[str, Any], **extra: Any) -> None:
    """``out`` as JSON: the command that rebuilds it, the code version, ``extra``, ``teams``."""
    command = shlex.join(["python", "-m", module, *sys.argv[1:]])
    payload = {"command": command, "code_version": code_version(), **extra, "teams": teams}
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps(payload, indent=2) + "\n")


def main(argv: Sequence[str] | None = None) -> int:
    args = team_arguments(__doc__.split("\n")[0], worlds=32, decisions=1000).parse_args(argv)
    torch.set_num_threads(1)
    teams: dict[str, Any] = {}
    for team in args.teams:
        state = load_team(team)
        result = tennis_diagnostics(
            state, worlds=args.worlds, decisions=args.decisions, seed=args.seed
        )
        result["tracking"] = team_tracking(state)
        result["frames"] = int(state.get("frames", 0))
        result["source"] = Path(state["path"]).name
        teams[team] = result
        print(row(team, result), flush=True)
    reference = scripted_tracking()
    write_results(args.out, "benchmarks.tennis_play", teams, scripted_tracking=reference)
    print(HEADER)
    for team, result in teams.items():
        print(row(team, result))
    print(f"| scripted team | | | | | | | | | | {tracking(reference)} |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
