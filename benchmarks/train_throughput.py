"""Training throughput at Table 3 on 1 and 2 processes, against the arithmetic ceiling.

A frame is one world-decision. Each *setup* is a real training run, started as a user
starts it (``python -m rlhc.run`` or ``torchrun --standalone --nproc_per_node=2 -m
rlhc.run``, Table 3 untouched, one torch thread per process), timed from its own
``metrics.csv``: a row per ``logger.summary_freq`` world-decisions, as Table 3 logs,
and the rate is the frames over the wall time between the first row and the last
(everything the loop does is included: collection, update, logging and the
data-parallel metric merges; checkpoints pushed past the end).

| setup | command |
|---|---|
| ``one`` | ``python -m rlhc.run`` |
| ``data`` | ``torchrun --nproc_per_node=2 -m rlhc.run parallel=data`` |
| ``pipeline`` | ``torchrun --nproc_per_node=2 -m rlhc.run parallel=pipeline`` |
| ``trunk`` | ``python -m rlhc.run model.shared_trunk=true`` (discrete actions: soccer) |
| ``trunk-pipeline`` | ``pipeline`` with ``model.shared_trunk=true`` (soccer) |

Setups run one after another, round-robin over ``--repeats``, and every ratio compares
runs of the same round (the machine is shared: a ratio within one invocation is what
this measures). The ceiling: fp32 GEMM GFLOP/s on one core, measured in the same
invocation at the shapes of the configured minibatch, times the processes, divided by
the FLOP per frame of the configured networks (:func:`rlhc.flops.training_flops`:
the actors to collect, the value estimator and ``epochs`` forward-backward passes of the
loss to train).

``--wrapper`` adds the older comparison with the straightforward TorchRL route (the
game's PettingZoo env in ``PettingZooWrapper`` inside a ``SerialEnv``, same trainer, in
this process); ``--breakdown`` summarises a py-spy profile instead.

Examples:
    python benchmarks/train_throughput.py --env soccer tennis --repeats 2
    python benchmarks/train_throughput.py --env soccer --setups one pipeline --updates 21 22
    python benchmarks/train_throughput.py --env soccer --setups one --wrapper
    py-spy record --format raw -o soccer.txt -- python benchmarks/train_throughput.py \\
        --env soccer --setups one --updates 41 22
    python benchmarks/train_throughput.py --breakdown soccer.txt
"""

from __future__ import annotations

import argparse
import csv
import json
import multiprocessing
import os
import platform
import re
import statistics
import subprocess
import sys
import tempfile
import time
import warnings
from collections import Counter
from pathlib import Path
from typing import Any

RESULTS = Path(__file__).parent / "results" / "train_throughput.json"
CONF_DIR = Path(__file__).resolve().parents[1] / "conf"
TORCHRUN = [sys.executable, "-m", "torch.distributed.run", "--standalone", "--nproc_per_node=2"]
#: setup -> (processes, overrides)
SETUPS: dict[str, tuple[int, list[str]]] = {
    "one": (1, []),
    "data": (2, ["parallel=data"]),
    "pipeline": (2, ["parallel=pipeline"]),
    "trunk": (1, ["model.shared_trunk=true"]),
    "trunk-pipeline": (2, ["parallel=pipeline", "model.shared_trunk=true"]),
}
#: Setups that need discrete actions.
DISCRETE_ONLY = ("trunk", "trunk-pipeline")


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


# --- processes -------------------------------------------------------------------------
def run_setup(env: str, critic: str, setup: str, updates: int) -> dict[str, Any]:
    """Train ``updates`` updates with ``setup``; frames/s from the first logged row on."""
    from rlhc.builders import Layout

    processes, extra = SETUPS[setup]
    layout = Layout.from_config(compose_config(env, critic, []))
    overrides = [f"env={env}", f"critic={critic}", *extra,
                 *run_overrides(updates * layout.frames_per_batch)]  # fmt: skip
    launcher = TORCHRUN if processes > 1 else [sys.executable]
    with tempfile.TemporaryDirectory(prefix=f"bench_{setup}_") as tmp:
        command = [*launcher, "-m", "rlhc.run", *overrides, f"hydra.run.dir={tmp}/run"]
        done = subprocess.run(command, capture_output=True, text=True, cwd=tmp)
        if done.returncode != 0:
            raise RuntimeError(f"{' '.join(command)} failed:\n{done.stderr[-3000:]}")
        rows = read_metrics(Path(tmp) / "run")
    if len(rows) < 2:
        raise RuntimeError(f"{setup}: {len(rows)} metrics row(s); raise --updates")
    frames = rows[-1]["frames"] - rows[0]["frames"]
    seconds = rows[-1]["wall_time"] - rows[0]["wall_time"]
    return {"env": env, "critic": critic, "setup": setup, "processes": processes,
            "frames_per_s": frames / seconds, "frames": frames, "seconds": seconds,
            "env_steps_per_s": statistics.mean(r["env_steps_per_s"] for r in rows[1:]),
            "worlds": layout.num_envs, "frames_per_batch": layout.frames_per_batch}  # fmt: skip


def run_overrides(max_steps: int) -> list[str]:
    """Table 3 untouched (its summary period too); the length, CSV only, no checkpoints."""
    return [
        f"algo.max_steps={max_steps}",
        "logger.backends=[csv]",
        "logger.progress=false",
        "checkpoint_freq=1000000000",  # one checkpoint, at the end, outside the timing
    ]


def read_metrics(run_dir: Path) -> list[dict[str, float]]:
    with (run_dir / "metrics.csv").open() as file:
        return [{k: float(v) for k, v in row.items() if v not in ("", None)} for row in csv.DictReader(file)]  # fmt: skip


# --- the arithmetic ceiling ------------------------------------------------------------
def gemm_gflops(rows: int, width: int, seconds: float = 1.0) -> float:
    """fp32 GFLOP/s of ``[rows, width] @ [width, width]`` on one thread."""
    import torch

    threads = torch.get_num_threads()
    torch.set_num_threads(1)
    a, b = torch.randn(rows, width), torch.randn(width, width)
    for _ in range(20):
        a @ b
    count, start = 0, time.perf_counter()
    while time.perf_counter() - start < seconds:
        for _ in range(20):
            a @ b
        count += 20
    elapsed = time.perf_counter() - start
    torch.set_num_threads(threads)
    return 2.0 * rows * width * width * count / elapsed / 1e9


def ceiling(env: str, critic: str, overrides: list[str]) -> dict[str, Any]:
    """FLOP per frame of the configured networks and the frames/s one core allows."""
    from rlhc.builders import Layout
    from rlhc.flops import training_flops

    cfg = compose_config(env, critic, overrides)
    layout = Layout.from_config(cfg)
    cost = training_flops(cfg)
    # The minibatch's rows through a hidden layer: the GEMM an update is made of.
    rows = layout.minibatch_frames * layout.agents_per_world
    gflops = gemm_gflops(rows, cfg.model.hidden_size)
    per_frame = cost.collection + cost.update
    return {"flop_per_frame": per_frame, "collection_flop_per_frame": cost.collection,
            "update_flop_per_frame": cost.update, "gemm_rows": rows,
            "gemm_width": cfg.model.hidden_size, "gemm_gflops_one_core": gflops,
            "ceiling_frames_per_s_one_core": gflops * 1e9 / per_frame}  # fmt: skip


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

    timed: Any = timed_trainer_class()

    class WrapperTrainer(timed):
        # Same train() and update() as the project's trainer; only the env differs.
        def update(self, batch: Any) -> dict[str, float]:
            # TorchRL's batched envs raise torch's thread count when they close
            # (BatchedEnvBase.close: + num_workers); seen here before the last update,
            # which then ran 2 OpenMP threads and took 25-50x longer on the loaded
            # machine. Keep the configured count, as the rlhc trainer has it.
            torch.set_num_threads(self.cfg.threads)
            return super().update(batch)

        def save(self) -> Path:  # the wrapper env has no game state to checkpoint
            return self.run_dir

    env = make_wrapper_env(cfg, Layout.from_config(cfg).num_envs)
    return WrapperTrainer(cfg, run_dir, env=env)


# --- measuring a route, in this process ---------------------------------------------------
def timed_trainer_class() -> type:
    """A :class:`~rlhc.trainer.Trainer` that records process CPU time per update.

    With one torch thread and a single-process env, CPU seconds are the seconds the
    loop actually ran, so frames per CPU-second hardly depends on the machine's load.
    """
    from rlhc.trainer import Trainer

    class Timed(Trainer):
        def __init__(self, *args: Any, **kwargs: Any) -> None:
            super().__init__(*args, **kwargs)
            #: CPU seconds of every update (:meth:`update`, the public seam).
            self.update_cpu: list[float] = []

        def update(self, batch: Any) -> dict[str, float]:
            start = time.process_time()
            out = super().update(batch)
            self.update_cpu.append(time.process_time() - start)
            return out

    return Timed


def instrument(trainer: Any) -> dict[str, list[float]]:
    """Record process CPU time per iteration and per update (wall time is in metrics.csv).

    ``trainer`` is built from :func:`timed_trainer_class`, which records the updates;
    an iteration ends at its row of metrics (one log per iteration, see bench_route).
    """
    cpu: dict[str, list[float]] = {"iteration": [], "update": trainer.update_cpu}
    marks = [time.process_time()]
    log = trainer.logger.log

    def timed_log(step: int, metrics: dict[str, float]) -> None:
        marks.append(time.process_time())
        cpu["iteration"].append(marks[-1] - marks[-2])
        log(step, metrics)

    trainer.logger.log = timed_log
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

    layout = Layout.from_config(compose_config(env, critic, []))
    cfg = compose_config(env, critic, bench_overrides(warmup + iterations, layout.frames_per_batch))
    with tempfile.TemporaryDirectory(prefix=f"bench_{route}_") as tmp:
        run_dir = Path(tmp)
        start = time.perf_counter()
        if route == "rlhc":
            trainer = timed_trainer_class()(cfg, run_dir)
        else:
            trainer = wrapper_trainer(cfg, run_dir)
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
    ("update: value estimator (critics + GAE)", r"objectives/value\.py"),
    ("collect: env step (game, numpy/pymunk)", r"rlhc/envs/(soccer|tennis)/|pettingzoo_adapter|pymunk"),
    ("collect: env adapter (arrays to TensorDict)", r"rlhc/envs/torchrl_adapter\.py|libs/pettingzoo\.py"),
    ("collect: policy forward", r"collectors/.*;.*(tensordict/nn|torchrl/modules)"),
    ("collect: TorchRL/TensorDict overhead", r"torchrl/(collectors|envs)/"),
    ("update: loss forward", r"objectives/(ppo|weighting)\.py|torchrl/objectives/"),
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


def write_results(path: Path, payload: dict[str, Any]) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(payload, indent=2) + "\n")


def summarise(
    runs: list[dict[str, Any]], ceilings: dict[str, dict[str, Any]]
) -> list[dict[str, Any]]:
    """Per env and setup: median frames/s, and the median of the per-round ratios to ``one``."""
    rows = []
    for env, setup in dict.fromkeys((r["env"], r["setup"]) for r in runs):
        mine = [r for r in runs if (r["env"], r["setup"]) == (env, setup)]
        ratios = []
        for run in mine:
            base = [
                r for r in runs if (r["env"], r["setup"], r["round"]) == (env, "one", run["round"])
            ]
            if base:
                ratios.append(run["frames_per_s"] / base[0]["frames_per_s"])
        ceiling = ceilings[env]["ceiling_frames_per_s_one_core"] * mine[0]["processes"]
        rate = statistics.median(r["frames_per_s"] for r in mine)
        rows.append({"env": env, "setup": setup, "processes": mine[0]["processes"],
                     "frames_per_s": rate, "per_round": [round(r["frames_per_s"], 1) for r in mine],
                     "ratio_vs_one": statistics.median(ratios) if ratios else None,
                     "ratios_per_round": [round(x, 3) for x in ratios],
                     "ceiling_frames_per_s": ceiling, "share_of_ceiling": rate / ceiling})  # fmt: skip
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--env", nargs="+", default=["soccer", "tennis"])
    parser.add_argument("--critic", default="hierarchical")
    parser.add_argument("--setups", nargs="+", default=list(SETUPS), choices=list(SETUPS))
    parser.add_argument("--updates", type=int, nargs=2, default=[13, 22], metavar=("SOCCER", "TENNIS"),
                        help="updates per run (timed from the first summary row: 2 and 7 updates)")  # fmt: skip
    parser.add_argument("--iterations", type=int, default=4, help="timed updates, --wrapper")
    parser.add_argument("--warmup", type=int, default=1, help="updates not timed, --wrapper")
    parser.add_argument("--repeats", type=int, default=1, help="rounds over the setups")
    parser.add_argument("--wrapper", action="store_true", help="add the PettingZooWrapper route")
    parser.add_argument("--breakdown", type=Path, help="summarise a py-spy raw profile and exit")
    parser.add_argument("--output", type=Path, default=RESULTS)
    args = parser.parse_args()
    if args.breakdown is not None:
        breakdown(args.breakdown)
        return

    load_before = os.getloadavg()
    ceilings = {env: ceiling(env, args.critic, []) for env in args.env}
    runs = []
    for round_ in range(args.repeats):
        for env in args.env:
            discrete = env == "soccer"
            for setup in args.setups:
                if setup in DISCRETE_ONLY and not discrete:
                    continue
                updates = args.updates[0] if env == "soccer" else args.updates[1]
                run = run_setup(env, args.critic, setup, updates)
                run["round"] = round_
                runs.append(run)
                print(f"round {round_} {env:7} {setup:15} {run['frames_per_s']:>8,.0f} frames/s "
                      f"(env {run['env_steps_per_s']:,.0f} steps/s)", flush=True)  # fmt: skip
    for env in args.env:  # the GEMM rate again, after the runs: the machine may have changed
        ceilings[env]["gemm_gflops_one_core_after"] = gemm_gflops(
            ceilings[env]["gemm_rows"], ceilings[env]["gemm_width"]
        )
    rows = summarise(runs, ceilings)
    print(
        f"\n{'env':7} {'setup':15} {'procs':>5} {'frames/s':>9} {'vs one':>7} {'ceiling':>9} {'share':>6}"
    )
    for row in rows:
        ratio = row["ratio_vs_one"]
        print(f"{row['env']:7} {row['setup']:15} {row['processes']:>5} {row['frames_per_s']:>9,.0f} "
              f"{'' if ratio is None else f'{ratio:.2f}x':>7} {row['ceiling_frames_per_s']:>9,.0f} "
              f"{row['share_of_ceiling']:>6.0%}")  # fmt: skip
    for env, info in ceilings.items():
        print(f"{env}: {info['flop_per_frame'] / 1e6:.2f} MFLOP per frame "
              f"({info['collection_flop_per_frame'] / 1e6:.2f} collect, "
              f"{info['update_flop_per_frame'] / 1e6:.2f} update); GEMM "
              f"[{info['gemm_rows']}x{info['gemm_width']}]@[{info['gemm_width']}x{info['gemm_width']}] "
              f"{info['gemm_gflops_one_core']:.1f} GFLOP/s on one core before the runs, "
              f"{info['gemm_gflops_one_core_after']:.1f} after")  # fmt: skip
    wrapper = []
    if args.wrapper:
        for env in args.env:
            ours = bench_route("rlhc", env, args.critic, args.iterations, args.warmup)
            theirs = bench_route("wrapper", env, args.critic, max(1, args.iterations // 4), 1)
            theirs["ratio_rlhc_vs_wrapper"] = (
                ours["train_frames_per_s"] / theirs["train_frames_per_s"]
            )
            wrapper += [ours, theirs]
    meta = {"machine": platform.machine(), "cpus": multiprocessing.cpu_count(),
            "python": platform.python_version(), "date": time.strftime("%Y-%m-%d %H:%M %Z"),
            "loadavg_before": load_before, "loadavg_after": os.getloadavg(),
            "updates": args.updates, "repeats": args.repeats,
            "command": " ".join([Path(sys.executable).name, *sys.argv])}  # fmt: skip
    write_results(args.output, {"measured": meta, "summary": rows, "ceilings": ceilings,
                                "runs": runs, "wrapper_route": wrapper})  # fmt: skip
    print(f"wrote {args.output}")


if __name__ == "__main__":
    main()
