"""Why a soccer team draws: what it does against the scripted team, beyond who wins.

A trained team plays the game's scripted team with mode actions, as in matches, on
fresh pitches, half of them with the trained team on each side; then it plays itself.
Every decision is recorded from the game's state and measured by
:func:`~rlhc.evaluation.diagnostics.soccer_events.count_events` (whose docstring defines
touches, shots and their outcomes). Per team:

| key | what |
|---|---|
| ``goals_per_1000``, ``shots_per_1000``, ``shots_on_target_per_1000`` | per 1,000 pitch-decisions (shots by striker or goalie) |
| ``goalie_shot_share`` | the goalie's share of the shots |
| ``on_target_outcomes`` | share of the shots on target ending in each of :data:`~rlhc.evaluation.diagnostics.soccer_events.SHOT_OUTCOMES` |
| ``ball_in_opponent_half`` | share of decisions with the ball in the opponents' half |
| ``striker_ball_distance``, ``goalie_goal_distance`` | mean distance of the striker to the ball, of the goalie to its own goal (m) |
| ``striker_touches_per_episode``, ``goalie_touches_per_episode`` | touches of the ball per episode |
| ``striker_actions``, ``goalie_actions`` | share of the decisions given to each action |
| ``goals``, ``shots``, ``shots_on_target`` | the raw counts |

and per play: ``episodes`` (started) and, over :func:`complete_episodes`, their number,
``goal_share`` (the others were truncated: a draw) and ``episode_length``. Self-play
pools both sides into team ``trained``.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
import torch
from torchrl.envs.utils import ExplorationType, set_exploration_type, step_mdp

from rlhc.envs import make_env
from rlhc.envs.keys import ACTION, DONE, NEXT, RESET, SCORING_TEAM
from rlhc.envs.soccer.controls import GOALIE_ACTIONS, STRIKER_ACTIONS
from rlhc.envs.soccer.game import SoccerGame
from rlhc.envs.soccer.options import SoccerOptions
from rlhc.envs.torchrl_adapter import BatchedGameEnv
from rlhc.evaluation.diagnostics.soccer_events import SHOT_OUTCOMES, PlayRecord, count_events
from rlhc.evaluation.matches import route_actions
from rlhc.evaluation.policies import observation_options, restore_policy
from rlhc.evaluation.teams import ScriptedPolicy, TeamPolicy

ACTION_NAMES: dict[str, tuple[str, ...]] = {"striker": STRIKER_ACTIONS, "goalie": GOALIE_ACTIONS}


def _soccer_game(env: BatchedGameEnv) -> SoccerGame:
    if not isinstance(env.game, SoccerGame):
        raise ValueError(f"soccer diagnostics need a soccer env, got a {env.game.name!r} one")
    return env.game


def record_play(
    env: BatchedGameEnv,
    home: TeamPolicy,
    away: TeamPolicy,
    home_side: torch.Tensor,
    decisions: int,
) -> PlayRecord:
    """Play ``decisions`` decisions of every pitch of ``env`` with mode actions; record them.

    A pitch whose episode ends kicks off again at once.

    Args:
        env: a soccer env of ``K`` pitches; it is reset first.
        home: the team policy of the home side; ``away`` likewise (may be ``home``).
        home_side: ``int [K]``, the team (0 or 1) ``home`` plays in each pitch.
        decisions: decisions per pitch.

    Raises:
        ValueError: ``env`` is not a soccer env, or ``decisions < 1``.
    """
    game = _soccer_game(env)
    if decisions < 1:
        raise ValueError(f"decisions must be >= 1, got {decisions}")
    worlds = game.num_worlds
    before, after, scoring, ended = [], [], [], []
    actions: dict[str, list[np.ndarray]] = {group: [] for group in ACTION_NAMES}
    tensordict = env.reset()
    with torch.no_grad(), set_exploration_type(ExplorationType.DETERMINISTIC):
        for _ in range(decisions):
            before.append(game.state())
            home_actions = home(tensordict)
            away_actions = home_actions if away is home else away(tensordict)
            route_actions(tensordict, home_actions, away_actions, home_side)
            for group in actions:
                actions[group].append(tensordict[group, ACTION].numpy().copy())
            tensordict = env.step(tensordict)
            after.append(game.state())
            scoring.append(tensordict[NEXT, SCORING_TEAM].view(worlds).numpy().copy())
            done = tensordict[NEXT, DONE].view(worlds).numpy().copy()
            ended.append(done)
            tensordict = step_mdp(tensordict)
            if done.any():
                tensordict.set(RESET, torch.from_numpy(done).view(worlds, 1))
                tensordict = env.reset(tensordict)
    return PlayRecord(
        before=np.stack(before),
        after=np.stack(after),
        scoring_team=np.stack(scoring),
        ended=np.stack(ended),
        actions={group: np.stack(taken) for group, taken in actions.items()},
    )


def summarise_play(
    record: PlayRecord, options: SoccerOptions, teams: Mapping[str, Sequence[np.ndarray]]
) -> dict[str, Any]:
    """The per-team table of the module docstring for a recorded play.

    ``teams`` maps a name to the team (0 or 1) it played in each pitch, ``int [K]``;
    several arrays pool their columns (self-play: both sides). Returns ``{name: metrics}``
    for every name, and the play's own metrics.
    """
    counts = count_events(record, options)
    worlds = np.arange(record.scoring_team.shape[1])
    result: dict[str, Any] = {}
    for name, picks in teams.items():
        total = {
            key: float(sum(value[worlds, pick].sum() for pick in picks))
            for key, value in counts.items()
            if value.ndim == 2
        }
        decisions = float(counts["decisions"].sum()) * len(picks)
        episodes = float(counts["episodes"].sum()) * len(picks)
        on_target = total["shots_on_target"]
        metrics: dict[str, Any] = {
            "goals_per_1000": 1000 * total["goals"] / decisions,
            "shots_per_1000": 1000 * total["shots"] / decisions,
            "goalie_shot_share": total["goalie_shots"] / total["shots"]
            if total["shots"]
            else float("nan"),
            "shots_on_target_per_1000": 1000 * total["shots_on_target"] / decisions,
            "on_target_outcomes": {
                outcome: total[f"on_target_{outcome}"] / on_target if on_target else float("nan")
                for outcome in SHOT_OUTCOMES
            },
            "ball_in_opponent_half": total["ball_in_opponent_half"] / decisions,
            "striker_ball_distance": total["striker_ball_distance"] / decisions,
            "goalie_goal_distance": total["goalie_goal_distance"] / decisions,
            "striker_touches_per_episode": total["striker_touches"] / episodes,
            "goalie_touches_per_episode": total["goalie_touches"] / episodes,
        }
        for group, names in ACTION_NAMES.items():
            taken = np.concatenate(
                [record.actions[group][:, worlds, pick].reshape(-1) for pick in picks]
            )
            shares = np.bincount(taken, minlength=len(names)) / len(taken)
            metrics[f"{group}_actions"] = dict(zip(names, shares.tolist(), strict=True))
        metrics.update({key: int(total[key]) for key in ("goals", "shots", "shots_on_target")})
        result[name] = metrics
    lengths, goals = complete_episodes(record, options.max_cycles)
    result["episodes"] = int(counts["episodes"].sum())
    result["complete_episodes"] = len(lengths)
    result["goal_share"] = float(goals.mean()) if len(goals) else float("nan")
    result["episode_length"] = float(lengths.mean()) if len(lengths) else float("nan")
    return result


def complete_episodes(record: PlayRecord, max_cycles: int) -> tuple[np.ndarray, np.ndarray]:
    """Length and goal flag of every episode that started at least ``max_cycles``
    decisions before the end of ``record``, hence ended within it however it ended
    (counting the episodes that ended within the play would favour short ones: goals).

    Examples:
        >>> ended = np.array([[0], [1], [0], [0], [0], [1], [0], [1], [0], [0]], dtype=bool)
        >>> scoring = np.where(ended, 0, -1)
        >>> scoring[5] = -1  # the second episode is truncated
        >>> record = PlayRecord(
        ...     np.zeros((10, 1, 28)), np.zeros((10, 1, 28)), scoring, ended, {}
        ... )
        >>> lengths, goals = complete_episodes(record, max_cycles=4)
        >>> lengths.tolist(), goals.tolist()
        ([2, 4, 2], [True, False, True])
    """
    decisions, worlds = record.ended.shape
    lengths: list[int] = []
    goals: list[bool] = []
    for world in range(worlds):
        start = 0
        for end in np.flatnonzero(record.ended[:, world]).tolist():
            if start + max_cycles > decisions:
                break
            lengths.append(end - start + 1)
            goals.append(bool(record.scoring_team[end, world] >= 0))
            start = end + 1
    return np.array(lengths, dtype=np.int64), np.array(goals, dtype=bool)


def soccer_diagnostics(
    state: Mapping[str, Any],
    *,
    worlds: int = 32,
    decisions: int = 1000,
    seed: int = 0,
) -> dict[str, Any]:
    """The table of the module docstring for a trained soccer team.

    Args:
        state: a loaded checkpoint or final team (:func:`rlhc.storage.final_team.load_team`).
        worlds: pitches played at once (the trained team on team ``k % 2`` of pitch ``k``).
        decisions: decisions per pitch, for each play (against scripted, self-play).
        seed: the pitches' seed (the same for both plays); torch is seeded with it too.

    Returns:
        A JSON-ready dict: ``worlds``, ``decisions``, ``seed``, ``vs_scripted``, ``self_play``.

    Raises:
        ValueError: ``state`` is not a soccer team.
    """
    if state["env"] != "soccer":
        raise ValueError(f"soccer_diagnostics needs a soccer team, got one of {state['env']!r}")
    options = observation_options(state)
    result: dict[str, Any] = {"worlds": worlds, "decisions": decisions, "seed": seed}
    sides = np.arange(worlds, dtype=np.int64) % 2  # the trained team's, alternating
    for play in ("vs_scripted", "self_play"):
        torch.manual_seed(seed)
        env = make_env("soccer", num_envs=worlds, seed=seed, **options)
        assert isinstance(env, BatchedGameEnv)
        try:
            trained = restore_policy(state, env)
            opponent: TeamPolicy = ScriptedPolicy(env) if play == "vs_scripted" else trained
            record = record_play(env, trained, opponent, torch.from_numpy(sides), decisions)
            game_options = _soccer_game(env).options
        finally:
            env.close()
        teams = (
            {"trained": [sides], "scripted": [1 - sides]}
            if play == "vs_scripted"
            else {"trained": [sides, 1 - sides]}
        )
        result[play] = summarise_play(record, game_options, teams)
    return result
