"""``compile=true``: the compiled minibatch loss is the eager one, to float rounding."""

from __future__ import annotations

import logging
from collections.abc import Iterator
from pathlib import Path

import pytest
import torch
import torch._dynamo
import torch._inductor.config
from configs import load_smoke
from tensordict import TensorDictBase
from torch._dynamo.utils import counters

from rlhc.config.validation import validate
from rlhc.errors import ConfigError
from rlhc.training import compilation
from rlhc.training.compilation import compile_problem, compiled
from rlhc.training.trainer import Trainer

PROBLEM = compile_problem()
pytestmark = pytest.mark.skipif(PROBLEM is not None, reason=f"torch cannot compile here: {PROBLEM}")


@pytest.fixture(autouse=True)
def fresh_dynamo() -> Iterator[None]:
    torch._dynamo.reset()
    yield
    torch._dynamo.reset()


def estimated_minibatch(trainer: Trainer) -> TensorDictBase:
    """A minibatch of a collected batch, with its advantages, as the update takes it."""
    batch = trainer.collect_batch()
    with torch.no_grad():
        for loss in trainer.losses.values():
            loss.value_estimator(batch)
    flat = batch.exclude("next").reshape(-1)
    return flat[: trainer.layout.minibatch_frames]


def gradients(
    trainer: Trainer, minibatch: TensorDictBase, *, compiled: bool
) -> dict[str, torch.Tensor]:
    """The loss's diagnostics and every parameter's gradient after one backward:
    through the trainer's step (compiled under ``compile=true``) or its eager loss."""
    torch.manual_seed(0)  # the same draws where an entropy is estimated by sampling
    if compiled:
        diagnostics = trainer.backward(minibatch.clone())
    else:
        trainer.optimizer.zero_grad(set_to_none=True)
        total, diagnostics = trainer.minibatch_loss(minibatch.clone())
        total.backward()
    named = {
        f"grad/{i}": p.grad.clone() for i, p in enumerate(trainer.parameters) if p.grad is not None
    }
    return {**diagnostics, **named}


@pytest.mark.parametrize(
    "overrides",
    [
        ("env=tennis", "league=mixed", "algo.normalize_advantage=true"),
        ("env=soccer", "critic=ppo", "algo.normalize_advantage=false"),
    ],
)
def test_the_compiled_loss_and_gradients_are_the_eager_ones(
    overrides: tuple[str, ...], tmp_path: Path
) -> None:
    trainer = Trainer(load_smoke(*overrides, "compile=true"), tmp_path)
    minibatch = estimated_minibatch(trainer)
    eager = gradients(trainer, minibatch, compiled=False)
    # Inductor draws its own random numbers unless told to fall back to torch's.
    with torch._inductor.config.patch(fallback_random=True):
        fast = gradients(trainer, minibatch, compiled=True)
    assert eager.keys() == fast.keys()
    assert any(name.endswith("loss_objective") for name in fast)
    for name, value in eager.items():
        torch.testing.assert_close(fast[name], value, rtol=1e-4, atol=1e-6, msg=name)


def test_a_compiled_run_compiles_once(tmp_path: Path) -> None:
    """The schedules change the loss's buffers and the optimiser's rate every update,
    and a league world mixes learners: none of it recompiles the loss."""
    cfg = load_smoke("env=tennis", "league=mixed", "compile=true")
    trainer = Trainer(cfg, tmp_path)
    before = counters["stats"]["unique_graphs"]
    trainer.train()
    assert trainer.iteration >= 2
    assert counters["stats"]["unique_graphs"] - before == 1
    assert sum(counters["graph_break"].values()) == 0


def test_torch_that_cannot_compile_trains_eagerly_with_a_warning(
    monkeypatch: pytest.MonkeyPatch, caplog: pytest.LogCaptureFixture
) -> None:
    def refuse(*args: object, **kwargs: object) -> None:
        raise RuntimeError("no C++ compiler found\nsecond line")

    monkeypatch.setattr(compilation.torch, "compile", refuse)

    def loss() -> int:
        return 1

    with caplog.at_level(logging.WARNING, logger=compilation.__name__):
        assert compiled(loss) is loss
    (record,) = caplog.records
    assert "RuntimeError: no C++ compiler found" in record.getMessage()
    assert "second line" not in record.getMessage()


def test_compile_refuses_data_parallel() -> None:
    cfg = load_smoke("compile=true", "parallel=data")
    with pytest.raises(ConfigError, match=r"compile=true with parallel=data on 2 processes"):
        validate(cfg, processes=2)
    validate(load_smoke("compile=true", "parallel=pipeline"), processes=2)
    validate(cfg, processes=1)
