"""Yuan et al. (2020) Figs. 11-12 and 15-16 analogs: DTE and bearing-acceleration spectra of the
FE rotor.

- Figs. 11-12: dynamic transmission error (DTE) and the y acceleration at bearing 1 at
  4000 rpm for 200, 350, 600 and 1000 N m, random cumulative pitch deviations (sine 15 um +
  N(0, 3 um), realisation 2020 as in the LTCA study), unmodified teeth.
- Figs. 15-16: the same at 1000 N m (our choice: Yuan et al. do not print the load of these
  figures; it is the load of the tip-relief optimum), unmodified against modified (parabolic
  tip relief 42 um / 11.4 mm, the error-free STE optimum of the LTCA at 1000 N m).

Spectra are the exact harmonics of the periodic steady state over one revolution (the long
period of the 30/30 pair), so the shaft frequency f_s, the mesh harmonics k f_m and the
sidebands k f_m +- i f_s fall on lines; no window, no leakage.

Run: ``gearuq study geared_rotor_spectra [--quick] [--out DIR]`` (under a minute), or
``python -m gearuq_studies.geared_rotor_spectra --paper-rotor`` for the rotor as printed (no
drive and load inertias). Writes netCDF + PNG into the output folder and prints what Yuan et
al. claim beside what the model finds. ``--quick`` uses a coarser LTCA (16 positions per mesh
cycle, 12 points per line instead of 24 x 20) and 601 instants per revolution.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np
import xarray as xr
from matplotlib.figure import Figure

import gearuq
from gearuq import plot
from gearuq.failure.report import describe_status
from gearuq.plot import save_figure

TORQUES = (200.0, 350.0, 600.0, 1000.0)
COLOURS = ("tab:blue", "tab:orange", "tab:green", "tab:red")
SPEED = 4000.0
RELIEF = {"tip_relief_amount": 42.0, "tip_relief_length": 11.4}
MAX_ORDER = 100  # orders shown (3.3 mesh harmonics)
SIDEBANDS = 14  # sideband window +-14 f_s: every order nearer to f_m than to 0 or 2 f_m
OUTPUTS = ["dte", "bearing_acceleration_y", "dte_spectrum", "bearing1_acceleration_y_spectrum",
           "dte_rms", "bearing1_acceleration_y_rms", "contact_loss_fraction", "mesh_force_min",
           "dte_mean", "ste_ptp"]


def order_groups(labels: np.ndarray) -> dict[str, np.ndarray]:
    """Masks of shaft orders, mesh harmonics and labelled sidebands."""
    mesh = np.array([lab.endswith("f_m") for lab in labels])
    side = np.array(["f_m" in lab and "f_s" in lab for lab in labels])
    return {"shaft orders": ~mesh & ~side, "sidebands f_m +- i f_s": side,
            "mesh harmonics": mesh}


def spectrum_panel(ax, ds: xr.Dataset, var: str, i: int, scale: float, units: str,
                   title: str) -> None:
    """Stems at every order, coloured by kind (shaft order, mesh harmonic, sideband)."""
    labels = ds["order_label"].values
    order = ds["order"].values
    amp = ds[var].values[i] * scale
    keep = (order >= 1) & (order <= MAX_ORDER)
    for (name, mask), colour in zip(order_groups(labels).items(),
                                    ("0.55", "tab:orange", "tab:red"), strict=True):
        m = mask & keep
        ax.vlines(order[m], 0.0, amp[m], colors=colour, lw=1.6, label=name)
    ax.set_xlim(0, MAX_ORDER + 1)
    ax.set_ylim(bottom=0.0)
    ax.set_xlabel("frequency / shaft frequency f_s (f_m = 30 f_s)")
    ax.set_ylabel(f"amplitude [{units}]")
    ax.set_title(title, fontsize=9)


def peaks(ds: xr.Dataset, var: str, i: int) -> dict[str, float]:
    """Amplitude at f_s, at f_m and 2 f_m, and the largest sideband around each.

    The sideband window is every order nearer to the mesh harmonic than to its neighbours,
    ``+-SIDEBANDS f_s``: the largest sidebands sit anywhere in it (``+4..+7 f_s`` at 1000 N m,
    up to ``+-14 f_s`` at 200 N m), and a window of +-3 missed them.
    """
    amp = ds[var].values[i]
    out = {"f_s": amp[1], "f_m": amp[30], "2f_m": amp[60],
           "max_non_dc_order": int(np.argmax(amp[1:]) + 1)}
    for key, h in (("side1", 30), ("side2", 60)):
        k = np.arange(1, SIDEBANDS + 1)
        both = np.maximum(amp[h - k], amp[h + k])
        j = int(np.argmax(both))
        out[key] = float(both[j])
        out[key + "_at"] = int(k[j] if amp[h + k[j]] >= amp[h - k[j]] else -k[j])
    return out


def figure_pair(ds: xr.Dataset, cases: list[str], var_t: str, var_s: str, scale: float,
                units: str, title: str) -> Figure:
    """One row per case: time over one revolution, spectrum."""
    fig = Figure(figsize=(11, 2.3 * len(cases) + 0.6), layout="constrained")
    axs = fig.subplots(len(cases), 2, squeeze=False, width_ratios=(1, 1.6))
    t_ms = ds["time"].values * 1e3
    for i, case in enumerate(cases):
        y = ds[var_t].values[i]
        if y.ndim == 2:
            y = y[0]  # bearing 1
        axs[i, 0].plot(t_ms, y * scale, color=COLOURS[i % 4], lw=0.8)
        axs[i, 0].set_xlabel("time [ms] (one pinion revolution)")
        axs[i, 0].set_ylabel(f"[{units}]")
        axs[i, 0].set_title(f"{case}: time history", fontsize=9)
        spectrum_panel(axs[i, 1], ds, var_s, i, scale, units, f"{case}: spectrum")
    axs[0, 1].legend(fontsize=7, loc="upper right")
    fig.suptitle(title, fontsize=10)
    return fig


@plot.quick_mode(
    "3 rotor runs on a coarse LTCA",
    left_out=(
        "the fine LTCA (24 x 20 instead of 16 x 12 per mesh cycle) and 1201 instants per "
        "revolution (601 here)"))
def run(out: str | Path = "gearuq_geared_rotor_spectra", quick: bool = False,
        paper_rotor: bool = False) -> int:
    """DTE and bearing-acceleration spectra of Yuan, Liu and Liu's geared rotor, Figs. 11-12, 15-16.

    Parameters
    ----------
    out : path
        Output folder (created): ``spectra_torques.nc``, ``spectra_relief.nc`` and the four
        figure analogs (PNG).
    quick : bool
        Coarser LTCA (16 positions per mesh cycle, 12 points per line) and 601 instants per
        revolution instead of 24 x 20 and 1201.
    paper_rotor : bool
        No drive and load inertias (the rotor as printed by Yuan et al.).

    Returns
    -------
    int
        0 when all six steady states converged, 1 otherwise.
    """
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    model = gearuq.get_model("geared_rotor")
    period = 60.0 / SPEED
    t = np.linspace(0.0, period, 601 if quick else 1201)
    start = time.perf_counter()
    seeded = {"pitch_model": "seeded"}  # Yuan et al.'s realisation (pitch_seed 2020)
    if quick:
        seeded |= {"positions_per_cycle": 16, "n_pts": 12}
    if paper_rotor:
        seeded["end_inertias"] = "none"  # the rotor as printed
    loads = model.response({"torque": list(TORQUES), "speed": [SPEED] * 4}, t, outputs=OUTPUTS,
                           **seeded)
    relief = model.response({"torque": [1000.0] * 2, "speed": [SPEED] * 2,
                             "tip_relief_amount": [0.0, RELIEF["tip_relief_amount"]],
                             "tip_relief_length": [RELIEF["tip_relief_length"]] * 2},
                            t, outputs=OUTPUTS, **seeded)
    wall = time.perf_counter() - start
    gearuq.save(loads, out / "spectra_torques.nc")
    gearuq.save(relief, out / "spectra_relief.nc")
    names = [f"{T:g} N m" for T in TORQUES]
    save_figure(figure_pair(loads, names, "dte", "dte_spectrum", 1e6, "um",
                            "Fig. 11 analog: DTE at 4000 rpm, random pitch deviations"),
                out / "fig11_dte_torques.png")
    save_figure(figure_pair(loads, names, "bearing_acceleration_y",
                            "bearing1_acceleration_y_spectrum", 1.0, "m s-2",
                            "Fig. 12 analog: bearing 1 acceleration along y, 4000 rpm"),
                out / "fig12_bearing1_acceleration_torques.png")
    cases = ["unmodified", "tip relief 42 um / 11.4 mm"]
    save_figure(figure_pair(relief, cases, "dte", "dte_spectrum", 1e6, "um",
                            "Fig. 15 analog: DTE, 1000 N m, 4000 rpm"),
                out / "fig15_dte_relief.png")
    save_figure(figure_pair(relief, cases, "bearing_acceleration_y",
                            "bearing1_acceleration_y_spectrum", 1.0, "m s-2",
                            "Fig. 16 analog: bearing 1 acceleration along y, 1000 N m"),
                out / "fig16_bearing1_acceleration_relief.png")
    report(loads, relief, wall)
    print(f"written: {out}")
    return int(np.any(loads["status"].values != 0) or np.any(relief["status"].values != 0))


def main(argv: list[str] | None = None) -> int:
    """Command line: ``python -m gearuq_studies.geared_rotor_spectra``."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, default=Path("gearuq_geared_rotor_spectra"))
    ap.add_argument("--quick", action="store_true", help="coarser LTCA and time grid")
    ap.add_argument("--paper-rotor", action="store_true",
                    help="no drive and load inertias (Yuan et al.'s rotor as printed)")
    args = ap.parse_args(argv)
    return run(args.out, quick=args.quick, paper_rotor=args.paper_rotor)


def report(loads: xr.Dataset, relief: xr.Dataset, wall: float) -> None:
    """Print Yuan et al.'s claims beside what the model gives."""
    print(f"geared_rotor spectra: 6 steady states (LTCA + reduction + harmonic balance) in "
          f"{wall:.1f} s (shared machine; provisional)")
    print(f"torques: {describe_status(loads)}; reliefs: {describe_status(relief)}")
    print("\nFig. 11/12 (4000 rpm, unmodified, random pitch deviations 15 um / 3 um)")
    print(" torque | DTE rms  A(f_s)  A(f_m) max side (at)  A(2fm) side2 (at) | acc rms  "
          "A(f_m) max side (at) A(2fm) side2 (at) | contact loss")
    for i, T in enumerate(TORQUES):
        d = peaks(loads, "dte_spectrum", i)
        a = peaks(loads, "bearing1_acceleration_y_spectrum", i)
        print(f" {T:6.0f} | {loads['dte_rms'].values[i] * 1e6:6.2f} {d['f_s'] * 1e6:7.2f} "
              f"{d['f_m'] * 1e6:7.3f} {d['side1'] * 1e6:8.3f} ({d['side1_at']:+d}) "
              f"{d['2f_m'] * 1e6:7.3f} {d['side2'] * 1e6:6.3f} ({d['side2_at']:+d}) | "
              f"{loads['bearing1_acceleration_y_rms'].values[i]:7.2f} {a['f_m']:7.2f} "
              f"{a['side1']:8.2f} ({a['side1_at']:+d}) {a['2f_m']:6.2f} {a['side2']:6.2f} "
              f"({a['side2_at']:+d}) | {loads['contact_loss_fraction'].values[i]:.3f}")
    d = [peaks(loads, "dte_spectrum", i) for i in range(4)]
    a = [peaks(loads, "bearing1_acceleration_y_spectrum", i) for i in range(4)]
    print("  Yuan et al.: DTE largest at f_s ->", all(x["max_non_dc_order"] == 1 for x in d))
    print("  Yuan et al.: A(f_m) < sidebands below 600 N m ->",
          [bool(x["f_m"] < x["side1"]) for x in d[:2]], " above ->",
          bool(d[3]["f_m"] > d[3]["side1"]))
    print("  sidebands around 2 f_m larger than 2 f_m (DTE, acc) ->",
          [(bool(x["side2"] > x["2f_m"]), bool(y["side2"] > y["2f_m"]))
           for x, y in zip(d, a, strict=True)])
    print("  Yuan et al.: A(f_m) grows with torque ->",
          bool(np.all(np.diff([x["f_m"] for x in d]) > 0)))
    print("  Yuan et al.: bearing acc, f_m predominant at 1000 N m ->",
          a[3]["max_non_dc_order"] == 30, f"(largest at order {a[3]['max_non_dc_order']})")
    print("  Yuan et al.: bearing acc, f_s not predominant ->",
          all(x["max_non_dc_order"] != 1 for x in a))
    print("\nFig. 15/16 (1000 N m, 4000 rpm): unmodified vs tip relief 42 um / 11.4 mm")
    for var, scale, unit in (("dte_spectrum", 1e6, "um"),
                             ("bearing1_acceleration_y_spectrum", 1.0, "m s-2")):
        u, m = peaks(relief, var, 0), peaks(relief, var, 1)
        print(f"  {var}: A(f_m) {u['f_m'] * scale:.3f} -> {m['f_m'] * scale:.3f} {unit}, "
              f"A(2 f_m) {u['2f_m'] * scale:.3f} -> {m['2f_m'] * scale:.3f}, largest sideband "
              f"at f_m {u['side1'] * scale:.3f} ({u['side1_at']:+d} f_s) -> "
              f"{m['side1'] * scale:.3f} ({m['side1_at']:+d} f_s)")
    print(f"  DTE rms {relief['dte_rms'].values[0] * 1e6:.3f} -> "
          f"{relief['dte_rms'].values[1] * 1e6:.3f} um; bearing-1 y acc rms "
          f"{relief['bearing1_acceleration_y_rms'].values[0]:.2f} -> "
          f"{relief['bearing1_acceleration_y_rms'].values[1]:.2f} m s-2")


if __name__ == "__main__":
    raise SystemExit(main())
