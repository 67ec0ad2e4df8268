"""``benchmarks/tennis_misses.py``: where the rackets were when a point was lost."""

from __future__ import annotations

import math

import torch

from benchmarks.tennis_misses import misses
from rlhc.envs import make_env
from rlhc.evaluation.opponents import make_team_policy


def rollout_of(team: str, decisions: int = 300):
    torch.manual_seed(0)
    env = make_env("tennis", num_envs=8, seed=0)
    policy = make_team_policy(team, env)

    def act(td):
        td.set(("racket", "action"), policy(td)["racket"])
        return td

    try:
        return env.rollout(decisions, policy=act, break_when_any_done=False)
    finally:
        env.close()


def test_a_random_team_misses_serves_and_stands_wherever() -> None:
    result = misses(rollout_of("random"))
    assert result["points"] > 20
    # Random rackets rarely touch the toss: most points end on it.
    assert result["serve_missed_share"] > 0.5
    assert 0.0 <= result["serve_missed_share"] + result["missed_share"] <= 1.0
    assert result["serve_closest_back"] >= 0.0 and result["serve_closest_front"] >= 0.0
    assert -1.0 <= result["serve_first_moves"] <= 1.0


def test_the_scripted_team_serves() -> None:
    result = misses(rollout_of("scripted"))
    assert result["serve_missed_share"] < 0.05
    # Two scripted teams rally: few points end in a ball not returned, and where one
    # does, the rackets' places are read in the team frame (the own half: x < 0).
    if result["missed_share"] > 0:
        assert all(x <= 0.0 for x in result["missed_rackets_x"])
    else:
        assert math.isnan(result["missed_nearer"])
