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


def options(group: str) -> list[str]:
    """The choices of a config group (its yaml files)."""
    return sorted(p.stem for p in (CONF / group).glob("*.yaml"))
