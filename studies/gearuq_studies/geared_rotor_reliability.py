"""The question Yuan et al. (2020) leaves open: how likely is a geared rotor to vibrate too much?

Yuan et al. (2020) shows one realisation of the random cumulative pitch deviations. Here the pitch
deviations are random (ISO 1328-1 flank tolerance class as the input: amplitude F_pT/2,
scatter f_pT/(3 sqrt 2) per gear, a new realisation per sample), together with the torque
(uniform 800-1200 N m), the bearing stiffness (lognormal, median 5e8 N/m, 20 %) and the modal
damping ratio (uniform 0.03-0.08). For grades 5, 6 and 7:

1. the distribution of the RMS DTE over speed (500-8000 rpm) by Latin hypercube Monte Carlo,
2. the probability that it exceeds a limit (documented below) with Wilson 95 % intervals,
3. which inputs drive it (Sobol' indices by the Monte Carlo engine, Jansen estimator) at
   4000 rpm for grade 6, compared with the indices of a polynomial chaos surrogate fitted on
   its own design, and the surrogate's exceedance probability against Monte Carlo. For this
   step the realisation is split into its germ: the two sine phases become inputs
   (``pitch_phases="parameters"``; smooth, so a surrogate can follow them) and
   ``pitch_seed`` keeps only the scatter.

Limit: RMS DTE <= 12 um. There is no standard for the RMS of the DTE; 12 um is the sine
amplitude F_pT / 2 = 12.1 um that ISO 1328 grade 5 allows this gear statically, i.e. a
dynamic error no larger than a grade-5 gear's kinematic one. Change ``--limit`` to explore.
The RMS DTE is dominated by the shaft orders (the kinematic error of the pitch deviations);
the RMS of the orders >= f_m / 2 (``dte_mesh_band_rms``, the part the mesh dynamics shapes)
is shown beside it.

LTCA discretisation: 16 positions per mesh cycle and 12 points per line (coarser than the
default 24 x 20: the mean mesh stiffness changes by 0.01 %, the STE by up to 4 % of its
range at 1000 N m).

Run: ``gearuq study geared_rotor_reliability [--quick] [--out DIR]`` (a few minutes), or
``python -m gearuq_studies.geared_rotor_reliability [--n N] [--n-base N] [--limit UM]``.
Writes netCDF + PNG into the output folder. ``--quick`` runs 8 samples per grade at 6 speeds
(500-8000 rpm in steps of 1500) and a Sobol' base of 8: the figure and the table have every
part, the probabilities are rough (Wilson intervals say how rough).
"""

from __future__ import annotations

import argparse
import math
import time
from pathlib import Path

import numpy as np
import xarray as xr
from matplotlib.figure import Figure

import gearuq
from gearuq import plot
from gearuq.failure.report import describe_status
from gearuq.plot import save_figure

GRADES = (5, 6, 7)
COLOURS = ("tab:green", "tab:blue", "tab:red")
SPEEDS = np.arange(500.0, 8001.0, 500.0)
QUICK_SPEEDS = np.arange(500.0, 8001.0, 1500.0)
OPTIONS = {"positions_per_cycle": 16, "n_pts": 12, "pitch_model": "seeded"}
SOBOL_SPEED = 4000.0


def random_inputs() -> gearuq.ParameterSpace:
    """Torque, bearing stiffness, damping and the pitch-deviation realisation."""
    return gearuq.ParameterSpace({
        "torque": {"dist": "uniform", "lower": 800.0, "upper": 1200.0},
        "bearing_stiffness": {"dist": "lognormal", "mu": math.log(5.0e8), "sigma": 0.2},
        "damping_ratio": {"dist": "uniform", "lower": 0.03, "upper": 0.08},
        "pitch_seed": {"dist": "uniform", "lower": 0.0, "upper": 2.0**32 - 1.0},
    })


def rms_over_speed(model, space, grade: int, n: int, seed: int,
                   speeds: np.ndarray = SPEEDS) -> xr.Dataset:
    """RMS DTE of ``n`` LHS samples at every speed (sample-major: one LTCA per sample)."""
    design = space.sample(n, rule="lhs", rng=seed)
    params = {k: np.repeat(v, speeds.size) for k, v in design.items()}
    params["speed"] = np.tile(speeds, n)
    params["iso_grade"] = np.full(n * speeds.size, grade)
    ds = model.response(params, None, outputs=["dte_rms", "dte_mesh_band_rms",
                                                "contact_loss_fraction"], **OPTIONS)
    shape = (n, speeds.size)
    return xr.Dataset(
        {"dte_rms": (("sample", "speed"), ds["dte_rms"].values.reshape(shape),
                     {"units": "m"}),
         "dte_mesh_band_rms": (("sample", "speed"), ds["dte_mesh_band_rms"].values.reshape(
             shape), {"units": "m"}),
         "contact_loss_fraction": (("sample", "speed"),
                                   ds["contact_loss_fraction"].values.reshape(shape)),
         "status": (("sample", "speed"), ds["status"].values.reshape(shape),
                    ds["status"].attrs)}
        | {k: ("sample", v, {}) for k, v in design.items()},
        coords={"sample": np.arange(n), "speed": ("speed", speeds, {"units": "rpm"})})


def exceedance(res: xr.Dataset, limit: float) -> xr.Dataset:
    """P(RMS DTE > limit) per speed, Wilson 95 % interval, failed samples counted apart."""
    rows = []
    for j in range(res.sizes["speed"]):
        ds = xr.Dataset({"dte_rms": ("sample", res["dte_rms"].values[:, j], {"units": "m"}),
                         "status": ("sample", res["status"].values[:, j])})
        rel = gearuq.reliability(ds, {"dte_rms": (None, limit)}, system=False)
        r = rel.sel(mode=rel["mode"].values[0])
        rows.append((float(r["pf"]), float(r["pf_lower"]), float(r["pf_upper"])))
    a = np.array(rows)
    return xr.Dataset({"pf": ("speed", a[:, 0]), "pf_lower": ("speed", a[:, 1]),
                       "pf_upper": ("speed", a[:, 2])}, coords={"speed": res["speed"]},
                      attrs={"limit_m": limit, "interval": "Wilson 95 %"})


def sensitivity_space() -> gearuq.ParameterSpace:
    """The random inputs with the realisation split into its germ: two sine phases (smooth
    inputs a surrogate can represent) and the scatter (``pitch_seed``)."""
    two_pi = 2.0 * math.pi
    return gearuq.ParameterSpace({
        "torque": {"dist": "uniform", "lower": 800.0, "upper": 1200.0},
        "bearing_stiffness": {"dist": "lognormal", "mu": math.log(5.0e8), "sigma": 0.2},
        "damping_ratio": {"dist": "uniform", "lower": 0.03, "upper": 0.08},
        "pitch_phase_pinion": {"dist": "uniform", "lower": 0.0, "upper": two_pi},
        "pitch_phase_wheel": {"dist": "uniform", "lower": 0.0, "upper": two_pi},
        "pitch_seed": {"dist": "uniform", "lower": 0.0, "upper": 2.0**32 - 1.0},
    })


def sensitivity(model, n_base: int) -> tuple[xr.Dataset, object, float]:
    """Sobol' indices (MC engine) and a sparse PCE of the RMS DTE at 4000 rpm, grade 6."""
    space = sensitivity_space()
    names = tuple(space.names)
    opts = {**OPTIONS, "pitch_phases": "parameters"}

    def rms(**p):
        n = np.size(p["torque"])
        p = {**p, "speed": np.full(n, SOBOL_SPEED), "iso_grade": np.full(n, 6)}
        return model.response(p, None, outputs=["dte_rms"], **opts)["dte_rms"].values * 1e6

    wrapper = gearuq.FunctionModel(
        rms, [model.parameter(k) for k in names],
        [gearuq.Output("dte_rms_um", "um", ("sample",), "RMS DTE at 4000 rpm, grade 6")],
        name="geared_rotor_rms_dte", description="RMS DTE of geared_rotor at 4000 rpm")
    sob = gearuq.sobol_indices(wrapper, space, n_base=n_base, estimator="jansen", rng=11,
                               executor="serial", n_bootstrap=300)
    start = time.perf_counter()
    pce = gearuq.polynomial_chaos(wrapper, space, order="auto", method="sparse",
                                  n_samples=4 * n_base, rng=12, executor="serial")
    return sob, pce, time.perf_counter() - start


def figure(results: dict, pfs: dict, sob: xr.Dataset, pce_sob: xr.Dataset, limit: float
           ) -> Figure:
    """RMS DTE bands over speed, exceedance probabilities, Sobol' bars, phase scatter."""
    speeds = next(iter(results.values()))["speed"].values
    fig = Figure(figsize=(13, 8.5), layout="constrained")
    axs = fig.subplots(2, 2)
    ax = axs[0, 0]
    for (g, res), c in zip(results.items(), COLOURS, strict=True):
        q = np.nanpercentile(res["dte_rms"].values * 1e6, [5, 50, 95], axis=0)
        ax.fill_between(speeds, q[0], q[2], color=c, alpha=0.2)
        ax.plot(speeds, q[1], color=c, lw=1.5, label=f"ISO grade {g}: median, 5-95 %")
        qm = np.nanpercentile(res["dte_mesh_band_rms"].values * 1e6, [5, 50, 95], axis=0)
        ax.fill_between(speeds, qm[0], qm[2], color=c, alpha=0.12, hatch="//")
        ax.plot(speeds, qm[1], color=c, lw=1.2, ls="--",
                label=f"grade {g}: mesh band (orders >= f_m/2)")
    ax.axhline(limit * 1e6, color="k", ls="--", lw=1, label=f"limit {limit * 1e6:g} um")
    ax.set(xlabel="pinion speed [rpm]", ylabel="RMS DTE [um]",
           title="RMS DTE over speed (random pitch deviations, torque, bearings, damping)")
    ax.set_ylim(bottom=0)
    ax.legend(fontsize=6, ncols=2, loc="upper left")
    ax.set_ylim(0, 42)
    ax = axs[0, 1]
    for (g, pf), c in zip(pfs.items(), COLOURS, strict=True):
        ax.errorbar(speeds, pf["pf"], yerr=[pf["pf"] - pf["pf_lower"],
                    pf["pf_upper"] - pf["pf"]], color=c, marker="o", ms=3, capsize=2,
                    label=f"grade {g}")
    ax.set(xlabel="pinion speed [rpm]", ylabel="P(RMS DTE > limit) [1]",
           title="exceedance probability, Wilson 95 % intervals")
    ax.set_ylim(-0.02, 1.02)
    ax.legend(fontsize=7)
    ax = axs[1, 0]
    names = list(sob["parameter"].values)
    x = np.arange(len(names))
    st = sob["ST"].sel(output="dte_rms_um").values
    s1 = sob["S1"].sel(output="dte_rms_um").values
    err = [st - sob["ST_lower"].sel(output="dte_rms_um").values,
           sob["ST_upper"].sel(output="dte_rms_um").values - st]
    ax.bar(x - 0.2, s1, 0.2, color="tab:blue", label="first order (MC)")
    ax.bar(x, st, 0.2, yerr=err, capsize=3, color="tab:orange", label="total (MC, 95 %)")
    ax.bar(x + 0.2, pce_sob["ST"].values, 0.2, color="tab:green", label="total (PCE)")
    ax.set_xticks(x, [n_.replace("pitch_", "").replace("_", "\n") for n_ in names],
                  fontsize=7)
    ax.set(ylabel="Sobol' index [1]", title=f"what drives the RMS DTE at "
           f"{SOBOL_SPEED:g} rpm (grade 6)")
    ax.legend(fontsize=7)
    ax = axs[1, 1]
    res = results[6]
    j = int(np.argmin(np.abs(speeds - SOBOL_SPEED)))
    diff = np.array([phase_difference(s_) for s_ in res["pitch_seed"].values])
    sc = ax.scatter(diff, res["dte_rms"].values[:, j] * 1e6, s=12, c=res["torque"].values,
                    cmap="viridis")
    fig.colorbar(sc, ax=ax, label="torque [N m]")
    ax.set(xlabel="difference of the pinion and wheel sine phases [rad]",
           ylabel="RMS DTE [um]", title=f"grade 6, {SOBOL_SPEED:g} rpm: the realisation "
           "acts through the phase difference")
    return fig


def phase_difference(seed: float) -> float:
    """Pinion minus wheel sine phase of a realisation, in [0, 2 pi)."""
    from gearuq.gears.deviations import pitch_deviation_germ

    p1, _, p2, _ = pitch_deviation_germ(30, 30, int(seed))
    return float(np.mod(p1 - p2, 2.0 * math.pi))


@plot.quick_mode(
    lambda a: f"{a['n'] or 8} samples per grade at 6 speeds, Sobol' base {a['n_base'] or 8}",
    left_out=(
        "96 samples per grade at 16 speeds and a Sobol' base of 48: probabilities and indices"
        " are rough (first-order indices may exceed total ones)"))
def run(out: str | Path = "gearuq_geared_rotor_reliability", quick: bool = False,
        n: int | None = None, n_base: int | None = None, limit_um: float = 12.0) -> int:
    """How likely is Yuan, Liu and Liu's geared rotor to vibrate too much, per ISO 1328 grade?

    RMS DTE over speed for grades 5, 6 and 7 by Latin hypercube Monte Carlo, its exceedance
    probability with Wilson intervals, and Sobol' indices (Monte Carlo and PCE) at 4000 rpm.

    Parameters
    ----------
    out : path
        Output folder (created): ``rms_dte_grade{5,6,7}.nc``, ``exceedance.nc``,
        ``sobol_mc.nc``, ``reliability.png``.
    quick : bool
        8 samples per grade at 6 speeds and a Sobol' base of 8 (instead of 96 at 16 speeds
        and 48).
    n : int, optional
        Monte Carlo samples per grade (overrides ``quick``).
    n_base : int, optional
        Sobol' base sample size (overrides ``quick``).
    limit_um : float
        RMS DTE limit [um], > 0.

    Returns
    -------
    int
        0.
    """
    if limit_um <= 0:
        raise ValueError(f"limit_um={limit_um}: the RMS DTE limit must be > 0 um")
    n = n or (8 if quick else 96)
    n_base = n_base or (8 if quick else 48)
    speeds = QUICK_SPEEDS if quick else SPEEDS
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    model = gearuq.get_model("geared_rotor")
    space = random_inputs()
    limit = limit_um * 1e-6
    start = time.perf_counter()
    results = {g: rms_over_speed(model, space, g, n, seed=100 + g, speeds=speeds)
               for g in GRADES}
    t_mc = time.perf_counter() - start
    pfs = {g: exceedance(r, limit) for g, r in results.items()}
    start = time.perf_counter()
    sob, pce, t_pce = sensitivity(model, n_base)
    t_sens = time.perf_counter() - start
    pce_sob = pce.sobol("dte_rms_um")
    for g, r in results.items():
        gearuq.save(r.assign_attrs(gearuq_version=gearuq.__version__, grade=g),
                    out / f"rms_dte_grade{g}.nc")
    gearuq.save(xr.concat(list(pfs.values()), dim=xr.DataArray(list(GRADES), dims="grade"))
                .assign_attrs(gearuq_version=gearuq.__version__), out / "exceedance.nc")
    gearuq.save(sob, out / "sobol_mc.nc")
    save_figure(figure(results, pfs, sob, pce_sob, limit), out / "reliability.png")
    report(results, pfs, sob, pce, pce_sob, limit, t_mc, t_sens, t_pce, n)
    print(f"written: {out}")
    return 0


def main(argv: list[str] | None = None) -> int:
    """Command line: ``python -m gearuq_studies.geared_rotor_reliability``."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, default=Path("gearuq_geared_rotor_reliability"))
    ap.add_argument("--quick", action="store_true", help="8 samples per grade, 6 speeds")
    ap.add_argument("--n", type=int, default=None, help="Monte Carlo samples per grade (96)")
    ap.add_argument("--n-base", type=int, default=None, help="Sobol' base sample size (48)")
    ap.add_argument("--limit", type=float, default=12.0, help="RMS DTE limit [um]")
    args = ap.parse_args(argv)
    return run(args.out, quick=args.quick, n=args.n, n_base=args.n_base, limit_um=args.limit)


def report(results, pfs, sob, pce, pce_sob, limit, t_mc, t_sens, t_pce, n) -> None:
    """Print the summary."""
    speeds = results[GRADES[0]]["speed"].values
    print(f"geared_rotor reliability: {len(GRADES)} x {n} samples x {speeds.size} speeds in "
          f"{t_mc:.0f} s; Sobol' + PCE {t_sens:.0f} s (shared machine; provisional)")
    for g in GRADES:
        r = results[g]["dte_rms"].values * 1e6
        j = int(np.nanargmax(np.nanmedian(r, axis=0)))
        pf = pfs[g]
        k = int(np.argmax(pf["pf"].values))
        mb = results[g]["dte_mesh_band_rms"].values * 1e6
        print(f"grade {g}: median RMS DTE {np.nanmedian(r):.2f} um, mesh band "
              f"{np.nanmedian(mb):.2f} um (95 % quantile {np.nanpercentile(mb, 95):.2f}); "
              f"worst speed "
              f"{speeds[j]:g} rpm: {np.nanmedian(r[:, j]):.2f}); P(> {limit * 1e6:g} um) "
              f"max {pf['pf'].values[k]:.3f} [{pf['pf_lower'].values[k]:.3f}, "
              f"{pf['pf_upper'].values[k]:.3f}] at {speeds[k]:g} rpm; "
              f"{describe_status(results[g])}")
    names = list(sob["parameter"].values)
    st = sob["ST"].sel(output="dte_rms_um").values
    print("Sobol' total (MC, Jansen):", {str(n_): round(float(v), 3) for n_, v in
                                         zip(names, st, strict=True)})
    print("Sobol' total (PCE):", {str(n_): round(float(v), 3) for n_, v in
                                  zip(pce_sob["parameter"].values, pce_sob["ST"].values,
                                      strict=True)})
    loo = pce.loo_error.get("dte_rms_um", float("nan")) if hasattr(pce, "loo_error") else None
    print(f"PCE: fitted in {t_pce:.0f} s, leave-one-out relative error {loo}")
    rng = np.random.default_rng(5)
    x = sensitivity_space().sample(20000, rng=rng)
    y = np.asarray(pce.predict(x, "dte_rms_um")).ravel()
    j = int(np.argmin(np.abs(speeds - SOBOL_SPEED)))
    mc = results[6]["dte_rms"].values[:, j] * 1e6
    print(f"P(RMS DTE > {limit * 1e6:g} um) at {SOBOL_SPEED:g} rpm, grade 6: Monte Carlo "
          f"{np.mean(mc > limit * 1e6):.3f} ({mc.size} runs), PCE surrogate "
          f"{np.mean(y > limit * 1e6):.3f} (2e4 predictions)")


if __name__ == "__main__":
    raise SystemExit(main())
