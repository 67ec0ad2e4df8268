"""Entry point: head-to-head matches and Elo ratings between checkpoints and built-ins.

Wiring only: compose and check the config and the players, seed, hand over to
:mod:`rlhc.evaluation.commands` (which lists the files written into
``outputs/evaluate/<env>/<mode>/<time>/``). A user error prints
``rlhc.evaluate: error: <one line>`` and exits 2 before any match is played.

Examples:
    python -m rlhc.evaluate env=soccer home=outputs/soccer/hierarchical/<time> away=scripted matches=100
    python -m rlhc.evaluate env=tennis home=scripted away=random deterministic=false video.enabled=true
    python -m rlhc.evaluate mode=elo env=soccer 'players=[scripted,random,outputs/soccer/ppo/<time>]'
    python -m rlhc.evaluate mode=showcase env=tennis home=outputs/tennis/hierarchical/<time>
"""

from __future__ import annotations

from pathlib import Path

import hydra
import torch
from hydra.core.hydra_config import HydraConfig
from omegaconf import DictConfig, OmegaConf

from rlhc.analysis.showcase import run_showcase
from rlhc.cli.hydra_hooks import PreflightFailed
from rlhc.cli.report import HYDRA_USER_ERRORS, user_errors_in_one_line
from rlhc.config.evaluate_schema import EvaluateConfig, register_evaluate_configs
from rlhc.config.train_schema import CONFIG_DIR
from rlhc.evaluation.commands import check_evaluation, run_elo, run_match
from rlhc.storage.checkpoint import seed_everything

PROGRAM = "rlhc.evaluate"

register_evaluate_configs()


# An absolute path: a relative one is read as a package when this runs as the module
# ``rlhc.evaluate`` (from :func:`cli`, in tests), and ``conf`` is not a package.
@hydra.main(version_base="1.3", config_path=str(CONFIG_DIR), config_name="evaluate")
def main(cfg: DictConfig) -> float:
    """Run one evaluation; returns the home score (``match``), the best rating (``elo``)
    or the share of the scripted team's points that ``home`` took (``showcase``)."""
    eval_cfg: EvaluateConfig = OmegaConf.to_object(cfg)  # type: ignore[assignment]
    check_evaluation(eval_cfg)  # again: a multirun's jobs are checked here only
    if eval_cfg.threads > 0:
        torch.set_num_threads(eval_cfg.threads)
    seed_everything(eval_cfg.seed)
    out_dir = Path(HydraConfig.get().runtime.output_dir)
    if eval_cfg.mode == "elo":
        return run_elo(eval_cfg, out_dir).standings()[0][1]
    if eval_cfg.mode == "showcase":
        return run_showcase(eval_cfg, out_dir)["headlines"]["points_won_vs_scripted"]
    return float(run_match(eval_cfg, out_dir)["score"])


def cli() -> None:
    """``python -m rlhc.evaluate``: :func:`main`, user errors in one line (exit 2)."""
    with user_errors_in_one_line(PROGRAM, HYDRA_USER_ERRORS):
        try:
            main()
        except PreflightFailed as failed:
            raise failed.error from None


if __name__ == "__main__":
    cli()
