"""The training loop: collector → hierarchical value estimator → PPO loss → Adam.

Read :meth:`Trainer.train` top to bottom: collect ``buffer_size`` agent-experiences per
group from every world, estimate fused values and advantages per group (RLHC), run
``epochs`` passes of minibatch PPO over the buffer, log, checkpoint. Both teams of a
game share each group's policy (symmetric self-play).

Units are ML-Agents 0.5's, the trainer the paper ran (see :class:`~rlhc.config.PPOConfig`
and :class:`~rlhc.builders.Layout`): the budget, summary and checkpoint periods count
world-decisions ("frames"), buffer and minibatch count agent-experiences per group.

Under ``torchrun`` the same loop runs on every process (:mod:`rlhc.distributed`):
data-parallel, each on its share of the worlds and of every minibatch, or as a
pipeline, rank 0 updating while rank 1 collects.
"""

from __future__ import annotations

import contextlib
import copy
import logging
import math
import random
import signal
import sys
import time
from collections import defaultdict
from collections.abc import Iterator, Mapping
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
    Layout,
    group_names,
    make_agents,
    make_training_env,
    network_config,
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
from rlhc.distributed import (
    Processes,
    WeightChannel,
    all_reduce_gradients,
    all_reduce_sum,
    any_process,
    average_floating_state,
    broadcast_object,
    broadcast_parameters,
    gather,
    receive_batch,
    remote_batches,
    send_batch,
)
from rlhc.envs import make_env
from rlhc.envs.base import BatchedGame
from rlhc.envs.keys import (
    DONE,
    EPISODE_REWARD,
    INFO,
    MANAGER_SELECTED,
    MANAGER_VALUE,
    NEXT,
    SCORING_TEAM,
    STATE_VALUE,
    STEP_COUNT,
    TERMINATED,
    WORKER_VALUE,
)
from rlhc.final_team import save_team
from rlhc.interrupt import StopSignals, TrainingInterrupted
from rlhc.league import LEARNER_TEAM, OPPONENT, League, LeaguePolicy
from rlhc.loggers import MetricLogger, ProgressLines
from rlhc.modules import make_actor
from rlhc.objectives import cut_trajectories, learner_weighted_loss
from rlhc.validation import validate

log = logging.getLogger(__name__)


def seed_everything(seed: int) -> None:
    """Seed python, numpy and torch (the game has its own generator, seeded by the env)."""
    random.seed(seed)
    np.random.seed(seed)
    torch.manual_seed(seed)


def schedules(algo: PPOConfig, frames: int) -> tuple[float, float, float]:
    """Learning rate, entropy coefficient and clip range after ``frames`` world-decisions.

    As ML-Agents 0.5: each decays linearly over the budget (where enabled) to its floor
    (``algo.final_lr``, ``final_entropy_coef``, ``final_clip_epsilon``; by default 0,
    1e-5 and 0.1).

    Examples:
        >>> from rlhc.config import PPOConfig
        >>> algo = PPOConfig(max_steps=100, lr=1e-3, entropy_coef=0.01, clip_epsilon=0.2,
        ...                  anneal_lr=True, anneal_entropy_coef=True, anneal_clip_epsilon=True)
        >>> schedules(algo, 50)
        (0.0005, 0.005005, 0.15000000000000002)
    """
    progress = min(1.0, frames / algo.max_steps)
    lr = algo.lr
    if algo.anneal_lr:
        lr = algo.lr * (1.0 - progress) + algo.final_lr * progress
    entropy_coef = algo.entropy_coef
    if algo.anneal_entropy_coef:
        entropy_coef += (algo.final_entropy_coef - entropy_coef) * progress
    clip_epsilon = algo.clip_epsilon
    if algo.anneal_clip_epsilon:
        clip_epsilon += (algo.final_clip_epsilon - clip_epsilon) * progress
    return lr, entropy_coef, clip_epsilon


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


class Trainer:
    """Trains one policy per agent group with PPO and a hierarchical value estimate.

    Args:
        cfg: a validated training config.
        run_dir: where ``metrics.csv``, TensorBoard files and checkpoints go.
        env: the collection env; ``None`` builds the batched game of ``cfg.env``. Another
            env (e.g. TorchRL's ``PettingZooWrapper`` route, for benchmarks) must follow
            the same TensorDict contract, with episode returns and observation norm from
            :func:`~rlhc.builders.with_training_transforms`.
        processes: this process's place in a ``torchrun`` run
            (:func:`rlhc.distributed.setup`); ``None``: one process.
        resume_state: the checkpoint of ``cfg.resume``, already loaded
            (:func:`~rlhc.checkpoint.load_checkpoint`); ``None``: load it here.

    Examples:
        >>> from hydra import compose, initialize_config_dir  # doctest: +SKIP
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
        self.processes = processes if processes is not None else Processes(mode=cfg.parallel)
        validate(cfg, self.processes.size)
        self.cfg = cfg
        self.run_dir = run_dir
        self.layout = Layout.from_config(cfg, self.processes.shards)
        if cfg.threads > 0:
            torch.set_num_threads(cfg.threads)
        resume = None
        if cfg.resume and self.processes.main:
            resume = load_checkpoint(cfg.resume) if resume_state is None else dict(resume_state)
            check_resumable(cfg, resume)
        if self.processes.active and cfg.resume:
            resume = broadcast_object(resume)
        # The same seed everywhere: every process builds the same initial networks.
        seed_everything(cfg.seed)

        self.env = (
            env if env is not None else make_training_env(cfg, self._local_worlds(), self._seed())
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
            self.league = League(cfg.league, self._local_worlds(), self._seed())
            net = network_config(cfg)
            self.collection_policy = LeaguePolicy(
                self.policy, self.league, self.env, lambda g: make_actor(self.env, g, net)
            )
        # fused: one kernel over all parameters (on CPU too), ~9% of a soccer update.
        self.parameters = self._parameters()
        self.optimizer = torch.optim.Adam(self.parameters, lr=cfg.algo.lr, fused=True)

        self._eval_env: EnvBase | None = None
        #: What the collecting process of a pipeline sends with each batch.
        self._remote: dict[str, Any] = {}
        self.frames = 0
        self.iteration = 0
        self.wall_time = 0.0
        if resume is not None:
            self._restore(resume)
        if self.processes.active:
            broadcast_parameters(self.parameters)
            # Apart from here on: each process samples its own actions and minibatches.
            seed_everything((self._seed() + self.frames) % 2**32)
        self.logger = (
            MetricLogger(
                cfg.logger,
                run_dir,
                run_name=run_dir.name,
                config=config_container(cfg),
                resume_step=self.frames if resume is not None else None,
            )
            if self.processes.main
            else None
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
        if not self.processes.learns:
            self._serve_batches()
            return last_metrics
        main = self.processes.main
        progress = tqdm(
            total=cfg.algo.max_steps,
            initial=self.frames,
            unit="frames",
            disable=not (main and self._show_progress()),
            dynamic_ncols=True,
        )
        lines = ProgressLines(cfg.algo.max_steps, self.frames)
        stop = StopSignals()
        stopping = False
        saved: tuple[int, Path] | None = None
        episodes: dict[str, list[torch.Tensor]] = defaultdict(list)
        summary: dict[str, list[float]] = defaultdict(list)
        start = time.perf_counter() - self.wall_time
        collect_start = time.perf_counter()
        with contextlib.ExitStack() as context:
            if not progress.disable:
                context.enter_context(logging_redirect_tqdm())
            if self.logger is not None:
                context.callback(self.logger.close)
            batches = self._batches(remaining, context)
            context.callback(progress.close)
            context.enter_context(stop)
            for batch in batches:
                collect_time = time.perf_counter() - collect_start
                self._collect_episode_stats(batch, episodes)
                if self.league is not None:
                    self._record_league(batch)
                if self.processes.data_parallel and cfg.algo.normalize_observations:
                    self._merge_normaliser()
                update_start = time.perf_counter()
                self._set_schedules()
                for name, value in self._update(batch).items():
                    summary[name].append(value)
                update_time = time.perf_counter() - update_start

                frames = batch.numel() * self.processes.shards
                previous, self.frames = self.frames, self.frames + frames
                self.iteration += 1
                if self.league is not None and self.iteration % cfg.league.snapshot_interval == 0:
                    self.league.add_snapshot(self.actors)
                self.wall_time = time.perf_counter() - start
                # Collection's own speed (a pipeline learner waited, the collector collected).
                env_rate = self._remote.get("env_steps_per_s", frames / collect_time)
                summary["env_steps_per_s"].append(env_rate)
                summary["train_frames_per_s"].append(frames / (collect_time + update_time))
                progress.update(self.frames - previous)

                if self._crossed(previous, cfg.logger.summary_freq) or self._finished():
                    last_metrics = self._summarise(summary, episodes)
                    if main and cfg.eval_freq and self._crossed(previous, cfg.eval_freq):
                        last_metrics.update(self.evaluate())
                    if self.logger is not None:
                        self.logger.log(self.frames, last_metrics)
                    progress.set_postfix(self._postfix(last_metrics))
                    summary.clear()
                    episodes.clear()
                if self._crossed(previous, cfg.checkpoint_freq) or self._finished():
                    saved = (self.frames, self.save())
                line = lines.update(self.frames, frames / env_rate, last_metrics)
                if main and line is not None:
                    log.info(line)
                stopping = stop.received is not None
                if self.processes.data_parallel:
                    stopping = any_process(stopping)
                if self.processes.pipeline:
                    self._publish_weights(go_on=not (self._finished() or stopping))
                if self._finished() or stopping:
                    break
                collect_start = time.perf_counter()
        if stopping and not self._finished():
            # Another process's signal stops this one too (data-parallel).
            signum = stop.received if stop.received is not None else signal.SIGTERM
            checkpoint = saved[1] if saved and saved[0] == self.frames else self.save()
            raise TrainingInterrupted(signum, self.frames, checkpoint)
        return last_metrics

    def _batches(self, remaining: int, context: contextlib.ExitStack) -> Iterator[TensorDictBase]:
        """The batches to train on: from this process's worlds, or from the collector."""
        if self.processes.pipeline:
            for batch, extras in remote_batches():
                self._receive_extras(extras)
                yield batch
            return
        local = self.layout.frames_per_batch // self.processes.shards
        collector = Collector(
            self.env,
            self.collection_policy,
            frames_per_batch=local,
            total_frames=math.ceil(remaining / self.layout.frames_per_batch) * local,
            # The policy is stateless (no recurrent state to initialise).
            auto_register_policy_transforms=False,
        )
        context.callback(collector.shutdown)
        yield from collector

    # --- the pipeline ---------------------------------------------------------------
    def _serve_batches(self) -> None:
        """The collecting process of a pipeline: collect, send, load the new weights.

        Batch ``k + 1`` is collected while the learner trains on batch ``k``, with the
        weights it had before that update (see :mod:`rlhc.distributed`). Stop signals
        are left to the learner, which says when to stop.
        """
        channel = WeightChannel(self._actor_parameters())
        collector = Collector(
            self.env,
            self.collection_policy,
            frames_per_batch=self.layout.frames_per_batch,
            total_frames=-1,
            auto_register_policy_transforms=False,
        )
        context = contextlib.ExitStack()
        context.callback(collector.shutdown)
        with context, StopSignals():
            start = time.perf_counter()
            for index, batch in enumerate(collector):
                extras = {
                    "env_steps_per_s": batch.numel() / (time.perf_counter() - start),
                    "env_transform": self.env.transform.state_dict(),
                    "game_rng": self._game.rng.bit_generator.state if self._game else None,
                }
                send_batch(batch, extras)
                if index >= 1 and not channel.receive():
                    break
                start = time.perf_counter()

    def _receive_extras(self, extras: dict[str, Any]) -> None:
        """Learner: keep the collector's normaliser statistics and game RNG (checkpoints)."""
        self._remote = extras
        self.env.transform.load_state_dict(extras["env_transform"])

    def _publish_weights(self, go_on: bool) -> None:
        """Learner: send the new weights; when stopping, take the batch still in flight."""
        if not hasattr(self, "_channel"):
            self._channel = WeightChannel(self._actor_parameters())
        self._channel.send(go_on)
        if not go_on:
            receive_batch()  # collected with the last weights; nobody trains on it
            self._channel.wait()

    def _actor_parameters(self) -> list[torch.nn.Parameter]:
        return [p for actor in self.actors.values() for p in actor.parameters()]

    def _merge_normaliser(self) -> None:
        """Data-parallel: average the normaliser statistics over the processes."""
        state = self.env.transform.state_dict()
        self.env.transform.load_state_dict(average_floating_state(state))

    def _update(self, batch: TensorDictBase) -> dict[str, float]:
        """Estimate advantages per group, then ``epochs`` passes of minibatch PPO."""
        algo = self.cfg.algo
        layout = self.layout
        stats: dict[str, list[float]] = defaultdict(list)
        cut_trajectories(batch, self.groups, layout.time_horizon)
        with torch.no_grad():
            for group, loss in self.losses.items():
                loss.value_estimator(batch)
                for key in (STATE_VALUE, WORKER_VALUE, MANAGER_VALUE, MANAGER_SELECTED):
                    stats[f"{group}/{key}"].append(batch[group, key].float().mean().item())
        flat = batch.reshape(-1)
        # Data-parallel: this process's share of every minibatch, from its own worlds.
        share = layout.minibatch_frames // self.processes.shards
        for _ in range(algo.epochs):
            # As ML-Agents 0.5: whole minibatches only, the shuffled remainder left out.
            order = torch.randperm(flat.numel())[: layout.minibatches * share]
            for index in order.split(share):
                self.backward(flat[index], stats)
                grad_norm = torch.nn.utils.clip_grad_norm_(self.parameters, algo.max_grad_norm)
                stats["grad_norm"].append(grad_norm.item())
                self.optimizer.step()
        return {name: float(np.mean(values)) for name, values in stats.items()}

    def backward(
        self, minibatch: TensorDictBase, stats: dict[str, list[float]] | None = None
    ) -> None:
        """Set every parameter's gradient to that of :meth:`minibatch_loss`.

        Data-parallel, ``minibatch`` is this process's share and the gradients are
        summed over the processes: every process then holds the gradient of the whole
        minibatch, the one a single process computes.
        """
        total = self.minibatch_loss(minibatch, stats)
        self.optimizer.zero_grad(set_to_none=True)
        total.backward()
        if self.processes.data_parallel:
            all_reduce_gradients(self.parameters)

    def minibatch_loss(
        self, minibatch: TensorDictBase, stats: dict[str, list[float]] | None = None
    ) -> torch.Tensor:
        """The summed PPO loss of every group on a minibatch (advantages already in it).

        Every term is averaged under the learner weight
        (:func:`~rlhc.objectives.learner_weighted_loss`): an experience that an
        opponent chose (a league world) adds nothing. Diagnostics go to ``stats`` (this
        process's share only, data-parallel; :meth:`_summarise` averages the processes).
        """
        reduce = all_reduce_sum if self.processes.data_parallel else None
        total = torch.zeros(())
        for group, loss in self.losses.items():
            weighted = learner_weighted_loss(
                loss,
                minibatch,
                normalize_advantage=self.cfg.algo.normalize_advantage,
                reduce=reduce,
            )
            total = total + weighted.total
            if stats is not None:
                for key, value in weighted.diagnostics.items():
                    stats[f"{group}/{key}"].append(value)
        return total

    def _record_league(self, batch: TensorDictBase) -> None:
        """Feed the results of the episodes that ended against league opponents to Elo."""
        assert self.league is not None
        done = batch[NEXT, DONE].squeeze(-1)
        if not done.any() and not self.processes.data_parallel:
            return
        opponent = batch[OPPONENT].squeeze(-1)[done].numpy()
        learner_team = batch[LEARNER_TEAM].squeeze(-1)[done].numpy()
        scoring = batch[NEXT, SCORING_TEAM].squeeze(-1)[done].numpy()
        scores = np.where(scoring < 0, 0.5, (scoring == learner_team).astype(float))
        if self.processes.data_parallel:
            # Every process records every result: the ratings stay the same everywhere.
            results = gather((opponent, scores))
            opponent = np.concatenate([o for o, _ in results])
            scores = np.concatenate([s for _, s in results])
        self.league.record(opponent, scores)

    # --- metrics --------------------------------------------------------------------
    def _collect_episode_stats(
        self, batch: TensorDictBase, episodes: dict[str, list[torch.Tensor]]
    ) -> None:
        """Returns and lengths of the episodes that ended in ``batch``; game events."""
        done = batch[NEXT, DONE].squeeze(-1)
        if (NEXT, INFO) in batch.keys(include_nested=True):
            for key, value in batch[NEXT, INFO].items():
                # Events per episode: summed over the window, divided by its episodes.
                per_world = value.reshape(*batch.shape, -1).sum(dim=(0, 1))
                episodes[f"events/{key}"].append(per_world)
        if not done.any():
            return
        episodes["episode_length"].append(batch[NEXT, STEP_COUNT][done].float().flatten())
        # The share of episodes the game ended (a point, a goal) before the time cap.
        terminated = batch[NEXT, TERMINATED].squeeze(-1)[done]
        episodes["episode_terminated"].append(terminated.float().flatten())
        for group in self.groups:
            # [episodes, n_g, 1] → one number per episode: the group's mean return.
            returns = batch[NEXT, group, EPISODE_REWARD][done].float()
            episodes[f"{group}/cumulative_reward"].append(returns.mean(dim=(-2, -1)))

    def _summarise(
        self, summary: dict[str, list[float]], episodes: dict[str, list[torch.Tensor]]
    ) -> dict[str, float]:
        if self.processes.data_parallel:
            # Every process's diagnostics and episodes (one gather per summary).
            merged_summary: dict[str, list[float]] = defaultdict(list)
            merged_episodes: dict[str, list[torch.Tensor]] = defaultdict(list)
            for part_summary, part_episodes in gather((dict(summary), dict(episodes))):
                for name, values in part_summary.items():
                    merged_summary[name].extend(values)
                for name, chunks in part_episodes.items():
                    merged_episodes[name].extend(chunks)
            # (Rates need no merging: every process counts the frames of all of them.)
            summary, episodes = merged_summary, merged_episodes
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
            "game_rng": self._game_rng(),
            "league": self.league.state_dict() if self.league is not None else None,
            "rng": rng_states(),
        }

    def save(self) -> Path:
        """Write a checkpoint (rank 0 only: the others hold the same state); its path.

        At the end of the budget the final team (:mod:`rlhc.final_team`) is written too.
        """
        path = self.run_dir / CHECKPOINT_DIR / f"step_{self.frames:09d}.pt"
        if self.processes.main:
            state = self.state()
            save_checkpoint(path, state)
            if self._finished():
                save_team(self.run_dir, state)
        return path

    def _restore(self, state: dict[str, Any]) -> None:
        for group, loss in self.losses.items():
            loss.load_state_dict(state["losses"][group])
        self.optimizer.load_state_dict(state["optimizer"])
        self.env.transform.load_state_dict(state["env_transform"])
        # The stored generator is the one rank 0 collected with (the collector's, in a
        # pipeline); other data-parallel processes keep their own seeds.
        owner = self.processes.pipeline or self.processes.main
        if self._game is not None and state["game_rng"] is not None and owner:
            self._game.rng.bit_generator.state = state["game_rng"]
        if self.league is not None and state.get("league") is not None:
            self.league.load_state_dict(state["league"])
        set_rng_states(state["rng"])
        self.frames = int(state["frames"])
        self.iteration = int(state["iteration"])
        self.wall_time = float(state["wall_time"])

    # --- helpers --------------------------------------------------------------------
    def _local_worlds(self) -> int:
        """Worlds this process steps: its share, all of them, or one (pipeline learner,
        which needs an env only for its specs and the normaliser statistics)."""
        if not self.processes.collects:
            return 1
        return self.layout.num_envs // self.processes.shards

    def _seed(self) -> int:
        """``cfg.seed`` for rank 0 (one process is unchanged), a derived seed elsewhere."""
        if self.processes.rank == 0:
            return self.cfg.seed
        return int(
            np.random.SeedSequence([self.cfg.seed, self.processes.rank]).generate_state(1)[0]
        )

    def _game_rng(self) -> Mapping[str, Any] | None:
        """The collecting game's generator state (the collector's, in a pipeline)."""
        if self.processes.pipeline:
            return self._remote.get("game_rng")
        return self._game.rng.bit_generator.state if self._game else None

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
