"""Reproduce the paper's comparison: RLHC vs PPO on tennis and soccer (+ extensions).

Runs every configuration of the study as a separate ``python -m rlhc.run`` process,
``--jobs`` at a time (one per core), each in
``benchmarks/results/reproduce/<study>/<config>/seed_<k>/``. A run whose final
checkpoint exists is skipped, so a killed reproduction continues where it stopped
(and an unfinished run resumes from its latest checkpoint).

Usage::

    python benchmarks/reproduce.py --jobs 2                 # the whole study (~11 M frames)
    python benchmarks/reproduce.py --study tennis --seeds 2 # a part of it
    python benchmarks/report.py                             # docs/RESULTS.md from the runs
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path

from rlhc.checkpoint import CHECKPOINT_DIR, LATEST, load_checkpoint

RESULTS = Path(__file__).resolve().parent / "results" / "reproduce"


@dataclass(frozen=True)
class Run:
    """One training run of the study."""

    study: str
    config: str
    seed: int
    overrides: tuple[str, ...]
    max_steps: int

    @property
    def run_dir(self) -> Path:
        return RESULTS / self.study / self.config / f"seed_{self.seed}"

    def is_done(self) -> bool:
        """Its latest checkpoint has reached ``max_steps`` frames."""
        latest = self.run_dir / CHECKPOINT_DIR / LATEST
        return latest.exists() and load_checkpoint(latest)["frames"] >= self.max_steps


#: study -> (config name -> overrides), seeds, frames per run (paper Table 3).
STUDIES: dict[str, tuple[dict[str, tuple[str, ...]], int, int]] = {
    "tennis": (
        {
            "ppo": ("env=tennis", "critic=ppo", "env.extended_obs=false"),
            "hierarchical": ("env=tennis", "critic=hierarchical", "env.extended_obs=false"),
            "ppo_extended": ("env=tennis", "critic=ppo", "env.extended_obs=true"),
            "hierarchical_extended": ("env=tennis", "critic=hierarchical", "env.extended_obs=true"),
        },
        5,
        200_000,
    ),
    "soccer": (
        {
            "ppo": ("env=soccer", "critic=ppo"),
            "hierarchical": ("env=soccer", "critic=hierarchical"),
        },
        5,
        500_000,
    ),
    "tennis_extensions": (
        {
            "manager": ("env=tennis", "critic=manager"),
            "mean": ("env=tennis", "critic=mean"),
            "hierarchical_k5": ("env=tennis", "critic=hierarchical", "critic.manager_interval=5"),
        },
        3,
        200_000,
    ),
}


def plan(studies: list[str], seeds: int | None) -> list[Run]:
    """Seed-major order, so that a partial reproduction compares configs on equal seeds."""
    runs = []
    for study in studies:
        configs, default_seeds, max_steps = STUDIES[study]
        for seed in range(seeds if seeds is not None else default_seeds):
            for config, overrides in configs.items():
                runs.append(Run(study, config, seed, overrides, max_steps))
    return runs


def code_version() -> str:
    """The git commit the run trains with (``+dirty`` with uncommitted changes)."""
    root = Path(__file__).resolve().parents[1]
    try:
        commit = subprocess.check_output(["git", "rev-parse", "HEAD"], cwd=root, text=True)
        dirty = subprocess.check_output(
            ["git", "status", "--porcelain", "--untracked-files=no", "rlhc", "conf"],
            cwd=root,
            text=True,
        )
    except (OSError, subprocess.CalledProcessError):
        return "unknown (not a git checkout)"
    return commit.strip() + ("+dirty" if dirty.strip() else "")


def execute(run: Run) -> tuple[Run, int, float]:
    """Train one run (resuming it if a checkpoint exists); returns its exit code and time."""
    run.run_dir.mkdir(parents=True, exist_ok=True)
    command = [
        sys.executable,
        "-m",
        "rlhc.run",
        *run.overrides,
        f"seed={run.seed}",
        f"algo.max_steps={run.max_steps}",
        "logger.backends=[csv]",
        "logger.progress=false",
        f"hydra.run.dir={run.run_dir}",
    ]
    if (run.run_dir / CHECKPOINT_DIR / LATEST).exists():
        command.append(f"resume={run.run_dir}")
    start = time.perf_counter()
    with (run.run_dir / "train.log").open("a") as log:
        log.write(f"code version: {code_version()}\n")
        log.flush()
        code = subprocess.call(command, stdout=log, stderr=subprocess.STDOUT)
    return run, code, time.perf_counter() - start


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--study", nargs="+", choices=sorted(STUDIES), default=list(STUDIES))
    parser.add_argument(
        "--seeds", type=int, default=None, help="seeds per config (default: study's)"
    )
    parser.add_argument("--jobs", type=int, default=2, help="runs in parallel (one per core)")
    args = parser.parse_args()

    todo = [run for run in plan(args.study, args.seeds) if not run.is_done()]
    print(f"{len(todo)} runs to do", flush=True)
    failures = 0
    with ThreadPoolExecutor(max_workers=args.jobs) as pool:
        for run, code, seconds in pool.map(execute, todo):
            status = "ok" if code == 0 else f"FAILED ({code}, see {run.run_dir / 'train.log'})"
            failures += code != 0
            print(
                f"{run.study}/{run.config}/seed_{run.seed}: {status} in {seconds:.0f} s", flush=True
            )
    sys.exit(1 if failures else 0)


if __name__ == "__main__":
    main()
