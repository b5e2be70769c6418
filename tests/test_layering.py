"""The layering rules of docs/architecture.md, checked from the source's imports."""

from __future__ import annotations

import ast
import graphlib
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def _imports(path: Path) -> set[str]:
    names: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text(), filename=str(path))):
        if isinstance(node, ast.Import):
            names.update(a.name for a in node.names)
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            names.add(node.module)
    return names


@pytest.mark.e2e
def test_generic_code_imports_no_plugin():
    offenders = {str(p.relative_to(ROOT)): sorted(n for n in _imports(p)
                                                   if n.startswith("gearuq_plugins"))
                 for p in (ROOT / "gearuq").rglob("*.py")}
    assert not {k: v for k, v in offenders.items() if v}


def test_plugins_do_not_import_each_other():
    for pkg in (ROOT / "plugins" / "gearuq_plugins").iterdir():
        if not pkg.is_dir() or pkg.name.startswith("__"):
            continue
        for path in pkg.rglob("*.py"):
            others = {n.split(".")[1] for n in _imports(path)
                      if n.startswith("gearuq_plugins.") and n.split(".")[1] != pkg.name}
            assert not others, f"{path.relative_to(ROOT)} imports plugin(s) {sorted(others)}"


def test_studies_use_the_public_api_only():
    """Studies import gearuq and a plugin's top-level public names (to build a model with
    its own force law, say), never a plugin's internal modules or another study."""
    paths = sorted((ROOT / "studies" / "gearuq_studies").glob("*.py"))
    assert len(paths) > 10, paths
    for path in paths:
        text = path.read_text()
        assert "sys.path" not in text, f"{path.name} changes sys.path"
        bad = sorted(n for n in _imports(path) if n.startswith("gearuq_studies")
                     or (n.startswith("gearuq_plugins") and n.count(".") > 1))
        assert not bad, f"{path.name} imports {bad} (use the plugin's public names)"


# ---------------------------------------------------------------- floors and cycles of gearuq/
def _runtime_imports(path: Path, package: str) -> set[str]:
    """Every gearuq module name ``path`` may import at run time: function-level imports
    count (they only defer an arrow), ``if TYPE_CHECKING:`` blocks do not (never run)."""
    tree = ast.parse(path.read_text(), filename=str(path))
    typing_only = {id(n) for node in ast.walk(tree)
                   if isinstance(node, ast.If) and "TYPE_CHECKING" in ast.unparse(node.test)
                   for n in ast.walk(node)}
    found: set[str] = set()
    for node in ast.walk(tree):
        if id(node) in typing_only:
            continue
        if isinstance(node, ast.Import):
            found.update(a.name for a in node.names)
        elif isinstance(node, ast.ImportFrom):
            parts = package.split(".")
            base = ".".join(parts[:len(parts) - node.level + 1] + [node.module or ""]).strip(".") \
                if node.level else node.module or ""
            found.add(base)
            found.update(f"{base}.{a.name}" for a in node.names)  # a submodule by name
    return {n for n in found if n == "gearuq" or n.startswith("gearuq.")}


def _gearuq_import_graph() -> dict[str, set[str]]:
    """Module -> the gearuq modules it imports (a package by its ``__init__``); an import of
    one's own parent package is left out, since Python runs the parent first anyway."""
    modules = {}
    for path in (ROOT / "gearuq").rglob("*.py"):
        parts = path.relative_to(ROOT).with_suffix("").parts
        modules[".".join(parts[:-1] if parts[-1] == "__init__" else parts)] = path
    graph = {}
    for name, path in modules.items():
        package = name if path.name == "__init__.py" else name.rpartition(".")[0]
        graph[name] = {m for m in _runtime_imports(path, package)
                       if m in modules and m != name and not name.startswith(m + ".")}
    return graph


def _room(module: str) -> str:
    """The room of a module: the package or module right under gearuq/."""
    return module.split(".")[1] if "." in module else "__init__"


def _cycle(graph: dict[str, set[str]]) -> tuple[str, ...]:
    try:
        graphlib.TopologicalSorter(graph).prepare()
    except graphlib.CycleError as err:
        return tuple(err.args[1])
    return ()


@pytest.mark.e2e
def test_no_import_cycle_in_gearuq_modules():
    graph = _gearuq_import_graph()
    assert len(graph) > 100 and sum(map(len, graph.values())) > 300  # the graph was read
    assert _cycle(graph) == ()


@pytest.mark.e2e
def test_no_arrow_climbs_back_up_between_rooms_of_gearuq():
    """The rooms of gearuq/ (engines, failure, execution, runs, ...) stand on floors: an
    arrow from a room to one that imports it back is a cycle of rooms."""
    rooms: dict[str, set[str]] = {}
    for module, imported in _gearuq_import_graph().items():
        rooms.setdefault(_room(module), set()).update(
            _room(m) for m in imported if _room(m) != _room(module))
    assert {"engines", "failure", "runs"} <= set(rooms["design"]) | set(rooms["engines"])
    assert _cycle(rooms) == ()
    # the run context is the floor both estimator wings share, and neither climbs to the other
    assert "runs" in rooms["engines"] and "runs" in rooms["failure"]
    assert "engines" not in rooms["failure"]
