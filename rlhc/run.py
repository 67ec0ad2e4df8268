"""Entry point: ``python -m rlhc.run env=<tennis|soccer> critic=<ppo|hierarchical|…>``.

Wiring only: compose and check the config, hand it to the trainer, report how the run
ended. Outputs go to ``outputs/<env>/<critic>/<time>/`` (multirun:
``multirun/<time>/<num>_<key>-<value>_…/``); ``resume=<run dir or checkpoint>`` continues
in the resumed run's directory, ``resume=auto`` from this run directory's own checkpoint
if it holds one (``docs/guide/training.md``).

| how it ends | output | exit code |
|---|---|---|
| trained to ``algo.max_steps`` | ``results in <run dir>`` | 0 |
| a resume of a run already at ``algo.max_steps`` | that it is finished; nothing is written | 0 |
| a user error (:data:`~rlhc.cli.hydra_hooks.USER_ERRORS`) | ``rlhc.run: error: <one line>``; no run directory is left behind | 2 |
| SIGINT / SIGTERM during training | the checkpoint and the command that resumes it | 130 / 143 |

``HYDRA_FULL_ERROR=1`` shows a user error's traceback; any other error is a bug (exit 1).
Under ``torchrun`` rank 0 alone writes the run directory (:mod:`rlhc.training.distributed`).
"""

from __future__ import annotations

import logging
import shlex
import sys
from pathlib import Path

import hydra
from hydra.core.hydra_config import HydraConfig
from hydra.types import RunMode
from omegaconf import DictConfig

from rlhc.cli.cleanup import (
    remove_empty_parents,
    remove_failed_job,
    remove_failed_sweeps,
    remove_if_unused,
)
from rlhc.cli.hydra_hooks import USER_ERRORS, PreflightFailed
from rlhc.cli.report import shown, user_errors_in_one_line
from rlhc.cli.start import forget_checked, take_checked
from rlhc.config.train_schema import CONFIG_DIR, register_configs
from rlhc.storage.run_lock import unlock_run_dirs
from rlhc.training.distributed import (
    broadcast_object,
    launched_rank,
    launched_size,
    setup,
    shutdown,
)
from rlhc.training.interrupt import TrainingInterrupted
from rlhc.training.trainer import Trainer

PROGRAM = "rlhc.run"
#: ``hydra.output_subdir`` that writes no ``.hydra/`` (Hydra's null).
NO_OUTPUT = "null"

log = logging.getLogger(__name__)
register_configs()


# An absolute path: Hydra reads a relative one as a package when this file runs as the
# module ``rlhc.run`` (see the end of the file), and ``conf`` is not a package.
@hydra.main(version_base="1.3", config_path=str(CONFIG_DIR), config_name="train")
def main(cfg: DictConfig) -> float:
    """Train one run; returns the last logged mean cumulative reward (for sweepers).

    A finished run returns ``nan``, writing nothing; a job that fails on a user error
    removes what its start created and raises. The run directory's lock, taken by the
    check, is released however training ends.
    """
    hydra_cfg = HydraConfig.get()
    run_dir = Path(hydra_cfg.runtime.output_dir)
    job_log = f"{hydra_cfg.job.name}.log"
    try:
        start = take_checked(cfg, run_dir)
    except USER_ERRORS:
        multirun = hydra_cfg.mode == RunMode.MULTIRUN
        remove_failed_job(run_dir, job_log, Path(hydra_cfg.sweep.dir) if multirun else None)
        raise
    message = start.finished_message()
    if message is not None:
        print(message, flush=True)  # not logged: the run's log stays as the run left it
        return float("nan")
    train_cfg = start.cfg
    try:
        processes = setup(train_cfg.parallel, train_cfg.device, train_cfg.league.active)
        if processes.active:
            # Rank 0's directory: the others' own (named by their clock) stays empty.
            main_dir = Path(broadcast_object(str(run_dir)))
            if main_dir != run_dir:
                remove_if_unused(run_dir, job_log)
                remove_empty_parents(run_dir)
            run_dir = main_dir
        trainer = Trainer(train_cfg, run_dir, processes=processes, resume_state=start.state)
        del start  # the trainer holds what it needs of the checkpoint
        metrics = trainer.train()
    except TrainingInterrupted as stop:
        if processes.main:
            log.warning(
                f"{stop.signal_name}: stopped at {stop.frames:,} frames of "
                f"{train_cfg.algo.max_steps:,}; checkpoint {shown(stop.checkpoint)}; resume "
                f"with: {resume_command(run_dir)}"
            )
        sys.exit(stop.exit_code)
    finally:
        shutdown()
        unlock_run_dirs()
    if processes.main:
        log.info(f"results in {shown(run_dir)}")
    rewards = [v for k, v in metrics.items() if k.endswith("/cumulative_reward")]
    return sum(rewards) / len(rewards) if rewards else float("nan")


def cli() -> None:
    """``python -m rlhc.run``: :func:`main`, with user errors reported in one line (exit 2)."""
    rank = launched_rank()
    if rank > 0:
        # torchrun's other processes: rank 0 alone writes the run directory.
        sys.argv += [f"hydra.output_subdir={NO_OUTPUT}", "hydra/job_logging=stdout"]
    program = f"{PROGRAM} (rank {rank})" if rank else PROGRAM
    try:
        with user_errors_in_one_line(program, USER_ERRORS):
            try:
                main()
            except PreflightFailed as failed:
                raise failed.error from None
            except USER_ERRORS:
                remove_failed_sweeps()
                raise
            finally:
                forget_checked()
    except KeyboardInterrupt:
        # Before training (building the envs) or a second Ctrl-C: nothing more to save.
        print(f"{PROGRAM}: interrupted; checkpoints written so far are complete", file=sys.stderr)
        sys.exit(130)


def resume_command(run_dir: Path) -> str:
    """The command line that continues this run in ``run_dir``."""
    overrides = [
        o for o in HydraConfig.get().overrides.task if o.lstrip("+~").split("=")[0] != "resume"
    ]
    launcher = [shown(Path(sys.executable))]
    size = launched_size()
    if size > 1:
        launcher = ["torchrun", "--standalone", f"--nproc_per_node={size}"]
    return shlex.join([*launcher, "-m", PROGRAM, *overrides, f"resume={shown(run_dir)}"])


if __name__ == "__main__":
    # Run the module's ``rlhc.run`` copy, so that log records name the logger ``rlhc.run``.
    from rlhc.run import cli as run_cli

    run_cli()
