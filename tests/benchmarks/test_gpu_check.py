"""``benchmarks/gpu_check.py``: refused in one line without a CUDA device; what it runs."""

from __future__ import annotations

import pytest
import torch

from benchmarks import gpu_check


def test_without_a_cuda_device_it_exits_2_in_one_line(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.setattr(torch.cuda, "is_available", lambda: False)
    assert gpu_check.main([]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "sees no CUDA device" in err


def test_it_runs_the_cuda_tests_then_cuda_against_cpu_throughput() -> None:
    args = gpu_check.argparse.Namespace(env=["tennis"], repeats=3, out="x.json")
    tests, throughput = gpu_check.commands(args)
    assert tests[-1] == "tests/training/test_device.py"
    assert throughput[1:] == [
        "benchmarks/train_throughput.py", "--env", "tennis", "--setups", "one",
        "--repeats", "3", "--variant", "cuda=device=cuda", "--out", "x.json",
    ]  # fmt: skip
