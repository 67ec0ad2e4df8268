"""The peer check: this package's IPPO and centralised critic against BenchMARL's IPPO and
MAPPO, on the same tasks, frames, hyperparameters and seeds.

BenchMARL (1.5.2, on TorchRL 0.11) cannot share this package's environment (TorchRL
0.14), so ``install`` makes it its own virtual environment, ``.venv-peer``, with the
same CPU torch. Each BenchMARL run is ``benchmarks/peer_benchmarl.py`` in that
environment: BenchMARL's own experiment, algorithm, model and task configs, as published,
but for the frame budget and no evaluation, rendering, loggers or checkpoints. Each run of
this package is ``python -m rlhc.run`` with the preset of ``conf/recipe/<source>/paper.yaml``
(BenchMARL's on-policy experiment in this package's units), BenchMARL's task options read
from its task yaml, its 10 worlds per update, and

=========  ==============================================  =================
algorithm  this package                                    BenchMARL
=========  ==============================================  =================
``ippo``   ``critic=ppo`` (each agent's own obs)            ``IppoConfig``
``mappo``  ``critic=manager env.manager_view=world|state``  ``MappoConfig``
=========  ==============================================  =================

(one critic value per world, the output of BenchMARL's centralised critic with shared
parameters, from its input: the env's global ``state`` on MPE, where BenchMARL's tasks
have one; on VMAS, which has none, the group's observations in index order, ``world``.)

Both log, per update, each group's mean return over the episodes that ended in it. A
run's score is the mean of its last five updates (30,000 frames); ``report`` compares, per
task and algorithm, this package's mean over seeds with the peer's 95 % interval, and the
frames per second of whole runs (start-up included), one process per core for both.

Usage:
    python -m benchmarks.peer_check install
    python -m benchmarks.peer_check run --tasks vmas/navigation --seeds 0 1 2 \
        --frames 300000 --jobs 2
    python -m benchmarks.peer_check report

Runs are resumable: a finished run leaves ``done.json`` and is skipped; this package's
runs resume from their checkpoints (``resume=auto``), BenchMARL's start again.
"""

from __future__ import annotations

import argparse
import csv
import json
import math
import os
import shutil
import statistics
import subprocess
import sys
import time
from collections.abc import Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parent.parent
PEER_VENV = ROOT / ".venv-peer"
RESULTS = ROOT / "benchmarks" / "results" / "peer"
#: What ``install`` puts in the peer's environment (torch first: the CPU wheel, as make
#: install). BenchMARL's MPE tasks are TorchRL's ``PettingZooEnv(task=...)``, which finds
#: them in ``pettingzoo.mpe``: PettingZoo 1.24.3 is the last release that has it (MPE now
#: lives in ``mpe2``, which this package's runs use: mpe2 1.1.1 adds type annotations and
#: opt-in options (curriculum, nearest neighbours) and is the same simulation with them off,
#: as a diff of simple_spread, simple_tag and the core shows).
PEER_PACKAGES = (
    ("torch==2.13.0",),
    ("benchmarl==1.5.2", "vmas==1.5.2", "pettingzoo[mpe]==1.24.3", "torch==2.13.0"),
)
#: BenchMARL's base_experiment.yaml, on-policy: frames per update and per minibatch, worlds.
FRAMES_PER_UPDATE, FRAMES_PER_MINIBATCH, WORLDS = 6000, 400, 10
#: The updates a run's score averages (its last 30,000 frames).
LAST_UPDATES = 5
IMPLEMENTATIONS = ("rlhc", "benchmarl")
ALGORITHMS = {
    "ippo": ["critic=ppo"],
    "mappo": ["critic=manager"],
}
#: The manager view of ``mappo`` by source. BenchMARL's MAPPO critic reads the env's global
#: state where its task has one (``Mappo.get_critic``: ``state_spec``; its MPE tasks all
#: have one, ``PettingZooClass.has_state``), else the group's observations (VMAS). On
#: simple_spread the two are equal (MPE's ``state()`` concatenates every agent's
#: observation and there is one group); on simple_tag the state also holds the other group's.
MAPPO_VIEWS = {"vmas": "world", "pettingzoo": "state"}
TASKS = ("vmas/navigation", "vmas/balance", "pettingzoo/simple_spread", "pettingzoo/simple_tag")
#: Student's t, two-sided 95 %, by degrees of freedom.
T95 = {1: 12.706, 2: 4.303, 3: 3.182, 4: 2.776, 5: 2.571, 6: 2.447, 7: 2.365, 8: 2.306, 9: 2.262}


@dataclass(frozen=True)
class Job:
    task: str
    algorithm: str
    implementation: str
    seed: int
    frames: int

    @property
    def directory(self) -> Path:
        name = self.task.replace("/", "_")
        return (
            RESULTS
            / "runs"
            / name
            / f"{self.implementation}_{self.algorithm}"
            / f"seed_{self.seed}"
        )


# --- the peer's environment -------------------------------------------------------------
def install() -> None:
    """Create ``.venv-peer`` with BenchMARL and the tasks' libraries (CPU torch)."""
    if not (PEER_VENV / "bin" / "python").exists():
        subprocess.run([sys.executable, "-m", "venv", str(PEER_VENV)], check=True)
    pip = [str(PEER_VENV / "bin" / "python"), "-m", "pip", "install", "--quiet"]
    for packages in PEER_PACKAGES:
        subprocess.run([*pip, *packages], check=True)


def task_options(task: str) -> dict[str, object]:
    """BenchMARL's options of ``task`` (``benchmarl/conf/task/<source>/<task>.yaml``)."""
    import yaml

    (path,) = PEER_VENV.glob(f"lib/python*/site-packages/benchmarl/conf/task/{task}.yaml")
    options = yaml.safe_load(path.read_text())
    options.pop("defaults", None)
    return options


def rlhc_overrides(task: str) -> list[str]:
    """``rlhc.run`` overrides for BenchMARL's ``task`` at its on-policy settings."""
    from rlhc.building.builders import group_names
    from rlhc.envs import make_env

    source, _ = task.split("/")
    options = task_options(task)
    if source == "vmas":
        env = [f"env.scenario={task.split('/')[1]}", f"env.max_cycles={options.pop('max_steps')}"]
        build: dict[str, Any] = {
            "scenario": task.split("/")[1],
            **({"kwargs": options} if options else {}),
        }
    else:
        name = options.pop("task")
        # BenchMARL prefers continuous actions where a task has both (prefer_continuous_actions).
        options["continuous_actions"] = True
        env = [f"env.factory=mpe2.{name}:parallel_env"]
        build = {"factory": f"mpe2.{name}:parallel_env", "kwargs": options}
    probe = make_env(source, num_envs=1, seed=0, **build)
    largest = max(probe.full_action_spec[group].shape[-1] for group in group_names(probe))
    probe.close()
    kwargs = "{" + ", ".join(f"{key}: {json.dumps(value)}" for key, value in options.items()) + "}"
    return [
        f"env={source}",
        *env,
        f"env.kwargs={kwargs}",
        f"env.num_envs={WORLDS}",
        f"algo.buffer_size={FRAMES_PER_UPDATE * largest}",
        f"algo.batch_size={FRAMES_PER_MINIBATCH * largest}",
    ]


def algorithm_overrides(job: Job) -> list[str]:
    """``rlhc.run`` overrides for ``job``'s algorithm on its task's source."""
    if job.algorithm == "mappo":
        view = MAPPO_VIEWS[job.task.split("/")[0]]
        return [*ALGORITHMS[job.algorithm], f"env.manager_view={view}"]
    return list(ALGORITHMS[job.algorithm])


# --- running ------------------------------------------------------------------------------
def command(job: Job, directory: Path | None = None) -> list[str]:
    """The command line that trains ``job`` into ``directory`` (its own by default)."""
    directory = directory or job.directory
    if job.implementation == "benchmarl":
        return [
            str(PEER_VENV / "bin" / "python"),
            str(ROOT / "benchmarks" / "peer_benchmarl.py"),
            f"--task={job.task}",
            f"--algorithm={job.algorithm}",
            f"--seed={job.seed}",
            f"--frames={job.frames}",
            f"--out={directory}",
        ]
    return [
        sys.executable,
        "-m",
        "rlhc.run",
        *rlhc_overrides(job.task),
        *algorithm_overrides(job),
        f"seed={job.seed}",
        f"algo.max_steps={job.frames}",
        "threads=1",
        f"logger.summary_freq={FRAMES_PER_UPDATE}",
        f"checkpoint_freq={5 * FRAMES_PER_UPDATE}",  # a killed run loses at most 5 updates
        "logger.backends=[csv]",
        "logger.progress=false",
        "resume=auto",
        f"hydra.run.dir={directory}",
    ]


def run_job(job: Job, directory: Path | None = None) -> str:
    """Train ``job`` into ``directory`` (its own by default) unless it is done there."""
    directory = directory or job.directory
    done = directory / "done.json"
    if done.exists():
        return f"{job}: done before"
    if job.implementation == "benchmarl" and directory.exists():
        shutil.rmtree(directory)  # BenchMARL starts again
    directory.mkdir(parents=True, exist_ok=True)
    env = {**os.environ, "OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"}
    start = time.perf_counter()
    with (directory / "stdout.log").open("a") as log:
        result = subprocess.run(
            command(job, directory), stdout=log, stderr=subprocess.STDOUT, env=env, cwd=ROOT
        )
    seconds = time.perf_counter() - start
    if result.returncode != 0:
        return f"{job}: FAILED ({result.returncode}), see {directory / 'stdout.log'}"
    if job.implementation == "rlhc":
        write_rlhc_curve(directory)
    done.write_text(json.dumps({"frames": job.frames, "seconds": seconds}) + "\n")
    return f"{job}: {seconds:.0f} s"


def write_rlhc_curve(directory: Path) -> None:
    """``curve.csv`` (frames, seconds, each group's mean return) from ``metrics.csv``."""
    with (directory / "metrics.csv").open() as file:
        rows = list(csv.DictReader(file))
    groups = sorted(key.split("/")[0] for key in rows[0] if key.endswith("/cumulative_reward"))
    with (directory / "curve.csv").open("w", newline="") as file:
        writer = csv.writer(file)
        writer.writerow(["frames", "seconds", *groups])
        for row in rows:
            returns = (row.get(f"{g}/cumulative_reward", "") for g in groups)
            writer.writerow([row["frames"], row["wall_time"], *returns])


def steady_rate(directory: Path) -> float:
    """Frames per second between the first and the last update (start-up left out)."""
    frames, seconds, _ = read_curve(directory)
    return (frames[-1] - frames[0]) / (seconds[-1] - seconds[0])


def check_peer_venv() -> None:
    """Exit 2 with one line if ``install`` has not made the peer's environment."""
    if not (PEER_VENV / "bin" / "python").exists():
        print(
            f"peer_check: error: {PEER_VENV} is missing; create it with "
            "python -m benchmarks.peer_check install",
            file=sys.stderr,
        )
        raise SystemExit(2)


def run(args: argparse.Namespace) -> None:
    check_peer_venv()
    jobs = [
        Job(task, algorithm, implementation, seed, args.frames)
        for seed in args.seeds
        for task in args.tasks
        for algorithm in args.algorithms
        for implementation in args.implementations
    ]
    # BenchMARL's runs are the longest: start them first so both cores stay busy to the end.
    jobs.sort(key=lambda job: job.implementation != "benchmarl")
    with ThreadPoolExecutor(args.jobs) as pool:
        for line in pool.map(run_job, jobs):
            print(line, flush=True)


# --- the report ---------------------------------------------------------------------------
def read_curve(directory: Path) -> tuple[list[float], list[float], dict[str, list[float]]]:
    """Frames, seconds and each group's mean return, per update."""
    with (directory / "curve.csv").open() as file:
        rows = list(csv.DictReader(file))
    frames = [float(row["frames"]) for row in rows]
    seconds = [float(row["seconds"]) for row in rows]
    groups = {
        key: [float(row[key] or "nan") for row in rows]
        for key in rows[0]
        if key not in ("frames", "seconds")
    }
    return frames, seconds, groups


def score(values: Sequence[float]) -> float:
    tail = [v for v in values[-LAST_UPDATES:] if not math.isnan(v)]
    return statistics.fmean(tail) if tail else float("nan")


def interval(values: Sequence[float]) -> tuple[float, float, float]:
    mean = statistics.fmean(values)
    if len(values) < 2:
        return mean, float("nan"), float("nan")
    half = T95[len(values) - 1] * statistics.stdev(values) / math.sqrt(len(values))
    return mean, mean - half, mean + half


def report(args: argparse.Namespace) -> None:
    """``summary.json``, ``table.md`` and ``curves.png`` of the finished runs."""
    summary: dict[str, dict[str, Any]] = {}
    runs = RESULTS / "runs"
    for task_dir in sorted(p for p in runs.iterdir() if p.is_dir()):
        for arm in sorted(p for p in task_dir.iterdir() if p.is_dir()):
            seeds = sorted(p for p in arm.iterdir() if (p / "done.json").exists())
            if not seeds:
                continue
            per_seed: dict[str, list[float]] = {}
            speeds = []
            for seed in seeds:
                if arm.name.startswith("rlhc"):
                    write_rlhc_curve(seed)  # derived from the committed metrics.csv
                _, _, groups = read_curve(seed)
                for group, values in groups.items():
                    per_seed.setdefault(group, []).append(score(values))
                speeds.append(steady_rate(seed))
            summary[f"{task_dir.name}/{arm.name}"] = {
                "seeds": [int(s.name.split("_")[1]) for s in seeds],
                "frames": json.loads((seeds[0] / "done.json").read_text())["frames"],
                "score": {
                    g: dict(zip(("mean", "low", "high"), interval(v), strict=True))
                    for g, v in per_seed.items()
                },
                "per_seed": per_seed,
                "frames_per_s": statistics.median(speeds),
            }
    RESULTS.mkdir(parents=True, exist_ok=True)
    (RESULTS / "summary.json").write_text(json.dumps(summary, indent=2) + "\n")
    lines = [
        "| task | algorithm | group | seeds | frames | rlhc (mean) | BenchMARL mean [95 %] | verdict | frames/s rlhc / BenchMARL |",
        "|---|---|---|---|---:|---:|---:|---|---:|",
    ]
    for key, ours in summary.items():
        task_name, arm_name = key.split("/")
        implementation, algorithm = arm_name.split("_", 1)
        peer = summary.get(f"{task_name}/benchmarl_{algorithm}")
        if implementation != "rlhc" or peer is None:
            continue
        for group, s in ours["score"].items():
            p = peer["score"].get(group)
            if p is None:
                continue
            if math.isnan(p["low"]):
                verdict = "n/a (one peer seed)"
            elif s["mean"] >= p["low"]:
                verdict = "within or above"
            else:
                verdict = f"below by {p['low'] - s['mean']:.3f}"
            lines.append(
                f"| {task_name} | {algorithm} | {group} | {len(ours['seeds'])} / {len(peer['seeds'])} "
                f"| {ours['frames']:,} | {s['mean']:.3f} | {p['mean']:.3f} [{p['low']:.3f}, {p['high']:.3f}] "
                f"| {verdict} | {ours['frames_per_s']:,.0f} / {peer['frames_per_s']:,.0f} |"
            )
    (RESULTS / "table.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))
    plot(summary)


def plot(summary: dict[str, dict[str, Any]]) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    tasks = sorted({key.split("/")[0] for key in summary})
    figure, axes = plt.subplots(1, len(tasks), figsize=(5 * len(tasks), 3.6), squeeze=False)
    for axis, task in zip(axes[0], tasks, strict=True):
        for arm_dir in sorted((RESULTS / "runs" / task).iterdir()):
            seeds = sorted(p for p in arm_dir.iterdir() if (p / "done.json").exists())
            if not seeds:
                continue
            curves = [read_curve(seed) for seed in seeds]
            frames = curves[0][0]
            n = min(len(c[0]) for c in curves)
            # One line per arm: the mean over seeds of the mean over groups.
            mean = [
                statistics.fmean(statistics.fmean(g[i] for g in c[2].values()) for c in curves)
                for i in range(n)
            ]
            style = "-" if arm_dir.name.startswith("rlhc") else "--"
            axis.plot([f / 1e6 for f in frames[:n]], mean, style, label=arm_dir.name)
        axis.set_title(task.replace("_", "/", 1))
        axis.set_xlabel("frames (M)")
        axis.set_ylabel("episode return (mean over groups)")
        axis.legend(fontsize=7)
    figure.tight_layout()
    figure.savefig(RESULTS / "curves.png", dpi=110)


def speed(args: argparse.Namespace) -> None:
    """Frames per second of both sides on one task, one process at a time, rounds
    interleaved (the order alternates), written to ``speed.json``."""
    check_peer_venv()
    rates: dict[str, list[float]] = {implementation: [] for implementation in IMPLEMENTATIONS}
    scratch = ROOT / "benchmarks" / "results" / "tmp" / "peer_speed"
    for round_ in range(args.rounds):
        order = IMPLEMENTATIONS if round_ % 2 == 0 else IMPLEMENTATIONS[::-1]
        for implementation in order:
            job = Job(args.task, args.algorithm, implementation, seed=0, frames=args.frames)
            directory = scratch / f"round_{round_}_{implementation}"
            if directory.exists():
                shutil.rmtree(directory)
            print(run_job(job, directory), flush=True)
            rates[implementation].append(steady_rate(directory))
    result = {
        "task": args.task,
        "algorithm": args.algorithm,
        "frames": args.frames,
        "frames_per_s": rates,
        "median": {key: statistics.median(values) for key, values in rates.items()},
        "ratio_per_round": [
            ours / peer for ours, peer in zip(rates["rlhc"], rates["benchmarl"], strict=True)
        ],
        "date": time.strftime("%Y-%m-%d"),
    }
    RESULTS.mkdir(parents=True, exist_ok=True)
    name = f"speed_{args.task.replace('/', '_')}_{args.algorithm}.json"
    (RESULTS / name).write_text(json.dumps(result, indent=2) + "\n")
    print(json.dumps(result["median"]), "ratio per round:", result["ratio_per_round"])


def main(argv: Sequence[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    commands = parser.add_subparsers(dest="command", required=True)
    commands.add_parser("install", help="create .venv-peer with BenchMARL")
    runner = commands.add_parser("run", help="train the missing runs")
    runner.add_argument("--tasks", nargs="+", choices=TASKS, default=list(TASKS))
    runner.add_argument(
        "--algorithms", nargs="+", choices=sorted(ALGORITHMS), default=sorted(ALGORITHMS)
    )
    runner.add_argument(
        "--implementations", nargs="+", choices=IMPLEMENTATIONS, default=list(IMPLEMENTATIONS)
    )
    runner.add_argument("--seeds", nargs="+", type=int, default=[0, 1, 2])
    runner.add_argument("--frames", type=int, default=3_000_000)
    runner.add_argument("--jobs", type=int, default=2, help="processes at once (one per core)")
    commands.add_parser("report", help="summary.json, table.md and curves.png of finished runs")
    timer = commands.add_parser("speed", help="frames/s of both sides, rounds interleaved")
    timer.add_argument("--task", choices=TASKS, default="vmas/navigation")
    timer.add_argument("--algorithm", choices=sorted(ALGORITHMS), default="mappo")
    timer.add_argument("--frames", type=int, default=60_000)
    timer.add_argument("--rounds", type=int, default=2)
    args = parser.parse_args(argv)
    {"install": lambda _: install(), "run": run, "report": report, "speed": speed}[args.command](
        args
    )


if __name__ == "__main__":
    main()
