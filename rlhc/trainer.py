"""The training loop: collector → hierarchical value estimator → PPO loss → Adam.

Read :meth:`Trainer.train` top to bottom: collect ``time_horizon`` steps from every
world, estimate fused values and advantages per group (RLHC), run ``epochs`` passes of
minibatch PPO over the buffer, log, checkpoint. Both teams of a game share each group's
policy (symmetric self-play).
"""

from __future__ import annotations

import copy
import math
import random
import sys
import time
from collections import defaultdict
from pathlib import Path
from typing import Any

import numpy as np
import torch
from omegaconf import OmegaConf
from tensordict import TensorDictBase
from tensordict.nn import TensorDictSequential
from torchrl.collectors import Collector
from torchrl.envs import EnvBase, TransformedEnv
from tqdm import tqdm

from rlhc.builders import (
    EPISODE_REWARD,
    Layout,
    group_names,
    make_agents,
    make_training_env,
    validate,
)
from rlhc.checkpoint import (
    CHECKPOINT_DIR,
    load_checkpoint,
    rng_states,
    save_checkpoint,
    set_rng_states,
)
from rlhc.config import TrainConfig
from rlhc.envs import make_env
from rlhc.envs.base import BatchedGame
from rlhc.loggers import MetricLogger
from rlhc.objectives import LOSS_KEYS

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
        if resume is not None and resume["env"] != cfg.env.name:
            raise ValueError(
                f"resume={cfg.resume!r} is a {resume['env']!r} checkpoint; this run is "
                f"env={cfg.env.name!r}"
            )
        seed_everything(cfg.seed)

        self.env = (
            env if env is not None else make_training_env(cfg, self.layout.num_envs, cfg.seed)
        )
        self.groups = group_names(self.env)
        self.actors, self.losses = make_agents(cfg, self.env)
        self.policy = TensorDictSequential(*self.actors.values())
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
            config=OmegaConf.to_container(OmegaConf.structured(cfg), resolve=True),  # type: ignore[arg-type]
            resume_step=self.frames if resume is not None else None,
        )

    # --- the loop -------------------------------------------------------------------
    def train(self) -> dict[str, float]:
        """Train until ``algo.max_steps`` frames; returns the last logged metrics."""
        cfg = self.cfg
        remaining = cfg.algo.max_steps - self.frames
        last_metrics: dict[str, float] = {}
        if remaining <= 0:
            return last_metrics
        collector = Collector(
            self.env,
            self.policy,
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
        episodes: dict[str, list[torch.Tensor]] = defaultdict(list)
        summary: dict[str, list[float]] = defaultdict(list)
        start = time.perf_counter() - self.wall_time
        collect_start = time.perf_counter()
        try:
            for batch in collector:
                collect_time = time.perf_counter() - collect_start
                self._collect_episode_stats(batch, episodes)
                update_start = time.perf_counter()
                self._set_learning_rate()
                for name, value in self._update(batch).items():
                    summary[name].append(value)
                update_time = time.perf_counter() - update_start

                previous, self.frames = self.frames, self.frames + batch.numel()
                self.iteration += 1
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
                    self.save()
                if self._finished():
                    break
                collect_start = time.perf_counter()
        finally:
            progress.close()
            collector.shutdown()
            self.logger.close()
        return last_metrics

    def _update(self, batch: TensorDictBase) -> dict[str, float]:
        """Estimate advantages per group, then ``epochs`` passes of minibatch PPO."""
        algo = self.cfg.algo
        stats: dict[str, list[float]] = defaultdict(list)
        with torch.no_grad():
            for group, loss in self.losses.items():
                loss.value_estimator(batch)
                for key in ("state_value", "worker_value", "manager_value", "manager_selected"):
                    stats[f"{group}/{key}"].append(batch[group, key].float().mean().item())
        flat = batch.reshape(-1)
        for _ in range(algo.epochs):
            for index in torch.randperm(flat.numel()).split(self.layout.minibatch_size):
                minibatch = flat[index]
                total = torch.zeros(())
                for group, loss in self.losses.items():
                    out = loss(minibatch)
                    total = total + sum(out[term] for term in LOSS_KEYS)
                    for key in LOSS_DIAGNOSTICS:
                        if key in out:
                            stats[f"{group}/{key}"].append(out[key].detach().float().mean().item())
                self.optimizer.zero_grad(set_to_none=True)
                total.backward()
                grad_norm = torch.nn.utils.clip_grad_norm_(self.parameters, algo.max_grad_norm)
                stats["grad_norm"].append(grad_norm.item())
                self.optimizer.step()
        return {name: float(np.mean(values)) for name, values in stats.items()}

    # --- metrics --------------------------------------------------------------------
    def _collect_episode_stats(
        self, batch: TensorDictBase, episodes: dict[str, list[torch.Tensor]]
    ) -> None:
        """Returns and lengths of the episodes that ended in ``batch``."""
        done = batch["next", "done"].squeeze(-1)
        if not done.any():
            return
        episodes["episode_length"].append(batch["next", "step_count"][done].float().flatten())
        for group in self.groups:
            # [episodes, n_g, 1] → one number per episode: the group's mean return.
            returns = batch["next", group, EPISODE_REWARD][done].float()
            episodes[f"{group}/cumulative_reward"].append(returns.mean(dim=(-2, -1)))

    def _summarise(
        self, summary: dict[str, list[float]], episodes: dict[str, list[torch.Tensor]]
    ) -> dict[str, float]:
        metrics = {name: float(np.mean(values)) for name, values in summary.items()}
        for name, chunks in episodes.items():
            metrics[name] = torch.cat(chunks).mean().item()
        metrics["episodes"] = float(sum(len(c) for c in episodes.get("episode_length", [])))
        metrics["lr"] = self.optimizer.param_groups[0]["lr"]
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

    def _set_learning_rate(self) -> None:
        lr = self.cfg.algo.lr
        if self.cfg.algo.anneal_lr:
            lr *= max(0.0, 1.0 - self.frames / self.cfg.algo.max_steps)
        for group in self.optimizer.param_groups:
            group["lr"] = lr

    def _crossed(self, previous: int, every: int) -> bool:
        return previous // every != self.frames // every

    def _finished(self) -> bool:
        return self.frames >= self.cfg.algo.max_steps

    def _show_progress(self) -> bool:
        if self.cfg.logger.progress is not None:
            return self.cfg.logger.progress
        return sys.stderr.isatty()
