"""Long-period LTCA: the line-load table against the full LTCA (``gearuq bench longperiod``).

For the 30/30 pair of Yuan, Liu and Liu (2020) and two hunting-tooth pairs (13/17, lcm 221;
a 27/79 electric-axle stage, lcm 2133), side by side in one run: CPU time per sample of the
full LTCA over the long period (:func:`gearuq.gears.ltca.ltca`, set-up reused) and of the
line-load table (:func:`gearuq.gears.long_period.long_period_ltca`, table reused), the table's
one-off cost, and the table's error against the full LTCA for each ``n_load_nodes``.
"""

from __future__ import annotations

import json
import math
import os
import time
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from gearuq._firstcall import kernels_route
from gearuq.bench.core import machine_description
from gearuq.gears.deviations import FlankDeviations, random_cumulative_pitch_deviations
from gearuq.gears.geometry import HelicalGearPair, seed002_pair
from gearuq.gears.long_period import LongPeriodSettings, line_load_table, long_period_ltca
from gearuq.gears.ltca import ltca, ltca_setup

__all__ = ["bench_cases", "compare", "eaxle_27_79_pair", "hunting_13_17_pair",
           "plugin_sample", "run", "run_rotor", "uniform_stage"]

_DEG = math.pi / 180.0


def eaxle_27_79_pair() -> HelicalGearPair:
    """A 27/79 electric-axle stage (lcm 2133): m_n 2 mm, helix 22 deg, b 30/28 mm, x +0.3/-0.2."""
    return HelicalGearPair(mn=2e-3, z1=27, z2=79, alpha_n=20 * _DEG, beta=22 * _DEG,
                           b1=30e-3, b2=28e-3, x1=0.3, x2=-0.2)


def hunting_13_17_pair() -> HelicalGearPair:
    """A small hunting-tooth pair (lcm 221): m_n 3 mm, helix 20 deg, b 30 mm, x +0.2/0."""
    return HelicalGearPair(mn=3e-3, z1=13, z2=17, alpha_n=20 * _DEG, beta=20 * _DEG,
                           b1=30e-3, b2=30e-3, x1=0.2, x2=0.0)


def _grade_deviations(pair: HelicalGearPair, grade: int, relief: tuple[float, float],
                      seed: int) -> FlankDeviations:
    """ISO 1328 grade ``grade`` random cumulative pitch deviations of both gears, one relief."""
    rng = np.random.default_rng(seed)
    fp = [random_cumulative_pitch_deviations(z, seed=rng, accuracy_grade=grade, d=d, mn=pair.mn)
          for z, d in ((pair.z1, pair.d1), (pair.z2, pair.d2))]
    return FlankDeviations.symmetric_tip_relief(*relief, Fp1=fp[0], Fp2=fp[1])


def bench_cases() -> list[dict]:
    """The benchmark's pairs, torques and deviation laws (relief in m, torque in N m)."""
    cases = []
    for label, pair, torque, relief in (
            ("30/30 (Yuan et al.)", seed002_pair(), 600.0, (20e-6, 10e-3)),
            ("13/17", hunting_13_17_pair(), 150.0, (8e-6, 3e-3)),
            ("27/79 e-axle", eaxle_27_79_pair(), 150.0, (8e-6, 2e-3))):
        cases.append({"label": label, "pair": pair, "torque": torque, "relief": relief,
                      "grade": 6})
    return cases


def _cpu(fn):
    t0 = time.process_time()
    out = fn()
    return time.process_time() - t0, out


def compare(fast: xr.Dataset, full: xr.Dataset) -> dict[str, float]:
    """Errors of the table route against the full LTCA of the same sample.

    Relative errors of the STE peak-to-peak and of the mean secant and tangent mesh
    stiffness; largest pointwise STE error [um], largest pointwise relative stiffness
    errors, largest CMS error [um] and positions whose partial-contact-loss flag differs.
    """
    def ptp(ds):
        return float(ds["ste"].max() - ds["ste"].min())

    def rel_mean(v):
        return float(fast[v].mean() / full[v].mean() - 1.0)

    return {
        "ste_ptp_rel": ptp(fast) / ptp(full) - 1.0,
        "lpms_mean_rel": rel_mean("lpms"),
        "lpms_tangent_mean_rel": rel_mean("lpms_tangent"),
        "ste_max_abs_um": float(np.abs(fast["ste"] - full["ste"]).max()),
        "lpms_max_rel": float((np.abs(fast["lpms"] - full["lpms"]) / full["lpms"]).max()),
        "lpms_tangent_max_rel": float((np.abs(fast["lpms_tangent"] - full["lpms_tangent"])
                                       / full["lpms_tangent"]).max()),
        "cms_max_abs_um": float(np.abs(fast["cms"] - full["cms"]).max()),
        "loss_flag_differs": int((fast["partial_contact_loss"].values
                                  != full["partial_contact_loss"].values).sum()),
    }


def _case_rows(case: dict, nodes: tuple[int, ...], n_samples: int) -> list[dict]:
    pair, torque = case["pair"], case["torque"]
    devs = [_grade_deviations(pair, case["grade"], case["relief"], seed)
            for seed in range(n_samples)]
    t_setup, setup = _cpu(lambda: ltca_setup(pair))
    fulls, t_full = [], 0.0
    for dev in devs:
        t, ds = _cpu(lambda dev=dev: ltca(pair, torque=torque, deviations=dev, setup=setup,
                                           keep_points=False))
        t_full += t
        fulls.append(ds)
    rows = [{"pair": case["label"], "lcm": math.lcm(pair.z1, pair.z2), "route": "full LTCA",
             "n_load_nodes": None, "one_off_s": t_setup, "cpu_per_sample_s": t_full / n_samples,
             "positions": fulls[0].sizes["position"]}]
    for n in nodes:
        settings = LongPeriodSettings(n_load_nodes=n)
        t_table, table = _cpu(lambda settings=settings: line_load_table(
            pair, max_torque=torque, modifications=devs[0], settings=settings))
        t_fast, errs = 0.0, []
        for dev, full in zip(devs, fulls, strict=True):
            t, fast = _cpu(lambda dev=dev, table=table: long_period_ltca(
                pair, dev, torque=torque, table=table, keep_lines=False))
            t_fast += t
            errs.append(compare(fast, full))
        worst = {k: max((e[k] for e in errs), key=abs) for k in errs[0]}
        rows.append({"pair": case["label"], "lcm": math.lcm(pair.z1, pair.z2),
                     "route": "line-load table", "n_load_nodes": n, "one_off_s": t_table,
                     "cpu_per_sample_s": t_fast / n_samples,
                     "positions": fulls[0].sizes["position"], **worst})
    return rows


def _warm_up() -> None:
    """Compile both routes' kernels on a tiny problem, so no timing includes compilation."""
    pair = seed002_pair()
    dev = _grade_deviations(pair, 6, (20e-6, 10e-3), 0)
    # forced: a small call from an empty cache would otherwise run interpreted (gearuq._firstcall)
    with kernels_route("compiled"):
        ltca(pair, torque=600.0, deviations=dev, n_cycles=1, positions_per_cycle=2, n_pts=2)
        long_period_ltca(pair, dev, torque=600.0, n_cycles=1, settings=LongPeriodSettings(
            positions_per_cycle=2, n_pts=2, n_load_nodes=4))


def render(rows: list[dict], header: str) -> str:
    """Markdown table of :func:`run`'s rows."""
    lines = [header, "",
             "| pair | lcm | route | load nodes | one-off CPU [s] | CPU/sample [ms] | / 30/30 "
             "full | STE p-p "
             "rel. err. | mean LPMS rel. err. | mean tangent rel. err. | max STE err. [um] | "
             "max LPMS rel. err. | max tangent rel. err. | max CMS err. [um] | loss flags "
             "differing |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        if r["route"] == "full LTCA":
            lines.append(f"| {r['pair']} | {r['lcm']} | full LTCA ({r['positions']} positions) "
                         f"| - | {r['one_off_s']:.3f} | {1e3 * r['cpu_per_sample_s']:.1f} | "
                         f"{r['cost_over_30_30_full']:.2f} | reference | | | | | | | |")
            continue
        lines.append(
            f"| {r['pair']} | {r['lcm']} | table | {r['n_load_nodes']} | {r['one_off_s']:.3f} | "
            f"{1e3 * r['cpu_per_sample_s']:.1f} | {r['cost_over_30_30_full']:.2f} | "
            f"{r['ste_ptp_rel']:.1e} | "
            f"{r['lpms_mean_rel']:.1e} | {r['lpms_tangent_mean_rel']:.1e} | "
            f"{r['ste_max_abs_um']:.1e} | {r['lpms_max_rel']:.1e} | "
            f"{r['lpms_tangent_max_rel']:.1e} | {r['cms_max_abs_um']:.1e} | "
            f"{r['loss_flag_differs']} |")
    return "\n".join(lines)


def run(out: str | Path = "gearuq_bench", quick: bool = False) -> list[dict]:
    """Run the benchmark, print and write ``longperiod.md`` / ``longperiod.json`` to ``out``.

    ``quick``: one sample per pair and 24 / 48 load nodes (the full run: 3 samples, 12 to
    96 nodes). Times are CPU seconds of this process (one core: the kernels are serial),
    per-position outputs only on both routes (``keep_points=False``, ``keep_lines=False``);
    ``cost_over_30_30_full`` divides by the 30/30 pair's full LTCA, the issue's yardstick.
    """
    nodes = (24, 48) if quick else (12, 24, 48, 96)
    n_samples = 1 if quick else 3
    _warm_up()
    load0 = os.getloadavg()[0]
    rows = []
    for case in bench_cases():
        rows.extend(_case_rows(case, nodes, n_samples))
    load1 = os.getloadavg()[0]
    base = rows[0]["cpu_per_sample_s"]  # the 30/30 pair's full LTCA, the yardstick
    for r in rows:
        r["cost_over_30_30_full"] = r["cpu_per_sample_s"] / base
    header = (f"Machine: {machine_description()}; load average {load0:.1f} -> {load1:.1f}; "
              f"{n_samples} sample(s) per pair (ISO 1328 grade 6 pitch deviations, tip "
              "relief), 24 positions per mesh cycle, 20 points per line; worst sample's error.")
    text = render(rows, header)
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    (out / "longperiod.md").write_text(text + "\n")
    (out / "longperiod.json").write_text(json.dumps(rows, indent=1, default=float))
    print(text)
    return rows


# ------------------------------------------------------------------------------ rotor
def _rotor_case():
    """13/17 pair of m_n 9 mm (fits the gear seats of Yuan et al.'s rotor), its excitation."""
    from gearuq.rotor.examples import seed002_rotor
    from gearuq.rotor.geared import GearedRotorProblem
    from gearuq.rotor.sideband_balance import excitation_from_long_period

    pair = HelicalGearPair(mn=9e-3, z1=13, z2=17, alpha_n=20 * _DEG, beta=20 * _DEG,
                           b1=40e-3, b2=40e-3, x1=0.2, x2=0.0)
    dev = _grade_deviations(pair, 6, (20e-6, 0.2 * pair.g_alpha), 0)
    exc = excitation_from_long_period(long_period_ltca(pair, dev, torque=600.0))
    n_mesh = 4
    problem = GearedRotorProblem(lambda k: seed002_rotor(k, pair=pair), exc, pinion_teeth=13,
                                 n_harmonics=n_mesh * math.lcm(13, 17))
    return pair, exc, problem, n_mesh


def _rotor_outputs(dte: np.ndarray, force: np.ndarray, loss: float) -> np.ndarray:
    return np.array([np.std(dte), np.ptp(dte), force.max(), force.min(), loss])


def _errors(res: np.ndarray, ref: np.ndarray) -> dict[str, float]:
    return {"dte_rms_rel": float(np.abs(res[:, 0] / ref[:, 0] - 1).max()),
            "dte_ptp_rel": float(np.abs(res[:, 1] / ref[:, 1] - 1).max()),
            "force_max_rel": float(np.abs(res[:, 2] / ref[:, 2] - 1).max()),
            "force_min_over_max": float((np.abs(res[:, 3] - ref[:, 3]) / ref[:, 2]).max()),
            "loss_abs": float(np.abs(res[:, 4] - ref[:, 4]).max())}


def _krylov_outputs(prep, sol, grid: np.ndarray | None = None) -> np.ndarray:
    """DTE on ``grid`` (default the solver's own instants) and force on the solver's grid."""
    from gearuq.rotor.harmonic_balance import synthesize

    N = prep.n_time
    dte = (np.fft.irfft(sol.channels["dte"] * N, n=N) if grid is None
           else synthesize(sol.channels["dte"], grid, sol.period))
    force = prep.k_grid * np.fft.irfft(sol.delta * N, n=N) - prep.ke_grid
    return _rotor_outputs(dte, force, sol.contact_loss_fraction)


def _krylov_row(problem, exc, n_mesh: int, speeds: np.ndarray, ref: np.ndarray) -> dict:
    """Every harmonic by GMRES against the dense balance (13/17)."""
    from gearuq.rotor.sideband_balance import prepare_krylov, solve_periodic_krylov

    # the dense balance's grid: with contact loss the grid is the law's discretisation, and
    # the force extremes are read on it
    prep = prepare_krylov(exc, n_mesh, n_time=problem.prep.n_time)
    res, t_all = [], 0.0
    # untimed: compiles the solver's kernels on a cold cache (3.5 s, 0.22 s per speed)
    solve_periodic_krylov(problem.reduced(speeds[0]), prep, problem.period(speeds[0]),
                          2 * math.pi * speeds[0] / 60, channels=["dte"])
    for rpm in speeds:
        model, T = problem.reduced(rpm), problem.period(rpm)
        t, sol = _cpu(lambda model=model, T=T, rpm=rpm: solve_periodic_krylov(
            model, prep, T, 2 * math.pi * rpm / 60, channels=["dte"]))
        t_all += t
        res.append(_krylov_outputs(prep, sol, np.arange(8192) * T / 8192))
    return {"method": "every harmonic, GMRES (full contact)", "n_orders": prep.n_harmonics + 1,
            "cpu_per_speed_ms": 1e3 * t_all / speeds.size, **_errors(np.array(res), ref)}


#: GMRES iterations a reference steady state may spend (the solver's default budget is
#: for samples; a reference must converge or say it did not: ``failed`` in its rows).
REFERENCE_BUDGET = 100_000


def _gmres_sweep(model_at, kp, speeds: np.ndarray, tol: float, continued: bool,
                 failed: list | None = None):
    """GMRES on every harmonic along ``speeds``: outputs, force harmonics, CPU, iterations.

    ``continued``: each speed starts GMRES (and Newton under contact loss) from the previous
    speed's solution, as ``LongPeriodProblem.dynamics_over_speeds`` does. CPU counts the
    receptances and the solve. ``failed`` (a list) receives the speeds whose status is not
    0; a 1e-10 sweep (the reference) runs with ``REFERENCE_BUDGET`` iterations.
    """
    from gearuq.rotor.sideband_balance import GMRES_BUDGET, solve_periodic_krylov

    budget = REFERENCE_BUDGET if tol <= 1e-10 else GMRES_BUDGET
    res, forces, t_all, its, prev = [], [], 0.0, 0, None
    for rpm in speeds:
        model, T = model_at(rpm)
        om = 2 * math.pi * rpm / 60

        def one(model=model, T=T, om=om, prev=prev):
            rec = model.receptances(om, 2 * np.pi / T * np.arange(kp.n_harmonics + 1),
                                    ["dte"])
            return solve_periodic_krylov(model, kp, T, om, tol=tol, receptance=rec,
                                         channels=["dte"], initial=prev, newton_start=prev,
                                         max_iter=budget)

        t, sol = _cpu(one)
        t_all += t
        its += sol.iterations
        prev = sol.delta if continued and sol.status == 0 else None
        if sol.status != 0 and failed is not None:
            failed.append(float(rpm))
        res.append(_krylov_outputs(kp, sol))
        forces.append(sol.force)
    return np.array(res), forces, t_all, its


def _eaxle_case(torque: float):
    """27/79 (m_n 6 mm) on Yuan et al.'s rotor at ``torque``: excitation, ``rpm -> (model, T)``
    (modes up to 1.5 x the highest of 4 mesh harmonics)."""
    from gearuq.rotor.examples import seed002_rotor
    from gearuq.rotor.geared import GearedRotorProblem
    from gearuq.rotor.sideband_balance import excitation_from_long_period

    pair = HelicalGearPair(mn=6e-3, z1=27, z2=79, alpha_n=20 * _DEG, beta=22 * _DEG,
                           b1=40e-3, b2=40e-3, x1=0.2, x2=0.0)
    dev = _grade_deviations(pair, 6, (20e-6, 0.2 * pair.g_alpha), 0)
    exc = excitation_from_long_period(long_period_ltca(pair, dev, torque=torque))
    L = math.lcm(27, 79)
    problem = GearedRotorProblem(lambda k: seed002_rotor(k, pair=pair), exc, pinion_teeth=27,
                                 n_harmonics=4)  # dense data unused: the cut-off is explicit

    def model_at(rpm):
        T = 60.0 * L / (27 * rpm)
        return problem.reduced(cutoff=1.5 * 4 * L * 2 * math.pi / T), T

    return exc, model_at


def _eaxle_contact_loss_rows(quick: bool) -> list[dict]:
    """27/79 at 100 N m, where the flanks separate: GMRES 1e-6 continued against 1e-10."""
    from gearuq.rotor.sideband_balance import prepare_krylov

    exc, model_at = _eaxle_case(100.0)
    speeds = np.linspace(25.0, 8000.0, 160)[::32 if quick else 16]
    kp = prepare_krylov(exc, 4)
    failed_ref: list[float] = []
    ref, _, t_ref, its = _gmres_sweep(model_at, kp, speeds, 1e-10, False, failed_ref)
    base = {"pair": "27/79 at 100 N m", "n_speeds": int(speeds.size),
            "max_contact_loss": float(ref[:, 4].max())}
    rows = [base | {"method": "every harmonic, GMRES 1e-10 (reference)",
                    "n_orders": kp.n_harmonics + 1,
                    "cpu_per_speed_ms": 1e3 * t_ref / speeds.size,
                    "gmres_iterations": its / speeds.size, "failed_speeds": failed_ref}]
    failed: list[float] = []
    res, _, t_set, its = _gmres_sweep(model_at, kp, speeds, 1e-6, True, failed)
    rows.append(base | {"method": "every harmonic, GMRES 1e-06, continued in speed",
                        "n_orders": kp.n_harmonics + 1,
                        "cpu_per_speed_ms": 1e3 * t_set / speeds.size,
                        "gmres_iterations": its / speeds.size, "failed_speeds": failed,
                        **_errors(res, ref)})
    return rows


def _eaxle_rotor_rows(quick: bool) -> list[dict]:
    """27/79 (m_n 6 mm) on Yuan et al.'s rotor: GMRES settings and sparse orders against GMRES
    on all 8532 harmonics converged to 1e-10, over 160 speeds (``quick``: 32)."""
    from gearuq.rotor.sideband_balance import (
        mesh_force_on_grid,
        prepare_krylov,
        prepare_orders,
        sideband_orders,
        solve_periodic_orders,
        spectral_orders,
    )

    exc, model_at = _eaxle_case(600.0)
    n_mesh, L = 4, math.lcm(27, 79)
    H = n_mesh * L
    speeds = np.linspace(25.0, 8000.0, 160)[::5 if quick else 1]
    kp = prepare_krylov(exc, n_mesh)
    ref, ref_force, t_ref, its = _gmres_sweep(model_at, kp, speeds, 1e-10, False)
    base = {"pair": "27/79", "n_speeds": int(speeds.size)}
    rows = [base | {"method": "every harmonic, GMRES 1e-10 (reference)", "n_orders": H + 1,
                    "cpu_per_speed_ms": 1e3 * t_ref / speeds.size,
                    "gmres_iterations": its / speeds.size}]
    for tol, continued in ((1e-6, False), (1e-6, True), (1e-4, True)):
        res, _, t_set, its = _gmres_sweep(model_at, kp, speeds, tol, continued)
        label = f"every harmonic, GMRES {tol:.0e}" + (", continued in speed" if continued
                                                      else "")
        rows.append(base | {"method": label, "n_orders": H + 1,
                            "cpu_per_speed_ms": 1e3 * t_set / speeds.size,
                            "gmres_iterations": its / speeds.size, **_errors(res, ref)})
    # sparse orders on every fifth speed (a dense real system of 2 |J| - 1 unknowns each)
    sub = np.arange(0, speeds.size, 5)
    mesh_orders = [h * L for h in range(1, n_mesh + 1)]
    sets = [("sidebands 2", sideband_orders(27, 79, n_mesh, 2))]
    sets += [(f"spectral {e}", spectral_orders(exc, H, e, always=mesh_orders))
             for e in (0.99, 0.995)]
    for label, J in sets:
        J = J[J <= H]
        prep = prepare_orders(exc, J)
        res, t_set, bound = [], 0.0, 0.0
        for i in sub:
            model, T = model_at(speeds[i])
            t, sol = _cpu(lambda model=model, T=T, rpm=speeds[i], prep=prep:
                          solve_periodic_orders(model, prep, T, 2 * math.pi * rpm / 60,
                                                channels=["dte"]))
            t_set += t
            N = prep.n_time
            c = np.zeros(N // 2 + 1, dtype=complex)
            c[J] = sol.channels["dte"]
            res.append(_rotor_outputs(np.fft.irfft(c * N, n=N), mesh_force_on_grid(prep, sol),
                                      sol.contact_loss_fraction))
            # what the orders left out can move an extreme by: the sum of their amplitudes
            left_out = np.ones(H + 1, bool)
            left_out[J] = False
            bound = max(bound, 2.0 * float(np.abs(ref_force[i][left_out]).sum())
                        / ref[i, 2])
        rows.append(base | {"method": label, "n_orders": int(J.size), "n_speeds": int(sub.size),
                            "cpu_per_speed_ms": 1e3 * t_set / sub.size,
                            "left_out_amplitude_sum": bound,
                            **_errors(np.array(res), ref[sub])})
    return rows


def uniform_stage(teeth: tuple[int, int], thin_seats: bool = False) -> Any:
    """The e-axle stage (``GearStage.example("e_axle_27_79")``) as ``geared_rotor`` takes it.

    Four equal bearings (400/150 N/um, 200 N s/m), ISO class 6 on both gears, no relief, the
    given tooth numbers; ``thin_seats``: 20 mm gear seats, so that small gears fit them.
    """
    from dataclasses import replace

    from gearuq.gears.stage import Bearing, GearStage

    e = GearStage.example("e_axle_27_79")
    bearing = Bearing(0.0, 400.0, 150.0, damping=200.0)
    shafts = {}
    for name in ("pinion_shaft", "wheel_shaft"):
        shaft = getattr(e, name)
        sections = tuple((length, 20.0 if thin_seats and i == 2 else outer, inner)
                         for i, (length, outer, inner) in enumerate(shaft.sections))
        shafts[name] = replace(shaft, sections=sections, bearings=tuple(
            replace(bearing, position=b.position) for b in shaft.bearings))
    return replace(e, teeth=teeth, pinion=replace(e.pinion, tip_relief=None),
                   wheel=replace(e.wheel, iso_grade=6, tip_relief=None),
                   name=f"uniform_{teeth[0]}_{teeth[1]}", **shafts)


#: Plugin samples of the rotor table: pair label, stage teeth (None: the 30/30 pair of Yuan,
#: Liu and Liu on their rotor), thin gear seats, speed range [rpm].
PLUGIN_SAMPLES = (("30/30", None, False, (25.0, 8000.0)),
                  ("13/17", (13, 17), True, (500.0, 16000.0)),
                  ("27/79", (27, 79), False, (500.0, 16000.0)))

#: Outputs of a plugin sample.
PLUGIN_OUTPUTS = ("kv_max", "speed_at_kv_max", "dte_rms_max", "kv_over_speed")


def plugin_sample(teeth: tuple[int, int] | None, thin_seats: bool,
                  speed_range: tuple[float, float], n_speeds: int = 160,
                  germ_seed: int = 7, **options: Any) -> tuple[float, xr.Dataset]:
    """CPU [s] of one ``geared_rotor`` sample over ``n_speeds`` speeds, and its outputs.

    150 N m, damping ratio 0.03, pitch germ drawn with ``germ_seed``; the grid and the peak
    refinement of ``kv_max`` and ``dte_rms_max``. A sample with another germ (seed 6) runs
    first on four speeds at the bottom of the range, so the timed one pays its own
    excitation and rotor problem but no compilation and no line-load table (built once per
    torque); on the whole range germ 6 of the 27/79 stage meets contact loss near a
    resonance (docs/theory/geared_rotor.md). One BLAS thread.
    """
    import gearuq
    from gearuq.rotor.geared import single_threaded_blas

    model = (gearuq.get_model("geared_rotor") if teeth is None else
             gearuq.get_model("geared_rotor", stage=uniform_stage(teeth, thin_seats)))
    opts = {"speed_min": speed_range[0], "speed_max": speed_range[1], "n_speeds": n_speeds}

    def germ(seed: int) -> dict[str, np.ndarray]:
        rng = np.random.default_rng(seed)
        return {"torque": np.array([150.0]), "damping_ratio": np.array([0.03])} | {
            p.name: rng.standard_normal(1) for p in model.parameters
            if p.name.startswith("pitch_xi_")}

    with single_threaded_blas():
        warm = opts | {"n_speeds": 4, "speed_max": 1.5 * speed_range[0]}
        with kernels_route("compiled"):  # the warm-up compiles, so the timing below does not
            model.response(germ(6), None, outputs=list(PLUGIN_OUTPUTS), **warm, **options)
        return _cpu(lambda: model.response(germ(germ_seed), None,
                                           outputs=list(PLUGIN_OUTPUTS), **opts, **options))


def _plugin_rows(quick: bool) -> list[dict]:
    """One plugin sample per pair: CPU, and against GMRES to 1e-10 on the long-period route."""
    rows = []
    n = 32 if quick else 160
    for label, teeth, thin, speeds in PLUGIN_SAMPLES:
        t, ds = plugin_sample(teeth, thin, speeds, n)
        row = {"pair": label, "plugin": True, "n_speeds": n, "cpu_s": t,
               "status": int(ds["status"][0]),
               **{k: float(ds[k][0]) for k in PLUGIN_OUTPUTS[:3]}}
        if teeth is not None:  # the long-period route: against its converged balance
            t_ref, ref = plugin_sample(teeth, thin, speeds, n, gmres_tol=1e-10)
            kv, kv_ref = ds["kv_over_speed"].values[0], ref["kv_over_speed"].values[0]
            row |= {"cpu_ref_s": t_ref,
                    "kv_max_rel": abs(row["kv_max"] / float(ref["kv_max"][0]) - 1.0),
                    "dte_rms_max_rel": abs(row["dte_rms_max"] / float(ref["dte_rms_max"][0])
                                           - 1.0),
                    "kv_over_speed_rel": float(np.max(np.abs(kv / kv_ref - 1.0)))}
        rows.append(row)
    return rows


def _rotor_table(rows: list[dict], lines: list[str]) -> None:
    """Append the 27/79, contact-loss and plugin-sample rows to the 13/17 table's ``lines``."""
    eaxle_header = False
    for r in rows:
        if r.get("plugin"):
            if r["pair"] == "30/30":
                lines += ["", f"One `geared_rotor` sample over {r['n_speeds']} speeds and the "
                          "peak refinement (150 N m, damping ratio 0.03, germ seed 7; 30/30: "
                          "the dense balance, 25-8000 rpm; stages 13/17 and 27/79: the "
                          "long-period route, GMRES 1e-6 continued, 500-16000 rpm), against "
                          "the same sample with `gmres_tol` 1e-10.", "",
                          "| pair | CPU per sample [s] | reference CPU [s] | status | kv_max | "
                          "dte_rms_max [m] | kv_max rel. | dte_rms_max rel. | kv_over_speed "
                          "rel. (worst speed) |", "|---|---|---|---|---|---|---|---|---|"]
            errs = ("| | | |" if "kv_max_rel" not in r else
                    f"| {r['kv_max_rel']:.1e} | {r['dte_rms_max_rel']:.1e} | "
                    f"{r['kv_over_speed_rel']:.1e} |")
            ref_cpu = f"{r['cpu_ref_s']:.2f}" if "cpu_ref_s" in r else "-"
            lines.append(f"| {r['pair']} | {r['cpu_s']:.2f} | {ref_cpu} | {r.get('status', '-')} "
                         f"| {r['kv_max']:.6f} | "
                         f"{r['dte_rms_max']:.4e} {errs}")
            continue
        if r.get("pair") == "27/79" and not eaxle_header:
            eaxle_header = True
            lines += ["", f"27/79 (m_n 6 mm) on the same rotor, 600 N m, grade 6, {r['n_speeds']} "
                      "speeds 25-8000 rpm (sparse orders: every fifth), all in full contact; "
                      "reference: every harmonic (8533) by GMRES to 1e-10; CPU per speed "
                      "with its receptances, for 160 speeds scaled.", "",
                      "| orders | kept | CPU per speed [ms] | CPU for 160 speeds [s] | GMRES "
                      "iterations | DTE RMS rel. | DTE p-p rel. | max force rel. | min force / "
                      "max | left-out amplitude sum / max |",
                      "|---|---|---|---|---|---|---|---|---|---|"]
        if r.get("pair") == "27/79":
            errs = ("reference | | | | |" if "dte_rms_rel" not in r else
                    f"{r['dte_rms_rel']:.1e} | {r['dte_ptp_rel']:.1e} | "
                    f"{r['force_max_rel']:.1e} | {r['force_min_over_max']:.1e} | "
                    + (f"{r['left_out_amplitude_sum']:.1e} |"
                       if "left_out_amplitude_sum" in r else "|"))
            its = f"{r['gmres_iterations']:.1f}" if "gmres_iterations" in r else "-"
            lines.append(f"| {r['method']} | {r['n_orders']} | {r['cpu_per_speed_ms']:.1f} | "
                         f"{0.16 * r['cpu_per_speed_ms']:.2f} | {its} | {errs}")
            continue
        if r.get("pair") == "27/79 at 100 N m":
            if "dte_rms_rel" not in r:
                lines += ["", f"27/79 at 100 N m, {r['n_speeds']} speeds 25-8000 rpm, largest "
                          f"contact-loss share {r['max_contact_loss']:.3f}.", "",
                          "| orders | kept | CPU per speed [ms] | GMRES iterations | DTE RMS "
                          "rel. | DTE p-p rel. | max force rel. | min force / max | "
                          "contact-loss share abs. |", "|---|---|---|---|---|---|---|---|---|"]
                errs = "reference | | | | |"
            else:
                errs = (f"{r['dte_rms_rel']:.1e} | {r['dte_ptp_rel']:.1e} | "
                        f"{r['force_max_rel']:.1e} | {r['force_min_over_max']:.1e} | "
                        f"{r['loss_abs']:.1e} |")
            failed = r.get("failed_speeds") or []
            note = (f" (not converged at {', '.join(f'{v:.0f}' for v in failed)} rpm)"
                    if failed else "")
            lines.append(f"| {r['method']}{note} | {r['n_orders']} | "
                         f"{r['cpu_per_speed_ms']:.1f} | {r['gmres_iterations']:.1f} | {errs}")
            continue
        if "dte_rms_rel" not in r:
            lines.append(f"| {r['method']} | {r['n_orders']} | {r['cpu_per_speed_ms']:.1f} | "
                         "reference | | | | |")
            continue
        lines.append(f"| {r['method']} | {r['n_orders']} | {r['cpu_per_speed_ms']:.1f} | "
                     f"{r['dte_rms_rel']:.1e} | {r['dte_ptp_rel']:.1e} | "
                     f"{r['force_max_rel']:.1e} | {r['force_min_over_max']:.1e} | "
                     f"{r['loss_abs']:.1e} |")


def run_rotor(out: str | Path = "gearuq_bench", quick: bool = False) -> list[dict]:
    """Rotor steady state on a sparse set of orders against the full harmonic balance.

    Second table: the 27/79 stage (m_n 6 mm) on the same rotor, 160 speeds (``quick``: 32):
    GMRES on every harmonic (:func:`~gearuq.rotor.sideband_balance.solve_periodic_krylov`)
    at looser tolerances and continued in speed, and sparse orders (every fifth speed),
    against GMRES converged to 1e-10; for the sparse orders also the sum of the reference
    force's amplitudes they leave out (a bound on what that moves an extreme by). Third
    table: the 27/79 stage at 100 N m, where the flanks separate, 10 speeds (``quick``: 5).

    13/17 pair on Yuan, Liu and Liu's rotor frame (600 N m, grade 6, 4 mesh orders: the full
    balance keeps 884 harmonics), speeds 500-8000 rpm (16; ``quick``: 6). Rows: the full
    balance (reference), fixed sideband counts (:func:`~gearuq.rotor.sideband_balance.
    sideband_orders`) and spectral selections (:func:`~gearuq.rotor.sideband_balance.
    spectral_orders`); errors are the worst over the speeds of the DTE RMS and peak-to-peak,
    the largest mesh force (relative) and the smallest (over the largest), and the
    contact-loss share. Writes ``longperiod_rotor.md`` / ``.json``.
    """
    from gearuq.rotor.geared import single_threaded_blas
    from gearuq.rotor.harmonic_balance import _contact_force, solve_periodic, synthesize
    from gearuq.rotor.sideband_balance import (
        mesh_force_on_grid,
        prepare_orders,
        sideband_orders,
        solve_periodic_orders,
        spectral_orders,
        synthesize_orders,
    )

    _warm_up()
    pair, exc, problem, n_mesh = _rotor_case()
    L = math.lcm(pair.z1, pair.z2)
    speeds = np.linspace(500.0, 8000.0, 6 if quick else 16)
    mesh_orders = [h * L for h in range(1, n_mesh + 1)]
    sets = [(f"sidebands {S}", sideband_orders(pair.z1, pair.z2, n_mesh, S)) for S in (2, 4)]
    sets += [(f"spectral {e}", spectral_orders(exc, n_mesh * L, e, always=mesh_orders))
             for e in (0.99, 0.999, 0.9999)]
    load0 = os.getloadavg()[0]
    ref, t_ref = [], 0.0
    with single_threaded_blas():
        for rpm in speeds:
            model, T = problem.reduced(rpm), problem.period(rpm)
            t, sol = _cpu(lambda model=model, T=T, rpm=rpm: solve_periodic(
                model, problem.prep, T, 2 * math.pi * rpm / 60, channels=["dte"]))
            t_ref += t
            grid = np.arange(8192) * T / 8192
            N = problem.prep.n_time
            force = _contact_force(problem.prep, np.fft.irfft(sol.delta * N, n=N), math.inf)[0]
            ref.append(_rotor_outputs(synthesize(sol.channels["dte"], grid, T), force,
                                      sol.contact_loss_fraction))
        ref = np.array(ref)
        rows = [{"method": f"full balance (H = {problem.n_harmonics})",
                 "n_orders": problem.n_harmonics + 1,
                 "cpu_per_speed_ms": 1e3 * t_ref / speeds.size}]
        for label, J in sets:
            J = J[J <= problem.n_harmonics]
            prep = prepare_orders(exc, J)
            res, t_set = [], 0.0
            for rpm in speeds:
                model, T = problem.reduced(rpm), problem.period(rpm)
                t, sol = _cpu(lambda model=model, T=T, rpm=rpm, prep=prep: solve_periodic_orders(
                    model, prep, T, 2 * math.pi * rpm / 60, channels=["dte"]))
                t_set += t
                grid = np.arange(8192) * T / 8192
                res.append(_rotor_outputs(synthesize_orders(sol.channels["dte"], J, grid, T),
                                          mesh_force_on_grid(prep, sol),
                                          sol.contact_loss_fraction))
            res = np.array(res)
            rows.append({
                "method": label, "n_orders": int(J.size),
                "cpu_per_speed_ms": 1e3 * t_set / speeds.size,
                "dte_rms_rel": float(np.abs(res[:, 0] / ref[:, 0] - 1).max()),
                "dte_ptp_rel": float(np.abs(res[:, 1] / ref[:, 1] - 1).max()),
                "force_max_rel": float(np.abs(res[:, 2] / ref[:, 2] - 1).max()),
                "force_min_over_max": float((np.abs(res[:, 3] - ref[:, 3]) / ref[:, 2]).max()),
                "loss_abs": float(np.abs(res[:, 4] - ref[:, 4]).max())})
        rows.append(_krylov_row(problem, exc, n_mesh, speeds, ref))
        rows += _eaxle_rotor_rows(quick)
        rows += _eaxle_contact_loss_rows(quick)
    rows += _plugin_rows(quick)
    load1 = os.getloadavg()[0]
    lines = [f"Machine: {machine_description()}; load average {load0:.1f} -> {load1:.1f}; "
             f"13/17 (m_n 9 mm) on Yuan et al.'s rotor, 600 N m, grade 6, {speeds.size} speeds "
             f"500-8000 rpm, largest contact-loss share of the reference "
             f"{ref[:, 4].max():.3f}; worst speed's error.", "",
             "| orders | kept | CPU per speed [ms] | DTE RMS rel. | DTE p-p rel. | max force rel. "
             "| min force / max | contact-loss share abs. |", "|---|---|---|---|---|---|---|---|"]
    _rotor_table(rows, lines)
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    (out / "longperiod_rotor.json").write_text(json.dumps(rows, indent=1, default=float))
    text = "\n".join(lines)
    (out / "longperiod_rotor.md").write_text(text + "\n")
    print(text)
    return rows
