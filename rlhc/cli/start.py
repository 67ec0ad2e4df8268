"""Before a training run writes anything: its config checked, its checkpoint loaded once,
its directory locked.

A start is checked before Hydra writes into the run's directory (:mod:`rlhc.cli.hydra_hooks`)
and again when :func:`rlhc.run.main` starts the job, which takes the kept check
(:func:`take_checked`) with the checkpoint it loaded. A start that will train takes its
run directory's lock (:mod:`rlhc.storage.run_lock`; under ``torchrun``, rank 0 alone).
"""

from __future__ import annotations

import copy
import dataclasses
import os
from pathlib import Path
from typing import Any

from omegaconf import DictConfig, OmegaConf, open_dict, read_write

from rlhc.building.builders import Layout
from rlhc.cli.report import shown
from rlhc.config.train_schema import RESUME_AUTO, TrainConfig
from rlhc.config.validation import validate
from rlhc.storage.checkpoint import ResumeError, checkpoint_candidates, load_checkpoint
from rlhc.storage.run_lock import lock_run_dir
from rlhc.training.distributed import launched_rank, launched_size
from rlhc.training.loggers import METRICS_FILE, recorded_frames
from rlhc.training.training_state import check_resumable


@dataclasses.dataclass(frozen=True)
class Start:
    """A checked start of a training run.

    Attributes:
        cfg: the config to train, ``resume=auto`` resolved (:func:`resolve_resume`).
        state: the checked checkpoint it continues; ``None``: a fresh run.
        recorded: :func:`recorded_without_checkpoint`.
    """

    cfg: TrainConfig
    state: dict[str, Any] | None
    recorded: int | None = None

    def finished_message(self) -> str | None:
        """What to say when the run already reached the budget, else ``None``."""
        budget = self.cfg.algo.max_steps
        if self.state is not None and int(self.state["frames"]) >= budget:
            return (
                f"{shown(Path(self.state['path']))} has trained {int(self.state['frames']):,} "
                f"frames of algo.max_steps={budget:,}: the run is finished, "
                "nothing to do (raise algo.max_steps to continue it)"
            )
        if self.recorded is not None and self.recorded >= budget:
            return (
                f"{METRICS_FILE} records {self.recorded:,} frames of algo.max_steps="
                f"{budget:,}: the run is finished, nothing to do (its checkpoints are not "
                "here: train it again in another directory to continue it)"
            )
        return None


#: The latest check (absolute run directory, start): one slot, so that at most one
#: checkpoint is held between a check and the job that takes it.
_latest: tuple[str, Start] | None = None


def task_config(config: DictConfig) -> Any:
    """The schema's dataclass (e.g. :class:`TrainConfig`) of a composed config, less ``hydra``."""
    task = copy.deepcopy(config)
    with read_write(task), open_dict(task):
        task.pop("hydra", None)
    return OmegaConf.to_object(task)


def resolve_resume(cfg: TrainConfig, run_dir: Path) -> TrainConfig:
    """``cfg`` with ``resume=auto`` replaced by what it means in ``run_dir``.

    ``auto`` becomes ``run_dir`` when it holds a checkpoint file, even one that fails to
    load (then :func:`preflight` refuses it rather than a fresh run overwriting the
    record), and ``None`` (a fresh run) otherwise; any other value is kept.

    Examples:
        >>> resolve_resume(TrainConfig(resume="auto"), Path("no/such/run")).resume is None
        True
    """
    if cfg.resume != RESUME_AUTO:
        return cfg
    resume = shown(run_dir) if checkpoint_candidates(run_dir) else None
    return dataclasses.replace(cfg, resume=resume)


def recorded_without_checkpoint(cfg: TrainConfig, run_dir: Path, *, auto: bool) -> int | None:
    """Frames a ``resume=auto`` run directory records in ``metrics.csv`` with no checkpoint.

    Such a run (a committed study run in a fresh clone) is never trained over: a
    finished one is left as it is, an unfinished one is refused. ``auto``: whether the
    config as given asked for ``resume=auto`` (``cfg`` has it resolved).

    Raises:
        ResumeError: the record stops short of ``algo.max_steps``.
    """
    if not auto or cfg.resume is not None:
        return None
    frames = recorded_frames(run_dir / METRICS_FILE)
    if frames is None or frames >= cfg.algo.max_steps:
        return frames
    raise ResumeError(
        f"resume=auto: {shown(run_dir)} records {frames:,} of algo.max_steps="
        f"{cfg.algo.max_steps:,} frames in {METRICS_FILE} but holds no checkpoint to "
        "continue from; a fresh run would overwrite that record. Move or delete the "
        "directory to train the run again from the start"
    )


def preflight(cfg: TrainConfig) -> dict[str, Any] | None:
    """Check everything that can fail before a file is written (``cfg.resume`` resolved);
    the loaded and checked checkpoint of ``cfg.resume``, ``None`` for a fresh run.

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


def checked(config: DictConfig, run_dir: Path, *, fresh: bool = False) -> Start:
    """The checked start of a composed ``config`` in ``run_dir``, its directory locked.

    The result is kept until the next check of the same config and directory, which
    returns it without loading the checkpoint again; ``fresh`` checks anew (the first
    check of a start). A start that will train takes ``run_dir``'s lock on rank 0.

    Raises:
        ConfigError, ResumeError: as :func:`preflight`.
        OmegaConfBaseException: a value of the wrong type (the schema's check).
        RunDirInUse: another process trains in ``run_dir``.
    """
    global _latest
    train_cfg: TrainConfig = task_config(config)
    cfg = resolve_resume(train_cfg, run_dir)
    key = os.path.abspath(run_dir)
    if not fresh and _latest is not None and _latest[0] == key and _latest[1].cfg == cfg:
        return _latest[1]
    _latest = None  # a failed check keeps no earlier start
    recorded = recorded_without_checkpoint(cfg, run_dir, auto=train_cfg.resume == RESUME_AUTO)
    start = Start(cfg, preflight(cfg), recorded)
    if start.finished_message() is None and launched_rank() == 0:
        lock_run_dir(Path(shown(run_dir)))  # as shown: the path the error names
    _latest = (key, start)
    return start


def take_checked(config: DictConfig, run_dir: Path) -> Start:
    """:func:`checked`, for the job that starts: the kept check is taken, not kept."""
    start = checked(config, run_dir)
    forget_checked()
    return start


def forget_checked() -> None:
    """Drop the kept check (and the checkpoint it holds)."""
    global _latest
    _latest = None
