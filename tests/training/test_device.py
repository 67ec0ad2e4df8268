"""``device``: the networks, losses and the update on a device, the games on CPU.

What a CPU-only machine can check runs everywhere: the setting's validation, the
networks and loss buffers built on the asked device (``meta`` stands in for an
accelerator: it allocates nothing), the collection policy sharing the loss's
parameters, checkpoints read back on CPU. The tests marked ``cuda`` train, resume and
evaluate on a GPU; they are skipped where torch sees none.
"""

from __future__ import annotations

from pathlib import Path

import pytest
import torch
from configs import load, load_smoke

from rlhc.building.builders import make_agents, make_training_env
from rlhc.config.validation import check_device, validate
from rlhc.errors import ConfigError

CUDA = pytest.mark.skipif(not torch.cuda.is_available(), reason="torch sees no CUDA device")


@pytest.mark.parametrize(
    ("device", "message"),
    [
        ("gpu", "device='gpu'; allowed: cpu, cuda or cuda:<index>"),
        ("cuda:x", "device='cuda:x'; allowed: cpu, cuda or cuda:<index>"),
        ("mps", "device='mps'; allowed: cpu, cuda or cuda:<index>"),
        ("meta", "device='meta'; allowed: cpu, cuda or cuda:<index>"),
    ],
)
def test_a_device_that_is_not_one_names_the_value_and_what_is_allowed(
    device: str, message: str
) -> None:
    with pytest.raises(ConfigError) as raised:
        validate(load("env=tennis", f"device={device}"))
    assert str(raised.value) == message


def test_cuda_without_a_cuda_device_is_refused(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(torch.cuda, "is_available", lambda: False)
    with pytest.raises(ConfigError, match=r"device='cuda', but torch sees no CUDA device"):
        check_device("cuda")


def test_a_cuda_index_beyond_the_devices_and_several_processes_are_refused(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    # A machine with one GPU, as torch would report it.
    monkeypatch.setattr(torch.cuda, "is_available", lambda: True)
    monkeypatch.setattr(torch.cuda, "device_count", lambda: 1)
    check_device("cuda")
    check_device("cuda:0")
    with pytest.raises(ConfigError, match=r"device='cuda:1'; allowed: .* cuda:0 to cuda:0"):
        check_device("cuda:1")
    with pytest.raises(ConfigError, match=r"device='cuda' with 2 processes"):
        check_device("cuda", processes=2)


@pytest.mark.parametrize(
    "overrides",
    [("env=tennis",), ("env=soccer",)],
    ids=["tennis", "soccer"],
)
def test_networks_and_losses_are_built_on_the_device_and_the_games_stay_on_cpu(
    overrides: tuple[str, ...],
) -> None:
    cfg = load(*overrides, "device=meta")
    env = make_training_env(cfg, num_envs=2, seed=0)
    actors, losses = make_agents(cfg, env)
    assert env.device == torch.device("cpu")
    for group, loss in losses.items():
        tensors = [*loss.parameters(), *loss.buffers(), *actors[group].parameters()]
        assert {t.device.type for t in tensors} == {"meta"}, group
        # Moved before the loss was built: the collection policy plays with the very
        # parameters the optimiser steps (a loss moved afterwards would hold copies).
        held = {id(p) for p in loss.parameters()}
        assert all(id(p) in held for p in actors[group].parameters()), group


@pytest.mark.parametrize("game", ["tennis", "soccer"])
def test_the_collection_policy_holds_the_losses_parameters(game: str) -> None:
    # Built on the device before the loss: an optimiser step on the loss's parameters
    # is what the collector's policy plays with next.
    cfg = load(f"env={game}")
    actors, losses = make_agents(cfg, make_training_env(cfg, num_envs=1, seed=0))
    for group, loss in losses.items():
        held = {p.data_ptr() for p in loss.parameters()}
        assert all(p.data_ptr() in held for p in actors[group].parameters()), group


@CUDA
@pytest.mark.parametrize("game", ["tennis", "soccer"])
def test_a_run_on_cuda_trains_then_resumes_on_cpu(game: str, tmp_path: Path) -> None:
    from rlhc.storage.final_team import load_team
    from rlhc.training.trainer import Trainer

    cfg = load_smoke(f"env={game}", "device=cuda", "league=mixed", "eval_freq=128")
    trainer = Trainer(cfg, tmp_path / "cuda")
    assert {p.device.type for p in trainer.parameters} == {"cuda"}
    assert "eval/win_rate" in trainer.train()
    # The same run continued on CPU from the GPU's checkpoint: the same weights.
    more = load_smoke(
        f"env={game}",
        "device=cpu",
        "league=mixed",
        f"algo.max_steps={2 * cfg.algo.max_steps}",
        f"resume={tmp_path / 'cuda'}",
    )
    resumed = Trainer(more, tmp_path / "cpu")
    assert resumed.frames == trainer.frames
    for on_cpu, on_cuda in zip(resumed.parameters, trainer.parameters, strict=True):
        torch.testing.assert_close(on_cpu, on_cuda.cpu(), rtol=0, atol=0)
    resumed.train()
    assert load_team(tmp_path / "cpu")["frames"] == 2 * cfg.algo.max_steps
