"""``compile=true``: the minibatch loss under ``torch.compile``, or eager where torch cannot.

TorchDynamo traces the loss of every group (actor, critics, fusion, PPO terms, learner
weighting) into one graph and AOTAutograd compiles its backward with it; the optimiser
step stays eager (Adam's ``fused`` kernel, already one kernel over every parameter), so
the learning-rate schedule and a restored optimiser state cost no recompilation.

A compiled loss is not the eager one to the bit: Inductor fuses and reorders float
arithmetic. On a collected batch its losses and gradients match the eager ones to float
rounding (``tests/test_compile.py``); Adam's first steps divide by the root of the
squared gradients, so a parameter whose gradient is near zero can move by up to a
fraction of the learning rate differently (measured after one minibatch: at most
2.8e-6 on soccer at Table 3), and like any perturbation of PPO the runs then diverge.
Hence ``compile=false`` by default: a seeded run is reproducible to the bit only eagerly.
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

    Compiles and runs a two-operation function with the default backend (Inductor),
    which needs, among others, a supported Python version and, on CPU, a C++ compiler.
    """
    try:
        torch.compile(_probe, dynamic=False)(torch.ones(2))
    except Exception as error:  # any failure to compile means: run eagerly
        return f"{type(error).__name__}: {str(error).splitlines()[0] if str(error) else ''}"
    return None


def _probe(x: torch.Tensor) -> torch.Tensor:
    return torch.tanh(x) * 2


def compiled(fn: Callable[P, R]) -> Callable[P, R]:
    """``torch.compile(fn)``, its first call's seconds logged (compilation included); or
    ``fn`` itself, with a one-line warning, where :func:`compile_problem` finds that this
    torch build cannot compile.

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
