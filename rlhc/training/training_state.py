"""What a checkpoint of a training run holds, and putting it back (:mod:`rlhc.storage.checkpoint` writes and reads the files).

A checkpoint is a plain dict (``torch.save``):

| key | holds |
|---|---|
| ``env``, ``config`` | the game's name and the run's whole config (a nested dict) |
| ``frames``, ``iteration``, ``wall_time`` | the counters (the schedules are functions of ``frames``) |
| ``actors`` | each group's actor ``state_dict`` (what matches and evaluations load) |
| ``losses`` | each group's PPO loss ``state_dict``: the actor and both critics |
| ``optimizer`` | Adam's state |
| ``env_transform`` | the training transforms' state: the observation normaliser's statistics |
| ``game_rng`` | the game's random generator (``None`` for an env that is no batched game) |
| ``league`` | the league's pool, ratings and draws (``None`` without a league) |
| ``rng`` | the global random states of python, numpy and torch |

:func:`check_resumable` refuses a checkpoint whose weights belong to other settings.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any, NamedTuple

import torch
from omegaconf import OmegaConf
from torchrl.envs import EnvBase, TransformedEnv

from rlhc.config.train_schema import TrainConfig
from rlhc.envs.torchrl_adapter import batched_game_env
from rlhc.storage.checkpoint import (
    ResumeError,
    config_differences,
    load_checkpoint,
    rng_states,
    set_rng_states,
)
from rlhc.training.league import League


class Counters(NamedTuple):
    """How far a run is: world-decisions trained, updates, seconds spent training."""

    frames: int
    iteration: int
    wall_time: float


def config_container(cfg: TrainConfig) -> dict[str, Any]:
    """``cfg`` as the plain nested dict a checkpoint stores."""
    return OmegaConf.to_container(OmegaConf.structured(cfg), resolve=True)  # type: ignore[return-value]


def check_resumable(cfg: TrainConfig, state: Mapping[str, Any]) -> None:
    """Refuse to continue ``state`` with settings its weights do not belong to.

    Args:
        cfg: the config of the run that would continue.
        state: a loaded checkpoint (:func:`~rlhc.storage.checkpoint.load_checkpoint`).

    Raises:
        ResumeError: naming every differing setting (:func:`~rlhc.storage.checkpoint.config_differences`).
    """
    stored = state.get("config") or {"env": {"name": state["env"]}}
    differing = config_differences(stored, config_container(cfg))
    if differing:
        raise ResumeError(
            f"resume={cfg.resume!r}: {state['path']} was trained with other settings, and a "
            f"resume cannot change them (checkpoint -> now): {'; '.join(differing)}"
        )


def checkpoint_to_resume(
    cfg: TrainConfig, given: Mapping[str, Any] | None, *, load: bool
) -> Mapping[str, Any] | None:
    """The checkpoint a run continues, checked (:func:`check_resumable`).

    Args:
        cfg: the run's config.
        given: an already loaded checkpoint, if any.
        load: without ``given``, load ``cfg.resume`` (if set); e.g. on rank 0 only.

    Returns:
        ``given``, or the checkpoint loaded, or ``None`` (a fresh run).

    Raises:
        ResumeError: the checkpoint's weights belong to other settings.
    """
    state = given
    if state is None and cfg.resume and load:
        state = load_checkpoint(cfg.resume)
    if state is not None:
        check_resumable(cfg, state)
    return state


def game_rng_state(env: EnvBase) -> Mapping[str, Any] | None:
    """The state of the generator of the game behind ``env`` (``None``: no batched game)."""
    game_env = batched_game_env(env)
    return game_env.game_rng_state if game_env is not None else None


def training_state(
    cfg: TrainConfig,
    counters: Counters,
    *,
    actors: Mapping[str, torch.nn.Module],
    losses: Mapping[str, torch.nn.Module],
    optimizer: torch.optim.Optimizer,
    env: TransformedEnv,
    game_rng: Mapping[str, Any] | None,
    league: League | None,
) -> dict[str, Any]:
    """Everything a resume (or an evaluation) needs, as the table of the module says.

    Args:
        cfg: the run's config.
        counters: frames, updates and wall time so far.
        actors: each group's actor.
        losses: each group's PPO loss (the actor and both critics).
        optimizer: the optimiser of every loss's parameters.
        env: the training env (its transforms' state is stored).
        game_rng: the state of the collecting game's generator (:func:`game_rng_state`
            of the env that collects, which is another process's in a pipeline).
        league: the league, if any.
    """
    return {
        "env": cfg.env.name,
        "config": config_container(cfg),
        "frames": counters.frames,
        "iteration": counters.iteration,
        "wall_time": counters.wall_time,
        "actors": {g: actor.state_dict() for g, actor in actors.items()},
        "losses": {g: loss.state_dict() for g, loss in losses.items()},
        "optimizer": optimizer.state_dict(),
        "env_transform": env.transform.state_dict(),
        "game_rng": game_rng,
        "league": league.state_dict() if league is not None else None,
        "rng": rng_states(),
    }


def restore_training_state(
    state: Mapping[str, Any],
    *,
    losses: Mapping[str, torch.nn.Module],
    optimizer: torch.optim.Optimizer,
    env: TransformedEnv,
    league: League | None,
    restore_game_rng: bool,
) -> Counters:
    """Load a :func:`training_state` into a freshly built run; its counters.

    The global random states are restored last.

    Args:
        state: a loaded checkpoint.
        losses: each group's PPO loss (which holds the actor and both critics).
        optimizer: the optimiser of every loss's parameters.
        env: the training env: its transforms' state, and its game's generator when
            ``restore_game_rng`` (and both the env and the checkpoint have one).
        league: the league, if any (a checkpoint without one leaves it as built).
        restore_game_rng: whether this process's game continues the stored generator
            (the process that collected it; another data-parallel process keeps its own).
    """
    for group, loss in losses.items():
        loss.load_state_dict(state["losses"][group])
    optimizer.load_state_dict(state["optimizer"])
    env.transform.load_state_dict(state["env_transform"])
    game_env = batched_game_env(env)
    if game_env is not None and state["game_rng"] is not None and restore_game_rng:
        game_env.set_game_rng_state(state["game_rng"])
    if league is not None and state.get("league") is not None:
        league.load_state_dict(state["league"])
    set_rng_states(state["rng"])
    return Counters(int(state["frames"]), int(state["iteration"]), float(state["wall_time"]))
