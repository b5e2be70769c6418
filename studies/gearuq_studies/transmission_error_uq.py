"""Uncertainty of the transmission error of Yuan, Liu and Liu's pair under random pitch deviations.

Yuan et al. (2020) shows one realisation of random cumulative pitch deviations (sine 15 um + N(0,
3 um)
per gear). This study asks what the realisations do as a population, with the
``mesh_excitation`` plugin (one long-period LTCA per sample):

1. Relief maps at the design torque 1000 N m (Yuan et al. Fig. 14 extended): STE peak-to-peak of the
   error-free flank (Yuan et al.'s criterion) and the mesh-band RMS of the STE (content within
   +-0.5 mesh orders of mesh orders 1-3, sidebands included) averaged over pitch-deviation
   realisations. Optima of both.
2. Distributions over realisations of the STE peak-to-peak, the first mesh-order amplitude
   and its largest shaft-order sideband at 200, 350, 600 and 1000 N m, for the unmodified
   flank, the error-free optimum relief and the relief that is best on average.
3. Probability that the STE peak-to-peak exceeds a limit: the ISO 1328-1:2013 total cumulative
   pitch tolerance F_pT of flank tolerance class 7 of one Yuan, Liu and Liu's gear, in the normal
   direction (43.2 um), with Wilson intervals.
4. Sobol indices (Jansen, bootstrap intervals) of tip-relief amount, tip-relief length,
   torque and pitch scatter sigma, with the realisation as a fifth input ``pitch_seed``
   (uniform over 2^32 labels: each label is one draw of the random germ), so its indices
   measure the nuisance variance of the random field itself.

Run: ``gearuq study transmission_error_uq [--quick] [--out DIR]``, or
``python -m gearuq_studies.transmission_error_uq --full``. The default run takes about 3-5
minutes on 2 shared cores (24 positions per mesh cycle, 10 points per line, 100 realisations
per case, 9 x 9 relief grid x 12 realisations, Sobol base 256); ``--full`` uses 20 points per
line, 400 realisations, 13 x 13 x 40 and base 512 (about 15-25 minutes); ``--quick`` uses 12
positions per mesh cycle, 6 points per line, 20 realisations per case, a 4 x 4 relief grid x 3
realisations and Sobol base 64 (the indices' bootstrap intervals are then wide). Writes netCDF
+ PNG into the output folder and prints a summary.
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
from gearuq.gears.deviations import iso1328_pitch_tolerances
from gearuq.model import Output
from gearuq.plot import save_figure

TORQUES = (200.0, 350.0, 600.0, 1000.0)
DESIGN_TORQUE = 1000.0
COLOURS = {"unmodified": "tab:red", "error-free optimum": "tab:blue",
           "robust optimum": "tab:green"}


def settings(full: bool, quick: bool = False) -> dict:
    """Sample sizes and resolution of the default, the ``--full`` and the ``--quick`` run."""
    if quick:
        return {"opts": {"positions_per_cycle": 12, "n_pts": 6, "pitch_model": "seeded"},
                "n_real": 20, "grid": 4, "grid_real": 3, "n_base": 64}
    if full:
        return {"opts": {"positions_per_cycle": 24, "n_pts": 20, "pitch_model": "seeded"},
                "n_real": 400, "grid": 13, "grid_real": 40, "n_base": 512}
    return {"opts": {"positions_per_cycle": 24, "n_pts": 10, "pitch_model": "seeded"},
            "n_real": 100, "grid": 9,
            "grid_real": 12, "n_base": 256}


def ste_limit_um(pair) -> float:
    """ISO 1328-1:2013 F_pT of class 7 (reference diameter of gear 1), normal direction."""
    _, F_pT = iso1328_pitch_tolerances(pair.d1, pair.mn, 7)
    return F_pT * math.cos(pair.alpha_t) * math.cos(pair.beta_b) * 1e6


def mesh_band_rms(ste: np.ndarray, ppc: int, n_cycles: int, n_orders: int = 3) -> np.ndarray:
    """RMS of the STE content within +-0.5 mesh orders of mesh orders 1..n_orders [um].

    ``ste`` (n_samples, n_cycles * ppc) on the uniform long-period grid; Parseval over the
    bins ``k / n_cycles`` in ``[h - 0.5, h + 0.5)`` (one-sided amplitudes, RMS = A / sqrt 2).
    """
    spec = np.fft.rfft(ste, axis=-1)
    amp = 2.0 * np.abs(spec) / ste.shape[-1]
    freq = np.arange(amp.shape[-1]) / n_cycles
    band = (freq >= 0.5) & (freq < n_orders + 0.5)
    return np.sqrt(0.5 * (amp[:, band] ** 2).sum(axis=-1))


def run_cases(model, values: dict, opts: dict) -> xr.Dataset:
    """STE series on the long-period grid, STE peak-to-peak and labelled spectrum."""
    ppc = opts["positions_per_cycle"]
    n_cycles = model.pair.z1 * model.pair.z2 // math.gcd(model.pair.z1, model.pair.z2)
    t = np.arange(n_cycles * ppc) / ppc
    ds = model.response(values, t, outputs=["ste", "ste_ptp", "ste_spectrum",
                                            "contact_loss_fraction"], **opts)
    if int((ds["status"] != 0).sum()):
        raise RuntimeError(f"the LTCA failed where the study needs every realisation: "
                           f"{describe_status(ds)}")
    ds["mesh_band_rms"] = ("sample", mesh_band_rms(ds["ste"].values, ppc, n_cycles),
                           {"units": "um", "long_name": "STE RMS within +-0.5 mesh orders of "
                            "mesh orders 1-3"})
    return ds


def relief_maps(model, cfg: dict) -> xr.Dataset:
    """Error-free and realisation-averaged relief maps at the design torque."""
    pair = model.pair
    amounts = np.linspace(0.0, 60.0, cfg["grid"])
    lengths = np.linspace(2.0, 0.5 * pair.g_alpha * 1e3, cfg["grid"])
    A, L = np.meshgrid(amounts, lengths, indexing="ij")
    a, ell = A.ravel(), L.ravel()
    base = {"torque": np.full(a.size, DESIGN_TORQUE), "tip_relief_amount": a,
            "tip_relief_length": ell}
    clean = run_cases(model, {**base, "pitch_amplitude": np.zeros(a.size),
                              "pitch_sigma": np.zeros(a.size)}, cfg["opts"])
    n_r = cfg["grid_real"]
    seeds = np.arange(1, n_r + 1, dtype=float)
    noisy = run_cases(model, {k: np.repeat(v, n_r) for k, v in base.items()}
                      | {"pitch_seed": np.tile(seeds, a.size)}, cfg["opts"])
    shape = (amounts.size, lengths.size)
    rms = noisy["mesh_band_rms"].values.reshape(*shape, n_r)
    ptp = noisy["ste_ptp"].values.reshape(*shape, n_r)
    dims = ("amount", "length")
    return xr.Dataset(
        {"ste_ptp_error_free": (dims, clean["ste_ptp"].values.reshape(shape), {"units": "um"}),
         "mesh_band_rms_error_free": (dims, clean["mesh_band_rms"].values.reshape(shape),
                                      {"units": "um"}),
         "mesh_band_rms_mean": (dims, rms.mean(-1), {"units": "um", "long_name":
                                "mean over pitch-deviation realisations"}),
         "mesh_band_rms_std": (dims, rms.std(-1, ddof=1), {"units": "um"}),
         "ste_ptp_mean": (dims, ptp.mean(-1), {"units": "um"})},
        coords={"amount": ("amount", amounts, {"units": "um"}),
                "length": ("length", lengths, {"units": "mm"})},
        attrs={"torque_Nm": DESIGN_TORQUE, "n_realisations": n_r},
    )


def optimum(maps: xr.Dataset, var: str) -> tuple[float, float]:
    """(amount [um], length [mm]) minimising ``var``."""
    i, j = np.unravel_index(int(np.argmin(maps[var].values)), maps[var].shape)
    return float(maps["amount"][i]), float(maps["length"][j])


def distributions(model, flanks: dict, cfg: dict) -> xr.Dataset:
    """Per flank variant and torque: the same realisations (common random numbers)."""
    n_r = cfg["n_real"]
    seeds = np.arange(1001, 1001 + n_r, dtype=float)
    parts = []
    for amount, length in flanks.values():
        values = {"torque": np.repeat(TORQUES, n_r), "pitch_seed": np.tile(seeds, len(TORQUES)),
                  "tip_relief_amount": np.full(n_r * len(TORQUES), amount),
                  "tip_relief_length": np.full(n_r * len(TORQUES), length)}
        ds = run_cases(model, values, cfg["opts"]).drop_vars("ste")
        ds = ds.assign_coords(torque_case=("sample", np.repeat(TORQUES, n_r)),
                              realisation=("sample", np.tile(np.arange(n_r), len(TORQUES))))
        ds = ds.set_index(sample=["torque_case", "realisation"]).unstack("sample")
        parts.append(ds[["ste_ptp", "ste_spectrum", "mesh_band_rms", "contact_loss_fraction"]])
    out = xr.concat(parts, dim=xr.DataArray(list(flanks), dims="flank", name="flank"))
    out["relief_amount"] = ("flank", [v[0] for v in flanks.values()], {"units": "um"})
    out["relief_length"] = ("flank", [v[1] for v in flanks.values()], {"units": "mm"})
    return out


def exceedance(dist: xr.Dataset, limit: float) -> xr.Dataset:
    """P(STE peak-to-peak > limit) per flank and torque with Wilson 95 % intervals."""
    rows = []
    for flank in dist["flank"].values:
        for torque in TORQUES:
            sub = dist.sel(flank=flank, torque_case=torque)
            ds = xr.Dataset({"ste_ptp": ("sample", sub["ste_ptp"].values, {"units": "um"}),
                             "status": ("sample", np.zeros(sub.sizes["realisation"], np.int8))})
            rel = gearuq.reliability(ds, {"ste_ptp": (None, limit)}, system=False)
            r = rel.sel(mode=rel["mode"].values[0])
            rows.append((float(r["pf"]), float(r["pf_lower"]), float(r["pf_upper"])))
    arr = np.array(rows).reshape(dist.sizes["flank"], len(TORQUES), 3)
    dims = ("flank", "torque_case")
    return xr.Dataset({"pf": (dims, arr[..., 0]), "pf_lower": (dims, arr[..., 1]),
                       "pf_upper": (dims, arr[..., 2])},
                      coords={"flank": dist["flank"].values, "torque_case": list(TORQUES)},
                      attrs={"limit_um": limit, "interval": "Wilson 95 %"})


def sensitivity(model, cfg: dict) -> xr.Dataset:
    """Sobol indices with the realisation label as a fifth (nuisance) input."""
    opts = cfg["opts"]
    names = ("tip_relief_amount", "tip_relief_length", "torque", "pitch_sigma", "pitch_seed")

    def metrics(tip_relief_amount, tip_relief_length, torque, pitch_sigma, pitch_seed):
        ds = run_cases(model, {"tip_relief_amount": tip_relief_amount,
                               "tip_relief_length": tip_relief_length, "torque": torque,
                               "pitch_sigma": pitch_sigma, "pitch_seed": pitch_seed}, opts)
        first = ds["ste_spectrum"].sel(order=1.0).values
        return {"ste_ptp": ds["ste_ptp"].values, "ste_1fm": first,
                "mesh_band_rms": ds["mesh_band_rms"].values}

    params = [model.parameter(n) for n in names]
    wrapper = gearuq.FunctionModel(metrics, params, [
        Output("ste_ptp", "um", ("sample",), "STE peak-to-peak"),
        Output("ste_1fm", "um", ("sample",), "first mesh-order amplitude of the STE"),
        Output("mesh_band_rms", "um", ("sample",), "STE RMS in the mesh bands 1-3")],
        name="transmission_error_metrics", description="STE metrics of mesh_excitation")
    space = gearuq.ParameterSpace({
        "tip_relief_amount": {"dist": "uniform", "lower": 0.0, "upper": 60.0},
        "tip_relief_length": {"dist": "uniform", "lower": 2.0, "upper": 14.0},
        "torque": {"dist": "uniform", "lower": 200.0, "upper": 1000.0},
        "pitch_sigma": {"dist": "uniform", "lower": 1.0, "upper": 5.0},
        "pitch_seed": {"dist": "uniform", "lower": 0.0, "upper": 2.0**32 - 1.0},
    })
    return gearuq.sobol_indices(wrapper, space, n_base=cfg["n_base"], estimator="jansen",
                                rng=7, executor="serial", n_bootstrap=300)


# ------------------------------------------------------------------------------ figures
def plot_maps(maps: xr.Dataset, opt_clean, opt_ptp, opt_robust, out: Path) -> None:
    fig = Figure(figsize=(15, 4.4), layout="constrained")
    axs = fig.subplots(1, 3)
    panels = (("ste_ptp_error_free", "error-free STE peak-to-peak [um] (Yuan et al. Fig. 14)",
               opt_ptp),
              ("mesh_band_rms_error_free", "error-free mesh-band RMS [um]", opt_clean),
              ("mesh_band_rms_mean", "mean mesh-band RMS over realisations [um]", opt_robust))
    for ax, (var, title, opt) in zip(axs, panels, strict=True):
        cs = ax.contourf(maps["length"], maps["amount"], maps[var], levels=20, cmap="viridis")
        fig.colorbar(cs, ax=ax, label=title.split("[")[0].strip() + " [um]")
        ax.plot(opt[1], opt[0], marker="*", color="red", ms=16, ls="none", clip_on=False,
                label=f"optimum {opt[0]:.1f} um, {opt[1]:.1f} mm")
        ax.set(xlabel="tip relief length L [mm]", ylabel="tip relief amount e_max [um]",
               title=title)
        ax.legend(fontsize=8, loc="upper right")
    save_figure(fig, out / "relief_maps.png")


def plot_distributions(dist: xr.Dataset, limit: float, out: Path) -> None:
    fig = Figure(figsize=(14, 8), layout="constrained")
    axs = fig.subplots(2, 4)
    bins = np.linspace(float(dist["ste_ptp"].min()), float(dist["ste_ptp"].max()), 30)
    for j, torque in enumerate(TORQUES):
        ax = axs[0, j]
        for flank in dist["flank"].values:
            v = dist["ste_ptp"].sel(flank=flank, torque_case=torque).values
            ax.hist(v, bins=bins, histtype="step", lw=1.8, color=COLOURS[str(flank)],
                    label=str(flank))
        ax.axvline(limit, color="k", ls="--", label=f"limit {limit:.1f} um")
        ax.set(xlabel="STE peak-to-peak [um]", ylabel="realisations",
               title=f"{torque:g} N m")
        if j == 0:
            ax.legend(fontsize=7)
        ax = axs[1, j]
        spec = dist["ste_spectrum"].sel(torque_case=torque)
        labels = [str(s) for s in dist["order_label"].values]
        first = labels.index("1fm")
        side = [i for i, s in enumerate(labels) if s.startswith("1fm") and s != "1fm"]
        pos = np.arange(dist.sizes["flank"])
        a1 = [spec.sel(flank=f).isel(order=first).values for f in dist["flank"].values]
        sb = [spec.sel(flank=f).isel(order=side).max("order").values
              for f in dist["flank"].values]
        b1 = ax.boxplot(a1, positions=pos - 0.18, widths=0.3, patch_artist=True)
        b2 = ax.boxplot(sb, positions=pos + 0.18, widths=0.3, patch_artist=True)
        for box in b1["boxes"]:
            box.set(facecolor="tab:orange", alpha=0.7)
        for box in b2["boxes"]:
            box.set(facecolor="tab:purple", alpha=0.7)
        ax.set_xticks(pos, [str(f).replace(" optimum", "\noptimum")
                            for f in dist["flank"].values], fontsize=7)
        ax.set(ylabel="STE amplitude [um]", yscale="log",
               title=f"{torque:g} N m: 1 fm (orange), largest 1fm +-i fs (purple)")
        ax.title.set_fontsize(8)
    save_figure(fig, out / "ste_distributions.png")


def plot_sobol(sob: xr.Dataset, out: Path) -> None:
    fig = Figure(figsize=(13, 4), layout="constrained")
    axs = fig.subplots(1, sob.sizes["output"])
    names = [str(p) for p in sob["parameter"].values]
    x = np.arange(len(names))
    for ax, o in zip(axs, sob["output"].values, strict=True):
        s = sob.sel(output=o)
        ax.bar(x - 0.2, s["S1"], 0.4, yerr=s["S1_conf"], color="tab:blue", label="S1")
        ax.bar(x + 0.2, s["ST"], 0.4, yerr=s["ST_conf"], color="tab:orange", label="ST")
        ax.set_xticks(x, [n.replace("_", "\n") for n in names], fontsize=7)
        ax.set(ylabel="Sobol index [-]", title=str(o), ylim=(-0.1, 1.1))
        ax.axhline(0, color="k", lw=0.5)
    axs[0].legend()
    save_figure(fig, out / "sobol_indices.png")


def plot_spectrum(dist: xr.Dataset, out: Path, torque: float = 600.0) -> None:
    fig = Figure(figsize=(10, 4), layout="constrained")
    ax = fig.subplots()
    order = dist["order"].values
    for k, flank in enumerate(dist["flank"].values):
        s = dist["ste_spectrum"].sel(flank=flank, torque_case=torque)
        med = np.maximum(s.median("realisation").values, 1e-4)
        ax.semilogy(order + 0.006 * (k - 1), med, "o", color=COLOURS[str(flank)],
                    label=f"{flank} (median)")
        lo, hi = s.quantile([0.05, 0.95], "realisation").values
        ax.vlines(order + 0.006 * (k - 1), np.maximum(lo, 1e-4), np.maximum(hi, 1e-4),
                  color=COLOURS[str(flank)], lw=1)
    ax.set(xlabel="frequency [mesh orders]", ylabel="STE amplitude [um] (5-95 %, floor 1e-4)",
           title=f"STE spectrum at {torque:g} N m over pitch-deviation realisations")
    ax.legend(fontsize=8)
    save_figure(fig, out / "ste_spectrum.png")


@plot.quick_mode(
    "20 realisations per case, Sobol' base 64",
    left_out=(
        "400 realisations, a 13 x 13 relief grid x 40 and Sobol' base 512 on a coarse LTCA: "
        "the indices' intervals are wide and S1 may be negative"))
def run(out: str | Path = "gearuq_transmission_error_uq", quick: bool = False,
        full: bool = False) -> int:
    """Transmission-error uncertainty of Yuan, Liu and Liu's pair under random pitch deviations.

    Relief maps averaged over realisations, STE distributions and exceedance probabilities
    at four torques, and Sobol' indices with the realisation as a nuisance input.

    Parameters
    ----------
    out : path
        Output folder (created): ``relief_maps.nc``, ``ste_distributions.nc``,
        ``ste_exceedance.nc``, ``sobol_indices.nc`` and four PNG figures.
    quick : bool
        12 positions per mesh cycle, 6 points per line, 20 realisations per case, a 4 x 4
        relief grid x 3 realisations, Sobol' base 64.
    full : bool
        20 points per line, 400 realisations, 13 x 13 x 40, Sobol' base 512.

    Returns
    -------
    int
        0.
    """
    if quick and full:
        raise ValueError("quick=True and full=True: choose one")
    t_start = time.perf_counter()
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    cfg = settings(full, quick)
    model = gearuq.get_model("mesh_excitation")
    limit = ste_limit_um(model.pair)

    t0 = time.perf_counter()
    maps = relief_maps(model, cfg)
    t_maps = time.perf_counter() - t0
    opt_ptp = optimum(maps, "ste_ptp_error_free")
    opt_clean = optimum(maps, "mesh_band_rms_error_free")
    opt_robust = optimum(maps, "mesh_band_rms_mean")
    gearuq.save(maps, out / "relief_maps.nc")
    plot_maps(maps, opt_clean, opt_ptp, opt_robust, out)

    flanks = {"unmodified": (0.0, 0.0), "error-free optimum": opt_ptp,
              "robust optimum": opt_robust}
    t0 = time.perf_counter()
    dist = distributions(model, flanks, cfg)
    t_dist = time.perf_counter() - t0
    exc = exceedance(dist, limit)
    gearuq.save(dist, out / "ste_distributions.nc")
    gearuq.save(exc, out / "ste_exceedance.nc")
    plot_distributions(dist, limit, out)
    plot_spectrum(dist, out)

    t0 = time.perf_counter()
    sob = sensitivity(model, cfg)
    t_sob = time.perf_counter() - t0
    gearuq.save(sob, out / "sobol_indices.nc")
    plot_sobol(sob, out)
    summary(maps, opt_ptp, opt_clean, opt_robust, dist, exc, sob, limit, cfg,
            (t_maps, t_dist, t_sob, time.perf_counter() - t_start))
    print(f"written: {out}")
    return 0


def summary(maps, opt_ptp, opt_clean, opt_robust, dist, exc, sob, limit, cfg, times) -> None:
    """Print the numbers the theory page quotes."""
    t_maps, t_dist, t_sob, total = times
    print(f"settings: {cfg}")

    def at(var, opt):
        return float(maps[var].sel(amount=opt[0], length=opt[1]))

    for name, opt in (("error-free STE ptp optimum", opt_ptp),
                      ("error-free mesh-band optimum", opt_clean),
                      ("robust (mean mesh-band) optimum", opt_robust)):
        print(f"{name:32s}: e_max {opt[0]:5.1f} um, L {opt[1]:5.2f} mm | error-free ptp "
              f"{at('ste_ptp_error_free', opt):6.3f} um, error-free band RMS "
              f"{at('mesh_band_rms_error_free', opt):6.3f} um, mean band RMS "
              f"{at('mesh_band_rms_mean', opt):6.3f} um")
    print(f"unmodified at {DESIGN_TORQUE:g} N m: error-free ptp "
          f"{float(maps['ste_ptp_error_free'][0, 0]):.3f} um, mean band RMS "
          f"{float(maps['mesh_band_rms_mean'][0, 0]):.3f} um")
    labels = [str(s) for s in dist["order_label"].values]
    side = [i for i, s in enumerate(labels) if s.startswith("1fm") and s != "1fm"]
    print(f"STE peak-to-peak limit {limit:.1f} um (ISO 1328 F_pT class 7, normal direction)")
    for flank in dist["flank"].values:
        for torque in TORQUES:
            d = dist.sel(flank=flank, torque_case=torque)
            a1 = d["ste_spectrum"].isel(order=labels.index("1fm")).values
            sb = d["ste_spectrum"].isel(order=side).max("order").values
            e = exc.sel(flank=flank, torque_case=torque)
            print(f"{str(flank):19s} {torque:6g} N m: ptp median {np.median(d['ste_ptp']):6.2f}"
                  f" (5-95 % {np.percentile(d['ste_ptp'], 5):6.2f}-"
                  f"{np.percentile(d['ste_ptp'], 95):6.2f}) um, 1fm median {np.median(a1):6.3f}"
                  f" um, largest 1fm sideband median {np.median(sb):6.3f} um, mesh-band RMS "
                  f"median {float(d['mesh_band_rms'].median()):6.3f} um, P(ptp > limit) "
                  f"{float(e['pf']):.3f} [{float(e['pf_lower']):.3f}, "
                  f"{float(e['pf_upper']):.3f}], positions with contact loss "
                  f"{float(d['contact_loss_fraction'].mean()):.3f}")
    for o in sob["output"].values:
        s = sob.sel(output=o)
        txt = ", ".join(f"{p}: S1 {float(s['S1'].sel(parameter=p)):.3f}+-"
                        f"{float(s['S1_conf'].sel(parameter=p)):.3f} ST "
                        f"{float(s['ST'].sel(parameter=p)):.3f}"
                        for p in s["parameter"].values)
        print(f"Sobol {o}: {txt}")
    print(f"times: relief maps {t_maps:.1f} s, distributions {t_dist:.1f} s, Sobol "
          f"{t_sob:.1f} s ({sob.attrs['n_model_evaluations']} runs), total {total:.1f} s")


def main(argv: list[str] | None = None) -> int:
    """Command line: ``python -m gearuq_studies.transmission_error_uq``."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, default=Path("gearuq_transmission_error_uq"))
    ap.add_argument("--quick", action="store_true", help="coarse LTCA, few realisations")
    ap.add_argument("--full", action="store_true", help="larger samples, 20 points per line")
    args = ap.parse_args(argv)
    return run(args.out, quick=args.quick, full=args.full)


if __name__ == "__main__":
    raise SystemExit(main())
