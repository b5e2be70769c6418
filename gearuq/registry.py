"""Model registry: plugins discovered through the ``gearuq.models`` entry-point group.

Listing reads package metadata only; a plugin module is imported when it is first asked for,
so one broken plugin never breaks the others.
"""

from __future__ import annotations

import traceback
from collections.abc import Callable
from dataclasses import dataclass
from importlib.metadata import entry_points
from typing import Any

ENTRY_POINT_GROUP = "gearuq.models"

#: Models registered at run time by :func:`register_model` (name -> class or factory).
_RUNTIME: dict[str, Callable[..., Any]] = {}


class ModelLoadError(ImportError):
    """A registered plugin could not be imported; the message names it and the cause."""


@dataclass(frozen=True)
class ModelInfo:
    """One row of :func:`describe_models`."""

    name: str
    target: str
    version: str = ""
    description: str = ""
    error: str = ""


def _entry_points() -> dict[str, Any]:
    return {ep.name: ep for ep in entry_points(group=ENTRY_POINT_GROUP)}


def list_models() -> list[str]:
    """Names of all registered models (entry points and run-time registrations).

    Reads metadata only: no plugin is imported.
    """
    return sorted(set(_entry_points()) | set(_RUNTIME))


def register_model(name: str, factory: Callable[..., Any], *, overwrite: bool = False) -> None:
    """Register a model class or factory under ``name`` for this process.

    Parameters
    ----------
    name : str
        Registry name.
    factory : callable
        Model class or function returning a model; called with ``get_model``'s options.
    overwrite : bool
        Replace an existing run-time registration of the same name.
    """
    if not overwrite and name in _RUNTIME:
        raise ValueError(f"a model named {name!r} is already registered")
    _RUNTIME[name] = factory


def _load_factory(name: str) -> Callable[..., Any]:
    if name in _RUNTIME:
        return _RUNTIME[name]
    eps = _entry_points()
    if name not in eps:
        available = ", ".join(list_models()) or "(none)"
        raise ValueError(f"unknown model {name!r}; available models: {available}")
    try:
        return eps[name].load()
    except Exception as exc:  # a broken plugin must be reported, not crash the registry
        cause = "".join(traceback.format_exception_only(type(exc), exc)).strip()
        raise ModelLoadError(
            f"plugin {name!r} ({eps[name].value}) failed to import: {cause}"
        ) from exc


def get_model(name: str, **options: Any) -> Any:
    """Instantiate the registered model ``name`` with construction ``options``.

    Raises
    ------
    ValueError
        If no model has that name (the message lists the available ones).
    ModelLoadError
        If the plugin is registered but fails to import.
    """
    return _load_factory(name)(**options)


def describe_models() -> list[ModelInfo]:
    """Import every plugin and return name, version, description, or the import error."""
    eps = _entry_points()
    rows = []
    for name in list_models():
        target = eps[name].value if name in eps else "runtime"
        try:
            cls = _load_factory(name)
            rows.append(ModelInfo(
                name, target, str(getattr(cls, "version", "")),
                str(getattr(cls, "description", "")),
            ))
        except ModelLoadError as exc:
            rows.append(ModelInfo(name, target, error=str(exc)))
    return rows
