"""The import picture: stages import only downward, the CLI only the workflows floor, other floors reach `cosim`,
`fmu` and `vehicle` only through their faces, and no module imports itself back through a circle; HTML pages come from
one writer (docs/architecture.md states the same rules)."""

from __future__ import annotations

import ast
import functools
import graphlib
import importlib
import subprocess
import sys
from pathlib import Path

PACKAGE = Path(__file__).resolve().parents[1] / "nnfmu"

# Floors, lowest first: a module may import its own top-level package and any package on a lower floor.
FLOORS: tuple[tuple[str, ...], ...] = (
    ("errors", "stopping", "input_files", "faces"),
    ("atomic", "safe_zip", "resources", "physics", "component", "kinds"),
    ("out_paths", "reference_stimulus", "reports"),
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
# Packages other floors import only through their `__init__` (the face: `from nnfmu.cosim import cosimulate`).
FACES = ("cosim", "fmu", "vehicle")


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


def test_other_floors_import_the_faced_packages_only_through_their_faces() -> None:
    """`from nnfmu.cosim import cosimulate`, never `from nnfmu.cosim.master import ...`, outside the package (imports
    for annotations count); inside it, its modules import each other, never its face (that would be a circle)."""
    wrong = []
    for name, targets in all_modules(typing=True).items():
        for target in targets:
            part = top(target)
            if part in FACES and part != top(name) and target != f"nnfmu.{part}":
                wrong.append(f"{name} -> {target} (import from nnfmu.{part})")
            elif part in FACES and part == top(name) and target == f"nnfmu.{part}" and name != target:
                wrong.append(f"{name} -> {target} (inside the package: import the module)")
    assert not wrong, "imports past a face:\n" + "\n".join(sorted(wrong))


def test_the_face_check_sees_an_internal_import() -> None:
    """A guard on the walk: internal modules of a faced package are imported, from inside it."""
    assert "nnfmu.cosim.direct" in all_modules()["nnfmu.cosim.master"]


# Every name of every face resolves, and the whole of them loads no torch (building and running FMUs never does):
# in a fresh interpreter, so the names this test process imported before cannot hide a wrong home.
FACE_SCRIPT = """
import importlib, sys
for package in sys.argv[1:]:
    face = importlib.import_module(package)
    for name in face.__all__:
        getattr(face, name)
assert "torch" not in sys.modules, "a face imported torch"
"""
# Importing the faces alone: no module of their packages loaded.
BARE_SCRIPT = """
import sys, nnfmu.cosim, nnfmu.fmu, nnfmu.vehicle
print(sorted(m for m in sys.modules if m.count(".") > 1 and m.split(".")[1] in ("cosim", "fmu", "vehicle")))
"""


def test_every_name_of_every_face_resolves_without_torch() -> None:
    faces = [f"nnfmu.{part}" for part in FACES]
    run = subprocess.run([sys.executable, "-c", FACE_SCRIPT, *faces], capture_output=True, text=True)
    assert run.returncode == 0, run.stderr


def test_a_face_loads_its_modules_only_when_a_name_is_asked_for() -> None:
    """The CLI's start-up and an FMU build pay only for what they use."""
    run = subprocess.run([sys.executable, "-c", BARE_SCRIPT], capture_output=True, text=True, check=True)
    assert run.stdout.strip() == "[]", run.stdout


def test_no_public_name_of_a_face_is_also_one_of_its_modules() -> None:
    """Loading a module sets it as its package's attribute, which a lazy face's name of the same spelling would then
    never replace (`from nnfmu.cosim import step_study` gave the module)."""
    for part in FACES:
        face = importlib.import_module(f"nnfmu.{part}")
        clash = [n for n in face.__all__ if (PACKAGE / part / f"{n}.py").exists() or (PACKAGE / part / n).is_dir()]
        assert not clash, f"nnfmu.{part}: public names that are also module names: {clash}"


def test_other_floors_import_the_diagnosis_only_through_its_package() -> None:
    """`nnfmu.diagnosis`'s `__init__` lists what other floors may use (the effect registries, the diagnosis, the
    held-out tests the vehicle loop shares); its modules stay its own."""
    inside = sorted(
        f"{name} -> {target}"
        for name, targets in all_modules().items()
        if top(name) != "diagnosis"
        for target in targets
        if target.startswith("nnfmu.diagnosis.")
    )
    assert not inside, "import nnfmu.diagnosis's public names instead:\n" + "\n".join(inside)


# The one module that makes a jinja2 environment for HTML, and those that make one for other text (FMI XML, C).
HTML_WRITER = "nnfmu.reports.html"
OTHER_TEMPLATES = {"nnfmu.fmu.model_description", "nnfmu.fmu.native.config"}


def html_writers(sources: dict[str, str]) -> list[str]:
    """Modules of `sources` (name -> Python text) that write HTML themselves: one that makes a jinja2 `Environment`
    (other than the report writer and the XML and C generators), or has `<html` or `<!doctype` in a string."""
    found = []
    for name, text in sources.items():
        if name == HTML_WRITER:
            continue
        for node in ast.walk(ast.parse(text)):
            if isinstance(node, ast.Call) and name not in OTHER_TEMPLATES:
                called = node.func.attr if isinstance(node.func, ast.Attribute) else getattr(node.func, "id", "")
                if called == "Environment":
                    found.append(f"{name}: makes a jinja2 Environment")
            if isinstance(node, ast.Constant) and isinstance(node.value, str):
                if "<html" in node.value.lower() or "<!doctype" in node.value.lower():
                    found.append(f"{name}: writes {node.value[:40]!r}")
    return found


def test_html_reports_come_from_the_one_writer() -> None:
    """`nnfmu.reports.html` renders every HTML page (one environment, autoescape, StrictUndefined, atomic writes)
    from the templates in `templates/reports/`; no other module builds a page, and no template lies elsewhere."""
    sources = {module_name(path): path.read_text(encoding="utf-8") for path in sorted(PACKAGE.rglob("*.py"))}
    assert not html_writers(sources), "HTML written outside nnfmu.reports.html:\n" + "\n".join(html_writers(sources))
    templates = [*PACKAGE.rglob("*.html*"), *(PACKAGE.parent / "templates").rglob("*.html*")]
    stray = [str(path) for path in templates if path.parent != PACKAGE.parent / "templates" / "reports"]
    assert not stray, f"HTML templates outside templates/reports/: {stray}"


def test_the_html_check_sees_a_page_built_by_hand() -> None:
    """A guard on the check: a hand-built page and a module of its own environment are found, the writer is not."""
    assert html_writers({"nnfmu.x": "page = '<!DOCTYPE html><html>'"}) == ["nnfmu.x: writes '<!DOCTYPE html><html>'"]
    assert html_writers({"nnfmu.y": "import jinja2\njinja2.Environment()"}) == ["nnfmu.y: makes a jinja2 Environment"]
    assert html_writers({HTML_WRITER: "import jinja2\njinja2.Environment()"}) == []
