"""rlhc uses only the public API of TorchRL and tensordict: losses, value estimators,
modules, environments, transforms and collectors.

A private name (leading underscore) of either library may change in any release, which
is why the ``torchrl`` pin used to be narrow. This test reads every module under
``rlhc/`` with :mod:`ast` and fails on:

* an import of a private module or name, e.g. ``from torchrl.x import _y``,
  ``import torchrl._utils``, ``from torchrl._utils import logger``;
* a use of a private attribute of TorchRL's losses, value estimators, environments,
  transforms, collectors or tensordict's modules: any underscore name that these classes define (read from the installed
  classes, so the list follows the library), plus a deny-list of private instance
  attributes and helpers (``_has_critic``, ``_value_estimator``, ``critic_network_params``,
  ``_self_set_grad_enabled``, ...), whether read, called, overridden by a ``def`` or
  named in ``getattr``/``setattr``/``hasattr``;
* a write into an object's ``__dict__`` (which bypasses ``torch.nn.Module``'s
  bookkeeping, the trick TorchRL uses internally for borrowed networks).

Defining (and naming, within its class) a nested ``_AcceptedKeys`` dataclass is
allowed: it is the extension point that ``LossModule``'s documentation prescribes for
configurable keys. Reaching a library's own, ``ClipPPOLoss._AcceptedKeys``, is not
(``ClipPPOLoss.default_keys`` is the same class under a public name).
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest
import torch
from tensordict.nn import (
    ProbabilisticTensorDictSequential,
    TensorDictModule,
    TensorDictModuleBase,
    TensorDictSequential,
)
from torchrl.collectors import Collector
from torchrl.envs import Compose, EnvBase, Transform, TransformedEnv, VecNormV2
from torchrl.objectives import ClipPPOLoss, LossModule, PPOLoss
from torchrl.objectives.value import GAE, MultiAgentGAE, ValueEstimatorBase

import rlhc

LIBRARIES = ("torchrl", "tensordict")
RLHC_ROOT = Path(rlhc.__file__).parent

#: Private instance attributes and module-level helpers of TorchRL that ``dir()`` of
#: the classes does not show, with why each one must not be used.
DENY_LIST: dict[str, str] = {
    "_loc": "VecNormV2's private running mean (use loc / get_extra_state)",
    "_var": "VecNormV2's private running second moment (use scale / get_extra_state)",
    "_count": "VecNormV2's private observation count (use get_extra_state)",
    "_has_critic": "PPOLoss's private critic switch (set critic_coeff instead)",
    "_value_estimator": "LossModule's private slot (use make_value_estimator / value_estimator)",
    "_tensor_keys": "private key store (use set_keys / tensor_keys)",
    "_out_keys": "PPOLoss's private out_keys cache (use the out_keys property)",
    "_in_keys": "PPOLoss's private in_keys cache (use the in_keys property)",
    "_entropy_coeff_map": "PPOLoss's private per-head entropy coefficients",
    "_has_update_associated": "LossModule's private target-updater bookkeeping",
    "_self_set_grad_enabled": "TorchRL's private estimator decorator",
    "_self_set_skip_existing": "TorchRL's private estimator decorator",
    "critic_network_params": "the loss's functional parameter container (an implementation detail)",
    "actor_network_params": "the loss's functional parameter container (an implementation detail)",
    "target_critic_network_params": "the loss's functional parameter container",
    "target_actor_network_params": "the loss's functional parameter container",
}

#: Classes whose underscore members are private to TorchRL / tensordict.
LIBRARY_CLASSES = (
    LossModule,
    PPOLoss,
    ClipPPOLoss,
    ValueEstimatorBase,
    GAE,
    MultiAgentGAE,
    TensorDictModuleBase,
    TensorDictModule,
    TensorDictSequential,
    ProbabilisticTensorDictSequential,
    EnvBase,
    TransformedEnv,
    Transform,
    Compose,
    VecNormV2,
    Collector,
)

#: Documented extension points that happen to start with an underscore: a loss's
#: configurable keys, and the hooks that TorchRL's docs tell a custom environment
#: (``_reset``, ``_step``, ``_set_seed``) and a custom transform (``_apply_transform``,
#: ``_call``, ``_reset``, ``_step``, their inverses) to define. Defining them is allowed;
#: reading or calling them is not.
ALLOWED_DEFINITIONS = frozenset(
    {
        "_AcceptedKeys",
        "_reset",
        "_step",
        "_set_seed",
        "_apply_transform",
        "_inv_apply_transform",
        "_call",
        "_inv_call",
    }
)


def library_private_names() -> dict[str, str]:
    """Every private member the library classes add to ``torch.nn.Module``, with a reason."""
    module_names = set(dir(torch.nn.Module))
    names = dict(DENY_LIST)
    for cls in LIBRARY_CLASSES:
        for name in dir(cls):
            if name.startswith("_") and not name.endswith("__") and name not in module_names:
                names.setdefault(name, f"a private member of {cls.__module__}.{cls.__qualname__}")
    return names


PRIVATE_NAMES = library_private_names()


def is_private_path(dotted: str) -> bool:
    """``"torchrl.objectives._utils"`` -> True: a component starts with an underscore."""
    return any(part.startswith("_") for part in dotted.split("."))


def violations(source: str, filename: str = "<source>") -> list[str]:
    """The private-API uses of TorchRL / tensordict in ``source``, one message each.

    Examples:
        >>> violations("from torchrl.objectives.value.advantages import _self_set_grad_enabled")
        ["<source>:1: imports private name '_self_set_grad_enabled' from torchrl.objectives.value.advantages"]
        >>> violations("from torchrl.objectives import ClipPPOLoss")
        []
    """
    found = []
    for node in ast.walk(ast.parse(source, filename)):
        where = f"{filename}:{getattr(node, 'lineno', '?')}"
        if isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            if node.module.split(".")[0] in LIBRARIES:
                if is_private_path(node.module):
                    found.append(f"{where}: imports from private module {node.module}")
                for alias in node.names:
                    if alias.name.startswith("_"):
                        found.append(
                            f"{where}: imports private name {alias.name!r} from {node.module}"
                        )
        elif isinstance(node, ast.Import):
            for alias in node.names:
                if alias.name.split(".")[0] in LIBRARIES and is_private_path(alias.name):
                    found.append(f"{where}: imports private module {alias.name}")
        elif isinstance(node, ast.Attribute) and node.attr in PRIVATE_NAMES:
            found.append(f"{where}: uses .{node.attr} ({PRIVATE_NAMES[node.attr]})")
        elif (
            isinstance(node, ast.Name)
            and node.id in PRIVATE_NAMES
            # a bare ``_AcceptedKeys`` is the class's own nested definition
            and node.id not in ALLOWED_DEFINITIONS
        ):
            found.append(f"{where}: uses {node.id} ({PRIVATE_NAMES[node.id]})")
        elif isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
            if node.name in PRIVATE_NAMES and node.name not in ALLOWED_DEFINITIONS:
                found.append(f"{where}: overrides {node.name} ({PRIVATE_NAMES[node.name]})")
        elif isinstance(node, ast.Call) and isinstance(node.func, ast.Name):
            if node.func.id in ("getattr", "setattr", "hasattr", "delattr") and len(node.args) > 1:
                name = node.args[1]
                if isinstance(name, ast.Constant) and name.value in PRIVATE_NAMES:
                    found.append(
                        f"{where}: {node.func.id}(..., {name.value!r}) "
                        f"({PRIVATE_NAMES[name.value]})"
                    )
        elif (
            isinstance(node, ast.Subscript)
            and isinstance(node.ctx, ast.Store)
            and isinstance(node.value, ast.Attribute)
            and node.value.attr == "__dict__"
        ):
            found.append(f"{where}: writes into __dict__ (bypasses torch.nn.Module)")
    return found


def rlhc_sources() -> list[Path]:
    return sorted(RLHC_ROOT.rglob("*.py"))


def test_rlhc_uses_only_public_torchrl_and_tensordict_api() -> None:
    sources = rlhc_sources()
    assert RLHC_ROOT / "objectives" / "ppo.py" in sources
    found = [
        message
        for path in sources
        for message in violations(path.read_text(), str(path.relative_to(RLHC_ROOT.parent)))
    ]
    assert not found, "private TorchRL / tensordict API used:\n" + "\n".join(found)


def test_the_private_names_include_those_rlhc_once_used() -> None:
    for name in (
        "_reduce_loss",
        "_has_critic",
        "_get_time_dim",
        "_self_set_grad_enabled",
        "_self_set_skip_existing",
        "_forward_value_estimator_keys",
        "critic_network_params",
    ):
        assert name in PRIVATE_NAMES, name


@pytest.mark.parametrize(
    ("source", "expected"),
    [
        ("from torchrl.objectives.value.advantages import _self_set_skip_existing", "private name"),
        ("from torchrl._utils import logger", "private module torchrl._utils"),
        ("from tensordict._td import TensorDict", "private module tensordict._td"),
        ("import torchrl._utils", "private module torchrl._utils"),
        ("import tensordict._C as c", "private module tensordict._C"),
        ("loss = self._reduce_loss(x, td)", "uses ._reduce_loss"),
        ("self._has_critic = False", "uses ._has_critic"),
        ("t = self._get_time_dim(None, td)", "uses ._get_time_dim"),
        ("self._forward_value_estimator_keys()", "uses ._forward_value_estimator_keys"),
        ("p = loss.critic_network_params", "uses .critic_network_params"),
        ("est = getattr(loss, '_value_estimator', None)", "getattr(..., '_value_estimator')"),
        ("self.__dict__['net'] = net", "writes into __dict__"),
        (
            "class L(ClipPPOLoss):\n    def _forward_value_estimator_keys(self): pass",
            "overrides _forward_value_estimator_keys",
        ),
        ("@_self_set_grad_enabled\ndef f(self): pass", "uses _self_set_grad_enabled"),
        ("class K(ClipPPOLoss._AcceptedKeys): pass", "uses ._AcceptedKeys"),
        ("class N(VecNormV2):\n    def _norm(self, data): pass", "overrides _norm"),
        ("scale = norm._get_loc_scale()", "uses ._get_loc_scale"),
        ("loc = norm._loc", "uses ._loc"),
        ("out = env.transform._step(td, next_td)", "uses ._step"),
        ("collector._increment_frames(n)", "uses ._increment_frames"),
    ],
)
def test_the_checker_flags(source: str, expected: str) -> None:
    found = violations(source)
    assert any(expected in message for message in found), found


@pytest.mark.parametrize(
    "source",
    [
        "from torchrl.objectives import ClipPPOLoss, ValueEstimators",
        "from tensordict.nn import TensorDictModuleBase, set_skip_existing",
        "class L(ClipPPOLoss):\n    class _AcceptedKeys(ClipPPOLoss.default_keys): pass",
        "self._critics = (worker, manager)",
        "from rlhc.objectives.value import FusedValue",
        "loss.make_value_estimator(estimator)",
        "class T(Transform):\n    def _step(self, td, next_td): return next_td",
        "class E(EnvBase):\n    def _set_seed(self, seed): pass",
        "state = transform.get_extra_state()",
    ],
)
def test_the_checker_passes_public_use(source: str) -> None:
    assert violations(source) == []
