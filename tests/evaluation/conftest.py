"""Fixtures of the evaluation tests: an untrained checkpoint per game, made in seconds."""

from __future__ import annotations

from pathlib import Path

import pytest
from hydra import compose, initialize_config_dir
from omegaconf import OmegaConf

from rlhc.config.train_schema import TrainConfig, register_configs
from rlhc.envs import games

CONF = Path(__file__).resolve().parents[2] / "conf"
register_configs()


def smoke_config(env: str, *overrides: str) -> TrainConfig:
    with initialize_config_dir(config_dir=str(CONF), version_base="1.3"):
        cfg = compose(config_name="train", overrides=["experiment=smoke", f"env={env}", *overrides])
    return OmegaConf.to_object(cfg)  # type: ignore[return-value]


@pytest.fixture(scope="session")
def checkpoints(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """``env -> run directory`` of a one-update smoke run (tennis normalises observations)."""
    from rlhc.training.trainer import Trainer

    runs = {}
    for env in games():
        run_dir = tmp_path_factory.mktemp(f"{env}_run")
        Trainer(smoke_config(env, "algo.max_steps=256", "logger.backends=[csv]"), run_dir).train()
        runs[env] = run_dir
    return runs


@pytest.fixture(scope="session")
def manager_view_checkpoint(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Run directory of a one-update tennis run whose actor reads the manager observation."""
    from rlhc.training.trainer import Trainer

    run_dir = tmp_path_factory.mktemp("tennis_manager_view")
    overrides = ("algo.max_steps=256", "logger.backends=[csv]", "model.actor_view=manager")
    Trainer(smoke_config("tennis", *overrides), run_dir).train()
    return run_dir


@pytest.fixture(scope="session")
def clipped_checkpoint(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Run directory of a one-update tennis run whose normalised observations are clipped
    (tight enough to bind)."""
    from rlhc.training.trainer import Trainer

    run_dir = tmp_path_factory.mktemp("tennis_clipped")
    overrides = ("algo.max_steps=256", "logger.backends=[csv]", "algo.observation_clip=0.5")
    Trainer(smoke_config("tennis", *overrides), run_dir).train()
    return run_dir
