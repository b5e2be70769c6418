"""Fingerprints of a call: which code, which model, which request, which design.

A chunk store is reused only by the same call. "Same" must include the code that computes
the results, not only names and versions, or an edited model silently returns the old
model's numbers. What is hashed:

* gearuq's version;
* the model's class (module and qualified name), its ``version`` and ``settings()``, the
  installed distribution that provides it and that distribution's version;
* the source files of the package that defines the model class (all ``.py`` files of that
  package folder), so a plugin edited without a version bump is caught;
* for a :class:`~gearuq.model.FunctionModel`: the function's code object (bytecode,
  constants, names, nested code objects), default arguments and closure values, and the
  declared parameters and outputs.

What it cannot see, and says so in the fingerprint: module-level globals that a function
reads at call time (their names are recorded, not their values), code of other packages a
model imports (covered only through gearuq's version and the plugin's distribution version),
and data files read at run time.
"""

from __future__ import annotations

import functools
import hashlib
import importlib.metadata
import pickle
import sys
import types
from pathlib import Path
from typing import Any

from gearuq._version import __version__

__all__ = ["model_fingerprint", "function_digest", "source_digest"]


def _update_code(h: Any, code: types.CodeType, globals_read: set[str]) -> None:
    h.update(code.co_code)
    h.update(repr(code.co_names).encode())
    h.update(repr(code.co_varnames).encode())
    globals_read.update(code.co_names)
    for const in code.co_consts:
        if isinstance(const, types.CodeType):
            _update_code(h, const, globals_read)
        else:
            h.update(repr(const).encode())


def _value_bytes(value: Any) -> bytes:
    try:
        import cloudpickle

        return cloudpickle.dumps(value)
    except Exception:  # noqa: BLE001 - fall back to the representation
        try:
            return pickle.dumps(value)
        except Exception:  # noqa: BLE001
            return repr(value).encode()


def function_digest(fn: Any) -> dict[str, Any]:
    """SHA-256 of a function's code, defaults and closure values.

    Returns
    -------
    dict
        ``sha256`` and ``globals_read`` (names the code may read from its module at call
        time; their values are not part of the digest).
    """
    h = hashlib.sha256()
    globals_read: set[str] = set()
    target = getattr(fn, "__func__", fn)
    code = getattr(target, "__code__", None)
    if code is None:  # a callable object: hash its class's __call__ and its state
        call = type(fn).__dict__.get("__call__")
        code = getattr(call, "__code__", None)
        h.update(_value_bytes(getattr(fn, "__dict__", {})))
    if code is not None:
        _update_code(h, code, globals_read)
    for extra in (getattr(target, "__defaults__", None), getattr(target, "__kwdefaults__", None)):
        if extra:
            h.update(_value_bytes(extra))
    for cell in getattr(target, "__closure__", None) or ():
        try:
            h.update(_value_bytes(cell.cell_contents))
        except ValueError:  # empty cell
            h.update(b"<empty>")
    builtins = set(dir(__builtins__)) if not isinstance(__builtins__, dict) else set(__builtins__)
    module_globals = getattr(target, "__globals__", {})
    read = sorted(n for n in globals_read if n in module_globals and n not in builtins)
    return {"sha256": h.hexdigest(), "globals_read": read}


def source_digest(cls: type) -> dict[str, Any]:
    """SHA-256 over the ``.py`` files of the package folder that defines ``cls``."""
    module = sys.modules.get(cls.__module__)
    file = getattr(module, "__file__", None)
    if not file:
        return {"sha256": None, "files": 0}
    folder = Path(file).parent
    files = sorted(folder.glob("*.py"))
    h = hashlib.sha256()
    for f in files:
        h.update(f.name.encode())
        h.update(f.read_bytes())
    return {"sha256": h.hexdigest(), "files": len(files), "package": folder.name}


@functools.lru_cache(maxsize=64)
def _distribution(module_name: str) -> tuple[str | None, str | None]:
    top = module_name.split(".")[0]
    if top in ("gearuq", "gearuq_plugins"):  # both ship in the gearuq distribution
        return "gearuq", __version__
    try:  # scans every installed distribution (~0.7 s), hence the cache
        names = importlib.metadata.packages_distributions().get(top, [])
    except Exception:  # noqa: BLE001 - metadata is informational
        names = []
    if not names:
        return None, None
    try:
        return names[0], importlib.metadata.version(names[0])
    except importlib.metadata.PackageNotFoundError:
        return names[0], None


def model_fingerprint(model: Any) -> dict[str, Any]:
    """Everything about a model that decides its numbers (see the module docstring)."""
    from gearuq.model import FunctionModel

    cls = type(model)
    dist, dist_version = _distribution(cls.__module__.split(".")[0])
    fp: dict[str, Any] = {
        "gearuq_version": __version__,
        "model": model.name,
        "model_version": str(model.version),
        "model_class": f"{cls.__module__}.{cls.__qualname__}",
        "model_settings": model.settings(),
        "distribution": dist,
        "distribution_version": dist_version,
        "source": source_digest(cls),
    }
    if getattr(model, "nominal_overrides", None):
        fp["nominal_overrides"] = dict(sorted(model.nominal_overrides.items()))
    if isinstance(model, FunctionModel):
        fp["function"] = function_digest(model.fn)
        fp["function_name"] = getattr(model.fn, "__qualname__", repr(model.fn))
        fp["declared"] = {
            "parameters": [[p.name, p.units, p.nominal, p.lower, p.upper] for p in
                           model.parameters],
            "outputs": [[o.name, o.units, list(o.dims)] for o in model.outputs],
        }
    return fp
