"""Soccer is symmetric under a half turn: both teams play the same game.

Both teams share one policy in self-play and team 1 sees the pitch turned by 180°, so
a scene turned by 180° (teams swapped) must evolve exactly like the original.
"""

from __future__ import annotations

import numpy as np
import pytest

from rlhc.envs.soccer import SoccerGame, scripted

#: body order of the turned scene: the teams swap (strikers 0↔1, goalies 2↔3, ball 4).
HALF_TURN = [1, 0, 3, 2, 4]


def half_turn(positions: np.ndarray, angles: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The scene turned by 180° about the centre spot, teams swapped (0 and π map exactly)."""
    turned = angles[:, HALF_TURN] + np.pi
    return -positions[:, HALF_TURN], np.where(turned > np.pi, turned - 2 * np.pi, turned)


def test_both_teams_move_exactly_opposite_from_a_still_kickoff() -> None:
    game = SoccerGame(num_worlds=1, seed=0, kickoff_jitter=0, kickoff_angle_jitter=0)
    for striker, goalie in [(0, 0), (1, 1), (4, 2), (5, 3), (0, 0)]:  # no contact yet
        game.step({"striker": np.full((1, 2), striker), "goalie": np.full((1, 2), goalie)})
        positions = game.physics.positions[0]
        np.testing.assert_array_equal(positions[[1, 3]], -positions[[0, 2]])


@pytest.mark.parametrize(("seed", "jitter"), [(0, 0.0), (0, 0.5), (1, 0.5), (2, 0.5)])
def test_a_half_turned_match_replays_the_original(seed: int, jitter: float) -> None:
    """Scripted team 0 against an idle team 1, and the same match turned by 180°."""
    options = dict(kickoff_jitter=jitter, kickoff_angle_jitter=jitter / 2, max_cycles=10**4)
    game = SoccerGame(num_worlds=1, seed=seed, **options)
    turned = SoccerGame(num_worlds=1, seed=seed, **options)
    turned.place(*half_turn(game.physics.positions, game.physics.angles))
    for step in range(150):
        state = game.state()
        actions = {
            "striker": np.stack([scripted.striker_actions(state, 0, game.options), [2]], 1),
            "goalie": np.stack([scripted.goalie_actions(state, 0, game.options), [step % 2]], 1),
        }
        outcome = game.step(actions)
        turned.step({group: a[:, ::-1].copy() for group, a in actions.items()})
        back, _ = half_turn(turned.physics.positions, turned.physics.angles)
        np.testing.assert_allclose(
            back, game.physics.positions, rtol=0, atol=1e-9, err_msg=f"step {step + 1}"
        )
        if outcome.terminated[0]:
            break


def test_the_scripted_striker_scores_as_fast_on_either_side() -> None:
    steps = []
    for team in (0, 1):
        game = SoccerGame(num_worlds=1, seed=0, kickoff_jitter=0, kickoff_angle_jitter=0)
        for step in range(500):
            state = game.state()
            striker, goalie = np.full((1, 2), 2), np.full((1, 2), step % 2)
            striker[:, team] = scripted.striker_actions(state, team, game.options)
            goalie[:, team] = scripted.goalie_actions(state, team, game.options)
            if game.step({"striker": striker, "goalie": goalie}).terminated[0]:
                break
        steps.append(step + 1)
    assert steps[0] == steps[1] < 500, steps
