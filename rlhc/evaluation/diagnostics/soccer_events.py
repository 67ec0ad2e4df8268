"""What happened in a recorded soccer play, read from the game's states alone (numpy).

A :class:`PlayRecord` holds the game's state before and after every decision of ``K``
pitches; :func:`count_events` turns it into per-team counts, each team in its own frame:
it attacks ``+x`` and defends the goal line at ``x = -L/2`` (``L``: ``pitch_length``).

| event | definition |
|---|---|
| in touch | a player's centre within ``player_radius + ball_radius +`` :data:`~rlhc.envs.soccer.controls.KICK_REACH` of the ball's (where the game lets a player kick) |
| touch | a player out of touch when a decision is taken and in touch once it is played |
| release | the end of a touch: the first decision after which the player is out of touch again, or the end of the episode |
| shot | a player's release (striker or goalie) after which the ball rolls towards the opponents' goal line fast enough to reach it, slowed by the game's drag only (``x + v_x dt d / (1 - d) >= L/2``, ``dt`` the frame, ``d`` the drag per frame), or a goal of its team scored during the touch |
| shot on target | a shot whose straight line crosses the goal line within the mouth (``abs(y) <= goal_width / 2``), or such a goal |
| outcome of a shot on target | the first of: ``goal`` (its team scores), ``saved`` (the opponents' goalie comes in touch), ``blocked`` (the opponents' striker does), ``retouched`` (its own team does), ``missed`` (the ball turns back, ``v_x <= 0``, untouched), ``unfinished`` (the episode is truncated or the record ends first) |

A bounce that begins and ends within one decision is not seen in touch (the tests
compare touches with pymunk's own contacts on scripted play: most are seen).

Examples:
    >>> from rlhc.envs.soccer.options import SoccerOptions
    >>> rolling_reach(np.array([6.7]), SoccerOptions()).round(1)  # a kick rolls ~18 m
    array([18.5])
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rlhc.envs.soccer.controls import KICK_REACH
from rlhc.envs.soccer.options import SoccerOptions

#: The outcomes of a shot on target, in the order they are checked.
SHOT_OUTCOMES = ("goal", "saved", "blocked", "retouched", "missed", "unfinished")
#: Body indices (the game's body order): the striker and the goalie of each team.
STRIKER = np.array([0, 1])
GOALIE = np.array([2, 3])
#: The team of each player, in body order.
PLAYER_TEAM = np.array([0, 1, 0, 1])
_TEAM_SIGN = np.array([1.0, -1.0])  # multiplies pitch coordinates into each team's frame


@dataclass
class PlayRecord:
    """``T`` decisions of ``K`` pitches, as :func:`count_events` reads them.

    Attributes:
        before: ``float32 [T, K, 28]`` the game's state when each decision was taken.
        after: ``float32 [T, K, 28]`` the state once it was played (before any reset).
        scoring_team: ``int64 [T, K]`` the team that scored on the decision, -1 if none.
        ended: ``bool [T, K]`` the episode ended on the decision (goal or truncation).
        actions: per group, ``int64 [T, K, 2]`` the actions taken (team 0, team 1).
    """

    before: np.ndarray
    after: np.ndarray
    scoring_team: np.ndarray
    ended: np.ndarray
    actions: dict[str, np.ndarray]

    def __post_init__(self) -> None:
        t, k = self.scoring_team.shape
        shapes = {
            "before": (self.before.shape, (t, k, 28)),
            "after": (self.after.shape, (t, k, 28)),
            "ended": (self.ended.shape, (t, k)),
        }
        wrong = {name: got for name, (got, want) in shapes.items() if got != want}
        if wrong:
            raise ValueError(f"PlayRecord of {t} decisions x {k} pitches: bad shapes {wrong}")


def ball_position(states: np.ndarray) -> np.ndarray:
    """``[..., 2]`` the ball's position in a ``[..., 28]`` state (pitch frame)."""
    return states[..., 0:2]


def ball_velocity(states: np.ndarray) -> np.ndarray:
    """``[..., 2]`` the ball's velocity in a ``[..., 28]`` state (pitch frame)."""
    return states[..., 2:4]


def player_positions(states: np.ndarray) -> np.ndarray:
    """``[..., 4, 2]`` the players' positions in body order (pitch frame)."""
    players = states[..., 4:].reshape(*states.shape[:-1], 4, 6)
    return players[..., 0:2]


def in_touch(states: np.ndarray, options: SoccerOptions) -> np.ndarray:
    """``bool [..., 4]``: which players are in touch with the ball (module table)."""
    distance = np.linalg.norm(
        player_positions(states) - ball_position(states)[..., None, :], axis=-1
    )
    return distance <= options.player_radius + options.ball_radius + KICK_REACH


def rolling_reach(speed: np.ndarray, options: SoccerOptions) -> np.ndarray:
    """How far a ball rolling at ``speed`` (m/s) goes, slowed by the game's drag ``d`` per
    frame ``dt`` only: ``v dt (d + d² + …) = v dt d / (1 - d)``."""
    drag = options.ball_drag
    if drag >= 1.0:
        return np.full(np.shape(speed), np.inf)
    return np.asarray(speed) * options.step_seconds * drag / (1.0 - drag)


def shot_targets(
    position: np.ndarray, velocity: np.ndarray, options: SoccerOptions
) -> tuple[np.ndarray, np.ndarray]:
    """Whether a ball at ``position`` rolling at ``velocity`` (both ``[..., 2]``, the
    shooting team's frame) is a shot, and whether it is on target (module table)."""
    half_length = options.pitch_length / 2
    vx = velocity[..., 0]
    heading = vx > 0
    reaches = position[..., 0] + rolling_reach(vx, options) >= half_length
    steps = np.where(heading, (half_length - position[..., 0]) / np.where(heading, vx, 1.0), 0.0)
    crossing = position[..., 1] + velocity[..., 1] * steps
    shot = heading & reaches
    return shot, shot & (np.abs(crossing) <= options.goal_width / 2)


def count_events(record: PlayRecord, options: SoccerOptions) -> dict[str, np.ndarray]:
    """Per-pitch, per-team counts of a recorded play (module table) under the game's ``options``.

    Returns:
        ``[K, 2]`` arrays (column = team) of counts (``goals``, ``shots``, ``goalie_shots``,
        ``on_target_<outcome>``, ``striker_touches``, …) and of sums over decisions
        (``ball_in_opponent_half``, ``striker_ball_distance`` in metres, …); ``[K]``
        arrays ``decisions`` and ``episodes``.
    """
    decisions, worlds = record.scoring_team.shape
    counts: dict[str, np.ndarray] = {
        key: np.zeros((worlds, 2))
        for key in (
            "goals",
            "shots",
            "shots_on_target",
            "goalie_shots",
            *(f"on_target_{outcome}" for outcome in SHOT_OUTCOMES),
            "striker_touches",
            "goalie_touches",
        )
    }
    _count_positions(record, options, counts)
    touching_before = in_touch(record.before, options)
    touching_after = in_touch(record.after, options)
    starts = touching_after & ~touching_before  # [T, K, 4]
    counts["striker_touches"] += starts[..., STRIKER].sum(0)
    counts["goalie_touches"] += starts[..., GOALIE].sum(0)
    for team in (0, 1):
        counts["goals"][:, team] = (record.scoring_team == team).sum(0)

    open_touch = np.zeros((worlds, 4), dtype=bool)  # a player's touch not yet released
    pending = np.full(worlds, -1)  # the team whose shot on target is under way, -1: none
    for t in range(decisions):
        scoring, ended = record.scoring_team[t], record.ended[t]
        after = record.after[t]
        _resolve_shots(pending, counts, scoring, ended, touching_after[t], after)
        open_touch |= starts[t]
        released = open_touch & (~touching_after[t] | ended[:, None])  # [K, 4]
        open_touch &= ~released
        # In each player's team's frame (body order).
        sign = _TEAM_SIGN[PLAYER_TEAM][None, :, None]
        position = sign * ball_position(after)[:, None, :]
        velocity = sign * ball_velocity(after)[:, None, :]
        shot, on_target = shot_targets(position, velocity, options)
        scored = scoring[:, None] == PLAYER_TEAM[None, :]
        shot, on_target = released & (shot | scored), released & (on_target | scored)
        # One ball: one shot per team and decision, the striker's if both released it.
        counts["shots"] += shot[:, STRIKER] | shot[:, GOALIE]
        counts["goalie_shots"] += shot[:, GOALIE] & ~shot[:, STRIKER]
        team_on_target = on_target[:, STRIKER] | on_target[:, GOALIE]  # [K, 2]
        team_scored = scored[:, STRIKER]
        counts["shots_on_target"] += team_on_target
        for team in (0, 1):
            new, goal = team_on_target[:, team], team_scored[:, team]
            counts["on_target_goal"][new & goal, team] += 1
            pending[new & ~goal & ~ended] = team
            counts["on_target_unfinished"][new & ~goal & ended, team] += 1
    for team in (0, 1):
        counts["on_target_unfinished"][pending == team, team] += 1
    counts["decisions"] = np.full(worlds, float(decisions))
    counts["episodes"] = 1.0 + record.ended[:-1].sum(0)
    return counts


def _resolve_shots(
    pending: np.ndarray,
    counts: dict[str, np.ndarray],
    scoring: np.ndarray,
    ended: np.ndarray,
    touching: np.ndarray,
    after: np.ndarray,
) -> None:
    """Settle the pending shots on target of one decision (module table), in place."""
    for team in (0, 1):
        live = pending == team
        if not live.any():
            continue
        other = 1 - team
        turned_back = _TEAM_SIGN[team] * ball_velocity(after)[:, 0] <= 0
        checks = (
            ("goal", scoring == team),
            ("saved", touching[:, GOALIE[other]]),
            ("blocked", touching[:, STRIKER[other]]),
            ("retouched", touching[:, STRIKER[team]] | touching[:, GOALIE[team]]),
            ("missed", turned_back | (scoring == other)),
            ("unfinished", ended),
        )
        for outcome, happened in checks:
            settled = live & happened
            counts[f"on_target_{outcome}"][settled, team] += 1
            pending[settled] = -1
            live &= ~settled


def _count_positions(
    record: PlayRecord, options: SoccerOptions, counts: dict[str, np.ndarray]
) -> None:
    """Where the ball and players were when each decision was taken, summed, in place."""
    states = record.before
    ball = ball_position(states)  # [T, K, 2]
    players = player_positions(states)  # [T, K, 4, 2]
    in_opponent_half = _TEAM_SIGN[None, None, :] * ball[..., 0:1] > 0  # [T, K, 2]
    counts["ball_in_opponent_half"] = in_opponent_half.sum(0).astype(float)
    striker_distance = np.linalg.norm(players[:, :, STRIKER] - ball[:, :, None, :], axis=-1)
    counts["striker_ball_distance"] = striker_distance.sum(0)
    own_goal = np.stack([-_TEAM_SIGN * options.pitch_length / 2, np.zeros(2)], axis=-1)  # [2, 2]
    goalie_distance = np.linalg.norm(players[:, :, GOALIE] - own_goal, axis=-1)
    counts["goalie_goal_distance"] = goalie_distance.sum(0)
