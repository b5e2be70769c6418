"""One entry point for failure probabilities, its method table and the method settings.

:func:`failure_probability` runs any of the methods on a model, a parameter space and a limit
state and returns the one report form (:mod:`gearuq.failure.report`). A method is a module of
:mod:`gearuq.failure.methods` with its declared ``SETTINGS`` and a runner
``run(evaluator, settings, seed, confidence) -> Dataset``; it joins by one entry in
:data:`METHOD_TABLE`.

==============  ===============================================================================
method          what it does
==============  ===============================================================================
``mc``          crude Monte Carlo / LHS / QMC, optionally as independent randomised replicates
``form``        first-order reliability method (iHLRF design point search, multiple starts)
``sorm``        FORM + curvatures: Breitung, Hohenbichler-Rackwitz, Tvedt
``importance``  importance sampling around the design points found by a multi-start FORM
                search, with a defensive component
``subset``      subset simulation (modified Metropolis or aCS), also for first passage over
                time
``akmcs``       active-learning Kriging on a Monte Carlo population (AK-MCS, AK-SYS)
``mfis``        multi-fidelity importance sampling: a cheap model (``low_fidelity=``) explores
                the failure domain, the expensive one runs only on draws from a defensive
                mixture fitted there
==============  ===============================================================================

``line_sampling``: line sampling, the exact failure probability along lines parallel to an
important direction (or radial in an important subspace), both sides searched.
"""

from __future__ import annotations

import functools
import os
import time
from collections.abc import Callable, Mapping
from typing import Any, NamedTuple

import xarray as xr

from gearuq.execution import workers_for_run
from gearuq.failure.evaluator import LimitStateEvaluator
from gearuq.failure.methods import akmcs, form, importance, line_sampling, mc, mfis, subset
from gearuq.model import Model, Option
from gearuq.runs import resolve_model, resolve_seed, route_keywords
from gearuq.space import ParameterSpace

__all__ = ["failure_probability", "method_settings", "validate_settings", "check_method",
           "METHODS", "METHOD_TABLE", "MethodEntry"]


class MethodEntry(NamedTuple):
    """One row of the method table."""

    settings: tuple[Option, ...]
    run: Callable[[LimitStateEvaluator, Mapping[str, Any], int, float], xr.Dataset]
    summary: str


#: The methods of :func:`failure_probability`; a new method joins by one entry.
METHOD_TABLE: dict[str, MethodEntry] = {
    "mc": MethodEntry(mc.SETTINGS, mc.run, "crude Monte Carlo / LHS / QMC"),
    "form": MethodEntry(form.FORM_SETTINGS, form.run_form, "first-order reliability method"),
    "sorm": MethodEntry(form.SORM_SETTINGS, functools.partial(form.run_form, second_order=True),
                        "second-order reliability method"),
    "importance": MethodEntry(importance.SETTINGS, importance.run_importance,
                              "importance sampling around the design points"),
    "subset": MethodEntry(subset.SETTINGS, subset.run_subset, "subset simulation"),
    "akmcs": MethodEntry(akmcs.SETTINGS, akmcs.run_akmcs, "active-learning Kriging (AK-MCS)"),
    "mfis": MethodEntry(mfis.SETTINGS, mfis.run_mfis,
                        "multi-fidelity importance sampling (a cheap model explores)"),
    "line_sampling": MethodEntry(line_sampling.SETTINGS, line_sampling.run_line_sampling,
                                 "line sampling along an important direction, both sides"),
}

#: Method names accepted by :func:`failure_probability`.
METHODS = tuple(METHOD_TABLE)

_ALIASES = {"montecarlo": "mc", "is": "importance", "ss": "subset", "linesampling": "line_sampling"}


def check_method(method: Any) -> str:
    """The table key of a method name (case, ``-`` and ``_`` ignored; a few aliases)."""
    if method in METHOD_TABLE:
        return str(method)
    key = str(method).strip().lower().replace("-", "").replace("_", "")
    key = _ALIASES.get(key, key)
    if key not in METHOD_TABLE:
        raise ValueError(f"method: unknown {method!r}; valid: {', '.join(METHOD_TABLE)}")
    return key


def method_settings(method: str) -> tuple[Option, ...]:
    """The declared settings of a method (name, default, valid values, meaning)."""
    return METHOD_TABLE[check_method(method)].settings


def validate_settings(method: str, settings: Mapping[str, Any]) -> dict[str, Any]:
    """Check method settings; return every declared setting with defaults filled in.

    Raises
    ------
    ValueError
        Unknown setting (the message lists the valid ones) or a bad value.
    """
    declared = method_settings(method)
    names = [o.name for o in declared]
    unknown = sorted(set(settings) - set(names))
    if unknown:
        valid = ", ".join(f"{o.name} ({o.valid_text()})" for o in declared)
        raise ValueError(f"method {method!r}: unknown setting(s) {', '.join(map(repr, unknown))};"
                         f" valid: {valid}")
    return {o.name: o.validate(settings.get(o.name, o.default), f"method {method!r}")
            for o in declared}


def failure_probability(
    model: Model | str,
    space: ParameterSpace | Mapping[str, Any] | None,
    limit_state: Any,
    t: Any = None,
    *,
    method: str = "subset",
    rng: Any = None,
    executor: Any = None,
    store: str | os.PathLike | None = None,
    chunk_size: int | None = None,
    confidence: float = 0.95,
    model_options: Mapping[str, Any] | None = None,
    **settings: Any,
) -> xr.Dataset:
    """Failure probability ``P(g <= 0)`` of a model over a parameter space, by any method.

    Parameters
    ----------
    model : Model or str
        A model instance or registered name.
    space : ParameterSpace, mapping or None
        Random parameters (``None``: the model's default space).
    limit_state : LimitState, System, Band or str
        Failure where ``g <= 0`` (:mod:`gearuq.failure.modes`); an output name means the output
        is ``g``. A time-dependent ``g`` is taken over the output instants ``t`` as a first
        passage (``min_t g``).
    t : array_like, optional
        Output instants (required for time-dependent outputs).
    method : {"mc", "form", "sorm", "importance", "subset", "akmcs", "mfis", "line_sampling"}
        See the module docstring; :func:`method_settings` lists each method's settings.
    rng : int, Generator or None
        Seed (``None``: fresh, recorded in ``attrs["seed"]``).
    executor, chunk_size :
        As in :func:`gearuq.monte_carlo`.
    store : path-like, optional
        Directory for a resumable run: every evaluation stage is stored (one chunk store per
        stage); calling again with the same arguments and seed resumes.
    confidence : float
        Two-sided confidence level of the interval.
    model_options : mapping, optional
        Declared model options (solver/fidelity settings).
    **settings
        The method's own settings (validated; unknown names raise with the list of valid
        ones). A model option given here is refused with the spelling to use
        (``model_options={...}``), and so is a name that is both a setting of the method and
        an option of the model unless ``model_options`` also holds it.

    Returns
    -------
    xarray.Dataset
        The report (see :func:`failure_report`): ``pf``, ``pf_lower``, ``pf_upper``,
        ``cov_pf``, ``beta``..., ``n_model_runs``, ``wall_time``, ``status``, design points
        where relevant, and method-specific variables.

    Raises
    ------
    ValueError
        Unknown method or setting, bad setting value, a model option given as a setting,
        a limit state on an unknown output,
        ambiguous limit-state input, a point outside the model's valid range.

    Examples
    --------
    >>> from gearuq.testing.reliability_problems import offset_model, offset_space
    >>> rep = failure_probability(offset_model(), offset_space(), "g", method="form")
    >>> round(float(rep["beta"]), 6)
    4.5
    """
    key = check_method(method)
    if not 0.0 < float(confidence) < 1.0:
        raise ValueError(f"confidence: must lie in (0, 1), got {confidence!r}")
    model = resolve_model(model)
    settings, model_options = route_keywords(
        f"failure_probability(method={key!r})", model, model_options, settings,
        [o.name for o in method_settings(key)], legacy_model_options=False)
    s = validate_settings(key, settings)
    seed = resolve_seed(rng)
    cpu_start = time.process_time()
    # one pool of workers for every step of the method (levels, batches, probes), not one
    # per step: each fresh worker costs seconds of imports and compiled kernels
    with workers_for_run(executor) as runner:
        ev = LimitStateEvaluator(model, space, limit_state, t, model_options=model_options,
                                 executor=runner, chunk_size=chunk_size, store=store,
                                 engine=f"failure_probability/{key}", seed=seed)
        report = METHOD_TABLE[key].run(ev, s, seed, float(confidence))
    worker_cpu = ev.worker_cpu + sum(c.worker_cpu for c in ev.companions)
    report["cpu_time"] = ((), time.process_time() - cpu_start + worker_cpu, {
        "units": "s", "long_name": "CPU time of the method, its worker processes included"})
    return report
