"""Composing the training config in tests, exactly as ``python -m rlhc.run`` does."""

from __future__ import annotations

from pathlib import Path

from hydra import compose, initialize_config_dir
from omegaconf import OmegaConf

from rlhc.config.train_schema import TrainConfig, register_configs

ROOT = Path(__file__).resolve().parents[1]
CONF = ROOT / "conf"
register_configs()


def load(*overrides: str) -> TrainConfig:
    """The validated-by-schema config of ``conf/train.yaml`` with ``overrides``."""
    with initialize_config_dir(config_dir=str(CONF), version_base="1.3"):
        cfg = compose(config_name="train", overrides=list(overrides))
    return OmegaConf.to_object(cfg)  # type: ignore[return-value]


def load_smoke(*overrides: str) -> TrainConfig:
    """:func:`load` on top of ``experiment=smoke`` (a run of a few seconds)."""
    return load("experiment=smoke", *overrides)


#: A run of a few seconds on the tiny PettingZoo env of ``tests/envs/tiny_envs.py`` (its
#: groups: ``blue``, 2 agents with 3 actions; ``red``, 1 agent in a 2-D box).
TINY_RUN = (
    "env=pettingzoo",
    "env.factory=tests.envs.tiny_envs:tiny",
    "algo.max_steps=96",
    "algo.buffer_size=96",
    "algo.batch_size=48",
    "algo.time_horizon=16",
    "algo.epochs=1",
    "model.num_layers=1",
    "model.hidden_size=16",
    "logger.backends=[csv]",
)


def train_tiny(run_dir: Path, *overrides: str) -> Path:
    """Train a :data:`TINY_RUN` with ``overrides`` into ``run_dir`` (its final team included)."""
    from rlhc.config.validation import validate
    from rlhc.training.trainer import Trainer

    cfg = load(*TINY_RUN, *overrides)
    validate(cfg)
    Trainer(cfg, run_dir).train()
    return run_dir


def options(group: str) -> list[str]:
    """The choices of a config group (its yaml files)."""
    return sorted(p.stem for p in (CONF / group).glob("*.yaml"))
