"""The import picture: stages import only downward, the CLI only the workflows floor, and no module imports itself
back through a circle (docs/architecture.md states the same rules)."""

from __future__ import annotations

import ast
import functools
import graphlib
from pathlib import Path

PACKAGE = Path(__file__).resolve().parents[1] / "nnfmu"

# Floors, lowest first: a module may import its own top-level package and any package on a lower floor.
FLOORS: tuple[tuple[str, ...], ...] = (
    ("errors", "stopping", "input_files"),
    ("atomic", "safe_zip", "resources", "physics", "component"),
    ("out_paths", "reference_stimulus"),
    ("data",),
    ("models",),
    ("export",),
    ("control",),
    ("fmu",),
    ("vehicle",),
    ("cosim",),
    ("validate",),
    ("diagnosis",),
    ("workflows",),
    ("cli",),
)
FLOOR = {name: level for level, names in enumerate(FLOORS) for name in names}
# What the CLI may import besides the workflows floor: the error base it catches, the output-path checks and the
# stop request its signal handler records.
CLI_ALLOWED = {"workflows", "errors", "out_paths", "stopping"}


def module_name(path: Path) -> str:
    parts = path.relative_to(PACKAGE.parent).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _runtime_nodes(tree: ast.AST) -> list[ast.AST]:
    """Every node of `tree` except those under `if TYPE_CHECKING:` (annotations only, never imported at run time)."""
    nodes, stack = [], [tree]
    while stack:
        node = stack.pop()
        nodes.append(node)
        for child in ast.iter_child_nodes(node):
            if isinstance(child, ast.If) and isinstance(child.test, ast.Name) and child.test.id == "TYPE_CHECKING":
                stack.extend(child.orelse)
            else:
                stack.append(child)
    return nodes


def imports(path: Path, typing: bool = False) -> set[str]:
    """Every nnfmu module `path` imports at run time, at any depth of its code (imports inside functions count);
    with `typing`, those under `if TYPE_CHECKING:` too."""
    name = module_name(path)
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    found: set[str] = set()
    tree = ast.parse(path.read_text(encoding="utf-8"))
    for node in ast.walk(tree) if typing else _runtime_nodes(tree):
        if isinstance(node, ast.Import):
            found |= {alias.name for alias in node.names if alias.name.split(".")[0] == "nnfmu"}
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")[: len(package.split(".")) - node.level + 1]
                target = ".".join(base + ([node.module] if node.module else []))
            else:
                target = node.module or ""
            if target.split(".")[0] == "nnfmu":
                found.add(target)
    return found


def top(module: str) -> str:
    """The top-level part of an nnfmu module name: `nnfmu.data.rigs` -> `data`, `nnfmu` -> ``."""
    parts = module.split(".")
    return parts[1] if len(parts) > 1 else ""


@functools.cache
def all_modules(typing: bool = False) -> dict[str, set[str]]:
    return {module_name(path): imports(path, typing) for path in sorted(PACKAGE.rglob("*.py"))}


def test_every_top_level_part_has_a_floor() -> None:
    parts = {top(name) for name in all_modules()} - {""}
    assert parts <= set(FLOOR), f"give these a floor in FLOORS and docs/architecture.md: {sorted(parts - set(FLOOR))}"


def test_stages_import_only_downward() -> None:
    upward = []
    for name, targets in all_modules().items():
        source = top(name)
        for target in targets:
            part = top(target)
            if source and part and part != source and FLOOR[part] >= FLOOR[source]:
                upward.append(f"{name} -> {target}")
    assert not upward, "imports running up or sideways:\n" + "\n".join(sorted(upward))


def test_the_cli_imports_only_the_workflows_floor() -> None:
    outside = sorted(t for t in all_modules()["nnfmu.cli"] if top(t) not in CLI_ALLOWED)
    assert not outside, f"nnfmu/cli.py imports past the workflows floor: {outside}"


def circles(modules: dict[str, set[str]]) -> str | None:
    """One import circle among `modules` (name -> the nnfmu modules it imports), as `a -> b -> a`; None if none."""
    graph: dict[str, set[str]] = {}
    for name, targets in modules.items():
        for target in targets:
            # `from nnfmu.x import y` names a module or a name in nnfmu.x: keep the longest prefix that is a module
            while target not in modules and "." in target:
                target = target.rpartition(".")[0]
            # a package's __init__ re-exporting its own modules, and a module reaching its parents, are not circles
            if target != name and not name.startswith(target + ".") and not target.startswith(name + "."):
                graph.setdefault(name, set()).add(target)
    try:
        tuple(graphlib.TopologicalSorter(graph).static_order())
    except graphlib.CycleError as error:
        return " -> ".join(error.args[1])
    return None


def test_no_module_imports_itself_back_through_a_circle() -> None:
    """Imports for annotations only (`if TYPE_CHECKING:`) count: a module reading another's types while that one
    imports it is the same knot, only hidden from the interpreter."""
    circle = circles(all_modules(typing=True))
    assert circle is None, f"import circle: {circle}"


def test_the_circle_check_sees_a_circle() -> None:
    """A guard on the check: a circle through an annotation-only import is found, a package re-exporting its own
    module is not one."""
    assert circles({"nnfmu.a.x": {"nnfmu.a.y"}, "nnfmu.a.y": {"nnfmu.a.x"}}) is not None
    assert circles({"nnfmu.a": {"nnfmu.a.x"}, "nnfmu.a.x": {"nnfmu.a"}}) is None


def test_the_checker_sees_an_upward_import() -> None:
    """A guard on the walk: the CLI's imports of the workflows floor are found (an empty walk would pass all)."""
    assert any(top(t) == "workflows" for t in all_modules()["nnfmu.cli"])
    assert any(top(t) == "data" for t in all_modules()["nnfmu.models.train"])
