"""Every check of a config that the schemas' types cannot make, with one error type.

:func:`validate` (training) and :func:`validate_evaluate` (evaluation) run before
anything is built and raise :class:`~rlhc.errors.ConfigError` naming the key, its value
and what is allowed. What depends on the built game (the layout of an update,
:class:`rlhc.building.builders.Layout`) is checked where it is known, with the same error.
"""

from __future__ import annotations

import math

import torch
import torch.distributed as dist

from rlhc.config.evaluate_schema import MODES, EvaluateConfig
from rlhc.config.train_schema import LeagueConfig, LoggerConfig, TrainConfig
from rlhc.envs import SOURCES, games
from rlhc.envs.registry import shapable_games
from rlhc.envs.tennis.rules import FAULT_PENALTIES
from rlhc.errors import ConfigError, allowed
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

    The ``model`` fields are checked by :class:`~rlhc.modules.NetworkConfig` itself.

    Raises:
        ConfigError: naming the first bad key, its value and what is allowed.
    """
    if cfg.critic.fusion not in FUSIONS:
        raise allowed("critic.fusion", cfg.critic.fusion, ", ".join(FUSIONS))
    if not 0.0 <= cfg.critic.weight <= 1.0:
        raise allowed("critic.weight", cfg.critic.weight, "a number in [0, 1]")
    if cfg.critic.manager_interval < 1:
        raise allowed("critic.manager_interval", cfg.critic.manager_interval, "an integer >= 1")
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
            raise allowed(name, value, "an integer >= 1")
    non_negative = {
        "eval_freq": (cfg.eval_freq, "0 (off) or a number of world-decisions"),
        "play_freq": (cfg.play_freq, "0 (off) or a number of world-decisions"),
        "threads": (cfg.threads, "0 (torch's default) or a thread count"),
    }
    for name, (value, what) in non_negative.items():
        if value < 0:
            raise allowed(name, value, what)
    if cfg.eval_freq and cfg.eval_matches < 2:
        raise allowed("eval_matches", cfg.eval_matches, "an integer >= 2 (half on each side)")
    if cfg.play_freq:
        for name, value in (
            ("play_worlds", cfg.play_worlds),
            ("play_decisions", cfg.play_decisions),
        ):
            if value < 1:
                raise allowed(name, value, "an integer >= 1")
    if cfg.env.num_envs is not None and cfg.env.num_envs < 1:
        raise allowed("env.num_envs", cfg.env.num_envs, "null or an integer >= 1")
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
            raise allowed(name, number, f"a finite number in {bracket}{low}, {high})")
    target_kl = cfg.algo.target_kl
    if target_kl is not None:
        if not (math.isfinite(target_kl) and target_kl > 0):
            raise allowed("algo.target_kl", target_kl, "null (off) or a finite number > 0")
        if cfg.algo.anneal_lr:
            raise ConfigError(
                f"algo.target_kl={target_kl} with algo.anneal_lr=true; allowed: one "
                "learning-rate schedule (set algo.anneal_lr=false to adapt the rate to the KL)"
            )
        if not (math.isfinite(cfg.algo.min_lr) and 0.0 < cfg.algo.min_lr <= cfg.algo.lr):
            raise allowed(
                "algo.min_lr", cfg.algo.min_lr, f"a number in (0, algo.lr = {cfg.algo.lr}]"
            )
    decay = cfg.algo.observation_decay
    if not (math.isfinite(decay) and 0.0 < decay <= 1.0):
        raise allowed("algo.observation_decay", decay, "a number in (0, 1] (1: cumulative)")
    clip = cfg.algo.observation_clip
    if clip is not None and not (math.isfinite(clip) and clip > 0):
        raise allowed("algo.observation_clip", clip, "null (no clip) or a finite number > 0")
    cap = cfg.algo.max_importance_ratio
    if cap is not None and not (math.isfinite(cap) and cap > 1.0 + cfg.algo.clip_epsilon):
        raise allowed(
            "algo.max_importance_ratio",
            cap,
            f"null (no cap) or a finite number above 1 + algo.clip_epsilon = "
            f"{1.0 + cfg.algo.clip_epsilon} (a lower cap would bind inside the clip range)",
        )
    if cfg.shaping.scale > 0 and cfg.env.name not in shapable_games():
        raise ConfigError(
            f"shaping.scale={cfg.shaping.scale} on env={cfg.env.name!r}; allowed: 0, or "
            f"shaping on a game with a potential: {', '.join(shapable_games())}"
        )
    problems = league_problems(cfg.league)
    if problems:
        raise ConfigError("; ".join(problems))
    if cfg.env.name in SOURCES:
        check_source_run(cfg)
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
        what = "null (the game's default) or an integer >= 1 (physics frames per decision)"
        raise allowed("env.decision_interval", interval, what)
    fault_penalty = getattr(cfg.env, "fault_penalty", None)
    if fault_penalty is not None and fault_penalty not in FAULT_PENALTIES:
        what = f"null or one of {', '.join(FAULT_PENALTIES)}"
        raise allowed("env.fault_penalty", fault_penalty, what)


def check_source_run(cfg: TrainConfig) -> None:
    """Refuse what needs a built-in game on an environment of another library
    (``env=pettingzoo``, ``env=vmas``): it has no scripted team, no match rules and no
    play diagnostics.

    Raises:
        ConfigError: naming the setting and why.
    """
    game_only = {
        "eval_freq": (cfg.eval_freq, "matches against the scripted team"),
        "play_freq": (cfg.play_freq, "the game's play diagnostics"),
        "league": (cfg.league.active, "opponents other than the learner itself"),
    }
    for key, (value, what) in game_only.items():
        if value:
            shown = (
                "league="
                + ",".join(f"{name}:{share}" for name, share in cfg.league.shares.items() if share)
                if key == "league"
                else f"{key}={value}"
            )
            raise ConfigError(
                f"{shown} on env={cfg.env.name}: it needs {what}, which only a built-in "
                f"game ({', '.join(games())}) has; "
                f"allowed: {'league=self_play' if key == 'league' else f'{key}=0'}"
            )


def check_logger(cfg: LoggerConfig) -> None:
    """Raise :class:`ConfigError` naming an unknown backend or wandb mode."""
    unknown = [b for b in cfg.backends if b not in BACKENDS]
    if unknown:
        raise ConfigError(f"logger.backends has {unknown}; allowed: {', '.join(BACKENDS)}")
    if cfg.wandb_mode not in WANDB_MODES:
        raise allowed("logger.wandb_mode", cfg.wandb_mode, ", ".join(WANDB_MODES))


def league_problems(cfg: LeagueConfig) -> list[str]:
    """Problems with ``cfg``, each naming the key, the value and what is allowed."""
    problems = []
    for kind, share in cfg.shares.items():
        if not (math.isfinite(share) and 0.0 <= share <= 1.0):
            key = "self_play" if kind == "self" else kind
            problems.append(str(allowed(f"league.{key}", share, "a share in [0, 1]")))
    total = sum(cfg.shares.values())
    if not math.isclose(total, 1.0, abs_tol=1e-6):
        problems.append(
            f"league shares sum to {total:g} (self_play={cfg.self_play}, snapshot="
            f"{cfg.snapshot}, scripted={cfg.scripted}, random={cfg.random}); allowed: a sum of 1"
        )
    for name in ("pool_size", "snapshot_interval"):
        if getattr(cfg, name) < 1:
            problems.append(str(allowed(f"league.{name}", getattr(cfg, name), "an integer >= 1")))
    if cfg.sampling not in SAMPLING:
        problems.append(str(allowed("league.sampling", cfg.sampling, ", ".join(SAMPLING))))
    return problems


#: Where the networks and the update may run (``device``); the games run on CPU.
DEVICE_TYPES = ("cpu", "cuda")


def check_device(device: str, processes: int = 1) -> None:
    """Refuse a ``device`` that this machine cannot train on.

    Raises:
        ConfigError: not a CPU or CUDA device, one torch does not see, or CUDA with several
            processes.

    Examples:
        >>> check_device("cpu")
        >>> check_device("gpu")
        Traceback (most recent call last):
        ...
        rlhc.errors.ConfigError: device='gpu'; allowed: cpu, cuda or cuda:<index>
    """
    try:
        parsed = torch.device(device)
    except (RuntimeError, TypeError):
        raise allowed("device", device, "cpu, cuda or cuda:<index>") from None
    if parsed.type not in DEVICE_TYPES:
        raise allowed("device", device, "cpu, cuda or cuda:<index>")
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
            with a league, or no collective backend for ``device`` in this torch build.
    """
    if mode not in PARALLEL_MODES:
        raise allowed("parallel", mode, ", ".join(PARALLEL_MODES))
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
        raise allowed("mode", cfg.mode, ", ".join(MODES))
    if cfg.env.name in SOURCES:
        raise ConfigError(
            f"env={cfg.env.name}: rlhc.evaluate plays matches, which need a built-in game "
            f"({', '.join(games())}) with a scripted team and match rules; judge a "
            f"{cfg.env.name} run by its returns (python -m rlhc.evaluation.returns <run "
            "dir> ...: returns, cross-play, a video)"
        )
    if cfg.env.name not in games():
        raise allowed("env", cfg.env.name, ", ".join(games()))
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
        raise allowed("video.format", cfg.video.format, "gif, mp4")
