"""A shaping potential for soccer (beyond the paper): ball progress towards the goal.

``Φ_team(s) = x_ball / half_length`` in the team's attacking direction (team 0 attacks
``+x``), in ``[-1, 1]``: every agent of a team gets its team's potential. Used by
:class:`~rlhc.building.shaping.PotentialShaping` as ``F = γ Φ(s') − Φ(s)`` (Ng, Harada &
Russell 1999), which leaves the optimal policies of the game unchanged.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from rlhc.envs.soccer.physics import BALL

if TYPE_CHECKING:
    from rlhc.envs.soccer.game import SoccerGame

#: Attacking direction of each team along x.
ATTACK_SIGN = np.array([1.0, -1.0])


def ball_progress(game: SoccerGame) -> dict[str, np.ndarray]:
    """``Φ`` of every agent of every group, ``float32 [N, n_g]``, for the current state.

    Examples:
        >>> from rlhc.envs.soccer import SoccerGame
        >>> game = SoccerGame(num_worlds=1, seed=0)
        >>> potential = ball_progress(game)
        >>> sorted(potential), potential["striker"].shape
        (['goalie', 'striker'], (1, 2))
    """
    progress = game.physics.positions[:, BALL, 0] / game.geometry.half_length
    out = {}
    for spec in game.groups:
        sign = ATTACK_SIGN[np.asarray(spec.teams)]
        out[spec.name] = (progress[:, None] * sign[None, :]).astype(np.float32)
    return out
