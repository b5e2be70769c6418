"""The layering rules of docs/architecture.md, checked from the source's imports."""

from __future__ import annotations

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def _imports(path: Path) -> set[str]:
    names: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text(), filename=str(path))):
        if isinstance(node, ast.Import):
            names.update(a.name for a in node.names)
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            names.add(node.module)
    return names


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
