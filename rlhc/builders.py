"""Factories that turn a validated :class:`~rlhc.config.TrainConfig` into objects.

Shared by the trainer and the evaluation tools, so that a checkpoint's config rebuilds
exactly the networks that were trained.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass

import torch
from torchrl.envs import Compose, EnvBase, RewardSum, TransformedEnv, VecNormV2

from rlhc.config import TrainConfig
from rlhc.envs import make_env
from rlhc.modules import NetworkConfig, make_actor, make_manager_critic, make_worker_critic
from rlhc.objectives import FUSIONS, HierarchicalPPOLoss, make_ppo_loss

EPISODE_REWARD = "episode_reward"
MODEL_KINDS = ("mlp", "lstm")


class ConfigError(ValueError):
    """A config value that passed the schema but is not allowed (names it and the options)."""


def validate(cfg: TrainConfig) -> None:
    """Check what a schema cannot express, before anything is built."""
    if cfg.critic.fusion not in FUSIONS:
        raise ConfigError(f"critic.fusion={cfg.critic.fusion!r}; allowed: {', '.join(FUSIONS)}")
    if not 0.0 <= cfg.critic.weight <= 1.0:
        raise ConfigError(f"critic.weight={cfg.critic.weight}; allowed: a number in [0, 1]")
    if cfg.critic.manager_interval < 1:
        raise ConfigError(
            f"critic.manager_interval={cfg.critic.manager_interval}; allowed: an integer >= 1"
        )
    if cfg.model.kind not in MODEL_KINDS:
        raise ConfigError(f"model.kind={cfg.model.kind!r}; allowed: {', '.join(MODEL_KINDS)}")
    if cfg.model.kind == "lstm":
        raise ConfigError(
            "model=lstm is not supported: both games' observations carry positions and "
            "velocities, so a feed-forward policy sees a Markov state, and the recurrent "
            "option would need sequence-aware minibatching that this trainer does not do. "
            "Use model=mlp."
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
    if cfg.env.num_envs is not None and cfg.env.num_envs < 1:
        raise ConfigError(f"env.num_envs={cfg.env.num_envs}; allowed: null or an integer >= 1")
    if not 0.0 < cfg.algo.gamma <= 1.0 or not 0.0 <= cfg.algo.lmbda <= 1.0:
        raise ConfigError(
            f"algo.gamma={cfg.algo.gamma}, algo.lmbda={cfg.algo.lmbda}; "
            "allowed: gamma in (0, 1], lmbda in [0, 1]"
        )
    if cfg.algo.lr <= 0:
        raise ConfigError(f"algo.lr={cfg.algo.lr}; allowed: a number > 0")


@dataclass(frozen=True)
class Layout:
    """How many worlds are simulated and how a buffer is cut (derived from the config)."""

    num_envs: int
    frames_per_batch: int
    minibatch_size: int

    @staticmethod
    def from_config(cfg: TrainConfig) -> Layout:
        num_envs = cfg.env.num_envs or math.ceil(cfg.algo.buffer_size / cfg.algo.time_horizon)
        frames = num_envs * cfg.algo.time_horizon
        return Layout(num_envs, frames, min(cfg.algo.batch_size, frames))


def make_training_env(cfg: TrainConfig, num_envs: int, seed: int) -> TransformedEnv:
    """The batched env with episode-return tracking and, optionally, observation norm."""
    base = make_env(
        cfg.env.name, num_envs=num_envs, seed=seed, device=cfg.device, **cfg.env.game_options()
    )
    return with_training_transforms(cfg, base)


def with_training_transforms(cfg: TrainConfig, base: EnvBase) -> TransformedEnv:
    """Episode-return tracking (``(g, "episode_reward")``) and optional observation norm."""
    groups = group_names(base)
    transforms = [
        RewardSum(
            in_keys=[(g, "reward") for g in groups],
            out_keys=[(g, EPISODE_REWARD) for g in groups],
        )
    ]
    if cfg.algo.normalize_observations:
        keys = [(g, key) for g in groups for key in ("observation", "manager_observation")]
        # Statistics are shared by the worlds (reduce_batch_dims) and kept per agent slot;
        # with mirrored observations and a shared policy both teams' slots converge alike.
        transforms.append(VecNormV2(in_keys=keys, decay=0.99999, reduce_batch_dims=True))
    with warnings.catch_warnings():
        # VecNormV2 calls batched containers "experimental": the batched path is the one
        # this project runs and tests (tests/test_train.py, tests/evaluation).
        warnings.filterwarnings("ignore", "Support of VecNormV2", UserWarning)
        return TransformedEnv(base, Compose(*transforms))


def group_names(env: EnvBase) -> list[str]:
    """The agent groups of a multi-agent env: the top-level entries of its action spec."""
    return [str(name) for name in env.full_action_spec.keys(include_nested=False)]


def network_config(cfg: TrainConfig) -> NetworkConfig:
    return NetworkConfig(
        num_layers=cfg.model.num_layers,
        hidden_size=cfg.model.hidden_size,
        activation=cfg.model.activation,
    )


def make_agents(
    cfg: TrainConfig, env: EnvBase
) -> tuple[dict[str, torch.nn.Module], dict[str, HierarchicalPPOLoss]]:
    """One actor and one PPO loss (owning both critics) per group."""
    net = network_config(cfg)
    actors: dict[str, torch.nn.Module] = {}
    losses: dict[str, HierarchicalPPOLoss] = {}
    for group in group_names(env):
        actor = make_actor(env, group, net)
        actors[group] = actor
        losses[group] = make_ppo_loss(
            actor=actor,
            worker_critic=make_worker_critic(env, group, net),
            manager_critic=make_manager_critic(env, group, net),
            group=group,
            gamma=cfg.algo.gamma,
            lmbda=cfg.algo.lmbda,
            fusion=cfg.critic.fusion,
            weight=cfg.critic.weight,
            manager_interval=cfg.critic.manager_interval,
            clip_epsilon=cfg.algo.clip_epsilon,
            entropy_coef=cfg.algo.entropy_coef,
            critic_coef=cfg.algo.critic_coef,
            normalize_advantage=cfg.algo.normalize_advantage,
        )
    return actors, losses
