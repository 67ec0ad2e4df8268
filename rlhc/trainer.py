"""The training loop: collector → hierarchical value estimator → PPO loss → Adam.

Read :meth:`Trainer.train` top to bottom: collect ``buffer_size`` agent-experiences per
group from every world, estimate fused values and advantages per group (RLHC), run
``epochs`` passes of minibatch PPO over the buffer, log, checkpoint. Both teams of a
game share each group's policy (symmetric self-play).

Units are ML-Agents 0.5's, the trainer the paper ran (see :class:`~rlhc.config.PPOConfig`
and :class:`~rlhc.builders.Layout`): the budget, summary and checkpoint periods count
world-decisions ("frames"), buffer and minibatch count agent-experiences per group.
"""

from __future__ import annotations

import contextlib
import copy
import logging
import math
import random
import sys
import time
from collections import defaultdict
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
import torch
from omegaconf import OmegaConf
from tensordict import TensorDictBase
from tensordict.nn import TensorDictModuleBase, TensorDictSequential
from torchrl.collectors import Collector
from torchrl.envs import EnvBase, TransformedEnv
from tqdm import tqdm
from tqdm.contrib.logging import logging_redirect_tqdm

from rlhc.builders import (
    EPISODE_REWARD,
    Layout,
    group_names,
    make_agents,
    make_training_env,
    network_config,
    validate,
)
from rlhc.checkpoint import (
    CHECKPOINT_DIR,
    ResumeError,
    config_differences,
    load_checkpoint,
    rng_states,
    save_checkpoint,
    set_rng_states,
)
from rlhc.config import PPOConfig, TrainConfig
from rlhc.envs import make_env
from rlhc.envs.base import BatchedGame
from rlhc.interrupt import StopSignals, TrainingInterrupted
from rlhc.league import LEARNER, LEARNER_TEAM, OPPONENT, League, LeaguePolicy
from rlhc.loggers import MetricLogger, ProgressLines
from rlhc.modules import make_actor
from rlhc.objectives import LOSS_KEYS

log = logging.getLogger(__name__)

#: Where ML-Agents 0.5 decays the entropy coefficient and the clip range to (linearly
#: over the budget, like the learning rate, which goes to 0).
FINAL_ENTROPY_COEF = 1e-5
FINAL_CLIP_EPSILON = 0.1

#: Loss-output diagnostics averaged over minibatches and logged per group.
LOSS_DIAGNOSTICS = (
    "loss_objective",
    "loss_critic",
    "loss_worker_critic",
    "loss_manager_critic",
    "loss_entropy",
    "entropy",
    "kl_approx",
    "clip_fraction",
    "explained_variance",
)


def seed_everything(seed: int) -> None:
    """Seed python, numpy and torch (the game has its own generator, seeded by the env)."""
    random.seed(seed)
    np.random.seed(seed)
    torch.manual_seed(seed)


def schedules(algo: PPOConfig, frames: int) -> tuple[float, float, float]:
    """Learning rate, entropy coefficient and clip range after ``frames`` world-decisions.

    As ML-Agents 0.5: each decays linearly over the budget (where enabled), the learning
    rate to 0, the entropy coefficient to 1e-5, the clip range to 0.1.

    Examples:
        >>> from rlhc.config import PPOConfig
        >>> schedules(PPOConfig(max_steps=100, lr=1e-3, entropy_coef=0.01), 50)
        (0.0005, 0.005005, 0.15000000000000002)
    """
    progress = min(1.0, frames / algo.max_steps)
    lr = algo.lr * (1.0 - progress) if algo.anneal_lr else algo.lr
    entropy_coef = algo.entropy_coef
    if algo.anneal_entropy_coef:
        entropy_coef += (FINAL_ENTROPY_COEF - entropy_coef) * progress
    clip_epsilon = algo.clip_epsilon
    if algo.anneal_clip_epsilon:
        clip_epsilon += (FINAL_CLIP_EPSILON - clip_epsilon) * progress
    return lr, entropy_coef, clip_epsilon


def learner_weight(data: TensorDictBase, group: str) -> torch.Tensor:
    """``float [B, n_g]``: 1 where the learning policy chose the action, else 0.

    All ones without a league; in a league world the opponent team's agents weigh 0,
    so their experiences carry no gradient and no statistics.
    """
    learner = data.get((group, LEARNER), None)
    if learner is None:
        return torch.ones(data[group, "action_log_prob"].shape[: data.ndim + 1])
    return learner.reshape(*learner.shape[: data.ndim + 1]).float()


def weighted_mean(value: torch.Tensor, weight: torch.Tensor) -> torch.Tensor:
    """The mean of ``value`` (a per-sample ``[B, n_g]`` term, or a scalar) under ``weight``."""
    if value.dim() == 0:
        return value
    return (value.reshape(weight.shape) * weight).sum() / weight.sum().clamp_min(1.0)


def standardise_advantage(data: TensorDictBase, group: str, weight: torch.Tensor) -> None:
    """Standardise ``(group, "advantage")`` of a minibatch in place, per agent slot.

    Over the experiences of weight 1 only (all of them without a league), as TorchRL's
    MAPPO does per slot; the losses are built with their own normalisation off.
    """
    advantage = data[group, "advantage"]
    shaped = advantage.reshape(weight.shape)
    count = weight.sum(dim=0).clamp_min(1.0)
    mean = (shaped * weight).sum(dim=0) / count
    var = (((shaped - mean) ** 2) * weight).sum(dim=0) / count
    standard = (shaped - mean) / (var.sqrt() + 1e-8)
    data.set((group, "advantage"), standard.reshape(advantage.shape))


def config_container(cfg: TrainConfig) -> dict[str, Any]:
    """``cfg`` as the plain nested dict a checkpoint stores."""
    return OmegaConf.to_container(OmegaConf.structured(cfg), resolve=True)  # type: ignore[return-value]


def check_resumable(cfg: TrainConfig, state: Mapping[str, Any]) -> None:
    """Refuse to continue ``state`` with settings its weights do not belong to.

    Args:
        cfg: the config of the run that would continue.
        state: a loaded checkpoint (:func:`~rlhc.checkpoint.load_checkpoint`).

    Raises:
        ResumeError: naming every differing setting (:func:`~rlhc.checkpoint.config_differences`).
    """
    stored = state.get("config") or {"env": {"name": state["env"]}}
    differing = config_differences(stored, config_container(cfg))
    if differing:
        raise ResumeError(
            f"resume={cfg.resume!r}: {state['path']} was trained with other settings, and a "
            f"resume cannot change them (checkpoint -> now): {'; '.join(differing)}"
        )


def cut_trajectories(batch: TensorDictBase, groups: list[str], horizon: int) -> None:
    """Cut every world's trajectory each ``horizon`` decisions of ``batch`` ``[N, T]``.

    ML-Agents cuts an agent's trajectory every ``time_horizon`` decisions and bootstraps
    there. A cut is a ``done`` that is not ``terminated`` (set in place on each group's
    ``("next", g, "done")``): GAE stops accumulating at it and bootstraps from the next
    observation's value. Nothing changes when ``T <= horizon``: the end of a batch is a
    cut anyway.
    """
    steps = batch.shape[-1]
    if steps <= horizon:
        return
    cut = torch.zeros(steps, dtype=torch.bool)
    cut[horizon - 1 :: horizon] = True
    for group in groups:
        done = batch["next", group, "done"]
        shape = (1, steps) + (1,) * (done.dim() - 2)
        batch["next", group, "done"] = done | cut.view(shape)


class Trainer:
    """Trains one policy per agent group with PPO and a hierarchical value estimate.

    Args:
        cfg: a validated training config.
        run_dir: where ``metrics.csv``, TensorBoard files and checkpoints go.
        env: the collection env; ``None`` builds the batched game of ``cfg.env``. Another
            env (e.g. TorchRL's ``PettingZooWrapper`` route, for benchmarks) must follow
            the same TensorDict contract, with episode returns and observation norm from
            :func:`~rlhc.builders.with_training_transforms`.

    Examples:
        >>> from hydra import compose, initialize_config_dir  # doctest: +SKIP
        >>> trainer = Trainer(cfg, Path("outputs/demo"))  # doctest: +SKIP
        >>> trainer.train()  # doctest: +SKIP
    """

    def __init__(self, cfg: TrainConfig, run_dir: Path, env: TransformedEnv | None = None) -> None:
        validate(cfg)
        self.cfg = cfg
        self.run_dir = run_dir
        self.layout = Layout.from_config(cfg)
        if cfg.threads > 0:
            torch.set_num_threads(cfg.threads)
        resume = load_checkpoint(cfg.resume) if cfg.resume else None
        if resume is not None:
            check_resumable(cfg, resume)
        seed_everything(cfg.seed)

        self.env = (
            env if env is not None else make_training_env(cfg, self.layout.num_envs, cfg.seed)
        )
        self.groups = group_names(self.env)
        self.actors, self.losses = make_agents(cfg, self.env)
        for loss in self.losses.values():
            # Per-sample terms, reduced here under the learner weights (league worlds),
            # and advantages standardised here over the learner's experiences only.
            loss.reduction = "none"
            loss.normalize_advantage = False
        self.policy = TensorDictSequential(*self.actors.values())
        self.league: League | None = None
        self.collection_policy: TensorDictModuleBase = self.policy
        if cfg.league.active:
            self.league = League(cfg.league, self.layout.num_envs, cfg.seed)
            net = network_config(cfg)
            self.collection_policy = LeaguePolicy(
                self.policy, self.league, self.env, lambda g: make_actor(self.env, g, net)
            )
        # fused: one kernel over all parameters (on CPU too), ~9% of a soccer update.
        self.parameters = self._parameters()
        self.optimizer = torch.optim.Adam(self.parameters, lr=cfg.algo.lr, fused=True)

        self._eval_env: EnvBase | None = None
        self.frames = 0
        self.iteration = 0
        self.wall_time = 0.0
        if resume is not None:
            self._restore(resume)
        self.logger = MetricLogger(
            cfg.logger,
            run_dir,
            run_name=run_dir.name,
            config=config_container(cfg),
            resume_step=self.frames if resume is not None else None,
        )

    # --- the loop -------------------------------------------------------------------
    def train(self) -> dict[str, float]:
        """Train until ``algo.max_steps`` frames; returns the last logged metrics.

        SIGINT and SIGTERM stop it cleanly (:mod:`rlhc.interrupt`): the update in
        progress finishes (a collection in progress too), a checkpoint is written and
        :class:`~rlhc.interrupt.TrainingInterrupted` is raised. A progress line goes to
        the ``logging`` module every tenth of the budget (with the bar on a terminal,
        above it).

        Raises:
            TrainingInterrupted: on SIGINT or SIGTERM, after the checkpoint is written.
        """
        cfg = self.cfg
        remaining = cfg.algo.max_steps - self.frames
        last_metrics: dict[str, float] = {}
        if remaining <= 0:
            return last_metrics
        collector = Collector(
            self.env,
            self.collection_policy,
            frames_per_batch=self.layout.frames_per_batch,
            total_frames=math.ceil(remaining / self.layout.frames_per_batch)
            * self.layout.frames_per_batch,
            # The policy is stateless (no recurrent state to initialise).
            auto_register_policy_transforms=False,
        )
        progress = tqdm(
            total=cfg.algo.max_steps,
            initial=self.frames,
            unit="frames",
            disable=not self._show_progress(),
            dynamic_ncols=True,
        )
        lines = ProgressLines(cfg.algo.max_steps, self.frames)
        stop = StopSignals()
        saved: tuple[int, Path] | None = None
        episodes: dict[str, list[torch.Tensor]] = defaultdict(list)
        summary: dict[str, list[float]] = defaultdict(list)
        start = time.perf_counter() - self.wall_time
        collect_start = time.perf_counter()
        with contextlib.ExitStack() as context:
            if not progress.disable:
                context.enter_context(logging_redirect_tqdm())
            context.callback(self.logger.close)
            context.callback(collector.shutdown)
            context.callback(progress.close)
            context.enter_context(stop)
            for batch in collector:
                collect_time = time.perf_counter() - collect_start
                self._collect_episode_stats(batch, episodes)
                if self.league is not None:
                    self._record_league(batch)
                update_start = time.perf_counter()
                self._set_schedules()
                for name, value in self._update(batch).items():
                    summary[name].append(value)
                update_time = time.perf_counter() - update_start

                previous, self.frames = self.frames, self.frames + batch.numel()
                self.iteration += 1
                if self.league is not None and self.iteration % cfg.league.snapshot_interval == 0:
                    self.league.add_snapshot(self.actors)
                self.wall_time = time.perf_counter() - start
                summary["env_steps_per_s"].append(batch.numel() / collect_time)
                summary["train_frames_per_s"].append(batch.numel() / (collect_time + update_time))
                progress.update(self.frames - previous)

                if self._crossed(previous, cfg.logger.summary_freq) or self._finished():
                    last_metrics = self._summarise(summary, episodes)
                    if cfg.eval_freq and self._crossed(previous, cfg.eval_freq):
                        last_metrics.update(self.evaluate())
                    self.logger.log(self.frames, last_metrics)
                    progress.set_postfix(self._postfix(last_metrics))
                    summary.clear()
                    episodes.clear()
                if self._crossed(previous, cfg.checkpoint_freq) or self._finished():
                    saved = (self.frames, self.save())
                line = lines.update(self.frames, collect_time, last_metrics)
                if line is not None:
                    log.info(line)
                if self._finished() or stop.received is not None:
                    break
                collect_start = time.perf_counter()
        if stop.received is not None and not self._finished():
            checkpoint = saved[1] if saved and saved[0] == self.frames else self.save()
            raise TrainingInterrupted(stop.received, self.frames, checkpoint)
        return last_metrics

    def _update(self, batch: TensorDictBase) -> dict[str, float]:
        """Estimate advantages per group, then ``epochs`` passes of minibatch PPO."""
        algo = self.cfg.algo
        layout = self.layout
        stats: dict[str, list[float]] = defaultdict(list)
        cut_trajectories(batch, self.groups, layout.time_horizon)
        with torch.no_grad():
            for group, loss in self.losses.items():
                loss.value_estimator(batch)
                for key in ("state_value", "worker_value", "manager_value", "manager_selected"):
                    stats[f"{group}/{key}"].append(batch[group, key].float().mean().item())
        flat = batch.reshape(-1)
        used = layout.minibatches * layout.minibatch_frames
        for _ in range(algo.epochs):
            # As ML-Agents 0.5: whole minibatches only, the shuffled remainder left out.
            for index in torch.randperm(flat.numel())[:used].split(layout.minibatch_frames):
                total = self.minibatch_loss(flat[index], stats)
                self.optimizer.zero_grad(set_to_none=True)
                total.backward()
                grad_norm = torch.nn.utils.clip_grad_norm_(self.parameters, algo.max_grad_norm)
                stats["grad_norm"].append(grad_norm.item())
                self.optimizer.step()
        return {name: float(np.mean(values)) for name, values in stats.items()}

    def minibatch_loss(
        self, minibatch: TensorDictBase, stats: dict[str, list[float]] | None = None
    ) -> torch.Tensor:
        """The summed PPO loss of every group on a minibatch (advantages already in it).

        Every term is averaged under :func:`learner_weight`: an experience that an
        opponent chose (a league world) adds nothing. Diagnostics go to ``stats``.
        """
        total = torch.zeros(())
        for group, loss in self.losses.items():
            weight = learner_weight(minibatch, group)
            if self.cfg.algo.normalize_advantage:
                standardise_advantage(minibatch, group, weight)
            out = loss(minibatch)
            total = total + sum(weighted_mean(out[term], weight) for term in LOSS_KEYS)
            if stats is not None:
                for key in LOSS_DIAGNOSTICS:
                    if key in out:
                        value = weighted_mean(out[key].detach().float(), weight)
                        stats[f"{group}/{key}"].append(value.item())
        return total

    def _record_league(self, batch: TensorDictBase) -> None:
        """Feed the results of the episodes that ended against league opponents to Elo."""
        assert self.league is not None
        done = batch["next", "done"].squeeze(-1)
        if not done.any():
            return
        opponent = batch[OPPONENT].squeeze(-1)[done].numpy()
        learner_team = batch[LEARNER_TEAM].squeeze(-1)[done].numpy()
        scoring = batch["next", "scoring_team"].squeeze(-1)[done].numpy()
        scores = np.where(scoring < 0, 0.5, (scoring == learner_team).astype(float))
        self.league.record(opponent, scores)

    # --- metrics --------------------------------------------------------------------
    def _collect_episode_stats(
        self, batch: TensorDictBase, episodes: dict[str, list[torch.Tensor]]
    ) -> None:
        """Returns and lengths of the episodes that ended in ``batch``; game events."""
        done = batch["next", "done"].squeeze(-1)
        if ("next", "info") in batch.keys(include_nested=True):
            for key, value in batch["next", "info"].items():
                # Events per episode: summed over the window, divided by its episodes.
                per_world = value.reshape(*batch.shape, -1).sum(dim=(0, 1))
                episodes[f"events/{key}"].append(per_world)
        if not done.any():
            return
        episodes["episode_length"].append(batch["next", "step_count"][done].float().flatten())
        # The share of episodes the game ended (a point, a goal) before the time cap.
        terminated = batch["next", "terminated"].squeeze(-1)[done]
        episodes["episode_terminated"].append(terminated.float().flatten())
        for group in self.groups:
            # [episodes, n_g, 1] → one number per episode: the group's mean return.
            returns = batch["next", group, EPISODE_REWARD][done].float()
            episodes[f"{group}/cumulative_reward"].append(returns.mean(dim=(-2, -1)))

    def _summarise(
        self, summary: dict[str, list[float]], episodes: dict[str, list[torch.Tensor]]
    ) -> dict[str, float]:
        metrics = {name: float(np.mean(values)) for name, values in summary.items()}
        count = float(sum(len(c) for c in episodes.get("episode_length", [])))
        for name, chunks in episodes.items():
            if name.startswith("events/"):
                totals = torch.stack(chunks).sum(dim=0) / max(count, 1.0)
                if totals.numel() == 1:
                    metrics[f"{name}_per_episode"] = totals.item()
                else:
                    for index, total in enumerate(totals.tolist()):
                        metrics[f"{name}_{index}_per_episode"] = total
            else:
                metrics[name] = torch.cat(chunks).mean().item()
        metrics["episodes"] = count
        if self.league is not None:
            metrics.update(self.league.metrics())
        metrics["frames"] = float(self.frames)
        for group in self.groups:
            metrics[f"{group}/experiences"] = float(self.frames * self.layout.agents_per_world)
        metrics["updates"] = float(self.iteration)
        metrics["lr"] = self.optimizer.param_groups[0]["lr"]
        first_loss = next(iter(self.losses.values()))
        metrics["entropy_coef"] = float(first_loss.entropy_coeff)
        metrics["clip_epsilon"] = float(first_loss.clip_epsilon)
        metrics["wall_time"] = self.wall_time
        metrics["iteration"] = float(self.iteration)
        return dict(sorted(metrics.items()))

    @staticmethod
    def _postfix(metrics: dict[str, float]) -> dict[str, str]:
        shown = {"steps/s": f"{metrics.get('train_frames_per_s', float('nan')):.0f}"}
        for name, value in metrics.items():
            if name.endswith("/cumulative_reward"):
                shown[name.split("/")[0]] = f"{value:+.3f}"
        return shown

    def evaluate(self) -> dict[str, float]:
        """Win/draw rates of the current policy (mode actions) against the scripted team."""
        from rlhc.evaluation.matches import evaluate_against
        from rlhc.evaluation.policies import RestoredPolicy, normaliser_statistics

        if self._eval_env is None:
            self._eval_env = make_env(
                self.cfg.env.name,
                num_envs=min(16, self.cfg.eval_matches),
                seed=self.cfg.seed + 1,
                **self.cfg.env.game_options(),
            )
        # The live actors, copied, behind a frozen copy of the running normaliser.
        actors = {g: copy.deepcopy(actor).eval() for g, actor in self.actors.items()}
        policy = RestoredPolicy(actors, *normaliser_statistics(self.env.transform, actors))
        result = evaluate_against(policy, "scripted", self._eval_env, self.cfg.eval_matches)
        return {
            "eval/win_rate": float(result["win_rate"]),
            "eval/draw_rate": float(result["draw_rate"]),
        }

    # --- checkpoints ----------------------------------------------------------------
    def state(self) -> dict[str, Any]:
        """Everything a resume (or an evaluation) needs."""
        return {
            "env": self.cfg.env.name,
            "config": OmegaConf.to_container(OmegaConf.structured(self.cfg), resolve=True),
            "frames": self.frames,
            "iteration": self.iteration,
            "wall_time": self.wall_time,
            "actors": {g: actor.state_dict() for g, actor in self.actors.items()},
            "losses": {g: loss.state_dict() for g, loss in self.losses.items()},
            "optimizer": self.optimizer.state_dict(),
            "env_transform": self.env.transform.state_dict(),
            "game_rng": self._game.rng.bit_generator.state if self._game else None,
            "league": self.league.state_dict() if self.league is not None else None,
            "rng": rng_states(),
        }

    def save(self) -> Path:
        path = self.run_dir / CHECKPOINT_DIR / f"step_{self.frames:09d}.pt"
        save_checkpoint(path, self.state())
        return path

    def _restore(self, state: dict[str, Any]) -> None:
        for group, loss in self.losses.items():
            loss.load_state_dict(state["losses"][group])
        self.optimizer.load_state_dict(state["optimizer"])
        self.env.transform.load_state_dict(state["env_transform"])
        if self._game is not None and state["game_rng"] is not None:
            self._game.rng.bit_generator.state = state["game_rng"]
        if self.league is not None and state.get("league") is not None:
            self.league.load_state_dict(state["league"])
        set_rng_states(state["rng"])
        self.frames = int(state["frames"])
        self.iteration = int(state["iteration"])
        self.wall_time = float(state["wall_time"])

    # --- helpers --------------------------------------------------------------------
    @property
    def _game(self) -> BatchedGame | None:
        """The numpy game behind the env (``None`` for an env of another kind)."""
        return getattr(self.env.base_env, "game", None)

    def _parameters(self) -> list[torch.nn.Parameter]:
        """The trainable parameters of every group's loss (actor + both critics), once each."""
        seen: dict[int, torch.nn.Parameter] = {}
        for loss in self.losses.values():
            for parameter in loss.parameters():
                if parameter.requires_grad:
                    seen.setdefault(id(parameter), parameter)
        return list(seen.values())

    def _set_schedules(self) -> None:
        lr, entropy_coef, clip_epsilon = schedules(self.cfg.algo, self.frames)
        for group in self.optimizer.param_groups:
            group["lr"] = lr
        for loss in self.losses.values():
            # Schedulable buffers of TorchRL's PPO losses: assignment updates them in place.
            loss.entropy_coeff = entropy_coef
            loss.clip_epsilon = clip_epsilon

    def _crossed(self, previous: int, every: int) -> bool:
        return previous // every != self.frames // every

    def _finished(self) -> bool:
        return self.frames >= self.cfg.algo.max_steps

    def _show_progress(self) -> bool:
        if self.cfg.logger.progress is not None:
            return self.cfg.logger.progress
        return sys.stderr.isatty()
