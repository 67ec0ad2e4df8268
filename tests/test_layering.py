"""The package's import graph: no cycles, and every import goes down the floors.

The graph is read from the source files with :mod:`ast` (nothing is imported): every
``import`` and ``from … import`` of an ``rlhc`` module, relative ones resolved, at any
depth (a function-level import is still a dependency), except inside
``if TYPE_CHECKING:`` blocks, which only the type checker runs.

The floors are README's "Layout", lowest first (:data:`LAYERS`):

1. ``rlhc.errors``: the one error type (and ``rlhc`` itself, its ``__init__``);
2. ``rlhc.envs``: the games (numpy) and their PettingZoo and TorchRL adapters;
3. ``rlhc.modules``: the networks;
4. ``rlhc.objectives``: the learning core (hierarchical value estimation, PPO);
5. ``rlhc.config``: the settings of both commands, their schemas and checks;
6. ``rlhc.storage``: checkpoint files and the final team (plain dicts and files);
7. ``rlhc.building``: a config turned into env, networks and losses;
8. ``rlhc.evaluation``: matches, Elo, the restored policies and built-in teams;
9. ``rlhc.training``: the loop, which evaluates itself and plays a league;
10. ``rlhc.analysis``: finished runs read back, their curves drawn;
11. ``rlhc.cli``: what the entry points share (one-line errors, Hydra callbacks);
12. the entry points, wiring only: ``rlhc.run``, ``rlhc.evaluate``, ``rlhc.plot``,
    ``rlhc.evaluation.diagnostics.__main__`` (``python -m rlhc.evaluation.diagnostics``)
    and ``rlhc.evaluation.returns.__main__`` (``python -m rlhc.evaluation.returns``).

A module may import its own floor and the floors below it, never one above. Some
neighbours do not import each other at all (``rlhc.storage`` imports no other
``rlhc`` module; ``rlhc.training`` and ``rlhc.analysis`` are independent): their order
is the one the README draws, and holds them to it.
"""

from __future__ import annotations

import ast
import re
from collections.abc import Iterator
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "rlhc"
README = PACKAGE.parent / "README.md"
#: The package itself: its ``__init__`` only (every other module has a floor of its own).
ROOT = "rlhc"
#: README "Layout", lowest floor first: the modules and packages of each floor (a
#: module's floor: the longest of these names it is, or lies under).
LAYERS: tuple[tuple[str, ...], ...] = (
    (ROOT, "rlhc.errors"),
    ("rlhc.envs",),
    ("rlhc.modules",),
    ("rlhc.objectives",),
    ("rlhc.config",),
    ("rlhc.storage",),
    ("rlhc.building",),
    ("rlhc.evaluation",),
    ("rlhc.training",),
    ("rlhc.analysis",),
    ("rlhc.cli",),
    (
        "rlhc.run",
        "rlhc.evaluate",
        "rlhc.plot",
        "rlhc.evaluation.diagnostics.__main__",
        "rlhc.evaluation.returns.__main__",
    ),
)


def module_name(path: Path) -> str:
    """``rlhc/envs/tennis/game.py`` -> ``rlhc.envs.tennis.game`` (packages: no ``__init__``)."""
    parts = path.relative_to(PACKAGE.parent).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def is_type_checking(test: ast.expr) -> bool:
    """Whether an ``if`` test is ``TYPE_CHECKING`` or ``typing.TYPE_CHECKING``."""
    return (isinstance(test, ast.Name) and test.id == "TYPE_CHECKING") or (
        isinstance(test, ast.Attribute) and test.attr == "TYPE_CHECKING"
    )


def runtime_imports(tree: ast.AST) -> Iterator[ast.Import | ast.ImportFrom]:
    """Every import statement of ``tree`` outside ``if TYPE_CHECKING:`` bodies."""
    for node in ast.iter_child_nodes(tree):
        if isinstance(node, ast.If) and is_type_checking(node.test):
            for child in node.orelse:
                yield from runtime_imports(ast.Module(body=[child], type_ignores=[]))
            continue
        if isinstance(node, ast.Import | ast.ImportFrom):
            yield node
        yield from runtime_imports(node)


def imported_modules(
    node: ast.Import | ast.ImportFrom, importer: str, is_package: bool
) -> set[str]:
    """The ``rlhc`` modules one import statement names (relative imports resolved).

    ``from rlhc.envs import keys`` names ``rlhc.envs.keys`` when that is a module, and
    ``rlhc.envs`` otherwise (an attribute of the package).
    """
    if isinstance(node, ast.Import):
        bases = [alias.name for alias in node.names]
        return {resolve(base) for base in bases if base.split(".")[0] == "rlhc"}
    if node.level:
        package = importer.split(".") if is_package else importer.split(".")[:-1]
        anchor = package[: len(package) - (node.level - 1)]
        base = ".".join([*anchor, *([node.module] if node.module else [])])
    else:
        base = node.module or ""
    if base.split(".")[0] != "rlhc":
        return set()
    found = set()
    for alias in node.names:
        candidate = f"{base}.{alias.name}"
        found.add(resolve(candidate) if is_module(candidate) else resolve(base))
    return found


def is_module(name: str) -> bool:
    """Whether ``name`` is a module or package of the source tree."""
    path = PACKAGE.parent.joinpath(*name.split("."))
    return path.with_suffix(".py").is_file() or (path / "__init__.py").is_file()


def resolve(name: str) -> str:
    """The longest prefix of ``name`` that is a module of the source tree."""
    parts = name.split(".")
    while parts and not is_module(".".join(parts)):
        parts.pop()
    return ".".join(parts)


def import_graph() -> dict[str, set[str]]:
    """``module -> the rlhc modules it imports at run time``, for every source file."""
    graph: dict[str, set[str]] = {}
    for path in sorted(PACKAGE.rglob("*.py")):
        name = module_name(path)
        tree = ast.parse(path.read_text(), filename=str(path))
        targets: set[str] = set()
        for node in runtime_imports(tree):
            targets |= imported_modules(node, name, path.name == "__init__.py")
        graph[name] = {target for target in targets if target and target != name}
    return graph


def find_cycle(graph: dict[str, set[str]]) -> list[str] | None:
    """One import cycle of ``graph`` as ``[a, b, …, a]``, or ``None`` (depth-first search)."""
    state: dict[str, int] = {}  # 1: on the current path, 2: finished
    path: list[str] = []

    def visit(node: str) -> list[str] | None:
        state[node] = 1
        path.append(node)
        for target in sorted(graph.get(node, ())):
            if state.get(target) == 1:
                return [*path[path.index(target) :], target]
            if target not in state and (cycle := visit(target)) is not None:
                return cycle
        path.pop()
        state[node] = 2
        return None

    for node in sorted(graph):
        if node not in state and (cycle := visit(node)) is not None:
            return cycle
    return None


def covers(name: str, module: str) -> bool:
    """Whether a floor's ``name`` covers ``module``: it is ``name`` or lies under it."""
    return module == name or (name != ROOT and module.startswith(name + "."))


def layer(module: str) -> int:
    """The index in :data:`LAYERS` of the floor ``module`` is on (its longest name)."""
    matches = [
        (len(name), index)
        for index, floor in enumerate(LAYERS)
        for name in floor
        if covers(name, module)
    ]
    if not matches:
        raise ValueError(f"{module!r} is on none of the floors {LAYERS}")
    return max(matches)[1]


def floor_names(index: int) -> str:
    """A floor's names, for messages: ``rlhc.run, rlhc.evaluate, …``."""
    return ", ".join(LAYERS[index])


def readme_floors() -> list[tuple[str, ...]]:
    """The ``rlhc`` rows of README's "Layout" table, in order, as module names.

    Each row's first cell names its modules and packages in backticks
    (``rlhc/envs/``, ``rlhc/run.py``); rows of other folders (``conf/``, …) are skipped.
    """
    text = README.read_text()
    section = text[text.index("\n## Layout\n") :].split("\n## ")[1]
    floors = []
    for line in section.splitlines():
        cells = line.split("|")
        if len(cells) < 3:
            continue
        paths = re.findall(r"`(rlhc/[^`]*)`", cells[1])
        if paths:
            floors.append(
                tuple(path.rstrip("/").removesuffix(".py").replace("/", ".") for path in paths)
            )
    return floors


def test_the_graph_sees_relative_lazy_and_type_checking_imports() -> None:
    source = (
        "from typing import TYPE_CHECKING\n"
        "from . import physics\n"
        "from .rules import judge\n"
        "if TYPE_CHECKING:\n"
        "    from rlhc.envs.soccer.game import SoccerGame\n"
        "def f():\n"
        "    from rlhc.envs import render\n"
    )
    tree = ast.parse(source)
    found: set[str] = set()
    for node in runtime_imports(tree):
        found |= imported_modules(node, "rlhc.envs.tennis.game", is_package=False)
    assert found == {"rlhc.envs.tennis.physics", "rlhc.envs.tennis.rules", "rlhc.envs.render"}
    assert find_cycle({"a": {"b"}, "b": {"c"}, "c": {"a"}}) == ["a", "b", "c", "a"]
    assert find_cycle({"a": {"b"}, "b": set()}) is None
    modules = ("rlhc.errors", "rlhc.envs.keys", "rlhc.objectives", "rlhc.run", "rlhc")
    assert [layer(m) for m in modules] == [0, 1, 3, len(LAYERS) - 1, 0]
    # The longest name wins: diagnostics are evaluation, their command an entry point.
    assert layer("rlhc.evaluation.diagnostics.soccer") == LAYERS.index(("rlhc.evaluation",))
    assert layer("rlhc.evaluation.diagnostics.__main__") == len(LAYERS) - 1
    # The package's own name covers its __init__ only, never a module without a floor.
    with pytest.raises(ValueError, match="none of the floors"):
        layer("rlhc.somewhere")


def test_no_import_cycle_inside_rlhc() -> None:
    cycle = find_cycle(import_graph())
    assert cycle is None, "import cycle: " + " -> ".join(cycle or [])


def test_every_module_is_on_a_floor_and_every_floor_exists() -> None:
    graph = import_graph()
    homeless = [m for m in graph if not any(covers(n, m) for floor in LAYERS for n in floor)]
    assert not homeless, f"modules on no floor of LAYERS (add them to one): {homeless}"
    missing = [name for floor in LAYERS for name in floor if name not in graph]
    assert not missing, f"floors that name no module of rlhc/: {missing}"


def test_the_readme_layout_draws_these_floors_in_this_order() -> None:
    drawn = readme_floors()
    tested = [tuple(name for name in floor if name != ROOT) for floor in LAYERS]
    assert drawn == tested, (
        "README's Layout table and LAYERS differ; README, lowest first:\n"
        + "\n".join(map(str, drawn))
    )


def test_imports_go_down_the_floors_of_the_readme_layout() -> None:
    upward = [
        f"{module} ({floor_names(layer(module))}) imports {target} ({floor_names(layer(target))})"
        for module, targets in import_graph().items()
        for target in sorted(targets)
        if layer(target) > layer(module)
    ]
    assert not upward, "imports from a lower floor to a higher one:\n" + "\n".join(upward)


def test_the_trainer_reaches_other_processes_only_through_its_strategy() -> None:
    """``rlhc.training.strategies`` holds every cross-process step of the loop: the trainer takes
    only the ``Processes`` record from ``rlhc.training.distributed``, and the modules the trainer
    is built from (strategies, summaries, training state) never import it back."""
    tree = ast.parse((PACKAGE / "training" / "trainer.py").read_text())
    from_distributed = {
        alias.name
        for node in runtime_imports(tree)
        if isinstance(node, ast.ImportFrom) and node.module == "rlhc.training.distributed"
        for alias in node.names
    }
    assert from_distributed == {"Processes"}
    graph = import_graph()
    assert "rlhc.training.distributed" in graph["rlhc.training.strategies"]
    for module in (
        "rlhc.training.strategies",
        "rlhc.training.summaries",
        "rlhc.training.training_state",
    ):
        assert "rlhc.training.trainer" not in graph[module], module
    # The learning core stays below: the loss's cross-process reduce is handed to it.
    assert all(
        not target.startswith("rlhc.training.distributed")
        for module, targets in graph.items()
        if layer(module) == LAYERS.index(("rlhc.objectives",))
        for target in targets
    )
