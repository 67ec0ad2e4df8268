"""The TensorDict keys, re-exported from :mod:`rlhc.envs.keys` where they are defined.

Kept so that ``from rlhc.modules import keys`` keeps working; new code imports
:mod:`rlhc.envs.keys`.
"""

from __future__ import annotations

from rlhc.envs.keys import *  # noqa: F403
from rlhc.envs.keys import __all__ as __all__
