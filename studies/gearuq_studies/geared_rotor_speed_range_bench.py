"""Benchmark: one random sample of ``geared_rotor`` over a whole speed range, old and new path.

Side by side in one run, for random samples of the default space (the pitch-deviation germ,
torque, bearings, damping) over 25-8000 rpm in 160 speeds:

* **today's path**: ``model.response`` with the 160 speeds as 160 rows (LTCA and reduction
  cached, every steady state with all output channels, its own BLAS thread limit, the complex
  harmonic-balance solve, 4 mesh harmonics, cut-off 1.5);
* the steps of the new path, each added to the previous one: (1) one BLAS limit and only the
  mesh and DTE receptances (``GearedRotorProblem.rms_over_speeds``), (2) the real-form solve,
  (3) the range settings (3 mesh harmonics, cut-off 1.0) = the plugin's ``dte_rms_max``;
* the error of ``dte_rms_max`` against a converged reference (11 mesh harmonics, cut-off 3,
  tolerance 1e-12, the same speeds) and the error of the 160-speed grid against 1281 speeds;
* what continuation along speed saves on a contact-loss sample (100 N m, 40 um);
* with ``--form``, ``--mc N``, ``--subset N``: FORM, crude Monte Carlo and subset simulation
  on "dte_rms_max above X" in the continuous default space.

Timings are process CPU seconds (one core; the BLAS is limited to one thread) and wall
seconds; the machine is shared, so read the CPU column. Run:
``gearuq study geared_rotor_speed_range_bench [--quick] [--out DIR]`` (3 samples; ``--quick``:
one sample, and the grid error against 321 speeds instead of 1281), or
``python -m gearuq_studies.geared_rotor_speed_range_bench [--samples 3] [--form]
[--limit 14e-6] [--mc N] [--subset N]``. Writes ``timings.nc``, ``timings.md`` and
``timings.png`` into the output folder.

The old paths are measured by switching the harmonic-balance solve back to its complex form
(``gearuq.rotor.harmonic_balance.REAL_FORM``, kept for this benchmark) and by clearing the
model's LTCA and reduction cache before each path, so that every path pays for its own.
"""

from __future__ import annotations

import argparse
import time
import warnings
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

import gearuq
from gearuq import plot
from gearuq.bench import machine_description
from gearuq.failure.report import describe_status

PATHS = ("today", "1 one limit, 2 channels", "2 + real form", "3 + range settings",
         "plugin dte_rms_max")


def _clock() -> tuple[float, float]:
    return time.process_time(), time.perf_counter()


def _since(start: tuple[float, float]) -> tuple[float, float]:
    c, w = _clock()
    return c - start[0], w - start[1]


def _cold(model: Any) -> None:
    """Forget the model's cached LTCA and reduction, so the next path pays for its own."""
    model._cache.clear()


def bench(model: Any, n_samples: int, n_fine: int = 1281) -> list[tuple]:
    """Time every path on ``n_samples`` random samples; return one row per sample."""
    import gearuq.rotor.harmonic_balance as hb
    from gearuq.rotor.geared import single_threaded_blas
    speeds = np.linspace(25.0, 8000.0, 160)
    samples = model.default_space().sample(n_samples + 1, rng=2026)
    nominal = {p.name: p.nominal for p in model.parameters}
    with gearuq.kernels_route("compiled"):  # compiles the LTCA kernel once, before timing
        model.response({k: v[-1:] for k, v in samples.items()}, None, outputs=["dte_rms_max"])
    rows = []
    try:
        for i in range(n_samples):
            values = nominal | {k: float(v[i]) for k, v in samples.items()}
            timings: dict[str, tuple[float, float]] = {}
            result: dict[str, float] = {}
            # today's path: 160 rows, complex solve, all channels
            _cold(model)
            hb.REAL_FORM = False
            start = _clock()
            ds = model.response({k: np.full(160, v) for k, v in values.items()
                                 if k != "speed"} | {"speed": speeds}, None,
                                outputs=["dte_rms"], n_mesh_harmonics=4)  # the former default
            timings["today"] = _since(start)
            result["today"] = float(np.nanmax(ds["dte_rms"].values))
            # steps of the new path (problem built inside each timing)
            for step, real, harmonics, cutoff in (("1 one limit, 2 channels", False, 4, 1.5),
                                                  ("2 + real form", True, 4, 1.5),
                                                  ("3 + range settings", True, 3, 1.0)):
                _cold(model)
                hb.REAL_FORM = real
                opts = model.validate_options({"range_mesh_harmonics": harmonics,
                                               "range_cutoff_factor": cutoff})
                start = _clock()
                with single_threaded_blas():
                    prob = model.rotor_problem(values, speed_range=True, **opts)
                    res = prob.rms_over_speeds(speeds)
                timings[step] = _since(start)
                result[step] = res.maximum()[0]
            hb.REAL_FORM = True
            _cold(model)
            start = _clock()
            ds = model.response({k: [v] for k, v in values.items()}, None,
                                outputs=["dte_rms_max", "speed_at_dte_rms_max"])
            timings["plugin dte_rms_max"] = _since(start)
            result["plugin dte_rms_max"] = float(ds["dte_rms_max"].values[0])
            # converged reference on the same speeds, and the grid error on a finer grid
            ref_opts = model.validate_options({"range_mesh_harmonics": 11,
                                               "range_cutoff_factor": 3.0, "tol": 1e-12})
            with single_threaded_blas():
                ref = model.rotor_problem(values, speed_range=True, **ref_opts
                                          ).rms_over_speeds(speeds, tol=1e-12)
                fine = model.rotor_problem(values, speed_range=True).rms_over_speeds(
                    np.linspace(25.0, 8000.0, n_fine))
            reference = ref.maximum()[0]
            rows.append((i, values, timings, result, reference, ref.maximum()[1],
                         fine.maximum()[0] / result["3 + range settings"] - 1.0))
    finally:
        hb.REAL_FORM = True  # never leave the process on the benchmark's old path
    return rows


def print_rows(rows: list[tuple], n_fine: int) -> list[str]:
    """The timing and accuracy table, printed and returned as lines."""
    lines = [machine_description(),
             "one random sample over 160 speeds (25-8000 rpm); CPU s / wall s; relative error "
             "of dte_rms_max against the converged reference (11 mesh harmonics, cut-off 3)"]
    for i, values, timings, result, reference, at, grid in rows:
        lines.append(
            f"\nsample {i}: torque {values['torque']:.0f} N m, bearing stiffness "
            f"{values['bearing_stiffness']:.3g} N/m, damping {values['damping_ratio']:.3f}, "
            f"A {values['pitch_amplitude']:.1f} um, sigma {values['pitch_sigma']:.2f} um; "
            f"reference {reference * 1e6:.4f} um at {at:.0f} rpm")
        lines.append(f"  {'path':28s} {'CPU s':>7s} {'wall s':>7s} {'error':>10s}")
        for name, (cpu, wall) in timings.items():
            lines.append(f"  {name:28s} {cpu:7.3f} {wall:7.3f} "
                         f"{result[name] / reference - 1:10.2e}")
        lines.append(f"  160-speed grid against {n_fine} speeds: max higher by {grid:.2e} on "
                     "the fine grid")
    print("\n".join(lines))
    return lines


def to_dataset(rows: list[tuple], n_fine: int) -> xr.Dataset:
    """CPU and wall seconds and the relative error of every path, per sample."""
    cpu = np.array([[r[2][p][0] for p in PATHS] for r in rows])
    wall = np.array([[r[2][p][1] for p in PATHS] for r in rows])
    err = np.array([[r[3][p] / r[4] - 1.0 for p in PATHS] for r in rows])
    dims = ("sample", "path")
    return xr.Dataset(
        {"cpu_time": (dims, cpu, {"units": "s", "long_name": "process CPU time"}),
         "wall_time": (dims, wall, {"units": "s"}),
         "relative_error": (dims, err, {"units": "1", "long_name": "dte_rms_max / converged "
                                        "reference - 1"}),
         "reference": ("sample", [r[4] for r in rows], {"units": "m", "long_name":
                       "dte_rms_max, 11 mesh harmonics, cut-off 3, tolerance 1e-12"}),
         "speed_at_reference": ("sample", [r[5] for r in rows], {"units": "rpm"}),
         "grid_error": ("sample", [r[6] for r in rows], {"units": "1", "long_name":
                        f"max over {n_fine} speeds / max over 160 speeds - 1"})},
        coords={"sample": np.arange(len(rows)), "path": list(PATHS)},
        attrs={"machine": machine_description(), "speeds": "160 in 25-8000 rpm"})


def figure(ds: xr.Dataset):
    """CPU seconds of every path (bars per sample) and its error (log axis)."""
    from matplotlib.figure import Figure

    fig = Figure(figsize=(12, 4.6), layout="constrained")
    ax1, ax2 = fig.subplots(1, 2)
    x = np.arange(ds.sizes["path"])
    width = 0.8 / ds.sizes["sample"]
    colours = ("tab:blue", "tab:orange", "tab:green", "tab:red", "tab:purple")
    for k in range(ds.sizes["sample"]):
        c = colours[k % len(colours)]
        ax1.bar(x + k * width, ds["cpu_time"].values[k], width, color=c, label=f"sample {k}")
        ax2.bar(x + k * width, np.maximum(np.abs(ds["relative_error"].values[k]), 1e-12),
                width, color=c, label=f"sample {k}")
    labels = [p.replace(" + ", "\n+ ").replace("plugin ", "plugin\n") for p in PATHS]
    for ax in (ax1, ax2):
        ax.set_xticks(x + 0.4 - width / 2, labels, fontsize=7)
        ax.grid(alpha=0.3, axis="y")
        ax.legend(fontsize=7)
    ax1.set(ylabel="CPU time over 160 speeds [s]", title="cost of one sample, per path")
    ax2.set(ylabel="|dte_rms_max / reference - 1| [1] (floor 1e-12)", yscale="log",
            title="error against the converged reference")
    return fig


def _continuation(model: gearuq.Model) -> None:
    from gearuq.rotor.geared import single_threaded_blas
    from gearuq.rotor.harmonic_balance import STATUS_MEANINGS
    values = {p.name: p.nominal for p in model.parameters} | {
        "torque": 100.0, "pitch_amplitude": 40.0, "pitch_xi_p_1": 1.0, "pitch_xi_g_2": 1.0}
    prob = model.rotor_problem(values, speed_range=True)
    speeds = np.linspace(25.0, 8000.0, 160)
    out = {}
    with single_threaded_blas():
        for cont in (False, True):
            start = _clock()
            res = prob.rms_over_speeds(speeds, continuation=cont)
            out[cont] = (_since(start), res)
    loss = int(np.sum(out[True][1].contact_loss_fraction > 0))
    print(f"\ncontinuation along speed (100 N m, 40 um, {loss} of 160 speeds with contact "
          "loss):")
    for cont, ((cpu, wall), res) in out.items():
        print(f"  {'continued' if cont else 'linear start'}: {int(res.iterations.sum())} Newton "
              f"iterations, CPU {cpu:.3f} s, wall {wall:.3f} s, dte_rms_max "
              f"{res.maximum()[0] * 1e6:.5f} um, status {res.maximum()[2]}: "
              f"{STATUS_MEANINGS[res.maximum()[2]].replace('_', ' ')}")


def form_check(model: Any, limit: float) -> None:
    """FORM on dte_rms_max > limit in the continuous default space (public API only)."""
    space = model.default_space()
    start = _clock()
    # one start (a search costs ~850 runs here); the report's status 8 then says that other
    # design points were not looked for - on this germ there is a whole circle of them
    res = gearuq.failure_probability(model, space, gearuq.LimitState.upper("dte_rms_max", limit),
                                     None, method="form", rng=1, n_starts=1)
    cpu, wall = _since(start)
    print(f"\nFORM, dte_rms_max > {limit * 1e6:g} um, {space.dim} inputs: "
          f"beta {float(res['beta']):.4f}, pf {float(res['pf']):.3e}, "
          f"{int(res['n_model_runs'])} model runs, CPU {cpu:.0f} s, wall {wall:.0f} s\n"
          f"  {describe_status(res)}")
    for name in ("design_point_u", "iterations"):
        if name in res:
            print(f"  {name}: {res[name].values}")
    u = res["design_point_u"].values.ravel() if "design_point_u" in res else None
    if u is not None:
        names = list(space.names)
        order = np.argsort(-np.abs(u))[:6]
        print("  largest design-point coordinates:",
              ", ".join(f"{names[j]} {u[j]:+.3f}" for j in order))


def sampling_check(model: Any, method: str, limit: float, rng: int, label: str,
                   **settings: Any) -> None:
    """A sampling method on the same limit state (crude MC: an independent estimator; subset
    simulation: its Markov chains need the continuous space)."""
    start = _clock()
    res = gearuq.failure_probability(model, model.default_space(),
                                     gearuq.LimitState.upper("dte_rms_max", limit), None,
                                     method=method, rng=rng, **settings)
    cpu, wall = _since(start)
    print(f"\n{label}, dte_rms_max > {limit * 1e6:g} um: pf "
          f"{float(res['pf']):.3e} [{float(res['pf_lower']):.3e}, {float(res['pf_upper']):.3e}]"
          f", {int(res['n_model_runs'])} model runs, CPU {cpu:.0f} s, wall {wall:.0f} s\n"
          f"  {describe_status(res)}")


@plot.quick_mode(
    lambda a: f"{a['samples'] or 1} sample(s) over 160 speeds",
    left_out=(
        "3 samples, and the grid error against 1281 speeds (321 here)"))
def run(out: str | Path = "gearuq_geared_rotor_speed_range_bench", quick: bool = False,
        samples: int | None = None, form: bool = False, limit: float = 14e-6, mc: int = 0,
        subset: int = 0) -> int:
    """Cost against error of one geared-rotor sample over 25-8000 rpm, old path and new path.

    Parameters
    ----------
    out : path
        Output folder (created): ``timings.nc``, ``timings.md``, ``timings.png``.
    quick : bool
        One sample (three otherwise), the grid error against 321 speeds instead of 1281.
    samples : int, optional
        Random samples of the default space (overrides ``quick``), >= 1.
    form : bool
        Also FORM on ``dte_rms_max > limit`` (minutes).
    limit : float
        ``X`` of ``dte_rms_max > X`` [m] for FORM, ``mc`` and ``subset``, > 0.
    mc, subset : int
        Also crude Monte Carlo with ``mc`` samples, subset simulation with ``subset``
        samples per level (0: not run).

    Returns
    -------
    int
        0.
    """
    samples = samples or (1 if quick else 3)
    if samples < 1:
        raise ValueError(f"samples={samples}: at least 1")
    if limit <= 0:
        raise ValueError(f"limit={limit}: the dte_rms_max limit must be > 0 m")
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    n_fine = 321 if quick else 1281
    model = gearuq.get_model("geared_rotor")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", category=UserWarning)
        rows = bench(model, samples, n_fine)
        lines = print_rows(rows, n_fine)
        ds = to_dataset(rows, n_fine)
        gearuq.save(ds, out / "timings.nc")
        (out / "timings.md").write_text("```\n" + "\n".join(lines) + "\n```\n")
        from gearuq.plot import save_figure

        save_figure(figure(ds), out / "timings.png")
        _continuation(model)
        if form:
            form_check(model, limit)
        if mc:
            sampling_check(model, "mc", limit, 7, f"Monte Carlo, {mc} samples", n_samples=mc)
        if subset:
            sampling_check(model, "subset", limit, 3, f"subset simulation, {subset} per level",
                           n_per_level=subset)
    print(f"written: {out} (timings.nc, timings.md, timings.png)")
    return 0


def main(argv: list[str] | None = None) -> int:
    """Command line: ``python -m gearuq_studies.geared_rotor_speed_range_bench``."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, default=Path("gearuq_geared_rotor_speed_range_bench"))
    ap.add_argument("--quick", action="store_true", help="one sample, coarser grid check")
    ap.add_argument("--samples", type=int, default=None, help="random samples (default 3)")
    ap.add_argument("--form", action="store_true", help="also run FORM (minutes)")
    ap.add_argument("--limit", type=float, default=14e-6, help="X of dte_rms_max > X [m]")
    ap.add_argument("--mc", type=int, default=0, help="also crude Monte Carlo with N samples")
    ap.add_argument("--subset", type=int, default=0,
                    help="also subset simulation with N samples per level")
    args = ap.parse_args(argv)
    return run(args.out, quick=args.quick, samples=args.samples, form=args.form,
               limit=args.limit, mc=args.mc, subset=args.subset)


if __name__ == "__main__":
    raise SystemExit(main())
