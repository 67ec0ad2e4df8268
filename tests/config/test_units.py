"""Table 3 in the units of ML-Agents 0.5: an update's size, the budget, the schedules.

Buffer and minibatch count agent-experiences per group; the budget counts
world-decisions; the number of worlds simulated at once changes none of them.
"""

from __future__ import annotations

import math
from pathlib import Path

import pytest
import torch
from configs import load
from tensordict import TensorDict
from tensordict.nn import TensorDictModule

from rlhc.building.builders import Layout
from rlhc.config.train_schema import LR_ADAPTATION_FACTOR, PPOConfig, adapted_lr, schedules
from rlhc.config.validation import validate
from rlhc.errors import ConfigError
from rlhc.objectives import HierarchicalValueEstimator, cut_trajectories
from rlhc.training.trainer import Trainer


# --- the layout of an update ---------------------------------------------------------
def test_paper_presets_in_agent_experiences() -> None:
    tennis = Layout.from_config(load("env=tennis"))
    # 10,240 racket-experiences / 4 rackets per court = 2,560 court-decisions.
    assert (tennis.frames_per_batch, tennis.experiences_per_batch) == (2560, 10240)
    assert (tennis.num_envs, tennis.steps_per_world) == (40, 64)
    assert (tennis.minibatch_frames, tennis.minibatches) == (256, 10)
    soccer = Layout.from_config(load("env=soccer"))
    # 2,000 experiences per group / 2 agents (striker or goalie) per pitch.
    assert (soccer.frames_per_batch, soccer.experiences_per_batch) == (1000, 2000)
    assert soccer.steps_per_world <= 128
    # 128 experiences = 64 pitch-decisions; 15 whole minibatches, remainder left out.
    assert (soccer.minibatch_frames, soccer.minibatches) == (64, 15)


@pytest.mark.parametrize("num_envs", [1, 8, 40, 64, 160, 2560])
def test_the_number_of_worlds_changes_neither_the_update_nor_the_minibatch(num_envs: int) -> None:
    layout = Layout.build(
        buffer_size=10240, batch_size=1024, time_horizon=64, agents_per_world=4, num_envs=num_envs
    )
    assert layout.frames_per_batch == 2560
    assert layout.num_envs * layout.steps_per_world == 2560
    assert (layout.minibatch_frames, layout.minibatches) == (256, 10)


def test_a_buffer_that_is_not_a_whole_number_of_world_decisions_rounds_up() -> None:
    layout = Layout.build(
        buffer_size=2001, batch_size=128, time_horizon=128, agents_per_world=2, num_envs=None
    )
    assert layout.frames_per_batch == math.ceil(2001 / 2)
    assert layout.experiences_per_batch >= 2001


@pytest.mark.parametrize("num_envs", [1, 2, 4, 8])
def test_one_update_takes_exactly_the_documented_world_decisions(
    num_envs: int, tmp_path: Path
) -> None:
    # 256 racket-experiences / 4 rackets = 64 court-decisions, whatever the courts.
    cfg = load(
        "env=tennis",
        "experiment=smoke",
        f"env.num_envs={num_envs}",
        "algo.buffer_size=256",
        "algo.batch_size=64",
        "algo.max_steps=64",
        "logger.summary_freq=64",
    )
    trainer = Trainer(cfg, tmp_path)
    metrics = trainer.train()
    assert (trainer.frames, trainer.iteration) == (64, 1)
    assert metrics["frames"] == 64
    assert metrics["racket/experiences"] == 256
    assert metrics["updates"] == 1


@pytest.mark.parametrize(
    ("overrides", "key"),
    [
        (("algo.buffer_size=512", "algo.batch_size=1024"), "algo.buffer_size=512"),
        (("algo.batch_size=1022",), "algo.batch_size=1022"),
        (("env.num_envs=48",), "env.num_envs=48"),
        (("env.decision_interval=0",), "env.decision_interval=0"),
        (("env.fault_penalty=everyone",), "env.fault_penalty='everyone'"),
        (("model.initial_action_scale=0",), "model.initial_action_scale=0"),
        (("algo.lr=inf",), "algo.lr=inf"),
        (("algo.entropy_coef=nan",), "algo.entropy_coef=nan"),
        (("algo.clip_epsilon=-1",), "algo.clip_epsilon=-1"),
        (("algo.max_importance_ratio=1.1",), "algo.max_importance_ratio=1.1"),
        (("model.actor_view=critic",), "model.actor_view='critic'"),
        (("algo.anneal_lr=false", "algo.target_kl=0"), "algo.target_kl=0"),
        (("algo.target_kl=0.01",), "algo.anneal_lr=true"),  # two schedules at once
        (("algo.anneal_lr=false", "algo.target_kl=0.01", "algo.min_lr=1"), "algo.min_lr=1"),
        (("algo.observation_decay=1.5",), "algo.observation_decay=1.5"),
        (("algo.observation_clip=-5",), "algo.observation_clip=-5"),
    ],
)
def test_bad_settings_fail_before_training_naming_the_key(
    overrides: tuple[str, ...], key: str, tmp_path: Path
) -> None:
    with pytest.raises(ConfigError, match="allowed") as error:
        # Network settings fail when the config is composed (their schema checks
        # them), the others in validate or the layout.
        cfg = load("env=tennis", *overrides)
        validate(cfg)
        Layout.from_config(cfg)
    assert key in str(error.value)


# --- trajectories cut at the time horizon --------------------------------------------
def test_a_cut_bootstraps_like_two_separate_segments() -> None:
    """GAE over [N, 2H] with a cut at H equals GAE over the two halves on their own."""
    torch.manual_seed(0)
    horizon, n, agents = 4, 3, 2
    value_net = torch.nn.Linear(1, 1)
    estimator = HierarchicalValueEstimator(
        worker_value_network=TensorDictModule(
            value_net, in_keys=[("g", "observation")], out_keys=[("g", "worker_value")]
        ),
        manager_value_network=TensorDictModule(
            value_net, in_keys=[("g", "manager_observation")], out_keys=[("g", "manager_value")]
        ),
        gamma=0.9,
        lmbda=0.8,
        fusion="local",
        group="g",
    )

    def batch(steps: int, observation: torch.Tensor, reward: torch.Tensor) -> TensorDict:
        false = torch.zeros(n, steps, agents, 1, dtype=torch.bool)
        return TensorDict(
            {
                "g": {
                    "observation": observation[:, :steps],
                    "manager_observation": observation[:, :steps],
                },
                "next": {
                    "g": {
                        "observation": observation[:, 1 : steps + 1],
                        "manager_observation": observation[:, 1 : steps + 1],
                        "reward": reward[:, :steps],
                        "done": false.clone(),
                        "terminated": false.clone(),
                    }
                },
            },
            batch_size=[n, steps],
        )

    observation = torch.randn(n, 2 * horizon + 1, agents, 1)
    reward = torch.randn(n, 2 * horizon, agents, 1)
    whole = batch(2 * horizon, observation, reward)
    cut_trajectories(whole, ["g"], horizon)
    with torch.no_grad():
        estimator(whole)
        first = estimator(batch(horizon, observation, reward))
        second = estimator(batch(horizon, observation[:, horizon:], reward[:, horizon:]))
    expected = torch.cat([first["g", "advantage"], second["g", "advantage"]], dim=1)
    torch.testing.assert_close(whole["g", "advantage"], expected)
    # Without the cut the first half would see the second's rewards: it differs.
    uncut = batch(2 * horizon, observation, reward)
    with torch.no_grad():
        estimator(uncut)
    assert not torch.allclose(uncut["g", "advantage"][:, :horizon], expected[:, :horizon])


def test_a_batch_within_the_horizon_is_not_cut() -> None:
    done = torch.zeros(2, 8, 1, 1, dtype=torch.bool)
    batch = TensorDict({"next": {"g": {"done": done}}}, batch_size=[2, 8])
    cut_trajectories(batch, ["g"], 8)
    assert not batch["next", "g", "done"].any()
    cut_trajectories(batch, ["g"], 3)
    assert batch["next", "g", "done"][0, :, 0, 0].tolist() == [
        False, False, True, False, False, True, False, False,
    ]  # fmt: skip


# --- schedules -----------------------------------------------------------------------
def test_lr_beta_and_epsilon_decay_linearly_over_the_budget() -> None:
    algo = PPOConfig(max_steps=1000, lr=3e-4, entropy_coef=0.005, clip_epsilon=0.2)
    assert schedules(algo, 0) == (3e-4, 0.005, 0.2)
    lr, beta, epsilon = schedules(algo, 1000)
    # ML-Agents 0.5's floors are the defaults: lr 0, beta 1e-5, epsilon 0.1.
    assert (lr, beta, epsilon) == pytest.approx((0.0, 1e-5, 0.1))
    lr, beta, epsilon = schedules(algo, 250)
    assert lr == pytest.approx(3e-4 * 0.75)
    assert beta == pytest.approx(0.005 + (1e-5 - 0.005) * 0.25)
    assert epsilon == pytest.approx(0.2 - 0.1 * 0.25)
    fixed = PPOConfig(
        max_steps=1000, anneal_lr=False, anneal_entropy_coef=False, anneal_clip_epsilon=False
    )
    assert schedules(fixed, 999) == (fixed.lr, fixed.entropy_coef, fixed.clip_epsilon)


def test_schedules_decay_to_their_floors() -> None:
    algo = PPOConfig(
        max_steps=1000,
        lr=3e-4,
        entropy_coef=0.02,
        clip_epsilon=0.2,
        final_lr=1e-4,
        final_entropy_coef=0.01,
        final_clip_epsilon=0.15,
    )
    assert schedules(algo, 1000) == pytest.approx((1e-4, 0.01, 0.15))
    assert schedules(algo, 5000) == pytest.approx((1e-4, 0.01, 0.15))  # past the budget
    assert schedules(algo, 500) == pytest.approx((2e-4, 0.015, 0.175))


def test_the_trainer_applies_the_schedules_to_the_losses(tmp_path: Path) -> None:
    cfg = load("env=tennis", "experiment=smoke", "algo.max_steps=512")
    trainer = Trainer(cfg, tmp_path)
    metrics = trainer.train()
    # Logged after the last update, which started at 448 of 512 frames.
    lr, beta, epsilon = schedules(cfg.algo, 448)
    assert metrics["lr"] == pytest.approx(lr)
    assert metrics["entropy_coef"] == pytest.approx(beta)
    assert metrics["clip_epsilon"] == pytest.approx(epsilon)
    loss = trainer.losses["racket"]
    assert float(loss.entropy_coeff) == pytest.approx(beta)
    assert float(loss.clip_epsilon) == pytest.approx(epsilon)


def test_the_adapted_lr_moves_by_the_factor_outside_the_band_and_stays_in_bounds() -> None:
    algo = PPOConfig(lr=1e-3, target_kl=0.02, min_lr=1e-5, anneal_lr=False)
    factor = LR_ADAPTATION_FACTOR
    assert adapted_lr(1e-4, 0.041, algo) == pytest.approx(1e-4 / factor)
    assert adapted_lr(1e-4, 0.009, algo) == pytest.approx(1e-4 * factor)
    for inside in (0.01, 0.02, 0.04, math.nan):  # the band's edges included; NaN: kept
        assert adapted_lr(1e-4, inside, algo) == 1e-4
    assert adapted_lr(1e-3, 0.0, algo) == 1e-3  # never above algo.lr
    assert adapted_lr(1.2e-5, 1.0, algo) == 1e-5  # never below algo.min_lr
    with pytest.raises(ValueError, match="target_kl"):
        adapted_lr(1e-3, 0.1, PPOConfig(lr=1e-3))


def test_each_update_adapts_the_lr_to_its_kl_and_a_resume_keeps_it(tmp_path: Path) -> None:
    overrides = ("env=tennis", "experiment=smoke", "algo.anneal_lr=false", "algo.lr=1e-2")
    # A target inside the spread of a smoke update's KL, so that the rate moves both ways.
    adaptive = ("algo.target_kl=0.004", "algo.min_lr=1e-5")
    cfg = load(*overrides, *adaptive, "algo.max_steps=256", "checkpoint_freq=256")
    trainer = Trainer(cfg, tmp_path)
    batch = trainer.collect_batch()
    lr = 1e-2
    for _ in range(6):
        kl = trainer.update(batch.clone())["racket/kl_approx"]
        lr = adapted_lr(lr, kl, cfg.algo)
        assert trainer.optimizer.param_groups[0]["lr"] == pytest.approx(lr, rel=1e-5)
    assert lr < 1e-2  # the policy moved beyond the target at least once
    trainer.train()
    trained_lr = trainer.optimizer.param_groups[0]["lr"]
    resumed = Trainer(
        load(*overrides, *adaptive, "algo.max_steps=512", f"resume={tmp_path}"), tmp_path
    )
    assert resumed.optimizer.param_groups[0]["lr"] == trained_lr  # in Adam's state


@pytest.mark.parametrize(
    ("override", "named"),
    [
        ("eval_freq=-5", "eval_freq=-5"),
        ("threads=-1", "threads=-1"),
        ("play_freq=-1", "play_freq=-1"),
        ("play_freq=100 play_worlds=0", "play_worlds=0"),
    ],
)
def test_negative_periods_and_thread_counts_are_refused(override: str, named: str) -> None:
    with pytest.raises(ConfigError, match="allowed") as error:
        validate(load("env=tennis", *override.split()))
    assert named in str(error.value)
