"""The GPU check, in one command on a machine with a CUDA device: the CUDA tests, then
training throughput with ``device=cuda`` against ``device=cpu`` in one invocation.

1. ``pytest tests/training/test_device.py``: the tests that train, resume and evaluate
   on the GPU (skipped, and so failing this check, where torch sees no CUDA device);
2. :mod:`benchmarks.train_throughput` on one process, the working tree as it is
   (``current``: ``device=cpu``) next to the variant ``cuda`` (``device=cuda``), rounds
   interleaved; the table is printed and the JSON written to ``--out``.

The games always step on CPU; ``device=cuda`` moves the networks, the loss and the update
(``docs/guide/performance.md``). ``make install`` installs the CPU wheel of torch: on a
GPU machine install a CUDA build first (``pip install torch==2.13.0 --index-url
https://download.pytorch.org/whl/cu128``).

Examples:
    python benchmarks/gpu_check.py
    python benchmarks/gpu_check.py --env soccer --repeats 3 --out /tmp/gpu.json
"""

from __future__ import annotations

import argparse
import subprocess
import sys
from collections.abc import Sequence
from pathlib import Path

import torch

ROOT = Path(__file__).resolve().parents[1]
PROGRAM = "benchmarks/gpu_check.py"


def commands(args: argparse.Namespace) -> list[list[str]]:
    """The two commands the check runs, in order."""
    return [
        [sys.executable, "-m", "pytest", "-q", "-rs", "tests/training/test_device.py"],
        [
            sys.executable, "benchmarks/train_throughput.py", "--env", *args.env,
            "--setups", "one", "--repeats", str(args.repeats),
            "--variant", "cuda=device=cuda", "--out", str(args.out),
        ],
    ]  # fmt: skip


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog=f"python {PROGRAM}", description=__doc__.split("\n")[0])
    parser.add_argument(
        "--env", nargs="+", default=["soccer", "tennis"], choices=["soccer", "tennis"]
    )
    parser.add_argument("--repeats", type=int, default=2, help="rounds (default: 2)")
    parser.add_argument(
        "--out", type=Path, default=ROOT / "benchmarks" / "results" / "gpu_check.json"
    )
    args = parser.parse_args(argv)
    if not torch.cuda.is_available():
        print(
            f"{PROGRAM}: error: torch {torch.__version__} sees no CUDA device; allowed: a "
            "machine with one and a CUDA build of torch (see this script's docstring)",
            file=sys.stderr,
        )
        return 2
    print(f"{torch.cuda.get_device_name()}, torch {torch.__version__}", flush=True)
    for command in commands(args):
        print("$", " ".join(command), flush=True)
        done = subprocess.run(command, cwd=ROOT, check=False)
        if done.returncode != 0:
            return done.returncode
    return 0


if __name__ == "__main__":
    sys.exit(main())
