"""Potential-based shaping: the terms telescope, and the logged returns stay unshaped."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import torch
from configs import load_smoke as load
from tensordict import TensorDict
from torchrl.envs import TransformedEnv

from rlhc.building.shaping import PotentialShaping
from rlhc.config.validation import validate
from rlhc.envs import make_env
from rlhc.envs.soccer.shaping import ball_progress
from rlhc.errors import ConfigError

GAMMA = 0.9


def test_a_hand_made_trajectory_telescopes_to_minus_the_first_potential() -> None:
    """Φ = 0.3, 0.5, -0.2, 0.8 then a goal: Σ γ^t F_t = γ^T·0 − Φ(s_0)."""
    values = iter([0.3, 0.5, -0.2, 0.8, 0.7])
    current = {"g": np.zeros((1, 2), np.float32)}

    def potential() -> dict[str, np.ndarray]:
        return {"g": current["g"]}

    shaping = PotentialShaping(potential, ["g"], gamma=GAMMA, scale=2.0)
    current["g"][:] = next(values)
    shaping._reset(TensorDict(), TensorDict())
    total = torch.zeros(1, 2, 1)
    for t, terminated in enumerate([False, False, False, True]):
        current["g"][:] = next(values)
        step = TensorDict(
            {
                "g": {
                    "reward": torch.zeros(1, 2, 1),
                    "terminated": torch.full((1, 2, 1), terminated),
                }
            },
            batch_size=[1],
        )
        shaping._step(TensorDict(), step)
        total += GAMMA**t * step["g", "reward"]
    # The terminal potential counts as 0: only -c·Φ(s_0) is left.
    torch.testing.assert_close(total, torch.full((1, 2, 1), -2.0 * 0.3))


def test_soccer_steps_telescope_with_the_ball_progress_potential() -> None:
    env = make_env("soccer", num_envs=4, seed=3)
    game = env.game  # type: ignore[attr-defined]
    shaped = TransformedEnv(
        env, PotentialShaping(lambda: ball_progress(game), ["striker", "goalie"], GAMMA, 1.0)
    )
    td = shaped.reset()
    first = {g: torch.from_numpy(v) for g, v in ball_progress(game).items()}
    torch.manual_seed(0)
    totals = {g: torch.zeros(4, 2) for g in first}
    unshaped = {g: torch.zeros(4, 2) for g in first}
    steps = 30
    for t in range(steps):
        td = shaped.rand_step(td)
        assert not td["next", "done"].any()  # random play scores rarely: 30 steps, no goal
        for group in totals:
            totals[group] += GAMMA**t * td["next", group, "reward"].squeeze(-1)
        td = td["next"]
    # Without shaping each decision pays the time term only.
    for group, term in (("striker", -0.001), ("goalie", 0.001)):
        unshaped[group] = torch.full((4, 2), term) * sum(GAMMA**t for t in range(steps))
    last = {g: torch.from_numpy(v) for g, v in ball_progress(game).items()}
    for group in totals:
        expected = unshaped[group] + GAMMA**steps * last[group] - first[group]
        torch.testing.assert_close(totals[group], expected, atol=1e-5, rtol=1e-5)
    # Zero-sum between the teams: the two sides' potentials are opposite.
    torch.testing.assert_close(last["striker"][:, 0], -last["striker"][:, 1])


def test_logged_returns_stay_the_games_own(tmp_path: Path) -> None:
    from rlhc.building.builders import make_training_env

    cfg = load("env=soccer", "shaping.scale=1.0")
    env = make_training_env(cfg, 2, seed=0)
    td = env.rollout(20, break_when_any_done=False)
    # RewardSum sits before the shaping: the episode return is the time terms only.
    expected = torch.arange(1, 21, dtype=torch.float32) * -0.001
    torch.testing.assert_close(
        td["next", "striker", "episode_reward"][0, :, 0, 0], expected, atol=1e-6, rtol=0
    )
    # The reward the learner sees does carry the shaping on top of the time term.
    shaped = td["next", "striker", "reward"][0, :, 0, 0]
    assert not torch.allclose(shaped, torch.full_like(shaped, -0.001))


@pytest.mark.parametrize(
    ("overrides", "named"),
    [
        (("env=soccer", "shaping.scale=-1"), "shaping.scale=-1"),
        (("env=tennis", "shaping.scale=0.5"), "tennis"),
    ],
)
def test_bad_shaping_settings_fail_before_training(overrides: tuple[str, ...], named: str) -> None:
    with pytest.raises(ConfigError, match="allowed") as error:
        validate(load(*overrides))
    assert named in str(error.value)
