"""Eritenel and Parker (2013) with the ``mesh_oscillator`` plugin: response regions, modified
gears, speed against error, and a reliability use of the cheap model.

Writes PNG + netCDF into the output folder and prints a summary:

1. ``regions.png`` - Eritenel and Parker's Fig. 4 analog: linear, first-order, second-order
   (stable solid, unstable dashed) and numerical (up and down sweeps) frequency responses of their
   example system, with the four response regions coloured and numbered.
2. ``gears.png`` - their Figs. 1-3 analog: tangent mesh stiffness and mean-removed
   excitation over a mesh cycle at 50, 150, 250 N m, and the first excitation harmonic
   alpha_0,1 against torque, for an unmodified and a tip-relieved spur pair, both from the
   LTCA force-deflection function.
3. ``speed_error.md`` - a 500-point frequency response by the second-order perturbation
   against numerical sweeps: time and amplitude error per region
   (``gearuq_plugins.mesh_oscillator.bench``).
4. ``reliability.png`` - probability that the resonant DTE amplitude of Yuan, Liu and Liu (2020)
   helical pair exceeds a limit under random damping, torque and tip-relief amount (Monte
   Carlo on the perturbation model), checked on a subsample against numerical sweeps.

Run: ``gearuq study mesh_oscillator_regions [--quick] [--out DIR]``. ``--quick``: 111
frequency points instead of 441, LTCA tables with 16 positions per mesh cycle and 10 points
per line (32 x 20), 12 torques instead of 23, the benchmark's quick mode and 400 reliability
samples instead of 4000, checked against numerical sweeps on at most 6 of them (30).
"""

from __future__ import annotations

import argparse
import math
import time
from pathlib import Path

import matplotlib
import matplotlib.pyplot as plt
import numpy as np
import xarray as xr

import gearuq
from gearuq import plot
from gearuq.failure.report import describe_status
from gearuq.gears.deviations import FlankDeviations
from gearuq.gears.geometry import HelicalGearPair
from gearuq.gears.ltca import normal_force_from_torque

REGION_COLOURS = {1: "#4daf4a", 2: "#377eb8", 3: "#ff7f00", 4: "#e41a1c"}


def example_spur_pair() -> HelicalGearPair:
    """Unity-ratio spur pair of our choice (Eritenel and Parker (2013) Tables 2-4 are lost): z
    50/50, module
    3 mm, 20 deg, face width 20 mm, standard rack."""
    return HelicalGearPair(mn=3e-3, z1=50, z2=50, alpha_n=math.radians(20.0), beta=0.0,
                           b1=20e-3, b2=20e-3)


def relief(pair: HelicalGearPair, amount: float) -> FlankDeviations:
    """Parabolic tip relief of ``amount`` on both gears over 30 % of the path of contact."""
    return FlankDeviations.symmetric_tip_relief(amount, 0.3 * pair.g_alpha)


# ------------------------------------------------------------------------------ 1 regions
def fig4_analog(out: Path, quick: bool) -> dict:
    """Eritenel and Parker's Fig. 4 analog; returns the headline numbers."""
    model = gearuq.get_model("mesh_oscillator")
    grid = np.linspace(0.86, 1.08, 111 if quick else 441)
    coarse = grid[::3]
    outs = ["branch_amplitude", "branch_stable", "n_branches", "amplitude_up", "amplitude_down",
            "region_up", "region_down", "linear_amplitude", "separation_down"]
    second = model.response({}, outputs=outs, frequencies=grid, order=2)
    first = model.response({}, outputs=outs, frequencies=grid, order=1)
    num = model.response({}, outputs=["amplitude_up", "amplitude_down", "region_up",
                                      "region_down", "separation_down"],
                         frequencies=coarse, method="sweep")
    fig, ax = plt.subplots(figsize=(11.5, 5.5))
    ax.plot(grid, second["linear_amplitude"][0], "-.", color="0.45", lw=1.2,
            label="linear (time-invariant)")
    _branches(ax, grid, first, "#984ea3", "first order (Eq. 27)", lw=1.0)
    _branches(ax, grid, second, "k", "second order (Eq. 31)", lw=2.2, regions=True)
    step = max(1, coarse.size // 50)  # every point is compared below; fewer are drawn
    ax.plot(coarse[::step], num["amplitude_up"][0][::step], "o", mfc="none", mec="#1b9e77",
            ms=6, label="numerical, upward sweep")
    ax.plot(coarse[::step], num["amplitude_down"][0][::step], "s", mfc="none", mec="#d95f02",
            ms=4, label="numerical, downward sweep")
    ax.set_xlabel(r"frequency ratio $\Omega$ = mesh frequency / $\omega_n$ [-]")
    ax.set_ylabel(r"fundamental amplitude $a$ of $u = (x - x_m)/d$ [-]")
    ax.set_title("Eritenel and Parker Fig. 4 analog: alpha01 = 2/75, alpha00 = 2/3, alpha20 = 1/4, "
                 "alpha30 = -1/24, e1 = 0.1, mu = 0.0082", fontsize=9)
    handles, labels = ax.get_legend_handles_labels()
    for r, col in REGION_COLOURS.items():
        handles.append(plt.Line2D([], [], color=col, lw=6, alpha=0.35))
        labels.append(f"region {r}")
    ax.legend(handles, labels, fontsize=8, loc="upper left", bbox_to_anchor=(1.01, 1.0))
    ax.set_ylim(0, 1.65)
    ax.grid(alpha=0.3)
    fig.tight_layout()
    plot.save_figure(fig, out / "regions.png", dpi=130)
    plt.close(fig)
    ds = xr.Dataset({f"second_{k}": second[k] for k in outs} | {f"first_{k}": first[k] for k in
                                                               ("amplitude_up",
                                                                "amplitude_down")})
    gearuq.save(ds.drop_vars([v for v in ds.coords if v not in ("frequency", "branch",
                                                                "sample")]),
                out / "regions_perturbation.nc")
    gearuq.save(num, out / "regions_numerical.nc")
    err = {}
    for w in ("up", "down"):
        ref = num[f"amplitude_{w}"].values[0]
        rel = np.abs(second[f"amplitude_{w}"].values[0][::3] - ref) / ref
        reg = num[f"region_{w}"].values[0]
        for r in (1, 2, 3, 4):
            if (reg == r).any():
                err.setdefault(r, []).extend(rel[reg == r])
    onset = second["onset_frequency_ratio"].values[0]
    return {"onset": onset, "errors": {r: max(v) for r, v in err.items()},
            "fold": grid[second["n_branches"].values[0] > 1][[0, -1]]}


def _branches(ax, grid, ds, colour, label, lw, regions=False):
    """Stable branches solid (coloured by region for the second order), unstable dashed."""
    amp = ds["branch_amplitude"].values[0]
    stable = ds["branch_stable"].values[0]
    n_b = ds["n_branches"].values[0]
    # a slot (lower/middle/upper) changes branch where the number of branches changes:
    # break the lines there instead of joining two branches
    change = np.concatenate([[False], np.diff(n_b) != 0])
    for b in range(3):  # lower, middle, upper
        a = np.where(stable[:, b] == 1, amp[:, b], np.nan)
        if b == 1:
            a = np.where(n_b == 3, a, np.nan)
        a = np.where(change, np.nan, a)
        ax.plot(grid, a, "-", color=colour, lw=lw, label=label if b == 0 else None)
        un = np.where((stable[:, b] == 0) & (n_b > 1) & ~change, amp[:, b], np.nan)
        ax.plot(grid, un, "--", color=colour, lw=lw * 0.8,
                label=f"{label}, unstable" if b == 1 else None)
    if not regions:
        return
    for w, off in (("up", 0.0), ("down", 0.0)):
        a = ds[f"amplitude_{w}"].values[0]
        reg = ds[f"region_{w}"].values[0]
        for r, col in REGION_COLOURS.items():
            ax.plot(grid, np.where(reg == r, a + off, np.nan), "-", color=col, lw=7,
                    alpha=0.35, solid_capstyle="butt")
            sel = np.flatnonzero(reg == r)
            if sel.size and w == "down":
                k = sel[sel.size // 2]
                ax.annotate(f"({r})", (grid[k], a[k]), textcoords="offset points",
                            xytext=(0, 9), ha="center", fontsize=11, color=col,
                            fontweight="bold")


# ------------------------------------------------------------------------------ 2 gears
def gear_tables(pair, amount, quick, torques=(5, 15, 30, 50, 75, 100, 150, 200, 250, 300,
                                                400)):
    """LTCA force-deflection table over one mesh cycle at the given torques [N m]."""
    from gearuq_plugins.mesh_oscillator import LoadDeflectionTable

    dev = relief(pair, amount) if amount > 0 else None
    torques = np.asarray(torques, dtype=float)
    loads = np.array([normal_force_from_torque(pair, t) for t in torques])
    return LoadDeflectionTable.from_ltca(pair, loads, positions_per_cycle=16 if quick else 32,
                                         n_pts=10 if quick else 20, deviations=dev)


def gear_comparison(out: Path, quick: bool) -> dict:
    """Eritenel and Parker's Figs. 1-3 analog; returns alpha_01 against torque, both gears."""
    from gearuq_plugins.mesh_oscillator import mean_deflection

    pair = example_spur_pair()
    torques = np.linspace(40.0, 260.0, 12 if quick else 23)
    forces = np.array([normal_force_from_torque(pair, t) for t in torques])
    fig, axes = plt.subplots(2, 3, figsize=(13, 7))
    summary = {}
    for row, (name, amount) in enumerate((("unmodified", 0.0), ("10 um tip relief", 10e-6))):
        table = gear_tables(pair, amount, quick)
        model = gearuq.get_model("mesh_oscillator", force=table,
                                 nominal={"mean_force": forces[0]})
        ds = model.response({"mean_force": forces}, outputs=["alpha", "mesh_stiffness",
                                                             "mean_deflection"],
                            harmonics=4)
        a01 = ds["alpha"].values[:, 0, 1]
        summary[name] = {"alpha01": a01, "torque": torques}
        phase = table.phase
        for t_nm, style in ((50.0, "-."), (150.0, "--"), (250.0, "-")):
            f0 = normal_force_from_torque(pair, t_nm)
            x_m = mean_deflection(table, np.array([f0]))[0]
            der = table.derivatives(np.full((1, phase.size, 1), x_m), phase, 1)[:, 0, :, 0]
            axes[row, 0].plot(phase, der[1] * 1e-6, style, color="k", label=f"{t_nm:.0f} N m")
            axes[row, 1].plot(phase, der[0] - der[0].mean(), style, color="k",
                              label=f"{t_nm:.0f} N m")
        axes[row, 0].set_ylabel(f"{name}\ntangent mesh stiffness [N/um]")
        axes[row, 1].set_ylabel("mean-removed excitation\nB0(t) - F0 [N]")
        for ax in axes[row, :2]:
            ax.set_xlabel("mesh phase [cycles]")
            ax.legend(fontsize=8)
            ax.grid(alpha=0.3)
    ax = axes[0, 2]
    for (name, res), col in zip(summary.items(), ("#1b9e77", "#d95f02"), strict=True):
        ax.plot(res["torque"], res["alpha01"], "o-", color=col, label=name)
    ax.set_xlabel("pinion torque [N m]")
    ax.set_ylabel(r"first excitation harmonic $\alpha_{0,1}$ [-]")
    ax.set_title("Eritenel and Parker Fig. 3 analog", fontsize=9)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    axes[1, 2].axis("off")
    axes[1, 2].text(0.0, 0.9, "Spur pair z 50/50, m 3 mm, 20 deg,\nb 20 mm (our example).\n"
                    "Relief: parabolic, 10 um over 30 %\nof the path of contact, both gears.\n"
                    "Force-deflection: gearuq.gears.ltca\n(one mesh cycle, LTCA tangent "
                    "stiffness).", fontsize=9, va="top")
    fig.suptitle("Eritenel and Parker Figs. 1-3 analog: unmodified (top) and tip-relieved "
                 "(bottom) gears")
    fig.tight_layout()
    plot.save_figure(fig, out / "gears.png", dpi=120)
    plt.close(fig)
    gearuq.save(xr.Dataset({k.replace(" ", "_"): ("torque", v["alpha01"], {"units": "1"})
                            for k, v in summary.items()},
                           coords={"torque": ("torque", torques, {"units": "N m"})}),
                out / "alpha01_vs_torque.nc")
    return summary


# ------------------------------------------------------------------------------ 4 reliability
def _relief_model(quick: bool):
    """mesh_oscillator of Yuan, Liu and Liu's helical pair with a tip-relief family (0-20 um)."""
    from gearuq.gears.geometry import seed002_pair
    from gearuq_plugins.mesh_oscillator import TableFamily

    pair = seed002_pair()
    amounts = np.linspace(0.0, 20e-6, 5)
    torques = (20, 50, 100, 150, 200, 300, 400, 500, 700, 1000)
    family = TableFamily(tuple(gear_tables(pair, a, quick, torques) for a in amounts),
                         tuple(amounts), name="relief", units="m",
                         description="tip relief amount")
    f300 = normal_force_from_torque(pair, 300.0)
    model = gearuq.get_model("mesh_oscillator", force=family,
                             nominal={"mean_force": f300, "mass": _mass(pair),
                                      "relief": 10e-6, "damping_ratio": 0.03})
    return model, f300


def _peaks(ds: xr.Dataset) -> dict[str, np.ndarray]:
    """Run-up peak (upward sweep) and overall peak (either sweep) of the DTE amplitude."""
    up = ds["dte_amplitude_up"].values
    down = ds["dte_amplitude_down"].values
    return {"run-up": np.nanmax(up, axis=1), "either sweep": np.fmax(np.nanmax(up, axis=1),
                                                                     np.nanmax(down, axis=1))}


def reliability(out: Path, quick: bool) -> dict:
    """P(resonant DTE amplitude > limit) of Yuan, Liu and Liu's helical pair under random damping,
    torque and tip relief; two questions: the peak met on a run-up (upward sweep) and the
    largest amplitude on either sweep. Checked on a subsample by numerical sweeps."""
    import chaospy as cp

    model, f300 = _relief_model(quick)
    space = gearuq.ParameterSpace({
        "damping_ratio": cp.Uniform(0.02, 0.05),              # Yuan et al.: 2-5 %
        "mean_force": cp.Normal(f300, 0.1 * f300),             # torque 300 N m, CoV 10 %
        "relief": cp.Uniform(0.0, 20e-6),
    })
    opts = {"frequency_min": 0.85, "frequency_max": 1.15, "n_frequencies": 121}
    outs = ["dte_amplitude_up", "dte_amplitude_down"]
    n = 400 if quick else 4000
    t0 = time.perf_counter()
    ds = gearuq.monte_carlo(model, space, n_samples=n, rule="lhs", rng=7, outputs=outs,
                            executor="serial", model_options=opts)
    wall = time.perf_counter() - t0
    valid = ds["status"].values == 0
    peaks = _peaks(ds)
    limit = 9e-6  # DTE amplitude limit [m] (our example)
    names = {"run-up": "peak_dte_runup", "either sweep": "peak_dte_either"}
    for key, var in names.items():
        ds[var] = ("sample", peaks[key], {"units": "m", "role": "output"})
    rel = gearuq.reliability(ds, {v: (None, limit) for v in names.values()})
    # check: random samples plus, for each question, those nearest the limit
    m_each = 2 if quick else 10  # a numerical sweep costs seconds per sample
    picks = [np.arange(m_each)] + [np.argsort(np.abs(np.where(valid, p, np.inf) - limit))[
        :m_each] for p in peaks.values()]
    pick = np.unique(np.concatenate(picks))
    sub = {k: ds[k].values[pick] for k in ("damping_ratio", "mean_force", "relief")}
    t1 = time.perf_counter()
    num = model.response(sub, outputs=outs, method="sweep", **opts)
    wall_num = time.perf_counter() - t1
    ok = num["status"].values == 0
    num_peaks = _peaks(num)
    result = {"n": n, "n_invalid": int((~valid).sum()), "limit_um": limit * 1e6,
              "wall": wall, "wall_check": wall_num, "m": pick.size, "n_check_ok": int(ok.sum()),
              "status_words": describe_status(ds), "check_status_words": describe_status(num),
              "questions": {}}
    for key, var in names.items():
        mode = rel.sel(mode=var)
        a_p, a_n = peaks[key][pick][ok], num_peaks[key][ok]
        err = np.abs(a_p - a_n) / a_n
        result["questions"][key] = {
            "pf": mode["pf"].item(), "pf_interval": (mode["pf_lower"].item(),
                                                     mode["pf_upper"].item()),
            "disagree": int(np.sum((a_p > limit) != (a_n > limit))),
            "err_median": float(np.median(err)), "err_max": float(err.max()),
            "a_p": a_p, "a_n": a_n}
    _reliability_plot(out, peaks, valid, limit, result)
    gearuq.save(ds, out / "reliability_mc.nc")
    gearuq.save(num, out / "reliability_check_sweeps.nc")
    return result


def _reliability_plot(out, peaks, valid, limit, result) -> None:
    fig, ax = plt.subplots(1, 2, figsize=(11.5, 4.5))
    styles = {"run-up": ("#377eb8", "o"), "either sweep": ("#ff7f00", "s")}
    lo, hi = np.inf, -np.inf
    for key, (col, marker) in styles.items():
        q = result["questions"][key]
        ax[0].hist(peaks[key][valid] * 1e6, bins=40, histtype="step", lw=1.8, color=col,
                   label=f"{key} peak: pf = {q['pf']:.4f}")
        ax[1].plot(q["a_n"] * 1e6, q["a_p"] * 1e6, marker, mfc="none", color=col,
                   label=f"{key}: {q['disagree']} of {result['n_check_ok']} classified "
                         "differently")
        lo = min(lo, q["a_n"].min(), q["a_p"].min())
        hi = max(hi, q["a_n"].max(), q["a_p"].max())
    ax[0].axvline(limit * 1e6, color="#e41a1c", lw=1.5, label=f"limit {limit * 1e6:.0f} um")
    ax[0].set_xlabel("resonant DTE amplitude a d [um]")
    ax[0].set_ylabel("samples [-]")
    ax[0].set_title(f"{result['n']} LHS samples, second-order perturbation", fontsize=9)
    ax[1].plot([lo * 1e6, hi * 1e6], [lo * 1e6, hi * 1e6], "-", color="0.5", lw=1)
    ax[1].axvline(limit * 1e6, color="#e41a1c", lw=1)
    ax[1].axhline(limit * 1e6, color="#e41a1c", lw=1)
    ax[1].set_xlabel("numerical sweep of the exact f [um]")
    ax[1].set_ylabel("second-order perturbation [um]")
    ax[1].set_title(f"check on {result['m']} samples (random and nearest the limit)",
                    fontsize=9)
    for a in ax:
        a.grid(alpha=0.3)
        a.legend(fontsize=8)
    fig.tight_layout()
    plot.save_figure(fig, out / "reliability.png", dpi=120)
    plt.close(fig)


def _mass(pair: HelicalGearPair, rho: float = 7850.0) -> float:
    """Equivalent mass of solid steel blanks of reference diameter and face width:
    J_p J_g / (J_p r_g^2 + J_g r_p^2) with pitch radii (as helical_pair does)."""
    r1, r2 = pair.d1 / 2, pair.d2 / 2
    j1 = 0.5 * rho * math.pi * r1**2 * pair.b1 * r1**2
    j2 = 0.5 * rho * math.pi * r2**2 * pair.b2 * r2**2
    return j1 * j2 / (j1 * r2**2 + j2 * r1**2)


@plot.quick_mode(
    "111 frequency points, 400 reliability samples",
    left_out=(
        "441 frequency points, LTCA tables of 32 x 20, 23 torques and 4000 reliability "
        "samples checked by numerical sweeps on 30 (6 here)"))
def run(out: str | Path = "gearuq_mesh_oscillator_regions", quick: bool = False) -> int:
    """Response regions of Eritenel and Parker's mesh oscillator, modified gears, a reliability.

    The four response regions of the frequency response (their Fig. 4), the excitation of
    unmodified and tip-relieved gears against torque (their Figs. 1-3), perturbation speed
    against error, and a resonant-amplitude reliability of Yuan, Liu and Liu's pair.

    Parameters
    ----------
    out : path
        Output folder (created): ``regions.png``, ``gears.png``, ``reliability.png``,
        ``speed_error.md`` and the netCDF files behind them.
    quick : bool
        111 frequency points, coarser LTCA tables, 12 torques, 400 reliability samples.

    Returns
    -------
    int
        0.
    """
    matplotlib.use("Agg")  # files only: no window, whatever backend the session has
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    fig4 = fig4_analog(out, quick)
    gears = gear_comparison(out, quick)
    table = gearuq.registry.get_benchmark("mesh_oscillator")(out=out, quick=quick)
    (out / "speed_error.md").write_text(table["markdown"] + "\n")
    rel = reliability(out, quick)
    print("\n== Eritenel and Parker Fig. 4 analog")
    print(f"  multi-valued (hysteresis) band of the second order: Omega "
          f"{fig4['fold'][0]:.4f}-{fig4['fold'][1]:.4f}")
    print(f"  contact loss starts/ends on the response curve at Omega {fig4['onset']}")
    print("  largest |a_2nd - a_numerical| / a_numerical per region: "
          + ", ".join(f"{r}: {e:.3f}" for r, e in sorted(fig4["errors"].items())))
    print("\n== Eritenel and Parker Figs. 2-3 analog (alpha_0,1 at the lowest / highest torque)")
    for name, res in gears.items():
        a = res["alpha01"]
        print(f"  {name:18s} alpha01 {a[0]:.4f} ({res['torque'][0]:.0f} N m) -> {a[-1]:.4f} "
              f"({res['torque'][-1]:.0f} N m), max/min {a.max() / a.min():.2f}")
    print("\n== reliability (Yuan, Liu and Liu's helical pair, 300 N m, random relief)")
    print(f"  {rel['n']} perturbation samples in {rel['wall']:.1f} s ({rel['n_invalid']} "
          f"flagged invalid); check: {rel['n_check_ok']} of {rel['m']} samples integrated "
          f"in {rel['wall_check']:.1f} s")
    print(f"  perturbation samples: {rel['status_words']}; check sweeps: "
          f"{rel['check_status_words']}")
    for key, q in rel["questions"].items():
        print(f"  {key:12s} P(peak > {rel['limit_um']:.0f} um) = {q['pf']:.4f} "
              f"[{q['pf_interval'][0]:.4f}, {q['pf_interval'][1]:.4f}]; check: "
              f"{q['disagree']} classified differently, amplitude error median "
              f"{q['err_median']:.3f}, max {q['err_max']:.3f}")
    print(f"\noutputs in {out}")
    return 0


def main(argv: list[str] | None = None) -> int:
    """Command line: ``python -m gearuq_studies.mesh_oscillator_regions``."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("gearuq_mesh_oscillator_regions"))
    parser.add_argument("--quick", action="store_true", help="coarser grids, fewer samples")
    args = parser.parse_args(argv)
    return run(args.out, quick=args.quick)


if __name__ == "__main__":
    raise SystemExit(main())
