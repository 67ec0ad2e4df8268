"""Every check of a training config, in one place, with one error type.

:func:`validate` (a training config) and :func:`validate_evaluate` (an evaluation
config) run before anything is built (``rlhc.run``'s preflight, the trainer):
it checks each setting the schemas' types cannot (ranges, choices, the league's shares,
the logger, how the processes of a ``torchrun`` run share it) and raises
:class:`~rlhc.errors.ConfigError` naming the key, its value and what is allowed. What
depends on the built game (the layout of an update: :class:`rlhc.building.builders.Layout`; a
shared trunk on continuous actions) is checked where it is known, with the same error.
"""

from __future__ import annotations

import math

import torch
import torch.distributed as dist

from rlhc.config.evaluate_schema import MODES, EvaluateConfig
from rlhc.config.train_schema import LeagueConfig, LoggerConfig, TrainConfig
from rlhc.envs import games
from rlhc.envs.registry import shapable_games
from rlhc.envs.tennis.rules import FAULT_PENALTIES
from rlhc.errors import ConfigError
from rlhc.objectives import FUSIONS

__all__ = ["ConfigError", "validate", "validate_evaluate"]

#: Metric backends (``logger.backends``) and wandb modes (``logger.wandb_mode``).
BACKENDS = ("csv", "tensorboard", "wandb")
WANDB_MODES = ("auto", "online", "offline", "disabled")
#: How the processes of a ``torchrun`` run share it (``parallel``; rlhc.training.distributed).
PARALLEL_MODES = ("data", "pipeline")
#: How the league draws a snapshot to play (``league.sampling``; rlhc.training.league).
SAMPLING = ("uniform", "elo")


def validate(cfg: TrainConfig, processes: int = 1) -> None:
    """Check every setting of ``cfg`` for ``processes`` processes, before anything is built.

    The network's own fields (``model.num_layers``, ``hidden_size``, ``activation``,
    ``initial_action_scale``) are checked by their schema,
    :class:`~rlhc.modules.NetworkConfig`, when the config is created.

    Raises:
        ConfigError: naming the first bad key, its value and what is allowed.
    """
    if cfg.critic.fusion not in FUSIONS:
        raise ConfigError(f"critic.fusion={cfg.critic.fusion!r}; allowed: {', '.join(FUSIONS)}")
    if not 0.0 <= cfg.critic.weight <= 1.0:
        raise ConfigError(f"critic.weight={cfg.critic.weight}; allowed: a number in [0, 1]")
    if cfg.critic.manager_interval < 1:
        raise ConfigError(
            f"critic.manager_interval={cfg.critic.manager_interval}; allowed: an integer >= 1"
        )
    positive = {
        "algo.max_steps": cfg.algo.max_steps,
        "algo.buffer_size": cfg.algo.buffer_size,
        "algo.time_horizon": cfg.algo.time_horizon,
        "algo.batch_size": cfg.algo.batch_size,
        "algo.epochs": cfg.algo.epochs,
        "logger.summary_freq": cfg.logger.summary_freq,
        "checkpoint_freq": cfg.checkpoint_freq,
    }
    for name, value in positive.items():
        if value < 1:
            raise ConfigError(f"{name}={value}; allowed: an integer >= 1")
    non_negative = {
        "eval_freq": (cfg.eval_freq, "0 (off) or a number of world-decisions"),
        "play_freq": (cfg.play_freq, "0 (off) or a number of world-decisions"),
        "threads": (cfg.threads, "0 (torch's default) or a thread count"),
    }
    for name, (value, allowed) in non_negative.items():
        if value < 0:
            raise ConfigError(f"{name}={value}; allowed: {allowed}")
    if cfg.eval_freq and cfg.eval_matches < 2:
        raise ConfigError(
            f"eval_matches={cfg.eval_matches}; allowed: an integer >= 2 (half on each side)"
        )
    if cfg.play_freq:
        for name, value in (
            ("play_worlds", cfg.play_worlds),
            ("play_decisions", cfg.play_decisions),
        ):
            if value < 1:
                raise ConfigError(f"{name}={value}; allowed: an integer >= 1")
    if cfg.env.num_envs is not None and cfg.env.num_envs < 1:
        raise ConfigError(f"env.num_envs={cfg.env.num_envs}; allowed: null or an integer >= 1")
    if not 0.0 < cfg.algo.gamma <= 1.0 or not 0.0 <= cfg.algo.lmbda <= 1.0:
        raise ConfigError(
            f"algo.gamma={cfg.algo.gamma}, algo.lmbda={cfg.algo.lmbda}; "
            "allowed: gamma in (0, 1], lmbda in [0, 1]"
        )
    numbers = {
        # name: (value, lowest, highest, lowest allowed itself)
        "algo.lr": (cfg.algo.lr, 0.0, math.inf, False),
        "algo.clip_epsilon": (cfg.algo.clip_epsilon, 0.0, 1.0, False),
        "algo.entropy_coef": (cfg.algo.entropy_coef, 0.0, math.inf, True),
        "algo.final_lr": (cfg.algo.final_lr, 0.0, math.inf, True),
        "algo.final_entropy_coef": (cfg.algo.final_entropy_coef, 0.0, math.inf, True),
        "algo.final_clip_epsilon": (cfg.algo.final_clip_epsilon, 0.0, 1.0, False),
        "algo.critic_coef": (cfg.algo.critic_coef, 0.0, math.inf, False),
        "algo.max_grad_norm": (cfg.algo.max_grad_norm, 0.0, math.inf, False),
        "shaping.scale": (cfg.shaping.scale, 0.0, math.inf, True),
    }
    for name, (number, low, high, closed) in numbers.items():
        above = number >= low if closed else number > low
        if not (math.isfinite(number) and above and number < high):
            bracket = "[" if closed else "("
            raise ConfigError(
                f"{name}={number}; allowed: a finite number in {bracket}{low}, {high})"
            )
    target_kl = cfg.algo.target_kl
    if target_kl is not None:
        if not (math.isfinite(target_kl) and target_kl > 0):
            raise ConfigError(
                f"algo.target_kl={target_kl}; allowed: null (off) or a finite number > 0"
            )
        if cfg.algo.anneal_lr:
            raise ConfigError(
                f"algo.target_kl={target_kl} with algo.anneal_lr=true; allowed: one "
                "learning-rate schedule (set algo.anneal_lr=false to adapt the rate to the KL)"
            )
        if not (math.isfinite(cfg.algo.min_lr) and 0.0 < cfg.algo.min_lr <= cfg.algo.lr):
            raise ConfigError(
                f"algo.min_lr={cfg.algo.min_lr}; allowed: a number in (0, algo.lr = {cfg.algo.lr}]"
            )
    decay = cfg.algo.observation_decay
    if not (math.isfinite(decay) and 0.0 < decay <= 1.0):
        raise ConfigError(
            f"algo.observation_decay={decay}; allowed: a number in (0, 1] (1: cumulative)"
        )
    clip = cfg.algo.observation_clip
    if clip is not None and not (math.isfinite(clip) and clip > 0):
        raise ConfigError(
            f"algo.observation_clip={clip}; allowed: null (no clip) or a finite number > 0"
        )
    cap = cfg.algo.max_importance_ratio
    if cap is not None and not (math.isfinite(cap) and cap > 1.0 + cfg.algo.clip_epsilon):
        raise ConfigError(
            f"algo.max_importance_ratio={cap}; allowed: null (no cap) or a finite number "
            f"above 1 + algo.clip_epsilon = {1.0 + cfg.algo.clip_epsilon} (a lower cap "
            "would bind inside the clip range)"
        )
    if cfg.shaping.scale > 0 and cfg.env.name not in shapable_games():
        raise ConfigError(
            f"shaping.scale={cfg.shaping.scale} on env={cfg.env.name!r}; allowed: 0, or "
            f"shaping on a game with a potential: {', '.join(shapable_games())}"
        )
    problems = league_problems(cfg.league)
    if problems:
        raise ConfigError("; ".join(problems))
    check_logger(cfg.logger)
    check_device(cfg.device, processes)
    check_parallel(cfg.parallel, processes, cfg.device, cfg.league.active)
    if cfg.compile and processes > 1 and cfg.parallel == "data":
        raise ConfigError(
            f"compile=true with parallel=data on {processes} processes: the loss sums its "
            "weights over the processes inside the compiled step, which is not supported; "
            "allowed: compile=false, or parallel=pipeline, or one process"
        )
    interval = cfg.env.decision_interval
    if interval is not None and interval < 1:
        raise ConfigError(
            f"env.decision_interval={interval}; allowed: null (the game's default) or an "
            "integer >= 1 (physics frames per decision)"
        )
    fault_penalty = getattr(cfg.env, "fault_penalty", None)
    if fault_penalty is not None and fault_penalty not in FAULT_PENALTIES:
        raise ConfigError(
            f"env.fault_penalty={fault_penalty!r}; allowed: null or one of "
            f"{', '.join(FAULT_PENALTIES)}"
        )


def check_logger(cfg: LoggerConfig) -> None:
    """Raise :class:`ConfigError` naming an unknown backend or wandb mode."""
    unknown = [b for b in cfg.backends if b not in BACKENDS]
    if unknown:
        raise ConfigError(f"logger.backends has {unknown}; allowed: {', '.join(BACKENDS)}")
    if cfg.wandb_mode not in WANDB_MODES:
        raise ConfigError(
            f"logger.wandb_mode={cfg.wandb_mode!r}; allowed: {', '.join(WANDB_MODES)}"
        )


def league_problems(cfg: LeagueConfig) -> list[str]:
    """Problems with ``cfg``, each naming the key, the value and what is allowed."""
    problems = []
    names = {
        "self": "self_play",
        "snapshot": "snapshot",
        "scripted": "scripted",
        "random": "random",
    }
    for kind, share in cfg.shares.items():
        if not (math.isfinite(share) and 0.0 <= share <= 1.0):
            problems.append(f"league.{names[kind]}={share}; allowed: a share in [0, 1]")
    total = sum(cfg.shares.values())
    if not math.isclose(total, 1.0, abs_tol=1e-6):
        problems.append(
            f"league shares sum to {total:g} (self_play={cfg.self_play}, snapshot="
            f"{cfg.snapshot}, scripted={cfg.scripted}, random={cfg.random}); allowed: a sum of 1"
        )
    if cfg.pool_size < 1:
        problems.append(f"league.pool_size={cfg.pool_size}; allowed: an integer >= 1")
    if cfg.snapshot_interval < 1:
        problems.append(
            f"league.snapshot_interval={cfg.snapshot_interval}; allowed: an integer >= 1"
        )
    if cfg.sampling not in SAMPLING:
        problems.append(f"league.sampling={cfg.sampling!r}; allowed: {', '.join(SAMPLING)}")
    return problems


#: Where the networks and the update may run (``device``); the games run on CPU.
DEVICE_TYPES = ("cpu", "cuda")


def check_device(device: str, processes: int = 1) -> None:
    """Refuse a ``device`` that this machine cannot train on.

    Raises:
        ConfigError: not a torch device of :data:`DEVICE_TYPES`, a CUDA device that
            torch does not see, or a CUDA device with several processes.

    Examples:
        >>> check_device("cpu")
        >>> check_device("gpu")
        Traceback (most recent call last):
        ...
        rlhc.errors.ConfigError: device='gpu'; allowed: cpu, cuda or cuda:<index>
    """
    allowed = "allowed: cpu, cuda or cuda:<index>"
    try:
        parsed = torch.device(device)
    except (RuntimeError, TypeError):
        raise ConfigError(f"device={device!r}; {allowed}") from None
    if parsed.type not in DEVICE_TYPES:
        raise ConfigError(f"device={device!r}; {allowed}")
    if parsed.type != "cuda":
        return
    count = torch.cuda.device_count() if torch.cuda.is_available() else 0
    if count == 0:
        raise ConfigError(
            f"device={device!r}, but torch sees no CUDA device here "
            f"(torch {torch.__version__}, built with CUDA {torch.version.cuda}); allowed: cpu"
        )
    if parsed.index is not None and parsed.index >= count:
        raise ConfigError(
            f"device={device!r}; allowed: cpu, cuda or cuda:0 to cuda:{count - 1} "
            f"({count} CUDA devices here)"
        )
    if processes > 1:
        raise ConfigError(
            f"device={device!r} with {processes} processes: the collective buffers of "
            "rlhc.training.distributed live on CPU; allowed: one process on a GPU, or "
            "device=cpu with torchrun"
        )


def backend(device: str) -> str:
    """The collective backend for ``device``: NCCL for CUDA, gloo otherwise."""
    return "nccl" if torch.device(device).type == "cuda" else "gloo"


def check_parallel(mode: str, size: int, device: str, league_active: bool) -> None:
    """Refuse a way of sharing a run over ``size`` processes that cannot work.

    Raises:
        ConfigError: an unknown ``parallel``, a pipeline of other than 2 processes or
            with a league, or no collective backend for ``device`` in
            this torch build.
    """
    if mode not in PARALLEL_MODES:
        raise ConfigError(f"parallel={mode!r}; allowed: {', '.join(PARALLEL_MODES)}")
    if size <= 1:
        return
    if mode == "pipeline" and size != 2:
        raise ConfigError(
            f"parallel=pipeline with {size} processes (torchrun --nproc_per_node); "
            "allowed: exactly 2 (one learner, one collector), or parallel=data for any number"
        )
    if mode == "pipeline" and league_active:
        raise ConfigError(
            "parallel=pipeline with league.active (league=mixed): the league's opponents "
            "live on the collecting process; allowed: league=self_play, or parallel=data"
        )
    name = backend(device)
    available = {"gloo": dist.is_gloo_available, "nccl": dist.is_nccl_available}
    if not dist.is_available() or not available[name]():
        raise ConfigError(
            f"device={device!r} with {size} processes needs torch.distributed's {name} "
            "backend, which this torch build does not have; allowed: one process, or a "
            f"torch build with {name}"
        )


def validate_evaluate(cfg: EvaluateConfig) -> None:
    """Check an evaluation config (``python -m rlhc.evaluate``) before anything is built.

    Raises:
        ConfigError: naming the bad key, its value and what is allowed.
    """
    if cfg.mode not in MODES:
        raise ConfigError(f"mode={cfg.mode!r}; allowed: {', '.join(MODES)}")
    if cfg.env.name not in games():
        raise ConfigError(f"env={cfg.env.name!r}; allowed: {', '.join(games())}")
    if cfg.matches < 1 or (cfg.env.num_envs is not None and cfg.env.num_envs < 1):
        raise ConfigError(
            f"matches={cfg.matches}, env.num_envs={cfg.env.num_envs}; both must be >= 1"
        )
    if cfg.mode == "elo" and len(set(cfg.players)) < 2:
        raise ConfigError(
            "mode=elo needs at least two distinct players, e.g. "
            "'players=[scripted,random,outputs/soccer/hierarchical/<time>]'"
        )
    if cfg.video.format not in ("gif", "mp4"):
        raise ConfigError(f"video.format={cfg.video.format!r}; allowed: gif, mp4")
