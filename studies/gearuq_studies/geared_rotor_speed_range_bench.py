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
``python studies/geared_rotor_speed_range_bench.py [--samples 3] [--form] [--limit 14e-6]``.
"""

from __future__ import annotations

import argparse
import time
import warnings

import numpy as np

import gearuq
from gearuq.bench import machine_description


def _model() -> gearuq.Model:
    from gearuq_plugins.geared_rotor import GearedRotor

    return GearedRotor()


def _clock() -> tuple[float, float]:
    return time.process_time(), time.perf_counter()


def _since(start: tuple[float, float]) -> tuple[float, float]:
    c, w = _clock()
    return c - start[0], w - start[1]


def bench(n_samples: int) -> None:
    """Print the timing and accuracy table."""
    import gearuq.rotor.harmonic_balance as hb
    from gearuq.rotor.geared import single_threaded_blas
    model = _model()
    speeds = np.linspace(25.0, 8000.0, 160)
    samples = model.default_space().sample(n_samples + 1, rng=2026)
    nominal = {p.name: p.nominal for p in model.parameters}
    model.response({k: v[-1:] for k, v in samples.items()}, None,
                   outputs=["dte_rms_max"])  # compiles the LTCA kernel once
    rows = []
    for i in range(n_samples):
        values = nominal | {k: float(v[i]) for k, v in samples.items()}
        timings: dict[str, tuple[float, float]] = {}
        result: dict[str, float] = {}
        # today's path: 160 rows, complex solve, all channels
        model._cache.clear()
        hb.REAL_FORM = False
        start = _clock()
        ds = model.response({k: np.full(160, v) for k, v in values.items() if k != "speed"}
                            | {"speed": speeds}, None, outputs=["dte_rms"],
                            n_mesh_harmonics=4)  # the former default
        timings["today"] = _since(start)
        result["today"] = float(np.nanmax(ds["dte_rms"].values))
        # steps of the new path (problem built inside each timing)
        for step, real, harmonics, cutoff in (("1 one limit, 2 channels", False, 4, 1.5),
                                              ("2 + real form", True, 4, 1.5),
                                              ("3 + range settings", True, 3, 1.0)):
            model._cache.clear()
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
        model._cache.clear()
        start = _clock()
        ds = model.response({k: [v] for k, v in values.items()}, None,
                            outputs=["dte_rms_max", "speed_at_dte_rms_max"])
        timings["plugin dte_rms_max"] = _since(start)
        result["plugin dte_rms_max"] = float(ds["dte_rms_max"].values[0])
        # converged reference on the same speeds, and the grid error on 1281 speeds
        ref_opts = model.validate_options({"range_mesh_harmonics": 11,
                                           "range_cutoff_factor": 3.0, "tol": 1e-12})
        with single_threaded_blas():
            ref = model.rotor_problem(values, speed_range=True, **ref_opts).rms_over_speeds(
                speeds, tol=1e-12)
            fine = model.rotor_problem(values, speed_range=True).rms_over_speeds(
                np.linspace(25.0, 8000.0, 1281))
        reference = ref.maximum()[0]
        rows.append((i, values, timings, result, reference, ref.maximum()[1],
                     fine.maximum()[0] / result["3 + range settings"] - 1.0))
    print(machine_description())
    print("one random sample over 160 speeds (25-8000 rpm); CPU s / wall s; relative error "
          "of dte_rms_max against the converged reference (11 mesh harmonics, cut-off 3)")
    for i, values, timings, result, reference, at, grid in rows:
        print(f"\nsample {i}: torque {values['torque']:.0f} N m, bearing stiffness "
              f"{values['bearing_stiffness']:.3g} N/m, damping {values['damping_ratio']:.3f}, "
              f"A {values['pitch_amplitude']:.1f} um, sigma {values['pitch_sigma']:.2f} um; "
              f"reference {reference * 1e6:.4f} um at {at:.0f} rpm")
        print(f"  {'path':28s} {'CPU s':>7s} {'wall s':>7s} {'error':>10s}")
        for name, (cpu, wall) in timings.items():
            print(f"  {name:28s} {cpu:7.3f} {wall:7.3f} {result[name] / reference - 1:10.2e}")
        print(f"  160-speed grid against 1281 speeds: max higher by {grid:.2e} on the fine grid")
    _continuation(model)


def _continuation(model: gearuq.Model) -> None:
    from gearuq.rotor.geared import single_threaded_blas
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
              f"{res.maximum()[0] * 1e6:.5f} um, status {res.maximum()[2]}")


def form_check(limit: float) -> None:
    """FORM on dte_rms_max > limit in the continuous default space (public API only)."""
    model = _model()
    space = model.default_space()
    start = _clock()
    # one start (a search costs ~850 runs here); the report's status 8 then says that other
    # design points were not looked for - on this germ there is a whole circle of them
    res = gearuq.failure_probability(model, space, gearuq.LimitState.upper("dte_rms_max", limit),
                                     None, method="form", rng=1, n_starts=1)
    cpu, wall = _since(start)
    print(f"\nFORM, dte_rms_max > {limit * 1e6:g} um, {space.dim} inputs: status "
          f"{int(res['status'])}, beta {float(res['beta']):.4f}, pf {float(res['pf']):.3e}, "
          f"{int(res['n_model_runs'])} model runs, CPU {cpu:.0f} s, wall {wall:.0f} s\n"
          f"  {res.attrs['message']}")
    for name in ("design_point_u", "iterations"):
        if name in res:
            print(f"  {name}: {res[name].values}")
    u = res["design_point_u"].values.ravel() if "design_point_u" in res else None
    if u is not None:
        names = list(space.names)
        order = np.argsort(-np.abs(u))[:6]
        print("  largest design-point coordinates:",
              ", ".join(f"{names[j]} {u[j]:+.3f}" for j in order))


def sampling_check(method: str, limit: float, rng: int, label: str, **settings) -> None:
    """A sampling method on the same limit state (crude MC: an independent estimator; subset
    simulation: its Markov chains need the continuous space)."""
    model = _model()
    start = _clock()
    res = gearuq.failure_probability(model, model.default_space(),
                                     gearuq.LimitState.upper("dte_rms_max", limit), None,
                                     method=method, rng=rng, **settings)
    cpu, wall = _since(start)
    print(f"\n{label}, dte_rms_max > {limit * 1e6:g} um: pf "
          f"{float(res['pf']):.3e} [{float(res['pf_lower']):.3e}, {float(res['pf_upper']):.3e}]"
          f", status {int(res['status'])}, {int(res['n_model_runs'])} model runs, CPU {cpu:.0f}"
          f" s, wall {wall:.0f} s")


def main() -> None:
    """Command line."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--samples", type=int, default=3)
    ap.add_argument("--form", action="store_true", help="also run FORM (minutes)")
    ap.add_argument("--limit", type=float, default=14e-6, help="X of dte_rms_max > X [m]")
    ap.add_argument("--mc", type=int, default=0, help="also crude Monte Carlo with N samples")
    ap.add_argument("--subset", type=int, default=0,
                    help="also subset simulation with N samples per level")
    args = ap.parse_args()
    warnings.simplefilter("ignore", category=UserWarning)
    if args.samples > 0:
        bench(args.samples)
    if args.form:
        form_check(args.limit)
    if args.mc:
        sampling_check("mc", args.limit, 7, f"Monte Carlo, {args.mc} samples",
                       n_samples=args.mc)
    if args.subset:
        sampling_check("subset", args.limit, 3,
                       f"subset simulation, {args.subset} per level", n_per_level=args.subset)


if __name__ == "__main__":
    main()
