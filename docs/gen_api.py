"""Regenerate docs/api.md from ``gearuq.__all__`` and the public modules' ``__all__``.

Run ``python docs/gen_api.py``; ``python docs/gen_api.py --check`` exits 1 when docs/api.md
is out of date (a test runs the same check, so the reference and the code stay in step).
"""

from __future__ import annotations

import importlib
import inspect
import sys
import textwrap
from pathlib import Path

import gearuq

#: Section of each exported name, by the module that defines it (longest prefix wins).
SECTIONS = {
    "gearuq.registry": "Models, studies and registry",
    "gearuq.model": "Models, studies and registry",
    "gearuq.space": "Parameter space",
    "gearuq.engines": "Engines",
    "gearuq.failure": "Reliability, limit states and fitting",
    "gearuq.fitting": "Reliability, limit states and fitting",
    "gearuq.io": "I/O",
}
ORDER = ["Models, studies and registry", "Parameter space", "Engines",
         "Reliability, limit states and fitting", "I/O", "Other"]
#: Public modules listed with their own ``__all__`` below the top-level names.
MODULES = ["gearuq.model", "gearuq.failure", "gearuq.execution", "gearuq.ode", "gearuq.signal", "gearuq.plot",
           "gearuq.testing", "gearuq.gears", "gearuq.rotor", "gearuq.io"]


def summary(obj: object) -> str:
    """First paragraph of a docstring, on one line."""
    doc = inspect.getdoc(obj) or ""
    return doc.split("\n\n")[0].replace("\n", " ")


def _signature(name: str, obj: object) -> str:
    try:
        return f"{name}{inspect.signature(obj)}"
    except (TypeError, ValueError):
        return name


def _section(obj: object) -> str:
    mod = getattr(obj, "__module__", "") or ""
    best = max((k for k in SECTIONS if mod == k or mod.startswith(k + ".")), key=len,
               default=None)
    return SECTIONS[best] if best else "Other"


def render() -> str:
    """The text of docs/api.md."""
    groups: dict[str, list[tuple[str, object]]] = {s: [] for s in ORDER}
    for name in gearuq.__all__:
        if name == "__version__":
            continue
        obj = getattr(gearuq, name)
        groups[_section(obj)].append((name, obj))
    lines = ["# API reference", "",
             "Generated from `gearuq.__all__` and the docstrings by `python docs/gen_api.py`; "
             "the docstrings (numpydoc) hold the full parameter descriptions.", ""]
    for title in ORDER:
        if not groups[title]:
            continue
        lines += [f"## {title}", ""]
        for name, obj in groups[title]:
            lines += [f"### `gearuq.{name}`", "", "```python",
                      textwrap.fill(_signature(name, obj), 96, subsequent_indent="    "),
                      "```", "", summary(obj), ""]
    lines += ["## Modules", ""]
    for mod_name in MODULES:
        try:
            mod = importlib.import_module(mod_name)
        except ImportError:
            continue
        lines += [f"### `{mod_name}`", "", summary(mod), ""]
        names = getattr(mod, "__all__", None) or [
            n for n, o in inspect.getmembers(mod)
            if not n.startswith("_") and getattr(o, "__module__", None) == mod_name
            and (inspect.isfunction(o) or inspect.isclass(o))]
        for name in names:
            obj = getattr(mod, name, None)
            if inspect.isfunction(obj) or inspect.isclass(obj):
                lines.append(f"- `{name}`: {summary(obj)}")
        lines.append("")
    return "\n".join(lines)


def main(argv: list[str]) -> int:
    path = Path(__file__).with_name("api.md")
    text = render()
    if "--check" in argv:
        if not path.exists() or path.read_text() != text:
            print("docs/api.md is out of date: run python docs/gen_api.py", file=sys.stderr)
            return 1
        return 0
    path.write_text(text)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
