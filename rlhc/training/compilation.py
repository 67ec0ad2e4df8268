"""``compile=true``: the minibatch loss under ``torch.compile``, or eager where torch cannot.

The loss and its backward compile into one graph; Adam's step stays eager, so the
learning-rate schedule and a restored optimiser cost no recompilation. Compiled float
arithmetic is not the eager one to the bit, so a seeded run reproduces exactly only
eagerly: hence ``compile=false`` by default.
"""

from __future__ import annotations

import functools
import logging
import time
from collections.abc import Callable
from typing import ParamSpec, TypeVar

import torch

log = logging.getLogger(__name__)

P = ParamSpec("P")
R = TypeVar("R")


def compile_problem() -> str | None:
    """Why this torch build cannot compile here (``None``: it can).

    Compiles a two-operation function with Inductor, which needs a supported Python and,
    on CPU, a C++ compiler.
    """
    try:
        torch.compile(lambda x: torch.tanh(x) * 2, dynamic=False)(torch.ones(2))
    except Exception as error:  # any failure to compile means: run eagerly
        return f"{type(error).__name__}: {str(error).splitlines()[0] if str(error) else ''}"
    return None


def compiled(fn: Callable[P, R]) -> Callable[P, R]:
    """``torch.compile(fn)``, its first call's seconds logged; or ``fn`` itself, with a
    one-line warning, where :func:`compile_problem` finds that torch cannot compile.

    Examples:
        >>> loss = compiled(trainer.minibatch_loss)  # doctest: +SKIP
    """
    problem = compile_problem()
    name = getattr(fn, "__qualname__", repr(fn))
    if problem is not None:
        log.warning("compile=true, but torch cannot compile here (%s): %s runs eagerly", problem, name)  # fmt: skip
        return fn
    compiled_fn = torch.compile(fn)
    first = True

    @functools.wraps(fn)
    def call(*args: P.args, **kwargs: P.kwargs) -> R:
        nonlocal first
        if not first:
            return compiled_fn(*args, **kwargs)
        first, start = False, time.perf_counter()
        out = compiled_fn(*args, **kwargs)
        log.info("compiled %s: first call %.1f s (compilation included)", name, time.perf_counter() - start)  # fmt: skip
        return out

    return call
