"""What goes into each row of ``metrics.csv`` (:class:`SummaryWindow`, the periodic
measurements), and the progress shown meanwhile (:class:`ProgressReport`)."""

from __future__ import annotations

import contextlib
import copy
import datetime
import logging
import re
import time
from collections import defaultdict
from collections.abc import Callable, Mapping, Sequence
from typing import Any

import numpy as np
import torch
from tensordict import TensorDictBase
from torchrl.envs import EnvBase, Transform
from tqdm import tqdm
from tqdm.contrib.logging import logging_redirect_tqdm

from rlhc.config.train_schema import TrainConfig
from rlhc.envs import make_env
from rlhc.envs.keys import DONE, EPISODE_REWARD, INFO, NEXT, STEP_COUNT, TERMINATED
from rlhc.storage.checkpoint import flatten, rng_states, set_rng_states

#: Every process's value, in rank order (``[value]`` for one process).
Gather = Callable[[Any], list[Any]]
#: Events of a game shown in progress lines: totals per episode, not per team.
_PER_TEAM = re.compile(r"_\d+_per_episode$")


class SummaryWindow:
    """Each update's statistics and the episodes that ended since the last summary.

    Examples:
        >>> window = SummaryWindow()
        >>> window.add_update({"grad_norm": 1.0})
        >>> window.add_update({"grad_norm": 3.0})
        >>> window.metrics(lambda part: [part])
        {'grad_norm': 2.0, 'episodes': 0.0}
    """

    def __init__(self) -> None:
        self.updates: dict[str, list[float]] = defaultdict(list)
        self.episodes: dict[str, list[torch.Tensor]] = defaultdict(list)

    def add_update(self, statistics: Mapping[str, float]) -> None:
        """One update's statistics (:meth:`~rlhc.training.trainer.Trainer.update`'s, speeds)."""
        for name, value in statistics.items():
            self.updates[name].append(value)

    def add_episodes(self, batch: TensorDictBase, groups: Sequence[str]) -> None:
        """Returns and lengths of the episodes that ended in ``batch``; game events."""
        done = batch[NEXT, DONE].squeeze(-1)
        if (NEXT, INFO) in batch.keys(include_nested=True):
            for key, value in batch[NEXT, INFO].items():
                # Events per episode: summed over the window, divided by its episodes.
                per_world = value.reshape(*batch.shape, -1).sum(dim=(0, 1))
                self.episodes[f"events/{key}"].append(per_world)
        if not done.any():
            return
        self.episodes["episode_length"].append(batch[NEXT, STEP_COUNT][done].float().flatten())
        # The share of episodes the game ended (a point, a goal) before the time cap.
        terminated = batch[NEXT, TERMINATED].squeeze(-1)[done]
        self.episodes["episode_terminated"].append(terminated.float().flatten())
        for group in groups:
            # [episodes, n_g, 1] → one number per episode: the group's mean return.
            returns = batch[NEXT, group, EPISODE_REWARD][done].float()
            self.episodes[f"{group}/cumulative_reward"].append(returns.mean(dim=(-2, -1)))

    def metrics(self, gather: Gather) -> dict[str, float]:
        """The window's means, events per episode and ``episodes``, pooled over the
        processes by ``gather`` (every process's value in rank order)."""
        updates: dict[str, list[float]] = defaultdict(list)
        episodes: dict[str, list[torch.Tensor]] = defaultdict(list)
        for part_updates, part_episodes in gather((dict(self.updates), dict(self.episodes))):
            for name, values in part_updates.items():
                updates[name].extend(values)
            for name, chunks in part_episodes.items():
                episodes[name].extend(chunks)
        metrics = {name: float(np.mean(values)) for name, values in updates.items()}
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
        return metrics

    def clear(self) -> None:
        """Start the next window."""
        self.updates.clear()
        self.episodes.clear()


class ProgressReport:
    """The progress bar (if ``bar``) and a line to ``log`` every tenth (``parts``) of the
    ``budget``, from ``frames`` already trained; while open, log records go above the bar.

    A line: frames, speeds since the last line (of the loop, of collection alone), each
    group's latest mean return, the game's events per episode, time spent and left.

    Examples:
        >>> report = ProgressReport(budget=1000, frames=0, bar=False, log=None)
        >>> line = report.line(100, collect_seconds=0.5, metrics={"racket/cumulative_reward": 0.1})
        >>> line.split(" | ")[0], line.split(" | ")[2]
        ('frames 100/1,000 (10%)', 'racket reward +0.100')
        >>> report.line(150, collect_seconds=0.5, metrics={}) is None
        True
    """

    def __init__(
        self, budget: int, frames: int, *, bar: bool, log: logging.Logger | None, parts: int = 10
    ) -> None:
        self.bar = tqdm(
            total=budget, initial=frames, unit="frames", disable=not bar, dynamic_ncols=True
        )
        self.log = log
        self._context = contextlib.ExitStack()
        self.budget = budget
        self.period = max(1, budget // parts)
        self.start = time.perf_counter()
        self.start_frames = frames
        self.frames = frames
        self.mark = (self.start, frames, 0.0)  # time, frames, collection seconds at the last line
        self.collect_seconds = 0.0

    def __enter__(self) -> ProgressReport:
        if not self.bar.disable:
            self._context.enter_context(logging_redirect_tqdm())
        self._context.callback(self.bar.close)
        return self

    def __exit__(self, *exc_info: object) -> None:
        self._context.close()

    def advance(
        self, frames: int, advanced: int, collect_seconds: float, metrics: Mapping[str, float]
    ) -> None:
        """After an iteration that trained ``advanced`` frames (``frames`` in all), its
        collection ``collect_seconds`` long; ``metrics``: the last logged ones."""
        self.bar.update(advanced)
        line = self.line(frames, collect_seconds, metrics)
        if self.log is not None and line is not None:
            self.log.info(line)

    def line(self, frames: int, collect_seconds: float, metrics: Mapping[str, float]) -> str | None:
        """Account an iteration; the line to write if it crossed a tenth of the budget."""
        previous, self.frames = self.frames, frames
        self.collect_seconds += collect_seconds
        if previous // self.period == frames // self.period and frames < self.budget:
            return None
        now = time.perf_counter()
        since, since_frames, since_collect = self.mark
        self.mark = (now, frames, self.collect_seconds)
        new_frames = frames - since_frames
        speed = new_frames / max(now - since, 1e-9)
        env_speed = new_frames / max(self.collect_seconds - since_collect, 1e-9)
        overall = (frames - self.start_frames) / max(now - self.start, 1e-9)
        left = max(self.budget - frames, 0) / max(overall, 1e-9)
        parts = [
            f"frames {frames:,}/{self.budget:,} ({100 * frames / self.budget:.0f}%)",
            f"{speed:,.0f} frames/s (env {env_speed:,.0f} steps/s)",
        ]
        for name, value in metrics.items():
            if name.endswith("/cumulative_reward"):
                parts.append(f"{name.split('/')[0]} reward {value:+.3f}")
        for name, value in metrics.items():
            # The headline events only: per-team counts and how points ended (tennis'
            # ended_<how>) stay in metrics.csv.
            if name.startswith("events/") and not _PER_TEAM.search(name) and "/ended_" not in name:
                event = name.removeprefix("events/").removesuffix("_per_episode")
                parts.append(f"{event} {value:.2f}/episode")
        parts.append(f"elapsed {_duration(now - self.start)}, left ~{_duration(left)}")
        return " | ".join(parts)

    def summarised(self, metrics: Mapping[str, float]) -> None:
        """A new row of metrics: the bar shows its speed and mean returns."""
        self.bar.set_postfix(postfix(metrics))


class ScriptedMatches:
    """``eval_freq``: ``cfg.eval_matches`` matches of the live policy (mode actions, half on
    each side) against the scripted team, on worlds of their own seeded ``cfg.seed + 1``."""

    def __init__(self, cfg: TrainConfig) -> None:
        self.cfg = cfg
        self.env: EnvBase | None = None

    def __call__(
        self, actors: Mapping[str, torch.nn.Module], transform: Transform
    ) -> dict[str, float]:
        """``eval/win_rate`` and ``eval/draw_rate`` of ``actors`` behind ``transform``'s
        observation normaliser (both copied: training goes on untouched)."""
        from rlhc.evaluation.matches import evaluate_against
        from rlhc.evaluation.policies import RestoredPolicy, normaliser_statistics

        if self.env is None:
            self.env = make_env(
                self.cfg.env.name,
                num_envs=min(16, self.cfg.eval_matches),
                seed=self.cfg.seed + 1,
                **self.cfg.env.game_options(),
            )
        # On CPU, with the games (the actors may train on another device).
        copies = {g: copy.deepcopy(actor).cpu().eval() for g, actor in actors.items()}
        policy = RestoredPolicy(copies, *normaliser_statistics(transform, copies))
        result = evaluate_against(policy, "scripted", self.env, self.cfg.eval_matches)
        return {f"eval/{rate}": float(result[rate]) for rate in ("win_rate", "draw_rate")}


#: Keys of a play measurement that echo its settings, not measure play.
PLAY_SETTINGS = ("worlds", "decisions", "seed")


def play_metrics(state: Mapping[str, Any], cfg: TrainConfig) -> dict[str, float]:
    """``play_freq``: :func:`rlhc.evaluation.diagnostics.diagnose` of the live training
    ``state``, flattened under ``play/`` (``play/hits_per_point``, ...).

    It seeds the global generators (``cfg.seed + 2``) and puts them back afterwards, so
    that training continues as if nothing had been played.
    """
    from rlhc.evaluation.diagnostics import diagnose

    states = rng_states()
    try:
        result = diagnose(
            state, worlds=cfg.play_worlds, decisions=cfg.play_decisions, seed=cfg.seed + 2
        )
    finally:
        set_rng_states(states)
    return {
        f"play/{name}": float(value)
        for name, value in flatten(result, sep="/").items()
        if isinstance(value, bool | int | float) and name.split("/")[-1] not in PLAY_SETTINGS
    }


def _duration(seconds: float) -> str:
    """``3725.2 -> '1:02:05'``."""
    return str(datetime.timedelta(seconds=round(seconds)))


def postfix(metrics: Mapping[str, float]) -> dict[str, str]:
    """The progress bar's short summary: speed and each group's mean return.

    Examples:
        >>> postfix({"train_frames_per_s": 812.3, "racket/cumulative_reward": -0.05})
        {'steps/s': '812', 'racket': '-0.050'}
    """
    shown = {"steps/s": f"{metrics.get('train_frames_per_s', float('nan')):.0f}"}
    for name, value in metrics.items():
        if name.endswith("/cumulative_reward"):
            shown[name.split("/")[0]] = f"{value:+.3f}"
    return shown
