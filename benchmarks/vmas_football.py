"""rlhc soccer next to VMAS football 2 vs 2, both through TorchRL, same loop, same machine.

VMAS (``pip install --no-deps vmas gym gym-notices``: benchmark only, not a project
dependency; ``--no-deps`` so that it cannot touch the installed torch) simulates
football as batched torch tensors. Both envs are stepped by the loop a collector runs:
``rand_action`` then ``step_and_maybe_reset``, ``batch_size=[worlds]``, one torch thread.

VMAS is configured 2 vs 2 with four learning agents and discrete actions
(``ai_red_agents=False``), as rlhc's soccer; ``--vmas-ai-red`` times its scripted red
team instead. The two games are not the same work: VMAS observes positions and
velocities (no rays), rlhc casts 136 rays per pitch-step and runs pymunk.

Examples:
    python benchmarks/vmas_football.py --worlds 64 256 1024 --steps 200
"""

from __future__ import annotations

import argparse
import json
import platform
import time
from pathlib import Path
from typing import Any


def make_vmas(worlds: int, ai_red: bool) -> Any:
    from torchrl.envs.libs.vmas import VmasEnv

    return VmasEnv(
        scenario="football",
        num_envs=worlds,
        device="cpu",
        continuous_actions=False,
        n_blue_agents=2,
        n_red_agents=2,
        ai_red_agents=ai_red,
        seed=0,
    )


def make_rlhc(worlds: int) -> Any:
    from rlhc.envs import make_env

    return make_env("soccer", num_envs=worlds, seed=0)


def steps_per_second(env: Any, worlds: int, steps: int, warmup: int = 20) -> float:
    """World-steps per second of ``rand_action`` + ``step_and_maybe_reset``."""
    td = env.reset()
    for _ in range(warmup):
        td = env.rand_action(td)
        _, td = env.step_and_maybe_reset(td)
    start = time.perf_counter()
    for _ in range(steps):
        td = env.rand_action(td)
        _, td = env.step_and_maybe_reset(td)
    return worlds * steps / (time.perf_counter() - start)


def main() -> None:
    import torch

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--worlds", nargs="+", type=int, default=[64, 256, 1024])
    parser.add_argument("--steps", type=int, default=200, help="timed steps per measurement")
    parser.add_argument("--repeats", type=int, default=3, help="best of this many runs")
    parser.add_argument("--vmas-ai-red", action="store_true", help="VMAS red team scripted")
    parser.add_argument("--output", type=Path, default=None, help="also write JSON here")
    args = parser.parse_args()
    torch.set_num_threads(1)

    rows = []
    print(f"{'env':16s} {'worlds':>6s} {'world-steps/s':>14s}")
    for worlds in args.worlds:
        builders = {
            "rlhc soccer": lambda n=worlds: make_rlhc(n),
            "vmas football": lambda n=worlds: make_vmas(n, args.vmas_ai_red),
        }
        for name, build in builders.items():
            env = build()
            rate = max(steps_per_second(env, worlds, args.steps) for _ in range(args.repeats))
            env.close()
            rows.append({"env": name, "worlds": worlds, "world_steps_per_s": rate})
            print(f"{name:16s} {worlds:6d} {rate:14,.0f}")
    if args.output is not None:
        meta = {
            "machine": platform.platform(),
            "processor": platform.processor(),
            "args": {**vars(args), "output": str(args.output)},
        }
        args.output.write_text(json.dumps({"meta": meta, "results": rows}, indent=2) + "\n")


if __name__ == "__main__":
    main()
