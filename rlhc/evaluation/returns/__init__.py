"""Trained teams on an environment of another library: their returns, their contests, a video.

``python -m rlhc.evaluation.returns`` (:mod:`rlhc.evaluation.returns.__main__`) judges
runs of ``env=pettingzoo`` or ``env=vmas`` (which have no scripted team, so no matches):
one run plays its own episodes; several runs play every lineup of
:func:`~rlhc.evaluation.cross_play.cross_play` (each group played by each run), and each
group's *advantage* of one run over another is how much more it returns against the same
opponents. ``--video`` records one episode of the first
run (every group its own) from the environment's own renderer.

Usage:
    python -m rlhc.evaluation.returns outputs/vmas/hierarchical/<time> --episodes 100
    python -m rlhc.evaluation.returns <run A> <run B> --out returns.json --video episode.gif

Each group's return is an episode's return averaged over the group's agents, as training
logs it (``<group>/cumulative_reward``), with the policies' mode actions (``--sampled``:
drawn as in training); every lineup plays the same episodes (``--seed``).
"""

from __future__ import annotations

import itertools
import os
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import torch
from torchrl.envs.utils import ExplorationType, set_exploration_type, step_mdp

from rlhc.envs import make_env
from rlhc.envs.generic import render_frame, rendering_options
from rlhc.envs.keys import ACTION, DONE, NEXT
from rlhc.evaluation.cross_play import CrossPlay, shared_env_options
from rlhc.evaluation.policies import restore_policy
from rlhc.evaluation.stats import t_interval
from rlhc.evaluation.video import FORMATS, write_video
from rlhc.storage.final_team import load_team

__all__ = ["format_summary", "record_episode", "summary"]


def summary(result: CrossPlay, *, episodes: int, seed: int, deterministic: bool) -> dict[str, Any]:
    """What the command prints and writes: each lineup's returns with their 95% t
    interval over episodes, and each group's advantage between every two runs."""
    lineups = []
    for lineup, returns in result.returns.items():
        intervals = {group: t_interval(values.tolist()) for group, values in returns.items()}
        lineups.append(
            {
                "plays": dict(zip(result.groups, (result.runs[i] for i in lineup), strict=True)),
                "returns": {
                    group: {"mean": ci.mean, "low": ci.low, "high": ci.high, "episodes": ci.n}
                    for group, ci in intervals.items()
                },
            }
        )
    advantages = [
        {
            "group": group,
            "first": result.runs[first],
            "second": result.runs[second],
            "advantage": result.group_advantage(group, first, second),
        }
        for first, second in itertools.combinations(range(len(result.runs)), 2)
        for group in result.groups
    ]
    return {
        "runs": list(result.runs),
        "groups": list(result.groups),
        "episodes": episodes,
        "seed": seed,
        "deterministic": deterministic,
        "lineups": lineups,
        "advantages": advantages,
    }


def format_summary(result: Mapping[str, Any]) -> str:
    """A few human-readable lines of :func:`summary`, the runs numbered from 1.

    Examples:
        >>> ci = {"mean": 2.0, "low": 1.0, "high": 3.0, "episodes": 10}
        >>> print(format_summary({
        ...     "runs": ["a", "b"], "episodes": 10, "seed": 0, "deterministic": True,
        ...     "lineups": [{"plays": {"red": "a", "blue": "b"}, "returns": {"red": ci, "blue": ci}}],
        ...     "advantages": [{"group": "red", "first": "a", "second": "b", "advantage": 0.5}],
        ... }))
        [1] a
        [2] b
        10 episodes per lineup, mode actions, seed 0; returns: mean [95% t]
        red [1], blue [2]: red 2 [1, 3], blue 2 [1, 3]
        red: [1] over [2] by +0.5 against the same opponents
    """
    number = {run: f"[{i}]" for i, run in enumerate(result["runs"], start=1)}
    actions = "mode actions" if result["deterministic"] else "sampled actions"
    lines = [f"{number[run]} {run}" for run in result["runs"]]
    lines.append(
        f"{result['episodes']} episodes per lineup, {actions}, seed {result['seed']}; "
        "returns: mean [95% t]"
    )
    for lineup in result["lineups"]:
        plays = ", ".join(f"{group} {number[run]}" for group, run in lineup["plays"].items())
        returns = ", ".join(
            f"{group} {ci['mean']:.4g} [{ci['low']:.4g}, {ci['high']:.4g}]"
            for group, ci in lineup["returns"].items()
        )
        lines.append(f"{plays}: {returns}")
    for advantage in result["advantages"]:
        lines.append(
            f"{advantage['group']}: {number[advantage['first']]} over "
            f"{number[advantage['second']]} by {advantage['advantage']:+.4g} against the "
            "same opponents"
        )
    return "\n".join(lines)


def record_episode(
    run: str | os.PathLike[str],
    path: str | os.PathLike[str],
    *,
    seed: int = 0,
    deterministic: bool = True,
    max_frames: int = 500,
    fps: int = 10,
) -> tuple[Path, int]:
    """One episode of ``run``'s team (every group its own) in one world, as a GIF or an MP4
    chosen by ``path``'s suffix; the episode is cut after ``max_frames - 1`` steps.

    Returns:
        ``(path written, frames)``.

    Raises:
        ValueError: ``max_frames < 2``, a run on a built-in game (its videos are matches:
            ``python -m rlhc.evaluate video.enabled=true``), an environment that renders
            no frame, or a ``path`` that is neither ``.gif`` nor ``.mp4``.
    """
    if max_frames < 2:
        raise ValueError(f"max_frames={max_frames}; allowed: >= 2")
    if Path(path).suffix.lower() not in FORMATS:
        raise ValueError(f"video {str(path)!r}; allowed: a file ending in {', '.join(FORMATS)}")
    state = load_team(run)
    options = shared_env_options([str(run)], [state])
    name = str(state["env"])
    env = make_env(name, num_envs=1, seed=seed, **rendering_options(name, options))
    policy = restore_policy(state, env)
    exploration = ExplorationType.DETERMINISTIC if deterministic else ExplorationType.RANDOM
    tensordict = env.reset()
    frames = [render_frame(env, name)]
    with torch.no_grad(), set_exploration_type(exploration):
        while len(frames) < max_frames:
            for group in policy.actors:
                tensordict[group, ACTION] = policy.act(group, tensordict)
            tensordict = env.step(tensordict)
            frames.append(render_frame(env, name))
            if bool(tensordict[NEXT, DONE].any()):
                break
            tensordict = step_mdp(tensordict)
    env.close()
    return write_video(frames, path, fps), len(frames)
