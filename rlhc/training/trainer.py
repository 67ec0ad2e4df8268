"""The training loop: collector → hierarchical value estimator → PPO loss → Adam.

Read :meth:`Trainer.train` top to bottom: collect, :meth:`Trainer.update`, log,
checkpoint. Both teams share each group's policy (symmetric self-play). Units are
ML-Agents 0.5's (:class:`~rlhc.building.builders.Layout`): the budget and periods count
world-decisions ("frames"), buffer and minibatch agent-experiences per group.
"""

from __future__ import annotations

import contextlib
import logging
import signal
import sys
import time
from collections import defaultdict
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
import torch
from tensordict import TensorDictBase
from tensordict.nn import TensorDictModuleBase
from torchrl.envs import TransformedEnv

from rlhc.building.builders import (
    Layout,
    group_names,
    make_agents,
    make_training_env,
    network_config,
    trainable_parameters,
)
from rlhc.config.train_schema import TrainConfig, adapted_lr, schedules
from rlhc.config.validation import validate
from rlhc.envs.keys import MANAGER_SELECTED, MANAGER_VALUE, STATE_VALUE, WORKER_VALUE
from rlhc.modules import make_actor
from rlhc.modules.policies import GroupPolicies
from rlhc.objectives import WeightedLoss, cut_trajectories, learner_weighted_loss
from rlhc.storage.checkpoint import CHECKPOINT_DIR, save_checkpoint, seed_everything
from rlhc.storage.final_team import save_team
from rlhc.training.compilation import compiled
from rlhc.training.distributed import Processes
from rlhc.training.interrupt import StopSignals, TrainingInterrupted
from rlhc.training.league import League, LeaguePolicy
from rlhc.training.loggers import MetricLogger
from rlhc.training.strategies import make_strategy
from rlhc.training.summaries import ProgressReport, ScriptedMatches, SummaryWindow, play_metrics
from rlhc.training.training_state import (
    Counters,
    checkpoint_to_resume,
    config_container,
    restore_training_state,
    training_state,
)

log = logging.getLogger(__name__)


class Trainer:
    """Trains one policy per agent group with PPO and a hierarchical value estimate.

    Args:
        cfg: a validated training config.
        run_dir: where ``metrics.csv``, TensorBoard files and checkpoints go.
        env: the collection env; ``None`` builds the batched game of ``cfg.env``. Another
            env needs the transforms of :func:`~rlhc.building.builders.with_training_transforms`.
        processes: this process's place in a ``torchrun`` run; ``None``: one process.
        resume_state: the checkpoint to continue, already loaded; ``None`` loads
            ``cfg.resume`` if set.

    Examples:
        >>> trainer = Trainer(cfg, Path("outputs/demo"))  # doctest: +SKIP
        >>> trainer.train()  # doctest: +SKIP
    """

    def __init__(
        self,
        cfg: TrainConfig,
        run_dir: Path,
        env: TransformedEnv | None = None,
        processes: Processes | None = None,
        *,
        resume_state: Mapping[str, Any] | None = None,
    ) -> None:
        processes = processes if processes is not None else Processes(mode=cfg.parallel)
        validate(cfg, processes.size)
        self.cfg = cfg
        self.run_dir = run_dir
        # Networks, losses and the update; the games run on CPU (the collector moves data).
        self.device = torch.device(cfg.device)
        self.strategy = make_strategy(
            processes, normalize_observations=cfg.algo.normalize_observations
        )
        self.layout = Layout.from_config(cfg, self.strategy.shards)
        if cfg.threads > 0:
            torch.set_num_threads(cfg.threads)
        resume = checkpoint_to_resume(cfg, resume_state, load=self.strategy.main)
        if cfg.resume:
            resume = self.strategy.share(resume)
        # The same seed everywhere: every process builds the same initial networks.
        seed_everything(cfg.seed)
        seed = self.strategy.process_seed(cfg.seed)
        worlds = self.strategy.local_worlds(self.layout)
        self.env = env if env is not None else make_training_env(cfg, worlds, seed)
        self.groups = group_names(self.env)
        #: Agents of each group in one world.
        self.group_sizes = {g: self.env.full_action_spec[g].shape[-1] for g in self.groups}
        # Per-sample losses: every term is averaged under the learner weight (league worlds).
        self.actors, self.losses = make_agents(cfg, self.env, learner_weighted=True)
        self.policy = GroupPolicies(self.actors)
        self.league: League | None = None
        self.collection_policy: TensorDictModuleBase = self.policy
        if cfg.league.active:
            self.league = League(cfg.league, worlds, seed)
            net = network_config(cfg)
            self.collection_policy = LeaguePolicy(
                self.policy,
                self.league,
                self.env,
                lambda g: make_actor(self.env, g, net).to(self.device),
            )
        # fused: one kernel over all parameters (on CPU too), ~9% of a soccer update.
        self.parameters = trainable_parameters(self.losses)
        self.optimizer = torch.optim.Adam(self.parameters, lr=cfg.algo.lr, fused=True)
        self._minibatch_loss = compiled(self.minibatch_loss) if cfg.compile else self.minibatch_loss
        self.scripted_matches = ScriptedMatches(cfg)
        self.frames, self.iteration, self.wall_time = 0, 0, 0.0
        if resume is not None:
            self.frames, self.iteration, self.wall_time = restore_training_state(
                resume,
                losses=self.losses,
                optimizer=self.optimizer,
                env=self.env,
                league=self.league,
                restore_game_rng=self.strategy.restores_game_rng,
            )
        self.strategy.synchronise(self.parameters, (seed + self.frames) % 2**32)
        self.logger: MetricLogger | None = None
        if self.strategy.main:
            resume_step = self.frames if resume is not None else None
            self.logger = MetricLogger(cfg.logger, run_dir, config_container(cfg), resume_step)

    # --- the loop -------------------------------------------------------------------
    def train(self) -> dict[str, float]:
        """Train until ``algo.max_steps`` frames; returns the last logged metrics.

        Raises:
            TrainingInterrupted: on SIGINT or SIGTERM, once the update in progress is
                done and a checkpoint written (:mod:`rlhc.training.interrupt`).
        """
        cfg, strategy = self.cfg, self.strategy
        remaining = cfg.algo.max_steps - self.frames
        if remaining <= 0:
            return {}
        if not strategy.learns:  # a pipeline's collecting process
            strategy.serve(self.env, self.collection_policy, self.layout, self._actor_parameters())
            return {}
        bar = cfg.logger.progress if cfg.logger.progress is not None else sys.stderr.isatty()
        report = ProgressReport(
            cfg.algo.max_steps,
            self.frames,
            bar=strategy.main and bar,
            log=log if strategy.main else None,
        )
        window = SummaryWindow()
        last_metrics: dict[str, float] = {}
        summarised_at = self.frames  # frames at the last row of metrics.csv
        saved: tuple[int, Path] | None = None
        stop, stopping = StopSignals(), False
        start = time.perf_counter() - self.wall_time
        collect_start = time.perf_counter()
        with contextlib.ExitStack() as context:
            context.enter_context(report)
            if self.logger is not None:
                context.callback(self.logger.close)
            context.enter_context(stop)
            batches = strategy.batches(
                self.env, self.collection_policy, self.layout, remaining, self.device
            )
            for batch in context.enter_context(contextlib.closing(batches)):
                # Collected: record its episodes, combine what the processes saw.
                collect_time = time.perf_counter() - collect_start
                window.add_episodes(batch, self.groups)
                if self.league is not None:
                    # Every process records every result: the ratings stay the same everywhere.
                    self.league.record_batch(batch, strategy.gather)
                strategy.after_collection(self.env)
                # Estimate, then epochs of minibatches.
                update_start = time.perf_counter()
                window.add_update(self.update(batch))
                update_time = time.perf_counter() - update_start

                frames = batch.numel() * strategy.shards
                previous, self.frames = self.frames, self.frames + frames
                self.iteration += 1
                if self.league is not None and self.iteration % cfg.league.snapshot_interval == 0:
                    self.league.add_snapshot(self.actors)
                self.wall_time = time.perf_counter() - start
                env_rate = strategy.env_steps_per_s(frames, collect_time)
                train_rate = frames / (collect_time + update_time)
                window.add_update({"env_steps_per_s": env_rate, "train_frames_per_s": train_rate})
                # Log, checkpoint.
                if self._crossed(previous, cfg.logger.summary_freq) or self._finished():
                    last_metrics = self._summarise(window, summarised_at)
                    summarised_at = self.frames
                    report.summarised(last_metrics)
                if self._crossed(previous, cfg.checkpoint_freq) or self._finished():
                    saved = (self.frames, self.save())
                report.advance(self.frames, frames, frames / env_rate, last_metrics)
                stopping = strategy.stop_requested(stop.received is not None)
                go_on = not (self._finished() or stopping)
                strategy.after_update(self._actor_parameters(), go_on)
                if not go_on:
                    break
                collect_start = time.perf_counter()
        if stopping and not self._finished():
            # Another process's signal stops this one too (data-parallel).
            signum = stop.received if stop.received is not None else signal.SIGTERM
            checkpoint = saved[1] if saved and saved[0] == self.frames else self.save()
            raise TrainingInterrupted(signum, self.frames, checkpoint)
        return last_metrics

    def collect_batch(self) -> TensorDictBase:
        """One batch ``[worlds, decisions]`` as :meth:`train` collects them, the counters
        not advanced (for checks)."""
        batches = self.strategy.batches(
            self.env, self.collection_policy, self.layout, self.layout.frames_per_batch, self.device
        )
        with contextlib.closing(batches):
            return next(batches)

    def update(self, batch: TensorDictBase) -> dict[str, float]:
        """One PPO update on a collected batch ``[worlds, decisions]``.

        At the schedules of the current frame count: cut the trajectories at the time
        horizon, estimate fused values and advantages per group, then ``algo.epochs``
        passes of shuffled minibatches (whole ones only, as ML-Agents 0.5); with
        ``algo.target_kl``, then adapt the learning rate to the update's mean KL.

        Returns:
            Means over the minibatches: ``<group>/<value, loss or diagnostic>``, ``grad_norm``.
        """
        self._set_schedules()
        algo, layout = self.cfg.algo, self.layout
        # Scalar tensors, read once at the end: nothing in the loop waits on the device.
        stats: dict[str, list[torch.Tensor]] = defaultdict(list)
        cut_trajectories(batch, self.groups, layout.time_horizon)
        with torch.no_grad():
            for group, loss in self.losses.items():
                loss.value_estimator(batch)
                for key in (STATE_VALUE, WORKER_VALUE, MANAGER_VALUE, MANAGER_SELECTED):
                    if (group, key) in batch.keys(include_nested=True):  # PPO: no manager
                        stats[f"{group}/{key}"].append(batch[group, key].float().mean())
        # The minibatches need no ("next", ...) entry once the advantages are in: half
        # the entries fewer to index and for the loss to copy, the same arithmetic.
        flat = batch.exclude("next").reshape(-1)
        # Data-parallel: this process's share of every minibatch, from its own worlds.
        share = layout.minibatch_frames // self.strategy.shards
        for _ in range(algo.epochs):
            order = torch.randperm(flat.numel())[: layout.minibatches * share]
            for index in order.split(share):
                for name, value in self.step(flat[index]).items():
                    stats[name].append(value)
        if algo.target_kl is not None:
            self._adapt_lr(stats)
        return {
            name: float(np.mean(torch.stack(values).tolist())) for name, values in stats.items()
        }

    def step(self, minibatch: TensorDictBase) -> dict[str, torch.Tensor]:
        """:meth:`backward`, the gradient clipped, Adam's step (eager, also compiled); the
        loss's diagnostics and ``grad_norm`` (before clipping)."""
        diagnostics = self.backward(minibatch)
        grad_norm = torch.nn.utils.clip_grad_norm_(self.parameters, self.cfg.algo.max_grad_norm)
        self.optimizer.step()
        return {**diagnostics, "grad_norm": grad_norm.detach()}

    def backward(self, minibatch: TensorDictBase) -> dict[str, torch.Tensor]:
        """Set every parameter's gradient to that of :meth:`minibatch_loss`; its diagnostics.

        Data-parallel, ``minibatch`` is this process's share and the gradients are summed
        over the processes: each holds the gradient one process computes on the whole.
        """
        total, diagnostics = self._minibatch_loss(minibatch)
        self.optimizer.zero_grad(set_to_none=True)
        total.backward()
        self.strategy.reduce_gradients(self.parameters)
        return diagnostics

    def minibatch_loss(self, minibatch: TensorDictBase) -> WeightedLoss:
        """The summed PPO loss of every group on a minibatch (advantages already in it),
        and its diagnostics ``<group>/<key>``.

        Every term is averaged under the learner weight
        (:func:`~rlhc.objectives.learner_weighted_loss`): an opponent's experience adds nothing.
        """
        total = torch.zeros((), device=self.device)
        diagnostics: dict[str, torch.Tensor] = {}
        for group, loss in self.losses.items():
            out = learner_weighted_loss(
                loss,
                minibatch,
                normalize_advantage=self.cfg.algo.normalize_advantage,
                reduce=self.strategy.reduce_sum,
            )
            total = total + out.total
            for key, value in out.diagnostics.items():
                diagnostics[f"{group}/{key}"] = value
        return WeightedLoss(total, diagnostics)

    # --- metrics --------------------------------------------------------------------
    def _summarise(self, window: SummaryWindow, summarised_at: int) -> dict[str, float]:
        """One row of ``metrics.csv``: the window, the counters, and the measurements whose
        period (``eval_freq``, ``play_freq``) was crossed since ``summarised_at`` frames."""
        metrics = window.metrics(self.strategy.gather)
        window.clear()
        if self.league is not None:
            metrics.update(self.league.metrics())
        metrics["frames"] = float(self.frames)
        for group in self.groups:
            metrics[f"{group}/experiences"] = float(self.frames * self.group_sizes[group])
        metrics["updates"] = float(self.iteration)
        metrics["lr"] = self.optimizer.param_groups[0]["lr"]
        first_loss = next(iter(self.losses.values()))
        metrics["entropy_coef"] = float(first_loss.entropy_coeff)
        metrics["clip_epsilon"] = float(first_loss.clip_epsilon)
        metrics["wall_time"] = self.wall_time
        metrics["iteration"] = float(self.iteration)
        metrics = dict(sorted(metrics.items()))
        if self.strategy.main:
            if self.cfg.eval_freq and self._crossed(summarised_at, self.cfg.eval_freq):
                metrics.update(self.scripted_matches(self.actors, self.env.transform))
            if self.cfg.play_freq and self._crossed(summarised_at, self.cfg.play_freq):
                metrics.update(play_metrics(self.state(), self.cfg))
        if self.logger is not None:
            self.logger.log(self.frames, metrics)
        return metrics

    # --- checkpoints ----------------------------------------------------------------
    def state(self) -> dict[str, Any]:
        """Everything a resume (or an evaluation) needs (:mod:`rlhc.training.training_state`)."""
        return training_state(
            self.cfg,
            Counters(self.frames, self.iteration, self.wall_time),
            actors=self.actors,
            losses=self.losses,
            optimizer=self.optimizer,
            env=self.env,
            game_rng=self.strategy.game_rng_state(self.env),
            league=self.league,
        )

    def save(self) -> Path:
        """Write a checkpoint (rank 0 only: the others hold the same state), and at the end
        of the budget the final team; the checkpoint's path."""
        path = self.run_dir / CHECKPOINT_DIR / f"step_{self.frames:09d}.pt"
        if self.strategy.main:
            state = self.state()
            save_checkpoint(path, state)
            if self._finished():
                save_team(self.run_dir, state)
        return path

    # --- helpers --------------------------------------------------------------------
    def _actor_parameters(self) -> list[torch.nn.Parameter]:
        return [p for actor in self.actors.values() for p in actor.parameters()]

    def _set_schedules(self) -> None:
        lr, entropy_coef, clip_epsilon = schedules(self.cfg.algo, self.frames)
        if self.cfg.algo.target_kl is None:  # else the rate is adapted after each update
            self._set_lr(lr)
        for loss in self.losses.values():
            # Schedulable buffers of TorchRL's PPO losses: assignment updates them in place.
            loss.entropy_coeff = entropy_coef
            loss.clip_epsilon = clip_epsilon

    def _set_lr(self, lr: float) -> None:
        for group in self.optimizer.param_groups:
            group["lr"] = lr

    def _adapt_lr(self, stats: dict[str, list[torch.Tensor]]) -> None:
        # The update's mean KL over groups and minibatches, the same on every process
        # (data-parallel: each averaged its share), read once per update.
        kl = torch.stack([torch.stack(stats[f"{g}/kl_approx"]).mean() for g in self.groups])
        kl = self.strategy.reduce_sum(kl.mean().detach().clone()) / self.strategy.shards
        lr = self.optimizer.param_groups[0]["lr"]
        self._set_lr(adapted_lr(lr, float(kl), self.cfg.algo))

    def _crossed(self, previous: int, every: int) -> bool:
        return previous // every != self.frames // every

    def _finished(self) -> bool:
        return self.frames >= self.cfg.algo.max_steps
