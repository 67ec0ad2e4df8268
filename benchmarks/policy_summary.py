"""Summarise trained tennis teams per policy: rallies, points won, KL per update.

For every ``<runs>/<policy>/seed_<s>`` run directory, reads what the evaluation
commands wrote into ``<evals>`` (``<policy>_<s>_scripted.json`` and ``_random.json``
from ``python -m rlhc.evaluate env=tennis home=<run> away=scripted|random matches=100``,
``<policy>_<s>_diag.txt`` from ``python -m rlhc.evaluation.diagnostics <run> --worlds
32 --decisions 1000``) and the run's ``metrics.csv``, and prints one JSON summary:
per seed and as the mean over seeds.

Usage:
    python -m benchmarks.policy_summary RUNS EVALS [--out FILE]
"""

from __future__ import annotations

import argparse
import csv
import json
import statistics
from pathlib import Path

#: What is summarised, by name: where it is read from.
MEASURES = (
    "hits_per_point",
    "hits_per_point_mode",
    "points_vs_scripted",
    "points_vs_random",
    "kl_last_tenth",
)


def kl_last_tenth(metrics: Path) -> float:
    """The mean ``kl_approx`` per update over the rows of the last tenth of the frames."""
    with metrics.open() as file:
        rows = [row for row in csv.DictReader(file) if row.get("racket/kl_approx")]
    last = max(float(row["frames"]) for row in rows)
    tail = [float(row["racket/kl_approx"]) for row in rows if float(row["frames"]) > 0.9 * last]
    return statistics.fmean(tail)


def summarise_run(run: Path, evals: Path, policy: str, seed: str) -> dict[str, float]:
    stem = evals / f"{policy}_{seed}"
    play = json.loads(Path(f"{stem}_diag.txt").read_text())
    scripted = json.loads(Path(f"{stem}_scripted.json").read_text())
    random = json.loads(Path(f"{stem}_random.json").read_text())
    return {
        "hits_per_point": play["hits_per_point"],
        "hits_per_point_mode": play["hits_per_point_mode"],
        "points_vs_scripted": scripted["points_won_rate"],
        "points_vs_random": random["points_won_rate"],
        "kl_last_tenth": kl_last_tenth(run / "metrics.csv"),
    }


def summarise(runs: Path, evals: Path) -> dict[str, dict]:
    summary: dict[str, dict] = {}
    for policy_dir in sorted(p for p in runs.iterdir() if p.is_dir()):
        seeds = {
            run.name: summarise_run(run, evals, policy_dir.name, run.name.removeprefix("seed_"))
            for run in sorted(policy_dir.glob("seed_*"))
        }
        if not seeds:
            continue
        mean = {m: statistics.fmean(s[m] for s in seeds.values()) for m in MEASURES}
        summary[policy_dir.name] = {"seeds": seeds, "mean": mean}
    return summary


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("runs", type=Path, help="holds <policy>/seed_<s>/ run directories")
    parser.add_argument("evals", type=Path, help="holds the evaluation outputs")
    parser.add_argument("--out", type=Path, help="also write the summary here")
    args = parser.parse_args(argv)
    text = json.dumps(summarise(args.runs, args.evals), indent=1)
    if args.out:
        args.out.write_text(text + "\n")
    print(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
