"""Training throughput at Table 3 on 1 and 2 processes, against plain torch and the ceiling.

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
| ``reference`` | none: :mod:`benchmarks.reference_loop`, in this process |

``reference`` is what the same arithmetic costs without a framework: a CleanRL-style
loop in plain torch (no TensorDict, TorchRL or Hydra) with the trainer's networks,
rollout, minibatches, epochs and optimiser, calling the game's batched numpy step; the
working tree's loop whatever the variant, timed after one warm-up update. It prints its
honesty checks: its minibatch step against a bare ``nn.Linear`` loop of its networks,
and its counted FLOP per frame against the trainer's.

Setups run one after another, round-robin over ``--repeats``, and every ratio compares
runs of the same round (the machine is shared: a ratio within one invocation is what
this measures): ``vs one`` and ``vs ref`` (``ratio_vs_one``, ``ratio_vs_reference``).
The ceiling: fp32 GEMM GFLOP/s on one core, measured in the same invocation at the
shapes of the configured minibatch, times the processes, divided by the FLOP per frame
of the configured networks (:func:`rlhc.building.flops.training_flops`: the actors to
collect, the value estimator and ``epochs`` forward-backward passes of the loss to train).

Before and after a change, in one invocation: ``--baseline REV`` adds the *variant*
``baseline``, the code at the git revision ``REV`` (checked out once with ``git worktree
add --detach`` into a temporary directory, removed at the end, and imported by its runs
through ``cwd`` and ``PYTHONPATH``), next to ``current``, the working tree as each run
starts. ``--variant NAME=OVERRIDES`` (repeatable) adds a variant of the working tree with
Hydra overrides appended to every run of it (quote several, space-separated). Every
round runs each setup once per variant, one after another (baseline, current, then the
``--variant`` ones in order); each variant's rate is compared with ``baseline``'s (or
``current``'s without ``--baseline``) of the same round and setup, and the median of those
per-round ratios is reported with each variant's median share of its ceiling (the
baseline's FLOP per frame and run length are taken from the working tree's config). The
Markdown table is printed and the JSON gets a ``comparison`` key; ``summary`` then holds
``current``'s runs only. ``--overrides`` are appended to every run of every variant, the
baseline's included: a preset compared before and after a change.

``--breakdown`` summarises a py-spy profile instead.

Examples:
    python benchmarks/train_throughput.py --env soccer tennis --repeats 2
    python benchmarks/train_throughput.py --env soccer --setups one reference --repeats 3
    python benchmarks/train_throughput.py --env soccer --setups one pipeline --updates 21 22
    python benchmarks/train_throughput.py --env tennis --setups one --repeats 3 \\
        --baseline HEAD~3 --out /tmp/before_after.json
    python benchmarks/train_throughput.py --env soccer --setups one --repeats 3 \\
        --variant ppo=critic=ppo --variant big="model.hidden_size=256 algo.epochs=4"
    python benchmarks/train_throughput.py --env tennis --setups one --repeats 3 \\
        --baseline HEAD~3 --overrides study=tennis_best resume=null
    py-spy record --format raw -o soccer.txt -- python benchmarks/train_throughput.py \\
        --env soccer --setups one --updates 41 22
    python benchmarks/train_throughput.py --breakdown soccer.txt
"""

from __future__ import annotations

import argparse
import contextlib
import csv
import json
import multiprocessing
import os
import platform
import re
import shlex
import statistics
import subprocess
import sys
import tempfile
import time
from collections import Counter
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

RESULTS = Path(__file__).parent / "results" / "train_throughput.json"
REPO = Path(__file__).resolve().parents[1]
TORCHRUN = [sys.executable, "-m", "torch.distributed.run", "--standalone", "--nproc_per_node=2"]
#: setup -> (processes, overrides)
SETUPS: dict[str, tuple[int, list[str]]] = {
    "one": (1, []),
    "data": (2, ["parallel=data"]),
    "pipeline": (2, ["parallel=pipeline"]),
    "reference": (1, []),  # not rlhc.run: benchmarks/reference_loop.py, in this process
}
#: Variant names the script gives itself: the code at ``--baseline`` and the working tree.
BASELINE, CURRENT = "baseline", "current"
VARIANT_NAME = re.compile(r"[A-Za-z0-9][A-Za-z0-9_.-]*")
VARIANT_FORM = "expected NAME=OVERRIDES (e.g. ppo=critic=ppo; overrides space-separated)"


# --- variants: the code and overrides a setup runs with -------------------------------
@dataclass(frozen=True)
class Variant:
    """What one run of a setup executes: a source tree and Hydra overrides appended."""

    name: str
    overrides: tuple[str, ...] = ()
    #: The tree ``python -m rlhc.run`` imports ``rlhc`` from; ``None``: the working tree.
    source: Path | None = None


def parse_variant(text: str) -> Variant:
    """``--variant NAME=OVERRIDES``: a variant of the working tree (argparse ``type``).

    OVERRIDES are Hydra overrides separated by spaces (an empty list runs the working
    tree again: an A/A check of the noise).

    >>> parse_variant("big=model.hidden_size=256 algo.epochs=4").overrides
    ('model.hidden_size=256', 'algo.epochs=4')
    """
    name, sep, rest = text.partition("=")
    if not sep or not VARIANT_NAME.fullmatch(name):
        raise argparse.ArgumentTypeError(f"{text!r}: {VARIANT_FORM}")
    if name in (BASELINE, CURRENT):
        raise argparse.ArgumentTypeError(f"{text!r}: the name {name!r} is reserved; {VARIANT_FORM}")
    try:
        overrides = tuple(shlex.split(rest))
    except ValueError as error:
        raise argparse.ArgumentTypeError(f"{text!r}: {error}; {VARIANT_FORM}") from None
    bad = [o for o in overrides if "=" not in o and not o.startswith("~")]
    if bad:
        raise argparse.ArgumentTypeError(
            f"{text!r}: {bad[0]!r} is not a Hydra override (KEY=VALUE); {VARIANT_FORM}"
        )
    return Variant(name, overrides)


def source_env(source: Path | None) -> dict[str, str] | None:
    """The environment of a run importing ``rlhc`` from ``source`` (``None``: inherited)."""
    if source is None:
        return None
    path = os.pathsep.join(p for p in (str(source), os.environ.get("PYTHONPATH", "")) if p)
    return {**os.environ, "PYTHONPATH": path}


def check_source(source: Path) -> None:
    """Fail unless a run started from ``source`` imports ``source``'s ``rlhc`` package."""
    done = subprocess.run(
        [sys.executable, "-c", "import rlhc; print(rlhc.__file__)"],
        capture_output=True, text=True, cwd=source, env=source_env(source),
    )  # fmt: skip
    if done.returncode != 0:
        raise RuntimeError(f"importing rlhc from {source} failed:\n{done.stderr[-3000:]}")
    imported = Path(done.stdout.strip()).resolve()
    if not imported.is_relative_to(source.resolve()):
        raise RuntimeError(f"a run started in {source} imports {imported}, not the baseline")


# --- git: the baseline revision ---------------------------------------------------------
def git(*args: str) -> str:
    """``git <args>`` in this repository; its stdout, stripped."""
    done = subprocess.run(["git", *args], capture_output=True, text=True, cwd=REPO)
    if done.returncode != 0:
        raise RuntimeError(f"git {' '.join(args)}: {done.stderr.strip()}")
    return done.stdout.strip()


def resolve_revision(rev: str) -> dict[str, str]:
    """``rev`` as a full commit hash, with its subject line."""
    commit = git("rev-parse", "--verify", "--end-of-options", f"{rev}^{{commit}}")
    return {"rev": rev, "commit": commit, "subject": git("log", "-1", "--format=%s", commit)}


def working_tree() -> dict[str, Any]:
    """What ``current`` ran: HEAD and the tracked files changed in the working tree."""
    modified = git("diff", "--name-only", "HEAD").splitlines()
    return {"head": git("rev-parse", "HEAD"), "modified": modified}


@contextlib.contextmanager
def baseline_worktree(commit: str) -> Iterator[Path]:
    """``commit`` checked out in a temporary ``git worktree``, removed on exit (errors too)."""
    with tempfile.TemporaryDirectory(prefix="bench_baseline_") as tmp:
        tree = Path(tmp) / "tree"
        git("worktree", "add", "--detach", str(tree), commit)
        try:
            yield tree
        finally:
            try:
                git("worktree", "remove", "--force", str(tree))
            except RuntimeError as error:  # the directory goes anyway; `git worktree prune`
                print(f"warning: {error}", file=sys.stderr)


def compose_config(env: str, critic: str, overrides: list[str]) -> Any:
    """The training config ``python -m rlhc.run env=… critic=… <overrides>`` would use."""
    from rlhc.config.train_schema import compose_config as compose

    return compose(f"env={env}", f"critic={critic}", *overrides)


# --- processes -------------------------------------------------------------------------
def run_setup(
    env: str,
    critic: str,
    setup: str,
    updates: int,
    variant_overrides: Sequence[str] = (),
    source: Path | None = None,
) -> dict[str, Any]:
    """Train ``updates`` updates with ``setup``; frames/s from the first logged row on
    (``reference``: after its first update).

    ``variant_overrides`` are appended to the command (the last value of a key wins);
    with ``source``, the run starts in that tree with it on ``PYTHONPATH``, so that it
    imports that tree's ``rlhc`` (the run directory stays in a temporary directory).
    """
    from rlhc.building.builders import Layout

    processes, extra = SETUPS[setup]
    if setup == "reference":  # this process, this tree: `benchmarks` importable as a script
        if str(REPO) not in sys.path:
            sys.path.append(str(REPO))
        from benchmarks.reference_loop import run_reference

        cfg = compose_config(env, critic, list(variant_overrides))
        return {"env": env, "critic": critic, "setup": setup, "processes": processes,
                **run_reference(cfg, updates)}  # fmt: skip
    layout = Layout.from_config(compose_config(env, critic, list(variant_overrides)))
    overrides = [f"env={env}", f"critic={critic}", *extra,
                 *run_overrides(updates * layout.frames_per_batch), *variant_overrides]  # fmt: skip
    launcher = TORCHRUN if processes > 1 else [sys.executable]
    with tempfile.TemporaryDirectory(prefix=f"bench_{setup}_") as tmp:
        command = [*launcher, "-m", "rlhc.run", *overrides, f"hydra.run.dir={tmp}/run"]
        done = subprocess.run(command, capture_output=True, text=True,
                              cwd=source or tmp, env=source_env(source))  # fmt: skip
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


def ceiling(
    env: str,
    critic: str,
    overrides: list[str],
    gemm: dict[tuple[int, int], float] | None = None,
) -> dict[str, Any]:
    """FLOP per frame of the configured networks and the frames/s one core allows.

    ``gemm`` caches GFLOP/s per GEMM shape: given, a shape measured before is reused.
    """
    from rlhc.building.builders import Layout
    from rlhc.building.flops import training_flops

    cfg = compose_config(env, critic, overrides)
    layout = Layout.from_config(cfg)
    cost = training_flops(cfg)
    # The minibatch's rows through a hidden layer: the GEMM an update is made of.
    rows = layout.minibatch_frames * layout.agents_per_world
    shape, cache = (rows, cfg.model.hidden_size), {} if gemm is None else gemm
    if shape not in cache:
        cache[shape] = gemm_gflops(*shape)
    gflops = cache[shape]
    per_frame = cost.collection + cost.update
    return {"flop_per_frame": per_frame, "collection_flop_per_frame": cost.collection,
            "update_flop_per_frame": cost.update, "gemm_rows": rows,
            "gemm_width": cfg.model.hidden_size, "gemm_gflops_one_core": gflops,
            "ceiling_frames_per_s_one_core": gflops * 1e9 / per_frame}  # fmt: skip


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
        if not stack or "train (rlhc/training/trainer.py" not in stack:
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
    """Per env and setup: median frames/s, and the medians of the per-round ratios to the
    setups ``one`` and ``reference`` (``None`` without such runs)."""
    rows = []
    for env, setup in dict.fromkeys((r["env"], r["setup"]) for r in runs):
        mine = [r for r in runs if (r["env"], r["setup"]) == (env, setup)]
        ratios: dict[str, list[float]] = {"one": [], "reference": []}
        for base_setup, found in ratios.items():
            rates = {r["round"]: r["frames_per_s"] for r in runs if (r["env"], r["setup"]) == (env, base_setup)}  # fmt: skip
            found += [r["frames_per_s"] / rates[r["round"]] for r in mine if r["round"] in rates]
        ceiling = ceilings[env]["ceiling_frames_per_s_one_core"] * mine[0]["processes"]
        rate = statistics.median(r["frames_per_s"] for r in mine)
        rows.append({"env": env, "setup": setup, "processes": mine[0]["processes"],
                     "frames_per_s": rate, "per_round": [round(r["frames_per_s"], 1) for r in mine],
                     **{f"ratio_vs_{k}": statistics.median(v) if v else None for k, v in ratios.items()},
                     "ratios_per_round": [round(x, 3) for x in ratios["one"]],
                     "ratios_vs_reference_per_round": [round(x, 3) for x in ratios["reference"]],
                     "ceiling_frames_per_s": ceiling, "share_of_ceiling": rate / ceiling})  # fmt: skip
    return rows


def compare(
    runs: list[dict[str, Any]], reference: str, ceilings: dict[str, dict[str, float]]
) -> list[dict[str, Any]]:
    """Per env, setup and variant: frames/s per round and the median, ratios to ``reference``.

    A ratio divides a run's rate by ``reference``'s run of the same env, setup and round
    (rounds without one are left out); ``ratio_to_reference`` is the median of those
    ratios, ``None`` without any. ``ceilings[variant][env]`` is the frames/s one core
    allows, times the setup's processes for the share.
    """
    rows = []
    for env, setup, variant in dict.fromkeys((r["env"], r["setup"], r["variant"]) for r in runs):
        mine = sorted(
            (r for r in runs if (r["env"], r["setup"], r["variant"]) == (env, setup, variant)),
            key=lambda r: r["round"],
        )
        reference_rates = {r["round"]: r["frames_per_s"] for r in runs
                           if (r["env"], r["setup"], r["variant"]) == (env, setup, reference)}  # fmt: skip
        ratios = [r["frames_per_s"] / reference_rates[r["round"]]
                  for r in mine if r["round"] in reference_rates]  # fmt: skip
        rate = statistics.median(r["frames_per_s"] for r in mine)
        limit = ceilings[variant][env] * mine[0]["processes"]
        rows.append({"env": env, "setup": setup, "variant": variant,
                     "processes": mine[0]["processes"], "rounds": [r["round"] for r in mine],
                     "per_round": [round(r["frames_per_s"], 1) for r in mine],
                     "frames_per_s": rate, "reference": reference,
                     "ratios_per_round": [round(x, 3) for x in ratios],
                     "ratio_to_reference": statistics.median(ratios) if ratios else None,
                     "ceiling_frames_per_s": limit, "share_of_ceiling": rate / limit})  # fmt: skip
    return rows


def markdown_table(rows: list[dict[str, Any]]) -> str:
    """The rows of :func:`compare` as a Markdown table."""
    reference = rows[0]["reference"] if rows else BASELINE
    lines = [
        f"| env | setup | variant | frames/s per round | median | ratio to {reference} "
        "(median of per-round ratios) | share of ceiling |",
        "|---|---|---|---|---:|---|---:|",
    ]
    for row in rows:
        ratios = row["ratios_per_round"]
        if row["variant"] == row["reference"]:
            ratio = "reference"
        elif row["ratio_to_reference"] is None:
            ratio = "n/a"
        else:
            ratio = f"{row['ratio_to_reference']:.3f}"
            if len(ratios) > 1:
                ratio += f" ({' / '.join(f'{x:.3f}' for x in ratios)})"
        lines.append(
            f"| {row['env']} | {row['setup']} | {row['variant']} | "
            f"{' / '.join(f'{x:,.0f}' for x in row['per_round'])} | "
            f"{row['frames_per_s']:,.0f} | {ratio} | {row['share_of_ceiling']:.1%} |"
        )
    return "\n".join(lines)


def make_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--env", nargs="+", default=["soccer", "tennis"])
    parser.add_argument("--critic", default="hierarchical")
    parser.add_argument("--setups", nargs="+", default=list(SETUPS), choices=list(SETUPS))
    parser.add_argument("--updates", type=int, nargs=2, default=[13, 22], metavar=("SOCCER", "TENNIS"),
                        help="updates per run (timed from the first summary row: 2 and 7 updates)")  # fmt: skip
    parser.add_argument("--repeats", type=int, default=1, help="rounds over the setups")
    parser.add_argument("--baseline", metavar="REV",
                        help="also run the code at this git revision, as the variant 'baseline'")  # fmt: skip
    parser.add_argument("--variant", action="append", default=[], type=parse_variant,
                        metavar="NAME=OVERRIDES",
                        help="also run the working tree with these Hydra overrides appended "
                             "(space-separated; repeatable)")  # fmt: skip
    parser.add_argument("--overrides", nargs="+", default=[], metavar="OVERRIDE",
                        help="Hydra overrides appended to every run of every variant, the "
                             "baseline's too (e.g. study=tennis_best resume=null)")  # fmt: skip
    parser.add_argument("--breakdown", type=Path, help="summarise a py-spy raw profile and exit")
    parser.add_argument("--output", "--out", type=Path, default=RESULTS)
    return parser


def parse_args(argv: Sequence[str] | None = None) -> argparse.Namespace:
    """The command line; variant names must be unique."""
    parser = make_parser()
    args = parser.parse_args(argv)
    names = [v.name for v in args.variant]
    repeated = sorted({n for n in names if names.count(n) > 1})
    if repeated:
        parser.error(f"argument --variant: the name {repeated[0]!r} is given twice")
    return args


def run_rounds(
    args: argparse.Namespace, variants: list[Variant], label: bool
) -> list[dict[str, Any]]:
    """Every round: each env and setup, and within a setup each variant, one after another."""
    runs = []
    for round_ in range(args.repeats):
        for env in args.env:
            for setup in args.setups:
                updates = args.updates[0] if env == "soccer" else args.updates[1]
                for variant in variants:
                    try:
                        run = run_setup(env, args.critic, setup, updates,
                                        (*args.overrides, *variant.overrides),
                                        variant.source)  # fmt: skip
                    except RuntimeError as error:
                        if not label:
                            raise
                        raise RuntimeError(f"variant {variant.name}: {error}") from error
                    run["round"] = round_
                    name = ""
                    if label:
                        run["variant"] = variant.name
                        name = f"{variant.name:12} "
                    runs.append(run)
                    print(f"round {round_} {env:7} {setup:15} {name}{run['frames_per_s']:>8,.0f} "
                          f"frames/s (env {run['env_steps_per_s']:,.0f} steps/s)", flush=True)  # fmt: skip
    return runs


def main() -> None:
    args = parse_args()
    if args.breakdown is not None:
        breakdown(args.breakdown)
        return

    comparing = args.baseline is not None or bool(args.variant)
    revision = None
    if args.baseline is not None:
        try:
            revision = resolve_revision(args.baseline)
        except RuntimeError as error:
            raise SystemExit(f"--baseline {args.baseline!r}: {error}") from None
    load_before = os.getloadavg()
    ceilings = {env: ceiling(env, args.critic, list(args.overrides)) for env in args.env}
    # Each variant's ceiling: its own FLOP per frame (the working tree's config for the
    # baseline), GEMM shapes already measured reused.
    gemm = {(c["gemm_rows"], c["gemm_width"]): c["gemm_gflops_one_core"] for c in ceilings.values()}
    variant_ceilings = {BASELINE: ceilings, CURRENT: ceilings}
    for variant in args.variant:
        variant_ceilings[variant.name] = {
            env: ceiling(env, args.critic, [*args.overrides, *variant.overrides], gemm)
            for env in args.env
        }
    tree_state = working_tree() if comparing else None
    with contextlib.ExitStack() as stack:
        variants = [Variant(CURRENT), *args.variant]
        if revision is not None:
            tree = stack.enter_context(baseline_worktree(revision["commit"]))
            check_source(tree)
            variants.insert(0, Variant(BASELINE, (), tree))
        runs = run_rounds(args, variants, label=comparing)
    for env in args.env:  # the GEMM rate again, after the runs: the machine may have changed
        ceilings[env]["gemm_gflops_one_core_after"] = gemm_gflops(
            ceilings[env]["gemm_rows"], ceilings[env]["gemm_width"]
        )
    rows = summarise([r for r in runs if r.get("variant", CURRENT) == CURRENT], ceilings)
    print(f"\n{'env':7} {'setup':15} {'procs':>5} {'frames/s':>9} {'vs one':>7} {'vs ref':>7} "
          f"{'ceiling':>9} {'share':>6}")  # fmt: skip
    for row in rows:
        one, ref = (row[f"ratio_vs_{k}"] for k in ("one", "reference"))
        print(f"{row['env']:7} {row['setup']:15} {row['processes']:>5} {row['frames_per_s']:>9,.0f} "
              f"{'' if one is None else f'{one:.2f}x':>7} {'' if ref is None else f'{ref:.2f}x':>7} "
              f"{row['ceiling_frames_per_s']:>9,.0f} {row['share_of_ceiling']:>6.0%}")  # fmt: skip
    for env, info in ceilings.items():
        print(f"{env}: {info['flop_per_frame'] / 1e6:.2f} MFLOP per frame "
              f"({info['collection_flop_per_frame'] / 1e6:.2f} collect, "
              f"{info['update_flop_per_frame'] / 1e6:.2f} update); GEMM "
              f"[{info['gemm_rows']}x{info['gemm_width']}]@[{info['gemm_width']}x{info['gemm_width']}] "
              f"{info['gemm_gflops_one_core']:.1f} GFLOP/s on one core before the runs, "
              f"{info['gemm_gflops_one_core_after']:.1f} after")  # fmt: skip
    comparison = None
    if comparing:
        reference = BASELINE if revision is not None else CURRENT
        one_core = {name: {env: c["ceiling_frames_per_s_one_core"] for env, c in per_env.items()}
                    for name, per_env in variant_ceilings.items()}  # fmt: skip
        table = compare(runs, reference, one_core)
        print(f"\n{markdown_table(table)}", flush=True)
        comparison = {
            "command": shlex.join([Path(sys.executable).name, *sys.argv]),
            "reference": reference, "order": [v.name for v in variants],
            "baseline": revision, "current": tree_state,
            "overrides": list(args.overrides),
            "variants": {v.name: list(v.overrides) for v in args.variant},
            "variant_ceilings": {v.name: variant_ceilings[v.name] for v in args.variant},
            "rows": table,
        }  # fmt: skip
    meta = {"machine": platform.machine(), "cpus": multiprocessing.cpu_count(),
            "python": platform.python_version(), "date": time.strftime("%Y-%m-%d %H:%M %Z"),
            "loadavg_before": load_before, "loadavg_after": os.getloadavg(),
            "updates": args.updates, "repeats": args.repeats,
            "command": " ".join([Path(sys.executable).name, *sys.argv])}  # fmt: skip
    payload = {"measured": meta, "summary": rows, "ceilings": ceilings, "runs": runs}
    if comparison is not None:
        payload["comparison"] = comparison
    write_results(args.output, payload)
    print(f"wrote {args.output}")


if __name__ == "__main__":
    main()
