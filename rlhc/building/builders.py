"""Factories that turn a validated :class:`~rlhc.config.train_schema.TrainConfig` into objects."""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from dataclasses import dataclass

import torch
from torchrl.envs import Compose, EnvBase, RewardSum, TransformedEnv

from rlhc.building.normalisation import SafeVecNorm
from rlhc.building.shaping import PotentialShaping, game_potential
from rlhc.config.train_schema import TrainConfig
from rlhc.envs import SOURCES, make_env, make_game
from rlhc.envs.generic import SHARED_VIEWS
from rlhc.envs.keys import EPISODE_REWARD, MANAGER_OBSERVATION, OBSERVATION, REWARD
from rlhc.errors import ConfigError
from rlhc.modules import (
    NetworkConfig,
    make_actor,
    make_manager_critic,
    make_worker_critic,
)
from rlhc.objectives import HierarchicalPPOLoss, make_ppo_loss


@dataclass(frozen=True)
class Layout:
    """How an update is collected and cut, in the units of ML-Agents 0.5.

    Attributes:
        agents_per_world: ``n_g``, the agents of the largest group in one world (all
            groups have the same size in both games; a group of fewer agents collects
            fewer experiences per update).
        num_envs: worlds simulated at once (a divisor of ``frames_per_batch``).
        frames_per_batch: world-decisions per update, ``ceil(buffer_size / n_g)``.
        steps_per_world: decisions of each world per update.
        minibatch_frames: world-decisions per minibatch, ``batch_size / n_g``.
        minibatches: minibatches per epoch, ``frames_per_batch // minibatch_frames``.
        time_horizon: decisions after which a trajectory is cut (GAE bootstraps).

    Examples:
        >>> layout = Layout.build(buffer_size=10240, batch_size=1024, time_horizon=64,
        ...                       agents_per_world=4, num_envs=None)
        >>> layout.frames_per_batch, layout.num_envs, layout.steps_per_world
        (2560, 40, 64)
        >>> layout.minibatch_frames, layout.minibatches
        (256, 10)
    """

    agents_per_world: int
    num_envs: int
    frames_per_batch: int
    steps_per_world: int
    minibatch_frames: int
    minibatches: int
    time_horizon: int

    @property
    def experiences_per_batch(self) -> int:
        """Agent-experiences of each group in one update (``>= buffer_size``)."""
        return self.frames_per_batch * self.agents_per_world

    @staticmethod
    def build(
        *,
        buffer_size: int,
        batch_size: int,
        time_horizon: int,
        agents_per_world: int,
        num_envs: int | None,
        shards: int = 1,
    ) -> Layout:
        """The layout of an update; :class:`ConfigError` names any setting that cannot work.

        ``shards`` data-parallel processes each step ``num_envs / shards`` worlds (of the
        ``num_envs`` of all processes) and compute ``1 / shards`` of every minibatch.
        """
        n = agents_per_world
        if batch_size % n:
            raise ConfigError(
                f"algo.batch_size={batch_size}; allowed: a multiple of {n}, the agents of the "
                f"largest group in one world (a minibatch holds whole world-decisions)"
            )
        if buffer_size < batch_size:
            raise ConfigError(
                f"algo.buffer_size={buffer_size} is smaller than algo.batch_size={batch_size}; "
                "allowed: buffer_size >= batch_size (both in agent-experiences per group)"
            )
        frames = math.ceil(buffer_size / n)
        divisors = [d for d in range(1, frames + 1) if frames % d == 0]
        if num_envs is None:
            # The fewest worlds that keep each world's share within one time horizon
            # (and split over the processes).
            num_envs = next(
                (d for d in divisors if frames // d <= time_horizon and d % shards == 0), None
            )
            if num_envs is None:
                raise ConfigError(
                    f"{shards} processes cannot share the {frames} world-decisions of an "
                    f"update (algo.buffer_size={buffer_size} experiences / {n} agents per "
                    f"group); allowed: a number of processes that divides {frames}"
                )
        elif num_envs % shards:
            raise ConfigError(
                f"env.num_envs={num_envs} worlds do not split over {shards} processes; "
                f"allowed: null or a multiple of {shards} that divides {frames}: "
                + ", ".join(str(d) for d in divisors if d % shards == 0 and d <= 1024)
            )
        elif frames % num_envs:
            shown = ", ".join(str(d) for d in divisors if d <= 1024)
            raise ConfigError(
                f"env.num_envs={num_envs} does not divide the {frames} world-decisions of an "
                f"update (algo.buffer_size={buffer_size} experiences / {n} agents per group); "
                f"allowed: null or one of {shown}"
            )
        minibatch = batch_size // n
        if minibatch % shards:
            raise ConfigError(
                f"algo.batch_size={batch_size} ({minibatch} world-decisions) does not split "
                f"over {shards} processes; allowed: a multiple of {n * shards} "
                f"({n} agents per group x {shards} processes)"
            )
        return Layout(
            agents_per_world=n,
            num_envs=num_envs,
            frames_per_batch=frames,
            steps_per_world=frames // num_envs,
            minibatch_frames=minibatch,
            minibatches=frames // minibatch,
            time_horizon=time_horizon,
        )

    @staticmethod
    def from_config(cfg: TrainConfig, shards: int = 1) -> Layout:
        """The layout of ``cfg`` over ``shards`` data-parallel processes (builds a one-world game)."""
        return Layout.build(
            buffer_size=cfg.algo.buffer_size,
            batch_size=cfg.algo.batch_size,
            time_horizon=cfg.algo.time_horizon,
            agents_per_world=agents_per_world(cfg),
            num_envs=cfg.env.num_envs,
            shards=shards,
        )


def agents_per_world(cfg: TrainConfig) -> int:
    """Agents of the largest group in one world of ``cfg.env``: the unit of
    ``algo.buffer_size`` and ``algo.batch_size`` (agent-experiences per group).

    Building the env (one world) is also where a bad environment of another library
    fails, in one line, before a run directory is made.
    """
    if cfg.env.name in SOURCES:
        env = make_env(cfg.env.name, num_envs=1, seed=0, **cfg.env.game_options())
        sizes = [env.full_action_spec[group].shape[-1] for group in group_names(env)]
        env.close()
        return max(sizes)
    game = make_game(cfg.env.name, num_envs=1, seed=0, **cfg.env.game_options())
    return max(spec.num_agents for spec in game.groups)


def make_training_env(cfg: TrainConfig, num_envs: int, seed: int) -> TransformedEnv:
    """The batched env with episode-return tracking and, optionally, observation norm.

    The games run on CPU whatever ``cfg.device`` is: the collector moves their tensors
    to the networks' device and back.
    """
    base = make_env(cfg.env.name, num_envs=num_envs, seed=seed, **cfg.env.game_options())
    return with_training_transforms(cfg, base)


def with_training_transforms(cfg: TrainConfig, base: EnvBase) -> TransformedEnv:
    """Episode-return tracking (``(g, "episode_reward")``) and optional observation norm."""
    groups = group_names(base)
    transforms = [
        RewardSum(
            in_keys=[(g, REWARD) for g in groups],
            out_keys=[(g, EPISODE_REWARD) for g in groups],
        )
    ]
    if cfg.shaping.scale > 0:
        # After RewardSum: the logged returns stay the game's own rewards.
        game = getattr(base, "game", None)
        transforms.append(
            PotentialShaping(game_potential(game), groups, cfg.algo.gamma, cfg.shaping.scale)
        )
    if cfg.algo.normalize_observations:
        keys = [(g, key) for g in groups for key in (OBSERVATION, MANAGER_OBSERVATION)]
        # Statistics are shared by the worlds and kept per agent slot; with mirrored
        # observations and a shared policy both teams' slots converge alike.
        norm = SafeVecNorm(keys, decay=cfg.algo.observation_decay, clip=cfg.algo.observation_clip)
        transforms.append(norm)
    if isinstance(base, TransformedEnv):
        # An env of another library comes with its contract's transforms: extend them
        # rather than nest a second TransformedEnv.
        for transform in transforms:
            base.append_transform(transform)
        return base
    return TransformedEnv(base, Compose(*transforms))


def group_names(env: EnvBase) -> list[str]:
    """The agent groups of a multi-agent env: the top-level entries of its action spec."""
    return [str(name) for name in env.full_action_spec.keys(include_nested=False)]


def network_config(cfg: TrainConfig) -> NetworkConfig:
    """The network shape of ``cfg.model`` (the same for every group).

    Examples:
        >>> from rlhc.config.train_schema import ModelConfig, TrainConfig
        >>> model = ModelConfig(num_layers=2, hidden_size=64, activation="silu", action_dist="gaussian")
        >>> net = network_config(TrainConfig(model=model))
        >>> net.hidden_size, net.action_dist
        (64, 'gaussian')
    """
    # Every field of the network schema, so that a setting added to it reaches the nets.
    fields = {
        field.name: getattr(cfg.model, field.name) for field in dataclasses.fields(NetworkConfig)
    }
    return NetworkConfig(**fields)


def trainable_parameters(losses: Mapping[str, torch.nn.Module]) -> list[torch.nn.Parameter]:
    """The trainable parameters of every group's loss (actor + both critics), once each."""
    seen: dict[int, torch.nn.Parameter] = {}
    for loss in losses.values():
        for parameter in loss.parameters():
            if parameter.requires_grad:
                seen.setdefault(id(parameter), parameter)
    return list(seen.values())


def make_agents(
    cfg: TrainConfig, env: EnvBase, *, learner_weighted: bool = False
) -> tuple[dict[str, torch.nn.Module], dict[str, HierarchicalPPOLoss]]:
    """One actor and one PPO loss (owning both critics) per group, on ``cfg.device``.

    ``env``'s specs size the networks. ``learner_weighted`` builds the losses for
    :func:`~rlhc.objectives.learner_weighted_loss`, as the trainer does: per-sample terms
    that it reduces and standardises under the learner weight; otherwise TorchRL's means
    and standardisation.
    """
    net = network_config(cfg)
    # A view of the whole world, the same for every agent: the manager critic runs once.
    shared_view = getattr(cfg.env, "manager_view", None) in SHARED_VIEWS
    actors: dict[str, torch.nn.Module] = {}
    losses: dict[str, HierarchicalPPOLoss] = {}
    for group in group_names(env):
        # On the device before the loss is built: the loss and the collection policy
        # then hold the same parameters (a loss moved afterwards would hold copies).
        actor = make_actor(env, group, net).to(cfg.device)
        worker_critic = make_worker_critic(env, group, net).to(cfg.device)
        manager_critic = make_manager_critic(
            env, group, net, manager_view=cfg.critic.manager_view, shared_view=shared_view
        ).to(cfg.device)
        actors[group] = actor
        losses[group] = make_ppo_loss(
            actor=actor,
            worker_critic=worker_critic,
            manager_critic=manager_critic,
            group=group,
            gamma=cfg.algo.gamma,
            lmbda=cfg.algo.lmbda,
            fusion=cfg.critic.fusion,
            weight=cfg.critic.weight,
            manager_interval=cfg.critic.manager_interval,
            clip_epsilon=cfg.algo.clip_epsilon,
            entropy_coef=cfg.algo.entropy_coef,
            critic_coef=cfg.algo.critic_coef,
            normalize_advantage=cfg.algo.normalize_advantage and not learner_weighted,
            reduction="none" if learner_weighted else "mean",
            manager_diagnostics=cfg.critic.manager_diagnostics,
            worker_diagnostics=cfg.critic.worker_diagnostics,
            # Collected batches are trajectories: the critics run once per batch.
            shifted=True,
            max_importance_ratio=cfg.algo.max_importance_ratio,
        ).to(cfg.device)
    return actors, losses
