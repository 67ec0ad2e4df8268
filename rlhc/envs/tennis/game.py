"""2 vs 2 doubles tennis (side view) as a batched numpy game.

| | |
|---|---|
| agents | ``racket_0``, ``racket_1`` (team 0, left), ``racket_2``, ``racket_3`` (team 1, right); one group ``racket`` |
| action | 3 continuous in ``[-1, 1]`` (clipped): move towards/away from the net, jump, paddle tilt (sets the angle) — see :mod:`~rlhc.envs.tennis.control` |
| decision | the action held for ``decision_interval`` physics frames of ``geometry.dt`` (default 5 × 0.02 s, ML-Agents' default) |
| worker observation | 8 (12 with ``extended_obs``) — see :mod:`~rlhc.envs.tennis.observations` |
| manager observation | 10 (14 with ``extended_obs``) |
| rewards | ``+0.1`` to the racket whose hit crosses the net, ``-0.1`` to both rackets of the team that loses the point (``fault_penalty="team"``) — see :mod:`~rlhc.envs.tennis.rules` |
| episode | one point (terminated), or ``max_cycles`` decisions (truncated; default 400 = 40 s) |
| info | ``hits_over_net``: hits paid for crossing the net in the decision ``[N]``; ``hits_over_net_by_team``: the same per hitting team ``[N, 2]``; ``ended_<how>``: the point ended this way in the decision ``[N]``, one per :data:`~rlhc.envs.tennis.rules.POINT_ENDINGS` (``serve_missed``, ``missed``, ``out``, ``net``, ``wall``) |
| state | 24: ball x, y, vx, vy + per racket x, y, vx, vy, angle (absolute frame, scaled) |

The serve alternates between the teams of a court: the ball is tossed, with a
random speed drawn from the game's seeded generator, into the serving team's half,
and that team must play it over the net.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import ClassVar

import numpy as np

from rlhc.envs.base import (
    BatchedGame,
    ContinuousAction,
    FrameOutcome,
    GroupObservation,
    GroupSpec,
)
from rlhc.envs.keys import ENDED_PREFIX
from rlhc.envs.tennis.control import DECISION_INTERVAL, drive_rackets
from rlhc.envs.tennis.observations import (
    LENGTH_SCALE,
    TEAM_SIGN,
    VELOCITY_SCALE,
    manager_size,
    observe_rackets,
    worker_size,
)
from rlhc.envs.tennis.physics import CourtGeometry, TennisPhysics
from rlhc.envs.tennis.render import render_court
from rlhc.envs.tennis.rules import FAULT_PENALTIES, POINT_ENDINGS, Rally, judge

GROUP = "racket"
AGENTS = ("racket_0", "racket_1", "racket_2", "racket_3")
#: Where the rackets stand at the start of a point, in the team frame (back, front).
HOME_X = np.array([-4.0, -1.8])
STATE_SIZE = 24
#: Decisions per point before truncation (40 s at 5 frames of 0.02 s).
MAX_CYCLES = 400


class TennisGame(BatchedGame):
    """``num_worlds`` doubles tennis courts stepped in lockstep.

    Args:
        num_worlds: number of courts.
        seed: seed of the serve generator.
        max_cycles: decisions after which a point is truncated.
        extended_obs: add the teammate's relative position and velocity to the
            observations (worker 12, manager 14).
        decision_interval: physics frames (of ``geometry.dt``) per decision.
        fault_penalty: who pays the ``-0.1`` of a lost point: ``"team"`` (both rackets
            of the team that lost it, the default) or ``"nearest"`` (one racket: the
            nearest to where the ball landed, or the last hitter).
        geometry: court sizes and physical constants (defaults: :class:`CourtGeometry`).
        **unknown: rejected with a ``ValueError`` naming them (a misspelt option
            must not pass silently).

    Examples:
        >>> game = TennisGame(num_worlds=2, seed=0)
        >>> game.reset()
        >>> outcome = game.step({"racket": np.zeros((2, 4, 3))})  # 5 frames of 0.02 s
        >>> game.observe()["racket"].observation.shape
        (2, 4, 8)
    """

    name = "tennis"
    published_info: ClassVar[dict[str, tuple[int, ...]]] = {
        "hits_over_net": (),
        "hits_over_net_by_team": (2,),
        **{f"{ENDED_PREFIX}{how}": () for how in POINT_ENDINGS},
    }
    metadata: ClassVar[dict[str, object]] = {"render_modes": ["rgb_array"], "render_fps": 25}

    def __init__(
        self,
        num_worlds: int = 1,
        seed: int | None = None,
        max_cycles: int = MAX_CYCLES,
        extended_obs: bool = False,
        decision_interval: int = DECISION_INTERVAL,
        fault_penalty: str = "team",
        geometry: CourtGeometry | None = None,
        **unknown: object,
    ) -> None:
        if unknown:
            raise ValueError(
                f"unknown tennis option(s) {sorted(unknown)}; known: max_cycles, "
                "extended_obs, decision_interval, fault_penalty, geometry, seed, num_worlds"
            )
        if fault_penalty not in FAULT_PENALTIES:
            raise ValueError(
                f"fault_penalty={fault_penalty!r}; allowed: {', '.join(FAULT_PENALTIES)}"
            )
        super().__init__(
            num_worlds=num_worlds,
            max_cycles=max_cycles,
            seed=seed,
            decision_interval=decision_interval,
        )
        self.extended_obs = bool(extended_obs)
        self.fault_penalty = fault_penalty
        self.geometry = geometry if geometry is not None else CourtGeometry()
        self.groups = (
            GroupSpec(
                name=GROUP,
                agents=AGENTS,
                observation_size=worker_size(self.extended_obs),
                manager_observation_size=manager_size(self.extended_obs),
                action=ContinuousAction(size=3),
                teams=(0, 0, 1, 1),
            ),
        )
        self.physics = TennisPhysics(num_worlds, self.geometry)
        self.rally = Rally.empty(num_worlds)
        self.jump_velocity = np.zeros((num_worlds, 4))
        # Each court's first server is random; afterwards the serve alternates.
        self.next_server = self.rng.integers(0, 2, size=num_worlds)
        self.reset()

    def seed(self, seed: int | None) -> None:
        super().seed(seed)
        self.next_server = self.rng.integers(0, 2, size=self.num_worlds)

    # --- dynamics --------------------------------------------------------------------
    def reset(self, mask: np.ndarray | None = None) -> None:
        """Start a new point (a serve) in the courts where ``mask`` is true (all if None)."""
        mask = np.ones(self.num_worlds, dtype=bool) if mask is None else np.asarray(mask, bool)
        if mask.shape != (self.num_worlds,):
            raise ValueError(f"reset mask must have shape ({self.num_worlds},), got {mask.shape}")
        count = int(mask.sum())
        if count == 0:
            return
        p, g = self.physics, self.geometry
        server = self.next_server[mask]
        self.next_server[mask] = 1 - server
        side = np.where(server == 0, 1.0, -1.0)  # x sign of the server's team frame
        # The toss: from above the serving half with a random speed; it comes down in
        # that half (at most 1.8 m of drift from x ∈ [-4.5, -2.5]) if nobody plays it.
        toss_x = self.rng.uniform(-4.5, -2.5, count)
        toss_y = self.rng.uniform(2.5, 3.5, count)
        toss_vx = self.rng.uniform(-1.0, 1.5, count)
        toss_vy = self.rng.uniform(0.0, 3.0, count)
        p.ball_position[mask] = np.stack([side * toss_x, toss_y], axis=-1)
        p.ball_velocity[mask] = np.stack([side * toss_vx, toss_vy], axis=-1)
        home = np.concatenate([HOME_X, HOME_X]) * TEAM_SIGN
        p.racket_position[mask, :, 0] = home
        p.racket_position[mask, :, 1] = g.racket_ground_y
        p.racket_velocity[mask] = 0.0
        p.racket_angle[mask] = 0.0
        p.racket_spin[mask] = 0.0
        self.jump_velocity[mask] = 0.0
        self.rally.last_hitter[mask] = -1
        self.rally.serving_team[mask] = server
        self.rally.credit_pending[mask] = False
        self.step_count[mask] = 0

    def advance(self, actions: Mapping[str, np.ndarray]) -> FrameOutcome:
        """Advance every court one frame (``geometry.dt`` seconds); see the module table."""
        action = actions[GROUP]
        p = self.physics
        velocity, angle, self.jump_velocity = drive_rackets(
            action, p.racket_position, self.jump_velocity, self.geometry
        )
        p.racket_velocity[:] = velocity
        p.racket_angle[:] = angle
        p.racket_spin[:] = 0.0
        previous_ball_x = p.ball_position[:, 0].copy()
        p.step()
        # The observed vertical speed is the ballistic one (0 once landed).
        p.racket_velocity[..., 1] = self.jump_velocity
        verdict = judge(
            self.rally,
            p.racket_touch,
            previous_ball_x,
            p.ball_position[:, 0],
            p.racket_position[..., 0],
            p.first_contact,
            p.contact_x,
            self.geometry.half_length,
            self.fault_penalty,
        )
        return FrameOutcome(
            rewards={GROUP: verdict.rewards},
            terminated=verdict.terminated,
            scoring_team=verdict.scoring_team,
            info={
                "hits_over_net": verdict.over_net,
                "hits_over_net_by_team": verdict.over_net_by_team,
                **{
                    f"{ENDED_PREFIX}{how}": verdict.ended_by == code
                    for code, how in enumerate(POINT_ENDINGS, start=1)
                },
            },
        )

    # --- views -----------------------------------------------------------------------
    def observe(self) -> dict[str, GroupObservation]:
        p = self.physics
        worker, manager = observe_rackets(
            p.ball_position,
            p.ball_velocity,
            p.racket_position,
            p.racket_velocity,
            self.extended_obs,
        )
        return {GROUP: GroupObservation(observation=worker, manager_observation=manager)}

    def state(self) -> np.ndarray:
        """``float32 [N, 24]``: ball x, y, vx, vy, then per racket x, y, vx, vy, angle.

        Absolute frame (team A on the left), scaled like the observations; angles in
        radians. :meth:`set_state` accepts the same layout.
        """
        p = self.physics
        ball = np.concatenate(
            [p.ball_position / LENGTH_SCALE, p.ball_velocity / VELOCITY_SCALE], axis=-1
        )
        rackets = np.concatenate(
            [
                p.racket_position / LENGTH_SCALE,
                p.racket_velocity / VELOCITY_SCALE,
                p.racket_angle[..., None],
            ],
            axis=-1,
        )
        return np.concatenate([ball, rackets.reshape(self.num_worlds, -1)], axis=-1).astype(
            np.float32
        )

    def set_state(self, state: np.ndarray, mask: np.ndarray | None = None) -> None:
        """Place ball and rackets as described by ``state`` (the layout of :meth:`state`).

        The rally memory is cleared (as after a serve by team 0) and the step count kept.
        Used by tests and demos to build exact situations.

        Args:
            state: ``[N, 24]`` (or ``[k, 24]`` with ``k`` true entries in ``mask``).
            mask: the courts to set (all if None).
        """
        mask = np.ones(self.num_worlds, dtype=bool) if mask is None else np.asarray(mask, bool)
        state = np.asarray(state, dtype=np.float64)
        if state.shape != (int(mask.sum()), STATE_SIZE):
            raise ValueError(
                f"state must have shape ({int(mask.sum())}, {STATE_SIZE}), got {state.shape}"
            )
        p = self.physics
        p.ball_position[mask] = state[:, 0:2] * LENGTH_SCALE
        p.ball_velocity[mask] = state[:, 2:4] * VELOCITY_SCALE
        rackets = state[:, 4:].reshape(-1, 4, 5)
        p.racket_position[mask] = rackets[..., 0:2] * LENGTH_SCALE
        p.racket_velocity[mask] = rackets[..., 2:4] * VELOCITY_SCALE
        p.racket_angle[mask] = rackets[..., 4]
        p.racket_spin[mask] = 0.0
        self.jump_velocity[mask] = rackets[..., 3] * VELOCITY_SCALE
        self.rally.last_hitter[mask] = -1
        self.rally.serving_team[mask] = 0
        self.rally.credit_pending[mask] = False

    def render(self, world: int = 0) -> np.ndarray:
        return render_court(self, world)
