"""The one error type of a bad setting, at the bottom of the layers (imports nothing).

Every check of a setting raises :class:`ConfigError`, naming the key, its value and
what is allowed; ``rlhc.run`` reports it in one line (exit 2). The checks themselves
live in :mod:`rlhc.config.validation` (a whole config) and in the network schema
(:class:`rlhc.modules.NetworkConfig`, which networks built without a config use).
"""

from __future__ import annotations


class ConfigError(ValueError):
    """A setting that is not allowed: names the key, the value and what is allowed."""


def allowed(key: str, value: object, what: str) -> ConfigError:
    """The error for ``key=value``, with ``what`` is allowed.

    Examples:
        >>> str(allowed("algo.epochs", 0, "an integer >= 1"))
        'algo.epochs=0; allowed: an integer >= 1'
        >>> str(allowed("league.sampling", "best", "uniform, elo"))
        "league.sampling='best'; allowed: uniform, elo"
    """
    shown = repr(value) if isinstance(value, str) else str(value)
    return ConfigError(f"{key}={shown}; allowed: {what}")


class EnvError(ValueError):
    """An environment that breaks the contract while it runs (an observation that is NaN,
    an agent that leaves mid-episode): names the agent, the step and what is allowed.
    ``rlhc.run`` reports it in one line (exit 2); checkpoints written so far stay."""
