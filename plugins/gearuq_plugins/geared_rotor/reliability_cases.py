"""The geared rotor's reliability benchmark case: its largest RMS DTE over 25-8000 rpm at
Pf ~ 1e-6 in 60 inputs, its reference, and the MFIS settings the headline study and the
coverage benchmark run on it.

Registered under the entry-point group ``gearuq.reliability_cases`` (``geared_rotor``), where
``gearuq bench reliability`` and the tests find it through
:func:`gearuq.registry.get_reliability_case`; the names below are also reachable as
``gearuq.testing.reliability_problems.NAME``, looked up through the same entry point.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from gearuq.failure.api import failure_probability
from gearuq.failure.modes import LimitState
from gearuq.registry import get_model
from gearuq.space import ParameterSpace

__all__ = [
    "geared_rotor_problem", "geared_rotor_reference", "geared_rotor_space",
    "geared_rotor_model", "GEARED_ROTOR_OPTIONS", "GEARED_ROTOR_LOW_FIDELITY_OPTIONS",
    "GEARED_ROTOR_LEVEL", "GEARED_ROTOR_PF", "GEARED_ROTOR_PF_INTERVAL",
    "geared_rotor_mfis_settings", "rotor_case", "geared_rotor_line_reference",
    "GEARED_ROTOR_LINE_SETTINGS", "GEARED_ROTOR_LINE_PF", "GEARED_ROTOR_LINE_PF_INTERVAL",
]


#: Options of the geared rotor in its rare-event case: the speed range on 40 speeds with 2 mesh
#: harmonics (the headline study's cheap model; 160 speeds and 3 harmonics by default), so that
#: 20 seeds of 1000 rotor runs fit in half an hour on 2 cores. The same physics on a coarser
#: grid: Pearson 1.0000 with the default's ``dte_rms_max``, at most 0.36 um below it.
GEARED_ROTOR_OPTIONS = {"n_speeds": 40, "range_mesh_harmonics": 2}
#: The cheap model of the case for multi-fidelity importance sampling: 20 speeds, 1 harmonic
#: (about 0.55 of a run of the case: the loaded tooth contact analysis is a fixed cost).
GEARED_ROTOR_LOW_FIDELITY_OPTIONS = {"n_speeds": 20, "range_mesh_harmonics": 1}
#: Limit on ``dte_rms_max`` [m] of the case.
GEARED_ROTOR_LEVEL = 60e-6
#: P(dte_rms_max >= 60 um) of the case, from :func:`geared_rotor_reference` (seed 77): 10^4
#: rotor runs from the tilted normal of a quadratic form fitted to 2400 runs of the case's
#: rotor itself, 3542 failing, CoV 4.5 %, Pareto k -0.61, largest weight 0.4 % of the
#: estimate; 95 % normal interval.
GEARED_ROTOR_PF = 7.12e-7
GEARED_ROTOR_PF_INTERVAL = (6.49e-7, 7.76e-7)
_ROTOR_SOURCE = ("importance sampling from the tilted normal of a quadratic form fitted to the "
                 "case's rotor itself: 10^4 runs (plus 2400 for the fit), CoV 4.5 %, Pareto "
                 "k -0.61")


def geared_rotor_space() -> ParameterSpace:
    """The headline space of the geared rotor: its pitch germ, tip-relief tolerance and torque.

    58 independent standard normals ``pitch_xi_{p,g}_{1..29}`` (the germ of each gear's random
    cumulative pitch deviations), ``tip_relief_amount`` uniform on 37-47 um (the 42 um design
    relief with a +-5 um drawing tolerance) and ``torque`` lognormal with mean 1000 N m and
    CoV 10 %.
    """
    germ = {f"pitch_xi_{gear}_{k}": {"dist": "normal", "mean": 0.0, "std": 1.0}
            for gear in ("p", "g") for k in range(1, 30)}
    return ParameterSpace({
        "torque": {"dist": "lognormal", "mean": 1000.0, "std": 100.0},
        "tip_relief_amount": {"dist": "uniform", "lower": 37.0, "upper": 47.0},
        **germ})


def geared_rotor_model() -> Any:
    """The geared rotor of Yuan, Liu and Liu (2020) at ISO 1328-1 grade 6."""
    return get_model("geared_rotor").with_nominal(iso_grade=6)


def geared_rotor_problem() -> dict[str, Any]:
    """The geared rotor's largest RMS DTE over 25-8000 rpm at Pf ~ 1e-6, with its reference.

    ``dte_rms_max >= GEARED_ROTOR_LEVEL`` over :func:`geared_rotor_space` (60 inputs), the
    rotor at :data:`GEARED_ROTOR_OPTIONS`. The reference is the independent one,
    :func:`geared_rotor_line_reference` (line sampling: it shares no estimator code with MFIS,
    which the coverage benchmark judges against it); the earlier importance-sampling
    reference :func:`geared_rotor_reference` (:data:`GEARED_ROTOR_PF`, MFIS's own density
    family) lies 0.5 of its standard error below it. Like the helical pair's, the case is not
    in :func:`gearuq.testing.reliability_problems.reliability_problems` (about 0.1 s per run).
    """
    return {"model": geared_rotor_model(), "space": geared_rotor_space(),
            "limit_state": LimitState.upper("dte_rms_max", GEARED_ROTOR_LEVEL),
            "model_options": dict(GEARED_ROTOR_OPTIONS), "pf": GEARED_ROTOR_LINE_PF,
            "pf_interval": GEARED_ROTOR_LINE_PF_INTERVAL, "source": _LINE_SOURCE}


def geared_rotor_mfis_settings(level: float = GEARED_ROTOR_LEVEL,
                               low_fidelity_options: Any = None) -> dict[str, Any]:
    """MFIS settings of the rotor at Pf ~ 1e-6, as the headline study and the benchmark run it.

    The cheap model (the same rotor with ``low_fidelity_options``; default
    :data:`GEARED_ROTOR_LOW_FIDELITY_OPTIONS`) has its ``dte_rms_max^2`` fitted as a
    quadratic form on 2400 runs (the form has 1891 coefficients in 60 inputs); the rotor then
    runs in batches of 200 from the tilted normal of that form (5 % defensive), up to 1000
    runs or a CoV of 0.15. ``level`` [m] is the limit X of ``g = X - dte_rms_max`` (the
    response offset).
    """
    options = GEARED_ROTOR_LOW_FIDELITY_OPTIONS if low_fidelity_options is None \
        else low_fidelity_options
    return {"low_fidelity": geared_rotor_model(), "low_fidelity_options": dict(options),
            "biasing": "quadratic", "response_offset": level, "n_fit": 2400,
            "n_samples": 200, "max_samples": 1000, "target_cov": 0.15, "defensive": 0.05}


def geared_rotor_reference(n_samples: int = 10_000, seed: int = 77, executor: Any = "processes",
                           chunk_size: int = 250) -> Any:
    """The reference of :func:`geared_rotor_problem`: one long importance-sampling run.

    The quadratic form of ``dte_rms_max^2`` is fitted to 2400 runs of the case's rotor itself
    (not of a cheaper model), and ``n_samples`` rotor runs are drawn from the exponentially
    tilted normal of that form (:mod:`gearuq.failure.methods.quadratic`), 5 % defensive.
    Returns the report (``pf``, ``pf_lower``, ``pf_upper``, ``cov_pf``).
    """
    p = geared_rotor_problem()
    settings = {**geared_rotor_mfis_settings(GEARED_ROTOR_LEVEL, p["model_options"]),
                "n_samples": 1000, "max_samples": n_samples, "target_cov": 1e-4}
    return failure_probability(p["model"], p["space"], p["limit_state"], method="mfis",
                               rng=seed, executor=executor, chunk_size=chunk_size,
                               model_options=p["model_options"], **settings)


def rotor_case() -> dict[str, Any]:
    """:func:`geared_rotor_problem` with its coverage row (``"coverage"``, full size only):
    MFIS as the headline study runs it (:func:`geared_rotor_mfis_settings`)."""
    return {**geared_rotor_problem(), "coverage": [("mfis", geared_rotor_mfis_settings())]}


#: Line-sampling settings of :func:`geared_rotor_line_reference`: radial lines in the
#: 2-dimensional subspace found by 4 gradient probes (a cylinder's exterior, the in-phase
#: once-per-revolution pitch wave of both gears), grid of 7 points over [-8, 8].
GEARED_ROTOR_LINE_SETTINGS = {"direction": "gradient", "subspace_dim": 2, "n_probe": 4,
                              "probe_std": 1.5, "probe_step": 0.05, "c_max": 8.0,
                              "n_grid": 7, "root_tol": 1e-3, "chunk_lines": 50}

#: P(dte_rms_max >= 60 um) of :func:`geared_rotor_problem` by :func:`geared_rotor_line_reference`
#: (seed 2030, 2 batches): 200 radial lines, every one crossing twice, per-line CoV 0.078,
#: 2444 rotor runs (244 for the probe), CoV 0.55 %; 95 % normal interval of the lines' mean.
#: It shares no estimator code with MFIS (the batches alone: 7.30e-7 and 7.27e-7).
GEARED_ROTOR_LINE_PF = 7.28e-7
_LINE_SOURCE = ("line sampling (radial lines in the 2-dimensional subspace of 4 gradient probes; "
                "shares no estimator code with MFIS): 200 lines, 2444 rotor runs, CoV 0.55 %")
GEARED_ROTOR_LINE_PF_INTERVAL = (7.19e-7, 7.37e-7)


def geared_rotor_line_reference(n_batches: int = 2, lines_per_batch: int = 100,
                                seed: int = 2030, store: Any = None,
                                executor: Any = "serial", confidence: float = 0.95) -> Any:
    """An independent reference of :func:`geared_rotor_problem` by line sampling.

    It shares no estimator code with MFIS (:mod:`gearuq.failure.methods.line_sampling`):
    the first batch finds the important subspace by finite-difference gradients of ``g`` at
    4 random points (``4 x 61`` runs; the leading two singular vectors, the third and fourth
    singular values saying how close to 2-dimensional the set is) and runs its lines; the
    other batches reuse that subspace with their own seeds. The batches' lines are i.i.d.,
    so they are pooled into one mean with its normal interval.

    Parameters
    ----------
    n_batches, lines_per_batch : int
        Independent runs of ``lines_per_batch`` lines each (seeds ``seed + b``).
    store : path-like, optional
        Directory; batch ``b`` is stored under ``store/batch{b}``, every step of it as its
        own chunk store, so an interrupted reference resumes where it stopped.
    executor : str or executor
        As in :func:`gearuq.failure_probability`.
    confidence : float
        Two-sided level of the interval.

    Returns
    -------
    xarray.Dataset
        ``pf``, ``pf_lower``, ``pf_upper``, ``cov_pf``, ``n_lines``, ``n_model_runs``,
        ``cpu_time`` (this process's CPU seconds), ``n_lines_by_crossings``, ``line_pf`` and
        the ``direction`` rows; ``attrs["batch_status"]`` lists each batch's status line.
    """
    import time
    from pathlib import Path

    import xarray as xr

    from gearuq.failure.api import failure_probability
    from gearuq.failure.methods.line_sampling import line_estimate
    from gearuq.failure.report import describe_status

    p = geared_rotor_problem()
    cpu0 = time.process_time()
    settings = dict(GEARED_ROTOR_LINE_SETTINGS)
    reports = []
    for b in range(n_batches):
        rep = failure_probability(
            p["model"], p["space"], p["limit_state"], method="line_sampling", rng=seed + b,
            executor=executor, store=None if store is None else Path(store) / f"batch{b}",
            model_options=p["model_options"], n_lines=lines_per_batch, **settings)
        reports.append(rep)
        settings["direction"] = rep["direction"].values  # the first batch's probe, kept
    est, low, high = (np.concatenate([r[v].values for r in reports])
                      for v in ("line_pf", "line_pf_lower", "line_pf_upper"))
    e = line_estimate(est, low, high, confidence)
    first = reports[0]
    scalar = {"units": "1"}
    out = xr.Dataset({
        "pf": ((), e["pf"], {**scalar, "long_name": "failure probability (mean of the lines)"}),
        "pf_lower": ((), e["pf_lower"], {**scalar, "long_name": "lower end of the interval"}),
        "pf_upper": ((), e["pf_upper"], {**scalar, "long_name": "upper end of the interval"}),
        "cov_pf": ((), e["se"] / e["pf"] if e["pf"] > 0 else math.inf, {
            **scalar, "long_name": "coefficient of variation of pf"}),
        "n_lines": ((), np.int64(est.size), scalar),
        "n_effective_lines": ((), e["n_effective"], scalar),
        "n_model_runs": ((), np.int64(sum(int(r["n_model_runs"]) for r in reports)), {
            **scalar, "long_name": "rotor runs, the gradient probe's included"}),
        "n_probe_runs": first["n_probe_runs"],
        "cpu_time": ((), time.process_time() - cpu0, {"units": "s", "long_name": (
            "CPU seconds of this process (0 for batches read back from the store)")}),
        "n_lines_by_crossings": sum(r["n_lines_by_crossings"] for r in reports),
        "line_pf": (("line",), est, {**scalar, "long_name": "each line's failure probability"}),
        "direction": first["direction"],
    })
    out.attrs.update({
        "method": "line_sampling", "confidence": float(confidence), "seed": seed,
        "settings": repr({**GEARED_ROTOR_LINE_SETTINGS, "lines_per_batch": lines_per_batch,
                          "n_batches": n_batches}),
        "direction_source": first.attrs.get("direction_source", ""),
        "probe_singular_values": first.attrs.get("probe_singular_values", ""),
        "batch_status": " | ".join(describe_status(r) for r in reports),
        "interval_kind": first.attrs["interval_kind"]})
    return out
