"""Environment throughput: world-steps per second, with random actions.

Measured in one run, per game:

* ``pettingzoo``: the PettingZoo ``ParallelEnv`` of one world, a plain Python loop;
* ``game``: the numpy :class:`~rlhc.envs.base.BatchedGame` at each ``--worlds``;
* ``torchrl``: the batched TorchRL env (``make_env``) at each ``--worlds``, stepped
  with ``step_and_maybe_reset`` as a collector does;
* ``torchrl xP``: ``--processes`` processes each stepping its own TorchRL env at the
  largest ``--worlds``, summed.

A game that is not importable yet is skipped. Prints a table and writes JSON.

Examples:
    python benchmarks/env_throughput.py --env tennis soccer
    python benchmarks/env_throughput.py --env tennis --worlds 16 64 256 --steps 300
"""

from __future__ import annotations

import argparse
import json
import multiprocessing
import platform
import time
from pathlib import Path
from typing import Any

import numpy as np

RESULTS = Path(__file__).parent / "results" / "env_throughput.json"


def random_actions(game: Any, rng: np.random.Generator, steps: int) -> list[dict[str, np.ndarray]]:
    """``steps`` batches of uniformly random actions for every group of ``game``."""
    from rlhc.envs.base import ContinuousAction

    batches = []
    for _ in range(steps):
        batch: dict[str, np.ndarray] = {}
        for spec in game.groups:
            shape = (game.num_worlds, spec.num_agents)
            if isinstance(spec.action, ContinuousAction):
                batch[spec.name] = rng.uniform(-1, 1, (*shape, spec.action.size))
            else:
                batch[spec.name] = rng.integers(0, spec.action.n, shape)
        batches.append(batch)
    return batches


def bench_pettingzoo(name: str, steps: int) -> float:
    from rlhc.envs import make_game
    from rlhc.envs.pettingzoo_adapter import BatchedGameParallelEnv

    env = BatchedGameParallelEnv(make_game(name, num_envs=1, seed=0))
    env.reset(seed=0)
    for agent in env.possible_agents:
        env.action_space(agent).seed(0)
    actions = [{a: env.action_space(a).sample() for a in env.possible_agents} for _ in range(steps)]
    start = time.perf_counter()
    for action in actions:
        env.step(action)
        if not env.agents:
            env.reset()
    return steps / (time.perf_counter() - start)


def bench_game(name: str, worlds: int, steps: int) -> float:
    from rlhc.envs import make_game

    game = make_game(name, num_envs=worlds, seed=0)
    actions = random_actions(game, np.random.default_rng(0), steps + 20)
    for action in actions[:20]:  # warm-up
        game.step(action)
    start = time.perf_counter()
    for action in actions[20:]:
        outcome = game.step(action)
        game.observe()
        ended = outcome.terminated | outcome.truncated
        if ended.any():
            game.reset(ended)
    return worlds * steps / (time.perf_counter() - start)


def bench_torchrl(name: str, worlds: int, steps: int) -> float:
    import torch

    from rlhc.envs import make_env

    torch.set_num_threads(1)
    env = make_env(name, num_envs=worlds, seed=0)
    actions = [
        {key: torch.as_tensor(value) for key, value in batch.items()}
        for batch in random_actions(env.game, np.random.default_rng(0), steps + 20)
    ]
    for batch in actions:  # match the spec's dtypes once, outside the timed loop
        for spec in env.game.groups:
            batch[spec.name] = batch[spec.name].to(env.full_action_spec[spec.name, "action"].dtype)
    td = env.reset()
    for i, batch in enumerate(actions):
        if i == 20:
            start = time.perf_counter()
        for group, action in batch.items():
            td.set((group, "action"), action)
        _, td = env.step_and_maybe_reset(td)
    return worlds * steps / (time.perf_counter() - start)


def _worker(args: tuple[str, int, int]) -> float:
    return bench_torchrl(*args)


def bench_processes(name: str, worlds: int, steps: int, processes: int) -> float:
    context = multiprocessing.get_context("spawn")
    with context.Pool(processes) as pool:
        rates = pool.map(_worker, [(name, worlds, steps)] * processes)
    return float(sum(rates))


def importable(name: str) -> bool:
    from rlhc.envs import game_class

    try:
        game_class(name)
    except ImportError as error:
        print(f"skipping {name}: {error}")
        return False
    return True


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--env", nargs="+", default=["tennis", "soccer"])
    parser.add_argument("--worlds", nargs="+", type=int, default=[16, 64, 256])
    parser.add_argument("--steps", type=int, default=300, help="timed steps per measurement")
    parser.add_argument("--pettingzoo-steps", type=int, default=2000)
    parser.add_argument("--processes", type=int, default=2)
    parser.add_argument("--output", type=Path, default=RESULTS)
    args = parser.parse_args()

    rows: list[dict[str, Any]] = []
    for name in args.env:
        if not importable(name):
            continue
        rows.append({"env": name, "path": "pettingzoo", "worlds": 1, "processes": 1,
                     "steps_per_s": bench_pettingzoo(name, args.pettingzoo_steps)})  # fmt: skip
        for worlds in args.worlds:
            rows.append({"env": name, "path": "game", "worlds": worlds, "processes": 1,
                         "steps_per_s": bench_game(name, worlds, args.steps)})  # fmt: skip
        for worlds in args.worlds:
            rows.append({"env": name, "path": "torchrl", "worlds": worlds, "processes": 1,
                         "steps_per_s": bench_torchrl(name, worlds, args.steps)})  # fmt: skip
        worlds = max(args.worlds)
        rate = bench_processes(name, worlds, args.steps, args.processes)
        rows.append({"env": name, "path": "torchrl", "worlds": worlds,
                     "processes": args.processes, "steps_per_s": rate})  # fmt: skip

    print(f"{'env':8} {'path':11} {'worlds':>6} {'procs':>5} {'world-steps/s':>14}")
    for row in rows:
        print(f"{row['env']:8} {row['path']:11} {row['worlds']:>6} {row['processes']:>5} "
              f"{row['steps_per_s']:>14,.0f}")  # fmt: skip
    args.output.parent.mkdir(parents=True, exist_ok=True)
    meta = {"machine": platform.machine(), "cpus": multiprocessing.cpu_count(),
            "python": platform.python_version(), "steps": args.steps}  # fmt: skip
    args.output.write_text(json.dumps({"meta": meta, "results": rows}, indent=2) + "\n")
    print(f"wrote {args.output}")


if __name__ == "__main__":
    main()
