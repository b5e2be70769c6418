"""Yuan et al. (2020) Figs. 8, 9, 10, 14 analogs: LTCA of the 30/30 helical pair with random
pitch errors.

- Fig. 8: random cumulative pitch deviations (sine 15 um + N(0, 3 um)) and pitch deviations
  of pinion and wheel.
- Fig. 9: LPMS (secant and tangent), STE and CMS over the long period (30 mesh cycles) at
  200, 350, 600, 1000 N m.
- Fig. 10: load distribution on the plane of action in the twelfth mesh cycle and in the
  cycle with the largest contact loss.
- Face-load picture: lines of contact coloured by line load at one position, unloaded parts
  marked, and the line load along the face (error-free, with pitch errors, with tip relief).
- Fig. 14: STE peak-to-peak over a 20 x 20 grid of symmetric tip-relief amount and length
  (perfect gears, 1000 N m), optimum marked.
- LTCA mean mesh stiffness over ISO 6336-1 method B for tooth numbers 17-120, shifts and
  basic racks A and D, before and after the root-circle correction.
- Sensitivity of the STE and mesh stiffness to the face-width coupling length.
- Both readings of Yuan et al.'s "amplitude 15 um" (sine amplitude, largest deviation).

Run: ``gearuq study pitch_deviation_excitation [--quick] [--out DIR]`` (about a minute), or
``python -m gearuq_studies.pitch_deviation_excitation --seed N`` for another realisation.
Writes netCDF + PNG into the output folder and prints a summary. ``--quick`` runs the LTCA
with 12 positions per mesh cycle and 10 points per line (24 x 20 otherwise), the tip-relief
map on 8 x 8 instead of 21 x 20, the ISO chart at 5 tooth numbers instead of 12 and the
coupling-length sensitivity at 4 lengths instead of 8.
"""

from __future__ import annotations

import argparse
import math
import time
import warnings
from pathlib import Path

import numpy as np
import xarray as xr
from matplotlib.collections import LineCollection
from matplotlib.colors import Normalize
from matplotlib.figure import Figure

import gearuq
from gearuq import plot
from gearuq.gears.compliance import ComplianceModel
from gearuq.gears.deviations import (
    FlankDeviations,
    pitch_deviations_from_cumulative,
    random_cumulative_pitch_deviations,
)
from gearuq.gears.face_coupling import plate_coupling_length
from gearuq.gears.geometry import HelicalGearPair, seed002_pair
from gearuq.gears.iso6336 import mesh_stiffness
from gearuq.gears.ltca import ltca, tip_relief_map
from gearuq.plot import save_figure

TORQUES = (200.0, 350.0, 600.0, 1000.0)
COLOURS = ("tab:blue", "tab:orange", "tab:green", "tab:red")


def realisation(pair: HelicalGearPair, seed: int,
                reading: str = "sine") -> tuple[np.ndarray, np.ndarray]:
    """Pinion and wheel cumulative pitch deviations of Yuan et al.'s random model [m]."""
    rng = np.random.default_rng(seed)
    return (random_cumulative_pitch_deviations(pair.z1, seed=rng, amplitude_reading=reading),
            random_cumulative_pitch_deviations(pair.z2, seed=rng, amplitude_reading=reading))


def fig08(pair, Fp1, Fp2, out: Path) -> None:
    fig = Figure(figsize=(9, 3.5), layout="constrained")
    axs = fig.subplots(1, 2)
    k = np.arange(pair.z1)
    for ax, Fp, name in zip(axs, (Fp1, Fp2), ("pinion", "wheel"), strict=True):
        ax.plot(k, Fp * 1e6, "o-", color="tab:blue", label="cumulative $F_{p,k}$")
        ax.bar(k, pitch_deviations_from_cumulative(Fp) * 1e6, alpha=0.5, color="tab:orange",
               label="pitch $f_{pt,k}$")
        ax.set(xlabel="tooth number k [-]", ylabel="deviation [um]", title=name)
        ax.legend(fontsize=8)
    save_figure(fig, out / "fig08_pitch_deviations.png")


def fig09(runs: list[xr.Dataset], out: Path) -> None:
    fig = Figure(figsize=(10, 10), layout="constrained")
    axs = fig.subplots(4, 1, sharex=True)
    for r, T, c in zip(runs, TORQUES, COLOURS, strict=True):
        axs[0].plot(r["tau"], r["lpms"], lw=0.8, color=c, label=f"{T:g} N m")
        axs[1].plot(r["tau"], r["lpms_tangent"], lw=0.8, color=c)
        axs[2].plot(r["tau"], r["ste"], lw=0.8, color=c)
        axs[3].plot(r["tau"], r["cms"], lw=0.8, color=c)
    # two lines: one line of the secant label is longer than its panel is tall (it was clipped)
    for ax, lab in zip(axs, ("LPMS secant [N/um]\n(Yuan et al. Eq. 4)", "LPMS tangent [N/um]",
                             "STE (normal) [um]", "CMS [um]"), strict=True):
        ax.set_ylabel(lab)
    axs[3].set_xlabel("mesh position [mesh cycles]")
    axs[0].legend(ncol=4, fontsize=8)
    save_figure(fig, out / "fig09_lpms_ste_cms.png")


def fig10(runs: list[xr.Dataset], out: Path) -> int:
    """Load distribution in the twelfth and in the worst cycle at 350 N m; returns the worst."""
    loss350 = runs[1]["contact_loss_fraction"].groupby("mesh_cycle").max().values
    worst = int(np.argmax(loss350))
    fig = Figure(figsize=(16, 7), layout="constrained")
    axs = fig.subplots(2, 4, sharex=True, sharey=True)
    qmax = max(float(r["line_load"].max()) for r in runs)
    for row, cyc in enumerate((11, worst)):
        for ax, r, T in zip(axs[row], runs, TORQUES, strict=True):
            c = r.where(r["mesh_cycle"] == cyc, drop=True)
            s, y, q = (c[v].values.ravel() for v in ("s", "y", "line_load"))
            ok = np.isfinite(s)
            on = ok & (q > 0)
            sc = ax.scatter(s[on], y[on], c=q[on], s=4, cmap="viridis", vmin=0, vmax=qmax)
            ax.scatter(s[ok & ~on], y[ok & ~on], c="red", s=6, marker="x", label="no contact")
            ax.set_title(f"{T:g} N m, mesh cycle {cyc + 1}", fontsize=9)
            ax.set(xlabel="s from T1 [mm]", ylabel="face width y [mm]")
            if (~on & ok).any():
                ax.legend(fontsize=7, loc="upper right")
    fig.colorbar(sc, ax=axs, label="line load [N/mm]")
    save_figure(fig, out / "fig10_load_distribution.png")
    return worst


def face_load(pair, comp, dev, out: Path, tau: float, n_pts: int = 40) -> dict[str, float]:
    """Face-load picture at one position: three flanks, lines coloured by line load."""
    cases = (("error-free, 1000 N m", 1000.0, None),
             ("pitch deviations, 350 N m", 350.0, dev),
             ("tip relief 20 um / 10 mm + pitch dev., 350 N m", 350.0,
              FlankDeviations(Fp1=dev.Fp1, Fp2=dev.Fp2, tip_relief1=(20e-6, 10e-3),
                              tip_relief2=(20e-6, 10e-3))))
    runs = [ltca(pair, torque=T, deviations=d, compliance=comp, tau=[tau], n_pts=n_pts)
            for _, T, d in cases]
    qmax = max(float(r["line_load"].max()) for r in runs)
    norm = Normalize(0.0, qmax)
    fig = Figure(figsize=(15, 8), layout="constrained")
    axs = fig.subplots(2, 3)
    kin = runs[0].attrs
    info = {}
    for j, ((title, _, _), r) in enumerate(zip(cases, runs, strict=True)):
        ax, ax2 = axs[0, j], axs[1, j]
        ax.add_patch(_zone(kin))
        for ln in range(r.sizes["line"]):
            if not bool(r["valid"].values[0, ln]):
                continue
            s, y = r["s"].values[0, ln], r["y"].values[0, ln]
            q = r["line_load"].values[0, ln]
            pts = np.column_stack([s, y])
            segs = np.stack([pts[:-1], pts[1:]], axis=1)
            lc = LineCollection(segs, cmap="viridis", norm=norm, linewidths=7)
            lc.set_array(0.5 * (q[:-1] + q[1:]))
            ax.add_collection(lc)
            off = q <= 0
            ax.plot(s[off], y[off], "x", color="red", ms=5)
            lab = (f"pair {int(r['pinion_tooth'].values[0, ln])}/"
                   f"{int(r['wheel_tooth'].values[0, ln])}")
            ax.annotate(lab, (s[0], y[0]), fontsize=7, xytext=(3, -10),
                        textcoords="offset points")
            ax2.plot(y, q, "o-", ms=3, label=lab)
        ax.set(xlim=(kin["s_A_m"] * 1e3 - 2, kin["s_E_m"] * 1e3 + 2),
               ylim=(-2, kin["face_width_m"] * 1e3 + 2), xlabel="s along the line of action [mm]",
               ylabel="face width y [mm]",
               title=f"{title}\nSTE {float(r['ste'][0]):.2f} um, unloaded share "
                     f"{float(r['contact_loss_fraction'][0]):.2f}")
        ax.title.set_fontsize(9)
        ax2.set(xlabel="face width y [mm]", ylabel="line load [N/mm]", ylim=(0, 1.05 * qmax))
        ax2.legend(fontsize=7)
        info[title] = float(r["line_load"].max())
    fig.colorbar(axs[0, 0].collections[0], ax=axs[0, :], label="line load [N/mm] "
                 "(red x: no contact)")
    save_figure(fig, out / "face_load_one_position.png")
    return info


def _zone(kin: dict):
    from matplotlib.patches import Rectangle

    return Rectangle((kin["s_A_m"] * 1e3, 0.0), (kin["s_E_m"] - kin["s_A_m"]) * 1e3,
                     kin["face_width_m"] * 1e3, fill=False, ls="--", color="grey")


def iso_chart(out: Path, quick: bool = False) -> xr.Dataset:
    """LTCA / ISO 6336-1 mean mesh stiffness over tooth numbers, shifts and racks."""
    zs = np.array([17, 30, 50, 75, 120] if quick else
                  [17, 21, 25, 30, 35, 42, 50, 60, 75, 90, 105, 120])
    variants = {"rack A, x = 0": (1.25, 0.38, 0.0), "rack A, x = +0.5": (1.25, 0.38, 0.5),
                "rack A, x = -0.3": (1.25, 0.38, -0.3), "rack D, x = 0": (1.4, 0.39, 0.0)}
    ratio = np.full((len(variants) + 1, zs.size), np.nan)
    for i, (hf, rho, x) in enumerate(list(variants.values()) + [(1.25, 0.38, 0.0)]):
        legacy = i == len(variants)
        for j, z in enumerate(zs):
            try:
                pair = HelicalGearPair(mn=4e-3, z1=int(z), z2=int(z), alpha_n=20 * math.pi / 180,
                                       beta=15 * math.pi / 180, b1=0.04, b2=0.04, x1=x, x2=x,
                                       hf_star=hf, rho_f_star=rho)
            except ValueError:
                continue
            opts = {"beam_root": "base_circle", "coupling_length": pair.mn} if legacy else {}
            comp = ComplianceModel(pair, **opts)
            P = 300.0 * pair.face_width * 1e3 / math.cos(pair.beta_b)
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", UserWarning)
                iso = mesh_stiffness(pair).k_mesh_N_per_m
            r = ltca(pair, normal_force=P, compliance=comp, n_cycles=1, positions_per_cycle=12,
                     n_pts=12, keep_points=False)
            ratio[i, j] = float(r["lpms"].mean()) * math.cos(pair.beta_b) ** 2 * 1e6 / iso
    names = [*variants, "version 1 (beam from the base circle, lam = 1 mn), rack A, x = 0"]
    ds = xr.Dataset({"ratio": (("variant", "z"), ratio, {
        "units": "1", "long_name": "LTCA mean mesh stiffness / ISO 6336-1 c_gamma_alpha b"})},
        coords={"variant": names, "z": zs})
    fig = Figure(figsize=(8, 4.5), layout="constrained")
    ax = fig.subplots()
    styles = ("o-", "s-", "^-", "d-", "x--")
    for k, (name, st) in enumerate(zip(names, styles, strict=True)):
        ax.plot(zs, ratio[k], st, color=("tab:blue", "tab:green", "tab:purple", "tab:orange",
                                         "grey")[k], label=name)
    ax.axhspan(0.75, 1.25, color="tab:blue", alpha=0.08, label="accepted band 0.75-1.25")
    ax.axhline(1.0, color="k", lw=0.6)
    ax.set(xlabel="number of teeth z (= z1 = z2) [-]", ylabel="LTCA / ISO 6336-1 [-]",
           title="mean mesh stiffness, m_n 4 mm, beta 15 deg, b 40 mm, 300 N/mm", ylim=(0.4, 1.3))
    ax.legend(fontsize=7, loc="lower left")
    save_figure(fig, out / "ltca_vs_iso_stiffness.png")
    return ds


def coupling_sensitivity(pair, dev, out: Path, grid: dict | None = None) -> xr.Dataset:
    """Mean mesh stiffness and STE peak-to-peak against the coupling length."""
    grid = grid or {}
    lam_plate = plate_coupling_length(pair)
    lams = np.array([0.0, 1.0, lam_plate / pair.mn, 3.0] if grid else
                    [0.0, 0.5, 1.0, 1.5, lam_plate / pair.mn, 2.0, 2.5, 3.0])
    rows = []
    for lam in lams:
        comp = ComplianceModel(pair, coupling_length=lam * pair.mn)
        perfect = ltca(pair, torque=1000.0, compliance=comp, n_cycles=1, keep_points=False,
                       **grid)
        rough = ltca(pair, torque=600.0, deviations=dev, compliance=comp, keep_points=False,
                     **grid)
        rows.append((float(perfect["lpms"].mean()), float(np.ptp(perfect["ste"].values)),
                     float(perfect["lpms_tangent"].mean()), float(np.ptp(rough["ste"].values))))
    rows = np.array(rows)
    ds = xr.Dataset({
        "lpms_mean": ("lam", rows[:, 0], {"units": "N/um"}),
        "ste_ptp_error_free": ("lam", rows[:, 1], {"units": "um"}),
        "lpms_tangent_mean": ("lam", rows[:, 2], {"units": "N/um"}),
        "ste_ptp_pitch_600": ("lam", rows[:, 3], {"units": "um"})},
        coords={"lam": ("lam", lams, {"units": "mn", "long_name": "coupling length / m_n"})},
        attrs={"plate_coupling_length_mn": lam_plate / pair.mn})
    fig = Figure(figsize=(10, 4), layout="constrained")
    ax1, ax2 = fig.subplots(1, 2)
    ax1.plot(lams, rows[:, 1], "o-", color="tab:blue", label="error-free, 1000 N m")
    ax1.set(xlabel="coupling length lam / m_n [-]", ylabel="STE peak-to-peak [um]")
    ax1b = ax1.twinx()
    ax1b.plot(lams, rows[:, 3], "s--", color="tab:red", label="pitch deviations, 600 N m")
    ax1b.set_ylabel("STE peak-to-peak with pitch deviations [um]", color="tab:red")
    ax1.legend(loc="lower left", fontsize=8)
    ax1b.legend(loc="center left", fontsize=8)
    ax2.plot(lams, rows[:, 0], "o-", color="tab:green", label="secant (Yuan et al. Eq. 4)")
    ax2.plot(lams, rows[:, 2], "s-", color="tab:purple", label="tangent")
    ax2.set(xlabel="coupling length lam / m_n [-]", ylabel="mean mesh stiffness [N/um]")
    ax2.legend(fontsize=8)
    for ax in (ax1, ax2):
        ax.axvline(lam_plate / pair.mn, color="k", ls=":", lw=1)
    ax1.set_title(f"plate calibration lam = {lam_plate / pair.mn:.2f} m_n (dotted)")
    save_figure(fig, out / "coupling_length_sensitivity.png")
    return ds


def fig14(pair, comp, out: Path, torque: float = 1000.0, quick: bool = False) -> xr.Dataset:
    """STE peak-to-peak over symmetric tip-relief amount and length, optimum marked."""
    amounts = np.linspace(0.0, 60e-6, 8 if quick else 21)
    lengths = np.linspace(0.5e-3, 0.5 * pair.g_alpha, 8 if quick else 20)
    rmap = tip_relief_map(pair, amounts, lengths, torque=torque, compliance=comp,
                          positions_per_cycle=12 if quick else 24, n_cycles=1)
    fig = Figure(figsize=(6, 4.5), layout="constrained")
    ax = fig.subplots()
    cs = ax.contourf(rmap["length"], rmap["amount"], rmap["ste_ptp"], levels=20, cmap="viridis")
    ax.contour(rmap["length"], rmap["amount"], rmap["ste_ptp"], levels=[0.5], colors="w")
    fig.colorbar(cs, ax=ax, label="STE peak-to-peak [um]")
    ax.plot(rmap.attrs["optimum_length_mm"], rmap.attrs["optimum_amount_um"], "r*", ms=14)
    ax.set(xlabel="relief length L [mm]", ylabel="relief amount e_max [um]",
           title=f"symmetric tip relief, {torque:g} N m (white: 0.5 um)")
    save_figure(fig, out / "fig14_tip_relief_map.png")
    return rmap


def readings(pair, comp, seed: int, grid: dict | None = None) -> dict[str, list]:
    """The long period at Yuan et al.'s torques for both readings of the 15 um amplitude."""
    grid = grid or {}
    res = {}
    for reading in ("sine", "largest"):
        Fp1, Fp2 = realisation(pair, seed, reading)
        dev = FlankDeviations(Fp1=Fp1, Fp2=Fp2)
        rows = []
        for T in TORQUES:
            r = ltca(pair, torque=T, deviations=dev, compliance=comp, keep_points=False, **grid)
            cyc = r["partial_contact_loss"].groupby("mesh_cycle").any().values
            rows.append((T, float(np.ptp(r["ste"].values)), float(r["lpms"].mean()),
                         int(cyc.sum()), float(np.abs(Fp1).max() * 1e6),
                         float(np.abs(Fp2).max() * 1e6)))
        res[reading] = rows
    return res


@plot.quick_mode(
    "LTCA at 12 positions x 10 points per mesh cycle",
    left_out=(
        "the 24 x 20 LTCA, the tip-relief map on 21 x 20 (8 x 8 here), the ISO chart at 12 "
        "tooth numbers (5) and the coupling length at 8 values (4)"))
def run(out: str | Path = "gearuq_pitch_deviation_excitation", quick: bool = False,
        seed: int = 2020) -> int:
    """LTCA of Yuan, Liu and Liu's helical pair with random pitch deviations (Figs. 8-10, 14).

    LPMS, STE and CMS over the long period at four torques, load distribution, tip-relief
    map, LTCA against ISO 6336-1 stiffness and the coupling-length sensitivity.

    Parameters
    ----------
    out : path
        Output folder (created): ``ltca_long_period.nc``, ``tip_relief_map.nc``,
        ``ltca_vs_iso.nc``, ``coupling_length_sensitivity.nc`` and the PNG figures.
    quick : bool
        LTCA with 12 positions per mesh cycle and 10 points per line, an 8 x 8 relief map,
        5 tooth numbers and 4 coupling lengths.
    seed : int
        Seed of the pitch-deviation realisation (2020 as in the rotor studies).

    Returns
    -------
    int
        0.
    """
    t_start = time.perf_counter()
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    grid = {"positions_per_cycle": 12, "n_pts": 10} if quick else {}
    pair = seed002_pair()
    comp = ComplianceModel(pair)
    Fp1, Fp2 = realisation(pair, seed)
    dev = FlankDeviations(Fp1=Fp1, Fp2=Fp2)
    fig08(pair, Fp1, Fp2, out)
    t0 = time.perf_counter()
    runs = [ltca(pair, torque=T, deviations=dev, compliance=comp,
                 **({"positions_per_cycle": 24, "n_pts": 20} | grid)) for T in TORQUES]
    t_run = (time.perf_counter() - t0) / len(TORQUES)
    res = xr.concat(runs, dim="torque", combine_attrs="drop_conflicts")
    res = res.assign_coords(torque=("torque", np.array(TORQUES), {"units": "N m"}))
    res["Fp1"] = ("pinion_tooth_number", Fp1 * 1e6, {"units": "um"})
    res["Fp2"] = ("wheel_tooth_number", Fp2 * 1e6, {"units": "um"})
    gearuq.save(res, out / "ltca_long_period.nc")
    fig09(runs, out)
    worst = fig10(runs, out)
    loss = runs[1]["contact_loss_fraction"].values
    tau_face = float(runs[1]["tau"][int(np.argmax(loss))])
    peak_loads = face_load(pair, comp, dev, out, tau_face, n_pts=20 if quick else 40)
    t0 = time.perf_counter()
    rmap = fig14(pair, comp, out, quick=quick)
    t_map = time.perf_counter() - t0
    gearuq.save(rmap, out / "tip_relief_map.nc")
    iso = iso_chart(out, quick)
    gearuq.save(iso, out / "ltca_vs_iso.nc")
    sens = coupling_sensitivity(pair, dev, out, grid)
    gearuq.save(sens, out / "coupling_length_sensitivity.nc")
    both = readings(pair, comp, seed, grid)
    summary(pair, comp, runs, rmap, iso, sens, both, worst, tau_face, peak_loads,
            (t_run, t_map, time.perf_counter() - t_start), grid)
    print(f"written: {out}")
    return 0


def summary(pair, comp, runs, rmap, iso, sens, both, worst, tau_face, peak_loads,
            times, res: dict | None = None) -> None:
    """Print the numbers quoted in docs/theory/ltca.md."""
    res = res or {}
    t_run, t_map, total = times
    iso_k = mesh_stiffness(pair)
    perfect = ltca(pair, torque=1000.0, compliance=comp, **res)
    km = float(perfect["lpms"].mean())
    cb2 = math.cos(pair.beta_b) ** 2
    print(f"Yuan et al.'s pair: eps_alpha {pair.eps_alpha:.4f}, eps_beta {pair.eps_beta:.4f}; "
          f"coupling length {comp.coupling_length * 1e3:.2f} mm "
          f"({comp.coupling_length / pair.mn:.2f} mn); LTCA {t_run:.2f} s per load "
          f"({30 * res.get('positions_per_cycle', 24)} positions x "
          f"{res.get('n_pts', 20)} points)")
    print(f"perfect gears, 1000 N m: mean LPMS {km:.1f} N/um secant, "
          f"{float(perfect['lpms_tangent'].mean()):.1f} N/um tangent (normal), "
          f"{km * cb2:.1f} N/um (transverse); ISO 6336-1 c_gamma_alpha b = "
          f"{iso_k.k_mesh_N_per_m * 1e-6:.1f} N/um; ratio "
          f"{km * cb2 / (iso_k.k_mesh_N_per_m * 1e-6):.3f}; "
          f"STE ptp {float(np.ptp(perfect['ste'].values)):.3f} um")
    cms_ref = runs[-1]["cms"].values
    for r, T in zip(runs, TORQUES, strict=True):
        cyc = r["partial_contact_loss"].groupby("mesh_cycle").any().values
        geo = (r["geometric_loss_fraction"] > 0.05).groupby("mesh_cycle").any().values
        km_cyc = r["lpms"].groupby("mesh_cycle").mean().values
        print(f"T = {T:6g} N m: cycles with partial contact loss {int(cyc.sum()):2d}/30 "
              f"(geometric measure {int(geo.sum()):2d}), LPMS mean "
              f"{float(r['lpms'].mean()):6.1f} (min cycle {km_cyc.min():6.1f}), tangent/secant "
              f"{float((r['lpms_tangent'] / r['lpms']).mean()):.4f}, STE mean "
              f"{float(r['ste'].mean()):6.2f} ptp {float(np.ptp(r['ste'].values)):5.2f} um, "
              f"max|CMS - CMS(1000)| {np.abs(r['cms'].values - cms_ref).max():5.3f} um, "
              f"max residual {float(r['complementarity_residual'].max()):.1e}")
    print(f"Fig. 10 worst cycle at 350 N m: {worst + 1}; face-load position tau = {tau_face:.3f}; "
          f"peak line loads {peak_loads}")
    print(f"tip-relief map 20x20 in {t_map:.1f} s: optimum e_max "
          f"{rmap.attrs['optimum_amount_um']:.1f} um, L {rmap.attrs['optimum_length_mm']:.2f} mm,"
          f" STE ptp {rmap.attrs['optimum_ste_ptp_um']:.3f} um (unmodified "
          f"{float(rmap['ste_ptp'][0].min()):.3f} um)")
    for v in iso["variant"].values:
        r = iso["ratio"].sel(variant=v).values
        print(f"LTCA/ISO {v}: " + " ".join(f"{z}:{x:.3f}" for z, x in
                                            zip(iso['z'].values, r, strict=True)
                                            if np.isfinite(x)))
    for i, lam in enumerate(sens["lam"].values):
        print(f"lam {lam:4.2f} mn: LPMS {float(sens['lpms_mean'][i]):6.1f} (tangent "
              f"{float(sens['lpms_tangent_mean'][i]):6.1f}) N/um, error-free STE ptp "
              f"{float(sens['ste_ptp_error_free'][i]):5.3f} um, with pitch deviations 600 N m "
              f"{float(sens['ste_ptp_pitch_600'][i]):6.2f} um")
    for reading, rows in both.items():
        for T, ptp, kmean, ncyc, m1, m2 in rows:
            print(f"amplitude read as {reading:7s}: max|Fp| {m1:5.1f}/{m2:5.1f} um, {T:6g} N m: "
                  f"STE ptp {ptp:6.2f} um, LPMS mean {kmean:6.1f} N/um, loss cycles {ncyc:2d}")
    print(f"total {total:.1f} s")


def main(argv: list[str] | None = None) -> int:
    """Command line: ``python -m gearuq_studies.pitch_deviation_excitation``."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, default=Path("gearuq_pitch_deviation_excitation"))
    ap.add_argument("--quick", action="store_true", help="coarser LTCA and maps")
    ap.add_argument("--seed", type=int, default=2020,
                    help="seed of the pitch-deviation realisation")
    args = ap.parse_args(argv)
    return run(args.out, quick=args.quick, seed=args.seed)


if __name__ == "__main__":
    raise SystemExit(main())
