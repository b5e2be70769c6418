"""Regenerate docs/api.md from the docstrings of the public API: ``python docs/gen_api.py``."""

from __future__ import annotations

import inspect
import textwrap
from pathlib import Path

import gearuq

SECTIONS = {
    "Models and registry": ["list_models", "get_model", "register_model", "describe_models",
                            "Model", "Parameter", "Output", "FunctionModel"],
    "Parameter space": ["ParameterSpace"],
    "Engines": ["monte_carlo"],
    "Reliability and fitting": ["reliability", "Band", "fit_distributions"],
    "I/O": ["save", "load"],
}
MODULES = ["gearuq.ode", "gearuq.signal", "gearuq.plot", "gearuq.testing",
           "gearuq.gears.geometry", "gearuq.gears.iso6336", "gearuq.execution"]


def _summary(obj: object) -> str:
    doc = inspect.getdoc(obj) or ""
    return doc.split("\n\n")[0].replace("\n", " ")


def _signature(name: str, obj: object) -> str:
    try:
        return f"{name}{inspect.signature(obj)}"
    except (TypeError, ValueError):
        return name


def main() -> None:
    import importlib

    lines = ["# API reference", "",
             "Generated from the docstrings by `python docs/gen_api.py`; the docstrings "
             "(numpydoc) hold the full parameter descriptions.", ""]
    for title, names in SECTIONS.items():
        lines += [f"## {title}", ""]
        for name in names:
            obj = getattr(gearuq, name)
            if inspect.ismodule(obj):  # gearuq.reliability is also a (callable) module
                obj = getattr(obj, name)
            lines += [f"### `gearuq.{name}`", "", "```python",
                      textwrap.fill(_signature(name, obj), 96, subsequent_indent="    "),
                      "```", "", _summary(obj), ""]
    lines += ["## Modules", ""]
    for mod_name in MODULES:
        mod = importlib.import_module(mod_name)
        lines += [f"### `{mod_name}`", "", _summary(mod), ""]
        for name, obj in inspect.getmembers(mod):
            if name.startswith("_") or getattr(obj, "__module__", None) != mod_name:
                continue
            if inspect.isfunction(obj) or inspect.isclass(obj):
                lines.append(f"- `{name}`: {_summary(obj)}")
        lines.append("")
    Path(__file__).with_name("api.md").write_text("\n".join(lines))


if __name__ == "__main__":
    main()
