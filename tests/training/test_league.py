"""The league of opponents: shares, masking, Elo, checkpoints, bad settings."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import torch
from configs import load_smoke as load
from hydra.errors import ConfigCompositionException
from torchrl.collectors import Collector

from rlhc.config.train_schema import LeagueConfig
from rlhc.config.validation import validate
from rlhc.envs import games
from rlhc.errors import ConfigError
from rlhc.evaluation.elo import expected_score
from rlhc.storage.checkpoint import load_checkpoint
from rlhc.training.league import (
    KINDS,
    LEARNER,
    LEARNER_TEAM,
    OPPONENT,
    SCRIPTED_ID,
    SELF_ID,
    League,
    allocate_worlds,
)
from rlhc.training.trainer import Trainer


# --- shares ---------------------------------------------------------------------------
@pytest.mark.parametrize("num_worlds", [1, 3, 7, 16, 100])
@pytest.mark.parametrize(
    "shares",
    [
        {"self": 1.0},
        {"self": 0.5, "snapshot": 0.3, "scripted": 0.1, "random": 0.1},
        {"self": 0.0, "snapshot": 1 / 3, "scripted": 1 / 3, "random": 1 / 3},
    ],
)
def test_worlds_follow_the_shares(num_worlds: int, shares: dict[str, float]) -> None:
    kinds = allocate_worlds(shares, num_worlds)
    assert len(kinds) == num_worlds
    for index, kind in enumerate(KINDS):
        count = int((kinds == index).sum())
        assert abs(count - shares.get(kind, 0.0) * num_worlds) < 1.0, (kind, count)


def test_league_worlds_alternate_the_learners_side() -> None:
    league = League(LeagueConfig(self_play=0.5, scripted=0.5), num_worlds=8, seed=0)
    assert (league.learner_team[:4] == -1).all()  # self-play worlds: both sides learn
    assert sorted(league.learner_team[4:].tolist()) == [0, 0, 1, 1]
    assert (league.opponent[4:] == SCRIPTED_ID).all()


def test_elo_sampling_prefers_the_stronger_snapshots() -> None:
    league = League(LeagueConfig(self_play=0.0, snapshot=1.0, sampling="elo"), 2000, seed=0)
    actor = torch.nn.Linear(1, 1)
    league.add_snapshot({"g": actor})
    league.add_snapshot({"g": actor})
    league.pool[0].rating, league.pool[1].rating = 1000.0, 1400.0
    league.draw(np.arange(2000))
    share_strong = float((league.opponent == league.pool[1].id).mean())
    weak, strong = expected_score(1000.0, 1200.0), expected_score(1400.0, 1200.0)
    assert share_strong == pytest.approx(strong / (weak + strong), abs=0.03)


def test_results_move_the_ratings() -> None:
    league = League(LeagueConfig(self_play=0.0, scripted=1.0), 2, seed=0)
    league.record(np.array([SCRIPTED_ID, SCRIPTED_ID, SELF_ID]), np.array([1.0, 1.0, 0.0]))
    assert league.rating > 1200.0 > league.built_in_ratings[SCRIPTED_ID]
    metrics = league.metrics()
    assert metrics["league/score_vs_scripted"] == 1.0
    assert metrics["league/episodes_vs_scripted"] == 2.0  # self-play results are ignored


# --- only the learner's experiences train ---------------------------------------------
@pytest.mark.parametrize("env", games())
def test_opponent_experiences_carry_no_gradient(env: str, tmp_path: Path) -> None:
    cfg = load(f"env={env}", "league.self_play=0.5", "league.scripted=0.5")
    trainer = Trainer(cfg, tmp_path)
    collector = Collector(
        trainer.env,
        trainer.collection_policy,
        frames_per_batch=trainer.layout.frames_per_batch,
        total_frames=trainer.layout.frames_per_batch,
        auto_register_policy_transforms=False,
    )
    batch = next(iter(collector))
    collector.shutdown()
    with torch.no_grad():
        for loss in trainer.losses.values():
            loss.value_estimator(batch)
    flat = batch.reshape(-1)

    # The mask: opponents' agents are exactly the other team in league worlds.
    for group in trainer.groups:
        learner = flat[group, LEARNER].squeeze(-1)
        team = flat[group, "team"].squeeze(-1)
        opponent = flat[OPPONENT]
        learner_team = flat[LEARNER_TEAM]
        expected = (opponent == SELF_ID) | (team == learner_team)
        assert torch.equal(learner, expected)
        assert (~learner).any() and learner.any()

    diagnostics: list[dict[str, float]] = []

    def gradients(data: object) -> list[torch.Tensor]:
        # TanhNormal's entropy is a Monte Carlo estimate: the same draws each time.
        torch.manual_seed(0)
        trainer.optimizer.zero_grad(set_to_none=True)
        total, stats = trainer.minibatch_loss(data.clone())  # type: ignore[attr-defined]
        total.backward()
        diagnostics.append({name: value.item() for name, value in stats.items()})
        return [p.grad.clone() for p in trainer.parameters if p.grad is not None]

    before = gradients(flat)
    # Scramble everything recorded for the opponents' agents: nothing may change.
    scrambled = flat.clone()
    for group in trainer.groups:
        mask = ~scrambled[group, LEARNER].squeeze(-1)
        for key in ("action_log_prob", "advantage", "value_target", "observation"):
            value = scrambled[group, key]
            noise = torch.randn_like(value.float()).to(value.dtype) * 10
            scrambled[group, key] = torch.where(
                mask.view(*mask.shape, *([1] * (value.dim() - mask.dim()))), noise, value
            )
    after = gradients(scrambled)
    assert len(before) == len(after) > 0
    for grad_before, grad_after in zip(before, after, strict=True):
        torch.testing.assert_close(grad_before, grad_after)
    # ... nor the logged diagnostics: losses, KL, clip fraction, entropy, explained variances.
    for group in trainer.groups:
        for key in (
            "loss_objective",
            "kl_approx",
            "clip_fraction",
            "entropy",
            "explained_variance_worker",
        ):
            assert f"{group}/{key}" in diagnostics[0]
    assert diagnostics[1] == pytest.approx(diagnostics[0], rel=1e-5, abs=1e-6)
    # Scrambling the learner's own experiences does change the gradient.
    scrambled = flat.clone()
    for group in trainer.groups:
        scrambled[group, "advantage"] = torch.randn_like(scrambled[group, "advantage"])
    assert any(not torch.allclose(a, b) for a, b in zip(before, gradients(scrambled), strict=True))


def test_snapshot_actors_are_frozen_and_outside_the_optimiser(tmp_path: Path) -> None:
    cfg = load("env=soccer", "league=mixed", "league.snapshot_interval=1", "algo.max_steps=512")
    trainer = Trainer(cfg, tmp_path)
    trainer.train()
    frozen = list(trainer.collection_policy.frozen.values())  # type: ignore[attr-defined]
    trained = {id(p) for p in trainer.parameters}
    for actor in frozen:
        for parameter in actor.parameters():
            assert not parameter.requires_grad
            assert id(parameter) not in trained
    assert trainer.league is not None and len(trainer.league.pool) >= 1


def test_the_pool_and_ratings_survive_a_resume(tmp_path: Path) -> None:
    first = load("env=soccer", "league=mixed", "league.snapshot_interval=1", "algo.max_steps=512")
    trainer = Trainer(first, tmp_path)
    trainer.train()
    league = trainer.league
    assert league is not None
    saved = load_checkpoint(tmp_path)["league"]
    assert [entry[0] for entry in saved["pool"]] == [s.id for s in league.pool]

    resumed = Trainer(
        load("env=soccer", "league=mixed", "league.snapshot_interval=1", f"resume={tmp_path}"),
        tmp_path / "resumed",
    )
    restored = resumed.league
    assert restored is not None
    assert [s.id for s in restored.pool] == [s.id for s in league.pool]
    assert [s.rating for s in restored.pool] == [s.rating for s in league.pool]
    assert restored.rating == league.rating
    assert restored.built_in_ratings == league.built_in_ratings
    assert restored.next_id == league.next_id
    for ours, theirs in zip(restored.pool, league.pool, strict=True):
        for group, weights in theirs.actors.items():
            for name, tensor in weights.items():
                torch.testing.assert_close(ours.actors[group][name], tensor)


# --- bad settings ---------------------------------------------------------------------
@pytest.mark.parametrize(
    ("overrides", "named"),
    [
        (("league.self_play=0.5",), "sum to 0.5"),
        (("league=mixed", "league.pool_size=0"), "league.pool_size=0"),
        (("league=mixed", "league.snapshot_interval=0"), "league.snapshot_interval=0"),
        (("league=mixed", "league.sampling=best"), "league.sampling='best'"),
        (("league.self_play=1.5", "league.random=-0.5"), "league.self_play=1.5"),
    ],
)
def test_bad_league_settings_fail_before_training(overrides: tuple[str, ...], named: str) -> None:
    with pytest.raises(ConfigError, match="allowed") as error:
        validate(load(*overrides))
    assert named in str(error.value)


def test_an_unknown_opponent_kind_is_refused() -> None:
    with pytest.raises(ValueError, match="unknown opponent kind"):
        allocate_worlds({"self": 0.5, "champion": 0.5}, 4)
    with pytest.raises(ConfigCompositionException):
        load("league.champion=0.5")
