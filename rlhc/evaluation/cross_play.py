"""Cross-play on an environment of several groups: each group of one run against the others of another.

A run trains every group of the environment with its critic. Where the groups' rewards
oppose (MPE ``simple_tag``: predators against prey), a group's training return is the
outcome of a contest between two learners of the same run, and comparing two runs'
returns compares two contests. Cross-play separates the learners: a *lineup* says which
run plays each group, and group ``g`` of run ``A`` is compared with group ``g`` of run
``B`` against the same opponents (:func:`group_advantage`).

Every lineup plays the same episodes of the environment (the same seed, so the same
starts), each group with its own run's actors and frozen observation normaliser
(:func:`~rlhc.evaluation.policies.restore_policy`); a group's return is an episode's
return averaged over the group's agents, as training logs it (``<group>/cumulative_reward``).

Examples:
    Two runs of two groups make four lineups, the runs' own two among them:

    >>> lineups(["blue", "red"], 2)
    [(0, 0), (0, 1), (1, 0), (1, 1)]
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Hashable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any, TypeVar

import torch
from torchrl.envs import RewardSum, TransformedEnv
from torchrl.envs.utils import ExplorationType, set_exploration_type

from rlhc.building.builders import group_names
from rlhc.envs import SOURCES, make_env
from rlhc.envs.keys import ACTION, DONE, EPISODE_REWARD, NEXT, REWARD
from rlhc.evaluation.policies import RestoredPolicy, checkpoint_config, restore_policy
from rlhc.storage.final_team import load_team

#: Who plays a group in a lineup: a run's index, a configuration's name.
Player = TypeVar("Player", bound=Hashable)
#: Env options that do not change the episodes a lineup plays.
FREE_OPTIONS = ("num_envs", "manager_view")


def lineups(groups: Sequence[str], runs: int) -> list[tuple[int, ...]]:
    """Every assignment of ``runs`` runs to ``groups``: one run index per group."""
    return list(itertools.product(range(runs), repeat=len(groups)))


def group_advantage(
    means: Mapping[tuple[Player, ...], Mapping[str, float]],
    groups: Sequence[str],
    group: str,
    first: Player,
    second: Player,
) -> float:
    """How much more ``group`` returns when ``first`` plays it than when ``second`` does,
    against the same opponents: the mean, over every assignment of ``first`` and
    ``second`` to the other groups, of the difference of the group's mean returns.

    Args:
        means: ``lineup -> group -> mean return``, a lineup naming who plays each of
            ``groups``; it holds every lineup of ``first`` and ``second``.

    Raises:
        ValueError: ``group`` is not one of ``groups``.

    Examples:
        Predators of ``a`` catch 2 more than those of ``b`` against either's prey:

        >>> means = {("a", "a"): {"predator": 5.0}, ("a", "b"): {"predator": 7.0},
        ...          ("b", "a"): {"predator": 3.0}, ("b", "b"): {"predator": 5.0}}
        >>> group_advantage(means, ["predator", "prey"], "predator", "a", "b")
        2.0
    """
    if group not in groups:
        raise ValueError(f"group {group!r}; allowed: one of {list(groups)}")
    index = list(groups).index(group)
    differences = [
        returns[group] - means[(*lineup[:index], second, *lineup[index + 1 :])][group]
        for lineup, returns in means.items()
        if lineup[index] == first and set(lineup) <= {first, second}
    ]
    return sum(differences) / len(differences)


@dataclass(frozen=True)
class CrossPlay:
    """Every lineup's returns.

    Attributes:
        groups: the environment's groups, in the order of a lineup's entries.
        runs: the runs, as given (paths or labels); a lineup indexes them.
        returns: ``lineup -> group -> [episodes]`` returns.
    """

    groups: tuple[str, ...]
    runs: tuple[str, ...]
    returns: Mapping[tuple[int, ...], Mapping[str, torch.Tensor]]

    def mean(self, lineup: tuple[int, ...], group: str) -> float:
        """The mean return of ``group`` in ``lineup``."""
        return float(self.returns[lineup][group].mean())

    def group_advantage(self, group: str, first: int, second: int) -> float:
        """How much more ``group`` returns when run ``first`` plays it than when run
        ``second`` does, against the same opponents (:func:`group_advantage`)."""
        means = {
            lineup: {g: float(values.mean()) for g, values in returns.items()}
            for lineup, returns in self.returns.items()
        }
        return group_advantage(means, self.groups, group, first, second)

    def rows(self) -> list[dict[str, Any]]:
        """One row per lineup: which run plays each group and each group's mean return."""
        return [
            {
                **{
                    f"{group}_run": self.runs[run]
                    for group, run in zip(self.groups, lineup, strict=True)
                },
                **{f"{group}_return": self.mean(lineup, group) for group in self.groups},
            }
            for lineup in self.returns
        ]


def cross_play(
    runs: Sequence[str],
    episodes: int = 100,
    *,
    num_envs: int = 10,
    seed: int = 0,
    deterministic: bool = True,
) -> CrossPlay:
    """Play every lineup of ``runs`` (run directories or checkpoint files) for ``episodes``
    episodes each.

    Args:
        runs: runs on the same environment of another library (``env=pettingzoo`` or
            ``env=vmas``) with the same options; one run plays its own episodes.
        episodes: episodes per lineup, at least: each of the ``num_envs`` worlds plays
            ``ceil(episodes / num_envs)`` of them, and all count.
        num_envs: worlds stepped as one batch.
        seed: the environment's seed, the same for every lineup.
        deterministic: the policies' mode action (``True``) or a sample.

    Raises:
        ValueError: no run, ``episodes < 1``, a run on a built-in game, or
            runs whose environments differ (the options named).
        FileNotFoundError: a path holds no checkpoint.
    """
    if not runs:
        raise ValueError("cross-play needs a run or more, got none")
    if episodes < 1:
        raise ValueError(f"episodes must be >= 1, got {episodes}")
    states = [load_team(run) for run in runs]
    options = shared_env_options(runs, states)
    name = str(states[0]["env"])
    env = returns_env(name, num_envs, seed, options)
    groups = tuple(group_names(env))
    policies = [restore_policy(state, env) for state in states]
    env.close()
    returns = {}
    for lineup in lineups(groups, len(runs)):
        env = returns_env(name, num_envs, seed, options)  # the same episodes for each
        sides = {group: policies[run] for group, run in zip(groups, lineup, strict=True)}
        returns[lineup] = play_episodes(env, sides, episodes, deterministic=deterministic)
        env.close()
    return CrossPlay(groups, tuple(str(run) for run in runs), returns)


def shared_env_options(runs: Sequence[str], states: Sequence[Mapping[str, Any]]) -> dict[str, Any]:
    """The env options every run of ``states`` trained with (those of :data:`FREE_OPTIONS`
    aside), as keyword arguments of :func:`~rlhc.envs.make_env`.

    Raises:
        ValueError: a run on a built-in game, or two runs on different environments.
    """
    configs = [checkpoint_config(state).env for state in states]
    for run, config in zip(runs, configs, strict=True):
        if config.name not in SOURCES:
            raise ValueError(
                f"{run!r} was trained on the game {config.name!r}: cross-play is for the "
                f"environments of other libraries ({', '.join(SOURCES)}); a game plays "
                "matches (python -m rlhc.evaluate)"
            )
    options = [
        {key: value for key, value in config.game_options().items() if key not in FREE_OPTIONS}
        for config in configs
    ]
    for run, config, own in zip(runs[1:], configs[1:], options[1:], strict=True):
        differ = sorted(key for key in {*own, *options[0]} if own.get(key) != options[0].get(key))
        if config.name != configs[0].name or differ:
            raise ValueError(
                f"{run!r} and {runs[0]!r} were trained on different environments "
                f"(env={config.name} vs env={configs[0].name}; options that differ: {differ})"
            )
    return options[0]


def returns_env(name: str, num_envs: int, seed: int, options: Mapping[str, Any]) -> TransformedEnv:
    """The environment ``name`` with ``options``, writing each group's return so far
    (``(group, "episode_reward")``, TorchRL's ``RewardSum``)."""
    env = make_env(name, num_envs=num_envs, seed=seed, **options)
    groups = group_names(env)
    env.append_transform(
        RewardSum(
            in_keys=[(g, REWARD) for g in groups], out_keys=[(g, EPISODE_REWARD) for g in groups]
        )
    )
    return env


def play_episodes(
    env: TransformedEnv,
    sides: Mapping[str, RestoredPolicy],
    episodes: int,
    *,
    deterministic: bool = True,
) -> dict[str, torch.Tensor]:
    """Each group's return over ``episodes`` episodes of ``env`` (:func:`returns_env`),
    ``sides[group]`` acting for ``group``.

    Returns:
        ``group -> [E]``: each episode's return, averaged over the group's agents, in the
        order the episodes ended; every world plays ``ceil(episodes / num_envs)`` of the
        ``E`` episodes (so that short episodes are not over-represented).
    """
    groups = list(sides)
    worlds = int(env.batch_size[0])
    quota = math.ceil(episodes / worlds)
    finished = torch.zeros(worlds, dtype=torch.long)
    returns: dict[str, list[torch.Tensor]] = {group: [] for group in groups}
    exploration = ExplorationType.DETERMINISTIC if deterministic else ExplorationType.RANDOM
    tensordict = env.reset()
    with torch.no_grad(), set_exploration_type(exploration):
        while bool((finished < quota).any()):
            for group, side in sides.items():
                tensordict[group, ACTION] = side.act(group, tensordict)
            step, tensordict = env.step_and_maybe_reset(tensordict)
            done = step[NEXT, DONE].reshape(worlds)
            counted = done & (finished < quota)
            for group in groups:
                episode = step[NEXT, group, EPISODE_REWARD][counted]  # [k, n_g, 1]
                returns[group].append(episode.mean(dim=(-2, -1)))
            finished += done.long()
    return {group: torch.cat(values) for group, values in returns.items()}


__all__ = [
    "FREE_OPTIONS",
    "CrossPlay",
    "cross_play",
    "group_advantage",
    "lineups",
    "play_episodes",
    "returns_env",
]
