"""Did the update or the observation normaliser break a team? Swap their statistics.

A run whose play collapsed between two checkpoints changed two things between them: the
weights (the updates) and the observation normaliser's running statistics (which follow
the play; ``algo.observation_decay``). This plays each checkpoint's weights with itself
under its own normaliser and under the other one's (sampled and mode actions, the play
diagnostics of :func:`rlhc.evaluation.diagnostics.diagnose`, same courts and seed): if
the earlier weights break under the later statistics while the later weights play under
the earlier ones, the statistics broke it. It also reports how far the statistics moved:
per feature of the actor's input, the shift of the mean in units of the earlier scale,
and the ratio of the scales.

Usage::

    python -m benchmarks.normaliser_swap \\
        benchmarks/results/learning/tennis/probe_mlagents_league_view_lr/ppo/seed_0 \\
        step_003502080.pt step_003750400.pt \\
        --out benchmarks/results/tennis_play/normaliser_swap_lr_seed0.json

(the checkpoints are a run's own, kept in ``<run>/checkpoints``).
"""

from __future__ import annotations

import argparse
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import torch

from benchmarks.tennis_play import write_results
from rlhc.envs import make_env
from rlhc.evaluation.diagnostics import diagnose
from rlhc.evaluation.policies import observation_options, restore_policy
from rlhc.storage.checkpoint import CHECKPOINT_DIR, load_checkpoint

#: What is kept of each play measurement.
KEPT = ("hits_per_point", "hits_per_point_mode", "points", "ended")


def statistics(state: dict[str, Any]) -> tuple[torch.Tensor, torch.Tensor]:
    """The actor's normaliser mean and scale ``[n_g, d]`` (tennis: the racket group)."""
    policy = restore_policy(state, make_env(state["env"], num_envs=1, **observation_options(state)))
    if policy.loc is None or policy.scale is None:
        raise ValueError("the run does not normalise observations: nothing to swap")
    (group,) = policy.loc
    return policy.loc[group], policy.scale[group]


def play(
    weights: dict[str, Any], normaliser: dict[str, Any], worlds: int, decisions: int, seed: int
) -> dict[str, Any]:
    state = {**weights, "env_transform": normaliser["env_transform"]}
    result = diagnose(state, worlds=worlds, decisions=decisions, seed=seed)
    return {key: result[key] for key in KEPT if key in result}


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("run", type=Path, help="a run directory")
    parser.add_argument("before", help="the earlier checkpoint's file name in <run>/checkpoints")
    parser.add_argument("after", help="the later one's")
    parser.add_argument("--out", type=Path, required=True, help="JSON file to write")
    parser.add_argument("--worlds", type=int, default=16)
    parser.add_argument("--decisions", type=int, default=500)
    parser.add_argument("--seed", type=int, default=2)
    args = parser.parse_args(argv)
    torch.set_num_threads(1)
    states = {
        name: load_checkpoint(args.run / CHECKPOINT_DIR / file)
        for name, file in (("before", args.before), ("after", args.after))
    }
    plays = {
        f"{weights}_weights_{stats}_normaliser": play(
            states[weights], states[stats], args.worlds, args.decisions, args.seed
        )
        for weights in states
        for stats in states
    }
    (loc_0, scale_0), (loc_1, scale_1) = (statistics(state) for state in states.values())
    drift = {
        "mean_shift_in_scales": ((loc_1 - loc_0) / scale_0).tolist(),
        "scale_ratio": (scale_1 / scale_0).tolist(),
        "scale_before": scale_0.tolist(),
    }
    for name, result in plays.items():
        print(
            f"{name}: {result['hits_per_point']:.2f} hits per point ({result['hits_per_point_mode']:.2f} mode)"
        )
    write_results(
        args.out,
        "benchmarks.normaliser_swap",
        plays,
        run=str(args.run),
        checkpoints={name: int(state["frames"]) for name, state in states.items()},
        drift=drift,
    )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
