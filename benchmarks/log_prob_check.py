"""Does a trained policy's loss score its own actions as they were sampled?

Resumes a run's newest checkpoint, collects one batch with its policy, and compares the
log-probability stored with each action at sampling time with the loss actor's scoring of
that action under the same weights, as PPO's first ratio sees them: the mean and largest
difference, the share of experiences whose ratio is already outside the clip range, and
the approximate KL, all at unchanged weights (0 for an exact scoring). With
``--rescored``, the same after :func:`rlhc.objectives.rescore_log_prob`.

Usage::

    python -m benchmarks.log_prob_check benchmarks/results/learning/tennis/long_bounded/ppo/seed_0
"""

from __future__ import annotations

import argparse
import json
import shlex
import sys
import tempfile
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import torch
from omegaconf import OmegaConf

from benchmarks.reporting.summary import code_version
from rlhc.config.train_schema import compose_config
from rlhc.envs.keys import ACTION
from rlhc.objectives import rescore_log_prob
from rlhc.training.trainer import Trainer

#: Recorded overrides that do not describe the policy (where the run wrote, logging).
NOT_THE_POLICY = ("hydra.", "resume", "logger.", "play_freq", "algo.max_steps")


def measure(run_dir: Path, rescored: bool) -> dict[str, Any]:
    """The discrepancies of one batch of ``run_dir``'s newest checkpoint, per group."""
    recorded = OmegaConf.to_container(OmegaConf.load(run_dir / ".hydra" / "overrides.yaml"))
    assert isinstance(recorded, list)
    overrides = [o for o in recorded if not o.startswith(NOT_THE_POLICY)]
    cfg = compose_config(
        *overrides,
        "logger.backends=[csv]",
        "logger.progress=false",
        "algo.max_steps=1000000000",
        f"resume={run_dir}",
    )
    trainer = Trainer(cfg, Path(tempfile.mkdtemp(prefix="log_prob_check_")))
    batch = trainer.collect_batch()
    result: dict[str, Any] = {"frames": trainer.frames, "groups": {}}
    for group, loss in trainer.losses.items():
        keys = loss.tensor_keys
        if rescored:
            rescore_log_prob(loss, batch)
        with torch.no_grad():
            dist = loss.actor_network.get_dist(batch)
            stored = batch[keys.sample_log_prob]
            scored = dist.log_prob(batch[keys.action]).reshape(stored.shape)
        log_ratio = scored - stored
        epsilon = float(loss.clip_epsilon)
        ratio = log_ratio.exp()
        result["groups"][group] = {
            "experiences": log_ratio.numel(),
            "mean_abs_difference": float(log_ratio.abs().mean()),
            "max_abs_difference": float(log_ratio.abs().max()),
            "share_outside_clip": float(
                ((ratio < 1 - epsilon) | (ratio > 1 + epsilon)).float().mean()
            ),
            "kl_approx": float(((ratio - 1) - log_ratio).mean()),
            # The game's action (tanh_normal_exact scores its pre-tanh draw instead).
            "share_near_bound": float((batch[group, ACTION].abs() > 0.999).float().mean()),
        }
    return result


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("run_dir", type=Path, help="a run directory with checkpoints")
    parser.add_argument("--rescored", action="store_true", help="rescore before comparing")
    parser.add_argument("--out", type=Path, help="JSON file to write")
    args = parser.parse_args(argv)
    if not (args.run_dir / ".hydra" / "overrides.yaml").is_file():
        parser.error(f"{args.run_dir} holds no .hydra/overrides.yaml: not a run directory")
    torch.manual_seed(0)
    result = measure(args.run_dir, args.rescored)
    result["run"] = str(args.run_dir)
    result["rescored"] = args.rescored
    result["code_version"] = code_version()
    result["command"] = shlex.join(["python", "-m", "benchmarks.log_prob_check", *sys.argv[1:]])
    print(json.dumps(result, indent=2))
    if args.out is not None:
        args.out.parent.mkdir(parents=True, exist_ok=True)
        args.out.write_text(json.dumps(result, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
