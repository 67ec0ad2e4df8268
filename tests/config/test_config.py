"""Every config composes and validates; bad overrides fail before anything is built;
experiment presets keep the logger choice."""

from __future__ import annotations

import pytest
from configs import load, options
from hydra.errors import ConfigCompositionException
from omegaconf.errors import ConfigKeyError, ValidationError

from rlhc.config.train_schema import TrainConfig
from rlhc.envs.schemas import (
    PettingZooEnvConfig,
    SoccerEnvConfig,
    TennisEnvConfig,
    VmasEnvConfig,
)


@pytest.mark.parametrize("env", options("env"))
@pytest.mark.parametrize("critic", options("critic"))
def test_every_env_and_critic_composes(env: str, critic: str) -> None:
    required = {"pettingzoo": ["env.factory=mpe2.simple_spread_v3:parallel_env"],
                "vmas": ["env.scenario=navigation"]}  # fmt: skip
    cfg = load(f"env={env}", f"critic={critic}", *required.get(env, []))
    assert isinstance(cfg, TrainConfig)
    assert cfg.env.name == env
    schemas = {"tennis": TennisEnvConfig, "soccer": SoccerEnvConfig,
               "pettingzoo": PettingZooEnvConfig, "vmas": VmasEnvConfig}  # fmt: skip
    assert isinstance(cfg.env, schemas[env])


@pytest.mark.parametrize("group", ["model", "logger", "experiment"])
def test_every_option_of_other_groups_composes(group: str) -> None:
    for option in options(group):
        assert isinstance(load(f"{group}={option}"), TrainConfig)


def test_critic_names_map_to_fusions() -> None:
    expected = {
        "ppo": "local",
        "hierarchical": "max",
        "manager": "manager",
        "mean": "mean",
        "weighted": "weighted",
        "twin": "max",
        "hierarchical_k5": "max",
    }
    assert {c: load(f"critic={c}").critic.fusion for c in options("critic")} == expected
    # Only the twin control's second critic reads the worker's own observation.
    views = {c: load(f"critic={c}").critic.manager_view for c in options("critic")}
    assert [c for c, view in views.items() if not view] == ["twin"]


@pytest.mark.parametrize(
    ("env", "values"),
    [
        (
            "tennis",
            # Paper: 200 K steps and summaries every 1,000 steps of an 18-court scene;
            # beta 0.005 on ML-Agents' entropy averaged over 3 action dimensions.
            dict(batch_size=1024, buffer_size=10240, max_steps=3_600_000, lr=3e-4,
                 entropy_coef=0.0016667, time_horizon=64, normalize_observations=True,
                 hidden_size=128, summary_freq=18_000),
        ),
        (
            "soccer",
            dict(batch_size=128, buffer_size=2000, max_steps=500_000, lr=1e-3,
                 entropy_coef=0.01, time_horizon=128, normalize_observations=False,
                 hidden_size=256, summary_freq=2000),
        ),
    ],
)  # fmt: skip
def test_defaults_follow_table_3(env: str, values: dict[str, float]) -> None:
    cfg = load(f"env={env}")
    got = {
        "batch_size": cfg.algo.batch_size,
        "buffer_size": cfg.algo.buffer_size,
        "max_steps": cfg.algo.max_steps,
        "lr": cfg.algo.lr,
        "entropy_coef": cfg.algo.entropy_coef,
        "time_horizon": cfg.algo.time_horizon,
        "normalize_observations": cfg.algo.normalize_observations,
        "hidden_size": cfg.model.hidden_size,
        "summary_freq": cfg.logger.summary_freq,
    }
    assert got == values
    assert (cfg.algo.gamma, cfg.algo.lmbda, cfg.algo.clip_epsilon, cfg.algo.epochs) == (
        0.99, 0.95, 0.2, 3,
    )  # fmt: skip
    assert cfg.model.num_layers == 2
    # ML-Agents 0.5 parity: swish, and lr, beta and epsilon decayed over the budget.
    assert cfg.model.activation == "silu"
    assert cfg.algo.anneal_lr and cfg.algo.anneal_entropy_coef and cfg.algo.anneal_clip_epsilon


def test_overrides_reach_the_config() -> None:
    cfg = load(
        "env=tennis",
        "env.extended_obs=true",
        "critic=weighted",
        "critic.weight=0.25",
        "critic.manager_interval=5",
        "algo.lr=1e-4",
        "seed=3",
    )
    assert cfg.env.extended_obs is True
    assert (cfg.critic.fusion, cfg.critic.weight, cfg.critic.manager_interval) == (
        "weighted", 0.25, 5,
    )  # fmt: skip
    assert cfg.algo.lr == 1e-4
    assert cfg.seed == 3


def test_smoke_experiment_overrides_table_3() -> None:
    cfg = load("env=soccer", "experiment=smoke")
    assert cfg.algo.max_steps < 5000
    assert cfg.env.num_envs == 4


# --- experiment presets compose with the other groups: never override the logger choice
def test_smoke_keeps_wandb_among_the_backends() -> None:
    cfg = load("env=tennis", "experiment=smoke", "logger=wandb")
    assert "wandb" in cfg.logger.backends
    assert cfg.logger.summary_freq == 256  # the preset still shortens the logging period


@pytest.mark.parametrize("logger", options("logger"))
@pytest.mark.parametrize("experiment", options("experiment"))
def test_every_experiment_keeps_every_logger_choice(experiment: str, logger: str) -> None:
    chosen = load("env=tennis", f"logger={logger}")
    combined = load("env=tennis", f"experiment={experiment}", f"logger={logger}")
    assert combined.logger.backends == chosen.logger.backends
    assert (combined.logger.wandb_project, combined.logger.wandb_mode) == (
        chosen.logger.wandb_project,
        chosen.logger.wandb_mode,
    )


@pytest.mark.parametrize(
    "override",
    ["algo.lrr=0.1", "env.extendd_obs=true", "critic.fusoin=max"],
)
def test_misspelt_key_fails_fast(override: str) -> None:
    with pytest.raises((ConfigCompositionException, ConfigKeyError)) as info:
        load(override)
    assert override.split("=")[0].split(".")[-1] in str(info.value) + str(info.value.__cause__)


@pytest.mark.parametrize("override", ["algo.lr=fast", "seed=abc", "env.extended_obs=maybe"])
def test_wrong_type_fails_fast(override: str) -> None:
    with pytest.raises((ConfigCompositionException, ValidationError)) as info:
        load(override)
    message = str(info.value) + str(info.value.__cause__)
    assert override.split("=")[1] in message


def test_soccer_time_rewards_reach_the_game_options() -> None:
    cfg = load("env=soccer", "env.striker_time_reward=-0.01")
    assert cfg.env.game_options() == {"striker_time_reward": -0.01}


def test_soccer_has_no_extended_obs() -> None:
    with pytest.raises((ConfigCompositionException, ConfigKeyError)):
        load("env=soccer", "env.extended_obs=true")
