"""Fixtures of the learning-core tests: specs, network sizes, fresh networks."""

from __future__ import annotations

from collections.abc import Callable

import pytest
import torch
from rlhc_synthetic import GROUP, make_specs

from rlhc.modules import (
    EnvSpecs,
    NetworkConfig,
    make_actor,
    make_manager_critic,
    make_worker_critic,
)


@pytest.fixture
def specs() -> EnvSpecs:
    return make_specs()


@pytest.fixture
def net_cfg() -> NetworkConfig:
    return NetworkConfig(num_layers=2, hidden_size=16)


@pytest.fixture
def networks(specs: EnvSpecs, net_cfg: NetworkConfig) -> Callable[[], tuple]:
    """A fresh (actor, worker critic, manager critic) of the tennis-like group."""

    def build() -> tuple:
        torch.manual_seed(0)
        return (
            make_actor(specs, GROUP, net_cfg),
            make_worker_critic(specs, GROUP, net_cfg),
            make_manager_critic(specs, GROUP, net_cfg),
        )

    return build
