"""Entry point: head-to-head matches and Elo ratings between checkpoints and built-ins.

Wiring only: compose and validate the config, seed, hand over to
:mod:`rlhc.evaluation.commands`. Outputs go to
``outputs/evaluate/<env>/<mode>/<time>/`` (``results.json``, ``matches.csv``; in
``mode=elo``: ``elo.json``, ``elo.csv``, ``pairings.csv``); with ``video.enabled=true`` a
match video (``match.gif``; in ``mode=elo`` one per pairing under ``videos/``).

Examples:
    python -m rlhc.evaluate env=soccer home=outputs/soccer/hierarchical/<time> away=scripted matches=100
    python -m rlhc.evaluate env=tennis home=scripted away=random deterministic=false video.enabled=true
    python -m rlhc.evaluate mode=elo env=soccer 'players=[scripted,random,outputs/soccer/ppo/<time>]'
"""

from __future__ import annotations

from pathlib import Path

import hydra
import torch
from hydra.core.hydra_config import HydraConfig
from omegaconf import DictConfig, OmegaConf

from rlhc.checkpoint import seed_everything
from rlhc.evaluation.commands import run_elo, run_match
from rlhc.evaluation.config import EvaluateConfig, register_evaluate_configs
from rlhc.validation import validate_evaluate

register_evaluate_configs()


@hydra.main(version_base="1.3", config_path="../conf", config_name="evaluate")
def main(cfg: DictConfig) -> float:
    """Run one evaluation; returns the home score (``match``) or the best rating (``elo``)."""
    eval_cfg: EvaluateConfig = OmegaConf.to_object(cfg)  # type: ignore[assignment]
    validate_evaluate(eval_cfg)
    if eval_cfg.threads > 0:
        torch.set_num_threads(eval_cfg.threads)
    seed_everything(eval_cfg.seed)
    out_dir = Path(HydraConfig.get().runtime.output_dir)
    if eval_cfg.mode == "elo":
        return run_elo(eval_cfg, out_dir).standings()[0][1]
    return float(run_match(eval_cfg, out_dir)["score"])


if __name__ == "__main__":
    main()
