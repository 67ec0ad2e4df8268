"""A scripted doubles tennis team: it tracks the ball and volleys it back.

Used by the tests (two scripted teams keep rallies going), by demos and as a
fixed evaluation opponent. It reads only the worker observations, batched over
courts, and splits the court between the two rackets of a team: the back racket
(``racket_0`` / ``racket_2``) takes balls coming down behind ``split_x``, the front
one the others; the idle racket walks back to its home position.

For the racket in charge it predicts where the ball will come down to paddle
height, runs there, and tilts the paddle so that a mirror reflection would send
the ball towards ``aim_x`` in the opponents' half on an arc of ``launch_speed_y``
upwards. A jump adds pace when the ball comes in slowly.

:func:`scripted_team` is the game's scripted team of the registry
(:class:`~rlhc.envs.registry.GameSpec`): all four rackets of every court.
"""

from __future__ import annotations

import numpy as np

from rlhc.envs.base import BatchedGame
from rlhc.envs.tennis.control import DECISION_INTERVAL
from rlhc.envs.tennis.game import TennisGame
from rlhc.envs.tennis.observations import LENGTH_SCALE, VELOCITY_SCALE
from rlhc.envs.tennis.physics import CourtGeometry

#: Team-frame home x of the back and front rackets (metres).
_HOME_X = np.array([-4.0, -1.8, -4.0, -1.8])
_IS_BACK = np.array([True, False, True, False])


class ScriptedTennisPolicy:
    """Observations ``[N, 4, >=8]`` (team frame, scaled) → actions ``[N, 4, 3]``.

    Args:
        geometry: the court the rackets play on (gravity, speeds, tilt range).
        decision_interval: physics frames per decision of the game it plays (the
            distance a racket covers before its next decision).
        split_x: team-frame x (metres) dividing the back and front rackets' zones.
        aim_x: team-frame x (metres) of the intended landing point, in the opponents' half.
        launch_speed_y: intended upward speed of the returned ball (m/s).
        jump_below_speed: jump into the ball when it comes in slower than this (m/s).

    Examples:
        >>> from rlhc.envs.tennis import TennisGame
        >>> game = TennisGame(num_worlds=2, seed=0)
        >>> policy = ScriptedTennisPolicy()
        >>> actions = policy(game.observe()["racket"].observation)
        >>> actions.shape
        (2, 4, 3)
    """

    def __init__(
        self,
        geometry: CourtGeometry | None = None,
        decision_interval: int = DECISION_INTERVAL,
        split_x: float = -3.0,
        aim_x: float = 3.0,
        launch_speed_y: float = 8.0,
        jump_below_speed: float = 8.0,
    ) -> None:
        self.geometry = geometry if geometry is not None else CourtGeometry()
        self.decision_seconds = self.geometry.dt * decision_interval
        self.split_x = split_x
        self.aim_x = aim_x
        self.launch_speed_y = launch_speed_y
        self.jump_below_speed = jump_below_speed

    def __call__(self, observation: np.ndarray) -> np.ndarray:
        """Actions for the four rackets of every court.

        Args:
            observation: ``[N, 4, d_w]`` worker observations (first 8 entries used).

        Returns:
            ``float32 [N, 4, 3]`` in ``[-1, 1]``.
        """
        g = self.geometry
        obs = np.asarray(observation, dtype=np.float64)
        ball_x, ball_y = obs[..., 0] * LENGTH_SCALE, obs[..., 1] * LENGTH_SCALE
        ball_vx, ball_vy = obs[..., 2] * VELOCITY_SCALE, obs[..., 3] * VELOCITY_SCALE
        racket_x, racket_y = obs[..., 4] * LENGTH_SCALE, obs[..., 5] * LENGTH_SCALE

        # When and where the ball comes down to paddle height (ballistic flight).
        contact_y = g.racket_ground_y + g.ball_radius + g.racket_radius
        drop = np.maximum(ball_y - contact_y, 0.0)
        time = (ball_vy + np.sqrt(ball_vy**2 + 2.0 * g.gravity * drop)) / g.gravity
        landing_x = ball_x + ball_vx * time
        incoming_vx, incoming_vy = ball_vx, ball_vy - g.gravity * time

        ours = (landing_x < 0.0) & ((ball_x < 0.0) | (ball_vx < 0.0))
        in_back_zone = landing_x < self.split_x
        in_charge = ours & (in_back_zone == _IS_BACK)
        target_x = np.where(in_charge, landing_x, _HOME_X)
        step = g.racket_speed * self.decision_seconds
        move = np.clip((target_x - racket_x) / step, -1.0, 1.0)

        # Paddle normal ∝ (outgoing direction - incoming direction): a mirror bounce.
        flight = 2.0 * self.launch_speed_y / g.gravity
        out_vx = (self.aim_x - landing_x) / flight
        out_norm = np.hypot(out_vx, self.launch_speed_y)
        in_norm = np.maximum(np.hypot(incoming_vx, incoming_vy), 1e-6)
        normal_x = out_vx / out_norm - incoming_vx / in_norm
        normal_y = self.launch_speed_y / out_norm - incoming_vy / in_norm
        tilt = np.arctan2(normal_x, normal_y)
        rotate = np.where(in_charge, np.clip(tilt / g.max_tilt, -1.0, 1.0), 0.0)

        # Jump into slow balls, timed so the paddle rises through the contact.
        slow = in_norm < self.jump_below_speed
        close = np.abs(landing_x - racket_x) < 0.3
        soon = time < 0.15
        grounded = racket_y <= g.racket_ground_y + 1e-3
        jump = np.where(in_charge & slow & close & soon & grounded, 0.6, 0.0)
        return np.stack([move, jump, rotate], axis=-1).astype(np.float32)


def scripted_team(game: BatchedGame) -> dict[str, np.ndarray]:
    """Actions of the scripted rackets of both teams, for every court of ``game``.

    Args:
        game: a :class:`~rlhc.envs.tennis.game.TennisGame`; its current worker
            observations are read (the court and decision interval it plays with).

    Returns:
        ``{"racket": float32 [N, 4, 3]}``, ready for :meth:`TennisGame.step`.

    Raises:
        TypeError: ``game`` is not a tennis game.

    Examples:
        >>> from rlhc.envs.tennis import TennisGame
        >>> game = TennisGame(num_worlds=2, seed=0)
        >>> scripted_team(game)["racket"].shape
        (2, 4, 3)
    """
    if not isinstance(game, TennisGame):
        raise TypeError(f"the scripted tennis team plays a TennisGame, got {type(game).__name__}")
    policy = ScriptedTennisPolicy(game.geometry, game.decision_interval)
    return {"racket": policy(game.observe()["racket"].observation)}
