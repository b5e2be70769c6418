"""Tip relief and crowning of the geared rotor that keep K_v least likely to exceed X.

Design under uncertainty on the finite-element helical geared rotor of Yuan, Liu and Liu
("Dynamic characteristics of a helical geared rotor system with random cumulative pitch
deviations", Applied Sciences 10 (2020) 4403): choose the nominal tip relief (amount, length
and shape, linear or parabolic) and lead crowning that minimise

    Pf(d) = P( kv_max >= X  |  both gears pass inspection )

where ``kv_max`` is the largest dynamic factor K_v = max dynamic mesh force / static mesh force
over 25-8000 rpm (ISO 6336-1's definition; the rotor locates the peaks between its grid
speeds), given the scatter of what is built and how it is loaded:

=====================  =====================================  ============================
input                  law                                    why
=====================  =====================================  ============================
pitch_xi_{p,g}_1..29   independent standard normals (58),     the pitch-deviation germ of
                       the capable process of ISO 1328-1      each gear; 5 % of the gears
                       class 6 (or 7): option                 exceed F_pT and inspection
                       ``pitch_tolerance_law=                 removes them: Pf is
                       "capable_process"``                    conditioned on acceptance
torque                 lognormal, mean 1000 N m, CoV 10 %     load spread
tip_relief_amount      uniform, design value +- 3 um          drawing tolerance
tip_relief_length      uniform, design value +- 1 mm          drawing tolerance
lead_crowning          uniform, design value +- 3 um          drawing tolerance (both gears)
=====================  =====================================  ============================

Failure given acceptance: the design measure is the joint probability P(kv_max >= X and both
pass), a :class:`gearuq.ParallelSystem`; P(pass) = 0.95^2 exactly (the germ's law, independent
of the relief), so the conditional Pf and its interval are the joint's divided by it, and the
design that minimises one minimises the other. X = :data:`LIMIT` (docs/design.md says why).

What the study does:

0. **Deterministic optimum**: nominal gears (germ 0), design torque, nominal relief and
   crowning, least kv_max on a grid of designs of both shapes. It seeds step 1.
1. **Search** per relief shape (:func:`gearuq.design.optimize_levels` over
   ``tip_relief_shape``; cheap fidelity :data:`SEARCH_OPTIONS`): a Gaussian process of the
   probit of Pf over amount x length x crowning, fitted to common-random-number estimates at
   a Latin hypercube of designs and at its own successive optima, its error carried into the
   landscape (amount x length at the chosen crowning); SLSQP on it. The deterministic
   optimum is run first in each shape's search (``start_designs``), so the search cannot
   end worse than it on its own estimates.
2. **Confirm** (expensive fidelity :data:`CONFIRM_OPTIONS`): an independent Monte Carlo run
   at each shape's chosen design, one fresh seed for both (paired: McNemar between shapes).
3. **Deterministic optimum under scatter**: its Pf confirmed with the confirmation's seed
   (the same built gears and loads), paired against the chosen design (McNemar).
4. **Brute force**: crude Monte Carlo on a grid of amount x length of the chosen shape at the
   chosen crowning, fresh seeds, search fidelity; its best design should agree with the
   optimiser's choice within the intervals. And the chosen design against its six neighbours
   (+-10 % of each range), one seed for the seven (common random numbers).
5. **Stage file**: the same design problem through ``get_model("geared_rotor", stage=...)``
   with the paper's stage file, checked sample by sample against the paper's rotor; ``stage=``
   runs the whole study on another stage.

Figures: the Pf landscape over amount x length at the chosen crowning (surrogate mean, its
interval width, the brute force's estimates); the chosen design's K_v band against speed
beside the deterministic optimum's. Run: ``gearuq study relief_design [--quick] [--out DIR]``;
``--quick`` runs a few dozen samples and marks every figure "quick: N runs, not a result".
Every step runs on one lasting pool of two process workers (``executor="processes"``); the
study prints each step's wall and CPU seconds (this process and its workers).
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr
from matplotlib.figure import Figure

import gearuq
from gearuq import plot
from gearuq.design import (
    DesignProblem,
    DesignVariable,
    Probability,
    at_level,
    evaluate_design,
    optimize_levels,
    paired_failures,
)
from gearuq.execution import evaluate_chunks, workers_for_run
from gearuq.failure.modes import LimitState
from gearuq.plot import save_figure

#: The response: the largest K_v over the model's speed range (25-8000 rpm).
RESPONSE = "kv_max"
#: Limit X of K_v (docs/design.md: chosen so Pf spans 0..1 over the design box).
LIMIT = 1.2
#: Share of gears beyond F_pT in the capable process; P(pass) of the pair.
SHARE_BEYOND = 0.05
P_PASS = (1.0 - SHARE_BEYOND) ** 2
#: Relief shapes compared (the rotor's option ``tip_relief_shape``).
SHAPES = ("parabolic", "linear")
_LAW = {"pitch_tolerance_law": "capable_process", "process_share_beyond": SHARE_BEYOND}
#: Cheap fidelity (search): 40 speeds, 2 mesh harmonics, one peak refined.
SEARCH_OPTIONS: dict[str, Any] = {**_LAW, "n_speeds": 40, "range_mesh_harmonics": 2,
                                  "peaks_refined": 1}
#: Expensive fidelity (confirmation): 80 speeds, 3 mesh harmonics, two peaks refined (the
#: settings of the geared_rotor_dynamic_factor study).
CONFIRM_OPTIONS: dict[str, Any] = {**_LAW, "n_speeds": 80, "range_mesh_harmonics": 3,
                                   "peaks_refined": 2}
#: Quick fidelity (``--quick``, every step): 12 speeds, 1 mesh harmonic, no peak refined.
#: Measured on 12 draws of the paper's rotor: 0.13 CPU s a run against 0.47 for
#: :data:`SEARCH_OPTIONS`, kv_max within 0.1 of it (lower: the peaks are not refined).
QUICK_OPTIONS: dict[str, Any] = {**_LAW, "n_speeds": 12, "range_mesh_harmonics": 1,
                                 "peaks_refined": 0}
#: Drawing tolerances (half-widths of the uniform laws) and design bounds (docs/design.md).
AMOUNT_TOL, LENGTH_TOL, CROWNING_TOL = 3.0, 1.0, 3.0
AMOUNT_BOUNDS, LENGTH_BOUNDS, CROWNING_BOUNDS = (3.0, 40.0), (4.0, 24.0), (3.0, 10.0)
#: The design box, one row per design variable (amount um, length mm, crowning um).
BOUNDS = np.array([AMOUNT_BOUNDS, LENGTH_BOUNDS, CROWNING_BOUNDS])
#: Samples per chunk on the two workers (a 40-run design is four chunks; a quick design's 8
#: runs are two, one a worker).
CHUNK, QUICK_CHUNK = 10, 4
#: Sample sizes: full and quick (``scale`` multiplies the full ones).
SIZES = {
    False: {"n_designs": 12, "n_infill": 3, "n_per_design": 40, "confirm": 120, "grid": 3,
            "brute": 30, "det_grid": 4, "stage": 10},
    True: {"n_designs": 5, "n_infill": 1, "n_per_design": 8, "confirm": 10, "grid": 2,
           "brute": 6, "det_grid": 2, "stage": 3},
}


def input_space(amount: float = 20.0, length: float = 11.4, crowning: float = 10.0
                ) -> gearuq.ParameterSpace:
    """The scatter of built and loaded gears around a design (relief amount um, length mm,
    lead crowning um summed over both gears)."""
    germ = {f"pitch_xi_{gear}_{k}": {"dist": "normal", "mean": 0.0, "std": 1.0}
            for gear in ("p", "g") for k in range(1, 30)}
    return gearuq.ParameterSpace({
        "torque": {"dist": "lognormal", "mean": 1000.0, "std": 100.0},
        "tip_relief_amount": {"dist": "uniform", "lower": amount - AMOUNT_TOL,
                              "upper": amount + AMOUNT_TOL},
        "tip_relief_length": {"dist": "uniform", "lower": length - LENGTH_TOL,
                              "upper": length + LENGTH_TOL},
        "lead_crowning": {"dist": "uniform", "lower": crowning - CROWNING_TOL,
                          "upper": crowning + CROWNING_TOL},
        **germ})


def rotor(grade: int = 6, stage: Any = None) -> gearuq.Model:
    """The paper's rotor (``stage=None``) or a stage's, both gears of ISO 1328-1 ``grade``."""
    if stage is None:
        return gearuq.get_model("geared_rotor").with_nominal(iso_grade=grade)
    if isinstance(stage, str):
        stage = gearuq.GearStage.example(stage) if "." not in stage \
            else gearuq.GearStage.from_toml(stage)
    return gearuq.get_model("geared_rotor", stage=stage).with_nominal(iso_grade=grade)


def failure_given_pass() -> Any:
    """kv_max >= LIMIT and both gears pass inspection (the joint event)."""
    return gearuq.ParallelSystem([
        LimitState.upper(RESPONSE, LIMIT, name=f"kv_max >= {LIMIT:g}"),
        LimitState.upper("pitch_acceptance_margin", 0.0, name="passes_inspection")])


def design_problem(options: dict[str, Any], grade: int = 6, stage: Any = None
                   ) -> DesignProblem:
    """Minimise P(kv_max >= LIMIT and pass) over the relief amount, length and crowning."""
    variables = [
        DesignVariable("amount", *AMOUNT_BOUNDS, target="tip_relief_amount", units="um",
                       description="nominal tip-relief amount on the drawing"),
        DesignVariable("length", *LENGTH_BOUNDS, target="tip_relief_length", units="mm",
                       description="nominal tip-relief length on the drawing"),
        DesignVariable("crowning", *CROWNING_BOUNDS, target="lead_crowning", units="um",
                       description="nominal lead crowning on the drawings (both gears)")]
    pf = Probability(failure_given_pass(), name="pf")
    return DesignProblem(rotor(grade, stage), input_space(), variables, pf,
                         model_options=options, run_outputs=["kv_over_speed"])


def given_pass(value: Any) -> float:
    """A joint probability (or an end of its interval) as the probability given acceptance."""
    return min(float(value) / P_PASS, 1.0)


def deterministic_optimum(options: dict[str, Any], per_dim: int, grade: int,
                          stage: Any = None, run_on: dict[str, Any] | None = None
                          ) -> tuple[np.ndarray, str, xr.Dataset]:
    """The design (and shape) with the least kv_max of nominal gears at the design load, on a
    ``per_dim``-point grid per design variable."""
    model = rotor(grade, stage)
    axes = [np.linspace(*b, per_dim) for b in BOUNDS]
    a, b, c = (g.ravel() for g in np.meshgrid(*axes, indexing="ij"))
    x = {n: np.zeros(a.size) for n in input_space().names}
    x.update(torque=np.full(a.size, 1000.0), tip_relief_amount=a, tip_relief_length=b,
             lead_crowning=c)
    y = np.full((len(SHAPES), *(per_dim,) * 3), np.nan)
    for k, shape in enumerate(SHAPES):
        request = model.prepare(None, outputs=[RESPONSE],
                                **{**options, "tip_relief_shape": shape})
        ds = evaluate_chunks(model, x, request, progress=False, **(run_on or {}))
        y[k] = np.where(ds["status"].values == 0, ds[RESPONSE].values,
                        np.nan).reshape((per_dim,) * 3)
    k, i, j, m = np.unravel_index(np.nanargmin(y), y.shape)
    dims = ("shape", "det_amount", "det_length", "det_crowning")
    grid = xr.Dataset({"deterministic_kv_max": (dims, y, {
        "units": "1", "long_name": "kv_max of nominal gears at the design torque"})},
        coords={"shape": list(SHAPES),
                **{d: (d, ax, {"units": u}) for d, ax, u in
                   zip(dims[1:], axes, ("um", "mm", "um"), strict=True)}})
    return np.array([axes[0][i], axes[1][j], axes[2][m]]), SHAPES[k], grid


def brute_force(problem: DesignProblem, per_dim: int, n: int, seed: int, crowning: float,
                run_on: dict[str, Any]) -> xr.Dataset:
    """Crude Monte Carlo on a grid of amount x length at ``crowning``, each design with its
    own fresh seed (Pf given pass)."""
    amounts = np.linspace(*AMOUNT_BOUNDS, per_dim)
    lengths = np.linspace(*LENGTH_BOUNDS, per_dim)
    est = np.full((3, per_dim, per_dim), np.nan)
    for i, a in enumerate(amounts):
        for j, b in enumerate(lengths):
            r = evaluate_design(problem, [a, b, crowning], n_samples=n, rng=seed + 7 * i + j,
                                **run_on)
            est[:, i, j] = [given_pass(r[f"pf{s}"]) for s in ("", "_lower", "_upper")]
    names = ("brute_pf", "brute_pf_lower", "brute_pf_upper")
    return xr.Dataset({k: (("brute_amount", "brute_length"), est[m], {"units": "1"})
                       for m, k in enumerate(names)},
                      coords={"brute_amount": ("brute_amount", amounts, {"units": "um"}),
                              "brute_length": ("brute_length", lengths, {"units": "mm"}),
                              "brute_crowning": ((), crowning, {"units": "um"})})


#: Names of the chosen design's neighbours, in the order :func:`neighbours` runs them.
NEIGHBOURS = ("chosen", "amount-", "amount+", "length-", "length+", "crowning-", "crowning+")


def neighbours(problem: DesignProblem, chosen: list[float], n: int, seed: int,
               run_on: dict[str, Any], step: float = 0.1) -> xr.Dataset:
    """Pf at the chosen design and at its six neighbours (+-``step`` of each range), all
    with one seed (common random numbers: the differences are sharper than the values)."""
    points = [np.array(chosen, dtype=float)]
    for j in range(len(BOUNDS)):
        for sign in (-1.0, 1.0):
            d = np.array(chosen, dtype=float)
            d[j] = np.clip(d[j] + sign * step * np.ptp(BOUNDS[j]), *BOUNDS[j])
            points.append(d)
    rows = [evaluate_design(problem, d, n_samples=n, rng=seed, **run_on) for d in points]
    return xr.Dataset({
        **{f"neighbour_{name}": ("neighbour", [p[j] for p in points], {"units": u})
           for j, (name, u) in enumerate((("amount", "um"), ("length", "mm"),
                                          ("crowning", "um")))},
        **{f"neighbour_pf{s}": ("neighbour", [given_pass(r[f"pf{s}"]) for r in rows],
                                {"units": "1"}) for s in ("", "_lower", "_upper")}},
        coords={"neighbour": list(NEIGHBOURS)})


def stage_check(problem: DesignProblem, chosen: list[float], n: int, seed: int,
                grade: int, run_on: dict[str, Any], stage: str = "yuan_liu_liu"
                ) -> dict[str, Any]:
    """The same design problem on the stage file's rotor: kv_max per sample beside the
    paper rotor's (the same seed, so the same gears, loads and reliefs)."""
    on_stage = design_problem(problem.model_options, grade, stage)
    a = evaluate_design(problem, chosen, n_samples=n, rng=seed, keep_runs=True, **run_on)
    b = evaluate_design(on_stage, chosen, n_samples=n, rng=seed, keep_runs=True, **run_on)
    ka, kb = a["run_kv_max"].values, b["run_kv_max"].values
    return {"stage": stage, "n": n, "kv_max_paper": ka.tolist(), "kv_max_stage": kb.tolist(),
            "largest_relative_difference": float(np.nanmax(np.abs(kb / ka - 1.0))),
            "pf_paper": given_pass(a["pf"]), "pf_stage": given_pass(b["pf"])}


def landscape_figure(res: xr.Dataset, det: np.ndarray, det_shape: str, brute: xr.Dataset,
                     tag: str, history: list[dict[str, Any]] | None = None) -> Figure:
    """Pf given acceptance over amount x length at the chosen shape (the surrogate's mean,
    its interval width) with the brute force's estimates written on it and, on the width
    panel, the designs the search ran (``history``: their Pf and crowning), the data behind
    the surrogate's slice."""
    fig = Figure(figsize=(11, 4.4))
    axes = fig.subplots(1, 2)
    a, b = res["grid_amount"].values, res["grid_length"].values
    pf = res["landscape_pf"] / P_PASS
    width = (res["landscape_pf_upper"] - res["landscape_pf_lower"]) / P_PASS
    shape = str(res["level"].values)
    held = f"crowning {float(res['design_crowning']):.1f} um, " if "design_crowning" in res \
        else ""
    for ax, var, title, label in ((axes[0], pf, "Pf given acceptance (surrogate mean)", "Pf"),
                                  (axes[1], width, "width of its 95 % interval", "width")):
        m = ax.pcolormesh(b, a, np.clip(var.values, 0, 1), shading="auto", cmap="viridis")
        fig.colorbar(m, ax=ax, label=f"{label} [-]")
        ax.set_xlabel("tip-relief length [mm]")
        ax.set_ylabel("tip-relief amount [um]")
        ax.set_title(f"{title}, {shape} relief,\n{held}X = {LIMIT:g}" + tag, fontsize=9)
        ax.plot(float(res["design_length"]), float(res["design_amount"]), "r*", ms=14,
                label="chosen (under scatter)")
        ax.plot(det[1], det[0], "s", color="orange", ms=9, mec="k",
                label=f"deterministic optimum ({det_shape}, crowning {det[2]:.1f} um)")
    for i, aa in enumerate(brute["brute_amount"].values):
        for j, bb in enumerate(brute["brute_length"].values):
            axes[0].annotate(f"{float(brute['brute_pf'][i, j]):.2f}\n"
                             f"[{float(brute['brute_pf_lower'][i, j]):.2f},"
                             f"{float(brute['brute_pf_upper'][i, j]):.2f}]",
                             (bb, aa), color="w", fontsize=7, ha="center",
                             bbox={"facecolor": "k", "alpha": 0.4, "pad": 1})
    for k, h in enumerate(history or []):
        amount, length, crowning = h["design"]
        axes[1].plot(length, amount, "o", mfc="none", mec="w", ms=7,
                     label="search designs: Pf, crowning [um]" if k == 0 else None)
        axes[1].annotate(f"{given_pass(h['pf']):.2f}, {crowning:.0f}", (length, amount),
                         color="w", fontsize=6, xytext=(4, 3), textcoords="offset points")
    # on the width panel: on the Pf panel it would hide the brute force's corner estimates
    axes[1].legend(loc="lower right", fontsize=7)
    return fig


def band_figure(chosen: xr.Dataset, det_conf: xr.Dataset, labels: tuple[str, str],
                tag: str) -> Figure:
    """K_v against speed (median and 5-95 % band of accepted pairs): chosen vs deterministic."""
    fig = Figure(figsize=(7.5, 4.4))
    ax = fig.subplots()
    for ds, label, colour in ((chosen, labels[0], "tab:blue"),
                              (det_conf, labels[1], "tab:red")):
        ok = ds["run_status"].values == 0
        if "run_pitch_acceptance_margin" in ds:
            ok &= ds["run_pitch_acceptance_margin"].values >= 0
        kv = ds["run_kv_over_speed"].values[ok]
        speed = ds["run_kv_over_speed"]["range_speed"].values
        lo, mid, hi = (np.nanquantile(kv, q, axis=0) for q in (0.05, 0.5, 0.95))
        ax.fill_between(speed, lo, hi, color=colour, alpha=0.25)
        ax.plot(speed, mid, color=colour, label=f"{label}: median, 5-95 % of {ok.sum()} pairs")
    ax.axhline(LIMIT, color="k", ls="--", label=f"X = {LIMIT:g}")
    ax.set_xlabel("pinion speed [rpm]")
    ax.set_ylabel("dynamic factor K_v [-]")
    ax.set_title("K_v over speed under scatter, gears that pass inspection" + tag, fontsize=9)
    ax.legend(fontsize=7)
    return fig


def _sizes(quick: bool, scale: float) -> dict[str, int]:
    base = SIZES[bool(quick)]
    if quick:
        return dict(base)
    keep = ("n_designs", "n_infill", "grid", "det_grid")
    return {k: (v if k in keep else max(2, int(round(v * scale)))) for k, v in base.items()}


@plot.quick_mode(
    "a few dozen cheap-rotor runs per design step",
    left_out=("the full search sizes, the 3 x 3 brute-force grid at full size, the search's "
              "fidelity (40 speeds, 2 mesh harmonics, the peak refined; quick: 12 speeds, 1 "
              "harmonic, peaks not refined) and the expensive-fidelity confirmation: the chosen "
              "design is not resolved"))
def run(out: str | Path = "gearuq_relief_design", quick: bool = False, seed: int = 29,
        grade: int = 6, scale: float = 1.0, stage: str | None = None,
        executor: Any = "processes") -> int:
    """Tip relief (amount, length, shape) of the geared rotor that minimises
    Pf(kv_max >= X | inspected gears).

    Parameters
    ----------
    out : path
        Output folder (created): ``relief_design.nc``, ``deterministic.nc``, ``brute.nc``,
        ``summary.json``, ``pf_landscape.png``, ``kv_band.png``.
    quick : bool
        A few runs per step at a lower fidelity (:data:`QUICK_OPTIONS`; under a minute of
        CPU once compiled); every figure says
        "quick: N runs, not a result".
    seed : int
        Seed of the search; the confirmations and the brute force draw their own.
    grade : int
        ISO 1328-1 class of both gears, 6 or 7.
    scale : float
        Multiplies the full sample sizes (per design, confirmation, brute force), in (0, 1];
        the numbers of designs stay.
    stage : str, optional
        Run the study on a stage's rotor (an example name such as ``"yuan_liu_liu"`` or a
        TOML file) instead of the paper's rotor.
    executor : str or runner
        Where the rotor runs go (:func:`gearuq.execution.workers_for_run`): ``"processes"``
        (default) keeps one pool of process workers for every step; ``"serial"`` runs in
        this process.

    Returns
    -------
    int
        0 when the design result's status is 0 and the checks agree; otherwise the larger of
        the two (the words are in ``summary.json``).
    """
    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        raise ValueError(f"seed={seed!r}: must be a non-negative integer")
    if grade not in (6, 7):
        raise ValueError(f"grade={grade!r}: the study is set for ISO 1328-1 classes 6 and 7")
    if not 0.0 < float(scale) <= 1.0:
        raise ValueError(f"scale={scale!r}: must lie in (0, 1]")
    size = _sizes(quick, float(scale))
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    t_start = time.perf_counter()
    search_options = QUICK_OPTIONS if quick else SEARCH_OPTIONS
    problem = design_problem(search_options, grade, stage)
    confirm_problem = design_problem(QUICK_OPTIONS if quick else CONFIRM_OPTIONS, grade, stage)
    steps: dict[str, tuple[float, float]] = {}
    # one pool of workers for every step (a fresh worker costs seconds of imports and
    # compiled kernels); a step's CPU is this process's plus its workers'
    with workers_for_run(executor) as pool:
        run_on = {"executor": pool, "chunk_size": QUICK_CHUNK if quick else CHUNK}

        def clock(step: str | None = None, since: tuple[float, float] = (0.0, 0.0)
                  ) -> tuple[float, float]:
            now = (time.perf_counter(), time.process_time()
                   + getattr(pool, "worker_cpu_seconds", 0.0))
            if step is not None:
                steps[step] = (now[0] - since[0], now[1] - since[1])
                print(f"step {step}: {steps[step][0]:.0f} s wall, {steps[step][1]:.0f} s CPU "
                      "(this process and its workers)", flush=True)
            return now

        t = clock()
        # the deterministic optimum first: it seeds each shape's search (classic RBDO starts
        # there), so the search cannot end worse than it on its own estimates
        det, det_shape, det_grid = deterministic_optimum(search_options, size["det_grid"],
                                                         grade, stage, run_on)
        t = clock("deterministic", t)
        levels = optimize_levels(problem, "tip_relief_shape", SHAPES, strategy="surrogate",
                                 n_samples=size["n_per_design"], n_designs=size["n_designs"],
                                 n_infill=size["n_infill"], grid=9, rng=seed,
                                 start_designs=[det], confirm_samples=size["confirm"],
                                 confirm_problem=confirm_problem,
                                 keep_confirmation_runs=True, **run_on)
        t = clock("search_and_confirm", t)
        shape = str(levels["best_level"].values)
        res = levels.sel(level=shape)
        chosen = [float(res[f"design_{v.name}"]) for v in problem.variables]
        # the confirmation's seed again: the two designs see the same built gears and loads
        det_conf = evaluate_design(at_level(confirm_problem, "tip_relief_shape", det_shape),
                                   det, n_samples=size["confirm"],
                                   rng=int(res.attrs["confirm_seed"]), keep_runs=True,
                                   **run_on)
        t = clock("deterministic_under_scatter", t)
        at_shape = at_level(problem, "tip_relief_shape", shape)
        brute = brute_force(at_shape, size["grid"], size["brute"], seed + 100, chosen[2],
                            run_on)
        t = clock("brute_force", t)
        near = neighbours(at_shape, chosen, size["brute"], seed + 200, run_on)
        t = clock("neighbours", t)
        staged = None if stage is not None else stage_check(at_shape, chosen, size["stage"],
                                                             seed + 300, grade, run_on)
        t = clock("stage_check", t)
    wall = time.perf_counter() - t_start
    cpu = sum(c for _, c in steps.values())
    paired = paired_failures(_fails(res), _fails(det_conf))
    status = _status(res, det_conf, brute, near, paired, staged)
    n_levels = len(SHAPES)
    n_runs = {"search": int(levels["n_model_runs_search"].sum()),
              "confirm": int(levels["n_model_runs_confirm"].sum()),
              "deterministic": n_levels * size["det_grid"] ** len(BOUNDS),
              "deterministic_confirm": int(det_conf["n_model_runs"]),
              "brute_force": size["grid"] ** 2 * size["brute"],
              "neighbours": len(NEIGHBOURS) * size["brute"],
              "stage_check": 0 if staged is None
              else 2 * size["stage"],
              "naive_nested_loop": int(levels["n_model_runs_naive"].sum())}
    n_total = sum(v for k, v in n_runs.items() if k != "naive_nested_loop")
    tag = f"\nquick: {n_total} runs, not a result" if quick else ""
    summary = {
        "chosen": {"shape": shape, "amount_um": chosen[0], "length_mm": chosen[1],
                   "crowning_um": chosen[2], **_pf_given_pass(res, "confirm_pf")},
        "per_shape": {str(lv): {"amount_um": float(levels["design_amount"].sel(level=lv)),
                                "length_mm": float(levels["design_length"].sel(level=lv)),
                                "crowning_um": float(levels["design_crowning"].sel(level=lv)),
                                **_pf_given_pass(levels.sel(level=lv), "confirm_pf")}
                      for lv in levels["level"].values},
        "shape_comparison": levels.attrs["level_message"],
        "shape_decided": bool(int(levels["level_decided"])),
        "deterministic": {"shape": det_shape, "amount_um": float(det[0]),
                          "length_mm": float(det[1]), "crowning_um": float(det[2]),
                          **_pf_given_pass(det_conf, "pf")},
        "paired_chosen_vs_deterministic": paired,
        "neighbours": {str(k): [float(near[f"neighbour_pf{s}"][i])
                                for s in ("", "_lower", "_upper")]
                       for i, k in enumerate(near["neighbour"].values)},
        "stage_check": staged, "stage": stage, "grade": grade,
        "limit_kv": LIMIT, "p_pass": P_PASS, "response": RESPONSE, "model_runs": n_runs,
        "search_options": search_options,
        "confirm_options": confirm_problem.model_options,
        "status": status[0], "message": status[1],
        "design_status": [int(v) for v in levels["status"].values],
        "design_message": json.loads(levels.attrs["message_per_level"]),
        "steps_wall_cpu_s": steps, "cpu_seconds": cpu, "wall_time_s": wall,
        "executor": repr(executor), "sizes": size, "quick": bool(quick)}
    keep = [v for v in levels.data_vars if not str(v).startswith("run_")]
    gearuq.save(levels[keep], out / "relief_design.nc")
    gearuq.save(xr.merge([det_grid, det_conf.drop_vars(
        [v for v in det_conf.data_vars if str(v).startswith("run_")])],
        combine_attrs="drop_conflicts"), out / "deterministic.nc")
    gearuq.save(xr.merge([brute, near]), out / "brute.nc")
    (out / "summary.json").write_text(json.dumps(summary, indent=2))
    save_figure(landscape_figure(res, det, det_shape, brute, tag, search_history(levels, shape)),
                out / "pf_landscape.png")
    labels = (f"chosen: {shape} {chosen[0]:.1f} um / {chosen[1]:.1f} mm, crown "
              f"{chosen[2]:.1f} um",
              f"deterministic optimum: {det_shape} {det[0]:.1f} um / {det[1]:.1f} mm, crown "
              f"{det[2]:.1f} um")
    save_figure(band_figure(res, det_conf, labels, tag), out / "kv_band.png")
    print(_report(summary, levels), flush=True)
    print(f"total: {wall:.0f} s wall, {cpu:.0f} s CPU; {n_total} rotor runs against "
          f"{n_runs['naive_nested_loop']} for a nested loop's search alone; the whole summary "
          f"in {out / 'summary.json'}")
    return max(status[0], int(res["status"]))


def _report(summary: dict[str, Any], levels: xr.Dataset) -> str:
    """The screen's summary: designs, their P(kv_max >= X | pass) and every status in words."""
    def design(d: dict[str, Any]) -> str:
        lo, up = d["pf_interval"]
        return (f"{d['amount_um']:.1f} um / {d['length_mm']:.1f} mm, crown "
                f"{d['crowning_um']:.1f} um: P(kv_max >= {LIMIT:g} | pass) = "
                f"{d['pf_given_pass']:.3g} [{lo:.3g}, {up:.3g}]")

    chosen, det, paired = (summary["chosen"], summary["deterministic"],
                           summary["paired_chosen_vs_deterministic"])
    lines = [f"chosen: {chosen['shape']} {design(chosen)}",
             f"deterministic optimum under scatter: {det['shape']} {design(det)}",
             f"  on the same {paired['n']} gears and loads: {paired['only_a']} fail only at the "
             f"chosen design, {paired['only_b']} only at the deterministic one (McNemar p = "
             f"{paired['p_value']:.2g})"]
    for shape, code, words in zip(levels["level"].values, summary["design_status"],
                                  summary["design_message"], strict=True):
        lines.append(f"shape {shape}: {design(summary['per_shape'][str(shape)])}; "
                     f"status {code}: {words}")
    lines.append(f"shapes: {summary['shape_comparison']}")
    lines.append(f"status {summary['status']}: {summary['message']}")
    return "\n".join(lines)


def search_history(levels: xr.Dataset, shape: str) -> list[dict[str, Any]]:
    """The designs the search ran at ``shape`` and their estimates (joint probability)."""
    per_level = json.loads(levels.attrs["search_history_per_level"])
    return json.loads(per_level[list(levels["level"].values).index(shape)])


def _pf_given_pass(ds: xr.Dataset, name: str) -> dict[str, Any]:
    return {"pf_given_pass": given_pass(ds[name]),
            "pf_interval": [given_pass(ds[f"{name}_lower"]), given_pass(ds[f"{name}_upper"])]}


def _fails(ds: xr.Dataset) -> np.ndarray:
    """Failure (kv_max >= X and pass) per confirmation run, NaN where the run is invalid."""
    ok = ds["run_status"].values == 0
    fail = (ds["run_kv_max"].values >= LIMIT) & (ds["run_pitch_acceptance_margin"].values >= 0)
    return np.where(ok, fail.astype(float), np.nan)


def _status(res: xr.Dataset, det_conf: xr.Dataset, brute: xr.Dataset, near: xr.Dataset,
            paired: dict[str, Any], staged: dict[str, Any] | None) -> tuple[int, str]:
    """0 when the brute force, the neighbours and the stage file agree with the choice."""
    words = []
    chosen_lo = float(near["neighbour_pf_lower"][0])
    better = [str(k) for k, up in zip(near["neighbour"].values[1:],
                                     near["neighbour_pf_upper"].values[1:], strict=True)
              if up < chosen_lo]
    if better:
        words.append(f"neighbour(s) {better} shown better than the chosen design (same seed)")
    if int((res["run_status"] != 0).sum()) or int(det_conf["n_invalid"]):
        words.append("invalid rotor runs in a confirmation")
    # the brute force runs the search's fidelity: compare it with the chosen design's estimate
    # at that fidelity (the neighbours' centre), not with the expensive confirmation
    best = float(brute["brute_pf_upper"].min())
    if chosen_lo > best:
        words.append(f"the brute-force grid holds a design whose upper end {best:.3g} lies "
                     f"below the chosen design's lower end {chosen_lo:.3g} (search fidelity): "
                     "the optimiser's choice is not the best")
    if paired["p_value"] < 0.05 and paired["only_a"] > paired["only_b"]:
        words.append(f"the deterministic optimum fails less often than the chosen design on the "
                     f"same {paired['n']} gears and loads ({paired['only_a']} fail only at the "
                     f"chosen design, {paired['only_b']} only at the deterministic one; "
                     f"McNemar p = {paired['p_value']:.2g}): the search did not find the better "
                     "design")
    if float(res["confirm_pf"]) == 0.0:
        words.append("no failure in the chosen design's confirmation: Pf is an upper bound")
    if staged is not None and not staged["largest_relative_difference"] <= 1e-6:
        words.append(f"the stage file's rotor differs from the paper's by "
                     f"{staged['largest_relative_difference']:.2g} in kv_max on the same samples")
    msg = "; ".join(words) or ("the chosen design is confirmed, no brute-force design or "
                               "neighbour is shown better, the stage file agrees")
    return (1 if words else 0), msg


def main(argv: list[str] | None = None) -> int:
    """Command line: ``python -m gearuq_studies.relief_design``."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, default=Path("gearuq_relief_design"))
    ap.add_argument("--quick", action="store_true", help="a few runs per step")
    ap.add_argument("--seed", type=int, default=29, help="seed of the search")
    ap.add_argument("--grade", type=int, default=6, help="ISO 1328-1 class (6 or 7)")
    ap.add_argument("--scale", type=float, default=1.0, help="multiplies the sample sizes")
    ap.add_argument("--stage", default=None, help="a stage example name or TOML file")
    ap.add_argument("--executor", default="processes", help="processes (default) or serial")
    args = ap.parse_args(argv)
    return run(args.out, quick=args.quick, seed=args.seed, grade=args.grade, scale=args.scale,
               stage=args.stage, executor=args.executor)


if __name__ == "__main__":
    raise SystemExit(main())
