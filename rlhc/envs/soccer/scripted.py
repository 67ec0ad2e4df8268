"""Scripted soccer players, batched over pitches: evaluation opponents and test drivers.

Both read the full state (:meth:`SoccerGame.state`, ``[N, 28]``) and reason in their
team's frame (team 1 rotates the pitch by 180°), so one rule serves both sides:

* the striker walks to a point behind the ball on the line from the ball to the
  opponent goal (aiming at the half of the mouth away from the opponent goalie), turns
  towards it, and runs through the ball (a forward contact kicks); facing its own half
  with the ball just ahead, it side-steps instead, so as never to kick towards its own
  goal;
* the goalie stays one metre in front of its goal line, where the line from the goal's
  centre to the ball crosses it (narrowing the angle) or, when the ball rolls towards
  the goal, where the ball's path crosses it; it steps out to clear a ball that comes
  close in front of it.

:func:`scripted_team` is the game's scripted team of the registry
(:class:`~rlhc.envs.registry.GameSpec`).
"""

from __future__ import annotations

import numpy as np

from rlhc.envs.base import BatchedGame
from rlhc.envs.soccer.controls import GOALIE_ACTIONS, STRIKER_ACTIONS
from rlhc.envs.soccer.game import SoccerGame
from rlhc.envs.soccer.options import SoccerOptions

_STRIKER = {name: index for index, name in enumerate(STRIKER_ACTIONS)}
_GOALIE = {name: index for index, name in enumerate(GOALIE_ACTIONS)}
_TURN_TOLERANCE = 0.35  # radians: beyond this heading error the striker turns first
_GOALIE_LINE_GAP = 1.0  # metres between the goalie's line and its goal line
_SIDESTEP_MARGIN = 0.3  # metres beyond touching within which the striker avoids the ball
_INCOMING_SPEED = 0.5  # m/s towards the goal from which the goalie intercepts the ball


def _player(state: np.ndarray, body: int, team: int) -> tuple[np.ndarray, np.ndarray]:
    """Position ``[N, 2]`` and facing ``[N, 2]`` of a player, in ``team``'s frame."""
    start = 4 + 6 * body
    sign = 1.0 if team == 0 else -1.0
    return sign * state[:, start : start + 2], sign * state[:, start + 4 : start + 6]


def _ball(state: np.ndarray, team: int) -> np.ndarray:
    return (1.0 if team == 0 else -1.0) * state[:, 0:2]


def striker_actions(
    state: np.ndarray, team: int, options: SoccerOptions | None = None
) -> np.ndarray:
    """``int64 [N]`` actions of ``striker_<team>`` driving the ball at the opponent goal.

    Args:
        state: ``[N, 28]`` full state.
        team: 0 or 1.
        options: the game options (pitch size, radii); defaults if ``None``.

    Examples:
        >>> from rlhc.envs.soccer.game import SoccerGame
        >>> game = SoccerGame(num_worlds=3, seed=0)
        >>> striker_actions(game.state(), team=1).shape
        (3,)
    """
    options = options or SoccerOptions()
    ball = _ball(state, team)
    position, facing = _player(state, team, team)
    opponent_goalie, _ = _player(state, 3 - team, team)
    # Aim at the half of the mouth the opponent goalie is not covering.
    aim_y = np.where(opponent_goalie[:, 1] > 0, -0.5, 0.5) * options.goal_width / 2
    aim = np.stack([np.full_like(aim_y, options.pitch_length / 2 + 0.5), aim_y], axis=-1)
    to_aim = aim - ball
    shot = to_aim / np.linalg.norm(to_aim, axis=-1, keepdims=True)
    normal = np.stack([-shot[:, 1], shot[:, 0]], axis=-1)

    reach = options.player_radius + options.ball_radius
    behind = ball - shot * (reach + 0.3)
    offset = position - ball
    along, across = np.sum(offset * shot, -1), np.sum(offset * normal, -1)
    lined_up = (along < -0.5 * reach) & (np.abs(across) < 0.5 * options.player_radius)
    # On the wrong side of the ball: go round it on the side the player is already on.
    wrong_side = along > -0.5 * reach
    detour = behind + np.where(across >= 0, 1.0, -1.0)[:, None] * normal * (reach + 0.3)
    target = np.where(lined_up[:, None], ball, np.where(wrong_side[:, None], detour, behind))

    to_target = target - position
    heading = np.arctan2(to_target[:, 1], to_target[:, 0])
    error = np.angle(np.exp(1j * (heading - np.arctan2(facing[:, 1], facing[:, 0]))))
    # Facing its own half with the ball just ahead (in the kicking arc), a forward step
    # would kick the ball towards its own goal: side-step away from the ball instead.
    to_ball = ball - position
    distance = np.linalg.norm(to_ball, axis=-1)
    in_the_way = (
        (np.sum(facing * shot, -1) < 0.0)
        & (distance < reach + _SIDESTEP_MARGIN)
        & (np.sum(to_ball * facing, -1) > 0.5 * distance)
    )
    ball_on_left = facing[:, 0] * to_ball[:, 1] - facing[:, 1] * to_ball[:, 0] > 0
    return np.where(
        in_the_way,
        np.where(ball_on_left, _STRIKER["side_right"], _STRIKER["side_left"]),
        np.where(
            np.abs(error) <= _TURN_TOLERANCE,
            _STRIKER["forward"],
            np.where(error > 0, _STRIKER["rotate_left"], _STRIKER["rotate_right"]),
        ),
    ).astype(np.int64)


def goalie_actions(
    state: np.ndarray, team: int, options: SoccerOptions | None = None
) -> np.ndarray:
    """``int64 [N]`` actions of ``goalie_<team>`` guarding its goal line.

    Args:
        state: ``[N, 28]`` full state.
        team: 0 or 1.
        options: the game options (pitch size, radii); defaults if ``None``.
    """
    options = options or SoccerOptions()
    ball = _ball(state, team)
    position, _ = _player(state, 2 + team, team)
    goal_line = -options.pitch_length / 2
    line = goal_line + _GOALIE_LINE_GAP
    # Narrow the angle: stand where the line from the goal's centre to the ball crosses
    # the goalie's line, within the mouth; a ball rolling towards the goal is met where
    # its path crosses that line instead.
    reach = np.maximum(ball[:, 0] - goal_line, _GOALIE_LINE_GAP)
    cover = options.goal_width / 2 - options.player_radius / 2
    narrow = ball[:, 1] * _GOALIE_LINE_GAP / reach
    velocity = (1.0 if team == 0 else -1.0) * state[:, 2:4]
    incoming = (velocity[:, 0] < -_INCOMING_SPEED) & (ball[:, 0] > line)
    time_to_line = (line - ball[:, 0]) / np.where(incoming, velocity[:, 0], -1.0)
    crossing = ball[:, 1] + velocity[:, 1] * time_to_line
    target_y = np.clip(np.where(incoming, crossing, narrow), -cover, cover)
    target = np.stack([np.full(len(state), line), target_y], axis=-1)
    to_ball = ball - position
    clear = (to_ball[:, 0] > 0) & (np.linalg.norm(to_ball, axis=-1) < 1.5)
    error = target - position
    sideways = (np.abs(error[:, 1]) > np.abs(error[:, 0])) & (np.abs(error[:, 1]) > 0.1)
    # The goalie faces +x in its team's frame: forward is +x, side left is +y.
    return np.where(
        clear,
        _GOALIE["forward"],
        np.where(
            sideways,
            np.where(error[:, 1] > 0, _GOALIE["side_left"], _GOALIE["side_right"]),
            np.where(error[:, 0] > 0, _GOALIE["forward"], _GOALIE["backward"]),
        ),
    ).astype(np.int64)


def scripted_actions(
    state: np.ndarray, options: SoccerOptions | None = None
) -> dict[str, np.ndarray]:
    """Actions of all four scripted players, ready for :meth:`SoccerGame.step`.

    Args:
        state: ``[N, 28]`` full state.
        options: the game options; defaults if ``None``.

    Returns:
        ``{"striker": int64 [N, 2], "goalie": int64 [N, 2]}`` (team 0, team 1).

    Examples:
        >>> from rlhc.envs.soccer.game import SoccerGame
        >>> game = SoccerGame(num_worlds=2, seed=0)
        >>> outcome = game.step(scripted_actions(game.state(), game.options))
        >>> outcome.rewards["striker"].shape
        (2, 2)
    """
    return {
        "striker": np.stack([striker_actions(state, team, options) for team in (0, 1)], axis=1),
        "goalie": np.stack([goalie_actions(state, team, options) for team in (0, 1)], axis=1),
    }


def scripted_team(game: BatchedGame) -> dict[str, np.ndarray]:
    """Actions of the scripted players of both teams, for every pitch of ``game``.

    Args:
        game: a :class:`~rlhc.envs.soccer.game.SoccerGame`; its current full state and
            its options are read.

    Returns:
        ``{"striker": int64 [N, 2], "goalie": int64 [N, 2]}`` (:func:`scripted_actions`).

    Raises:
        TypeError: ``game`` is not a soccer game.

    Examples:
        >>> from rlhc.envs.soccer.game import SoccerGame
        >>> sorted(scripted_team(SoccerGame(num_worlds=2, seed=0)))
        ['goalie', 'striker']
    """
    if not isinstance(game, SoccerGame):
        raise TypeError(f"the scripted soccer team plays a SoccerGame, got {type(game).__name__}")
    return scripted_actions(game.state(), game.options)
