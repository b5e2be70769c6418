"""How likely is the geared rotor's RMS DTE to exceed X anywhere in 25-8000 rpm, and why?

The drivetrain engineer's question, answered end to end on the finite-element helical geared
rotor of Yuan, Liu and Liu ("Dynamic characteristics of a helical geared rotor system with
random cumulative pitch deviations", Applied Sciences 10 (2020) 4403), with its loaded tooth
contact analysis and the explicit pitch-deviation germ:

=====================  =========================================  ==========================
input                  distribution                               why
=====================  =========================================  ==========================
pitch_xi_{p,g}_1..29   independent standard normals (58)          the germ of each gear's
                                                                  random cumulative pitch
                                                                  deviations at ISO 1328-1
                                                                  grade 6 (``iso_grade`` 6
                                                                  fixed: F_pT / 2 sine
                                                                  amplitude, f_pT / 3 scatter)
tip_relief_amount      uniform 37 .. 47 um                        the 42 um design relief
                                                                  (the LTCA optimum at
                                                                  1000 N m) with a +-5 um
                                                                  drawing tolerance
torque                 lognormal, mean 1000 N m, CoV 10 %         load spread about the
                                                                  design torque
=====================  =========================================  ==========================

Everything else is at its nominal value (tip-relief length 11.4 mm, bearings, damping 5 %,
drive and load inertias 0.03 kg m^2). The response is ``dte_rms_max``: the largest RMS
dynamic transmission error over 160 speeds from 25 to 8000 rpm, and where it sits
(``speed_at_dte_rms_max``). Failure: ``dte_rms_max >= X``.

What the study does:

1. **Moderate level** (``X`` at Pf ~ 1e-3): crude Monte Carlo through a chunk store (a rerun
   reuses it) against multi-fidelity importance sampling.
2. **Rare level** (``X`` at Pf ~ 1e-6): two independent methods, multi-fidelity importance
   sampling (the cheap model fits the quadratic form of ``dte_rms_max^2``, the rotor is run
   only on the exponentially tilted Gaussian of that form: :func:`mfis`) and subset
   simulation on the rotor itself; their intervals should overlap.
3. **What drives it**: grouped Sobol' indices (pinion germ, wheel germ, tip relief, torque;
   SALib, Saltelli design) on the cheap model, whose values differ from the rotor's by at
   most 0.2 um (measured, below).
4. Figures: Pf against X with intervals; where in speed the worst case sits; the Sobol' bars.

The cheap model is the same rotor on a coarser speed grid with fewer harmonics
(``n_speeds`` 40 instead of 160, ``range_mesh_harmonics`` 2 instead of 3): measured on 120
random samples 4.75x cheaper, Pearson correlation 1.0000 and at most 0.17 um from the
rotor's ``dte_rms_max`` (0.36 um on a sample whose peak falls between the coarse speeds).
It is a legitimate low fidelity (a discretisation of the same physics); multi-fidelity
importance sampling stays unbiased whatever its quality.

What the answer is about (a kinematic example, not a dynamic one). An audit of this study
with an independent estimator confirmed its Pf, and found that the question is decided by
kinematics: 94-98 % of the variance of the RMS DTE, at every speed from 25 to 8000 rpm, is
the once-per-revolution wave of the cumulative pitch deviations of pinion and wheel in phase
(the 30/30 pair: each tooth always meets the same mate), so four of the 60 inputs decide it
(the same amplitudes give 50 um or 0.004 um depending only on the two waves' relative
phase); the speed dependence is 4-9 % and the "worst speed" is the end of the range; the
mesh-band part that the dynamics shape (``dte_mesh_band_rms``) stays under 0.32 um; torque
and relief have Sobol' indices below 1e-3. And the rare event lives in gears no inspection
would pass: with the wave's amplitude at F_pT / 2, 48 % of the sampled "class 6" gears
exceed the class-6 F_pT, and at the 62 um failure set both gears have F_p of 1.7-4.0 times
F_pT (none would pass class 6, 7 or 8). The study is kept as that kinematic example; the
dynamic question (K_v and the mesh orders, on gears that pass inspection) is the study
``geared_rotor_dynamic_factor``.

Run: ``gearuq study geared_rotor_rare_events [--quick] [--out DIR]``. ``--quick`` answers
one smaller question, Pf ~ 1e-1, by the study's three routes side by side (100 crude Monte
Carlo runs, multi-fidelity importance sampling and subset simulation; about 330 rotor runs,
52 s of CPU) two fidelity steps down (the rotor at 20 speeds and 1 mesh harmonic, its cheap
model at 10), in one process, and says so. The full study ran end to end in 77 minutes on
a 2-core machine shared with another job (about 45 on a quiet one, by the per-run costs),
most of it the two checks, crude Monte Carlo and subset simulation on the rotor; the answer
at Pf ~ 1e-6 alone took 11 minutes there and 7.2 on the quiet machine (docs/benchmarks.md).
Model runs go to worker processes, 100 samples a chunk (``--executor``, ``--chunk-size``);
the answers do not depend on how they are spread.
"""

from __future__ import annotations

import argparse
import json
import math
import time
from pathlib import Path
from typing import Any

import numpy as np

import gearuq
from gearuq import plot
from gearuq.execution import evaluate_chunks
from gearuq.failure.api import failure_probability
from gearuq.failure.intervals import clopper_pearson_interval
from gearuq.failure.modes import LimitState
from gearuq.failure.report import describe_status
from gearuq.testing.reliability_problems import (
    GEARED_ROTOR_LOW_FIDELITY_OPTIONS,
    GEARED_ROTOR_OPTIONS,
    geared_rotor_mfis_settings,
    geared_rotor_model,
    geared_rotor_space,
)

#: Limits on ``dte_rms_max`` [um] (full study): Pf ~ 1e-2 and ~ 1e-3 (checked against crude
#: Monte Carlo) and ~ 1e-6, read off a pilot subset simulation on the cheap model (500 per
#: level, seed 11, 3650 runs): its thresholds at p0^k were 24.9, 34.0, 44.6, 50.6, 56.9 and
#: 61.6 um for k = 1 ... 6.
LEVELS_UM = {"1e-2": 34.0, "1e-3": 45.0, "1e-6": 62.0}
#: Quick study: one limit, at Pf ~ 1e-1, where 100 crude Monte Carlo runs check both methods.
QUICK_LEVELS_UM = {"1e-1": 25.0}
#: Options of the cheap model (the same rotor, coarser over speed).
LOW_FIDELITY_OPTIONS = GEARED_ROTOR_OPTIONS
#: The quick run's rotor, two fidelity steps down: the benchmark case's cheap model (20 speeds,
#: 1 mesh harmonic, 0.084 s of CPU a run against 0.16 s at 40 speeds and 2 harmonics) plays
#: the rotor, and the same at 10 speeds (0.071 s: the tooth contact analysis of each sample,
#: not the speed grid, is most of a run's cost) the cheap one.
QUICK_MODEL_OPTIONS = GEARED_ROTOR_LOW_FIDELITY_OPTIONS
QUICK_LOW_FIDELITY_OPTIONS = {"n_speeds": 10, "range_mesh_harmonics": 1}
OUTPUTS = ["dte_rms_max", "speed_at_dte_rms_max"]


def study_model() -> gearuq.Model:
    """The rotor at ISO 1328-1 grade 6 (the germ's amplitude and scatter)."""
    return geared_rotor_model()


def study_space() -> gearuq.ParameterSpace:
    """Pitch germ of both gears, tip-relief tolerance and torque spread (module docstring)."""
    return geared_rotor_space()


def limit_state(x_um: float) -> LimitState:
    """Failure when the largest RMS DTE over the speed range reaches ``x_um``."""
    return LimitState.upper("dte_rms_max", x_um * 1e-6, name=f"dte_rms_max >= {x_um:g} um")


#: How the study's model runs are spread over the cores: worker processes, 100 samples a
#: chunk (every batch of 200 rotor runs, and every cheap design, then fills two workers; a
#: single chunk would run in one process). Results do not depend on it (bit-identical).
DEFAULT_EXECUTION: dict[str, Any] = {"executor": "processes", "chunk_size": 100}


def crude_monte_carlo(n: int, seed: int, store: Path | None,
                      execution: dict[str, Any] | None = None,
                      model_options: dict[str, Any] | None = None) -> dict[str, np.ndarray]:
    """``n`` rotor runs (through ``store`` when given: a rerun reuses its chunks) with the
    rotor's ``model_options`` (default: its own)."""
    ds = gearuq.monte_carlo(study_model(), study_space(), None, n_samples=n, rng=seed,
                            outputs=OUTPUTS, store=store, progress=False,
                            model_options=model_options, **(execution or {}))
    return {"y": ds["dte_rms_max"].values * 1e6, "speed": ds["speed_at_dte_rms_max"].values,
            "ok": ds["status"].values == 0, "wall": float(ds.attrs.get("wall_time", math.nan))}


def exceedance(mc: dict[str, np.ndarray], x_um: float) -> dict[str, float]:
    """Crude-MC estimate of P(dte_rms_max >= x) with its Clopper-Pearson interval; failed
    runs are counted apart (the interval then spans both readings of them)."""
    n = int(mc["y"].size)
    bad = int((~mc["ok"]).sum())
    k = int(((mc["y"] >= x_um) & mc["ok"]).sum())
    lo, _ = clopper_pearson_interval(k, n)
    _, up = clopper_pearson_interval(k + bad, n)
    return {"pf": k / n, "lower": float(lo), "upper": float(up), "failures": k, "runs": n,
            "invalid": bad}


def mfis(x_um: float, seed: int, quick: bool, execution: dict[str, Any] | None = None) -> Any:
    """Multi-fidelity importance sampling with the coarse rotor as the cheap model.

    The full study's density is the exponentially tilted Gaussian of a quadratic form
    (``biasing="quadratic"``): ``dte_rms_max`` is an RMS of a response nearly linear in the
    pitch germ, so its square is nearly a quadratic form in the 60 inputs and the failure set
    a shell around an ellipsoid; the form is fitted by least squares to ``n_fit`` cheap runs
    (half on a widened standard normal, half on the first tilt), and tilting the standard
    normal by ``exp(t y^2)`` puts the rotor's draws on the shell with weights bounded there.
    A Gaussian mixture fitted to subset simulation's last level covered that shell badly (one
    draw carried 31 % of the estimate at 62 um). The quick run keeps the mixture: a few hundred
    cheap runs cannot fit the 1891 coefficients of the form, and it runs two fidelity steps
    down (:data:`QUICK_MODEL_OPTIONS`, :data:`QUICK_LOW_FIDELITY_OPTIONS`). At its Pf ~ 1e-1 it
    fits one Gaussian (150 cheap runs a level leave little for more) and draws half of its 80
    rotor runs from the standard normal (``defensive=0.5``): every weight is then at most 2,
    so the estimate is never much worse than crude Monte Carlo's on 40 runs. Measured (seed
    2021): 0.14 [0.013, 0.27], status 3 (8 failing draws, effective size 4.2: flagged, in
    words), where 100 crude Monte Carlo runs give 0.09 and subset simulation 0.078 [0.032,
    0.19]; with the study's mixture settings and 60 draws it was 0.033 [0, 0.070], status 3.

    Measured at 62 um (four random seeds, each 1000 rotor and 2400 cheap runs): the form fits
    the cheap model with R^2 = 1.0000; Pf 3.37e-7, 2.96e-7, 3.01e-7 and 2.19e-7, CoV
    0.14-0.16, status 0 (the last: 1, CoV 0.157 at the 1000-run cap), Pareto k -0.4 to -0.7,
    largest weight share at most 4 %; every pair of intervals overlaps and subset simulation
    on the rotor (2560 runs, 4.4e-7 [4.4e-8, 4.3e-6]) holds all four. Wall on 2 cores with
    worker processes and 100 samples a chunk: 7.2 min on a quiet machine (serially: 25-37
    min on a shared one). Over 20 seeds on the rotor's benchmark case (40 speeds):
    docs/benchmarks.md.
    """
    model = study_model()
    common = {"method": "mfis", "rng": seed, "low_fidelity": model,
              "low_fidelity_options": LOW_FIDELITY_OPTIONS, **(execution or {})}
    if quick:
        return failure_probability(model, study_space(), limit_state(x_um), **{
            **common, "low_fidelity_options": QUICK_LOW_FIDELITY_OPTIONS},
            model_options=QUICK_MODEL_OPTIONS, n_per_level=150, n_samples=80,
            max_samples=80, target_cov=0.2, defensive=0.5, max_components=1)
    return failure_probability(model, study_space(), limit_state(x_um), **{
        **common, **geared_rotor_mfis_settings(x_um * 1e-6, LOW_FIDELITY_OPTIONS)})


def subset(x_um: float, seed: int, quick: bool, execution: dict[str, Any] | None = None) -> Any:
    """Subset simulation on the rotor itself (quick: at :data:`QUICK_MODEL_OPTIONS`)."""
    return failure_probability(study_model(), study_space(), limit_state(x_um),
                               method="subset", rng=seed, n_per_level=80 if quick else 400,
                               model_options=QUICK_MODEL_OPTIONS if quick else None,
                               **(execution or {}))


def grouped_sobol(n_base: int, seed: int,
                  execution: dict[str, Any] | None = None) -> dict[str, Any]:
    """First-order and total Sobol' indices of ``dte_rms_max`` with the germ grouped per gear.

    SALib's Saltelli design with groups (``n_base (G + 2)`` runs) on the cheap model, through
    the space's inverse CDFs; confidence intervals by SALib's bootstrap.
    """
    from SALib.analyze import sobol as sobol_analyze
    from SALib.sample import sobol as sobol_sample

    space = study_space()
    names = space.names
    group = {"torque": "torque", "tip_relief_amount": "tip relief"}
    groups = [group.get(n, "pinion pitch germ" if "_p_" in n else "wheel pitch germ")
              for n in names]
    problem = {"num_vars": len(names), "names": names, "groups": groups,
               "bounds": [[0.0, 1.0]] * len(names)}
    unit = sobol_sample.sample(problem, n_base, calc_second_order=False, seed=seed)
    unit = np.clip(unit, 1e-12, 1 - 1e-12)
    x = space.transform(unit)
    model = study_model()
    request = model.prepare(None, outputs=["dte_rms_max"], **LOW_FIDELITY_OPTIONS)
    ds = evaluate_chunks(model, x, request,
                         progress=False, **(execution or {}))
    y = ds["dte_rms_max"].values * 1e6
    if not np.all(ds["status"].values == 0) or not np.all(np.isfinite(y)):
        raise RuntimeError("grouped Sobol': some cheap-model runs failed; indices not computed")
    res = sobol_analyze.analyze(problem, y, calc_second_order=False, seed=seed)
    labels = list(dict.fromkeys(groups))
    return {"groups": labels, "S1": res["S1"].tolist(), "S1_conf": res["S1_conf"].tolist(),
            "ST": res["ST"].tolist(), "ST_conf": res["ST_conf"].tolist(), "runs": int(y.size)}


def _row(method: str, x_um: float, rep: Any) -> dict[str, Any]:
    return {"method": method, "X_um": x_um, "pf": float(rep["pf"]),
            "lower": float(rep["pf_lower"]), "upper": float(rep["pf_upper"]),
            "cov": float(rep["cov_pf"]), "status": int(rep["status"]),
            "message": rep.attrs.get("message", ""),
            "hf_runs": int(rep["n_model_runs"]),
            "lf_runs": int(rep["n_low_fidelity_runs"]) if "n_low_fidelity_runs" in rep else 0,
            "wall": float(rep["wall_time"])}


def figures(out: Path, mc: dict[str, np.ndarray], rows: list[dict[str, Any]],
            walk_levels: list[tuple[float, float]], sobol: dict[str, Any] | None) -> list[Path]:
    """Pf against X, where in speed the worst case sits, and the Sobol' bars."""
    import matplotlib.pyplot as plt

    paths = []
    fig, ax = plt.subplots(figsize=(7.5, 4.8))
    ok = mc["ok"]
    xs = np.linspace(np.percentile(mc["y"][ok], 50), mc["y"][ok].max(), 25)
    est = [exceedance(mc, x) for x in xs]
    pf = np.array([e["pf"] for e in est])
    keep = pf > 0
    ax.fill_between(xs, [e["lower"] for e in est], [e["upper"] for e in est], color="0.8",
                    label=f"crude Monte Carlo, {mc['y'].size} rotor runs (95 % CP band)")
    ax.plot(xs[keep], pf[keep], color="0.3")
    if walk_levels:
        lx, lp = zip(*walk_levels, strict=True)
        ax.plot(lx, lp, "s", color="tab:green", ms=4,
                label="subset simulation on the rotor: intermediate levels")
    colours = {"mfis": "tab:blue", "subset": "tab:orange"}
    names = {"mfis": "multi-fidelity IS", "subset": "subset simulation"}
    labelled: set[tuple[str, bool]] = set()
    for r in rows:
        shift = 0.25 * (1 if r["method"] == "mfis" else -1)
        vouched = r["status"] == 0
        # an interval reaching 0 would vanish on the log axis: draw it to pf / 100 and say so
        lower = r["lower"] if r["lower"] > 0 else r["pf"] / 100.0
        key = (r["method"], vouched)
        label = None
        if key not in labelled:
            labelled.add(key)
            label = names[r["method"]] + (" (95 %)" if vouched else
                                          " (status != 0: not vouched for)")
        ax.errorbar(r["X_um"] + shift, r["pf"], yerr=[[r["pf"] - lower],
                                                      [r["upper"] - r["pf"]]],
                    fmt="o", color=colours[r["method"]], capsize=4, label=label,
                    mfc=colours[r["method"]] if vouched else "white")
        if r["lower"] <= 0:
            ax.annotate("interval reaches 0", (r["X_um"] + shift, lower), fontsize=7,
                        xytext=(4, -10), textcoords="offset points",
                        color=colours[r["method"]])
    ax.set_yscale("log")
    ax.set_xlabel("limit X on the largest RMS DTE over 25-8000 rpm [um]")
    ax.set_ylabel("P(dte_rms_max >= X) [-]")
    ax.set_title("Geared rotor (Yuan, Liu and Liu 2020), ISO grade 6: exceedance of X",
                 fontsize=10)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    paths.append(out / "pf_vs_limit.png")
    plot.save_figure(fig, paths[-1], dpi=130)
    plt.close(fig)

    fig, ax = plt.subplots(figsize=(7.5, 4.2))
    bins = np.linspace(25.0, 8000.0, 41)
    top = mc["y"] >= np.quantile(mc["y"][ok], 0.95)
    ax.hist(mc["speed"][ok], bins=bins, color="0.7", label=f"all {int(ok.sum())} samples")
    ax.hist(mc["speed"][ok & top], bins=bins, color="tab:red",
            label=f"worst 5 % ({int((ok & top).sum())} samples)")
    ax.set_xlabel("pinion speed at which the RMS DTE peaks [rpm]")
    ax.set_ylabel("samples [-]")
    ax.set_title("Where in 25-8000 rpm the worst case sits", fontsize=10)
    ax.legend(fontsize=8)
    fig.tight_layout()
    paths.append(out / "worst_speed.png")
    plot.save_figure(fig, paths[-1], dpi=130)
    plt.close(fig)

    if sobol is not None:
        fig, ax = plt.subplots(figsize=(7.5, 3.8))
        k = np.arange(len(sobol["groups"]))
        ax.bar(k - 0.18, sobol["S1"], 0.36, yerr=sobol["S1_conf"], color="tab:blue",
               capsize=3, label="first order")
        ax.bar(k + 0.18, sobol["ST"], 0.36, yerr=sobol["ST_conf"], color="tab:orange",
               capsize=3, label="total")
        for i, (s1, st) in enumerate(zip(sobol["S1"], sobol["ST"], strict=True)):
            if max(abs(s1), abs(st)) < 0.01:  # bars too short to see: say what they are
                ax.annotate(f"first {s1:.0e}\ntotal {st:.0e}", (i, 0.0), xytext=(0, 6),
                            textcoords="offset points", ha="center", fontsize=7)
        ax.set_xticks(k, sobol["groups"])
        ax.set_ylabel("Sobol' index of dte_rms_max [-]")
        ax.set_title(f"What drives the worst RMS DTE ({sobol['runs']} cheap-model runs, "
                     "95 % bootstrap)", fontsize=10)
        ax.legend(fontsize=8)
        fig.tight_layout()
        paths.append(out / "sobol_groups.png")
        plot.save_figure(fig, paths[-1], dpi=130)
        plt.close(fig)
    return paths


@plot.quick_mode(
    "about 330 rotor and 330 cheap-model runs",
    left_out=(
        "the questions the study answers (Pf ~ 1e-2, 1e-3 and 1e-6): this run asks Pf ~ 1e-1 "
        "only, by crude Monte Carlo (100 runs), multi-fidelity importance sampling and subset "
        "simulation, with no grouped Sobol' indices; the rotor at 20 speeds and 1 mesh "
        "harmonic (the study's: 160 and 3), its cheap model at 10 and 1"))
def run(out: str | Path = "gearuq_geared_rotor_rare_events", quick: bool = False,
        seed: int = 2020, executor: Any = None,
        chunk_size: int | None = DEFAULT_EXECUTION["chunk_size"]) -> int:
    """Headline: P(largest RMS DTE of the geared rotor over 25-8000 rpm >= X) at ISO grade 6.

    Pf ~ 1e-3 checked against crude Monte Carlo, Pf ~ 1e-6 by two methods, grouped Sobol'
    indices; writes reports (netCDF), ``summary.json``, ``table.md`` and figures.

    Parameters
    ----------
    out : path
        Output folder (created); the crude Monte Carlo store lives in it and is reused.
    quick : bool
        One smaller question (Pf ~ 1e-1) by the three routes, on a coarser rotor: a check of
        the machinery, not the answer.
    seed : int
        Seed of every random stage.
    executor, chunk_size :
        How model runs are spread over the cores (:func:`gearuq.execution.evaluate_chunks`):
        by default worker processes, 100 samples a chunk; the quick run, whose stages are a
        few seconds each, runs in this process unless an executor is given (starting a pool
        of workers, each importing gearuq and loading the kernels, cost more CPU than the
        runs they would share). The answers do not depend on them.

    Returns
    -------
    int
        0.
    """
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    levels = QUICK_LEVELS_UM if quick else LEVELS_UM
    *moderates, rare = levels.values()
    t0 = time.perf_counter()
    if executor is None:
        executor = "serial" if quick else DEFAULT_EXECUTION["executor"]
    execution = {"executor": executor, "chunk_size": chunk_size}
    # one cheap rotor run here first: from an empty numba cache it compiles the rotor's kernels
    # once, and the worker processes load them instead of each compiling them at the same time
    # (forced: a small first call would otherwise run them as plain Python, compiling nothing)
    with gearuq.kernels_route("compiled"):
        study_model().response({}, None, outputs=["dte_rms_max"], **QUICK_LOW_FIDELITY_OPTIONS)
    rows, reps = [], {}
    for x_um in (*moderates, rare):
        for method in ("mfis", "subset"):
            if method == "subset" and x_um != rare:
                continue  # the moderate levels' check is crude Monte Carlo
            rep = (mfis if method == "mfis" else subset)(x_um, seed + 1, quick, execution)
            reps[(method, x_um)] = rep
            rows.append(_row(method, x_um, rep))
            r = rows[-1]
            print(f"  {method:<7} X = {x_um:g} um: pf = {r['pf']:.3g} [{r['lower']:.3g}, "
                  f"{r['upper']:.3g}], {r['hf_runs']} rotor runs, {r['lf_runs']} cheap runs, "
                  f"{r['wall']:.0f} s; {describe_status(rep)}", flush=True)
            gearuq.save(rep, out / f"{method}_{x_um:g}um.nc")
    walk = reps[("subset", rare)]
    walk_levels = []
    if "level_threshold" in walk:
        # the limit state is g = X - y in metres: threshold b_i is the level y = X - b_i
        p = np.cumprod(walk["level_probability"].values)
        walk_levels = [(rare - 1e6 * float(b), float(pk)) for b, pk in
                       zip(walk["level_threshold"].values, p, strict=True) if float(b) > 0]
    sobol = None if quick else grouped_sobol(256, seed + 2, execution)
    # the check last: its store may already hold the runs (a rerun, or a run started apart)
    n_mc = 100 if quick else 4000
    print(f"crude Monte Carlo, {n_mc} rotor runs (store {out / 'mc_store'}) ...", flush=True)
    mc = crude_monte_carlo(n_mc, seed, out / "mc_store", execution,
                           QUICK_MODEL_OPTIONS if quick else None)
    # the quick run's one level is checked by crude Monte Carlo too (Pf ~ 1e-1: 100 runs see it)
    checks = [{"X_um": x, **exceedance(mc, x)} for x in (levels.values() if quick else moderates)]
    paths = figures(out, mc, rows, walk_levels, sobol)
    info = {"levels_um": levels, "quick": quick, "execution": execution, "seed": seed,
            "crude_mc": checks, "rows": rows,
            "sobol": sobol, "total_wall": time.perf_counter() - t0}
    (out / "summary.json").write_text(json.dumps(info, indent=1, default=float))
    lines = ["| X [um] | method | Pf | 95 % interval | CoV | status | rotor runs | "
             "cheap runs | wall [s] |", "|---|---|---|---|---|---|---|---|---|"]
    lines += [f"| {c['X_um']:g} | crude MC | {c['pf']:.3g} | [{c['lower']:.3g}, "
              f"{c['upper']:.3g}] | | | {c['runs']} | 0 | |" for c in checks]
    lines += [f"| {r['X_um']:g} | {r['method']} | {r['pf']:.3g} | [{r['lower']:.3g}, "
              f"{r['upper']:.3g}] | {r['cov']:.2f} | {r['status']} | {r['hf_runs']} | "
              f"{r['lf_runs']} | {r['wall']:.0f} |" for r in rows]
    (out / "table.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))
    if sobol is not None:
        print("grouped Sobol' (first order / total): " + ", ".join(
            f"{g} {s1:.2f}/{st:.2f}" for g, s1, st in
            zip(sobol["groups"], sobol["S1"], sobol["ST"], strict=True)))
    print(f"written: {out} ({', '.join(p.name for p in paths)}, *.nc, summary.json, "
          f"table.md); {info['total_wall']:.0f} s")
    return 0


def main(argv: list[str] | None = None) -> int:
    """Command line: ``python -m gearuq_studies.geared_rotor_rare_events``."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("gearuq_geared_rotor_rare_events"))
    parser.add_argument("--quick", action="store_true", help="a quick check, not the answer")
    parser.add_argument("--seed", type=int, default=2020)
    parser.add_argument("--executor", default=DEFAULT_EXECUTION["executor"],
                        help="serial, processes (default) or a dask scheduler address")
    parser.add_argument("--chunk-size", type=int, default=DEFAULT_EXECUTION["chunk_size"],
                        help="samples per chunk of model runs (default %(default)s)")
    args = parser.parse_args(argv)
    return run(args.out, quick=args.quick, seed=args.seed, executor=args.executor,
               chunk_size=args.chunk_size)


if __name__ == "__main__":
    raise SystemExit(main())
