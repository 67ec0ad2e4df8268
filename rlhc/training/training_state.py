"""What a checkpoint of a training run holds, and putting it back.

:mod:`rlhc.storage.checkpoint` writes and reads the files; a checkpoint is a plain dict:

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
    """Refuse to continue the checkpoint ``state`` with settings its weights do not belong to.

    Raises:
        ResumeError: naming each (:func:`~rlhc.storage.checkpoint.config_differences`).
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
    """The checkpoint a run continues (``None``: a fresh run): ``given``, or else
    ``cfg.resume`` loaded if ``load`` (e.g. on rank 0 only); checked by :func:`check_resumable`.

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
    """Everything a resume (or an evaluation) needs, as the module's table says; ``game_rng``
    is that of the game that collects (another process's, in a pipeline)."""
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
    """Load a :func:`training_state` into a freshly built run, the global random states
    last; its counters.

    ``restore_game_rng``: whether this process's game continues the stored generator (the
    process that collected it; other data-parallel processes keep their own).
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
