"""Kick-off, goals and rewards of 2 vs 2 soccer.

Rewards (paper Table 2, per agent and step):

======== ============== ================ ===========================
role     its team scores its team concedes every step (time term)
======== ============== ================ ===========================
striker  +1              -0.1             ``striker_time_reward`` (-0.001)
goalie   +0.1            -1               ``goalie_time_reward`` (+0.001)
======== ============== ================ ===========================

A goal is scored when the whole ball has crossed a goal line inside the mouth; it ends
the episode. The time terms are those of the Unity soccer the paper ran: the striker is
pushed to score quickly, the goalie rewarded for every step the ball stays out.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rlhc.envs.soccer.options import SoccerOptions
from rlhc.envs.soccer.physics import BALL, BODIES_PER_WORLD, PLAYER_TEAM, PitchGeometry

#: sparse reward when the agent's team scores / concedes, per role (paper Table 2).
SCORE_REWARD: dict[str, float] = {"striker": 1.0, "goalie": 0.1}
CONCEDE_REWARD: dict[str, float] = {"striker": -0.1, "goalie": -1.0}

#: players of each role, as body indices (team 0 first).
ROLE_BODIES: dict[str, np.ndarray] = {"striker": np.array([0, 1]), "goalie": np.array([2, 3])}

#: kick-off spots in team 0's frame, as fractions: (x / half_length, y / half_width).
_STRIKER_SPOT = (-0.5, 0.0)
_GOALIE_GAP = 1.2  # metres between a goalie's centre and its goal line at kick-off


def kickoff(
    rng: np.random.Generator, count: int, options: SoccerOptions, geometry: PitchGeometry
) -> tuple[np.ndarray, np.ndarray]:
    """Kick-off positions and angles for ``count`` pitches, jittered from ``rng``.

    Team 1's spots are team 0's rotated by 180° about the centre spot; each player gets
    its own jitter, so a kick-off is only symmetric on average.

    Returns:
        ``[count, 5, 2]`` positions and ``[count, 5]`` angles (body order).
    """
    base = np.zeros((BODIES_PER_WORLD, 2))
    base[0] = (_STRIKER_SPOT[0] * geometry.half_length, _STRIKER_SPOT[1] * geometry.half_width)
    base[2] = (-geometry.half_length + _GOALIE_GAP, 0.0)
    base[1], base[3] = -base[0], -base[2]
    jitter = options.kickoff_jitter
    noise = rng.uniform(-jitter, jitter, size=(count, BODIES_PER_WORLD, 2))
    noise[:, BALL] *= 0.5  # the ball stays near the centre spot
    positions = base + noise
    angles = np.where(PLAYER_TEAM == 0, 0.0, np.pi)[None].repeat(count, axis=0)
    turn = rng.uniform(-options.kickoff_angle_jitter, options.kickoff_angle_jitter, (count, 2))
    angles[:, :2] += turn  # strikers only: a goalie's facing is fixed
    return positions, np.concatenate([angles, np.zeros((count, 1))], axis=1)


def scoring_team(
    ball_positions: np.ndarray, geometry: PitchGeometry, ball_radius: float
) -> np.ndarray:
    """``int64 [N]``: the team that has just scored, -1 if none.

    Team 0 scores when the whole ball is past the goal line at ``+x`` (only the mouth
    is open there), team 1 past the one at ``-x``.
    """
    line = geometry.half_length + ball_radius
    x = ball_positions[:, 0]
    return np.where(x > line, 0, np.where(x < -line, 1, -1)).astype(np.int64)


@dataclass
class Rewards:
    """Per-role rewards of one step, ``float32 [N, 2]`` each (team 0, team 1).

    Attributes:
        total: what the agents receive.
        sparse: the goal part (scored / conceded).
        time: the per-step time term.
    """

    total: dict[str, np.ndarray]
    sparse: dict[str, np.ndarray]
    time: dict[str, np.ndarray]


def rewards(scoring: np.ndarray, options: SoccerOptions, time_share: float = 1.0) -> Rewards:
    """The rewards of every agent given which team scored this frame.

    Args:
        scoring: ``int64 [N]``, the scoring team or -1.
        options: the time terms.
        time_share: the share of a decision's time term paid on this frame
            (``1 / decision_interval``: the terms are per decision, as in ML-Agents).

    Examples:
        >>> parts = rewards(np.array([0, -1]), SoccerOptions(striker_time_reward=0.0))
        >>> parts.total["striker"]
        array([[ 1. , -0.1],
               [ 0. ,  0. ]], dtype=float32)
        >>> parts.total["goalie"]
        array([[ 0.101, -0.999],
               [ 0.001,  0.001]], dtype=float32)
    """
    teams = np.array([0, 1])
    scored = scoring[:, None] == teams
    conceded = (scoring[:, None] >= 0) & ~scored
    time_terms = {"striker": options.striker_time_reward, "goalie": options.goalie_time_reward}
    total, sparse, time = {}, {}, {}
    for role in ROLE_BODIES:
        sparse[role] = (scored * SCORE_REWARD[role] + conceded * CONCEDE_REWARD[role]).astype(
            np.float32
        )
        time[role] = np.full(scored.shape, time_terms[role] * time_share, dtype=np.float32)
        total[role] = sparse[role] + time[role]
    return Rewards(total=total, sparse=sparse, time=time)
