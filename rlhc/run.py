"""Entry point: ``python -m rlhc.run env=<tennis|soccer> critic=<ppo|hierarchical|…>``.

Wiring only: compose and validate the config, then hand it to the trainer.
Outputs go to ``outputs/<env>/<critic>/<time>/`` (multirun: ``multirun/<time>/<job>/``).
"""

from __future__ import annotations

from pathlib import Path

import hydra
from hydra.core.hydra_config import HydraConfig
from omegaconf import DictConfig, OmegaConf

from rlhc.config import TrainConfig, register_configs
from rlhc.trainer import Trainer

register_configs()


@hydra.main(version_base="1.3", config_path="../conf", config_name="train")
def main(cfg: DictConfig) -> float:
    """Train one run; returns the last logged mean cumulative reward (for sweepers)."""
    train_cfg: TrainConfig = OmegaConf.to_object(cfg)  # type: ignore[assignment]
    run_dir = Path(HydraConfig.get().runtime.output_dir)
    metrics = Trainer(train_cfg, run_dir).train()
    rewards = [v for k, v in metrics.items() if k.endswith("/cumulative_reward")]
    return sum(rewards) / len(rewards) if rewards else float("nan")


if __name__ == "__main__":
    main()
