"""Model registry: plugins discovered through the ``gearuq.models`` entry-point group.

Listing reads package metadata only; a plugin module is imported when it is first asked for,
so one broken plugin never breaks the others.
"""

from __future__ import annotations

import importlib
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
    factory = _load_factory(name)
    if options:
        import inspect

        try:
            accepted = inspect.signature(factory).parameters
        except (TypeError, ValueError):  # a factory without a signature: let it decide
            accepted = None
        if accepted is not None and not any(p.kind is p.VAR_KEYWORD
                                            for p in accepted.values()):
            valid = [n for n, p in accepted.items()
                     if p.kind in (p.POSITIONAL_OR_KEYWORD, p.KEYWORD_ONLY)]
            unknown = sorted(set(options) - set(valid))
            if unknown:
                raise ValueError(
                    f"get_model({name!r}): unknown construction option(s) {unknown}; valid: "
                    f"{valid or 'none (this model takes no construction options)'} (run-time "
                    "options go to response(..., **options))")
    return factory(**options)


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


# =========================================================================== studies
STUDY_GROUP = "gearuq.studies"
#: The study ``gearuq demo`` runs.
DEFAULT_STUDY = "helical_pair_reliability"


@dataclass(frozen=True)
class StudyInfo:
    """One row of :func:`describe_studies`."""

    name: str
    target: str
    description: str = ""
    error: str = ""


def list_studies() -> list[str]:
    """Names of the studies registered under the ``gearuq.studies`` entry-point group.

    A study is a packaged function ``run(out, quick=False, **settings) -> int`` (exit code)
    that writes its netCDF, PNG and markdown files into the folder ``out`` and prints its
    summary; the first line of its docstring is its description, ``quick=True`` a smaller
    version. Like models, studies are found through entry points, so a plugin distribution
    can ship its own; ``gearuq study NAME`` runs one, ``python -m gearuq_studies.NAME`` is the
    command line of a packaged study with all its settings.
    """
    return sorted(ep.name for ep in entry_points(group=STUDY_GROUP))


def get_study(name: str) -> Callable[..., int]:
    """The run function of study ``name``.

    Raises
    ------
    ValueError
        Unknown name (the message lists the registered studies).
    ModelLoadError
        The study's module failed to import (the message names it and the cause).
    """
    return _load_named(STUDY_GROUP, name, "study")


def _load_named(group: str, name: str, kind: str) -> Any:
    """Load entry point ``name`` of ``group``; unknown names list the registered ones, an
    import failure names the entry point and its cause."""
    eps = {ep.name: ep for ep in entry_points(group=group)}
    if name not in eps:
        raise ValueError(f"unknown {kind} {name!r}; registered: "
                         f"{', '.join(sorted(eps)) or 'none'}")
    try:
        return eps[name].load()
    except Exception as exc:  # noqa: BLE001 - report which entry point is broken and why
        raise ModelLoadError(f"{kind} {name!r} ({eps[name].value}) failed to import: "
                             f"{type(exc).__name__}: {exc}") from exc


def describe_studies() -> list[StudyInfo]:
    """Import every registered study and return its first docstring line, or the error."""
    eps = {ep.name: ep for ep in entry_points(group=STUDY_GROUP)}
    rows = []
    for name in list_studies():
        try:
            fn = get_study(name)
            doc = (fn.__doc__ or "").strip().splitlines()
            rows.append(StudyInfo(name, eps[name].value, doc[0] if doc else ""))
        except ModelLoadError as exc:
            rows.append(StudyInfo(name, eps[name].value, error=str(exc)))
    return rows


# =========================================================================== benchmarks
BENCH_GROUP = "gearuq.benchmarks"


def list_benchmarks() -> list[str]:
    """Benchmarks that plugins register under the ``gearuq.benchmarks`` entry-point group.

    Each is a function ``run(out, quick=False)`` that measures speed against error side by
    side in one run and writes its table into ``out``; ``gearuq bench NAME`` runs it next to
    the built-in benchmarks of the generic engines.
    """
    return sorted(ep.name for ep in entry_points(group=BENCH_GROUP))


def get_benchmark(name: str) -> Callable[..., Any]:
    """The run function of the plugin benchmark ``name`` (see :func:`list_benchmarks`)."""
    return _load_named(BENCH_GROUP, name, "benchmark")


# =========================================================================== fidelity links
LINK_GROUP = "gearuq.links"
#: Links registered at run time by :func:`register_link` ("HIGH->LOW" -> factory).
_RUNTIME_LINKS: dict[str, Callable[..., Any]] = {}


def link_name(high: str, low: str) -> str:
    """Registry name of the link from model ``high`` to model ``low``: ``"HIGH->LOW"``."""
    return f"{high}->{low}"


def list_links() -> list[tuple[str, str]]:
    """``(high, low)`` model names of every registered fidelity link (metadata only).

    A link is a factory ``build(**options) -> gearuq.links.FidelityLink`` registered under
    the entry-point group ``gearuq.links`` with the name ``"HIGH->LOW"``.
    """
    names = {ep.name for ep in entry_points(group=LINK_GROUP)} | set(_RUNTIME_LINKS)
    return sorted(tuple(n.split("->", 1)) for n in names if "->" in n)


def register_link(high: str, low: str, factory: Callable[..., Any], *,
                  overwrite: bool = False) -> None:
    """Register a link factory from model ``high`` to model ``low`` for this process."""
    name = link_name(high, low)
    if not overwrite and name in _RUNTIME_LINKS:
        raise ValueError(f"a link {name!r} is already registered")
    _RUNTIME_LINKS[name] = factory


def get_link(high: str, low: str, **options: Any) -> Any:
    """The registered fidelity link from model ``high`` to model ``low``.

    ``get_link("helical_pair", "mesh_oscillator")`` is a :class:`gearuq.links.FidelityLink`
    over the helical pair's parameters, to give as ``low_fidelity=`` to
    ``failure_probability(..., method="mfis")`` or as a cheaper model to
    ``multifidelity_estimate``. ``options`` go to the link's factory.

    Raises
    ------
    ValueError
        No link between these models (the message lists the registered links).
    ModelLoadError
        The link's module failed to import.
    """
    name = link_name(high, low)
    if name in _RUNTIME_LINKS:
        return _RUNTIME_LINKS[name](**options)
    eps = {ep.name for ep in entry_points(group=LINK_GROUP)}
    if name not in eps:
        known = ", ".join(f"{h} -> {lo}" for h, lo in list_links()) or "none"
        raise ValueError(f"no fidelity link from {high!r} to {low!r}; registered links: "
                         f"{known}")
    return _load_named(LINK_GROUP, name, "link")(**options)


# =========================================================================== reliability cases
RELIABILITY_CASE_GROUP = "gearuq.reliability_cases"


def list_reliability_cases() -> list[str]:
    """Reliability benchmark cases that plugins register under ``gearuq.reliability_cases``.

    Each entry point is a function ``case() -> dict`` that builds a case on its plugin's
    model: ``model``, ``space``, ``limit_state``, ``t`` (where the model has time), ``pf``
    (the reference), ``pf_interval``, ``source`` (how the reference was made), optionally
    ``model_options``, and ``coverage``: the ``(method, settings)`` rows ``gearuq bench
    reliability`` runs on it at full size. Reads metadata only: no plugin is imported.
    """
    return sorted(ep.name for ep in entry_points(group=RELIABILITY_CASE_GROUP))


def get_reliability_case(name: str) -> dict[str, Any]:
    """The reliability benchmark case ``name``, built (see :func:`list_reliability_cases`).

    Raises
    ------
    ValueError
        Unknown name (the message lists the registered cases).
    ModelLoadError
        The case's module failed to import.
    """
    return _load_named(RELIABILITY_CASE_GROUP, name, "reliability case")()


def reliability_case_attribute(name: str, where: str) -> Any:
    """A public name (in ``__all__``) of a module that registers reliability cases.

    The benchmark cases of the gear models, their references and settings once lived in
    ``where`` (generic code); they now live in their plugins, and ``where``'s module
    ``__getattr__`` finds the old names here, through the entry points, without importing a
    plugin by name.

    Raises
    ------
    AttributeError
        No registered case module exports ``name``.
    """
    for ep in entry_points(group=RELIABILITY_CASE_GROUP):
        module = importlib.import_module(ep.module)
        if name in getattr(module, "__all__", ()):
            return getattr(module, name)
    raise AttributeError(f"module {where!r} has no attribute {name!r}")
