"""Speed against error: perturbation frequency response against numerical frequency sweeps.

``run()`` measures, side by side in one process, a frequency response on the same grid of
``n_points`` frequencies (500 by default) for the example system of EP Fig. 4:

- the multiple-scales solution, second order with the closed-form separation (Eqs. 31, 34,
  35), second order with the numerical separation (Eqs. 32-33) and first order (Eq. 27);
- numerical upward and downward sweeps of Eq. 11 (``gearuq.ode.solve_batch``, DOP853,
  rtol 1e-8, transients decayed to ``settle_tolerance`` at every frequency), on one core;
- a tighter sweep (``settle_tolerance`` 1e-6) as the check of the sweep itself;
- the speed ratio at other damping ratios (the sweep's settle time grows like ``1/mu``).

Errors are the relative amplitude differences to the sweep, per response region (regions
from the sweep), in two forms: along the sweep paths (where the perturbation and the sweep
jump at frequencies one grid step apart, this is the branch-to-branch distance), and on
the same branch (the stable perturbation branch nearest to the sweep's amplitude at each
frequency: the accuracy of the solution itself). Timings are wall-clock on this machine
(the best of repeated runs for the fast methods); the ratio to the sweep is what a quiet
machine should reproduce.

Call ``gearuq_plugins.mesh_oscillator.bench.run(out="gearuq_bench", quick=False)``.

EP: Eritenel and Parker (2013), the paper this model follows (docs/models.md).
"""

from __future__ import annotations

import json
import time
import warnings
from pathlib import Path
from typing import Any

import numpy as np

from gearuq import kernels_route
from gearuq.bench import best_time, machine_description
from gearuq_plugins.mesh_oscillator import perturbation, sweeps, timedomain
from gearuq_plugins.mesh_oscillator.evaluate import regions
from gearuq_plugins.mesh_oscillator.model import MeshOscillator

GRID = (0.85, 1.10)
#: Spread of the per-period amplitudes above which a sweep point is taken as still settling.
UNSETTLED = 1e-3


def _sweep(system, grid, tolerance: float) -> tuple[float, dict]:
    """Upward and downward sweeps, serial (one core), amplitudes and separations."""
    problem = timedomain.expanded_rows(system)
    settle = sweeps.settle_periods(system.mu, np.array([grid.max()]), tolerance)
    both = sweeps.OscillatorProblem(problem.kind, np.vstack([problem.rows] * 2), 1)
    coefs = system.coefficients()
    y0 = np.vstack([timedomain.initial_linear(coefs, grid[:1]),
                    timedomain.initial_linear(coefs, grid[-1:])])
    t0 = time.perf_counter()
    res = sweeps.integrate_schedule(both, np.vstack([grid, grid[::-1]]),
                                    np.repeat(settle, 2), 4, 32, y0, parallel=False)
    wall = time.perf_counter() - t0
    return wall, {"up": res.amplitude[0], "down": res.amplitude[1][::-1],
                  "sep_up": res.separation[0], "sep_down": res.separation[1][::-1],
                  "unsettled_up": res.unsettled[0], "unsettled_down": res.unsettled[1][::-1],
                  "settle_periods": int(settle[0]), "steps": int(res.n_steps.sum()),
                  "status": res.status.tolist()}


def _errors(amp: dict, ref: dict, reg: dict, branches: dict | None = None) -> dict[str, float]:
    """Max and RMS relative amplitude error against ``ref`` per region (both sweeps); with
    ``branches`` (every stable perturbation amplitude, (K, B) per direction, NaN elsewhere)
    also the same-branch error ``same_max_r*``, ``same_rms_r*``: at each frequency the
    stable perturbation branch nearest to the sweep, leaving out the points where the sweep
    has just jumped and is still settling (``jump_points``: spread of the per-period
    amplitudes above :data:`UNSETTLED`)."""
    rel = np.concatenate([np.abs(amp[w] - ref[w]) / ref[w] for w in ("up", "down")])
    where = np.concatenate([reg["up"], reg["down"]])
    out: dict[str, float] = {"max_all": float(np.nanmax(rel))}
    sets = [("", rel)]
    if branches is not None:
        # where the sweep has just jumped to another branch it is still settling (spread of
        # the per-period amplitudes above the settle tolerance): no reference there
        jump = {w: ref[f"unsettled_{w}"] > UNSETTLED for w in ("up", "down")}
        out["jump_points"] = int(jump["up"].sum() + jump["down"].sum())
        with np.errstate(invalid="ignore"), warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)  # no stable branch: NaN
            near = np.concatenate([np.where(jump[w], np.nan, np.nanmin(
                np.abs(branches[w] - ref[w][:, None]), axis=1) / ref[w])
                for w in ("up", "down")])
        sets.append(("same_", near))
    for prefix, err in sets:
        for r in (1, 2, 3, 4):
            sel = where == r
            out[f"{prefix}max_r{r}"] = float(np.nanmax(err[sel])) if sel.any() else np.nan
            out[f"{prefix}rms_r{r}"] = (float(np.sqrt(np.nanmean(err[sel] ** 2))) if sel.any()
                                        else np.nan)
    return out


def _stable_branches(res: Any) -> np.ndarray:
    """Every stable steady-state amplitude of the (single) sample, shape (K, branches)."""
    return np.where(res.stable[0] == 1, res.amplitude[0], np.nan)


def damping_dependence(n_points: int, dampings: tuple[float, ...],
                       repeat: int = 1) -> list[dict[str, Any]]:
    """Speed ratio sweep / perturbation (second order, closed form) at several damping
    ratios of the EP Fig. 4 system: the settle periods of the sweep grow like ``1/mu``."""
    model = MeshOscillator()
    options = model.validate_options({})
    grid = np.linspace(*GRID, n_points)
    rows = []
    for mu in dampings:
        system = model.system(model.validate_params({"damping_ratio": mu}), options)
        coefs = system.coefficients()
        with kernels_route("compiled"):  # compile / load once, outside the timing
            perturbation.frequency_response(coefs, grid, parallel=False)
        wall, _ = best_time(lambda c=coefs: perturbation.frequency_response(
            c, grid, parallel=False), 5 * repeat)
        sweep_wall, ref = _sweep(system, grid, 1e-3)
        if repeat > 1:
            sweep_wall = min(sweep_wall, _sweep(system, grid, 1e-3)[0])
        rows.append({"damping_ratio": mu, "settle_periods": ref["settle_periods"],
                     "perturbation_s": wall, "sweep_s": sweep_wall,
                     "speedup_vs_sweep": sweep_wall / wall})
    return rows


def measure(n_points: int = 500, quick: bool = False,
            dampings: tuple[float, ...] = (0.02, 0.05)) -> dict[str, Any]:
    """Run the comparison; return rows (one per method), the damping dependence of the
    speed ratio and the settings."""
    model = MeshOscillator()
    options = model.validate_options({})
    system = model.system(model.validate_params({}), options)
    coefs = system.coefficients()
    grid = np.linspace(*GRID, n_points)
    sweep_wall, ref = _sweep(system, grid, 1e-3)
    if not quick:  # best of two: the machine may be shared
        sweep_wall = min(sweep_wall, _sweep(system, grid, 1e-3)[0])
    reg = {w: regions(ref[w], ref[f"sep_{w}"], coefs, grid[None], options["region_tolerance"],
                      options["onset_separation"])[0] for w in ("up", "down")}
    rows = []
    methods = [("perturbation, 2nd order, closed-form separation", 2, "closed_form", 5),
               ("perturbation, 1st order", 1, "closed_form", 5),
               ("perturbation, 2nd order, numerical separation", 2, "numerical", 1)]
    for label, order, sep, repeat in methods:
        with kernels_route("compiled"):  # compile / load once, outside the timing
            perturbation.frequency_response(coefs, grid, order=order, separation=sep,
                                            parallel=False)
        wall, res = best_time(lambda o=order, s=sep: perturbation.frequency_response(
            coefs, grid, order=o, separation=s, parallel=False), 1 if quick else repeat)
        amp = {"up": res.path("up")[0], "down": res.path("down")[0]}
        stable = _stable_branches(res)
        rows.append({"method": label, "wall_s": wall, "us_per_point": wall / n_points * 1e6,
                     "speedup_vs_sweep": sweep_wall / wall,
                     **_errors(amp, ref, reg, {"up": stable, "down": stable})})
    rows.append({"method": f"numerical sweeps up + down (settle {ref['settle_periods']} "
                           "periods)", "wall_s": sweep_wall,
                 "us_per_point": sweep_wall / n_points * 1e6, "speedup_vs_sweep": 1.0,
                 **_errors(ref, ref, reg)})
    if not quick:
        tight_wall, tight = _sweep(system, grid, 1e-6)
        rows.append({"method": f"numerical sweeps, tighter settle ({tight['settle_periods']} "
                               "periods): error of the sweep itself", "wall_s": tight_wall,
                     "us_per_point": tight_wall / n_points * 1e6,
                     "speedup_vs_sweep": sweep_wall / tight_wall, **_errors(ref, tight, reg)})
    counts = {f"points_r{r}": int(sum((reg[w] == r).sum() for w in ("up", "down")))
              for r in (1, 2, 3, 4)}
    damping = [{"damping_ratio": float(coefs[0, 0]), "settle_periods": ref["settle_periods"],
                "perturbation_s": rows[0]["wall_s"], "sweep_s": sweep_wall,
                "speedup_vs_sweep": rows[0]["speedup_vs_sweep"]}]
    damping += damping_dependence(n_points, dampings, 1 if quick else 2)
    return {"rows": rows, "n_points": n_points, "grid": list(GRID), "system": "EP Fig. 4",
            "region_points": counts, "sweep_status": ref["status"],
            "sweep_steps": ref["steps"], "damping": damping,
            "machine": machine_description() + " (shared with other jobs)"}


def markdown(result: dict[str, Any]) -> str:
    """The result as markdown tables."""
    lines = [f"{result['n_points']}-point frequency response, Omega in {result['grid']} "
             f"({result['system']}); relative amplitude error against the sweep per region, "
             f"max / rms along the sweep paths and [on the same branch, leaving out the "
             f"{result['rows'][0].get('jump_points', 0)} points where the sweep has just "
             f"jumped and is still settling] (points per region, up + down: "
             f"{result['region_points']})", "",
             "| method | wall [s] | us / point | speed-up vs sweep | region 1 | region 2 "
             "| region 3 | region 4 |", "|---|---|---|---|---|---|---|---|"]
    for r in result["rows"]:
        cells = []
        for k in (1, 2, 3, 4):
            cell = f"{r[f'max_r{k}']:.2g} / {r[f'rms_r{k}']:.2g}"
            if f"same_max_r{k}" in r:
                cell += f" [{r[f'same_max_r{k}']:.2g} / {r[f'same_rms_r{k}']:.2g}]"
            cells.append(cell)
        lines.append(f"| {r['method']} | {r['wall_s']:.4g} | {r['us_per_point']:.4g} | "
                     f"{r['speedup_vs_sweep']:.4g} | " + " | ".join(cells) + " |")
    lines += ["", "Speed ratio against damping (second order, closed form; the sweep settles "
              "ln(1/1e-3) Omega / (2 pi mu) periods per frequency):", "",
              "| damping ratio | settle periods | perturbation [s] | sweeps [s] | speed-up |",
              "|---|---|---|---|---|"]
    for d in result.get("damping", []):
        lines.append(f"| {d['damping_ratio']:.4g} | {d['settle_periods']} | "
                     f"{d['perturbation_s']:.3g} | {d['sweep_s']:.3g} | "
                     f"{d['speedup_vs_sweep']:.4g} |")
    if "machine" in result:
        lines += ["", f"Machine: {result['machine']}"]
    return "\n".join(lines)


def run(out: str | Path | None = "gearuq_bench", quick: bool = False) -> dict[str, Any]:
    """Measure, print the table and write ``mesh_oscillator_bench.{json,md}`` into ``out``.

    Parameters
    ----------
    out : path or None
        Output folder (created); ``None`` writes nothing.
    quick : bool
        100 frequencies, no repeated timings and no tight reference sweep (~10 s).
    """
    result = measure(100 if quick else 500, quick=quick)
    text = markdown(result)
    print(text)
    if out is not None:
        folder = Path(out)
        folder.mkdir(parents=True, exist_ok=True)
        (folder / "mesh_oscillator_bench.json").write_text(json.dumps(result, indent=1))
        (folder / "mesh_oscillator_bench.md").write_text(text + "\n")
    result["markdown"] = text
    return result
