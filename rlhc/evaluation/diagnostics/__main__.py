"""``python -m rlhc.evaluation.diagnostics <run dir or .pt> [--worlds N] [--decisions T]``."""

from __future__ import annotations

import argparse
import json
from collections.abc import Sequence

import torch

from rlhc.cli.report import user_errors_in_one_line
from rlhc.evaluation.diagnostics import diagnose
from rlhc.storage.final_team import load_team


def main(argv: Sequence[str] | None = None) -> int:
    """Print the play diagnostics of one team as JSON; a user error exits 2 in one line."""
    parser = argparse.ArgumentParser(
        prog="python -m rlhc.evaluation.diagnostics",
        description="Play diagnostics of a trained team (rlhc.evaluation.diagnostics).",
    )
    parser.add_argument("team", help="a run directory, checkpoint or final-team file")
    parser.add_argument("--worlds", type=int, default=32, help="worlds played at once")
    parser.add_argument("--decisions", type=int, default=1000, help="per world and mode")
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args(argv)
    torch.set_num_threads(1)
    # The one-line report of every entry point (HYDRA_FULL_ERROR=1: the traceback).
    with user_errors_in_one_line("rlhc.evaluation.diagnostics", (FileNotFoundError, ValueError)):
        result = diagnose(
            load_team(args.team), worlds=args.worlds, decisions=args.decisions, seed=args.seed
        )
    print(json.dumps(result, indent=2))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
