"""Li, Hu and Han Fig. 4 analog: dynamic response of the helical pair at n = 3600 rpm, T = 2600 N m.

Time history, velocity, phase portrait, amplitude spectrum and Poincare section (sampled once
per mesh period after the transient) for the driving and driven gear along x, and the same
panels for the other DOFs; each response is classified from its Poincare points.

Run: ``gearuq study helical_pair_dynamics [--quick] [--out DIR]``, or
``python -m gearuq_studies.helical_pair_dynamics --n RPM --torque NM`` for another operating
point. Writes ``dynamics.nc`` and one PNG per DOF pair into the output folder. ``--quick``
integrates 400 mesh periods (steady state from period 300) at 32 points per period instead of
3300 (from 3000) at 64: the support modes have not fully decayed, so its classification of
the response is a preview, not the answer.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
import xarray as xr

import gearuq
from gearuq import plot, signal
from gearuq.failure.report import describe_status

DOFS = [("x_p", "x_g"), ("y_p", "y_g"), ("z_p", "z_g"), ("theta_py", "theta_gy"),
        ("theta_pz", "theta_gz")]
STATE = {name: i + 1 for i, name in enumerate(
    ["x_p", "y_p", "z_p", "theta_py", "theta_pz", "x_g", "y_g", "z_g", "theta_gy", "theta_gz"])}


@plot.quick_mode(
    "1 run of 400 mesh periods",
    left_out=(
        "3300 mesh periods (steady state from 3000): the support modes have not decayed, so "
        "the response classes are a preview"))
def run(out: str | Path = "gearuq_helical_pair_dynamics", quick: bool = False,
        n_rpm: float = 3600.0, torque: float = 2600.0, periods: int | None = None,
        transient_periods: int | None = None, points_per_period: int | None = None) -> int:
    """Time, phase, spectrum and Poincare panels of Li, Hu and Han's helical pair (their Fig. 4).

    Parameters
    ----------
    out : path
        Output folder (created): ``dynamics.nc`` and ``fig4_<dof>_<dof>.png``.
    quick : bool
        400 mesh periods (steady from 300) at 32 points per period instead of 3300 (from 3000)
        at 64: a preview whose support modes have not fully decayed.
    n_rpm, torque : float
        Pinion speed [rpm] and torque [N m].
    periods, transient_periods, points_per_period : int, optional
        Window length and steady-state start in mesh periods, time points per period
        (defaults depend on ``quick``).

    Returns
    -------
    int
        0 when every integration succeeded, 1 otherwise.
    """
    out = Path(out)
    # None takes the default; 0 or a negative value is refused, not replaced by the default
    for name, value in (("periods", periods), ("transient_periods", transient_periods),
                        ("points_per_period", points_per_period)):
        if value is not None and (isinstance(value, bool) or not isinstance(value, int)
                                  or value < 1):
            raise ValueError(f"{name}={value!r} is outside its valid range: integers >= 1")
    periods = periods if periods is not None else (400 if quick else 3300)
    transient_periods = transient_periods if transient_periods is not None else (
        300 if quick else 3000)
    points_per_period = points_per_period if points_per_period is not None else (
        32 if quick else 64)
    if not 0 < transient_periods < periods:
        raise ValueError(f"transient_periods={transient_periods}: must lie in (0, periods="
                         f"{periods})")
    out.mkdir(parents=True, exist_ok=True)
    model = gearuq.get_model("helical_pair")
    params = {"n": [n_rpm], "T": [torque]}
    omega = float(model.response(params, outputs=["omega_n", "mesh_frequency"])
                  .pipe(lambda d: 2 * np.pi * d["mesh_frequency"] / d["omega_n"])[0])
    period = 2 * np.pi / omega  # mesh period in tau
    tau = np.arange(periods * points_per_period + 1) * (period / points_per_period)
    names = [f"p{i}" for i in range(1, 11)] + [f"dp{i}" for i in range(1, 11)] + [
        "mesh_force", "mesh_deflection"]
    # the support modes (omega ~ 0.05 omega_n, zeta_s = 0.05) need ~3000 mesh periods to decay
    ds = model.response(params, tau, outputs=names, rtol=1e-9, atol=1e-11)
    ds.attrs["mesh_period_tau"] = period
    gearuq.save(ds, out / "dynamics.nc")
    t_start = transient_periods * period
    print(f"helical_pair at n = {n_rpm:g} rpm, T = {torque:g} N m: Omega = {omega:.4f}, "
          f"mesh period = {period:.4f} tau, window tau in [0, {tau[-1]:.0f}], "
          f"steady state from tau = {t_start:.0f}; {describe_status(ds)}, "
          f"{int(ds['n_steps'][0])} steps, {int(ds['n_events'][0])} dead-zone switchings")
    b5 = 2e-5
    d = ds["mesh_deflection"].values[0][tau >= t_start]
    print(f"mesh deflection in steady state: [{d.min() * 1e6:.2f}, {d.max() * 1e6:.2f}] um, "
          f"half backlash {b5 * 1e6:.0f} um: contact lost "
          f"{100 * np.mean(np.abs(d) <= b5):.1f} % of the time, back-side impacts: "
          f"{'yes' if (d < -b5).any() else 'no'}")
    # p is a length in units of L (the option length_scale, default 1e-05 m); rotations are
    # pitch-circle arcs r theta in the same unit; tau = omega_n t is nondimensional, so dp/dtau
    # has the unit of p
    length = str(ds.attrs.get("length_scale", "1")).split(" (")[0]
    t_da = xr.DataArray(tau, dims="time",
                        attrs={"long_name": "tau = omega_n t", "units": "1"})
    for pair in DOFS:
        series = {}
        for name in pair:
            i = STATE[name]
            series[f"{name} (p{i})"] = (ds[f"p{i}"].values[0], ds[f"dp{i}"].values[0])
        unit = length + (" arc" if pair[0].startswith("theta") else "")
        fig, _ = plot.plot_time_panels(t_da, series, period, t_start, normalize_frequency=True,
                                       fmax=4.0, x_name="p", v_name="dp/dtau",
                                       units=(unit, unit),  # tau is nondimensional
                                       time_window=12 * period)
        fig.suptitle(f"helical_pair, n = {n_rpm:g} rpm, T = {torque:g} N m: {pair[0]} / "
                     f"{pair[1]} (p in units of {length}, rotations as pitch-circle arcs)")
        plot.save_figure(fig, out / f"fig4_{pair[0]}_{pair[1]}.png")
        for name in pair:
            i = STATE[name]
            sec = signal.poincare_section(tau, ds[f"p{i}"].values[0], ds[f"dp{i}"].values[0],
                                          period=period, t_start=t_start)
            cls = signal.classify_response(sec, rtol=1e-4)
            f, a = signal.amplitude_spectrum(ds[f"p{i}"].values[0][tau >= t_start],
                                             tau[tau >= t_start], window="flattop")
            peaks, amps = signal.dominant_frequencies(f, a, n=3)
            orders = ", ".join(f"{p * period:.3f} ({q:.3g})" for p, q in zip(peaks, amps,
                                                                              strict=True))
            steady = ds[f"p{i}"].values[0][tau >= t_start]
            print(f"  {name:<9} rms {signal.rms(steady, center=True):.4f}"
                  f"  p-p {signal.peak_to_peak(steady):.4f}"
                  f"  response: {cls.label:<15} peaks at mesh orders {orders}")
    print(f"written: {out}")
    return int(ds["status"][0] != 0)


def main(argv: list[str] | None = None) -> int:
    """Command line: ``python -m gearuq_studies.helical_pair_dynamics``."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("gearuq_helical_pair_dynamics"))
    parser.add_argument("--quick", action="store_true", help="400 mesh periods: a preview")
    parser.add_argument("--n", type=float, default=3600.0, help="pinion speed [rpm]")
    parser.add_argument("--torque", type=float, default=2600.0, help="pinion torque [N m]")
    args = parser.parse_args(argv)
    return run(args.out, quick=args.quick, n_rpm=args.n, torque=args.torque)


if __name__ == "__main__":
    raise SystemExit(main())
