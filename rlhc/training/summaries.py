"""The bookkeeping behind each row of ``metrics.csv``, and the progress shown meanwhile.

A :class:`SummaryWindow` collects, between two summaries, each update's statistics
(losses, values, speeds: one number per update) and the episodes that ended in the
collected batches (returns, lengths, the game's events); :meth:`SummaryWindow.metrics`
turns them into one row's numbers, every process's included (data-parallel runs hand
it their ``gather``). :class:`ProgressReport` is the bar and the periodic log line,
:class:`ScriptedMatches` the periodic evaluation a row may hold.
"""

from __future__ import annotations

import contextlib
import copy
import logging
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
from rlhc.storage.checkpoint import rng_states, set_rng_states
from rlhc.training.loggers import ProgressLines

#: Every process's value, in rank order (``[value]`` for one process).
Gather = Callable[[Any], list[Any]]


class SummaryWindow:
    """Update statistics and ended episodes since the last summary.

    Examples:
        >>> window = SummaryWindow()
        >>> window.add_update({"grad_norm": 1.0})
        >>> window.add("grad_norm", 3.0)
        >>> window.metrics(lambda part: [part])
        {'grad_norm': 2.0, 'episodes': 0.0}
    """

    def __init__(self) -> None:
        self.updates: dict[str, list[float]] = defaultdict(list)
        self.episodes: dict[str, list[torch.Tensor]] = defaultdict(list)

    def add_update(self, statistics: Mapping[str, float]) -> None:
        """One update's statistics (e.g. :meth:`rlhc.training.trainer.Trainer.update`'s)."""
        for name, value in statistics.items():
            self.updates[name].append(value)

    def add(self, name: str, value: float) -> None:
        """One more value of one statistic (e.g. an iteration's speed)."""
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
        """The window's numbers over every process: means, per-episode events, ``episodes``.

        Args:
            gather: every process's value in rank order (``[value]`` for one process);
                each process's diagnostics and episodes are pooled, in rank order.
        """
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
    """The progress bar (if shown) and a log line every tenth of the budget.

    A context manager: while it is open, with the bar shown, log records go above the
    bar; it closes the bar on exit.

    Args:
        budget: ``algo.max_steps``.
        frames: frames already trained (a resume starts from the checkpoint's).
        bar: show tqdm's bar.
        log: where the progress lines go (``None``: nowhere, e.g. not rank 0).
    """

    def __init__(self, budget: int, frames: int, *, bar: bool, log: logging.Logger | None) -> None:
        self.bar = tqdm(
            total=budget, initial=frames, unit="frames", disable=not bar, dynamic_ncols=True
        )
        self.lines = ProgressLines(budget, frames)
        self.log = log
        self._context = contextlib.ExitStack()

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
        """After an iteration: ``advanced`` frames more, ``frames`` in all.

        Args:
            frames: frames trained so far.
            advanced: frames this iteration trained.
            collect_seconds: seconds this iteration's collection took (at its own speed).
            metrics: the last logged metrics.
        """
        self.bar.update(advanced)
        line = self.lines.update(frames, collect_seconds, metrics)
        if self.log is not None and line is not None:
            self.log.info(line)

    def summarised(self, metrics: Mapping[str, float]) -> None:
        """A new row of metrics: the bar shows its speed and mean returns."""
        self.bar.set_postfix(postfix(metrics))


class ScriptedMatches:
    """The periodic evaluation of a row: the live policy against the scripted team.

    Plays ``cfg.eval_matches`` matches (half on each side) with mode actions, on worlds
    of their own (seeded ``cfg.seed + 1``, built at the first call).

    Args:
        cfg: the run's config (its game, seed and ``eval_matches``).
    """

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
        return {
            "eval/win_rate": float(result["win_rate"]),
            "eval/draw_rate": float(result["draw_rate"]),
        }


#: Keys of a play measurement that echo its settings, not measure play.
PLAY_SETTINGS = ("worlds", "decisions", "seed")


def play_metrics(state: Mapping[str, Any], cfg: TrainConfig) -> dict[str, float]:
    """The periodic play measurement (``play_freq``): the numbers of
    :func:`rlhc.evaluation.diagnostics.diagnose` on ``state`` (the live training state),
    flattened under ``play/`` (``play/hits_per_point``, ``play/sigma_near/move``, ...).

    The measurement seeds the global generators (``cfg.seed + 2``); they are put back
    afterwards, so that training continues as if nothing had been played.
    """
    from rlhc.evaluation.diagnostics import diagnose

    states = rng_states()
    try:
        result = diagnose(
            state, worlds=cfg.play_worlds, decisions=cfg.play_decisions, seed=cfg.seed + 2
        )
    finally:
        set_rng_states(states)
    return {f"play/{name}": value for name, value in numbers(result)}


def numbers(tree: Mapping[str, Any], prefix: str = "") -> list[tuple[str, float]]:
    """The numeric leaves of a nested mapping, named by their ``/``-joined path.

    The measurement's own settings (``worlds``, ``decisions``, ``seed``) are left out.

    Examples:
        >>> numbers({"hits": 2, "sigma": {"move": 0.5}, "seed": 0, "team": "scripted"})
        [('hits', 2.0), ('sigma/move', 0.5)]
    """
    found = []
    for key, value in tree.items():
        name = f"{prefix}{key}"
        if isinstance(value, Mapping):
            found += numbers(value, f"{name}/")
        elif isinstance(value, bool | int | float) and key not in PLAY_SETTINGS:
            found.append((name, float(value)))
    return found


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
