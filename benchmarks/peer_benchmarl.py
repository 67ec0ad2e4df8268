"""One BenchMARL run of the peer check, as published: run by ``benchmarks/peer_check.py``
in BenchMARL's own virtual environment (``.venv-peer``), never imported by ``rlhc``.

BenchMARL's own configs are loaded from its package (``base_experiment.yaml``, the
algorithm's yaml, ``layers/mlp.yaml``, the task's yaml); only what a benchmark must change
is overridden: the frame budget, no evaluation, rendering, loggers or checkpoints, and the
output folder. A callback records, after every collected batch, the frames so far, the
wall time, and each group's mean episode return over the episodes that ended in the batch
(BenchMARL's ``collection/<group>/reward/episode_reward_mean``).

    .venv-peer/bin/python benchmarks/peer_benchmarl.py --task vmas/navigation \
        --algorithm mappo --seed 0 --frames 600000 --out <dir>
"""

from __future__ import annotations

import argparse
import csv
import json
import time
from pathlib import Path

import torch
from benchmarl.algorithms import IppoConfig, MappoConfig
from benchmarl.environments import PettingZooTask, VmasTask
from benchmarl.experiment import Callback, Experiment, ExperimentConfig
from benchmarl.models.mlp import MlpConfig

ALGORITHMS = {"ippo": IppoConfig, "mappo": MappoConfig}
SOURCES = {"vmas": VmasTask, "pettingzoo": PettingZooTask}


class Record(Callback):
    """Each batch: frames, seconds since the start, each group's mean episode return."""

    def __init__(self, path: Path) -> None:
        super().__init__()
        self.path = path
        self.rows: list[dict[str, float]] = []
        self.start = time.perf_counter()

    def on_batch_collected(self, batch) -> None:
        row = {
            "frames": float(self.experiment.total_frames),
            "seconds": time.perf_counter() - self.start,
        }
        for group in self.experiment.group_map:
            done = batch.get(("next", group, "done"), None)
            if done is None:
                done = (
                    batch.get(("next", "done"))
                    .unsqueeze(-2)
                    .expand(*batch.get(("next", group, "episode_reward")).shape)
                )
            returns = batch.get(("next", group, "episode_reward"))
            # One number per ended episode: the mean over the group's agents.
            ended = done.any(-2).squeeze(-1)
            row[group] = (
                returns.mean(-2).squeeze(-1)[ended].mean().item() if ended.any() else float("nan")
            )
        self.rows.append(row)

    def write(self) -> None:
        with self.path.open("w", newline="") as file:
            writer = csv.DictWriter(file, fieldnames=list(self.rows[0]))
            writer.writeheader()
            writer.writerows(self.rows)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--task", required=True, help="<vmas|pettingzoo>/<task>")
    parser.add_argument("--algorithm", required=True, choices=sorted(ALGORITHMS))
    parser.add_argument("--seed", type=int, required=True)
    parser.add_argument("--frames", type=int, required=True)
    parser.add_argument("--out", type=Path, required=True)
    args = parser.parse_args()
    torch.set_num_threads(1)

    source, name = args.task.split("/")
    task = getattr(SOURCES[source], name.upper()).get_from_yaml()
    config = ExperimentConfig.get_from_yaml()
    config.max_n_frames = args.frames
    config.evaluation = False
    config.render = False
    config.loggers = []
    config.create_json = False
    config.checkpoint_interval = 0
    config.checkpoint_at_end = False
    args.out.mkdir(parents=True, exist_ok=True)
    config.save_folder = str(args.out)
    record = Record(args.out / "curve.csv")
    experiment = Experiment(
        task=task,
        algorithm_config=ALGORITHMS[args.algorithm].get_from_yaml(),
        model_config=MlpConfig.get_from_yaml(),
        critic_model_config=MlpConfig.get_from_yaml(),
        seed=args.seed,
        config=config,
        callbacks=[record],
    )
    experiment.run()
    record.write()
    (args.out / "task.json").write_text(json.dumps({"task": args.task, **dict(task.config)}))


if __name__ == "__main__":
    main()
