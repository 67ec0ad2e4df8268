"""The umpire: rewards and the end of a point, vectorised over courts.

The rules follow the Unity tennis the RLHC paper trained on (volley tennis: the
ball may not touch the ground):

| event | reward | point to |
|---|---|---|
| a racket hits the ball and it then crosses the net | ``+0.1`` to that racket | — (rally goes on) |
| the ball lands inside a team's half (missed) | ``-0.1`` to both rackets of that team | the other team |
| the ball lands outside the court, or hits a wall, the ceiling or the net | ``-0.1`` to both rackets of the last hitter's team | the other team |

The paper's Table 1 gives "−0.1 when agents miss the ball": the team that misses pays.
``fault_penalty="nearest"`` (the rule of earlier versions) charges one racket instead:
the one of the missing team nearest to where the ball landed, or the last hitter.
With that rule, in training runs of the earlier frame-based trainer, each racket
learned to run *from* a falling ball and leave the penalty to its partner (its move
anti-correlated with the ball's offset in its half), so ``"team"`` is the default.

Edge cases, decided here once:

* before anyone has hit the ball (the serve), the serving team is at fault (with
  ``"nearest"``: its racket nearest to the ball);
* the over-the-net bonus is paid once per hit, only if the ball crosses from the
  hitter's own half;
* on one step a racket may collect several entries (e.g. a hit over the net and the
  ball then landing out), and its reward is their sum;
* the first rally-ending contact of a step decides the point.

How a point ended (:data:`POINT_ENDINGS`, :attr:`Verdict.ended_by`): ``serve_missed``, the
tossed ball landed before anyone touched it; ``missed``, after a hit the ball landed
inside a team's half (that team did not play it); ``out``, it landed outside the court;
``net``, it hit the net; ``wall``, a wall or the ceiling.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rlhc.envs.tennis.physics import GROUND_CONTACT, NET_CONTACT, NO_CONTACT, WALL_CONTACT

#: The reward table.
HIT_OVER_NET_REWARD = 0.1
FAULT_REWARD = -0.1
#: Who pays ``FAULT_REWARD`` (see the module docstring).
FAULT_PENALTIES = ("team", "nearest")
#: Team of each racket.
RACKET_TEAM = np.array([0, 0, 1, 1])
#: How a point can end; :attr:`Verdict.ended_by` holds ``index + 1`` (``0``: not ended).
POINT_ENDINGS = ("serve_missed", "missed", "out", "net", "wall")


@dataclass
class Rally:
    """Per-court memory of the umpire between steps.

    Attributes:
        last_hitter: ``int64 [N]``: the racket that last touched the ball, ``-1`` since the serve.
        serving_team: ``int64 [N]``: the team that served this point.
        credit_pending: ``bool [N]``: the last hit has not yet been paid for crossing the net.
    """

    last_hitter: np.ndarray
    serving_team: np.ndarray
    credit_pending: np.ndarray

    @classmethod
    def empty(cls, num_courts: int) -> Rally:
        return cls(
            last_hitter=np.full(num_courts, -1, dtype=np.int64),
            serving_team=np.zeros(num_courts, dtype=np.int64),
            credit_pending=np.zeros(num_courts, dtype=bool),
        )


@dataclass
class Verdict:
    """The umpire's decision for one step.

    Attributes:
        rewards: ``float32 [N, 4]``.
        terminated: ``bool [N]``: the point is over.
        scoring_team: ``int64 [N]``: who won the point, ``-1`` if it goes on.
        over_net: ``bool [N]``: a hit was paid for crossing the net on this step.
        over_net_by_team: ``bool [N, 2]``: ``over_net`` by the hitter's team.
        ended_by: ``int64 [N]``: how the point ended, ``1 + `` its index in
            :data:`POINT_ENDINGS`; ``0`` if it goes on.
    """

    rewards: np.ndarray
    terminated: np.ndarray
    scoring_team: np.ndarray
    over_net: np.ndarray
    over_net_by_team: np.ndarray
    ended_by: np.ndarray


def _nearest_of_team(team: np.ndarray, x: np.ndarray, racket_x: np.ndarray) -> np.ndarray:
    """Index (0–3) of the racket of ``team`` horizontally nearest to ``x``, per court."""
    first = 2 * team
    rows = np.arange(len(team))
    first_x = racket_x[rows, first]
    second_x = racket_x[rows, first + 1]
    return first + (np.abs(second_x - x) < np.abs(first_x - x))


def judge(
    rally: Rally,
    racket_touch: np.ndarray,
    previous_ball_x: np.ndarray,
    ball_x: np.ndarray,
    racket_x: np.ndarray,
    first_contact: np.ndarray,
    contact_x: np.ndarray,
    half_length: float,
    fault_penalty: str = "team",
) -> Verdict:
    """Score one step of every court and update ``rally`` in place.

    Args:
        rally: the umpire's memory (updated in place).
        racket_touch: ``bool [N, 4]``: which rackets began touching the ball this step.
        previous_ball_x: ``[N]``: the ball's x before the step (court-local).
        ball_x: ``[N]``: the ball's x after the step.
        racket_x: ``[N, 4]``: the rackets' x after the step.
        first_contact: ``int [N]``: the first rally-ending contact of the step
            (``physics.NO_CONTACT``, ``GROUND_CONTACT``, ``NET_CONTACT`` or ``WALL_CONTACT``).
        contact_x: ``[N]``: the ball's x at that contact.
        half_length: the court spans ``[-half_length, half_length]``.
        fault_penalty: ``"team"`` (both rackets of the losing team pay) or ``"nearest"``
            (one racket pays).

    Returns:
        The :class:`Verdict`.

    Examples:
        >>> rally = Rally.empty(1)
        >>> verdict = judge(rally, np.array([[True, False, False, False]]),
        ...                 np.array([-0.5]), np.array([0.5]), np.array([[-1.0, -3, 3, 1]]),
        ...                 np.array([0]), np.array([0.0]), 6.0)
        >>> verdict.rewards.tolist(), bool(verdict.terminated[0])
        ([[0.10000000149011612, 0.0, 0.0, 0.0]], False)
    """
    n = len(ball_x)
    rows = np.arange(n)
    rewards = np.zeros((n, 4), dtype=np.float32)

    # Hits. Two rackets touching on one step is rare; the lower index takes the hit.
    hit = racket_touch.any(axis=1)
    rally.last_hitter = np.where(hit, np.argmax(racket_touch, axis=1), rally.last_hitter)
    rally.credit_pending |= hit

    # Crossing the net (only possible above it: the net is solid).
    from_team = (previous_ball_x > 0).astype(np.int64)  # team A's half is x < 0
    crossed = (previous_ball_x < 0) != (ball_x < 0)
    hitter = np.maximum(rally.last_hitter, 0)
    over_net = (
        crossed
        & rally.credit_pending
        & (rally.last_hitter >= 0)
        & (RACKET_TEAM[hitter] == from_team)
    )
    rewards[rows[over_net], hitter[over_net]] += HIT_OVER_NET_REWARD
    rally.credit_pending &= ~crossed

    # The end of the point.
    ended = first_contact != NO_CONTACT
    inside = np.abs(contact_x) <= half_length
    missed = ended & (first_contact == GROUND_CONTACT) & inside
    missing_team = (contact_x > 0).astype(np.int64)
    missed_by = _nearest_of_team(missing_team, contact_x, racket_x)
    # Out, wall, ceiling or net: the last hitter's fault (the server's team since the serve).
    serve_culprit = _nearest_of_team(rally.serving_team, ball_x, racket_x)
    faulted_by = np.where(rally.last_hitter >= 0, rally.last_hitter, serve_culprit)
    culprit = np.where(missed, missed_by, faulted_by)
    losing_team = RACKET_TEAM[culprit]
    if fault_penalty == "team":
        pays = (RACKET_TEAM[None, :] == losing_team[:, None]) & ended[:, None]
        rewards += np.where(pays, np.float32(FAULT_REWARD), np.float32(0.0))
    elif fault_penalty == "nearest":
        rewards[rows[ended], culprit[ended]] += FAULT_REWARD
    else:
        raise ValueError(f"fault_penalty={fault_penalty!r}; allowed: {', '.join(FAULT_PENALTIES)}")
    scoring_team = np.where(ended, 1 - losing_team, -1).astype(np.int64)
    over_net_by_team = over_net[:, None] & (RACKET_TEAM[hitter][:, None] == np.arange(2))
    return Verdict(
        rewards=rewards,
        terminated=ended,
        scoring_team=scoring_team,
        over_net=over_net,
        over_net_by_team=over_net_by_team,
        ended_by=_ending(ended, first_contact, inside, rally.last_hitter >= 0),
    )


def _ending(
    ended: np.ndarray, first_contact: np.ndarray, inside: np.ndarray, hit: np.ndarray
) -> np.ndarray:
    """:attr:`Verdict.ended_by` from the first contact, where it was and whether the ball
    had been hit since the serve.

    Examples:
        >>> from rlhc.envs.tennis.physics import GROUND_CONTACT, NET_CONTACT
        >>> codes = _ending(np.array([True, True, True, True, False]),
        ...                 np.array([GROUND_CONTACT, GROUND_CONTACT, GROUND_CONTACT, NET_CONTACT, 0]),
        ...                 np.array([True, True, False, True, True]),
        ...                 np.array([False, True, True, True, True]))
        >>> [POINT_ENDINGS[c - 1] if c else None for c in codes]
        ['serve_missed', 'missed', 'out', 'net', None]
    """
    ground = first_contact == GROUND_CONTACT
    name = np.select(
        [
            ground & inside & ~hit,
            ground & inside & hit,
            ground & ~inside,
            first_contact == NET_CONTACT,
            first_contact == WALL_CONTACT,
        ],
        [1, 2, 3, 4, 5],
        default=0,
    )
    return np.where(ended, name, 0).astype(np.int64)
