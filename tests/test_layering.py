"""The package's import graph: no cycles, and every import goes down the layers.

The graph is read from the source files with :mod:`ast` (nothing is imported): every
``import`` and ``from … import`` of an ``rlhc`` module, relative ones resolved, at any
depth (a function-level import is still a dependency), except inside
``if TYPE_CHECKING:`` blocks, which only the type checker runs.

The layers are README's "Layout", lowest first: ``rlhc.envs`` (the games, numpy and
the adapters), ``rlhc.modules`` (networks), ``rlhc.objectives`` (the learning core),
then everything else in ``rlhc`` (trainer, configs, evaluation, …); below them all,
``rlhc.errors``, which imports nothing. A module may import its own layer and the
layers below it, never one above.
"""

from __future__ import annotations

import ast
from collections.abc import Iterator
from pathlib import Path

PACKAGE = Path(__file__).resolve().parents[1] / "rlhc"
#: README "Layout", lowest layer first (a module's layer: the longest prefix it has).
LAYERS = ("rlhc.errors", "rlhc.envs", "rlhc.modules", "rlhc.objectives", "rlhc")


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


def layer(module: str) -> int:
    """The index in :data:`LAYERS` of the layer ``module`` belongs to (longest prefix)."""
    matches = [
        (len(prefix), index)
        for index, prefix in enumerate(LAYERS)
        if module == prefix or module.startswith(prefix + ".")
    ]
    if not matches:
        raise ValueError(f"{module!r} is in none of the layers {LAYERS}")
    return max(matches)[1]


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
    assert [layer(m) for m in ("rlhc.errors", "rlhc.envs.keys", "rlhc.objectives", "rlhc.run")] == [
        0,
        1,
        3,
        4,
    ]


def test_no_import_cycle_inside_rlhc() -> None:
    cycle = find_cycle(import_graph())
    assert cycle is None, "import cycle: " + " -> ".join(cycle or [])


def test_imports_go_down_the_layers_of_the_readme_layout() -> None:
    upward = [
        f"{module} ({LAYERS[layer(module)]}) imports {target} ({LAYERS[layer(target)]})"
        for module, targets in import_graph().items()
        for target in sorted(targets)
        if layer(target) > layer(module)
    ]
    assert not upward, "imports from a lower layer to a higher one:\n" + "\n".join(upward)


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
        if layer(module) == LAYERS.index("rlhc.objectives")
        for target in targets
    )
