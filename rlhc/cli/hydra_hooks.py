"""What ``conf/train.yaml`` and ``conf/evaluate.yaml`` name: callbacks and two resolvers.

| name in ``conf/<config>.yaml`` | here | answers |
|---|---|---|
| ``hydra.callbacks.preflight`` of ``train`` | :class:`Preflight` | checks a single run before Hydra creates its directory |
| ``hydra.callbacks.preflight`` of ``evaluate`` | :class:`EvaluatePreflight` | checks a single evaluation (values, players) before Hydra creates its directory |
| ``${rlhc.run_dir:…}`` (``hydra.run.dir``) | :func:`run_directory` | a resume continues in the resumed run's directory |
| ``${rlhc.output_subdir:…}`` (``hydra.output_subdir``) | :func:`output_subdir` | a multirun job that will not train gets no ``.hydra/`` |

The resolvers are registered when this module is imported.
"""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Any

from hydra.core.hydra_config import HydraConfig
from hydra.experimental.callback import Callback
from hydra.types import RunMode
from omegaconf import DictConfig, OmegaConf

from rlhc.cli.report import HYDRA_USER_ERRORS
from rlhc.cli.start import checked, task_config
from rlhc.config.evaluate_schema import EvaluateConfig
from rlhc.config.train_schema import RESUME_AUTO
from rlhc.errors import EnvError
from rlhc.evaluation.commands import check_evaluation
from rlhc.storage.checkpoint import ResumeError, run_dir_of
from rlhc.storage.run_lock import RunDirInUse

#: Errors a user fixes by changing the command line of ``rlhc.run`` (or by waiting).
USER_ERRORS: tuple[type[BaseException], ...] = (
    *HYDRA_USER_ERRORS,
    EnvError,
    ResumeError,
    RunDirInUse,
)


class PreflightFailed(BaseException):
    """A user error found by a callback, carried past Hydra to the entry point's ``cli``
    (a ``BaseException``: Hydra turns a callback's ``Exception`` into a warning)."""

    def __init__(self, error: BaseException) -> None:
        super().__init__(str(error))
        self.error = error


class Preflight(Callback):
    """Hydra callback: check a single run (:func:`rlhc.cli.start.checked`) before Hydra
    creates its directory.

    A finished run ends here (exit 0) without writing anything; a user error reaches
    :func:`rlhc.run.cli` as :class:`PreflightFailed`. The check is kept for the job.
    """

    def on_run_start(self, config: DictConfig, **kwargs: Any) -> None:
        # As Hydra does first thing for the job: ``hydra.run.dir`` may read it.
        HydraConfig.instance().set_config(config)
        try:
            start = checked(config, Path(str(config.hydra.run.dir)), fresh=True)
        except USER_ERRORS as error:
            raise PreflightFailed(error) from error
        message = start.finished_message()
        if message is not None:
            print(message, flush=True)
            sys.exit(0)


class EvaluatePreflight(Callback):
    """Hydra callback: check a single evaluation (values and players) before Hydra creates
    its directory; a user error reaches :func:`rlhc.evaluate.cli` as :class:`PreflightFailed`.
    """

    def on_run_start(self, config: DictConfig, **kwargs: Any) -> None:
        HydraConfig.instance().set_config(config)
        try:
            eval_cfg: EvaluateConfig = task_config(config)
            check_evaluation(eval_cfg)
        except HYDRA_USER_ERRORS as error:
            raise PreflightFailed(error) from error


def run_directory(resume: str | None, default: str) -> str:
    """``hydra.run.dir`` (the ``rlhc.run_dir`` resolver): the resumed run's directory, else
    ``default`` (a new one; also for ``resume=auto``). A ``hydra.run.dir=`` override wins.

    Examples:
        >>> run_directory(None, "outputs/new"), run_directory("auto", "outputs/new")
        ('outputs/new', 'outputs/new')
    """
    run_dir = run_dir_of(resume) if resume and resume != RESUME_AUTO else None
    return default if run_dir is None else str(run_dir)


def output_subdir(subdir: str, *, _root_: DictConfig) -> str | None:
    """``hydra.output_subdir``: ``subdir``, or ``None`` for a multirun job that will not train.

    The ``rlhc.output_subdir`` resolver. Hydra writes ``.hydra/`` into a multirun job's
    directory before the job starts, with no hook before that: this checks the job
    (:func:`rlhc.cli.start.checked`) so that a finished run's directory, or one a user
    error reaches, stays as it was. ``_root_``: the job's whole config.
    """
    try:
        hydra_cfg = HydraConfig.get()
        if hydra_cfg.mode != RunMode.MULTIRUN:
            return subdir
        start = checked(_root_, Path(hydra_cfg.runtime.output_dir))
    except Exception:  # whatever fails here fails again in main(), which reports it
        return None
    return subdir if start.finished_message() is None else None


def register_resolvers() -> None:
    """Register ``rlhc.run_dir`` and ``rlhc.output_subdir`` with OmegaConf (again: replaced)."""
    OmegaConf.register_new_resolver("rlhc.run_dir", run_directory, replace=True)
    OmegaConf.register_new_resolver("rlhc.output_subdir", output_subdir, replace=True)


register_resolvers()

__all__ = [
    "USER_ERRORS",
    "EvaluatePreflight",
    "Preflight",
    "PreflightFailed",
    "output_subdir",
    "register_resolvers",
    "run_directory",
]
