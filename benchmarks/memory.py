"""Memory: resident set size of a full training run, sampled over time.

Builds the run as ``python -m rlhc.run env=<env> critic=<critic>`` does (Hydra config,
:class:`rlhc.training.trainer.Trainer`, default loggers: CSV + TensorBoard, checkpoints every
``checkpoint_freq`` frames), and samples ``VmRSS`` from ``/proc/self/status`` in a
background thread together with the trainer's frame counter. Reports the peak RSS,
the min/max after the first ``--settle`` share of the frames, and the least-squares
slope of RSS against frames over that part (a leak shows as a positive slope).
Writes JSON and a PNG plot of RSS against frames.

Examples:
    python benchmarks/memory.py --env soccer                       # Table 3: 500 K frames
    python benchmarks/memory.py --env soccer --max-steps 100000    # a shorter run
"""

from __future__ import annotations

import argparse
import json
import multiprocessing
import os
import platform
import tempfile
import threading
import time
from pathlib import Path
from typing import Any

import numpy as np
from train_throughput import compose_config

from rlhc.analysis.drawing import save_figure

RESULTS = Path(__file__).parent / "results"


def rss_mib() -> float:
    """Resident set size of this process, MiB (Linux ``/proc/self/status``)."""
    with open("/proc/self/status") as status:
        for line in status:
            if line.startswith("VmRSS:"):
                return int(line.split()[1]) / 1024
    raise RuntimeError("no VmRSS in /proc/self/status (Linux only)")


class Sampler(threading.Thread):
    """Every ``interval`` seconds: (wall time, frames trained so far, RSS MiB)."""

    def __init__(self, trainer: Any, interval: float) -> None:
        super().__init__(daemon=True)
        self.trainer, self.interval = trainer, interval
        self.samples: list[tuple[float, int, float]] = []
        self.stopped = threading.Event()
        self.start_time = time.perf_counter()

    def run(self) -> None:
        while not self.stopped.is_set():
            self.sample()
            self.stopped.wait(self.interval)

    def sample(self) -> None:
        now = time.perf_counter() - self.start_time
        self.samples.append((now, self.trainer.frames, rss_mib()))


def summarise(samples: np.ndarray, max_steps: int, settle: float) -> dict[str, float]:
    """Peak, and min/max/slope after ``settle * max_steps`` frames."""
    frames, rss = samples[:, 1], samples[:, 2]
    after = frames >= settle * max_steps
    slope, _ = np.polyfit(frames[after], rss[after], 1)
    return {
        "peak_rss_mib": float(rss.max()),
        "rss_at_start_mib": float(rss[0]),
        "settled_from_frames": float(settle * max_steps),
        "settled_min_rss_mib": float(rss[after].min()),
        "settled_max_rss_mib": float(rss[after].max()),
        "settled_slope_mib_per_100k_frames": float(slope * 100_000),
        "samples": len(rss),
    }


def plot(samples: np.ndarray, path: Path, title: str, settle_frames: float) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    figure, axes = plt.subplots(figsize=(7, 3.5))
    axes.plot(samples[:, 1], samples[:, 2], lw=1)
    axes.axvline(settle_frames, color="grey", ls="--", lw=0.8, label="end of warm-up share")
    axes.set_xlabel("frames trained")
    axes.set_ylabel("RSS (MiB)")
    axes.set_title(title, fontsize=9)
    axes.set_ylim(bottom=0)
    axes.legend(loc="lower right", fontsize=8)
    figure.tight_layout()
    save_figure(figure, path)
    plt.close(figure)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--env", default="soccer")
    parser.add_argument("--critic", default="hierarchical")
    parser.add_argument("--max-steps", type=int, help="frames (default: Table 3's max steps)")
    parser.add_argument("--interval", type=float, default=0.5, help="seconds between samples")
    parser.add_argument("--settle", type=float, default=0.1, help="warm-up share of the frames")
    parser.add_argument("--output-dir", type=Path, default=RESULTS)
    args = parser.parse_args()

    from rlhc.training.trainer import Trainer

    overrides = ["logger.progress=false"]
    if args.max_steps is not None:
        overrides.append(f"algo.max_steps={args.max_steps}")
    cfg = compose_config(args.env, args.critic, overrides)
    load_before = os.getloadavg()
    with tempfile.TemporaryDirectory(prefix="bench_memory_") as tmp:
        trainer = Trainer(cfg, Path(tmp))
        sampler = Sampler(trainer, args.interval)
        sampler.start()
        start, cpu_start = time.perf_counter(), time.process_time()
        trainer.train()
        wall, cpu = time.perf_counter() - start, time.process_time() - cpu_start
        sampler.stopped.set()
        sampler.join()
        sampler.sample()

    samples = np.asarray(sampler.samples)
    result = {"env": args.env, "critic": args.critic, "max_steps": cfg.algo.max_steps,
              "frames": trainer.frames, "wall_s": wall, "cpu_s": cpu,
              "frames_per_s": trainer.frames / wall}  # fmt: skip
    result.update(summarise(samples, cfg.algo.max_steps, args.settle))
    meta = {"machine": platform.machine(), "cpus": multiprocessing.cpu_count(),
            "python": platform.python_version(), "date": time.strftime("%Y-%m-%d %H:%M %Z"),
            "loadavg_before": load_before, "loadavg_after": os.getloadavg()}  # fmt: skip
    for key, value in result.items():
        print(f"{key:36} {value:,.2f}" if isinstance(value, float) else f"{key:36} {value}")
    args.output_dir.mkdir(parents=True, exist_ok=True)
    trace = [[round(t, 2), int(f), round(r, 1)] for t, f, r in samples.tolist()]
    out = {"meta": meta, "result": result, "trace_time_frames_rss_mib": trace}
    (args.output_dir / "memory.json").write_text(json.dumps(out, indent=1) + "\n")
    title = (f"{args.env} {args.critic}, Table 3, {trainer.frames:,} frames: peak "
             f"{result['peak_rss_mib']:.0f} MiB, slope after {args.settle:.0%} "
             f"{result['settled_slope_mib_per_100k_frames']:+.2f} MiB / 100k frames")  # fmt: skip
    plot(
        samples, args.output_dir / f"memory_{args.env}.png", title, args.settle * cfg.algo.max_steps
    )
    print(f"wrote {args.output_dir / 'memory.json'} and memory_{args.env}.png")


if __name__ == "__main__":
    main()
