"""Training throughput: frames per second of the whole loop, ours vs the TorchRL route.

A frame is one step of one world; a training frame/s counts collection, the
hierarchical value estimator and the PPO epochs (paper Table 3 settings, one torch
thread). Measured in one run, per ``--env`` and ``--critic``:

* ``rlhc``: the project's own pipeline, built from the Hydra config exactly as
  ``python -m rlhc.run`` builds it (``hydra.compose`` + :class:`rlhc.trainer.Trainer`),
  the batched ``make_env`` game on the collection path;
* ``wrapper``: the straightforward TorchRL route: the game's PettingZoo env
  (``rlhc.envs.<game>.parallel_env()``) in ``torchrl.envs.PettingZooWrapper``, inside a
  ``SerialEnv`` of the same number of worlds, adapted to the TensorDict contract with
  TorchRL transforms (``RenameTransform`` for the manager observation that the wrapper
  leaves in ``(group, "info")``, ``StepCounter`` for the root ``step_count``,
  ``RewardSum``, and ``VecNormV2`` when the config normalises observations). Same
  networks (``make_actor``, ``make_worker_critic``, ``make_manager_critic``), same loss
  (``make_ppo_loss``), and the same ``Trainer.train`` loop (a subclass swaps the env).

Both routes report ``train_frames_per_s`` per iteration in ``metrics.csv`` (the
trainer times collection + update, not logging or checkpoints); the first
``--warmup`` iterations are dropped and the rest are combined as total frames over
total time. ``--breakdown`` summarises a py-spy profile of this script instead.

Examples:
    python benchmarks/train_throughput.py --env soccer tennis --critic hierarchical ppo
    python benchmarks/train_throughput.py --env soccer --iterations 20 --skip-wrapper
    py-spy record --format raw -o soccer.txt -- python benchmarks/train_throughput.py \\
        --env soccer --critic hierarchical --iterations 40 --skip-wrapper
    python benchmarks/train_throughput.py --breakdown soccer.txt
"""

from __future__ import annotations

import argparse
import csv
import json
import math
import multiprocessing
import os
import platform
import re
import tempfile
import time
import warnings
from collections import Counter
from pathlib import Path
from typing import Any

RESULTS = Path(__file__).parent / "results" / "train_throughput.json"
CONF_DIR = Path(__file__).resolve().parents[1] / "conf"


def compose_config(env: str, critic: str, overrides: list[str]) -> Any:
    """The training config ``python -m rlhc.run env=… critic=… <overrides>`` would use."""
    from hydra import compose, initialize_config_dir
    from hydra.core.global_hydra import GlobalHydra
    from omegaconf import OmegaConf

    from rlhc.config import register_configs

    register_configs()
    GlobalHydra.instance().clear()
    with initialize_config_dir(config_dir=str(CONF_DIR), version_base="1.3"):
        cfg = compose(config_name="train", overrides=[f"env={env}", f"critic={critic}", *overrides])
    return OmegaConf.to_object(cfg)


def bench_overrides(iterations: int, frames_per_batch: int) -> list[str]:
    """Table 3 untouched; only the run length, the log backends and checkpoints change."""
    return [
        f"algo.max_steps={iterations * frames_per_batch}",
        "logger.backends=[csv]",
        "logger.progress=false",
        f"logger.summary_freq={frames_per_batch}",  # one metrics row per iteration
        "checkpoint_freq=1000000000",  # one checkpoint, at the end, outside the timing
    ]


# --- the TorchRL wrapper route -----------------------------------------------------------
def make_wrapper_env(cfg: Any, num_envs: int) -> Any:
    """``SerialEnv`` of ``PettingZooWrapper``\\ s, transformed to the TensorDict contract."""
    import importlib

    from torchrl.envs import (
        Compose,
        PettingZooWrapper,
        RenameTransform,
        SerialEnv,
        StepCounter,
        TransformedEnv,
    )

    from rlhc.builders import with_training_transforms

    game_module = importlib.import_module(f"rlhc.envs.{cfg.env.name}")
    options = cfg.env.game_options()

    def make_one(seed: int) -> Any:
        return PettingZooWrapper(
            game_module.parallel_env(seed=seed, **options),
            return_state=False,
            categorical_actions=True,
            seed=seed,
        )

    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", "PettingZoo in TorchRL is tested", UserWarning)
        probe = make_one(cfg.seed)
        groups = list(probe.group_map)
        probe.close()
        base = SerialEnv(
            num_envs, [lambda i=i: make_one(cfg.seed + i) for i in range(num_envs)]
        )  # fmt: skip
    # Rename the manager observation out of the infos and count steps, then the same
    # episode-return tracking and observation norm as the project's training env.
    renamed = TransformedEnv(
        base,
        Compose(
            RenameTransform(
                in_keys=[(g, "info", "manager_observation") for g in groups],
                out_keys=[(g, "manager_observation") for g in groups],
            ),
            StepCounter(),
        ),
    )
    return with_training_transforms(cfg, renamed)


def wrapper_trainer(cfg: Any, run_dir: Path) -> Any:
    """A :class:`~rlhc.trainer.Trainer` whose collection env is the wrapper route."""
    import torch

    from rlhc.builders import Layout
    from rlhc.trainer import Trainer

    class WrapperTrainer(Trainer):
        # Same train() and _update() as the project's trainer; only the env differs.
        def _update(self, batch: Any) -> dict[str, float]:
            # TorchRL's batched envs raise torch's thread count when they close
            # (BatchedEnvBase.close: + num_workers); seen here before the last update,
            # which then ran 2 OpenMP threads and took 25-50x longer on the loaded
            # machine. Keep the configured count, as the rlhc trainer has it.
            torch.set_num_threads(self.cfg.threads)
            return super()._update(batch)

        def save(self) -> Path:  # the wrapper env has no game state to checkpoint
            return self.run_dir

    env = make_wrapper_env(cfg, Layout.from_config(cfg).num_envs)
    return WrapperTrainer(cfg, run_dir, env=env)


# --- measuring ---------------------------------------------------------------------------
def read_metrics(run_dir: Path) -> list[dict[str, float]]:
    with (run_dir / "metrics.csv").open() as file:
        return [{k: float(v) for k, v in row.items() if v not in ("", None)} for row in csv.DictReader(file)]  # fmt: skip


def instrument(trainer: Any) -> dict[str, list[float]]:
    """Record process CPU time per iteration and per update (wall time is in metrics.csv).

    With one torch thread and a single-process env, CPU seconds are the seconds the
    loop actually ran, so frames per CPU-second hardly depends on the machine's load.
    """
    cpu: dict[str, list[float]] = {"iteration": [], "update": []}
    marks = [time.process_time()]
    update, log = trainer._update, trainer.logger.log

    def timed_update(batch: Any) -> Any:
        start = time.process_time()
        out = update(batch)
        cpu["update"].append(time.process_time() - start)
        return out

    def timed_log(step: int, metrics: dict[str, float]) -> None:
        marks.append(time.process_time())  # one log per iteration (see bench_route)
        cpu["iteration"].append(marks[-1] - marks[-2])
        log(step, metrics)

    trainer._update, trainer.logger.log = timed_update, timed_log
    return cpu


def combine(
    rows: list[dict[str, float]], cpu: dict[str, list[float]], frames_per_batch: int, warmup: int
) -> dict[str, Any]:
    """Frames over time of the iterations after the warm-up (one row per iteration)."""
    timed = rows[warmup:]
    if not timed:
        raise ValueError(f"no iteration left after {warmup} warm-up iteration(s)")
    train_time = sum(frames_per_batch / row["train_frames_per_s"] for row in timed)
    collect_time = sum(frames_per_batch / row["env_steps_per_s"] for row in timed)
    cpu_time = sum(cpu["iteration"][warmup:])
    update_cpu = sum(cpu["update"][warmup:])
    frames = frames_per_batch * len(timed)
    return {
        "train_frames_per_s": frames / train_time,
        "collect_share": collect_time / train_time,
        "train_frames_per_cpu_s": frames / cpu_time,
        "collect_share_cpu": 1.0 - update_cpu / cpu_time,
        "cpu_per_wall": cpu_time / train_time,
        "timed_iterations": len(timed),
        "per_iteration_train_frames_per_s": [round(r["train_frames_per_s"], 1) for r in timed],
        "per_iteration_cpu_s": [round(t, 3) for t in cpu["iteration"]],
        "per_iteration_update_cpu_s": [round(t, 3) for t in cpu["update"]],
    }


def bench_route(route: str, env: str, critic: str, iterations: int, warmup: int) -> dict[str, Any]:
    from rlhc.builders import Layout
    from rlhc.trainer import Trainer

    layout = Layout.from_config(compose_config(env, critic, []))
    cfg = compose_config(env, critic, bench_overrides(warmup + iterations, layout.frames_per_batch))
    with tempfile.TemporaryDirectory(prefix=f"bench_{route}_") as tmp:
        run_dir = Path(tmp)
        start = time.perf_counter()
        trainer = Trainer(cfg, run_dir) if route == "rlhc" else wrapper_trainer(cfg, run_dir)
        build = time.perf_counter() - start
        cpu = instrument(trainer)
        trainer.train()
        rows = read_metrics(run_dir)
    if len(rows) != warmup + iterations:  # summary_freq <= frames per batch in Table 3
        raise RuntimeError(f"expected one metrics row per iteration, got {len(rows)}")
    result = {"env": env, "critic": critic, "route": route, "worlds": layout.num_envs,
              "frames_per_batch": layout.frames_per_batch,
              "minibatch": layout.minibatch_frames, "warmup_iterations": warmup,
              "build_s": build}  # fmt: skip
    result.update(combine(rows, cpu, layout.frames_per_batch, warmup))
    print(f"{env:7} {critic:13} {route:8} {result['train_frames_per_s']:>9,.0f} train frames/s, "
          f"{result['train_frames_per_cpu_s']:>9,.0f} per CPU-s "
          f"(collection {result['collect_share_cpu']:.0%} of the CPU time, "
          f"{result['cpu_per_wall']:.0%} of a core, "
          f"{result['timed_iterations']} iterations)", flush=True)  # fmt: skip
    return result


# --- py-spy profile summary --------------------------------------------------------------
#: (category, regex on one collapsed stack); the first that matches wins, in this order.
CATEGORIES: tuple[tuple[str, str], ...] = (
    ("update: backward", r"backward \(torch/(autograd|_tensor)"),
    ("update: optimizer (Adam, grad clip)", r"(step|_single_tensor_adam|_multi_tensor_adam|adam) \(torch/optim|clip_grad_norm_"),
    ("update: value estimator (critics + GAE)", r"objectives/value\.py|hierarchical_gae"),
    ("collect: env step (game, numpy/pymunk)", r"rlhc/envs/(soccer|tennis)/|pettingzoo_adapter|pymunk"),
    ("collect: env adapter (arrays to TensorDict)", r"rlhc/envs/torchrl_adapter\.py|libs/pettingzoo\.py"),
    ("collect: policy forward", r"collectors/.*;.*(tensordict/nn|torchrl/modules)"),
    ("collect: TorchRL/TensorDict overhead", r"torchrl/(collectors|envs)/"),
    ("update: loss forward", r"objectives/ppo\.py|torchrl/objectives/"),
    ("update: minibatch indexing / TensorDict", r"trainer\.py\).*;.*tensordict/"),
)  # fmt: skip


def breakdown(path: Path) -> dict[str, float]:
    """Share of samples per category in a ``py-spy record --format raw`` file."""
    counts: Counter[str] = Counter()
    total = 0
    compiled = [(name, re.compile(pattern)) for name, pattern in CATEGORIES]
    for line in path.read_text().splitlines():
        stack, _, count = line.rpartition(" ")
        if not stack or "train (rlhc/trainer.py" not in stack:
            continue  # imports, config, set-up, teardown
        total += int(count)
        name = next((n for n, p in compiled if p.search(stack)), "other (trainer loop)")
        counts[name] += int(count)
    shares = {name: counts[name] / total for name, _ in counts.most_common()}
    print(f"{total} samples inside Trainer.train")
    for name, share in shares.items():
        print(f"{share:6.1%}  {name}")
    return shares


def write_results(path: Path, results: list[dict[str, Any]]) -> None:
    """Add ``results`` to the file, replacing rows of the same env, critic and route."""
    measured = {(r["env"], r["critic"], r["route"]) for r in results}
    kept = []
    if path.exists():
        kept = [r for r in json.loads(path.read_text())["results"]
                if (r["env"], r["critic"], r["route"]) not in measured]  # fmt: skip
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps({"results": kept + results}, indent=2) + "\n")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--env", nargs="+", default=["soccer", "tennis"])
    parser.add_argument("--critic", nargs="+", default=["hierarchical", "ppo"])
    parser.add_argument("--iterations", type=int, default=10, help="timed iterations, ours")
    parser.add_argument("--wrapper-iterations", type=int, default=2, help="timed, wrapper route")
    parser.add_argument("--warmup", type=int, default=1, help="iterations dropped before timing")
    parser.add_argument("--wrapper-warmup", type=int, default=1, help="the same, wrapper route")
    parser.add_argument("--skip-wrapper", action="store_true", help="time the rlhc route only")
    parser.add_argument("--breakdown", type=Path, help="summarise a py-spy raw profile and exit")
    parser.add_argument("--output", type=Path, default=RESULTS)
    args = parser.parse_args()
    if args.breakdown is not None:
        breakdown(args.breakdown)
        return

    load_before = os.getloadavg()
    results = []
    for env in args.env:
        for critic in args.critic:
            ours = bench_route("rlhc", env, critic, args.iterations, args.warmup)
            results.append(ours)
            if args.skip_wrapper:
                continue
            theirs = bench_route(
                "wrapper", env, critic, args.wrapper_iterations, args.wrapper_warmup
            )
            results.append(theirs)
            ratio = ours["train_frames_per_s"] / theirs["train_frames_per_s"]
            cpu_ratio = ours["train_frames_per_cpu_s"] / theirs["train_frames_per_cpu_s"]
            for row in (ours, theirs):
                row["ratio_vs_wrapper"], row["cpu_ratio_vs_wrapper"] = ratio, cpu_ratio
            print(f"{env:7} {critic:13} rlhc / wrapper: {ratio:.1f}x wall, {cpu_ratio:.1f}x CPU",
                  flush=True)  # fmt: skip

    print(f"\n{'env':7} {'critic':13} {'route':8} {'worlds':>6} {'frames/s':>9} {'/CPU-s':>9} "
          f"{'collect':>7} {'core':>5} {'ratio':>6} {'CPU ratio':>9}")  # fmt: skip
    for row in results:
        ratio = row.get("ratio_vs_wrapper", math.nan)
        cpu_ratio = row.get("cpu_ratio_vs_wrapper", math.nan)
        print(f"{row['env']:7} {row['critic']:13} {row['route']:8} {row['worlds']:>6} "
              f"{row['train_frames_per_s']:>9,.0f} {row['train_frames_per_cpu_s']:>9,.0f} "
              f"{row['collect_share_cpu']:>7.0%} {row['cpu_per_wall']:>5.0%} {ratio:>6.1f} "
              f"{cpu_ratio:>9.1f}")  # fmt: skip
    meta = {"machine": platform.machine(), "cpus": multiprocessing.cpu_count(),
            "python": platform.python_version(), "date": time.strftime("%Y-%m-%d %H:%M %Z"),
            "loadavg_before": load_before, "loadavg_after": os.getloadavg(),
            "iterations": args.iterations, "wrapper_iterations": args.wrapper_iterations,
            "warmup": args.warmup, "wrapper_warmup": args.wrapper_warmup}  # fmt: skip
    for row in results:
        row["measured"] = meta
    write_results(args.output, results)
    print(f"wrote {args.output}")


if __name__ == "__main__":
    main()
