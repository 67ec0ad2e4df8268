"""Experiment presets compose with the other groups: they never override the logger choice."""

from __future__ import annotations

import pytest
from configs import load, options


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
