"""Cross-play of a study's configurations on an environment of several groups.

On a contest (MPE ``simple_tag``: predators against prey) every group of a run learns
with the run's critic, so comparing two configurations' returns compares two contests.
This plays, for every pair of configurations and every seed both completed, the four
lineups of :func:`rlhc.evaluation.cross_play.cross_play` (each group played by either
run), and scores each group by its *advantage*: how much more the group returns when the
first configuration plays it than when the second does, against the same opponents.

The lineups' mean returns go to ``<root>/cross_play.csv`` (one row per seed, pair and
lineup), small enough to commit; the report reads them from there and plays nothing.

Usage:
    python -m benchmarks.cross_play benchmarks/results/learning/pettingzoo_simple_tag
    python -m benchmarks.cross_play benchmarks/results/peer/runs/pettingzoo_simple_tag \
        --configs rlhc_ippo rlhc_mappo --episodes 100

A root holds ``<config>/seed_<s>/`` run directories; a seed counts once both runs have
their ``final_team.pt``. A pair and seed already in the file is not played again.
"""

from __future__ import annotations

import argparse
import csv
import itertools
import sys
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path

#: The file, in the root of the runs.
FILE = "cross_play.csv"
#: Its columns besides ``<group>_plays`` and ``<group>_return`` of every group.
KEYS = ("seed", "first", "second", "episodes")


@dataclass(frozen=True)
class Advantage:
    """One group's advantage of ``first`` over ``second`` at one seed."""

    group: str
    first: str
    second: str
    seed: int
    value: float


def seeds_of(root: Path, config: str) -> set[int]:
    """The seeds of ``config`` under ``root`` whose final team is written."""
    return {
        int(run.parent.name.removeprefix("seed_"))
        for run in (root / config).glob("seed_*/final_team.pt")
    }


def configs_of(root: Path) -> list[str]:
    """The configurations under ``root`` with a finished run, by name."""
    return sorted(p.name for p in root.iterdir() if p.is_dir() and seeds_of(root, p.name))


def read_rows(path: Path) -> list[dict[str, str]]:
    """The rows of a cross-play file (none if it does not exist)."""
    if not path.exists():
        return []
    with path.open(newline="") as f:
        return list(csv.DictReader(f))


def advantages(rows: Iterable[dict[str, str]]) -> list[Advantage]:
    """Each group's advantage per pair and seed
    (:func:`rlhc.evaluation.cross_play.group_advantage`), from a cross-play file's rows."""
    from rlhc.evaluation.cross_play import group_advantage

    means: dict[tuple[int, str, str], dict[tuple[str, ...], dict[str, float]]] = {}
    groups: list[str] = []
    for row in rows:
        groups = sorted(key.removesuffix("_plays") for key in row if key.endswith("_plays"))
        lineup = tuple(row[f"{g}_plays"] for g in groups)
        key = (int(row["seed"]), row["first"], row["second"])
        means.setdefault(key, {})[lineup] = {g: float(row[f"{g}_return"]) for g in groups}
    return [
        Advantage(
            group, first, second, seed, group_advantage(lineups, groups, group, first, second)
        )
        for (seed, first, second), lineups in sorted(means.items())
        for group in groups
    ]


def play(root: Path, configs: Sequence[str], episodes: int) -> Path:
    """Play every pair of ``configs`` at every seed both finished and not yet in the file
    (in either order); append their rows to ``<root>/cross_play.csv``."""
    from rlhc.evaluation.cross_play import cross_play

    path = root / FILE
    rows = read_rows(path)
    played = {(row["seed"], row["first"], row["second"]) for row in rows}
    for first, second in itertools.combinations(configs, 2):
        for seed in sorted(seeds_of(root, first) & seeds_of(root, second)):
            if {(str(seed), first, second), (str(seed), second, first)} & played:
                continue  # in either order
            runs = [str(root / config / f"seed_{seed}") for config in (first, second)]
            result = cross_play(runs, episodes, seed=seed)
            names = dict(zip(runs, (first, second), strict=True))
            for lineup in result.rows():
                rows.append(
                    {
                        "seed": str(seed),
                        "first": first,
                        "second": second,
                        "episodes": str(episodes),
                        **{f"{g}_plays": names[str(lineup[f"{g}_run"])] for g in result.groups},
                        **{f"{g}_return": str(lineup[f"{g}_return"]) for g in result.groups},
                    }
                )
            print(f"{root.name}: {first} vs {second}, seed {seed}: played", flush=True)
            write_rows(path, rows)
    return path


def write_rows(path: Path, rows: Sequence[dict[str, str]]) -> None:
    """Write ``rows`` whole, through a temporary file (a kill leaves the old file)."""
    columns = list(KEYS) + sorted({key for row in rows for key in row} - set(KEYS))
    temporary = path.with_suffix(".tmp")
    with temporary.open("w", newline="") as f:
        writer = csv.DictWriter(f, columns)
        writer.writeheader()
        writer.writerows(rows)
    temporary.replace(path)


def parse_args(argv: Sequence[str] | None = None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("root", type=Path, help="a directory of <config>/seed_<s>/ runs")
    parser.add_argument(
        "--configs", nargs="+", help="the configurations to pair (default: every finished one)"
    )
    parser.add_argument("--episodes", type=int, default=100, help="episodes per lineup")
    args = parser.parse_args(argv)
    if not args.root.is_dir():
        parser.error(f"root {str(args.root)!r} is not a directory")
    known = configs_of(args.root)
    args.configs = args.configs or known
    unknown = [c for c in args.configs if c not in known]
    if unknown:
        parser.error(f"--configs {unknown}: no finished run there; allowed: {known}")
    if len(args.configs) < 2:
        parser.error(f"--configs {args.configs}: cross-play needs two; finished: {known}")
    if args.episodes < 1:
        parser.error(f"--episodes {args.episodes}; allowed: >= 1")
    return args


def main(argv: Sequence[str] | None = None) -> None:
    import torch

    args = parse_args(argv)
    torch.set_num_threads(1)  # one process per core, as the runs
    path = play(args.root, args.configs, args.episodes)
    for advantage in summarise(advantages(read_rows(path))):
        print(advantage)


def per_seed(values: Iterable[Advantage]) -> dict[tuple[str, str, str], list[float]]:
    """``(group, first, second) -> [advantage at each seed]``, in the order first met."""
    seeds: dict[tuple[str, str, str], list[float]] = {}
    for value in values:
        seeds.setdefault((value.group, value.first, value.second), []).append(value.value)
    return seeds


def summarise(values: Sequence[Advantage]) -> list[str]:
    """One line per group and pair: the mean advantage over seeds [95% t]."""
    from rlhc.evaluation.stats import t_interval

    lines = []
    for (group, first, second), seeds in per_seed(values).items():
        interval = t_interval(seeds)
        spread = (
            f"[{interval.low:+.2f}, {interval.high:+.2f}] ({len(seeds)} seeds)"
            if len(seeds) > 1
            else "(1 seed, no interval)"
        )
        lines.append(f"{group}: {first} over {second} by {interval.mean:+.2f} {spread}")
    return lines


if __name__ == "__main__":
    main(sys.argv[1:])
