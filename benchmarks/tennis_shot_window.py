"""How narrow is tennis's shot window? The scripted team under Gaussian action noise.

Two scripted teams play with ``N(0, sigma)`` noise added to every action (clipped to
``[-1, 1]``); the over-the-net hits per point measure how much aim the game demands,
and so how much exploration noise a learning policy can afford. Each action dimension
is also perturbed alone (move, jump, tilt).

Usage::

    python benchmarks/tennis_shot_window.py            # JSON to benchmarks/results/
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np

from rlhc.envs.tennis import ScriptedTennisPolicy, TennisGame

RESULTS = Path(__file__).resolve().parent / "results" / "tennis_shot_window.json"
DIMENSIONS = {"all": (0, 1, 2), "move": (0,), "jump": (1,), "tilt": (2,)}


def hits_per_point(sigma: float, dims: tuple[int, ...], decisions: int, courts: int) -> float:
    """Over-the-net hits per point of two noisy scripted teams."""
    game = TennisGame(num_worlds=courts, seed=0)
    policy = ScriptedTennisPolicy(game.geometry, game.decision_interval)
    rng = np.random.default_rng(0)
    mask = np.zeros(3)
    mask[list(dims)] = 1.0
    hits, points = 0.0, 0
    for _ in range(decisions):
        action = policy(game.observe()["racket"].observation)
        action = np.clip(action + sigma * mask * rng.standard_normal(action.shape), -1, 1)
        outcome = game.step({"racket": action})
        hits += float(outcome.info["hits_over_net"].sum())
        points += int(outcome.terminated.sum())
        game.reset(outcome.terminated | outcome.truncated)
    return hits / max(points, 1)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--sigmas", type=float, nargs="+", default=[0.0, 0.1, 0.3, 0.6])
    parser.add_argument("--decisions", type=int, default=600)
    parser.add_argument("--courts", type=int, default=64)
    parser.add_argument("--output", type=Path, default=RESULTS)
    args = parser.parse_args()
    table = {
        name: {
            str(sigma): hits_per_point(sigma, dims, args.decisions, args.courts)
            for sigma in args.sigmas
        }
        for name, dims in DIMENSIONS.items()
    }
    result = {
        "command": "python benchmarks/tennis_shot_window.py",
        "measured_at": time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()),
        "decisions": args.decisions,
        "courts": args.courts,
        "hits_over_net_per_point": table,
    }
    args.output.parent.mkdir(parents=True, exist_ok=True)
    args.output.write_text(json.dumps(result, indent=2) + "\n")
    print("noise on   " + "".join(f"  sigma={s:<5}" for s in args.sigmas))
    for name, row in table.items():
        print(f"{name:<10}" + "".join(f"  {v:>11.2f}" for v in row.values()))
    print(f"results: {args.output}")


if __name__ == "__main__":
    main()
