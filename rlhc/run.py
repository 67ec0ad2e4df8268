"""Entry point: ``python -m rlhc.run env=<tennis|soccer> critic=<ppo|hierarchical|…>``.

Wiring only: compose and check the config, hand it to the trainer, report how the run
ended. Outputs go to ``outputs/<env>/<critic>/<time>/`` (multirun:
``multirun/<time>/<num>_<key>-<value>_…/``; a study of ``conf/study/``: its sweep
directory's ``<critic>/seed_<k>/``); ``resume=<run dir or checkpoint>`` continues in the
resumed run's own directory (the ``rlhc.run_dir`` resolver of ``conf/train.yaml``)
unless ``hydra.run.dir`` is given. ``resume=auto`` continues from the run directory's own
checkpoint if it holds one and starts fresh otherwise (:func:`resolve_resume`): a study
run again continues its unfinished runs and skips its finished ones.

How it ends, and its exit code:

| case | output | code |
|---|---|---|
| trained to ``algo.max_steps`` | ``results in <run dir>`` | 0 |
| ``resume=`` of a run that reached ``algo.max_steps`` (a multirun job: that job) | that it is finished; nothing is written | 0 |
| a user error: a bad value (:class:`~rlhc.errors.ConfigError`), a resume path that holds no checkpoint or whose settings differ (:class:`~rlhc.checkpoint.ResumeError`), a Hydra override or composition error | ``rlhc.run: error: <one line>``; no run directory is left behind, an existing one is left as it was | 2 |
| SIGINT / SIGTERM during training | where the checkpoint is and the command that resumes it | 130 / 143 |

``HYDRA_FULL_ERROR=1`` shows the traceback of a user error instead. Any other error is
a bug and keeps its traceback (exit 1).

A single run is checked (:func:`preflight`) before Hydra creates its directory. A
multirun job is checked inside the job, after Hydra created its directory, so the
``rlhc.output_subdir`` resolver keeps Hydra from writing ``.hydra/`` into the directory of
a job that will not train, and after a user error :func:`remove_if_unused` removes only
what the failed start created: empty directories and an empty job log, never a file with
content (a trained run's ``checkpoints/``, ``metrics.csv``, logs or ``.hydra/``).

Under ``torchrun --nproc_per_node=N`` every process runs this entry point
(:mod:`rlhc.distributed`): rank 0 owns the run directory and all output; the other
ranks write nothing (Hydra's files off, their log lines on stdout) and use rank 0's
directory.
"""

from __future__ import annotations

import copy
import dataclasses
import logging
import os
import shlex
import sys
from pathlib import Path
from typing import Any

import hydra
from hydra.core.hydra_config import HydraConfig
from hydra.errors import HydraException
from hydra.experimental.callback import Callback
from hydra.types import RunMode
from omegaconf import DictConfig, OmegaConf, open_dict, read_write
from omegaconf.errors import OmegaConfBaseException

from rlhc.builders import Layout
from rlhc.checkpoint import ResumeError, checkpoint_candidates, load_checkpoint, run_dir_of
from rlhc.config import RESUME_AUTO, TrainConfig, register_configs
from rlhc.distributed import broadcast_object, launched_rank, launched_size, setup, shutdown
from rlhc.errors import ConfigError
from rlhc.interrupt import TrainingInterrupted
from rlhc.trainer import Trainer
from rlhc.training_state import check_resumable
from rlhc.validation import validate

PROGRAM = "rlhc.run"
#: An absolute path: Hydra reads a relative one as a package when this file runs as the
#: module ``rlhc.run`` (see the end of the file), and ``conf`` is not a package.
CONFIG_DIR = str(Path(__file__).resolve().parents[1] / "conf")
#: Exit code of a user error (as argparse's).
USAGE_ERROR = 2
#: ``hydra.output_subdir`` that writes no ``.hydra/`` (Hydra's null).
NO_OUTPUT = "null"
#: Errors a user fixes by changing the command line, reported in one line.
USER_ERRORS = (ConfigError, ResumeError, HydraException, OmegaConfBaseException)

#: What Hydra writes into a multirun's sweep directory before its jobs start.
MULTIRUN_FILE = "multirun.yaml"

log = logging.getLogger(__name__)
#: Sweep directories of multirun jobs that failed on a user error: :func:`cli` removes
#: those left holding only Hydra's ``multirun.yaml`` (jobs run in this process only).
_failed_sweeps: set[Path] = set()


class PreflightFailed(BaseException):
    """A user error found by :class:`Preflight`, carried past Hydra to :func:`cli`.

    A ``BaseException``: Hydra turns a callback's ``Exception`` into a warning and runs
    the job anyway.
    """

    def __init__(self, error: Exception) -> None:
        super().__init__(str(error))
        self.error = error


def run_directory(resume: str | None, default: str) -> str:
    """``hydra.run.dir``: the resumed run's directory, else ``default`` (a new one).

    Registered as the ``rlhc.run_dir`` resolver; ``hydra.run.dir=`` on the command line
    replaces the interpolation, so an explicit directory always wins. ``resume=auto``
    names no other run: the run directory is ``default``.
    """
    run_dir = run_dir_of(resume) if resume and resume != RESUME_AUTO else None
    return default if run_dir is None else str(run_dir)


def output_subdir(subdir: str, *, _root_: DictConfig) -> str | None:
    """``hydra.output_subdir``: ``subdir``, or ``None`` for a multirun job that will not train.

    Registered as the ``rlhc.output_subdir`` resolver. Hydra writes ``.hydra/`` into a
    multirun job's directory before the job starts and offers no hook before that, so
    this answers, for each job, whether :func:`preflight` lets it train: a finished run's
    directory must stay as it was, and so must any directory a user error reaches. A
    single run was checked already (:class:`Preflight`).

    Args:
        subdir: where ``.hydra/`` goes when the job trains (Hydra's ``.hydra``).
        _root_: the job's whole config (given by OmegaConf).

    Returns:
        ``subdir``, or ``None`` (Hydra's "write no ``.hydra/``").
    """
    try:
        hydra_cfg = HydraConfig.get()
        if hydra_cfg.mode != RunMode.MULTIRUN:
            return subdir
        cfg, state = checked(_root_, Path(hydra_cfg.runtime.output_dir))
    except Exception:  # whatever fails here fails again in main(), which reports it
        return None
    return subdir if finished_message(cfg, state) is None else None


register_configs()
# ``replace``: ``python -m rlhc.run`` executes this file twice, as ``__main__`` and as
# ``rlhc.run`` (see the end of the file).
OmegaConf.register_new_resolver("rlhc.run_dir", run_directory, replace=True)
OmegaConf.register_new_resolver("rlhc.output_subdir", output_subdir, replace=True)


def task_config(config: DictConfig) -> TrainConfig:
    """The training config of a composed config, without its ``hydra`` node if it has one."""
    task = copy.deepcopy(config)
    with read_write(task), open_dict(task):
        task.pop("hydra", None)
    return OmegaConf.to_object(task)  # type: ignore[return-value]


def resolve_resume(cfg: TrainConfig, run_dir: Path) -> TrainConfig:
    """``cfg`` with ``resume=auto`` replaced by what it means in ``run_dir``.

    ``auto`` becomes ``run_dir`` when it holds a checkpoint file and ``None`` (a fresh
    run) otherwise; any other value is kept. A directory whose checkpoint files all fail
    to load becomes ``run_dir`` too, so that :func:`preflight` refuses it, naming each
    file, rather than a fresh run overwriting the run's ``metrics.csv``.

    Args:
        cfg: the composed config (not changed).
        run_dir: the directory this run writes to.

    Examples:
        >>> resolve_resume(TrainConfig(resume="auto"), Path("no/such/run")).resume is None
        True
    """
    if cfg.resume != RESUME_AUTO:
        return cfg
    resume = shown(run_dir) if checkpoint_candidates(run_dir) else None
    return dataclasses.replace(cfg, resume=resume)


def preflight(cfg: TrainConfig) -> dict[str, Any] | None:
    """Check everything that can fail before a file is written; the checkpoint to resume.

    Args:
        cfg: the config, ``resume=auto`` already resolved (:func:`resolve_resume`).

    Raises:
        ConfigError: a value the schema let through but the trainer cannot use.
        ResumeError: ``cfg.resume`` holds no loadable checkpoint, or one trained with
            settings a resume cannot change.
    """
    size = launched_size()
    validate(cfg, size)
    Layout.from_config(cfg, size if cfg.parallel == "data" else 1)
    if not cfg.resume:
        return None
    try:
        state = load_checkpoint(cfg.resume)
    except (FileNotFoundError, ValueError) as error:
        raise ResumeError(f"resume={cfg.resume!r}: {error}") from error
    check_resumable(cfg, state)
    return state


def checked(config: DictConfig, run_dir: Path) -> tuple[TrainConfig, dict[str, Any] | None]:
    """The training config of a composed ``config`` for ``run_dir``, checked.

    Args:
        config: the composed config (its ``hydra`` node, if any, is left out).
        run_dir: the directory the run writes to (where ``resume=auto`` looks).

    Returns:
        The config to train (:func:`resolve_resume`) and the checkpoint it continues
        (``None``: a fresh run).

    Raises:
        ConfigError, ResumeError: as :func:`preflight`.
        OmegaConfBaseException: a value of the wrong type (the schema's check).
    """
    cfg = resolve_resume(task_config(config), run_dir)
    return cfg, preflight(cfg)


def finished_message(cfg: TrainConfig, state: dict[str, Any] | None) -> str | None:
    """What to say when ``state`` already reached the budget, else ``None``."""
    if state is None or int(state["frames"]) < cfg.algo.max_steps:
        return None
    return (
        f"{shown(Path(state['path']))} has trained {int(state['frames']):,} frames of "
        f"algo.max_steps={cfg.algo.max_steps:,}: the run is finished, nothing to do "
        "(raise algo.max_steps to continue it)"
    )


class Preflight(Callback):
    """Hydra callback: :func:`preflight` a single run before Hydra creates its directory.

    Configured in ``conf/train.yaml`` (``hydra.callbacks``). A finished run ends here
    (exit 0) without writing anything; a user error reaches :func:`cli` as
    :class:`PreflightFailed`. A multirun checks each job in :func:`main` instead (and
    removes the job's directory if the job created it).
    """

    def on_run_start(self, config: DictConfig, **kwargs: Any) -> None:
        # As Hydra does first thing for the job: ``hydra.run.dir`` may read it.
        HydraConfig.instance().set_config(config)
        try:
            cfg, state = checked(config, Path(str(config.hydra.run.dir)))
        except USER_ERRORS as error:
            raise PreflightFailed(error) from error
        message = finished_message(cfg, state)
        if message is not None:
            print(message, flush=True)
            sys.exit(0)


@hydra.main(version_base="1.3", config_path=CONFIG_DIR, config_name="train")
def main(cfg: DictConfig) -> float:
    """Train one run; returns the last logged mean cumulative reward (for sweepers).

    A multirun job whose run is finished says so and returns ``nan``, writing nothing;
    one that fails on a user error removes what its start created
    (:func:`remove_if_unused`) and raises.
    """
    hydra_cfg = HydraConfig.get()
    run_dir = Path(hydra_cfg.runtime.output_dir)
    try:
        train_cfg, state = checked(cfg, run_dir)
    except USER_ERRORS:
        remove_if_unused(run_dir, f"{hydra_cfg.job.name}.log")
        if hydra_cfg.mode == RunMode.MULTIRUN:
            remove_empty_parents(run_dir, top=Path(hydra_cfg.sweep.dir))
            _failed_sweeps.add(Path(hydra_cfg.sweep.dir))
        raise
    message = finished_message(train_cfg, state)
    if message is not None:
        print(message, flush=True)  # not logged: the run's log stays as the run left it
        return float("nan")
    processes = setup(train_cfg.parallel, train_cfg.device, train_cfg.league.active)
    try:
        if processes.active:
            # Rank 0's directory: the others' own (named by their clock) stays empty.
            main_dir = Path(broadcast_object(str(run_dir)))
            if main_dir != run_dir:
                remove_if_unused(run_dir, f"{hydra_cfg.job.name}.log")
                remove_empty_parents(run_dir)
            run_dir = main_dir
        metrics = Trainer(train_cfg, run_dir, processes=processes).train()
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
    if processes.main:
        log.info(f"results in {shown(run_dir)}")
    rewards = [v for k, v in metrics.items() if k.endswith("/cumulative_reward")]
    return sum(rewards) / len(rewards) if rewards else float("nan")


def cli() -> None:
    """``python -m rlhc.run``: :func:`main`, with user errors reported in one line (exit 2)."""
    full_error = os.environ.get("HYDRA_FULL_ERROR") == "1"
    if launched_rank() > 0:
        # torchrun's other processes: rank 0 alone writes the run directory.
        sys.argv += [f"hydra.output_subdir={NO_OUTPUT}", "hydra/job_logging=stdout"]
    # Hydra's documented switch to let exceptions through unprinted: reported below.
    os.environ["HYDRA_FULL_ERROR"] = "1"
    try:
        try:
            main()
        except PreflightFailed as failed:
            raise failed.error from None
    except KeyboardInterrupt:
        # Before training (building the envs) or a second Ctrl-C: nothing more to save.
        print(f"{PROGRAM}: interrupted; checkpoints written so far are complete", file=sys.stderr)
        sys.exit(130)
    except USER_ERRORS as error:
        for sweep in _failed_sweeps:
            remove_unused_sweep(sweep)
        if full_error:
            raise
        rank = launched_rank()
        where = f" (rank {rank})" if rank else ""
        print(f"{PROGRAM}{where}: error: {one_line(error)}", file=sys.stderr)
        sys.exit(USAGE_ERROR)


def one_line(error: BaseException) -> str:
    """An error and its causes in one line, without OmegaConf's and Hydra's diagnostics.

    Examples:
        >>> one_line(ValueError("Could not override 'algo.lrr'.\\nTo append use +algo.lrr=1"))
        "Could not override 'algo.lrr'. To append use +algo.lrr=1"
    """
    parts: list[str] = []
    current: BaseException | None = error
    while current is not None:
        for raw in str(current).splitlines():
            line = raw.strip()
            if line.startswith(("Config search path", "Set the environment variable")):
                break  # the rest is Hydra's search path, or advice this line replaces
            if not line or line.startswith(_DIAGNOSTICS) or any(line in p for p in parts):
                continue
            if raw[:1].isspace() and parts:  # an indented item of a list (e.g. options)
                parts[-1] += ("" if parts[-1].endswith(":") else ",") + f" {line}"
            else:
                parts.append(line)
        current = current.__cause__
    return " ".join(parts)


#: OmegaConf's lines that locate a key in its own types.
_DIAGNOSTICS = ("full_key:", "reference_type=", "object_type=", "key:", "value:")


# --- after a start that failed ------------------------------------------------------
# Only what the failed start created is removed: a job directory empty but for an empty
# job log, the empty directories above it, and a sweep directory holding nothing but the
# multirun.yaml its sweep wrote. A file with content is never removed, so a directory
# that held anything before (a trained run's checkpoints/, metrics.csv, logs, .hydra/)
# stays exactly as it was.


def remove_if_unused(run_dir: Path, job_log: str) -> None:
    """Remove ``run_dir`` if it holds nothing, or nothing but an empty ``job_log``.

    Hydra creates a job's directory before the job starts; its log opens at the first
    record (``delay: true``: ``conf/hydra/job_logging/rlhc.yaml``), or before the job
    under a logging config without it: a job that fails before logging a line leaves
    just that. (It writes no ``.hydra/`` for such a job: :func:`output_subdir`; a single
    run fails before Hydra creates anything: :class:`Preflight`.)

    Args:
        run_dir: the job's directory.
        job_log: the name of the log Hydra opened in it (``<job name>.log``).

    Examples:
        >>> import tempfile
        >>> run = Path(tempfile.mkdtemp())
        >>> (run / "metrics.csv").touch()
        >>> remove_if_unused(run, "run.log")
        >>> sorted(p.name for p in run.iterdir())
        ['metrics.csv']
    """
    if not run_dir.is_dir():
        return
    log_file = run_dir / job_log
    if os.listdir(run_dir) == [job_log] and log_file.is_file() and log_file.stat().st_size == 0:
        log_file.unlink()
    try:
        run_dir.rmdir()
    except OSError:  # not empty: what it holds stays
        return


def remove_unused_sweep(sweep_dir: Path) -> None:
    """Remove a sweep directory that holds only the ``multirun.yaml`` its sweep wrote."""
    if not sweep_dir.is_dir() or set(os.listdir(sweep_dir)) - {MULTIRUN_FILE}:
        return
    (sweep_dir / MULTIRUN_FILE).unlink(missing_ok=True)
    sweep_dir.rmdir()
    remove_empty_parents(sweep_dir)


def remove_empty_parents(path: Path, top: Path | None = None) -> None:
    """Remove the now empty directories above ``path``, up to the working directory.

    Args:
        path: where to start (``path`` itself is not removed).
        top: a directory to stop at (not removed) before the working directory.
    """
    cwd = Path.cwd()
    stop = Path(os.path.abspath(top)) if top is not None else cwd
    for parent in Path(os.path.abspath(path)).parents:
        if parent in (cwd, stop) or not parent.is_relative_to(cwd):
            return
        try:
            parent.rmdir()
        except OSError:  # not empty
            return


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


def shown(path: Path) -> str:
    """``path`` relative to the working directory when inside it, else absolute."""
    absolute = Path(os.path.abspath(path))
    try:
        return str(absolute.relative_to(Path.cwd()))
    except ValueError:
        return str(absolute)


if __name__ == "__main__":
    # Run the module's ``rlhc.run`` copy, the one Hydra imports for the callback, so
    # that both share one :class:`PreflightFailed` (and one logger name).
    from rlhc.run import cli as run_cli

    run_cli()
