"""How likely is the dynamic factor K_v of gears that pass inspection to exceed X over 25-8000 rpm?

The dynamic question on the finite-element helical geared rotor of Yuan, Liu and Liu
("Dynamic characteristics of a helical geared rotor system with random cumulative pitch
deviations", Applied Sciences 10 (2020) 4403): with ISO 1328-1 class-6 (or 7) gears that
passed inspection, a tip-relief tolerance, a load spread and uncertain damping, how likely is
K_v = max dynamic mesh force / static mesh force (ISO 6336-1's definition, whose Method A is
"a comprehensive dynamic analysis") to exceed X anywhere in the speed range, where do the
resonances sit, and what drives it? ISO 6336-1 Method B's K_v for the same stage, class and
load is drawn beside the simulated population.

=====================  =========================================  ==========================
input                  distribution                               why
=====================  =========================================  ==========================
pitch_xi_{p,g}_1..29   independent standard normals (58), the     each gear's cumulative
                       germ of a capable process: 5 % of the      pitch deviations; the
                       gears exceed F_pT (``capable_process``)    gears that fail
                       and inspection removes them                inspection are removed:
                                                                  Pf is conditioned on
                                                                  ``pitch_acceptance_margin
                                                                  >= 0``
tip_relief_amount      normal about 42 um, 1 % beyond +-5 um,     the design relief with
                       truncated to 37..47 um (inspected)         its drawing tolerance
torque                 lognormal, mean 1000 N m, CoV 10 %         load spread
damping_ratio          uniform 0.03 .. 0.08                       modal damping, uncertain
=====================  =========================================  ==========================

Failure given acceptance is the system event (kv_max >= X and the pair passes inspection)
over P(pass): a :class:`gearuq.ParallelSystem` of the two limit states, so every method of
:func:`gearuq.failure.failure_probability` applies. Steps:

1. a crude Monte Carlo population (``kv_max``, K_v over speed, the ISO value, the mesh-band
   and mesh-order responses, the acceptance margin);
2. X at a moderate level (the population's 90 % quantile of accepted pairs), P(fail | pass)
   by subset simulation on the system, checked against the population's count;
3. grouped Sobol' indices of ``kv_max`` by cause (pitch of each gear, relief, load,
   damping; SALib, Saltelli design on the untruncated process law, whose 95 % per-gear
   acceptance makes it close to the accepted one). At 64 base samples (448 runs, 368 CPU
   s) the totals are wheel pitch 0.55, pinion pitch 0.49, damping 0.31 (+-0.16), load 0.15
   (+-0.07), relief 0.007: the dynamics carry a visible share, the relief tolerance none
   (docs/benchmarks.md, "The dynamic question", seventh round);
4. figures: K_v against speed with the population's bands and ISO 6336-1 Method B; a
   Campbell-like map (speed of the K_v peak against K_v, failures marked, the speeds where
   the mesh frequency meets the natural frequencies with the most mesh strain energy);
5. the rare level, P(kv_max >= :data:`RARE_X` | pass) near 1e-6, by two methods that share
   no estimator code (``--rare-methods``, default ``lines,mirrored``). Inspection is a gate
   on the germs (:func:`germ_acceptance_margin`, the plugin's margin without the rotor): the
   accepted law is sampled exactly and a rejected pair costs no run.

   - ``lines`` (:func:`lines_given_acceptance`, :data:`RARE_LINES`): line sampling behind
     the gate along the pinion-plus-wheel coordinate of the alternating tooth-to-tooth
     harmonic 15 (where the event lives: a light load, low damping and that wave; harmonics
     12-14 help), each line's origin drawn from a defensive mixture at the cross-entropy
     moments of earlier line terms. At X = 1.77: **1.65e-6 [1.21e-6, 2.10e-6]** (170
     lines, 42 effective, status 0; 1509 rotor runs, 1034 CPU s / 574 s wall on two quiet
     cores) and 1.44e-6 [1.13e-6, 1.74e-6] (250 lines of another seed, status 0).
   - ``mirrored`` (:func:`mirrored_given_acceptance`, :data:`RARE_MIRRORED`): importance
     sampling whose density (besides a defensive standard normal) sits at the moments of
     the lines' origins times two normals mirrored along harmonic 15 (K_v fails at both
     ends of it). At X = 1.77, 1500 draws (seed 12; the default is now 2000):
     **1.36e-6 [8.9e-7, 1.83e-6]**, 31.6 effective failing draws, status 0, 1342 rotor runs,
     904 CPU s / 492 s wall: inside both line intervals, and both line estimates inside
     its own. Its coverage against the 420 pooled line terms (:data:`LINES_REFERENCE`,
     1.52e-6, :func:`mirrored_coverage`), 2000 draws a seed: of seeds 3001-3020, 15 of the
     17 status-0 intervals hold it and the 3 flagged ones (status 3) too, about
     1300 CPU s a seed; the status-0 estimates average 1.76e-06 (standard error
     6.3e-08), 1.7 joint standard errors above the lines' (the store,
     resumable towards 20 seeds:
     ``docs/data/rotor_mirrored_coverage.jsonl``; docs/benchmarks.md, "Sixth round" and
     "Seventh round").
   - ``subspace``, ``harmonic`` (densities fitted by cross-entropy on the cheap model),
     ``mfis`` and ``subset`` stay available; at this level their weights or levels do not
     vouch for an interval (status 3 or 1; docs/benchmarks.md, "The dynamic question",
     third to sixth rounds).

``--quick`` runs 12 rotor runs, subset simulation with 16 per level on the coarsest speed
grid (:data:`QUICK_OPTIONS`), the rare stage's methods at the moderate X with
:data:`CHEAP_OPTIONS` as their rotor (4 lines, 24 mirrored draws: their densities aim at
the rare level, so they end flagged, status 3 or 4: the code path, not an answer), all in
under a minute of CPU, and marks every figure "quick: N runs, not a result".

**On a gear stage** (``--stage e_axle_27_79`` or a stage TOML file; :func:`run_on_stage`):
the population stage on the stage's own rotor and speed range. Inputs: the pitch germ of its
tooth numbers (26 + 78 normals for 27/79), each gear at its own class (6 and 7) under the
capable process, the pair kept when both pass inspection; each relief of the drawing as an
inspected normal (8 +- 3 um per gear, 1 % of the process beyond, as the paper's relief); the
torque uniform on the stage's operating range (50-250 N m, the range its file's
``[random.mean_force]`` spans) and the damping ratio as the file declares it (uniform 1-5
%). ISO 6336-1 Method B takes the coarser class, 7. The steady states are solved by GMRES on
every harmonic, the reduced rotor integrated in time where Newton's method stagnates under
contact loss (:data:`STAGE_SOLVER`). ``--grade`` does not apply on a stage; subset
simulation at the moderate X runs with ``n_per_level`` > 0; the grouped Sobol' indices with
``sobol_base`` > 0 (a run without a steady state is solved again on the spectral orders,
:data:`STAGE_FALLBACK_SOLVER`; runs that stay without one void the indices, said so); the
rare level with ``--rare-x`` (subset simulation behind inspection's gate: the walk samples
the accepted law and a rejected pair costs no run, :func:`rare_subset_on_stage`,
``--rare-per-level`` a level; with ``--rare-methods subset,lines`` then line sampling along
the walk's failing mean in damping, torque and relief, :func:`lines_on_stage`; the rotor's
other rare methods need its cheap model or its known direction and are refused on a stage).
Measured on the e-axle (112 runs, seed 2028;
docs/benchmarks.md, "On the e-axle 27/79 stage", seventh round): every run has a steady
state; 101 pairs pass inspection (0.95^2 = 90.25 % expected) with ``kv_max`` 1.18 / 1.67 /
2.64 (5 / 50 / 95 %) against Method B's 1.41 / 1.52 / 2.06; 98 of them peak at 11 440-12 330
rpm, below the crossing of ``f_m`` with the 5.82 kHz mode (15 % of its strain energy in the
mesh) at 12 960 rpm, a speed that agrees with the sideband ``f_m + 2 f_s`` of the pinion's
pitch deviations on it; without pitch deviations K_v is 1.02. At X = 2.34 (the 90 %
quantile), P(kv_max >= X | pass) = 0.109 [0.056, 0.187] by count (11 of 101), 0.107 [0.066,
0.172] by subset simulation (489 runs, status 0). At ``--rare-x 3.2``: 3.1e-3 [5.2e-4,
5.8e-2], status 6 (669 runs, 3524 CPU s; 29 runs at damping 1.0-1.7 % without a periodic
response or a located peak, the interval covering both readings); the failures sit at
damping 1.0-1.9 % and torque 50-66 N m, and Pf about 1e-6 lies far above 3.2
(docs/benchmarks.md, eighth round). Behind the gate (tenth round) the walk's thresholds at
0.1, 1e-2, 1e-3 and 1e-4 are K_v 2.47, 2.95, 3.38 and 3.66 (399 runs, none on a rejected
pair), and at ``--rare-x 3.6`` it reads 6.6e-5 [4.8e-6, 1.7e-3] with status 1 (its failures
descend from one chain; one run with status 21 read as failed); 20 lines along damping,
torque and relief all miss that set (status 4, upper end 0.19). Rank correlations with
``kv_max``: pinion F_p +0.64, damping -0.50, torque -0.44, wheel F_p and the reliefs |rho|
<= 0.08. Grouped Sobol' totals (16 base samples, 112 runs): pinion pitch 0.37, load 0.25,
damping 0.23 (+-0.19-0.27), wheel pitch and relief 0.00; one run (damping 1.0 %) enters with
a lower bound of its peak (status 21: at 11 776 rpm it has no periodic response). The speeds
are swept up and, over the run-up's contact-loss ranges, down
(``sweep_direction="up_and_down"``): where the teeth separate two periodic responses can
coexist and the larger counts; on the e-axle the run-down raised ``kv_max`` by 0.02 on two
of 112 draws (docs/benchmarks.md, eighth round). Where a lightly damped draw rattles without
a periodic response, K_v at that speed is the largest mesh force over the time integration's
last 10 long periods (``aperiodic_response="window_max"``; the screen says how many runs and
speeds were read so).

Run: ``gearuq study geared_rotor_dynamic_factor [--quick] [--out DIR] [--grade 6|7]
[--stage NAME|FILE]``.
"""

from __future__ import annotations

import argparse
import functools
import inspect
import json
import math
import time
from pathlib import Path
from typing import Any

import numpy as np

import gearuq
from gearuq import plot
from gearuq.execution import evaluate_chunks, workers_for_run
from gearuq.failure import LimitState, describe_status, failure_probability
from gearuq.failure.intervals import clopper_pearson_interval
from gearuq.failure.methods.gated_lines import gated_line_sampling
from gearuq.failure.methods.subspace import (
    fit_subspace_density,
    gate_probability,
    given_gate,
    subspace_density,
    subspace_estimate,
)
from gearuq.gears.deviations import (
    capable_pitch_scatter,
    inspected_normal_spec,
    iso1328_pitch_tolerances,
    pitch_germ_basis,
    pitch_germ_names,
    pitch_germ_scales,
    total_cumulative_pitch_deviation,
)
from gearuq.gears.geometry import seed002_pair
from gearuq.gears.stage import GearStage
from gearuq.model import status_meanings
from gearuq.space import ParameterSpace

#: Model options of the study: the capable process law, 80 speeds (100 rpm steps; peaks
#: located to 1 rpm between them), three mesh harmonics.
OPTIONS: dict[str, Any] = {"pitch_tolerance_law": "capable_process",
                           "process_share_beyond": 0.05, "n_speeds": 80,
                           "range_mesh_harmonics": 3, "peaks_refined": 2}
OUTPUTS = ["kv_max", "speed_at_kv_max", "kv_over_speed", "kv_iso_over_speed", "kv_iso_max",
           "dte_mesh_band_rms_max", "bearing1_acceleration_y_mesh_order_max",
           "pitch_acceptance_margin", "pitch_total_deviation_pinion",
           "pitch_total_deviation_wheel"]
#: Cause groups of the Sobol' indices.
GROUPS = {"torque": "load", "tip_relief_amount": "relief", "damping_ratio": "damping",
          # a stage's reliefs of each gear (its drawing's tip reliefs)
          "pinion_tip_relief_amount": "relief", "wheel_tip_relief_amount": "relief",
          "pinion_root_relief_amount": "relief", "wheel_root_relief_amount": "relief"}
DEFAULT_EXECUTION: dict[str, Any] = {"executor": "processes", "chunk_size": 25}
#: The cheap fidelity of the rare stage: the same rotor on 20 speeds (420 rpm steps), two
#: mesh harmonics and the largest grid peak of K_v located to 10 rpm; about 0.29 CPU s a run
#: against 0.93-1.1 (docs/benchmarks.md, "The dynamic question": Pearson 0.9999 with the
#: rotor's ``kv_max``, within -0.010..+0.019 of it). Without the peak located (0.17 s) it
#: misses the resonance near 7800 rpm that the rare event lives on, by up to 0.24.
CHEAP_OPTIONS: dict[str, Any] = {**OPTIONS, "n_speeds": 20, "range_mesh_harmonics": 2,
                                 "peaks_refined": 1, "peak_speed_tol": 10.0}
#: The coarsest fidelity, for ``--quick`` only: 6 speeds, one mesh harmonic, no peak located
#: (about 0.06 CPU s a run against 0.39 for :data:`CHEAP_OPTIONS` and 0.84 for
#: :data:`OPTIONS`, measured side by side). ``--quick`` runs its subset simulation on it and
#: its rare stage with it as the cheap model and :data:`CHEAP_OPTIONS` as the rotor: the code
#: paths, not their answers.
QUICK_OPTIONS: dict[str, Any] = {**OPTIONS, "n_speeds": 6, "range_mesh_harmonics": 1,
                                 "peaks_refined": 0}
#: X of the rare stage, where P(kv_max >= X | pass) is about 1e-6 on the rotor by our
#: reading: six importance-sampling runs of four densities put it at 6.6e-8 .. 2.5e-6 here
#: (mean 8e-7), each with one draw carrying 26-85 % of its estimate, so no interval is
#: vouched for (docs/benchmarks.md, "Third round"). It was 1.83 (about 1e-7) until then.
#: Straight lines along harmonic 15 gave 1.3e-6 [7.1e-7, 1.9e-6] and 1.6e-6 [9.0e-7,
#: 2.4e-6] here, 14.7 and 16.5 effective lines of 60 and 130, status 3 (docs/benchmarks.md,
#: "Fourth round"); with the origins' density at the cross-entropy moments
#: (:data:`RARE_LINES`) 1.65e-6 [1.21e-6, 2.10e-6] (170 lines) and 1.44e-6 [1.13e-6,
#: 1.74e-6] (250 lines), both status 0 ("Fifth round").
RARE_X = 1.77
#: MFIS of the rare stage (``rare_methods=("mfis",)``): subset simulation on the cheap
#: model at 250 per level (about 1600 cheap runs, 460 CPU s), the Gaussian mixture fitted
#: to its last level (10 % defensive), the rotor in batches of 125 up to 500 runs (about
#: 500 CPU s) or a CoV of 0.2; at X = 1.83 its weights degenerated (docs/benchmarks.md).
RARE_MFIS: dict[str, Any] = {"biasing": "gaussian", "n_per_level": 250, "n_samples": 125,
                             "max_samples": 500, "target_cov": 0.2, "defensive": 0.1}
#: The rare stage of ``--quick``: the same code path with a few dozen runs.
QUICK_MFIS: dict[str, Any] = {**RARE_MFIS, "n_per_level": 100, "n_samples": 20,
                              "max_samples": 40, "target_cov": 0.5}


def load_stage(stage: str | Path | GearStage) -> GearStage:
    """A :class:`gearuq.GearStage` from a built-in name (``e_axle_27_79``) or a TOML path."""
    if isinstance(stage, GearStage):
        return stage
    if not isinstance(stage, (str, Path)):
        raise TypeError(f"stage={stage!r} must be a stage name, a TOML path or a GearStage")
    if str(stage) in GearStage.examples():
        return GearStage.example(str(stage))
    if Path(stage).is_file():
        return GearStage.from_toml(stage)
    raise ValueError(f"stage={str(stage)!r} is neither a built-in stage (valid: "
                     f"{', '.join(GearStage.examples())}) nor an existing TOML file")


#: The long-period solver of a hunting-tooth stage: GMRES on every harmonic (the plugin's
#: default), the reduced rotor integrated in time where Newton's method stagnates under
#: contact loss. On the 13 e-axle draws of seed 2028 whose steady states the spectral orders
#: (98 % of the energy, this setting before) could not find (status 16), it found all 13
#: (5.6-9.5 CPU s a run, ``kv_max`` 2.29-2.86); on 8 draws that both solve, it costs 0.6-6.1
#: CPU s a run and the spectral orders read ``kv_max`` 0.016-0.072 low (docs/benchmarks.md,
#: "On the e-axle 27/79 stage", seventh round). The speeds are swept up and, over the
#: run-up's contact-loss ranges, down (both of two coexisting responses seen; eighth round:
#: 15 % more GMRES iterations, ``kv_max`` 0.02 higher on two of 112 draws). A speed whose
#: response is not periodic on the long period (a rattle at 1-2 % damping) reads K_v as the
#: largest mesh force over the time integration's last 10 long periods
#: (``aperiodic_response="window_max"``, counted per run in ``aperiodic_speeds``): without
#: it those runs had no value and filled the rare level's walk (ninth round).
STAGE_SOLVER: dict[str, Any] = {"long_period_solver": "gmres",
                                "sweep_direction": "up_and_down",
                                "aperiodic_response": "window_max"}
#: Where GMRES finds no steady state on a stage (its iteration budget spent under deep
#: contact loss), the grouped Sobol' design's run is solved again on the spectral orders
#: (the setting before :data:`STAGE_SOLVER`; ``kv_max`` 0.00-0.11 lower, 0.04 on average,
#: on 99 e-axle draws both solve), so that one hole does not void the design; the count is
#: reported (``retried``).
STAGE_FALLBACK_SOLVER: dict[str, Any] = {"long_period_solver": "spectral_orders",
                                         "spectral_energy": 0.98}


#: Speeds of ``--quick --stage`` (80 otherwise), whose peaks are not located (grid maxima):
#: its eight runs check the code path. Locating the peaks is what costs: on the two
#: light-load draws of seed 2028 (63 and 70 N m, one losing its steady state) 33 and 20 CPU s
#: a run with them located, 4 and 6 without (docs/benchmarks.md).
QUICK_STAGE_SPEEDS = 20


def stage_options(stage: GearStage, quick: bool = False) -> dict[str, Any]:
    """:data:`OPTIONS` on the stage's own speed range (its ``[operation] speed``), with
    :data:`STAGE_SOLVER` (used only when the stage's long period is a hunting tooth's); on
    :data:`QUICK_STAGE_SPEEDS` speeds, peaks not located, when ``quick``."""
    low, high = stage.operation.speed
    return {**OPTIONS, **STAGE_SOLVER, "speed_min": float(low), "speed_max": float(high),
            **({"n_speeds": QUICK_STAGE_SPEEDS, "peaks_refined": 0} if quick else {})}


def study_model(grade: int = 6, stage: GearStage | None = None) -> gearuq.Model:
    """The rotor with both gears of ISO 1328-1 class ``grade``; or the rotor of ``stage``
    with the stage's own classes (``grade`` is then not used)."""
    if stage is not None:
        return gearuq.get_model("geared_rotor", stage=stage)
    return gearuq.get_model("geared_rotor").with_nominal(iso_grade=grade)


def study_space(stage: GearStage | None = None) -> ParameterSpace:
    """Pitch germs, inspected relief, load spread and damping (module docstring).

    On a ``stage``: the germ of its tooth numbers (``z - 1`` normals per gear), each relief
    of the drawing as an inspected normal (its amount and tolerance, 1 % beyond), the torque
    uniform on its operating range and the laws its ``[random.*]`` tables declare for
    parameters of the rotor (the e-axle's ``damping_ratio``; without one, uniform 3-8 %).
    """
    if stage is not None:
        return _stage_space(stage)
    germ = {f"pitch_xi_{g}_{k}": {"dist": "normal", "mean": 0.0, "std": 1.0}
            for g in ("p", "g") for k in range(1, 30)}
    return ParameterSpace({
        **germ,
        "tip_relief_amount": inspected_normal_spec(42.0, 5.0, 0.01),
        "torque": {"dist": "lognormal", "mean": 1000.0, "std": 100.0},
        "damping_ratio": {"dist": "uniform", "lower": 0.03, "upper": 0.08},
    })


def _stage_space(stage: GearStage) -> ParameterSpace:
    names = set(study_model(stage=stage).parameter_names)
    spec: dict[str, Any] = {name: {"dist": "normal", "mean": 0.0, "std": 1.0}
                            for gear, z in ((1, stage.teeth[0]), (2, stage.teeth[1]))
                            for name in pitch_germ_names(z, gear) if name in names}
    for gear in ("pinion", "wheel"):
        for kind in ("tip", "root"):
            relief = getattr(getattr(stage, gear), f"{kind}_relief")
            # a relief of its own, or the one shared parabolic tip relief of the paper's route
            name = next((n for n in (f"{gear}_{kind}_relief_amount", f"{kind}_relief_amount")
                         if n in names), None)
            if relief is not None and name is not None and relief.amount_tolerance > 0:
                spec[name] = inspected_normal_spec(relief.amount, relief.amount_tolerance,
                                                   0.01)
    spec["torque"] = {"dist": "uniform", "lower": stage.operation.torque[0],
                      "upper": stage.operation.torque[1]}
    spec["damping_ratio"] = {"dist": "uniform", "lower": 0.03, "upper": 0.08}
    spec |= {name: dict(law) for name, law in stage.random if name in names}
    return ParameterSpace(spec)


def accepted() -> LimitState:
    """'Failure' side = the pair passes inspection (both F_p <= F_pT)."""
    return LimitState.upper("pitch_acceptance_margin", 0.0, name="passes_inspection")


#: The geared rotor's status of a sample whose every grid speed converged but a steady state
#: failed while a resonance peak was being located: its ``kv_max`` is the largest value found
#: before it, a lower bound of the peak (the plugin's ``physics.STATUS_PEAK_NOT_LOCATED``,
#: meaning ``steady_state_failed_while_locating_a_peak``; a test holds the two equal).
PEAK_NOT_LOCATED = 21


def kv_exceeds(x: float) -> LimitState:
    """K_v somewhere in the speed range at or above ``x``.

    A run whose peak could not be located (:data:`PEAK_NOT_LOCATED`) has a ``kv_max``
    that is a lower bound of its peak: it is censored (subset simulation reads it at that
    bound while it explores, instead of as failed; it stays an invalid run in the counts)."""
    return LimitState.upper("kv_max", x, name=f"kv_max >= {x:.4g}",
                            censored_statuses=[PEAK_NOT_LOCATED])


def population(n: int, seed: int, grade: int, out: Path,
               execution: dict[str, Any], stage: GearStage | None = None,
               quick: bool = False) -> Any:
    """``n`` rotor runs of the untruncated process, stored (a rerun reuses them); on a
    ``stage``, its rotor, inputs and speed range (store ``mc_store_<stage name>``), on
    :data:`QUICK_STAGE_SPEEDS` speeds when ``quick``."""
    store, options = ((f"mc_store_grade{grade}", OPTIONS) if stage is None
                      else (f"mc_store_{stage.name}", stage_options(stage, quick)))
    store += "_quick" if quick else ""
    return gearuq.monte_carlo(study_model(grade, stage), study_space(stage), None,
                              n_samples=n, rng=seed, outputs=OUTPUTS, store=out / store,
                              progress=False, model_options=options, **execution)


def conditional_count(ds: Any, x: float) -> dict[str, float]:
    """P(kv_max >= x | pass) by counting, Clopper-Pearson interval over the accepted runs."""
    ok = ds["status"].values == 0
    acc = (ds["pitch_acceptance_margin"].values >= 0) & ok
    k = int(np.sum(acc & (ds["kv_max"].values >= x)))
    n = int(acc.sum())
    lo, up = clopper_pearson_interval(k, n)
    return {"pf": k / max(n, 1), "lower": float(lo), "upper": float(up), "failures": k,
            "accepted": n, "runs": int(ok.size), "invalid": int((~ok).sum())}


def given_acceptance(rep: Any, p_pass: tuple[float, float]) -> dict[str, Any]:
    """A report of P(fail and pass) turned into P(fail | pass) by :func:`given_gate`.

    ``p_pass``: P(pass) and its standard error as counted (:func:`accepted_probability` on
    the paper's rotor), not the declared ``(1 - process_share_beyond)^2``: the capable
    process's F_p quantile is itself estimated once (200 000 germs of a fixed seed), so the
    share it puts beyond F_pT is not exactly 5 %: on the paper's rotor P(pass) = 0.9033
    (standard error 2e-4) against 0.9025 declared. The interval's ends are divided by
    P(pass)'s upper and lower ends.
    """
    cov = float(rep["cov_pf"]) if "cov_pf" in rep else math.nan
    est = {"pf": float(rep["pf"]), "lower": float(rep["pf_lower"]),
           "upper": float(rep["pf_upper"]), "cov": cov}
    out = given_gate(est, *p_pass)
    return {"pf": out["pf"], "lower": out["lower"], "upper": out["upper"],
            "status": int(rep["status"]), "message": describe_status(rep),
            "runs": int(rep["n_model_runs"]), "wall": float(rep["wall_time"]),
            "p_pass": p_pass[0], "p_pass_se": p_pass[1]}


@functools.lru_cache(maxsize=4)
def accepted_probability(grade: int, stage: GearStage | None = None,
                         n: int = 2_000_000) -> tuple[float, float]:
    """P(pass) of the paper's pair at class ``grade`` (or of ``stage``) and its standard
    error: the share of ``n`` germ pairs (seed 0) that :func:`germ_acceptance_margin`
    accepts (two million: about 5 CPU s on the paper's pair, 12 on the e-axle; once a
    process). Every rare path of the study divides by this one count."""
    dim = 58 if stage is None else sum(stage.teeth) - 2
    return gate_probability(_acceptance_gate(grade, stage), dim,
                            n=n, seed=0)


def subset_given_acceptance(x: float, seed: int, grade: int, n_per_level: int,
                            execution: dict[str, Any],
                            options: dict[str, Any] | None = None,
                            stage: GearStage | None = None, **settings: Any) -> dict[str, Any]:
    """P(fail and pass) by subset simulation on the parallel system, over P(pass).

    On the paper's rotor at class ``grade``, or on ``stage`` (its model, space and
    :func:`stage_options`; ``grade`` not used). ``settings`` go to
    :func:`gearuq.failure.failure_probability` (``max_levels``, ``store``). Besides
    :func:`given_acceptance`'s fields: ``levels``, the conditional levels run.
    """
    if stage is not None:
        grade = 0
    model, space = study_model(grade, stage), study_space(stage)
    system = gearuq.ParallelSystem([kv_exceeds(x), accepted()])
    default = OPTIONS if stage is None else stage_options(stage)
    rep = failure_probability(model, space, system, method="subset", rng=seed,
                              n_per_level=n_per_level, model_options=options or default,
                              **settings, **execution)
    levels = int(np.size(rep["level_threshold"])) if "level_threshold" in rep else 0
    return {**given_acceptance(rep, accepted_probability(grade, stage)), "levels": levels}


def mfis_given_acceptance(x: float, seed: int, grade: int, settings: dict[str, Any],
                          execution: dict[str, Any], options: dict[str, Any] | None = None,
                          cheap_options: dict[str, Any] | None = None) -> dict[str, Any]:
    """P(kv_max >= x | pass) by multi-fidelity importance sampling on the parallel system.

    The cheap model is the same rotor at ``cheap_options`` (default :data:`CHEAP_OPTIONS`),
    the same system on its outputs; MFIS measures the discrepancy of the two on its pilot
    and widens the cheap failure set by it. ``settings`` are MFIS's (:data:`RARE_MFIS`).
    """
    model, space = study_model(grade), study_space()
    system = gearuq.ParallelSystem([kv_exceeds(x), accepted()])
    rep = failure_probability(model, space, system, method="mfis", rng=seed,
                              low_fidelity=model,
                              low_fidelity_options=cheap_options or CHEAP_OPTIONS,
                              model_options=options or OPTIONS, **settings, **execution)
    return {**given_acceptance(rep, accepted_probability(grade)),
            "cheap_runs": int(rep["n_low_fidelity_runs"]),
            "discrepancy_measured": float(rep["discrepancy_measured"]),
            "discrepancy_bound": float(rep["discrepancy_bound"]),
            "widened": bool(rep["widened"]), "cov": float(rep["cov_pf"])}


#: The rare stage's importance sampling in a few directions (:func:`subspace_given_acceptance`):
#: cross-entropy on the cheap model, ``n_per_level`` draws a level, to ``X - widen`` (the
#: cheap model's K_v is within -0.010..+0.019 of the rotor's on the draws compared), then
#: fresh draws of the fitted density on the cheap model (``n_cheap``) and on the rotor
#: (``n_rotor``); pitch directions from finite-difference gradients of the cheap K_v
#: (step ``step``) at the ``n_bases`` largest of ``n_germs`` accepted germs at the corner
#: (damping 3 %, torque at its 1 % quantile, nominal relief).
RARE_SUBSPACE: dict[str, Any] = {"n_per_level": 200, "p0": 0.1, "defensive": 0.1,
                                 "min_std": 1.0, "widen": 0.03, "n_cheap": 500,
                                 "n_rotor": 300, "n_germs": 30, "n_bases": 4, "step": 0.1,
                                 "n_pitch_directions": 3}
#: The same stage in ``--quick``: the code path with a few dozen runs.
QUICK_SUBSPACE: dict[str, Any] = {**RARE_SUBSPACE, "n_per_level": 40, "n_cheap": 40,
                                  "n_rotor": 12, "n_germs": 6, "n_bases": 1,
                                  "n_pitch_directions": 1}
#: Inputs of the study space other than the 58 pitch germs, in its order.
_OTHER = ("tip_relief_amount", "torque", "damping_ratio")
#: Tooth-to-tooth pitch harmonics whose pinion-plus-wheel sums carry the rare K_v: the cheap
#: K_v's gradients at the low-damping, light-load corner lean on them (docs/benchmarks.md,
#: "The dynamic question").
RARE_HARMONICS = (12, 13, 14, 15)
#: The rare stage's importance sampling centred in the harmonic planes
#: (``rare_methods=("harmonic",)``, :func:`harmonic_planes`): the settings of
#: :data:`RARE_SUBSPACE` without the gradient directions, cross-entropy at 150 a level.
RARE_HARMONIC: dict[str, Any] = {**RARE_SUBSPACE, "harmonics": RARE_HARMONICS,
                                 "n_per_level": 150, "n_cheap": 400, "n_rotor": 250}
#: The same in ``--quick`` (``rare_methods=("harmonic",)``): the code path, a few dozen runs.
QUICK_HARMONIC: dict[str, Any] = {**QUICK_SUBSPACE, "harmonics": RARE_HARMONICS}


def harmonic_planes(harmonics: tuple[int, ...] = RARE_HARMONICS
                    ) -> tuple[np.ndarray, list[list[int]]]:
    """Directions (61 x k, orthonormal) of the rare density and its centred groups.

    Relief, torque and damping, in which the density may shift; then, for each tooth-to-tooth
    harmonic ``m`` of ``harmonics``, the cosine and sine of the pinion-plus-wheel germ sum
    ``(xi_p + xi_g) / sqrt 2`` (the cosine alone at ``m = z / 2 = 15``). Each harmonic's
    columns form a group in which the density stays centred and isotropic
    (:func:`gearuq.failure.methods.subspace.fit_subspace_density`, ``centred``): K_v depends
    on a harmonic's amplitude, not its phase, so its failure set in that plane is an annulus
    that a mean shift would reach at one phase only.
    """
    names = study_space().names
    n_germ = len(pitch_germ_names(seed002_pair().z1, 1))
    if any(int(m) != m or not 1 <= m <= (n_germ + 1) // 2 for m in harmonics):
        raise ValueError(f"harmonics={harmonics!r} is outside its valid range: integers "
                         f"1..{(n_germ + 1) // 2}")
    cols, groups = [], []
    for name in _OTHER:
        cols.append(np.eye(len(names))[names.index(name)])
    for m in harmonics:
        group = []
        for c in (2 * m - 2, 2 * m - 1):
            if c < n_germ:
                col = np.zeros(len(names))
                col[c] = col[n_germ + c] = math.sqrt(0.5)
                group.append(len(cols))
                cols.append(col)
        groups.append(group)
    return np.array(cols).T, groups


def germ_acceptance_margin(u: np.ndarray, grade: int,
                           stage: GearStage | None = None) -> np.ndarray:
    """``pitch_acceptance_margin`` of the rotor from the germs alone, vectorised.

    ``u``: draws ``(n, >= 58)`` in the study space's order (``pitch_xi_p_1..29``,
    ``pitch_xi_g_1..29`` first; on a ``stage``, its ``z1 - 1`` then ``z2 - 1`` germ
    normals, each gear at its own class, ``grade`` unused). The same formula as the plugin's
    output (min over both gears of ``1 - F_p / F_pT``, the capable process of ``OPTIONS``),
    without the rotor: a million pairs in seconds, so the accepted law is sampled exactly by
    rejection.
    """
    pair = seed002_pair() if stage is None else stage.pair
    grades = (grade, grade) if stage is None else (stage.pinion.iso_grade,
                                                   stage.wheel.iso_grade)
    if stage is not None and any(g.single_pitch_deviations is not None
                                 for g in (stage.pinion, stage.wheel)):
        raise ValueError(f"stage={stage.name!r} declares measured pitch deviations: its "
                         "margin is not a function of the germ alone; valid: a stage without")
    margins, start = [], 0
    for z, d, g in ((pair.z1, pair.d1, grades[0]), (pair.z2, pair.d2, grades[1])):
        f_pT, F_pT = iso1328_pitch_tolerances(d, pair.mn, g)
        amp, sigma = capable_pitch_scatter(z, f_pT, F_pT, OPTIONS["process_share_beyond"])
        scales = pitch_germ_scales(z, amplitude=amp, sigma=sigma)
        xi = u[:, start:start + scales.size]
        start += scales.size
        fp = (xi * scales) @ pitch_germ_basis(z, scales.size)
        margins.append(1.0 - total_cumulative_pitch_deviation(fp) / F_pT)
    return np.minimum(*margins)


class AcceptanceGate:
    """``gate(u) -> bool mask``: inspection accepts the pair of the germs in ``u``
    (:func:`germ_acceptance_margin` at least 0), the gate the rare methods take.

    An object rather than a closure so that its ``repr`` names the class and stage: a
    resumable run's store recognises the same gate in the next process.
    """

    def __init__(self, grade: int, stage: GearStage | None = None) -> None:
        self.grade, self.stage = grade, stage

    def __call__(self, u: np.ndarray) -> np.ndarray:
        return germ_acceptance_margin(u, self.grade, self.stage) >= 0.0

    def __repr__(self) -> str:
        where = f"stage={self.stage.name!r}" if self.stage else f"grade={self.grade}"
        return f"AcceptanceGate({where})"


def _acceptance_gate(grade: int, stage: GearStage | None = None) -> AcceptanceGate:
    """The inspection gate of the paper's pair at class ``grade`` or of ``stage``."""
    return AcceptanceGate(grade, stage)


def _kv_on_normals(model: gearuq.Model, options: dict[str, Any], execution: dict[str, Any],
                   x: float, stage: GearStage | None = None, store: Path | None = None) -> Any:
    """``limit(u) -> (x - kv_max, ok)`` of the model on standard normal draws ``u`` (of the
    paper's rotor's space, or of ``stage``'s). With a ``store``, call ``k`` keeps its runs
    in ``store/call_k``: a method whose calls are a deterministic sequence resumes."""
    space = study_space(stage)
    request = model.prepare(None, outputs=["kv_max"], **options)
    calls = [0]

    def limit(u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        design = {n: space.marginal(n).from_normal(u[:, j]) for j, n in enumerate(space.names)}
        where = None if store is None else {"store": store / f"call_{calls[0]:04d}"}
        calls[0] += 1
        ds = evaluate_chunks(model, design, request, progress=False, **execution,
                             **(where or {}))
        ok = ds["status"].values == 0
        return np.where(ok, x - ds["kv_max"].values, np.nan), ok

    return limit


def rare_directions(grade: int, seed: int, settings: dict[str, Any],
                    execution: dict[str, Any], cheap_options: dict[str, Any]
                    ) -> tuple[np.ndarray, dict[str, Any]]:
    """Orthonormal directions (61 x k) the rare stage's density may move in.

    Damping, torque and relief, and the ``n_pitch_directions`` leading right singular
    vectors of the cheap K_v's gradients in the 58 pitch germs, taken by forward differences
    at the ``n_bases`` largest of ``n_germs`` accepted germs at the corner where K_v is
    largest (damping 3 %, torque at its 1 % quantile, nominal relief). On the paper's
    30/30 pair the gradients of pinion and wheel germs are equal (each tooth meets the
    same mate: the mesh sees their sum) and lean on the tooth-to-tooth harmonics 12-15.
    """
    space = study_space()
    model, names = study_model(grade), space.names
    rng = np.random.default_rng(seed)
    germs = rng.standard_normal((4 * settings["n_germs"] + 20, 58))
    germs = germs[germ_acceptance_margin(germs, grade) >= 0][:settings["n_germs"]]
    corner = {"tip_relief_amount": 42.0, "damping_ratio": 0.03,
              "torque": float(space.ppf("torque", 0.01))}
    request = model.prepare(None, outputs=["kv_max"], **cheap_options)

    def kv(points: np.ndarray) -> np.ndarray:
        design = {n: points[:, j] for j, n in enumerate(names[:58])}
        design |= {n: np.full(len(points), v) for n, v in corner.items()}
        ds = evaluate_chunks(model, design, request, progress=False, **execution)
        if not np.all(ds["status"].values == 0):
            raise RuntimeError("rare directions: a cheap rotor run failed at the corner")
        return ds["kv_max"].values

    base_kv = kv(germs)
    grads = []
    for b in np.argsort(-base_kv)[:settings["n_bases"]]:
        steps = germs[b] + settings["step"] * np.eye(58)
        grads.append((kv(steps) - base_kv[b]) / settings["step"])
    _, sv, vt = np.linalg.svd(np.array(grads), full_matrices=False)
    k = int(settings["n_pitch_directions"])
    basis = np.zeros((len(names), 3 + k))
    for j, n in enumerate(_OTHER):
        basis[names.index(n), j] = 1.0
    basis[:58, 3:] = vt[:k].T
    return basis, {"corner_kv": np.sort(base_kv)[::-1][:settings["n_bases"]].tolist(),
                   "singular_values": sv.tolist(),
                   "runs": int(base_kv.size + 58 * len(grads))}


def subspace_given_acceptance(x: float, seed: int, grade: int, settings: dict[str, Any],
                              execution: dict[str, Any], options: dict[str, Any] | None = None,
                              cheap_options: dict[str, Any] | None = None) -> dict[str, Any]:
    """P(kv_max >= x | pass) by importance sampling moved in a few directions only.

    The accepted law is sampled exactly (inspection is a gate on the germs,
    :func:`germ_acceptance_margin`: rejected pairs cost no run); the density moves only
    damping, torque, relief and a few pitch directions (:func:`rare_directions`), fitted by
    cross-entropy on the cheap model (:data:`CHEAP_OPTIONS`) to ``x - widen``, so its
    weights depend on a handful of coordinates, are bounded by ``1 / defensive`` and cannot
    degenerate in 61 dimensions (:mod:`gearuq.failure.methods.subspace`). Fresh draws of the
    density then give the cheap model's and the rotor's estimates, each unbiased whatever the
    fit; P(pass) is counted on two million germ pairs.

    Returns
    -------
    dict
        ``"cheap"`` and ``"rotor"``: ``pf``, ``lower``, ``upper`` (95 %), ``cov``,
        ``status``, ``message``, ``runs``, ``ess``, ``max_share``, ``lower_one_sided``
        (Markov's 95 % lower bound, which holds whatever the status); ``"fit"``: the
        cross-entropy levels and runs; ``"directions"``; ``"p_pass"``.
    """
    cheap_options = cheap_options or CHEAP_OPTIONS
    model = study_model(grade)
    if settings.get("harmonics"):
        basis, groups = harmonic_planes(tuple(settings["harmonics"]))
        directions: dict[str, Any] = {"harmonics": list(settings["harmonics"]), "runs": 0}
    else:
        basis, directions = rare_directions(grade, seed, settings, execution, cheap_options)
        groups = None

    gate = _acceptance_gate(grade)

    density, fit = fit_subspace_density(
        _kv_on_normals(model, cheap_options, execution, x - settings["widen"]), basis,
        n_per_level=settings["n_per_level"], seed=seed, gate=gate, p0=settings["p0"],
        defensive=settings["defensive"], min_std=settings["min_std"], centred=groups,
        keep_levels=bool(settings.get("keep_levels", False)))
    p_pass, se_pass = accepted_probability(grade)
    out: dict[str, Any] = {"X": x, "p_pass": p_pass, "directions": directions,
                           "fit": {"levels": fit["levels"], "runs": fit["runs"],
                                   "reached": fit["reached"]}}
    for name, opts, n in (("cheap", cheap_options, settings["n_cheap"]),
                          ("rotor", options or OPTIONS, settings["n_rotor"])):
        seen: list[tuple[np.ndarray, np.ndarray]] = []
        est = subspace_estimate(_recorded(_kv_on_normals(model, opts, execution, x), seen),
                                density, n=n, seed=seed + (1 if name == "cheap" else 2),
                                gate=gate)
        out[name] = {**given_gate(est, p_pass, se_pass),
                     **{k: est[k] for k in ("status", "message", "runs", "ess", "max_share",
                                            "n_fail", "pareto_k")},
                     "pf_over_x": _pf_over_x(seen, density, n, x, p_pass)}
    return out


#: The rare stage's second method (``rare_methods=("lines",)``,
#: :func:`lines_given_acceptance`): straight lines along the pinion-plus-wheel coordinate of
#: the alternating tooth-to-tooth harmonic 15 (``along``), where the heaviest radial lines of
#: the fourth round pointed; each line's origin (relief, torque, damping and the planes of
#: harmonics 12-14) drawn from a defensive mixture (``origin_means``, ``origin_std``; every
#: weight at most 1 / 0.3) at the cross-entropy moments of the 250 line terms of three
#: earlier straight runs: relief +0.47, torque -2.16, damping -1.96 standard units with
#: spreads 0.86, 0.67 and 0.51, the harmonic planes widened to 1.4. K_v on ``t_grid`` and at
#: the crossings (secant to ``root_tol``). At X = 1.77 on the rotor, 170 lines (seed 2042):
#: 1.65e-6 [1.21e-6, 2.10e-6], 42 effective lines, status 0, 1509 runs, 1034 CPU s / 574 s
#: wall on two quiet cores (inside the issue's 10 minutes); 250 lines (seed 2041): 1.44e-6
#: [1.13e-6, 1.74e-6], 66 effective lines, status 0, 1621 CPU s / 879 s wall
#: (docs/benchmarks.md, "Fifth round").
RARE_LINES: dict[str, Any] = {"n_lines": 170, "harmonics": RARE_HARMONICS, "along": 15,
                              "t_grid": (-6.0, -4.0, 0.0, 4.0, 6.0), "root_tol": 0.005,
                              "chunk_lines": 85,
                              "origin_means": (0.47, -2.16, -1.96) + (0.0,) * 6,
                              "origin_std": (0.86, 0.67, 0.51) + (1.4,) * 6,
                              "origin_defensive": 0.3}
#: The radial variant (``along`` None): lines in the 10 directions of
#: :func:`harmonic_planes`, their directions drawn from projected normals about
#: ``direction_means`` (relief +0.8, torque -1.2, damping -1.2, harmonic 15 at +-2.3: 3 times
#: the heavy lines' mean direction over three pilots), 30 % uniform. At X = 1.77 it left
#: 1.4-8.7 effective lines of 80-100 (docs/benchmarks.md, "Fourth round").
RADIAL_LINES: dict[str, Any] = {"n_lines": 100, "harmonics": RARE_HARMONICS, "along": None,
                                "t_grid": (-9.0, -6.0, 0.0, 6.0, 9.0), "root_tol": 0.005,
                                "chunk_lines": 100,
                                "direction_means": tuple((0.8, -1.2, -1.2) + (0.0,) * 6 + (h,)
                                                         for h in (2.3, -2.3)),
                                "direction_defensive": 0.3}
#: The same in ``--quick``: the code path with a few dozen runs.
QUICK_LINES: dict[str, Any] = {**RARE_LINES, "n_lines": 4, "t_grid": (-4.0, 0.0, 4.0),
                               "root_tol": 0.05, "chunk_lines": 4}


def _origin_moments(settings: dict[str, Any], exact: bool
                    ) -> tuple[np.ndarray, int, np.ndarray, np.ndarray]:
    """The columns of :func:`harmonic_planes` that ``settings["origin_means"]`` and
    ``settings["origin_std"]`` move (relief, torque, damping, then the planes of the
    harmonics before ``settings["along"]``), one mean and one standard deviation each.

    Returns the planes, the column of ``along``'s pinion-plus-wheel coordinate, the means and
    the standard deviations (ones where ``origin_std`` is not set). With ``exact`` every
    column before ``along``'s must be given, otherwise at most those.
    """
    planes, groups = harmonic_planes(tuple(settings["harmonics"]))
    column = groups[list(settings["harmonics"]).index(settings["along"])][0]
    shift = np.array(settings["origin_means"], dtype=float)
    spread = np.array(settings.get("origin_std", np.ones(shift.size)), dtype=float)
    if (shift.size != column if exact else shift.size > column) or spread.shape != shift.shape:
        count = f"{column}" if exact else f"at most {column}"
        raise ValueError(f"origin_means={settings['origin_means']!r} is outside its valid "
                         f"range: {count} values (the columns before harmonic "
                         f"{settings['along']}'s), one origin_std each")
    return planes, column, shift, spread


def lines_given_acceptance(x: float, seed: int, grade: int, settings: dict[str, Any],
                           execution: dict[str, Any], options: dict[str, Any] | None = None
                           ) -> dict[str, Any]:
    """P(kv_max >= x | pass) by line sampling behind the inspection gate.

    A method that shares no estimator code with the importance samplers and has no weight
    along its lines (:func:`gearuq.failure.methods.gated_lines.gated_line_sampling`):
    inspection's verdict along each line is exact without the rotor
    (:func:`germ_acceptance_margin`, bisected), the rotor runs on the accepted part only,
    and the line's probability is the mass of {t : kv_max >= x and accepted}. With
    ``settings["along"]`` (:data:`RARE_LINES`) the lines are straight, along that harmonic's
    pinion-plus-wheel coordinate (``t`` standard normal), and their origins are drawn from a
    defensive mixture moving the leading columns of :func:`harmonic_planes`
    (``origin_means``, ``origin_std``, ``origin_defensive``); without it
    (:data:`RADIAL_LINES`) they are radial in the planes' span (``|t|`` chi), their
    directions optionally drawn about ``direction_means``. Every weight is at most
    1 / defensive, the mean of the i.i.d. line terms is unbiased whatever the settings, and
    its normal interval is vouched for when enough lines carry it (status 0); it is then
    divided by the counted P(pass) (:func:`accepted_probability`).

    Returns
    -------
    dict
        ``pf``, ``lower``, ``upper`` (95 %, given acceptance), ``cov``, ``status``,
        ``message``, ``runs``, ``n_lines``, ``n_effective``, ``lines_gated_out``,
        ``lines_by_crossings`` (0, 1, 2, more), ``max_weight``, ``p_pass`` and the per-line
        ``line_pf`` (of P(fail and pass)) and ``line_weight``.

    Raises
    ------
    ValueError
        More ``origin_means`` than columns before the line's, or ``origin_std`` of another
        length.
    """
    planes, groups = harmonic_planes(tuple(settings["harmonics"]))
    basis, origin_density, means = planes, None, settings.get("direction_means")
    if settings.get("along") is not None:
        # straight lines along one harmonic's pinion-plus-wheel coordinate (the first of its
        # plane); the origins' relief, torque and damping from a shifted defensive mixture
        planes, column, shift, spread = _origin_moments(settings, exact=False)
        basis, means = planes[:, column:column + 1], None
        origin_density = subspace_density(planes[:, :shift.size], shift, np.diag(spread**2),
                                          float(settings["origin_defensive"]))

    gate = _acceptance_gate(grade)

    est = gated_line_sampling(
        _kv_on_normals(study_model(grade), options or OPTIONS, execution, x), basis,
        n_lines=int(settings["n_lines"]), seed=seed, gate=gate,
        t_grid=np.array(settings["t_grid"], dtype=float), root_tol=settings["root_tol"],
        chunk_lines=int(settings["chunk_lines"]),
        direction_means=None if means is None else np.array(means, dtype=float),
        direction_defensive=float(settings.get("direction_defensive", 0.3)),
        origin_density=origin_density)
    p_pass, se_pass = accepted_probability(grade)
    return {**given_gate(est, p_pass, se_pass),
            **{k: est[k] for k in ("status", "message", "runs", "n_lines", "n_effective",
                                   "lines_gated_out", "lines_by_crossings", "max_weight")},
            "line_weight": est["line_weight"].tolist(),
            "p_pass": p_pass, "p_pass_se": se_pass, "X": x,
            "line_pf": est["line_pf"].tolist()}


#: The rare stage's importance sampling mirrored along harmonic 15
#: (``rare_methods=("mirrored",)``, :func:`mirrored_given_acceptance`): a share
#: ``defensive`` of the standard normal (every weight at most 1 / 0.3), the rest two
#: components of equal share, each a normal at the moments of the straight lines' origins
#: (:data:`RARE_LINES`: relief, torque, damping and the planes of harmonics 12-14) times,
#: along harmonic 15's pinion-plus-wheel coordinate, a normal at ``+along_mean`` or
#: ``-along_mean`` with ``along_std`` (K_v fails at both ends of that coordinate, so a
#: one-sided shift would miss half the failure set); ``along_mean`` 3.6 and ``along_std``
#: 1.0: the lines' line terms put E|t| given failure at 3.58-3.75 (spread 0.53-0.60),
#: widened. ``n_rotor`` 2000: 1500 draws gave 31.6 effective failing draws at X = 1.77,
#: just above ``min_ess``.
#: ``min_ess``: fewer effective failing draws give status 3 (the lines' rule).
RARE_MIRRORED: dict[str, Any] = {"harmonics": RARE_HARMONICS, "along": 15,
                                 "along_mean": 3.6, "along_std": 1.0,
                                 "origin_means": RARE_LINES["origin_means"],
                                 "origin_std": RARE_LINES["origin_std"], "defensive": 0.3,
                                 "n_rotor": 2000, "batch": 250, "target_cov": 0.2,
                                 "min_ess": 30.0}
#: The same in ``--quick``: the code path with a few dozen runs.
QUICK_MIRRORED: dict[str, Any] = {**RARE_MIRRORED, "n_rotor": 24, "batch": 24}


def mirrored_density(settings: dict[str, Any]) -> Any:
    """The defensive mixture of :func:`mirrored_given_acceptance` (``settings`` as
    :data:`RARE_MIRRORED`): moved in the columns of :func:`harmonic_planes` up to and
    including the first of ``along``'s plane, two components mirrored in that one."""
    planes, column, shift, spread = _origin_moments(settings, exact=True)
    for name in ("along_mean", "along_std"):
        if not float(settings[name]) > 0.0:
            raise ValueError(f"{name}={settings[name]!r} is outside its valid range (0, inf)")
    means = np.zeros((2, column + 1))
    means[:, :column] = shift
    means[:, column] = (settings["along_mean"], -settings["along_mean"])
    cov = np.diag(np.append(spread, settings["along_std"]) ** 2)
    return subspace_density(planes[:, :column + 1], means, np.stack([cov, cov]),
                            float(settings["defensive"]))


def mirrored_given_acceptance(x: float, seed: int, grade: int, settings: dict[str, Any],
                              execution: dict[str, Any],
                              options: dict[str, Any] | None = None) -> dict[str, Any]:
    """P(kv_max >= x | pass) by importance sampling of a density set, not fitted.

    The density (:func:`mirrored_density`): the standard normal as its defensive share, the
    rest at the moments of the straight lines' origins times two normals mirrored along
    harmonic 15's pinion-plus-wheel coordinate, where
    :func:`lines_given_acceptance` found the failure set: an estimator (fresh weighted draws,
    :func:`gearuq.failure.methods.subspace.subspace_estimate`) that shares no code with the
    lines' and is unbiased whatever the density; inspection's gate is applied before any run.
    Status 3 below ``settings["min_ess"]`` effective failing draws, where the weights' other
    diagnostics give 0 or 1: a heavy-tailed sum of a few dozen terms understates its own
    variance (a threshold that flags the thinnest runs only: docs/reliability.md, "What
    status 0 does not promise").

    Returns
    -------
    dict
        ``pf``, ``lower``, ``upper`` (95 %, given acceptance), ``cov``, ``status``,
        ``message``, ``runs``, ``ess``, ``max_share``, ``n_fail``, ``lower_one_sided``
        (Markov's bound, whatever the status), ``pf_over_x``, ``p_pass``, ``X``.
    """
    density = mirrored_density(settings)
    gate = _acceptance_gate(grade)
    seen: list[tuple[np.ndarray, np.ndarray]] = []
    limit = _recorded(_kv_on_normals(study_model(grade), options or OPTIONS, execution, x),
                      seen)
    est = subspace_estimate(limit, density, n=int(settings["n_rotor"]), seed=seed, gate=gate,
                            batch=int(settings["batch"]),
                            target_cov=float(settings["target_cov"]),
                            min_ess=float(settings["min_ess"]))
    p_pass, se_pass = accepted_probability(grade)
    return {**given_gate(est, p_pass, se_pass),
            **{k: est[k] for k in ("status", "message", "runs", "ess", "max_share", "n_fail")},
            "pf_over_x": _pf_over_x(seen, density, int(settings["n_rotor"]), x, p_pass),
            "p_pass": p_pass, "X": x}


#: The rare level's reference for coverage (:func:`mirrored_coverage`): the 420 line terms
#: of the two status-0 runs of :data:`RARE_LINES` at X = 1.77 (seeds 2041 and 2042, 250 and
#: 170 lines, one design), pooled as one sample: P(kv_max >= 1.77 | pass), its standard
#: error, 106.8 effective lines, 3747 rotor runs (docs/benchmarks.md, "Sixth round"). Line
#: sampling shares no estimator code with the importance samplers.
LINES_REFERENCE: dict[str, Any] = {"X": 1.77, "pf": 1.524e-6, "se": 1.275e-7,
                                   "n_lines": 420, "n_effective": 106.8, "runs": 3747,
                                   "seeds": (2041, 2042)}


def mirrored_coverage(seeds: Any, store: str | Path, *, grade: int = 6,
                      settings: dict[str, Any] | None = None,
                      reference: dict[str, Any] | None = None,
                      execution: dict[str, Any] | None = None,
                      options: dict[str, Any] | None = None) -> dict[str, Any]:
    """Coverage of :func:`mirrored_given_acceptance`'s intervals on the rotor, resumable.

    Each seed of ``seeds`` not yet in ``store`` (a JSON-lines file, one line per finished
    seed, written as soon as the seed ends: an interrupted run loses at most the seed under
    way) is run at ``reference["X"]`` with ``settings`` (default :data:`RARE_MIRRORED`); the
    table then counts the intervals that hold ``reference["pf"]`` (default
    :data:`LINES_REFERENCE`), among all seeds and among those of status 0.

    Returns
    -------
    dict
        ``rows`` (seed, pf, lower, upper, status, ess, n_fail, runs, wall_s, cpu_s, holds),
        ``n``, ``held``, ``n_status0``, ``held_status0``, ``reference``.
    """
    settings = settings or RARE_MIRRORED
    reference = reference or LINES_REFERENCE
    seeds = list(dict.fromkeys(int(s) for s in seeds))  # once each, in the order given
    store = Path(store)
    store.parent.mkdir(parents=True, exist_ok=True)
    # what a stored row must match to count here: a rerun with other settings, X or class
    # refuses to mix its rows with these
    key = {"X": float(reference["X"]), "grade": int(grade),
           "settings": json.dumps(settings, sort_keys=True, default=str)}
    rows = []
    lines = store.read_text().splitlines() if store.exists() else []
    for i, line in enumerate(lines):
        if not line.strip():
            continue
        try:
            row = json.loads(line)
        except json.JSONDecodeError:
            if i == len(lines) - 1:  # a write cut short by an interruption: drop it, redo
                store.write_text("".join(f"{kept}\n" for kept in lines[:i]))
                continue
            raise ValueError(f"store={str(store)!r} has an unreadable line {i + 1}; valid: "
                             "one JSON object a line") from None
        if any(row.get(k) != v for k, v in key.items()):
            raise ValueError(f"store={str(store)!r} holds seed {row.get('seed')} of other "
                             f"settings, X or class than these ({key['X']}, class "
                             f"{key['grade']}); valid: a store of this run's settings only")
        rows.append(row)
    done = {r["seed"] for r in rows}
    todo = [s for s in seeds if s not in done]
    if todo:
        with workers_for_run((execution or {}).get("executor", "processes")) as pool:
            run_on = {"executor": pool, "chunk_size": (execution or {}).get("chunk_size", 25)}
            for seed in todo:
                t0, c0 = wall_and_cpu(pool)
                res = mirrored_given_acceptance(key["X"], seed, grade, settings, run_on,
                                                options)
                t1, c1 = wall_and_cpu(pool)
                row = {"seed": seed, **{k: res[k] for k in ("pf", "lower", "upper", "status",
                                                            "ess", "n_fail", "runs",
                                                            "max_share")},
                       "wall_s": t1 - t0, "cpu_s": c1 - c0, **key}
                with store.open("a") as fh:
                    fh.write(json.dumps(row, default=float) + "\n")
                rows.append(row)
                print(f"seed {seed}: {row['pf']:.3g} [{row['lower']:.3g}, {row['upper']:.3g}]"
                      f", status {row['status']}, {row['ess']:.1f} effective of "
                      f"{row['n_fail']} failing, {row['runs']} runs, {row['wall_s']:.0f} s "
                      f"wall, {row['cpu_s']:.0f} s CPU", flush=True)
    wanted = set(seeds)
    rows = [r for r in rows if r["seed"] in wanted]
    for r in rows:
        r["holds"] = bool(r["lower"] <= reference["pf"] <= r["upper"])
    ok = [r for r in rows if r["status"] == 0]
    return {"rows": rows, "n": len(rows), "held": sum(r["holds"] for r in rows),
            "n_status0": len(ok), "held_status0": sum(r["holds"] for r in ok),
            "reference": reference}


def _recorded(limit: Any, seen: list[tuple[np.ndarray, np.ndarray]]) -> Any:
    """``limit`` that also keeps each batch's draws and ``kv_max`` (NaN where invalid)."""
    def record(u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        g, ok = limit(u)
        seen.append((u, g))
        return g, ok

    return record


def _pf_over_x(seen: list[tuple[np.ndarray, np.ndarray]], density: Any, n: int, x: float,
               p_pass: float) -> dict[str, Any]:
    """P(kv_max >= x' | pass) at x' = x - 0.06 .. x + 0.06 from the same weighted draws (the
    level where P is near a target, read off one run; not vouched for away from ``x``).

    An invalid run (no steady state: ``kv_max`` NaN) is read as the main estimate reads it:
    as safe in ``"pf"``, as failed in ``"invalid_as_failures"`` (the upper reading), and
    counted in ``"invalid_runs"``, never silently taken as below ``x'``.
    """
    if not seen:
        return {"pf": {}, "invalid_as_failures": {}, "invalid_runs": 0}
    u = np.concatenate([a for a, _ in seen])
    kv = x - np.concatenate([g for _, g in seen])
    w = np.exp(density.log_weights(u))
    invalid = ~np.isfinite(kv)
    levels = x + np.arange(-0.06, 0.0601, 0.02)
    with np.errstate(invalid="ignore"):
        above = [kv >= xp for xp in levels]
    return {"pf": {f"{xp:.3f}": float(np.sum(w * a) / n / p_pass)
                   for xp, a in zip(levels, above, strict=True)},
            "invalid_as_failures": {f"{xp:.3f}": float(np.sum(w * (a | invalid)) / n / p_pass)
                                    for xp, a in zip(levels, above, strict=True)},
            "invalid_runs": int(invalid.sum())}


def sobol_groups(names: list[str]) -> list[str]:
    """The cause of each input of :func:`study_space` (:data:`GROUPS`; the pitch germ
    ``pitch_xi_p_*`` of the pinion, ``pitch_xi_g_*`` of the wheel).

    Raises
    ------
    ValueError
        An input of no known cause.
    """
    causes = []
    for name in names:
        if name in GROUPS:
            causes.append(GROUPS[name])
        elif name.startswith(("pitch_xi_p_", "pitch_xi_g_")):
            causes.append("pinion pitch" if name.startswith("pitch_xi_p_") else "wheel pitch")
        else:
            raise ValueError(f"input {name!r} has no cause in the grouped Sobol' indices; "
                             f"valid: {sorted(GROUPS)} or the pitch germs pitch_xi_p_*, "
                             "pitch_xi_g_*")
    return causes


def grouped_sobol(n_base: int, seed: int, grade: int, execution: dict[str, Any],
                  stage: GearStage | None = None,
                  store: str | Path | None = None) -> dict[str, Any]:
    """First-order and total Sobol' indices of ``kv_max``, inputs grouped by cause (the
    pitch germ of each gear, relief, load, damping: :data:`GROUPS`), over the untruncated
    law of :func:`study_space` (``stage``'s on a stage, with :func:`stage_options`).

    The runs go to ``store`` when given (a rerun reuses them). A run whose every grid speed
    has a steady state but whose peak search failed (the plugin's
    ``steady_state_failed_while_locating_a_peak``) enters with its largest value found, a
    lower bound of its peak, counted in ``lower_bounds``. On a stage, a run without a
    steady state is solved again with :data:`STAGE_FALLBACK_SOLVER`.

    Returns
    -------
    dict
        ``groups``, ``S1``, ``S1_conf``, ``ST``, ``ST_conf`` (95 % bootstrap half-widths),
        ``runs``, ``retried``, ``lower_bounds``; or, where runs are still without a steady
        state, no indices (a design with holes has none) but ``failed``, ``failed_status``
        and ``message``.
    """
    from SALib.analyze import sobol as sobol_analyze
    from SALib.sample import sobol as sobol_sample

    space = study_space(stage)
    names = space.names
    groups = sobol_groups(names)
    problem = {"num_vars": len(names), "names": names, "groups": groups,
               "bounds": [[0.0, 1.0]] * len(names)}
    unit = np.clip(sobol_sample.sample(problem, n_base, calc_second_order=False, seed=seed),
                   1e-12, 1 - 1e-12)
    model = study_model(grade, stage)
    options = OPTIONS if stage is None else stage_options(stage)
    design = space.transform(unit)
    ds = evaluate_chunks(model, design, model.prepare(None, outputs=["kv_max"], **options),
                         progress=False, store=store, **execution)
    y, status = ds["kv_max"].values.copy(), ds["status"].values.copy()
    codes = {name: code for code, name in status_meanings(ds["status"]).items()}
    peak_missed = codes.get("steady_state_failed_while_locating_a_peak")
    lower = (status == peak_missed) & np.isfinite(y) if peak_missed is not None else \
        np.zeros(y.size, bool)
    failed = np.flatnonzero(((status != 0) & ~lower) | ~np.isfinite(y))
    retried = 0
    if failed.size and stage is not None:
        again = evaluate_chunks(
            model, {k: np.asarray(v)[failed] for k, v in design.items()},
            model.prepare(None, outputs=["kv_max"], **{**options, **STAGE_FALLBACK_SOLVER}),
            progress=False, **execution)
        fixed = (again["status"].values == 0) & np.isfinite(again["kv_max"].values)
        y[failed[fixed]] = again["kv_max"].values[fixed]
        status[failed] = again["status"].values
        retried, failed = int(fixed.sum()), failed[~fixed]
    if failed.size:
        codes = dict(zip(*np.unique(status[failed], return_counts=True), strict=True))
        return {"runs": int(y.size), "retried": retried, "lower_bounds": int(lower.sum()),
                "failed": int(failed.size),
                "failed_status": {int(k): int(v) for k, v in codes.items()},
                "message": f"{failed.size} of {y.size} rotor runs without a steady state "
                           f"(status {sorted(int(k) for k in codes)}): the indices are not "
                           "computed from a design with holes"}
    res = sobol_analyze.analyze(problem, y, calc_second_order=False, seed=seed)
    return {"groups": list(dict.fromkeys(groups)), "S1": res["S1"].tolist(),
            "S1_conf": res["S1_conf"].tolist(), "ST": res["ST"].tolist(),
            "ST_conf": res["ST_conf"].tolist(), "runs": int(y.size), "retried": retried,
            "lower_bounds": int(lower.sum())}


def mesh_mode_speeds(grade: int, stage: GearStage | None = None) -> list[tuple[float, float]]:
    """``(speed [rpm], mesh strain-energy share)`` where z1 n / 60 meets a natural frequency.

    Natural frequencies of the nominal rotor linearised at its mean mesh stiffness; only
    modes with more than 3 % of their strain energy in the mesh. On a ``stage``: its rotor
    at the middle of its torque range (the mesh stiffness, and so the modes, follow the
    load), and the modes whose crossing with ``f_m`` or ``2 f_m`` lies in its speed range.
    """
    if stage is None:
        prob = study_model(grade).rotor_problem(speed_range=True)
        low, high, top = 0.0, 8000.0, 8000.0
    else:
        low, high = stage.operation.speed
        top = 2.0 * high  # 2 f_m meets the mode inside the range
        prob = study_model(stage=stage).rotor_problem(
            {"torque": float(np.mean(stage.operation.torque))}, speed_range=True,
            **stage_options(stage))
    modes = prob.modes.elastic
    v = prob.rotor.mesh_vector()
    share = prob.excitation.mean_stiffness * (v @ modes.shapes) ** 2 / modes.omega**2
    speeds = modes.omega / (2.0 * math.pi) * 60.0 / prob.pinion_teeth
    return [(float(s), float(e)) for s, e in zip(speeds, share, strict=True)
            if e > 0.03 and low <= s < top]


def figures(out: Path, ds: Any, x: float, modes: list[tuple[float, float]],
            sobol: dict[str, Any] | None, grade: int,
            stage: GearStage | None = None) -> list[Path]:
    """K_v against speed with bands and ISO; the Campbell-like map; the Sobol' bars.

    On a ``stage`` the ISO curve is labelled with its two classes (Method B takes the
    coarser) and the titles name the stage; mode lines are drawn inside the speed range.
    """
    import matplotlib.pyplot as plt

    ok = (ds["status"].values == 0) & (ds["pitch_acceptance_margin"].values >= 0)
    n = int(ok.sum())
    speeds = ds["range_speed"].values

    def inside(speed: float) -> bool:  # a line off the range would widen the axes
        return bool(speeds[0] <= speed <= speeds[-1])

    iso_class, where = f"class {grade}", ""
    if stage is not None:
        iso_class = (f"classes {stage.pinion.iso_grade}/{stage.wheel.iso_grade}, the coarser "
                     "taken")
        where = f", {stage.name}"
    kv = ds["kv_over_speed"].values[ok]
    iso = ds["kv_iso_over_speed"].values[ok]
    paths = []
    fig, ax = plt.subplots(figsize=(7.5, 4.6))
    for lo, hi, shade in ((0, 100, "0.85"), (5, 95, "0.7"), (25, 75, "0.55")):
        ax.fill_between(speeds, np.percentile(kv, lo, axis=0), np.percentile(kv, hi, axis=0),
                        color=shade, label=f"simulated K_v, {lo}-{hi} % of {n} accepted pairs")
    ax.plot(speeds, np.median(kv, axis=0), color="k", lw=1, label="simulated median")
    ax.plot(speeds, np.median(iso, axis=0), color="tab:red", lw=1.5,
            label=f"ISO 6336-1 Method B, {iso_class}, median load and relief")
    ax.axhline(x, color="tab:blue", ls="--", lw=1, label=f"X = {x:.3g}")
    for s, _ in modes:
        if inside(s):
            ax.axvline(s, color="tab:green", lw=0.6, alpha=0.6)
    ax.set(xlabel="pinion speed [rpm]", ylabel="K_v [1]", title="Dynamic factor over the speed "
           f"range{where}\n(green: mesh frequency = natural frequency)")
    # below the axes: inside, it covered the top band where the resonance peaks
    ax.legend(fontsize=7, loc="upper center", bbox_to_anchor=(0.5, -0.12), ncol=2,
              frameon=False)
    paths.append(out / "kv_over_speed.png")
    plot.save_figure(fig, paths[-1], dpi=130, bbox_inches="tight")  # stamps a quick run

    fig, ax = plt.subplots(figsize=(7.0, 4.6))
    at, top = ds["speed_at_kv_max"].values[ok], ds["kv_max"].values[ok]
    fail = top >= x
    ax.scatter(at[~fail], top[~fail], s=10, color="0.5", label="accepted, K_v < X")
    ax.scatter(at[fail], top[fail], s=18, color="tab:red", label="accepted, K_v >= X")
    for s, e in modes:
        if inside(s):
            ax.axvline(s, color="tab:green", lw=0.8, alpha=0.7)
            # inside the axes, at their top: clear of the title whatever the data's range
            ax.annotate(f"{e:.0%}", (s, 0.98), xycoords=("data", "axes fraction"),
                        fontsize=6, ha="center", va="top", color="tab:green")
        if inside(s / 2.0):
            ax.axvline(s / 2.0, color="tab:green", lw=0.8, alpha=0.5, ls=":")
    ax.set(xlabel="speed of the K_v peak [rpm]", ylabel="kv_max [1]",
           title=f"Where the peaks sit{where} (green: f_m, dotted: 2 f_m = a natural "
           "frequency; share of mesh strain energy)")
    ax.legend(fontsize=7)
    paths.append(out / "campbell_map.png")
    plot.save_figure(fig, paths[-1], dpi=130, bbox_inches="tight")  # stamps a quick run

    if sobol is not None and "S1" in sobol:
        fig, ax = plt.subplots(figsize=(6.0, 3.6))
        pos = np.arange(len(sobol["groups"]))
        ax.bar(pos - 0.2, sobol["S1"], 0.4, yerr=sobol["S1_conf"], label="first order")
        ax.bar(pos + 0.2, sobol["ST"], 0.4, yerr=sobol["ST_conf"], label="total")
        ax.set_xticks(pos, sobol["groups"])
        ax.set(ylabel="Sobol' index of kv_max (1)", title=f"What drives K_v{where} "
               f"({sobol['runs']} rotor runs)")
        ax.legend(fontsize=7)
        paths.append(out / "sobol_kv.png")
        plot.save_figure(fig, paths[-1], dpi=130, bbox_inches="tight")  # stamps a quick run
    return paths


#: Runs of ``--quick --stage``: a check of the stage's code path, not an answer.
QUICK_STAGE_RUNS = 8
#: Inputs whose rank correlation with ``kv_max`` the stage reports (relief amounts added).
DRIVERS = ("damping_ratio", "torque", "pitch_total_deviation_pinion",
           "pitch_total_deviation_wheel")


def wall_and_cpu(pool: Any) -> tuple[float, float]:
    """Wall-clock seconds, and CPU seconds of this process plus ``pool``'s workers."""
    return time.perf_counter(), time.process_time() + getattr(pool, "worker_cpu_seconds", 0.0)


def kv_drivers(ds: Any) -> dict[str, float]:
    """Spearman rank correlation of ``kv_max`` with each cause over the accepted pairs.

    A first look at what drives K_v (damping, load, each relief, each gear's F_p), cheap
    beside grouped Sobol' indices: it sees monotone effects only, one input at a time.
    """
    from scipy.stats import spearmanr

    ok = (ds["status"].values == 0) & (ds["pitch_acceptance_margin"].values >= 0)
    names = [*DRIVERS, *(n for n in ds.data_vars if str(n).endswith("relief_amount"))]
    return {str(n): float(spearmanr(ds[n].values[ok], ds["kv_max"].values[ok])[0])
            for n in names if np.ptp(ds[n].values[ok]) > 0}


def invalid_as_failures(ds: Any, x: float) -> dict[str, float]:
    """P(kv_max >= x | pass) with every accepted run whose steady state failed counted as a
    failure: an upper bound beside :func:`conditional_count`, which leaves them out.

    The runs that fail are those whose teeth separate most at the resonance, i.e. the
    largest K_v, so leaving them out leans low; inspection's verdict is kinematic and known
    for them.
    """
    bad = (ds["status"].values != 0) & (ds["pitch_acceptance_margin"].values >= 0)
    count = conditional_count(ds, x)
    k, n = count["failures"] + int(bad.sum()), count["accepted"] + int(bad.sum())
    lo, up = clopper_pearson_interval(k, n)
    return {"pf": k / max(n, 1), "lower": float(lo), "upper": float(up), "failures": k,
            "accepted": n, "invalid_accepted": int(bad.sum())}


def peak_sites(ds: Any, modes: list[tuple[float, float]]) -> list[dict[str, float]]:
    """How many accepted pairs have their K_v peak nearest each crossing of ``f_m`` or
    ``2 f_m`` with a mesh mode (and at the top of the range, where a crossing lies above)."""
    ok = (ds["status"].values == 0) & (ds["pitch_acceptance_margin"].values >= 0)
    at = ds["speed_at_kv_max"].values[ok]
    top = float(ds["range_speed"].values[-1])
    sites = [(top, 0, 0.0)] + [(s / h, h, e) for s, e in modes for h in (1, 2)
                               if s / h <= top]
    nearest = np.argmin(np.abs(at[:, None] - np.array([c for c, _, _ in sites])), axis=1)
    return [{"speed": c, "harmonic": h, "mesh_energy_share": e,
             "peaks": int(np.sum(nearest == i))} for i, (c, h, e) in enumerate(sites)]


@plot.quick_mode(
    lambda a: f"{QUICK_STAGE_RUNS} rotor runs on the stage at {QUICK_STAGE_SPEEDS} speeds",
    left_out=("the population of n_runs rotor runs on 80 speeds with the K_v peaks located, "
              "and subset simulation on the stage: no quantile, probability or ranking here "
              "is resolved"))
def run_on_stage(stage: str | Path | GearStage, out: str | Path, quick: bool = False,
                 seed: int = 2028, executor: Any = DEFAULT_EXECUTION["executor"],
                 chunk_size: int | None = DEFAULT_EXECUTION["chunk_size"], n_runs: int = 400,
                 n_per_level: int = 200, sobol_base: int = 16, rare_x: float | None = None,
                 rare_per_level: int = 200, rare_lines: bool = False) -> int:
    """The population stage of the dynamic question on a gear stage (``--stage``).

    The stage's rotor, classes, reliefs, load and speed range (:func:`study_space`), the
    capable process truncated by inspection; K_v over speed beside ISO 6336-1 Method B,
    the Campbell-like map, the accepted share against its closed form ``(1 - s)^2``, X at
    the 90 % quantile of accepted ``kv_max`` with P(kv_max >= X | pass) by counting and by
    subset simulation on the parallel system (not in ``quick``), the rank correlations of
    ``kv_max`` with its causes, and (not in ``quick``) the grouped Sobol' indices of
    ``kv_max`` (:func:`grouped_sobol`). With ``rare_x``, P(kv_max >= rare_x | pass) by
    subset simulation behind inspection's gate (:func:`rare_subset_on_stage`), the rare
    method that needs neither a cheap model nor a known direction of the stage's failure
    set; with ``rare_lines`` also by line sampling along the walk's failing mean in the
    inputs that are not pitch germs (:func:`stage_line_direction`)
    (:func:`lines_on_stage`), a second estimator.

    Parameters
    ----------
    stage : str, path or GearStage
        A built-in stage name or a stage TOML file (:func:`load_stage`).
    out : path
        Output folder (created); the Monte Carlo store lives in it and is reused.
    quick : bool
        :data:`QUICK_STAGE_RUNS` rotor runs and no subset simulation: a check.
    seed : int
        Seed of every random stage.
    executor, chunk_size :
        How rotor runs are spread over the cores; the answers do not depend on them.
    n_runs, n_per_level : int
        Crude Monte Carlo runs and subset-simulation samples per level (0: no subset
        simulation).
    sobol_base : int
        Saltelli base samples of the grouped Sobol' indices (``7 sobol_base`` runs; 0: none).
    rare_x : float, optional
        X of the rare level on the stage (default: none run; not in ``quick``).
    rare_per_level : int
        Subset-simulation samples per level at ``rare_x``.
    rare_lines : bool
        After the walk, line sampling at ``rare_x`` (:data:`STAGE_LINES`).

    Returns
    -------
    int
        0.
    """
    stage = load_stage(stage)
    if rare_x is not None and not (math.isfinite(rare_x) and rare_x > 1.0):
        raise ValueError(f"rare_x={rare_x!r} is outside its valid range: a K_v level in "
                         "(1, inf)")
    if int(rare_per_level) != rare_per_level or rare_per_level < 10:
        raise ValueError(f"rare_per_level={rare_per_level!r} is outside its valid range: "
                         "integers >= 10")
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    if int(n_runs) != n_runs or n_runs < 10:
        raise ValueError(f"n_runs={n_runs!r} is outside its valid range: integers >= 10")
    if int(n_per_level) != n_per_level or not (n_per_level == 0 or n_per_level >= 10):
        raise ValueError(f"n_per_level={n_per_level!r} is outside its valid range: 0 (no "
                         "subset simulation) or integers >= 10")
    if int(sobol_base) != sobol_base or not (sobol_base == 0 or sobol_base >= 2):
        raise ValueError(f"sobol_base={sobol_base!r} is outside its valid range: 0 (no Sobol' "
                         "indices) or integers >= 2")
    n_mc, stages = (QUICK_STAGE_RUNS if quick else int(n_runs)), {}
    with workers_for_run(executor) as pool:
        run_on = {"executor": pool, "chunk_size": chunk_size}
        clock = functools.partial(wall_and_cpu, pool)
        t0, c0 = clock()
        ds = population(n_mc, seed, 0, out, run_on, stage, quick)
        t1, c1 = clock()
        stages["population"] = (t1 - t0, c1 - c0)
        ok = (ds["status"].values == 0) & (ds["pitch_acceptance_margin"].values >= 0)
        x = float(np.quantile(ds["kv_max"].values[ok], 0.9))
        ss = None
        if not quick and n_per_level:
            ss = subset_given_acceptance(x, seed + 1, 0, int(n_per_level), run_on,
                                         stage=stage)
            stages["subset"] = tuple(np.subtract(clock(), (t1, c1)))
        sobol = None
        if not quick and sobol_base:
            t2, c2 = clock()
            sobol = grouped_sobol(int(sobol_base), seed + 2, 0, run_on, stage,
                                  out / f"sobol_store_{stage.name}")
            stages["sobol"] = tuple(np.subtract(clock(), (t2, c2)))
        rare, rare_lines_est = None, None
        if not quick and rare_x is not None:
            t3, c3 = clock()
            rare = rare_subset_on_stage(stage, float(rare_x), seed + 3, int(rare_per_level),
                                        run_on, out / f"rare_gated_store_{stage.name}")
            stages["rare_subset"] = tuple(np.subtract(clock(), (t3, c3)))
            if rare_lines and rare["failure_mean_u"] is not None:
                t4, c4 = clock()
                rare_lines_est = lines_on_stage(stage, float(rare_x), stage_line_direction(
                                                    stage, rare["failure_mean_u"]),
                                                seed + 6, STAGE_LINES, run_on,
                                                out / f"rare_lines_store_{stage.name}")
                stages["rare_lines"] = tuple(np.subtract(clock(), (t4, c4)))
    modes = mesh_mode_speeds(0, stage)
    paths = figures(out, ds, x, modes, sobol, 0, stage)
    p_pass = (1.0 - OPTIONS["process_share_beyond"]) ** 2
    # counted on germ pairs (12 CPU s for two million on the e-axle; a fifth in quick)
    n_germs = 400_000 if quick else 2_000_000
    n_ok = int((ds["status"].values == 0).sum())
    info = {"quick": quick, "stage": stage.name, "classes": [stage.pinion.iso_grade,
                                                             stage.wheel.iso_grade],
            "seed": seed, "X": x, "crude_mc": conditional_count(ds, x),
            "crude_mc_invalid_as_failures": invalid_as_failures(ds, x), "subset": ss,
            "sobol": sobol, "rare_subset": rare, "rare_lines": rare_lines_est,
            "accepted_share": int(ok.sum()) / max(n_ok, 1), "accepted_share_interval":
            clopper_pearson_interval(int(ok.sum()), n_ok), "accepted_share_closed_form": p_pass,
            "accepted_probability_counted": (*accepted_probability(0, stage, n_germs),
                                             n_germs),
            "kv_max_quantiles": np.quantile(ds["kv_max"].values[ok], [0.05, 0.5, 0.95]),
            "kv_iso_max_quantiles": np.quantile(ds["kv_iso_max"].values[ok],
                                                [0.05, 0.5, 0.95]),
            "speed_at_kv_max_quantiles": np.quantile(ds["speed_at_kv_max"].values[ok],
                                                     [0.05, 0.5, 0.95]),
            "kv_rank_correlations": kv_drivers(ds), "mesh_mode_speeds": modes,
            "aperiodic_runs": aperiodic_runs(ds),
            "peak_sites": peak_sites(ds, modes), "options": stage_options(stage, quick),
            "space": [m for m in study_space(stage).to_dict()["parameters"]
                      if not m["name"].startswith("pitch_xi_")],
            "population_cpu_s_per_run": stages["population"][1] / n_mc,
            "stages_wall_cpu_s": stages, "execution": {"executor": executor,
                                                       "chunk_size": chunk_size}}
    gearuq.save(ds, out / "population.nc")
    (out / "summary.json").write_text(json.dumps(info, indent=1, default=lambda v: (
        v.tolist() if hasattr(v, "tolist") else float(v))))
    _print_stage(info, out, paths)
    return 0


#: Most conditional levels of the rare subset simulation on a stage (``p0 = 0.1``: 1e-7).
STAGE_RARE_LEVELS = 7


def rare_subset_on_stage(stage: GearStage, x: float, seed: int, n_per_level: int,
                         execution: dict[str, Any], store: Path, **settings: Any
                         ) -> dict[str, Any]:
    """P(kv_max >= x | pass) on a stage by subset simulation behind inspection's gate.

    Inspection is a function of the germs alone (:func:`germ_acceptance_margin`), so the walk
    samples the accepted law itself (subset's ``gate``): level 0 keeps the first
    ``n_per_level`` accepted draws, and a chain's candidate that inspection rejects is
    refused without a rotor run. On the parallel system ``kv_max >= x and pass`` the walk
    spent most of its deeper levels on rejected pairs (72 % of the e-axle's level 3 at
    X = 5, ninth round), since a rejected pair lies inside every level whose threshold is
    still above 0. The stage's model, space and options (:func:`stage_options`); at most
    :data:`STAGE_RARE_LEVELS` levels (below ``0.1^7`` the run stops and says so: its value
    is then an upper end, not an estimate). Stored in ``store``; resumes from it; a walk at
    another ``x`` with the same seed reads back every run the two share. ``settings`` go to
    subset simulation (``second_walk``).

    Returns
    -------
    dict
        ``pf``, ``lower``, ``upper`` (95 %, given acceptance), ``status``, ``message``,
        ``runs``, ``wall``, ``levels``, ``x``, ``level_kv`` (the K_v of each level),
        ``p_pass`` (counted, for the joint probability ``pf p_pass``),
        ``failure_mean_u`` (the last level's failing mean, :func:`lines_on_stage`'s
        direction; None when none failed), ``censored`` (runs whose peak was located only
        from below, read at that bound) and ``censored_refused`` (how often a level refused
        one on its bound: pf may be low by their share).
    """
    rep = failure_probability(study_model(0, stage), study_space(stage), kv_exceeds(x),
                              method="subset", rng=seed, n_per_level=n_per_level,
                              gate=_acceptance_gate(0, stage), max_levels=STAGE_RARE_LEVELS,
                              store=store, model_options=stage_options(stage),
                              **settings, **execution)
    thresholds = x - np.atleast_1d(rep["level_threshold"].values) \
        if "level_threshold" in rep else np.array([])
    mean = rep["failure_mean_u"].values.tolist() if "failure_mean_u" in rep else None
    return {"pf": float(rep["pf"]), "lower": float(rep["pf_lower"]),
            "upper": float(rep["pf_upper"]), "status": int(rep["status"]),
            "message": describe_status(rep), "runs": int(rep["n_model_runs"]),
            "wall": float(rep["wall_time"]), "cpu": float(rep["cpu_time"]),
            "levels": int(thresholds.size), "x": x,
            "level_kv": thresholds.tolist(), "p_pass": accepted_probability(0, stage)[0],
            "failure_mean_u": mean,
            "censored": int(rep["n_censored"]) if "n_censored" in rep else 0,
            "censored_refused": _censored_refused(rep)}


def _censored_refused(rep: Any) -> int:
    """Refusals of censored runs on their bound, every walk of the report (a pair's or the
    replicates' per-walk sums; a single walk's levels)."""
    for name in ("replicate_censored_left_out", "level_censored_left_out"):
        if name in rep:
            return int(rep[name].sum())
    return 0


#: Line sampling on a stage (:func:`lines_on_stage`), the rare level's second method beside
#: the gated walk: straight lines along :func:`stage_line_direction` (the walk's failing mean
#: in the inputs that are not pitch germs: damping, torque, reliefs), origins standard
#: normal, inspection's verdict exact along each line (constant along it: the germs do not
#: move). K_v grows as damping and torque fall, so the failure set lies at positive ``t``:
#: the grid's points are at ``t >= 0``, besides the line's ends at -8 and 8 that every line
#: evaluates (six runs a line before its crossing is refined).
STAGE_LINES: dict[str, Any] = {"n_lines": 20, "t_grid": (0.0, 2.0, 3.5, 5.0, 8.0),
                               "root_tol": 0.02, "chunk_lines": 20}


def stage_line_direction(stage: GearStage, failure_mean_u: Any) -> np.ndarray:
    """The lines' direction on a stage: the walk's failing mean with its pitch-germ
    coordinates set to 0.

    Damping and torque carry the walk's failures consistently (on the e-axle's level 1 at
    K_v >= 2.82 their means are -1.4 and -1.9 standard units with spreads 0.5 and 0.2),
    while each of the 104 germ coordinates averages a few correlated failing samples whose
    spread is about 1: their mean is mostly noise, and inspection bounds what the germs can
    do. Along this direction the germs stay fixed, so inspection's verdict is that of the
    line's origin.
    """
    names = study_space(stage).names
    mean = np.asarray(failure_mean_u, dtype=float)
    if mean.shape != (len(names),):
        raise ValueError(f"failure_mean_u: {len(names)} standard normal coordinates, got "
                         f"shape {mean.shape}")
    return np.where([n.startswith("pitch_xi_") for n in names], 0.0, mean)


def lines_on_stage(stage: GearStage, x: float, direction: Any, seed: int,
                   settings: dict[str, Any], execution: dict[str, Any],
                   store: Path | None = None) -> dict[str, Any]:
    """P(kv_max >= x | pass) on a stage by line sampling behind inspection's gate.

    Lines parallel to ``direction`` (standard normal space of :func:`study_space`;
    :func:`stage_line_direction` of the gated walk); inspection's verdict along each line
    exact without the
    rotor; the rotor runs on the accepted part (:func:`gated_line_sampling`, an estimator
    that shares no code with subset simulation's: the direction steers its variance, not
    its mean). P(fail and pass) divided by the counted P(pass). ``settings`` as
    :data:`STAGE_LINES`; runs kept in ``store`` (resumable).

    Returns
    -------
    dict
        ``pf``, ``lower``, ``upper`` (95 %, given acceptance), ``cov``, ``status``,
        ``message``, ``runs``, ``n_lines``, ``n_effective``, ``lines_by_crossings``,
        ``direction_norm`` (the norm of ``direction``), ``x``.
    """
    direction = np.asarray(direction, dtype=float)
    norm = float(np.linalg.norm(direction))
    if direction.shape != (len(study_space(stage).names),) or not norm > 0:
        raise ValueError(f"direction: a nonzero vector of {len(study_space(stage).names)} "
                         f"standard normal coordinates, got shape {direction.shape}")
    limit = _kv_on_normals(study_model(0, stage), stage_options(stage), execution, x, stage,
                           store)
    est = gated_line_sampling(limit, (direction / norm)[:, None],
                              n_lines=int(settings["n_lines"]), seed=seed,
                              gate=_acceptance_gate(0, stage),
                              t_grid=np.array(settings["t_grid"], dtype=float),
                              root_tol=settings["root_tol"],
                              chunk_lines=int(settings["chunk_lines"]))
    p_pass, se_pass = accepted_probability(0, stage)
    return {**given_gate(est, p_pass, se_pass),
            **{k: est[k] for k in ("status", "message", "runs", "n_lines", "n_effective",
                                   "lines_by_crossings")},
            "direction_norm": norm, "x": x, "line_pf": est["line_pf"].tolist()}


def aperiodic_runs(ds: Any) -> dict[str, int]:
    """Runs (and their speeds) whose values were read from a time window because the
    response there is not periodic (``aperiodic_speeds`` > 0; zeros for a run made before
    the variable existed)."""
    if "aperiodic_speeds" not in ds:
        return {"runs": 0, "speeds": 0}
    counts = np.nan_to_num(ds["aperiodic_speeds"].values).astype(int)
    return {"runs": int((counts > 0).sum()), "speeds": int(counts.sum())}


def acceptance_line(info: dict[str, Any]) -> str:
    """The stage's screen line on inspection: three values, each named.

    The share of the rotor runs that passed (with its Clopper-Pearson interval), P(pass)
    counted on germ pairs by :func:`accepted_probability` with its standard error (what the
    rare paths divide by), and the declared process share's closed form ``(1 - s)^2``.
    """
    count, (lo, up) = info["crude_mc"], info["accepted_share_interval"]
    p, se, n_germs = info["accepted_probability_counted"]
    share = 1.0 - math.sqrt(info["accepted_share_closed_form"])
    return (f"{info['stage']}: inspection passed {count['accepted']} of "
            f"{count['runs'] - count['invalid']} runs ({info['accepted_share']:.3f} "
            f"[{lo:.3f}, {up:.3f}]); counted P(pass) = {p:.4f} +- {se:.4f} (standard error, "
            f"{n_germs:.0f} germ pairs); closed form (1 - {share:.2f})^2 = "
            f"{info['accepted_share_closed_form']:.4f}")


def _print_stage(info: dict[str, Any], out: Path, paths: list[Path]) -> None:
    count, ss = info["crude_mc"], info["subset"]
    print(acceptance_line(info))
    print(f"X = {info['X']:.4g} (90 % of accepted kv_max)")
    print(f"  crude MC : P(kv_max >= X | pass) = {count['pf']:.3g} [{count['lower']:.3g}, "
          f"{count['upper']:.3g}] ({count['failures']} of {count['accepted']})")
    bound = info["crude_mc_invalid_as_failures"]
    if bound["invalid_accepted"]:
        print(f"  {count['invalid']} runs without a steady state (status != 0), "
              f"{bound['invalid_accepted']} of them accepted; counted as failures: "
              f"{bound['pf']:.3g} [{bound['lower']:.3g}, {bound['upper']:.3g}]")
    if ss is not None:
        print(f"  subset   : {ss['pf']:.3g} [{ss['lower']:.3g}, {ss['upper']:.3g}], status "
              f"{ss['status']} ({ss['message']}), {ss['runs']} rotor runs")
    window = info.get("aperiodic_runs", {"runs": 0})
    if window["runs"]:
        print(f"  {window['runs']} runs read K_v from a time window at {window['speeds']} "
              "speeds (no periodic response there: the largest mesh force over 10 long "
              "periods)")
    print("  kv_max 5/50/95 %: " + ", ".join(f"{v:.3f}" for v in info["kv_max_quantiles"])
          + "; ISO Method B: " + ", ".join(f"{v:.3f}" for v in info["kv_iso_max_quantiles"]))
    print("  rank correlation with kv_max: " + ", ".join(
        f"{k} {v:+.2f}" for k, v in info["kv_rank_correlations"].items()))
    if info["sobol"] is not None:
        _print_sobol(info["sobol"])
    rare = info.get("rare_subset")
    if rare is not None:
        print(f"  rare     : P(kv_max >= {rare['x']:.4g} | pass) = {rare['pf']:.3g} "
              f"[{rare['lower']:.3g}, {rare['upper']:.3g}] by subset simulation, status "
              f"{rare['status']} ({rare['message']}), {rare['runs']} rotor runs of accepted "
              f"pairs, {rare['levels']} levels (K_v " + ", ".join(
                  f"{v:.3g}" for v in rare.get("level_kv", [])) + ")")
    lines = info.get("rare_lines")
    if lines is not None:
        print(f"  rare     : {lines['pf']:.3g} [{lines['lower']:.3g}, {lines['upper']:.3g}] by "
              f"line sampling along the walk's failing mean in damping, torque and relief "
              f"(|u| = "
              f"{lines['direction_norm']:.2f}), status {lines['status']} ({lines['message']}), "
              f"{lines['runs']} rotor runs, {lines['n_lines']} lines, "
              f"{lines['n_effective']:.1f} effective")
    print("  peaks nearest: " + ", ".join(
        f"{p['speed']:.0f} rpm (h {p['harmonic']}) {p['peaks']}" for p in info["peak_sites"]
        if p["peaks"]))
    for name, (wall, cpu) in info["stages_wall_cpu_s"].items():
        print(f"  stage {name}: {wall:.0f} s wall, {cpu:.0f} s CPU (this process and its "
              "workers)")
    print(f"written: {out} ({', '.join(p.name for p in paths)}, population.nc, summary.json)")


def _print_sobol(sobol: dict[str, Any]) -> None:
    """The grouped Sobol' indices on one line, each with its bootstrap half-width (or why
    there are none)."""
    if "S1" not in sobol:
        print(f"  grouped Sobol' of kv_max: not computed: {sobol['message']}")
        return
    retried = (f"; {sobol['retried']} solved again on the spectral orders"
               if sobol.get("retried") else "")
    retried += (f"; {sobol['lower_bounds']} with a lower bound of the peak (its search "
                "failed)" if sobol.get("lower_bounds") else "")
    print(f"  grouped Sobol' of kv_max, first order / total (+- 95 % bootstrap, "
          f"{sobol['runs']} runs{retried}): " + ", ".join(
              f"{g} {a:.2f}+-{da:.2f}/{b:.2f}+-{db:.2f}" for g, a, da, b, db in
              zip(sobol["groups"], sobol["S1"], sobol["S1_conf"], sobol["ST"],
                  sobol["ST_conf"], strict=True)))


def _stage_route(run_paper: Any) -> Any:
    """Send a call of ``run`` with ``stage`` to :func:`run_on_stage` (its own quick mode);
    a setting the stage does not use, changed from its default, is refused by name."""
    signature = inspect.signature(run_paper)

    @functools.wraps(run_paper)
    def run(*args: Any, **kwargs: Any) -> int:
        bound = signature.bind(*args, **kwargs)
        bound.apply_defaults()
        settings = dict(bound.arguments)
        if settings.pop("stage") is None:
            return run_paper(*args, **kwargs)
        own = inspect.signature(run_on_stage).parameters
        given = {k: v for k, v in settings.items() if v != signature.parameters[k].default}
        methods = tuple(given.pop("rare_methods", ("subset",)))
        if set(methods) not in ({"subset"}, {"subset", "lines"}):
            raise ValueError(f"rare_methods={methods!r} is outside what a stage runs: "
                             "('subset',), the gated walk at --rare-x, or ('subset', "
                             "'lines'), then line sampling along the walk's failing mean (the "
                             "other methods need the paper's rotor's cheap model or its known "
                             "direction)")
        for name, value in given.items():
            if name not in own:
                raise ValueError(f"{name}={value!r} is not used on a stage (it takes its "
                                 "classes from its file); valid: the default")
        # rare_x is the stage's only when given: its default is the paper's rotor's level
        keep = {k: v for k, v in settings.items() if k in own and k != "rare_x"}
        return run_on_stage(bound.arguments["stage"], **keep, rare_lines="lines" in methods,
                            **({"rare_x": given["rare_x"]} if "rare_x" in given else {}))

    return run


@_stage_route
@plot.quick_mode(
    "12 rotor runs; subset simulation with 16 per level and the rare stage's methods "
    "(--rare-methods) at the moderate X with a few dozen runs, on coarser speed grids",
    left_out=("the 400-run population, subset simulation at 200 per level, the grouped "
              "Sobol' indices and the rare level (X near P = 1e-6, the rare stage's methods "
              "at full size on the rotor): no probability or ranking here is resolved"))
def run(out: str | Path = "gearuq_geared_rotor_dynamic_factor", quick: bool = False,
        seed: int = 2028, grade: int = 6, executor: Any = DEFAULT_EXECUTION["executor"],
        chunk_size: int | None = DEFAULT_EXECUTION["chunk_size"], n_runs: int = 400,
        n_per_level: int = 200, sobol_base: int = 16, rare_x: float = RARE_X,
        rare_per_level: int = 200, rare_methods: tuple[str, ...] = ("lines", "mirrored"),
        stage: str | None = None) -> int:
    """P(K_v >= X anywhere in 25-8000 rpm | the gears pass inspection), where, and why.

    Parameters
    ----------
    out : path
        Output folder (created); the Monte Carlo store lives in it and is reused.
    quick : bool
        A few dozen rotor runs, no Sobol' indices: a check, not the answer.
    seed : int
        Seed of every random stage.
    grade : int
        ISO 1328-1 class of both gears (6 or 7 in the question).
    executor, chunk_size :
        How rotor runs are spread over the cores; the answers do not depend on them.
    n_runs : int
        Crude Monte Carlo runs of the population, at least 10 (``quick``: 12, 8 on a stage).
    n_per_level : int
        Subset-simulation samples per level at the moderate X, at least 10; on a stage 0
        skips it (``quick``: 16).
    sobol_base : int
        Saltelli base samples of the grouped Sobol' indices, ``sobol_base (G + 2)`` = 7
        ``sobol_base`` runs, at least 2; on a stage 0 skips them (``quick``: none).
    rare_x : float
        X of the rare stage (default :data:`RARE_X`, P near 1e-6); ``quick`` runs the stage
        at the moderate X instead, with a few dozen runs. On a stage the rare level runs
        only when this is given (subset simulation behind inspection's gate,
        :func:`rare_subset_on_stage`).
    rare_per_level : int
        Samples per level of subset simulation in the rare stage.
    rare_methods : tuple of str
        Methods of the rare stage (default ``("lines", "mirrored")``, the two that vouch
        for an interval at :data:`RARE_X`; together about 2300 CPU s, 20 min of wall on
        two cores), of ``"lines"`` (:func:`lines_given_acceptance`:
        line sampling behind the inspection gate along harmonic 15's coordinate,
        :data:`RARE_LINES`), ``"mirrored"`` (:func:`mirrored_given_acceptance`: importance
        sampling mirrored along it, :data:`RARE_MIRRORED`), ``"subspace"``
        (:func:`subspace_given_acceptance`: the cheap model's and the rotor's estimates),
        ``"harmonic"`` (the same, its density centred in the harmonic planes of
        :func:`harmonic_planes`), ``"mfis"`` (:func:`mfis_given_acceptance`, the Gaussian
        mixture over all inputs) and ``"subset"`` (:func:`subset_given_acceptance` on the
        rotor). On a stage: ``"subset"`` (the walk behind inspection's gate,
        :func:`rare_subset_on_stage`), with ``"lines"`` then line sampling along the
        walk's failing mean in damping, torque and relief (:func:`lines_on_stage`).
    stage : str, optional
        A built-in stage name (``e_axle_27_79``) or a stage TOML path: the population
        stage on that stage instead (:func:`run_on_stage`); default: the paper's rotor.

    Returns
    -------
    int
        0.
    """
    if grade not in range(1, 13):
        raise ValueError(f"grade={grade!r} is outside its valid range: integers 1..12")
    unknown = set(rare_methods) - {"harmonic", "subspace", "lines", "mirrored", "mfis",
                                   "subset"}
    if unknown or not rare_methods:
        raise ValueError(f"rare_methods={rare_methods!r} is outside its valid set: a non-empty "
                         "tuple of 'harmonic', 'subspace', 'lines', 'mirrored', 'mfis', "
                         "'subset'")
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    execution = {"executor": executor, "chunk_size": chunk_size}
    for name, value, low in (("n_runs", n_runs, 10), ("n_per_level", n_per_level, 10),
                             ("sobol_base", sobol_base, 2), ("rare_per_level", rare_per_level,
                                                             10)):
        if int(value) != value or value < low:
            raise ValueError(f"{name}={value!r} is outside its valid range: integers >= {low}")
    n_mc, n_level = (12, 16) if quick else (int(n_runs), int(n_per_level))
    stages = {}
    if quick:
        print(f"quick run: {n_mc} rotor runs, subset simulation with 16 per level on 6 "
              "speeds, the rare stage on 20 and 6 speeds, no Sobol' indices: a check, not "
              "the answer", flush=True)
    # one pool of workers for every stage (each fresh worker costs seconds of imports and
    # compiled kernels); a stage's CPU is this process's plus its workers'
    with workers_for_run(executor) as pool:
        run_on = {"executor": pool, "chunk_size": chunk_size}
        clock = functools.partial(wall_and_cpu, pool)
        t0, c0 = clock()
        ds = population(n_mc, seed, grade, out, run_on)
        t1, c1 = clock()
        stages["population"] = (t1 - t0, c1 - c0)
        ok = (ds["status"].values == 0) & (ds["pitch_acceptance_margin"].values >= 0)
        x = float(np.quantile(ds["kv_max"].values[ok], 0.9))
        count = conditional_count(ds, x)
        ss = subset_given_acceptance(x, seed + 1, grade, n_level, run_on,
                                     QUICK_OPTIONS if quick else None)
        t2, c2 = clock()
        stages["subset"] = (t2 - t1, c2 - c1)
        sobol = None
        if not quick:
            sobol = grouped_sobol(int(sobol_base), seed + 2, grade, run_on,
                                  store=out / f"sobol_store_grade{grade}")
            t3, c3 = clock()
            stages["sobol"] = (t3 - t2, c3 - c2)
        rare: dict[str, Any] = {}
        # quick: the stage's code path at the moderate X, a few dozen runs
        rare["X"] = x if quick else float(rare_x)
        # quick: the rotor is the cheap fidelity and the cheap one the coarsest
        fidelities = ({"options": CHEAP_OPTIONS, "cheap_options": QUICK_OPTIONS} if quick
                      else {})
        for method in rare_methods:
            t4, c4 = clock()
            if method in ("subspace", "harmonic"):
                settings = {"subspace": (RARE_SUBSPACE, QUICK_SUBSPACE),
                            "harmonic": (RARE_HARMONIC, QUICK_HARMONIC)}[method][int(quick)]
                rare[method] = subspace_given_acceptance(rare["X"], seed + 3, grade, settings,
                                                         run_on, **fidelities)
            elif method == "lines":
                rare[method] = lines_given_acceptance(
                    rare["X"], seed + 3, grade, QUICK_LINES if quick else RARE_LINES, run_on,
                    fidelities.get("options"))
            elif method == "mirrored":
                rare[method] = mirrored_given_acceptance(
                    rare["X"], seed + 5, grade, QUICK_MIRRORED if quick else RARE_MIRRORED,
                    run_on, fidelities.get("options"))
            elif method == "mfis":
                rare[method] = mfis_given_acceptance(rare["X"], seed + 3, grade,
                                                     QUICK_MFIS if quick else RARE_MFIS, run_on,
                                                     **fidelities)
            else:
                rare[method] = subset_given_acceptance(rare["X"], seed + 4, grade,
                                                       16 if quick else int(rare_per_level),
                                                       run_on, fidelities.get("cheap_options"))
            stages[f"rare_{method}"] = tuple(np.subtract(clock(), (t4, c4)))
    modes = mesh_mode_speeds(grade)
    paths = figures(out, ds, x, modes, sobol, grade)
    kv_iso = ds["kv_iso_max"].values[ok]
    info = {"quick": quick, "grade": grade, "seed": seed, "X": x, "crude_mc": count,
            "subset": ss, "sobol": sobol, "rare": rare, "mesh_mode_speeds": modes,
            "kv_max_quantiles": np.quantile(ds["kv_max"].values[ok], [0.05, 0.5, 0.95]),
            "kv_iso_max_quantiles": np.quantile(kv_iso, [0.05, 0.5, 0.95]),
            "accepted_share": float(ok.mean()), "options": OPTIONS,
            "stages_wall_cpu_s": stages, "execution": execution}
    gearuq.save(ds, out / "population.nc")
    (out / "summary.json").write_text(json.dumps(info, indent=1, default=lambda v: (
        v.tolist() if hasattr(v, "tolist") else float(v))))
    print(f"X = {x:.4g} (90 % of accepted kv_max); accepted {ok.sum()} of {ok.size}")
    print(f"  crude MC : P(kv_max >= X | pass) = {count['pf']:.3g} [{count['lower']:.3g}, "
          f"{count['upper']:.3g}] ({count['failures']} of {count['accepted']})")
    print(f"  subset   : {ss['pf']:.3g} [{ss['lower']:.3g}, {ss['upper']:.3g}], "
          f"{ss['message']}, {ss['runs']} rotor runs")
    print("  kv_max 5/50/95 %: " + ", ".join(f"{v:.3f}" for v in info["kv_max_quantiles"])
          + "; ISO Method B: " + ", ".join(f"{v:.3f}" for v in info["kv_iso_max_quantiles"]))
    for method, r in rare.items():
        if method == "X":
            continue
        parts = ([(f"{method}, {k} model", r[k]) for k in ("cheap", "rotor")]
                 if method in ("subspace", "harmonic") else [(method, r)])
        for label, e in parts:
            print(f"  rare level, {label}: P(kv_max >= {rare['X']:.4g} | pass) = {e['pf']:.3g} "
                  f"[{e['lower']:.3g}, {e['upper']:.3g}], {e['runs']} runs"
                  + (f" and {e['cheap_runs']} cheap runs" if "cheap_runs" in e else "")
                  + (f" on {e['n_lines']} lines ({e['n_effective']:.1f} effective; by "
                     f"crossings 0/1/2/more: {e['lines_by_crossings']})" if "n_lines" in e
                     else "")
                  + f"; status {e['status']}: {e['message']}"
                  + (f"; whatever the status, P >= {e['lower_one_sided']:.3g} at 95 % "
                     "(Markov's inequality on the unbiased estimate)"
                     if e.get("status") and "lower_one_sided" in e else ""))
    if sobol is not None:
        _print_sobol(sobol)
    for name, (wall, cpu) in stages.items():
        print(f"  stage {name}: {wall:.0f} s wall, {cpu:.0f} s CPU (this process and its "
              "workers)")
    print(f"written: {out} ({', '.join(p.name for p in paths)}, population.nc, summary.json)")
    return 0


def main(argv: list[str] | None = None) -> int:
    """Command line: ``python -m gearuq_studies.geared_rotor_dynamic_factor``."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("gearuq_geared_rotor_dynamic_factor"))
    parser.add_argument("--quick", action="store_true", help="a quick check, not the answer")
    parser.add_argument("--seed", type=int, default=2028)
    parser.add_argument("--grade", type=int, default=6)
    parser.add_argument("--executor", default=DEFAULT_EXECUTION["executor"])
    parser.add_argument("--chunk-size", type=int, default=DEFAULT_EXECUTION["chunk_size"])
    parser.add_argument("--runs", type=int, default=400, help="crude Monte Carlo runs")
    parser.add_argument("--per-level", type=int, default=200,
                        help="subset-simulation samples per level")
    parser.add_argument("--sobol-base", type=int, default=16, help="Saltelli base samples")
    parser.add_argument("--rare-x", type=float, default=RARE_X,
                        help="X of the rare stage (P near 1e-6 at the default)")
    parser.add_argument("--rare-per-level", type=int, default=200,
                        help="subset-simulation samples per level of the rare stage")
    parser.add_argument("--rare-methods", default="lines,mirrored",
                        help="comma-separated methods of the rare stage: subspace, harmonic, "
                        "lines, mirrored, mfis, subset")
    parser.add_argument("--stage", default=None, help="a built-in stage name or a stage "
                        "TOML path: the population stage on it (default: the paper's rotor)")
    args = parser.parse_args(argv)
    return run(args.out, quick=args.quick, seed=args.seed, grade=args.grade,
               executor=args.executor, chunk_size=args.chunk_size, n_runs=args.runs,
               n_per_level=args.per_level, sobol_base=args.sobol_base, rare_x=args.rare_x,
               rare_per_level=args.rare_per_level,
               rare_methods=tuple(m.strip() for m in args.rare_methods.split(",")),
               stage=args.stage)


if __name__ == "__main__":
    raise SystemExit(main())
