"""Stopping a run cleanly on SIGINT (Ctrl-C) or SIGTERM (``kill``, a scheduler's stop).

The default reactions end the process wherever it is, losing the frames since the last
checkpoint. Under :class:`StopSignals` the loop finishes the update, writes a checkpoint
and raises :class:`TrainingInterrupted`; a second signal ends the process at once.
"""

from __future__ import annotations

import signal
import threading
from pathlib import Path
from types import FrameType
from typing import Any

#: The signals that stop a run cleanly.
STOP_SIGNALS = (signal.SIGINT, signal.SIGTERM)


class TrainingInterrupted(Exception):
    """Training stopped on signal ``signum`` at ``frames``, saved to ``checkpoint``."""

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

    The first signal restores the previous handlers, so a second one acts as usual. A
    signal ignored on entry (SIGINT under ``nohup``) stays ignored; outside the main
    thread, where Python cannot install handlers, nothing changes.

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

    def __exit__(self, *exc_info: object) -> None:
        self._restore()

    def _handle(self, signum: int, frame: FrameType | None) -> None:
        self.received = signum
        self._restore()

    def _restore(self) -> None:
        for signum, handler in self._previous.items():
            # None: a handler not installed from Python; the default is the best stand-in.
            signal.signal(signum, signal.SIG_DFL if handler is None else handler)
        self._previous.clear()
