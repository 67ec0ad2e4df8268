"""Stopping a run cleanly on SIGINT (Ctrl-C) or SIGTERM (``kill``, a scheduler's stop).

The default reactions end the process wherever it is: a ``KeyboardInterrupt`` raised
inside TorchRL's collector (which then fails on its half-written TensorDicts) or an
immediate exit that loses the frames since the last checkpoint. While
:class:`StopSignals` is active, either signal only records that a stop was asked for;
the training loop finishes the update in progress, writes a checkpoint and raises
:class:`TrainingInterrupted`, and ``rlhc.run`` exits ``128 + signal`` (130 / 143),
as a shell reports a process ended by that signal.

A second signal is not intercepted: it ends the process at once, as it would have
without :class:`StopSignals` (the checkpoints written so far are complete, see
:mod:`rlhc.storage.checkpoint`).
"""

from __future__ import annotations

import signal
import threading
from pathlib import Path
from types import FrameType, TracebackType
from typing import Any

#: The signals that stop a run cleanly.
STOP_SIGNALS = (signal.SIGINT, signal.SIGTERM)


class TrainingInterrupted(Exception):
    """Training stopped on a signal after saving a checkpoint.

    Args:
        signum: the signal received.
        frames: world-decisions trained when it stopped.
        checkpoint: the checkpoint just written (or the one already written at
            ``frames``).
    """

    def __init__(self, signum: int, frames: int, checkpoint: Path) -> None:
        self.signum = signum
        self.frames = frames
        self.checkpoint = checkpoint
        super().__init__(f"{self.signal_name} at {frames} frames; checkpoint {checkpoint}")

    @property
    def signal_name(self) -> str:
        return signal.Signals(self.signum).name

    @property
    def exit_code(self) -> int:
        """``128 + signal``: 130 for SIGINT, 143 for SIGTERM."""
        return 128 + self.signum


class StopSignals:
    """While active (``with``), SIGINT and SIGTERM set :attr:`received` instead of acting.

    The first signal restores the previous handlers, so a second one acts as usual
    (Ctrl-C twice: ``KeyboardInterrupt`` at once). A signal that was ignored when the
    block was entered (e.g. SIGINT of a job started with ``nohup`` or ``&``) stays
    ignored. Outside the main thread, where Python cannot install handlers, nothing
    changes and :attr:`received` stays ``None``.

    Examples:
        >>> with StopSignals() as stop:
        ...     while stop.received is None:
        ...         break  # one unit of work per check
    """

    def __init__(self) -> None:
        self.received: int | None = None
        self._previous: dict[int, Any] = {}

    def __enter__(self) -> StopSignals:
        if threading.current_thread() is threading.main_thread():
            for signum in STOP_SIGNALS:
                if signal.getsignal(signum) is not signal.SIG_IGN:
                    self._previous[signum] = signal.signal(signum, self._handle)
        return self

    def __exit__(
        self,
        kind: type[BaseException] | None,
        error: BaseException | None,
        traceback: TracebackType | None,
    ) -> None:
        self._restore()

    def _handle(self, signum: int, frame: FrameType | None) -> None:
        self.received = signum
        self._restore()

    def _restore(self) -> None:
        for signum, handler in self._previous.items():
            # None: a handler not installed from Python; the default is the best stand-in.
            signal.signal(signum, signal.SIG_DFL if handler is None else handler)
        self._previous.clear()
