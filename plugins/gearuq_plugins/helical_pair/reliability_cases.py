"""The helical pair's reliability benchmark cases: the peak dynamic mesh force at Pf ~ 1e-4,
the earlier aliased case, its deep level, their references and the MFIS settings the coverage
benchmark runs on them.

Registered under the entry-point group ``gearuq.reliability_cases`` (``helical_pair``,
``helical_pair_grid``, ``helical_pair_deep``), where ``gearuq bench reliability`` and the
tests find them through :func:`gearuq.registry.get_reliability_case`; the names below are
also reachable as ``gearuq.testing.reliability_problems.NAME``, looked up through the same
entry points. How the references were made: :mod:`gearuq.testing.helical_pair_reference`.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from gearuq.failure.modes import LimitState
from gearuq.registry import get_model

__all__ = [
    "helical_pair_problem", "HELICAL_PAIR_LEVEL", "HELICAL_PAIR_PF", "HELICAL_PAIR_PF_INTERVAL",
    "HELICAL_PAIR_T", "HELICAL_PAIR_GRID_LEVEL", "HELICAL_PAIR_GRID_PF",
    "HELICAL_PAIR_GRID_PF_INTERVAL", "HELICAL_PAIR_DEEP_LEVEL", "HELICAL_PAIR_DEEP_PF",
    "HELICAL_PAIR_LOW_FIDELITY", "HELICAL_PAIR_LOW_FIDELITY_T", "peak_case", "grid_case",
    "deep_case",
]


#: Peak dynamic mesh force level [N] of the helical-pair rare-event case.
HELICAL_PAIR_LEVEL = 76_220.0
#: Output instants of the case: tau in [100, 200] every 0.05 (about 114 instants per mesh
#: period); the peak between them is taken by a parabola through each local maximum
#: (``first_passage="parabola"``): within 0.2 N of the continuous-time peak on 100 draws
#: about the failure domain (against 0.0025 instants), where the plain maximum over the old
#: grid (one instant per time unit, 5.7 per mesh period) was up to 190 N low.
HELICAL_PAIR_T = np.linspace(100.0, 200.0, 2001)
#: P(continuous-time peak of mesh_force over tau in [100, 200] >= 76 220 N), the model's
#: default space and options: importance sampling with every weight bounded by 2 (half the
#: standard normal, half a broad normal about the failure region; 1.2 x 10^5 runs, 9495
#: failing, CoV 2.1 %, :mod:`gearuq.testing.helical_pair_reference`), 95 % normal interval;
#: crude Monte Carlo on independent draws agrees (``helical_pair_problem()["source"]``).
HELICAL_PAIR_PF = 7.92e-5
HELICAL_PAIR_PF_INTERVAL = (7.60e-5, 8.25e-5)

#: The earlier case: the largest mesh force on the instants tau = 0, 1, ..., 200 within
#: [100, 200] at 76 200 N (aliased: see :func:`helical_pair_problem`), from the same
#: bounded-weight runs (8319 failing, CoV 2.3 %). The earlier crude-MC reference, 1.11e-4
#: [9.69e-5, 1.27e-4] from 2 x 10^6 runs (222 failures), was 1.5 of its own standard errors
#: above it.
HELICAL_PAIR_GRID_LEVEL = 76_200.0
HELICAL_PAIR_GRID_PF = 9.94e-5
HELICAL_PAIR_GRID_PF_INTERVAL = (9.49e-5, 1.04e-4)


_PEAK_SOURCE = ("importance sampling with weights <= 2, 1.2 x 10^5 runs (CoV 2.1 %); crude MC "
                "on independent draws: 2 x 10^6 runs, 178 failures, 8.90e-5 [7.64e-5, 1.03e-4]")
_GRID_SOURCE = ("importance sampling with weights <= 2, 1.2 x 10^5 runs (CoV 2.3 %); crude MC: "
                "2 x 10^6 runs, 222 failures, 1.11e-4 [9.69e-5, 1.27e-4]; on the peak case's "
                "2 x 10^6 draws 216 failures, 1.08e-4 [9.41e-5, 1.23e-4]")


#: The deep level of the aliased grid case [N] and its estimate: four groups of ten pooled
#: subset runs gave 3.0e-8, 1.5e-8, 2.2e-8 and 2.7e-8 (docs/reliability.md); their mean. An
#: estimate from one method, not a reference: a coverage row on it is indicative only.
HELICAL_PAIR_DEEP_LEVEL = 76_300.0
HELICAL_PAIR_DEEP_PF = 2.35e-8
_DEEP_SOURCE = ("mean of four groups of ten pooled subset-simulation runs (3.0e-8, 1.5e-8, "
                "2.2e-8, 2.7e-8); not checkable by crude Monte Carlo (~5e9 runs)")


def helical_pair_problem(variant: str = "peak") -> dict[str, Any]:
    """The helical pair's peak mesh force at Pf ~ 1e-4 with its reference.

    Parameters
    ----------
    variant : {"peak", "grid", "deep"}
        ``"peak"``: the continuous-time peak (parabola through the local maxima on
        :data:`HELICAL_PAIR_T`) at :data:`HELICAL_PAIR_LEVEL`. ``"grid"``: the earlier case,
        the largest value on ``tau = 0, 1, ..., 200`` at 76 200 N. Its mesh force peaks are
        sharp (curvature ~7e4 N per tau^2) and the grid has 5.7 instants per mesh period, so
        the grid maximum depends on where the instants fall on the peaks: up to 190 N low,
        and with a pattern that moves with every parameter that shifts the response's phase
        (aliasing fingers in the failure set); kept to show what that does to the methods.
        ``"deep"``: the same grid at 76 300 N (Pf ~ 2e-8, the README's old level), where
        subset simulation's chains do not mix; its value is the mean of four pooled groups
        of ten subset runs (no method can check it: crude MC would need ~5e9 runs).

    Not in :func:`gearuq.testing.reliability_problems.reliability_problems` (it needs the
    plugin and ~1 ms per run); the reference's own interval is in the ``"pf_interval"``
    entry: a method's interval is judged against the point value, as for the 2e7-sample
    oscillator reference.
    """
    model = get_model("helical_pair")
    if variant == "peak":
        limit = LimitState.upper("mesh_force", HELICAL_PAIR_LEVEL, window=(100.0, 200.0),
                                 first_passage="parabola")
        return {"model": model, "space": model.default_space(), "limit_state": limit,
                "t": HELICAL_PAIR_T, "pf": HELICAL_PAIR_PF,
                "pf_interval": HELICAL_PAIR_PF_INTERVAL,
                "source": _PEAK_SOURCE}
    if variant == "deep":
        limit = LimitState.upper("mesh_force", HELICAL_PAIR_DEEP_LEVEL, window=(100.0, 200.0))
        return {"model": model, "space": model.default_space(), "limit_state": limit,
                "t": np.linspace(0.0, 200.0, 201), "pf": HELICAL_PAIR_DEEP_PF,
                "pf_interval": (math.nan, math.nan), "source": _DEEP_SOURCE}
    if variant == "grid":
        limit = LimitState.upper("mesh_force", HELICAL_PAIR_GRID_LEVEL, window=(100.0, 200.0))
        return {"model": model, "space": model.default_space(), "limit_state": limit,
                "t": np.linspace(0.0, 200.0, 201), "pf": HELICAL_PAIR_GRID_PF,
                "pf_interval": HELICAL_PAIR_GRID_PF_INTERVAL,
                "source": _GRID_SOURCE}
    raise ValueError(f"variant: {variant!r} is not 'peak', 'grid' or 'deep'")


#: The helical pair's cheap model for MFIS: the same model at a looser step tolerance
#: (rtol 1e-4 instead of 1e-6): half the cost, peaks within 1 N of the default's on 2000
#: draws about the failure domain (docs/reliability.md).
HELICAL_PAIR_LOW_FIDELITY = {"low_fidelity": "helical_pair",
                             "low_fidelity_options": {"rtol": 1e-4}}


#: Output instants of that cheap model in the second MFIS row: every fourth instant of the
#: case's ``linspace(100, 200, 2001)``.
HELICAL_PAIR_LOW_FIDELITY_T = np.linspace(100.0, 200.0, 501)


# ============================================================ the cases of the coverage benchmark
def peak_case() -> dict[str, Any]:
    """The ``"peak"`` case with its coverage rows (``"coverage"``: ``(method, settings)``
    pairs that ``gearuq bench reliability`` runs on it, full size only): subset simulation
    alone and as 5 replicates, MFIS with the cheap model on all instants and on a quarter of
    them (0.42 of an expensive run instead of 0.67, peaks within 7 N, docs/reliability.md),
    and AK-MCS."""
    mfis = {**HELICAL_PAIR_LOW_FIDELITY, "n_per_level": 1000, "max_samples": 20_000}
    return {**helical_pair_problem("peak"), "coverage": [
        ("subset", {}), ("subset", {"replicates": 5}), ("mfis", mfis),
        ("mfis", {**mfis, "low_fidelity_t": HELICAL_PAIR_LOW_FIDELITY_T}),
        ("akmcs", {"max_runs": 150, "n_mc": 50_000, "max_mc": 400_000})]}


def grid_case() -> dict[str, Any]:
    """The earlier, aliased ``"grid"`` case and its coverage row: what MFIS does there,
    against its corrected reference."""
    return {**helical_pair_problem("grid"), "coverage": [
        ("mfis", {**HELICAL_PAIR_LOW_FIDELITY, "n_per_level": 1000, "max_samples": 20_000})]}


def deep_case() -> dict[str, Any]:
    """The ``"deep"`` level (Pf ~ 2e-8) and its coverage row: subset simulation, whose chains
    do not mix there."""
    return {**helical_pair_problem("deep"), "coverage": [("subset", {})]}
