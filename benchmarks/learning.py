"""Learning benchmark: do trained teams play? Train a preset, then match it.

Every (critic, seed) run of a preset trains as its own ``python -m rlhc.run`` process,
``--jobs`` at a time, in ``<results>/<env>/<preset>/<critic>/seed_<k>/`` (``metrics.csv``,
``.hydra/``, ``train.log``; ``checkpoints/`` and ``tb/`` are not committed). A run whose
checkpoint reached the budget is skipped, an unfinished one resumes from its newest
checkpoint. The final checkpoint of each run then plays ``--matches`` matches against the
``random`` and the ``scripted`` team (half on each side, mode actions, seeded), in this
process on one thread. Written next to the run directories:

- ``<env>_<preset>.json``: per run its training command, code version, frames, wall time,
  mean training speed, last logged metrics and both match summaries
  (:meth:`rlhc.evaluation.matches.MatchResult.summary`); per critic the means over seeds.
  Runs already in the file and not re-evaluated are kept (so critics can be run one at
  a time); ``commands`` lists the invocations that rebuild the file.
- ``<env>_<preset>.png``: learning curves against frames, one line per critic (mean over
  seeds, TensorBoard-smoothed, shaded 95% t interval).

``--max-steps N`` (a quick check) writes under the preset name ``<preset>_<N>``, so it
never mixes with full runs.

Usage::

    python -m benchmarks.learning --env tennis --preset paper --critic ppo hierarchical --seeds 0 1 --jobs 2 --matches 100
    python -m benchmarks.learning --env tennis --preset paper --critic ppo --seeds 0 --evaluate-only
    python -m benchmarks.learning --env tennis --preset paper --critic ppo --max-steps 2560 --matches 4 --extra-overrides experiment=smoke
"""

from __future__ import annotations

import argparse
import json
import shlex
import subprocess
import sys
import time
from collections.abc import Sequence
from concurrent.futures import ThreadPoolExecutor, as_completed
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import torch
from omegaconf import OmegaConf

from benchmarks.reporting.learning import OPPONENTS, means_over_seeds, plot_curves, table
from benchmarks.reporting.summary import code_version
from rlhc.analysis.curves import METRICS_FILE, read_metrics
from rlhc.evaluation.diagnostics import DIAGNOSTICS, diagnose
from rlhc.evaluation.matches import evaluate_against, make_match_env
from rlhc.evaluation.opponents import make_team_policy
from rlhc.storage.checkpoint import CHECKPOINT_DIR, load_checkpoint, seed_everything

ROOT = Path(__file__).resolve().parents[1]
CONF_DIR = ROOT / "conf"
RESULTS = ROOT / "benchmarks" / "results" / "learning"
CRITICS = tuple(sorted(path.stem for path in (CONF_DIR / "critic").glob("*.yaml")))
#: Worlds playing matches at once: ``python -m rlhc.evaluate``'s default, so its command
#: (recorded per run) reproduces the numbers.
EVAL_WORLDS = 32
#: Keys this script sets itself; ``--extra-overrides`` may not change them.
RESERVED_KEYS = ("env", "critic", "seed", "algo.max_steps", "resume", "hydra.run.dir")
LOGGING = ("logger.backends=[csv]", "logger.progress=false")

#: The tennis probes' schedule: constant lr and entropy coefficient (a run can be read
#: at any budget and continued), 10 M court-decisions, a checkpoint every 250 K.
#: (Order matters: a resumed run's recorded overrides must match.)
PROBE_SCHEDULE = (
    "algo.anneal_lr=false",
    "algo.anneal_entropy_coef=false",
    "algo.max_steps=10000000",
    "checkpoint_freq=250000",
)
#: A state-free Gaussian policy from scale 1 with its mean head at 0.01 (ML-Agents 0.5).
GAUSSIAN_POLICY = (
    "model.action_dist=gaussian",
    "model.initial_action_scale=1.0",
    "model.head_init_scale=0.01",
)
#: ML-Agents 0.5's Gaussian as that trainer scales it: actions clip(u, -3, 3) / 3.
MLAGENTS_POLICY = (*GAUSSIAN_POLICY, "model.pre_clip_range=3.0")
#: A league where 30 % of the courts play the scripted team and 20 % past selves.
LEAGUE_WITH_SCRIPTED = (
    "league=mixed",
    "league.snapshot=0.2",
    "league.scripted=0.3",
    "league.random=0",
)
#: ML-Agents 0.5's entropy bonus per action dimension (beta / 3 on tennis' three), the
#: actor reading the manager's view, in :data:`LEAGUE_WITH_SCRIPTED`.
MLAGENTS_VIEW_LEAGUE = (
    "algo.entropy_coef=0.0016667",
    "model.actor_view=manager",
    *LEAGUE_WITH_SCRIPTED,
)
#: probe_mlagents_league_view (see PRESETS).
MLAGENTS_LEAGUE_VIEW = (
    *MLAGENTS_POLICY,
    *PROBE_SCHEDULE,
    "algo.lr=1e-3",
    "algo.epochs=6",
    *MLAGENTS_VIEW_LEAGUE,
)
#: ML-Agents 0.5's observation normaliser: cumulative statistics, values clipped to +-5.
MLAGENTS_NORMALISER = ("algo.observation_decay=1.0", "algo.observation_clip=5.0")

#: The tennis preset whose teams rally (``best``, study ``tennis_best``): ML-Agents 0.5's
#: Gaussian, entropy bonus per dimension and observation normaliser, the actor reading the
#: manager's view, lr 1e-3 decayed linearly to 0 over 5 M court-decisions, 6 epochs, half
#: of the courts against the scripted team and a fifth against past selves.
TENNIS_BEST = (
    *MLAGENTS_POLICY,
    "algo.anneal_lr=true",
    "algo.anneal_entropy_coef=false",
    "algo.max_steps=5000000",
    "checkpoint_freq=250000",
    "algo.lr=1e-3",
    "algo.epochs=6",
    "algo.entropy_coef=0.0016667",
    "model.actor_view=manager",
    "league=mixed",
    "league.self_play=0.3",
    "league.snapshot=0.2",
    "league.scripted=0.5",
    "league.random=0",
    *MLAGENTS_NORMALISER,
)

#: env -> preset name -> overrides of the training config (after ``env=`` and ``critic=``).
PRESETS: dict[str, dict[str, tuple[str, ...]]] = {
    "tennis": {
        "paper": (),  # Table 3 as composed by conf/table3/tennis.yaml
        # Beyond the paper: a league of opponents, at the paper's budget.
        "league": ("league=mixed",),
        # The paper preset on 2 processes, collection overlapped with the update.
        "pipeline": ("parallel=pipeline",),
        # Learning probe: a 4x entropy bonus, no decay of lr and beta, 10 M court-decisions
        # (the paper preset's noise shrinks and its lr reaches 0 while hits still climb).
        "probe_entropy": ("algo.entropy_coef=0.02", *PROBE_SCHEDULE),
        # Learning probe: a Gaussian policy (state-free learned scale from 1 in action units,
        # mean head at 0.01, no squashing), the paper's beta, no decay, 10 M. Its scale is
        # 3x ML-Agents' (no pre_clip_range): see probe_mlagents.
        "probe_gaussian": (*GAUSSIAN_POLICY, *PROBE_SCHEDULE),
        # Learning probe: ML-Agents 0.5's Gaussian with its scaling (actions clip(u, -3, 3)/3,
        # so the initial scale is a third of the action range), otherwise probe_gaussian.
        "probe_mlagents": (*MLAGENTS_POLICY, *PROBE_SCHEDULE),
        # Learning probe: probe_gaussian in a league: half the courts self-play, 30 %
        # against the scripted team (which returns the ball: many more balls to play),
        # 20 % against past selves.
        "probe_gaussian_league": (*GAUSSIAN_POLICY, *PROBE_SCHEDULE, *LEAGUE_WITH_SCRIPTED),
        # Learning probes: probe_gaussian at 3.3x its learning rate (its KL per update
        # stays at 0.002-0.004 and its clip fraction under 6 %), then that with twice the
        # epochs (more gradient steps per collected experience).
        "probe_gaussian_lr": (*GAUSSIAN_POLICY, *PROBE_SCHEDULE, "algo.lr=1e-3"),
        "probe_gaussian_lr_epochs": (
            *GAUSSIAN_POLICY,
            *PROBE_SCHEDULE,
            "algo.lr=1e-3",
            "algo.epochs=6",
        ),
        # The paper preset over 10 M court-decisions: Table 3 but the budget, so that lr,
        # beta and epsilon decay over 10 M (the paper's runs still gain when their lr
        # reaches 0 at 3.6 M), a checkpoint every 250 K.
        "long": ("algo.max_steps=10000000", "checkpoint_freq=250000"),
        # ML-Agents 0.5's Gaussian as that trainer has it: its scaling (pre_clip_range=3)
        # and its entropy bonus per action dimension (it averages the entropy over the
        # dimensions where IndependentNormal sums them: beta / 3 on tennis' three), at
        # probe_gaussian_lr_epochs' lr 1e-3 and 6 epochs, constant.
        "probe_mlagents_lr_epochs": (
            *MLAGENTS_POLICY,
            *PROBE_SCHEDULE,
            "algo.lr=1e-3",
            "algo.epochs=6",
            "algo.entropy_coef=0.0016667",
        ),
        # long with the behaviour log-probabilities rescored before each update
        # (algo.rescore_log_prob): TanhNormal's atanh rescoring of its stored actions is
        # off where the pre-tanh value is large, and long_bounded seed 0 still logs a KL
        # of 0.064 per update at lr 2e-8 (0.053 measured on its own batch at unchanged
        # weights, 1.4 % of its ratios outside the clip range).
        "long_rescored": (
            "algo.rescore_log_prob=true",
            "algo.max_steps=10000000",
            "checkpoint_freq=250000",
        ),
        # long_rescored with the actor reading the manager's view (the 8 values and the
        # ball relative to the racket): on a falling ball, the final move of long_rescored
        # seed 0 hardly depends on where the ball is (0.39 -> 0.57 over 4 m of ball x),
        # long seed 1's not at all, while the two teams that rally best (long seed 0,
        # probe_gaussian_lr_epochs seed 0) run towards it; on its missed serves (35 % of
        # points) long_rescored seed 0 plays the same moves wherever the toss falls.
        "long_actor_view": (
            "algo.rescore_log_prob=true",
            "algo.max_steps=10000000",
            "checkpoint_freq=250000",
            "model.actor_view=manager",
        ),
        # long_actor_view with the pre-tanh sample stored and scored: its seed 1 rallied 9.5
        # hits per point with itself at 4.0 M (14.8 with mode actions), then a saturated
        # action rescored through atanh at -1007 nats moved by 245 in one step, the
        # weights went NaN, and with the ratio capped its KL per update reached 4e4.
        "long_actor_view_exact": (
            "algo.max_steps=10000000",
            "checkpoint_freq=250000",
            "model.actor_view=manager",
            "model.action_dist=tanh_normal_exact",
        ),
        # probe_gaussian_lr_epochs (the state-free Gaussian: no atanh to overflow; the best
        # median share of points against the scripted team, 33 % over three seeds) with
        # the actor reading the manager's view (long_actor_view: 2.1-2.2 hits per point at
        # 3 M on all three seeds, its rackets running to a falling ball).
        "probe_gaussian_view": (
            *GAUSSIAN_POLICY,
            *PROBE_SCHEDULE,
            "algo.lr=1e-3",
            "algo.epochs=6",
            "model.actor_view=manager",
        ),
        # probe_mlagents_lr_epochs (11.4 hits per point with itself, mode actions, but 13.6 %
        # of points against the scripted team: a rally with itself) in a league where 30 %
        # of the courts play the scripted team and 20 % past selves, its actor reading the
        # manager's view (long_actor_view seed 0: no serve missed from 1.3 M on).
        "probe_mlagents_league_view": MLAGENTS_LEAGUE_VIEW,
        # probe_mlagents_league_view at Table 3's lr (3e-4) and epochs (3), kept constant:
        # its seed 0 rallied 13.5 hits per point with itself at 1.26 M (38 with mode
        # actions) and took 22-36 % of the points of its courts against the scripted team,
        # then lost its serve within 0.25 M (untouched serves 0.02 -> 0.37 per point) while
        # every update moved the policy to the clip range's edge (KL 0.02-0.03, clip
        # fraction 0.23-0.29, scale 0.04 on the move).
        "probe_mlagents_league_view_lr": (*MLAGENTS_POLICY, *PROBE_SCHEDULE, *MLAGENTS_VIEW_LEAGUE),
        # probe_mlagents_league_view with its learning rate adapted to the KL per update
        # (algo.target_kl 0.01: the rate, at most 1e-3, falls by 1.5 after an update
        # whose KL exceeded 0.02 and rises after one under 0.005), its 6 epochs kept: the
        # fast start of lr 1e-3 (a rally with itself by 1 M on seeds 0 and 1), the steps
        # of a smaller rate once the policy is narrow.
        "probe_mlagents_league_view_adaptive": (
            *MLAGENTS_POLICY,
            *PROBE_SCHEDULE,
            "algo.lr=1e-3",
            "algo.target_kl=0.01",
            "algo.epochs=6",
            *MLAGENTS_VIEW_LEAGUE,
        ),
        # probe_mlagents_league_view with ML-Agents 0.5's observation normaliser:
        # cumulative statistics and normalised values clipped to [-5, 5]. Its
        # probe_mlagents_league_view_lr seed 0 lost its rally and serve at 3.6 M from one
        # update to the next at a KL of 0.006; the 3.5 M weights with the 3.75 M
        # normaliser play 0.86 hits per point with themselves (32 % of points on untouched
        # serves), with their own 6.5; the 3.75 M weights with the 3.5 M normaliser 4.3:
        # the statistics' drift, not the update, broke it (the racket's height, scale
        # 0.015, normalises to tens where a racket jumps).
        "probe_mlagents_league_view_norm": (
            *MLAGENTS_LEAGUE_VIEW,
            *MLAGENTS_NORMALISER,
        ),
        # probe_mlagents_league_view_norm with half of the courts against the scripted team
        # and its lr decayed linearly to 0 over 5 M (ML-Agents 0.5 decays it over its
        # budget). At constant lr its seeds 0 and 1 beat the scripted team from 2.25-2.5 M
        # (74 and 58 of 100 matches), but seed 0 declined from 3 M (5 matches at 4.58 M)
        # with a KL of 0.03 per update, and seed 2 rallied 20-30 hits per point with
        # itself while losing 0.46 points per point on scripted shots it did not return.
        "probe_mlagents_norm_scripted_anneal": TENNIS_BEST,
        # The study tennis_best (conf/study/tennis_best.yaml, its runs in tennis/best):
        # probe_mlagents_norm_scripted_anneal, every critic.
        "best": TENNIS_BEST,
        # long with the pre-tanh mean bounded (model.loc_bound): long seed 0 keeps a KL of
        # 0.037 per update at lr 2e-8 at the end (TanhNormal's log-probability of a
        # saturated mean, rebuilt through atanh) and collapses near 8 M.
        "long_bounded": (
            "model.action_dist=tanh_normal_bounded",
            "algo.max_steps=10000000",
            "checkpoint_freq=250000",
        ),
        # long with probe_entropy's bonus (0.02, decaying to the same floor): long's seed 1
        # stays under one hit per point for 6 M court-decisions, its move scale near the
        # ball down to 0.02 and 36 % of its moves toward the ball (seed 0: 57 %).
        "long_entropy": (
            "algo.entropy_coef=0.02",
            "algo.max_steps=10000000",
            "checkpoint_freq=250000",
        ),
        # probe_gaussian_lr_epochs with the entropy bonus decaying (0.005 -> 1e-5 over 10 M)
        # or off, the learning rate kept: all three seeds of that probe raise their
        # state-free scale from ~2 M on (entropy -0.2 -> 2.5 by 10 M in seed 0, whose
        # 10-hit rallies at 7 M are lost as it grows).
        "probe_gaussian_beta_decay": (
            *GAUSSIAN_POLICY,
            "algo.anneal_lr=false",
            "algo.anneal_entropy_coef=true",
            "algo.max_steps=10000000",
            "checkpoint_freq=250000",
            "algo.lr=1e-3",
            "algo.epochs=6",
        ),
        "probe_gaussian_beta0": (
            *GAUSSIAN_POLICY,
            *PROBE_SCHEDULE,
            "algo.lr=1e-3",
            "algo.epochs=6",
            "algo.entropy_coef=0",
        ),
        # probe_gaussian_lr_epochs with the paper's decay over its 10 M (that probe peaks
        # at 10 hits per point near 7 M and falls back at a constant lr, its scale growing).
        "long_gaussian": (
            *GAUSSIAN_POLICY,
            "algo.lr=1e-3",
            "algo.epochs=6",
            "algo.max_steps=10000000",
            "checkpoint_freq=250000",
        ),
    },
    "soccer": {
        "paper": (),  # Table 3 as composed by conf/table3/soccer.yaml
        # Beyond the paper: a league, ball-progress shaping and twice the budget.
        "best": ("league=mixed", "shaping.scale=0.1", "algo.max_steps=1000000"),
        "pipeline": ("parallel=pipeline",),
        # ML-Agents 0.5's discrete network: actor and worker critic on one trunk.
        "trunk_pipeline": ("parallel=pipeline", "model.shared_trunk=true"),
    },
}
#: Presets that train on several processes (``torchrun --nproc_per_node``); others: one.
PROCESSES: dict[str, int] = {"pipeline": 2, "trunk_pipeline": 2}


@dataclass(frozen=True)
class LearningRun:
    """One (critic, seed) training run of a preset.

    Attributes:
        env: the game.
        preset: the directory name of the preset (``<preset>`` or ``<preset>_<max_steps>``).
        critic: a ``conf/critic`` choice.
        seed: the training seed.
        overrides: every ``rlhc.run`` override but the run directory and ``resume``.
        results: the benchmark's results directory.
    """

    env: str
    preset: str
    critic: str
    seed: int
    overrides: tuple[str, ...]
    results: Path
    processes: int = 1

    @property
    def run_dir(self) -> Path:
        return self.results / self.env / self.preset / self.critic / f"seed_{self.seed}"

    def command(self, resume: bool = False) -> list[str]:
        """The training command, run from the repository root with the project's python."""
        tail = [f"resume={shown(self.run_dir)}"] if resume else []
        run_dir = f"hydra.run.dir={shown(self.run_dir)}"
        launcher = ["python"]
        if self.processes > 1:
            launcher = ["torchrun", "--standalone", f"--nproc_per_node={self.processes}"]
        return [*launcher, "-m", "rlhc.run", *self.overrides, run_dir, *tail]


def shown(path: Path) -> str:
    """``path`` relative to the repository root when inside it (commands run from there)."""
    return str(path.relative_to(ROOT)) if path.is_relative_to(ROOT) else str(path)


def override_key(override: str) -> str:
    """``"+algo.lr=1e-3" -> "algo.lr"``."""
    return override.split("=", 1)[0].lstrip("+~")


def plan(args: argparse.Namespace) -> list[LearningRun]:
    """The runs of the invocation, seed-major (a partial benchmark compares equal seeds)."""
    budget = [f"algo.max_steps={args.max_steps}"] if args.max_steps else []
    runs = []
    for seed in args.seeds:
        for critic in args.critic:
            overrides = (
                f"env={args.env}",
                f"critic={critic}",
                *PRESETS[args.env][args.preset],
                f"seed={seed}",
                *budget,
                *LOGGING,
                *args.extra_overrides,
            )
            processes = PROCESSES.get(args.preset, 1)
            runs.append(
                LearningRun(
                    args.env, preset_dir(args), critic, seed, overrides, args.results, processes
                )
            )
    return runs


def preset_dir(args: argparse.Namespace) -> str:
    """The preset's directory name: ``<preset>``, or ``<preset>_<N>`` with ``--max-steps N``."""
    return f"{args.preset}_{args.max_steps}" if args.max_steps else args.preset


def budget_of(run: LearningRun) -> int:
    """``algo.max_steps`` of the composed training config (what ``rlhc.run`` trains to)."""
    from hydra import compose, initialize_config_dir
    from hydra.core.global_hydra import GlobalHydra

    from rlhc.config.train_schema import register_configs

    register_configs()
    GlobalHydra.instance().clear()
    with initialize_config_dir(config_dir=str(CONF_DIR), version_base="1.3"):
        return int(compose(config_name="train", overrides=list(run.overrides)).algo.max_steps)


def check_overrides(run: LearningRun) -> None:
    """Refuse to continue or report a run that was trained with other overrides.

    Raises:
        ValueError: the run's ``.hydra/overrides.yaml`` differs (both lists are named).
    """
    recorded_file = run.run_dir / ".hydra" / "overrides.yaml"
    if not (run.run_dir / CHECKPOINT_DIR).is_dir() or not recorded_file.is_file():
        return
    recorded = [o for o in OmegaConf.load(recorded_file) if override_key(str(o)) != "resume"]
    if recorded != list(run.overrides):
        raise ValueError(
            f"run directory {shown(run.run_dir)!r} was trained with overrides {recorded}, "
            f"this invocation asks for {list(run.overrides)}; use another --results "
            "directory, or the run's own overrides"
        )


def execute(run: LearningRun) -> tuple[LearningRun, int, float]:
    """Train one run (resuming it if a checkpoint exists); its exit code and seconds."""
    run.run_dir.mkdir(parents=True, exist_ok=True)
    command = run.command(resume=(run.run_dir / CHECKPOINT_DIR).is_dir())
    start = time.perf_counter()
    with (run.run_dir / "train.log").open("a") as log:
        log.write(f"code version: {code_version()}\ncommand: {shlex.join(command)}\n")
        log.flush()
        launcher = [sys.executable]
        if run.processes > 1:  # torchrun, as the module of this python
            launcher = [sys.executable, "-m", "torch.distributed.run"]
        code = subprocess.call(
            [*launcher, *command[1:]],  # command[0]: "python" or "torchrun"
            cwd=ROOT,
            stdout=log,
            stderr=subprocess.STDOUT,
        )
    return run, code, time.perf_counter() - start


def trained_frames(run: LearningRun) -> int | None:
    """Frames of the run's newest checkpoint, ``None`` without one."""
    try:
        return int(load_checkpoint(run.run_dir)["frames"])
    except FileNotFoundError:
        return None


def train(runs: Sequence[LearningRun], jobs: int) -> list[LearningRun]:
    """Train the unfinished ``runs``, ``jobs`` at a time; the runs that failed."""
    budgets = {run: budget_of(run) for run in runs}
    todo = [run for run in runs if (trained_frames(run) or 0) < budgets[run]]
    print(f"{len(todo)} of {len(runs)} runs to train", flush=True)
    failed = []
    with ThreadPoolExecutor(max_workers=jobs) as pool:
        for future in as_completed([pool.submit(execute, run) for run in todo]):
            run, code, seconds = future.result()
            status = "ok" if code == 0 else f"FAILED ({code}, see {run.run_dir / 'train.log'})"
            print(f"{run.critic}/seed_{run.seed}: {status} in {seconds:.0f} s", flush=True)
            if code != 0:
                failed.append(run)
    return failed


def match_summary(
    checkpoint: str | Path, env: str, opponent: str, matches: int, seed: int
) -> dict[str, Any]:
    """``matches`` matches of a checkpoint against ``opponent``, mode actions, sides swapped.

    As ``python -m rlhc.evaluate env=<env> home=<checkpoint> away=<opponent>
    matches=<matches> seed=<seed>``: seed, then build the env and both players.
    """
    seed_everything(seed)
    match_env = make_match_env(env, min(EVAL_WORLDS, matches), seed, [str(checkpoint)])
    try:
        policy = make_team_policy(str(checkpoint), match_env)
        return evaluate_against(policy, opponent, match_env, matches)
    finally:
        match_env.close()


def evaluate(run: LearningRun, matches: int, seed: int) -> dict[str, Any]:
    """Match summaries of the run's newest checkpoint against each of :data:`OPPONENTS`."""
    checkpoint = load_checkpoint(run.run_dir)["path"]
    return {
        opponent: match_summary(checkpoint, run.env, opponent, matches, seed)
        for opponent in OPPONENTS
    }


def record(run: LearningRun, args: argparse.Namespace) -> dict[str, Any]:
    """The JSON entry of a trained run: training facts, last metrics, both evaluations."""
    state = load_checkpoint(run.run_dir)
    columns = read_metrics(run.run_dir / METRICS_FILE)
    last = {name: float(values[-1]) for name, values in columns.items()}
    final = {
        name: value
        for name, value in last.items()
        if name in ("step", "episode_length")
        or name.startswith("events/")
        or name.endswith("/cumulative_reward")
    }
    log = run.run_dir / "train.log"
    versions = [
        line.removeprefix("code version: ").strip()
        for line in (log.read_text().splitlines() if log.is_file() else [])
        if line.startswith("code version: ")
    ]
    speed = columns.get("train_frames_per_s", np.array([np.nan]))
    summaries = evaluate(run, args.matches, args.eval_seed)
    evaluate_cli = {
        opponent: shlex.join(
            [
                *("python", "-m", "rlhc.evaluate", f"env={run.env}"),
                *(f"home={shown(run.run_dir)}", f"away={opponent}", f"matches={args.matches}"),
                *(f"seed={args.eval_seed}", "threads=1"),
            ]
        )
        for opponent in OPPONENTS
    }
    return {
        "env": run.env,
        "preset": args.preset,
        "critic": run.critic,
        "seed": run.seed,
        "run_dir": shown(run.run_dir),
        "command": shlex.join(run.command()),
        "extra_overrides": list(args.extra_overrides),
        "code_version": versions[-1] if versions else "unknown (no train.log)",
        "training_code_versions": list(dict.fromkeys(versions)),
        "max_steps": int(state["config"]["algo"]["max_steps"]),
        "frames": int(state["frames"]),
        "finished": int(state["frames"]) >= int(state["config"]["algo"]["max_steps"]),
        "checkpoint": Path(state["path"]).name,
        "wall_time_s": last.get("wall_time"),
        "train_frames_per_s_mean": float(np.nanmean(speed)),
        "final_metrics": final,
        "evaluation": {
            "opponents": list(OPPONENTS),
            "matches": args.matches,
            "seed": args.eval_seed,
            "worlds": min(EVAL_WORLDS, args.matches),
            "deterministic": True,
            "swap_sides": True,
            "threads": 1,
            "code_version": code_version(),
            "commands": evaluate_cli,
        },
        **{f"vs_{opponent}": summaries[opponent] for opponent in OPPONENTS},
        # What the team does beyond who wins (python -m rlhc.evaluation.diagnostics).
        **(
            {"play_diagnostics": diagnose(state, worlds=EVAL_WORLDS, decisions=1000, seed=0)}
            if run.env in DIAGNOSTICS
            else {}
        ),
        "benchmark_command": benchmark_command(args),
    }


def benchmark_command(args: argparse.Namespace) -> str:
    """The invocation that trains and evaluates these runs (``--jobs`` changes nothing)."""
    words = ["python", "-m", "benchmarks.learning", "--env", args.env, "--preset", args.preset]
    words += ["--critic", *args.critic, "--seeds", *map(str, args.seeds)]
    words += ["--matches", str(args.matches), "--eval-seed", str(args.eval_seed)]
    if args.max_steps:
        words += ["--max-steps", str(args.max_steps)]
    if args.extra_overrides:
        words += ["--extra-overrides", *args.extra_overrides]
    if args.results.resolve() != RESULTS:
        words += ["--results", shown(args.results.resolve())]
    return shlex.join(words)


def write_results(new: Sequence[dict[str, Any]], args: argparse.Namespace) -> Path:
    """Merge ``new`` into the preset's JSON (an entry of the same critic and seed is
    replaced), write it with the means over seeds, draw its curves and print its table.

    Returns:
        The JSON file; the PNG is next to it.
    """
    path = args.results / f"{args.env}_{preset_dir(args)}.json"
    kept = json.loads(path.read_text())["runs"] if path.is_file() else []
    fresh = {(run["critic"], run["seed"]) for run in new}
    runs = sorted(
        [run for run in kept if (run["critic"], run["seed"]) not in fresh] + list(new),
        key=lambda run: (run["critic"], run["seed"]),
    )
    means = means_over_seeds(runs)
    document = {
        "benchmark": "learning",
        "env": args.env,
        "preset": args.preset,
        "preset_overrides": list(PRESETS[args.env][args.preset]),
        "max_steps_override": args.max_steps,
        "commands": sorted({run["benchmark_command"] for run in runs}),
        "means_over_seeds": means,
        "runs": runs,
    }
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(document, indent=2) + "\n")
    run_dirs: dict[str, list[Path]] = {}
    for run in runs:
        run_dirs.setdefault(run["critic"], []).append(ROOT / run["run_dir"])  # absolute stays
    title = f"{args.env}, preset {preset_dir(args)}"
    figure = plot_curves(run_dirs, args.env, title, path.with_suffix(".png"))
    print("\n".join(table(runs, means)))
    print(f"results: {shown(path)}\nfigure:  {shown(figure)}")
    return path


def parse_args(argv: Sequence[str] | None = None) -> argparse.Namespace:
    """The command line; errors name the bad value and what is allowed."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--env", choices=sorted(PRESETS), default="tennis")
    parser.add_argument("--preset", default="paper", help="a key of PRESETS[env]")
    parser.add_argument("--critic", nargs="+", choices=CRITICS, default=["ppo", "hierarchical"])
    parser.add_argument("--seeds", nargs="+", type=int, default=[0])
    parser.add_argument("--jobs", type=int, default=2, help="training runs in parallel")
    parser.add_argument("--matches", type=int, default=100, help="per opponent, even")
    parser.add_argument("--eval-seed", type=int, default=0, help="seed of the matches")
    parser.add_argument("--max-steps", type=int, default=None, help="budget (world-decisions)")
    parser.add_argument("--extra-overrides", nargs="+", default=[], metavar="OVERRIDE")
    parser.add_argument("--evaluate-only", action="store_true", help="skip training")
    parser.add_argument("--results", type=Path, default=RESULTS, help="results directory")
    args = parser.parse_args(argv)
    if args.preset not in PRESETS[args.env]:
        known = ", ".join(sorted(PRESETS[args.env]))
        parser.error(f"--preset {args.preset!r} is not a preset of {args.env}; known: {known}")
    if args.matches < 2 or args.matches % 2:
        parser.error(f"--matches must be even and >= 2 (half on each side), got {args.matches}")
    if args.max_steps is not None and args.max_steps < 1:
        parser.error(f"--max-steps must be >= 1, got {args.max_steps}")
    if args.jobs < 1:
        parser.error(f"--jobs must be >= 1, got {args.jobs}")
    if any(seed < 0 for seed in args.seeds):
        parser.error(f"--seeds must be >= 0, got {args.seeds}")
    reserved = [o for o in args.extra_overrides if override_key(o) in RESERVED_KEYS]
    if reserved:
        parser.error(
            f"--extra-overrides {reserved} set keys this script sets itself "
            f"({', '.join(RESERVED_KEYS)}); use --env, --critic, --seeds or --max-steps"
        )
    args.critic = list(dict.fromkeys(args.critic))
    args.seeds = list(dict.fromkeys(args.seeds))
    args.results = args.results.resolve()
    return args


def main(argv: Sequence[str] | None = None) -> int:
    """Train, evaluate, write the JSON and the figure, print the table; the exit code."""
    args = parse_args(argv)
    runs = plan(args)
    for run in runs:
        check_overrides(run)
    failed = [] if args.evaluate_only else train(runs, args.jobs)
    torch.set_num_threads(1)
    records = []
    for run in runs:
        if run in failed:
            continue
        if trained_frames(run) is None:
            print(f"{run.critic}/seed_{run.seed}: no checkpoint in {shown(run.run_dir)}, skipped")
            failed.append(run)
            continue
        print(f"{run.critic}/seed_{run.seed}: evaluating", flush=True)
        entry = record(run, args)
        if not entry["finished"]:
            print(f"  note: unfinished ({entry['frames']} of {entry['max_steps']} frames)")
        records.append(entry)
    if not records:
        print("nothing to report")
        return 1
    write_results(records, args)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
