"""How the entry points talk to a user: a user error in one line, paths as typed.

Every entry point runs its work inside :func:`user_errors_in_one_line`; any error that
is not a user error is a bug and keeps its traceback (exit 1).
"""

from __future__ import annotations

import contextlib
import os
import sys
from collections.abc import Iterator
from pathlib import Path

from hydra.errors import HydraException
from omegaconf.errors import OmegaConfBaseException

from rlhc.errors import ConfigError

#: Exit code of a user error (as argparse's).
USAGE_ERROR = 2
#: The environment variable that shows a user error's traceback (Hydra's own switch).
FULL_ERROR = "HYDRA_FULL_ERROR"
#: User errors of every Hydra entry point: a bad value, an override or composition error.
HYDRA_USER_ERRORS: tuple[type[BaseException], ...] = (
    ConfigError,
    HydraException,
    OmegaConfBaseException,
)


class UsageError(Exception):
    """A command-line mistake that is not a setting (e.g. a path that holds nothing to read)."""


@contextlib.contextmanager
def user_errors_in_one_line(
    program: str, errors: tuple[type[BaseException], ...]
) -> Iterator[None]:
    """Report ``errors`` raised inside as ``<program>: error: <one line>`` and exit 2.

    Hydra lets exceptions through unprinted meanwhile (its switch ``HYDRA_FULL_ERROR=1``);
    if the user set it, ``errors`` propagate with their traceback instead.

    Examples:
        >>> import contextlib, io
        >>> stderr = io.StringIO()
        >>> with contextlib.redirect_stderr(stderr):
        ...     try:
        ...         with user_errors_in_one_line("rlhc.plot", (UsageError,)):
        ...             raise UsageError("no run directory under 'x'")
        ...     except SystemExit as stop:
        ...         print(stop.code)
        2
        >>> stderr.getvalue()
        "rlhc.plot: error: no run directory under 'x'\\n"
    """
    requested = os.environ.get(FULL_ERROR)
    os.environ[FULL_ERROR] = "1"
    try:
        yield
    except errors as error:
        if requested == "1":
            raise
        print(f"{program}: error: {one_line(error)}", file=sys.stderr)
        sys.exit(USAGE_ERROR)
    finally:
        if requested is None:
            os.environ.pop(FULL_ERROR, None)
        else:
            os.environ[FULL_ERROR] = requested


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


def shown(path: Path) -> str:
    """``path`` relative to the working directory when inside it, else absolute.

    Examples:
        >>> shown(Path.cwd() / "outputs" / "run")
        'outputs/run'
    """
    absolute = Path(os.path.abspath(path))
    try:
        return str(absolute.relative_to(Path.cwd()))
    except ValueError:
        return str(absolute)
