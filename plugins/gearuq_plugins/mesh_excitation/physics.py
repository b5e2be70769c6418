"""Evaluation of the ``mesh_excitation`` model: one long-period LTCA per sample.

The contact grid and influence blocks depend only on the pair, the compliance and the
discretisation, so they are prepared once per model instance and option set
(:func:`gearuq.gears.ltca.ltca_setup`) and shared by every sample; a sample only builds its
clearances (pitch deviations, reliefs, crowning) and runs the compiled solver, which releases
the GIL, so samples run in threads.

With ``ltca_route="table"`` a sample's long period comes instead from a line-load table
(:func:`gearuq.gears.long_period.long_period_ltca`): one table per (positions per cycle,
points per line, designed modifications, torque level), cached on the model, so a sample
costs one scalar equation per position whatever ``lcm(z1, z2)``. The torque levels form a
ladder of ratio ``2**(1/4)``; a sample uses the table of the lowest level at or above its
torque, so its result does not depend on which other samples share its chunk.
"""

from __future__ import annotations

import math
import threading
from concurrent.futures import ThreadPoolExecutor
from dataclasses import replace
from typing import Any

import numpy as np

from gearuq.model import STATUS_MODEL_ERROR, STATUS_NONFINITE, Evaluation

#: Plugin status code: the LTCA solver did not converge at some mesh position.
STATUS_LTCA_NOT_CONVERGED = 16
#: Plugin status code (table route): a line's load left its tabulated valid range at some
#: mesh position (a short line loaded beyond the range of Weber's formula).
STATUS_TABLE_OUT_OF_RANGE = 17

#: Torque levels of the line-load tables: 2**(k / 4) N m (each level 19 % above the last).
TABLE_TORQUE_STEPS_PER_OCTAVE = 4

_TABLE_LOCK = threading.Lock()  # one table per key even when samples run in threads

_SCALARS = {
    "ste": ("ste_mean", "ste_ptp", 1e6),
    "lpms": ("lpms_mean", "lpms_ptp", 1e-6),
    "lpms_tangent": ("lpms_tangent_mean", "lpms_tangent_ptp", 1e-6),
    "cms": ("cms_mean", "cms_ptp", 1e6),
}
_TIME_UNITS = {"ste": 1e6, "lpms": 1e-6, "lpms_tangent": 1e-6, "cms": 1e6}
_SPECTRA = {"ste_spectrum": ("ste", 1e6), "lpms_tangent_spectrum": ("lpms_tangent", 1e-6)}


def order_table(
    n_cycles: int, z_shaft: int, n_mesh_orders: int, n_sidebands: int, positions_per_cycle: int
) -> tuple[np.ndarray, list[str], np.ndarray]:
    """Frequencies, labels and FFT bins of the reported orders.

    Over one long period of ``n_cycles`` mesh cycles sampled at ``positions_per_cycle``, FFT
    bin ``k`` is ``k / n_cycles`` mesh orders. Reported: the shaft orders ``i fs``
    (``i = 1..n_sidebands``, ``fs = 1/z_shaft`` mesh orders), then for every mesh order
    ``h = 1..n_mesh_orders`` the lower sidebands ``h fm - i fs``, ``h fm`` itself and the upper
    sidebands ``h fm + i fs``.

    Returns
    -------
    orders : ndarray
        Frequencies in mesh orders.
    labels : list of str
        ``"1fs"``, ``"1fm-2fs"``, ``"1fm"``, ``"1fm+1fs"``, ...
    bins : ndarray of int
        FFT bins.
    """
    if 2 * n_sidebands >= z_shaft:
        raise ValueError(f"n_sidebands={n_sidebands!r} is outside its valid range "
                         f"[0, {(z_shaft - 1) // 2}]: sidebands of neighbouring mesh orders "
                         f"would coincide (z={z_shaft})")
    top = n_mesh_orders + n_sidebands / z_shaft
    if 2 * top >= positions_per_cycle:
        raise ValueError(f"n_mesh_orders={n_mesh_orders!r} with n_sidebands={n_sidebands!r}: "
                         f"highest order {top:g} must stay below half the sampling rate "
                         f"(positions_per_cycle / 2 = {positions_per_cycle / 2:g})")
    per_shaft = n_cycles // z_shaft  # FFT bins per shaft order
    entries = [(i * per_shaft, f"{i}fs") for i in range(1, n_sidebands + 1)]
    for h in range(1, n_mesh_orders + 1):
        entries += [(h * n_cycles - i * per_shaft, f"{h}fm-{i}fs")
                    for i in range(n_sidebands, 0, -1)]
        entries.append((h * n_cycles, f"{h}fm"))
        entries += [(h * n_cycles + i * per_shaft, f"{h}fm+{i}fs")
                    for i in range(1, n_sidebands + 1)]
    bins = np.array([b for b, _ in entries], dtype=np.int64)
    return bins / n_cycles, [lab for _, lab in entries], bins


def order_amplitudes(signal: np.ndarray, bins: np.ndarray) -> np.ndarray:
    """Single-sided Fourier amplitudes ``2 |X_k| / N`` of a periodic signal at ``bins``."""
    spectrum = np.fft.rfft(signal)
    return 2.0 * np.abs(spectrum[bins]) / signal.size


def _prepared(model: Any, options: dict[str, Any], t: np.ndarray) -> dict[str, Any]:
    """Grids and influence blocks shared by all samples (cached on the model instance)."""
    from gearuq.gears.contact import long_period_cycles
    from gearuq.gears.ltca import ltca_setup

    ppc, n_pts = options["positions_per_cycle"], options["n_pts"]
    pair = model.pair
    n_cycles = long_period_cycles(pair)
    z_shaft = pair.z1 if options["sideband_shaft"] == "pinion" else pair.z2
    orders, labels, bins = order_table(n_cycles, z_shaft, options["n_mesh_orders"],
                                       options["n_sidebands"], ppc)
    key = ("grid", ppc, n_pts)
    if options["ltca_route"] == "full" and key not in model._cache:
        model._cache[key] = (
            ltca_setup(pair, compliance=model.compliance, positions_per_cycle=ppc,
                       n_pts=n_pts),
            ltca_setup(pair, compliance=model.compliance, positions_per_cycle=ppc, n_cycles=1,
                       n_pts=n_pts),
        )
    main, reference = model._cache.get(key, (None, None))
    # output instants: wrap into the long period; on the grid they are read off, otherwise
    # the LTCA is solved there too (exact, no interpolation)
    tau = np.mod(t, n_cycles)
    index = tau * ppc
    on_grid = bool(np.all(np.abs(index - np.round(index)) < 1e-9))
    extra = None
    if t.size and not on_grid:
        tkey = ("instants", n_pts, tau.tobytes())
        if tkey not in model._cache:
            model._cache[tkey] = ltca_setup(pair, compliance=model.compliance, tau=tau,
                                            n_pts=n_pts)
        extra = model._cache[tkey]
    if options["ltca_route"] == "table":
        main = reference = None  # the long period comes from line-load tables
    return {"main": main, "reference": reference, "extra": extra, "n_cycles": n_cycles,
            "route": options["ltca_route"], "n_pts": n_pts,
            "stage_relief": getattr(model, "stage_relief", None),
            "ppc": ppc, "grid_index": np.mod(np.round(index).astype(np.int64),
                                              n_cycles * ppc) if on_grid else None,
            "orders": orders, "labels": labels, "bins": bins}


def sample_deviations(pair: Any, values: dict[str, float], amplitude_reading: str,
                      pitch_model: str = "germ", pitch_harmonics: int | None = None) -> Any:
    """The :class:`FlankDeviations` of one sample (SI units inside).

    ``pitch_model="germ"``: the smooth expansion of the standard normals ``pitch_xi_p_*``,
    ``pitch_xi_g_*``; ``"seeded"``: the realisation of ``pitch_seed``.
    """
    from gearuq.gears.deviations import (
        FlankDeviations,
        cumulative_pitch_from_germ,
        cumulative_pitch_from_normals,
        iso1328_pitch_tolerances,
        pitch_deviation_germ,
        pitch_germ_from_values,
    )

    grade = int(values["iso_grade"])
    fp = []
    germ = (None if pitch_model == "germ" else
            pitch_deviation_germ(pair.z1, pair.z2, int(values["pitch_seed"])))
    for gear, z, d in ((1, pair.z1, pair.d1), (2, pair.z2, pair.d2)):
        if gear == 2 and "iso_grade_wheel" in values:  # a stage with per-gear classes
            grade = int(values["iso_grade_wheel"])
        if grade > 0:
            f_pT, F_pT = iso1328_pitch_tolerances(d, pair.mn, grade)
            amp, sigma, reading = 0.5 * F_pT, f_pT / (3.0 * math.sqrt(2.0)), "sine"
        else:
            # um -> m by division: 15 / 1e6 is the double nearest 15e-6 (15 * 1e-6 is not)
            amp, sigma = values["pitch_amplitude"] / 1e6, values["pitch_sigma"] / 1e6
            reading = amplitude_reading
        if germ is None:
            xi = pitch_germ_from_values(values, z, gear, pitch_harmonics)
            fp.append(cumulative_pitch_from_normals(xi, z, amplitude=amp, sigma=sigma))
        else:
            phase, normals = germ[2 * gear - 2], germ[2 * gear - 1]
            fp.append(cumulative_pitch_from_germ(phase, normals, amplitude=amp, sigma=sigma,
                                                 amplitude_reading=reading))
    tip = (values["tip_relief_amount"] / 1e6, values["tip_relief_length"] / 1e3)
    root = (values["root_relief_amount"] / 1e6, values["root_relief_length"] / 1e3)
    return FlankDeviations(Fp1=fp[0], Fp2=fp[1], tip_relief1=tip, tip_relief2=tip,
                           root_relief1=root, root_relief2=root,
                           crowning=values["crowning"] / 1e6)


def _check_germ(pair: Any, params: dict[str, np.ndarray], options: dict[str, Any]) -> None:
    """Refuse, before anything runs, a germ the kept harmonics cannot represent."""
    from gearuq.gears.deviations import pitch_germ_dimension, pitch_germ_from_values

    for gear, z in ((1, pair.z1), (2, pair.z2)):
        pitch_germ_dimension(z, options["pitch_harmonics"])  # range of the option
        if options["pitch_model"] == "germ":
            first = {k: float(v[np.argmax(v != 0)].item()) for k, v in params.items()
                     if k.startswith(("pitch_xi_p_", "pitch_xi_g_")) and np.any(v != 0)}
            pitch_germ_from_values(first, z, gear, options["pitch_harmonics"])


def _one_sample(prep: dict[str, Any], pair: Any, values: dict[str, float],
                reading: str, pitch_model: str = "germ", pitch_harmonics: int | None = None
                ) -> tuple[dict[str, np.ndarray], int]:
    """Long-period LTCA of one sample: per-position series, scalars, spectra, status."""
    from gearuq.gears.ltca import ltca_solve, mesh_summaries, normal_force_from_torque

    main, reference = prep["main"], prep["reference"]
    dev = sample_deviations(pair, values, reading, pitch_model, pitch_harmonics)
    if prep["stage_relief"] is not None:  # a stage's reliefs: any shape, per gear
        dev = replace(dev, user=prep["stage_relief"](values))
    P = normal_force_from_torque(pair, values["torque"])
    sol = ltca_solve(main, P, main.clearance(dev))
    # the design pattern keeps the designed modifications, a stage's relief map included
    # (design_only() alone drops the map and would count its relief as contact loss)
    ref = ltca_solve(reference, P, reference.clearance(replace(dev.design_only(), user=dev.user)))
    ppc = prep["ppc"]
    pattern = (ref.force > 0.0)[np.arange(sol.force.shape[0]) % ppc]
    summ = mesh_summaries(main, sol, pattern)
    out: dict[str, np.ndarray] = {}
    for name, (mean, ptp, unit) in _SCALARS.items():
        out[mean] = np.float64(summ[name].mean() * unit)
        out[ptp] = np.float64(np.ptp(summ[name]) * unit)
    loss = summ["contact_loss_fraction"]
    from gearuq.gears.ltca import PARTIAL_LOSS_THRESHOLD

    out["contact_loss_fraction"] = np.float64((loss > PARTIAL_LOSS_THRESHOLD).mean())
    out["unloaded_share_max"] = np.float64(loss.max())
    for name, (series, unit) in _SPECTRA.items():
        out[name] = order_amplitudes(summ[series] * unit, prep["bins"])
    status = 0 if (sol.status.max() == 0 and ref.status.max() == 0) else STATUS_LTCA_NOT_CONVERGED
    if prep["extra"] is not None:
        series_t, converged = _off_grid_series(prep["extra"], P, dev)
        out.update(series_t)
        if not converged:
            status = STATUS_LTCA_NOT_CONVERGED
    else:
        for name, unit in _TIME_UNITS.items():
            out[name] = summ[name][prep["grid_index"]] * unit
    return out, status


def _off_grid_series(extra: Any, force: float, dev: Any) -> tuple[dict[str, np.ndarray], bool]:
    """Time outputs at the instants off the cycle grid: the full LTCA at those alone (both
    routes); and whether it converged."""
    from gearuq.gears.ltca import ltca_solve, mesh_summaries

    sol = ltca_solve(extra, force, extra.clearance(dev))
    summ = mesh_summaries(extra, sol)
    return ({name: summ[name] * unit for name, unit in _TIME_UNITS.items()},
            bool(sol.status.max() == 0))


def table_torque(torque: float) -> float:
    """Torque level [N m] of the line-load table serving ``torque``: the lowest
    ``2**(k / TABLE_TORQUE_STEPS_PER_OCTAVE)`` at or above it."""
    if not (math.isfinite(torque) and torque > 0.0):
        raise ValueError(f"torque={torque!r} is outside its valid range (0, inf) N m")
    steps = TABLE_TORQUE_STEPS_PER_OCTAVE
    level = 2.0 ** (math.ceil(math.log2(torque) * steps - 1e-12) / steps)
    return level if level >= torque else level * 2.0 ** (1.0 / steps)


def _table(model: Any, prep: dict[str, Any], design: Any, values: dict[str, float]) -> Any:
    """The cached line-load table of this sample's designed modifications and torque level."""
    from gearuq.gears.long_period import LongPeriodSettings, line_load_table

    stage_keys = () if prep["stage_relief"] is None else tuple(
        values[f"{k}_relief_amount"] for k in prep["stage_relief"].keys)
    level = table_torque(values["torque"])
    key = ("table", prep["ppc"], prep["n_pts"], level, design.tip_relief1, design.root_relief1,
           design.crowning, stage_keys)
    with _TABLE_LOCK:
        if key not in model._cache:
            model._cache[key] = line_load_table(
                model.pair, max_torque=level, modifications=design,
                compliance=model.compliance,
                settings=LongPeriodSettings(positions_per_cycle=prep["ppc"],
                                            n_pts=prep["n_pts"]))
        return model._cache[key]


def _one_sample_table(model: Any, prep: dict[str, Any], values: dict[str, float],
                      reading: str, pitch_model: str = "germ",
                      pitch_harmonics: int | None = None) -> tuple[dict[str, np.ndarray], int]:
    """Long period of one sample from a line-load table: the outputs of :func:`_one_sample`."""
    from gearuq.gears.long_period import long_period_ltca

    pair = model.pair
    dev = sample_deviations(pair, values, reading, pitch_model, pitch_harmonics)
    design = dev.design_only()
    if prep["stage_relief"] is not None:  # a stage's reliefs: the same map on every tooth
        design = replace(design, user=prep["stage_relief"](values))
    table = _table(model, prep, design, values)
    # the table's own map object, so the route sees the modifications it was built for
    dev = replace(dev, user=table.modifications.user)
    ds = long_period_ltca(pair, dev, torque=values["torque"], table=table, keep_lines=False)
    series = {name: ds[name].values for name in _TIME_UNITS}  # um and N/um already
    out: dict[str, np.ndarray] = {}
    for name, (mean, ptp, _) in _SCALARS.items():
        out[mean] = np.float64(series[name].mean())
        out[ptp] = np.float64(np.ptp(series[name]))
    loss = ds["contact_loss_fraction"].values
    out["contact_loss_fraction"] = np.float64(ds["partial_contact_loss"].values.mean())
    out["unloaded_share_max"] = np.float64(loss.max())
    for name, (source, _) in _SPECTRA.items():
        out[name] = order_amplitudes(series[source], prep["bins"])
    worst = int(ds["status"].values.max())
    status = 0 if worst == 0 else (STATUS_TABLE_OUT_OF_RANGE if worst == 2
                                   else STATUS_LTCA_NOT_CONVERGED)
    if prep["extra"] is not None:  # instants off the grid: the full LTCA at those alone
        from gearuq.gears.ltca import normal_force_from_torque

        full_dev = replace(dev, user=prep["stage_relief"](values)) \
            if prep["stage_relief"] is not None else dev
        series_t, converged = _off_grid_series(
            prep["extra"], normal_force_from_torque(pair, values["torque"]), full_dev)
        out.update(series_t)
        if not converged:
            status = STATUS_LTCA_NOT_CONVERGED
    else:
        for name in _TIME_UNITS:
            out[name] = series[name][prep["grid_index"]]
    return out, status


def evaluate(model: Any, params: dict[str, np.ndarray], t: np.ndarray, outputs: list[str],
             **options: Any) -> Evaluation:
    """Evaluate ``outputs`` for every sample (threads over samples)."""
    prep = _prepared(model, options, t)
    _check_germ(model.pair, params, options)
    n = next(iter(params.values())).shape[0]
    shapes = {o.name: (n, t.size) if o.time_dependent else
              (n, len(prep["labels"])) if "order" in o.dims else (n,) for o in model.outputs}
    data = {k: np.full(shapes[k], np.nan) for k in outputs}
    status = np.zeros(n, dtype=np.int8)
    errors: dict[int, str] = {}

    def run(i: int) -> None:
        values = {k: float(v[i]) for k, v in params.items()}
        try:
            if prep["route"] == "table":
                res, code = _one_sample_table(model, prep, values,
                                              options["amplitude_reading"],
                                              options["pitch_model"], options["pitch_harmonics"])
            else:
                res, code = _one_sample(prep, model.pair, values, options["amplitude_reading"],
                                        options["pitch_model"], options["pitch_harmonics"])
        except (ValueError, ArithmeticError, np.linalg.LinAlgError) as exc:
            status[i] = STATUS_MODEL_ERROR  # flagged, outputs stay NaN
            errors[i] = f"{type(exc).__name__}: {exc}"
            return
        for k in outputs:
            data[k][i] = res[k]
        finite = all(np.all(np.isfinite(res[k])) for k in outputs)
        status[i] = code if finite else STATUS_NONFINITE

    if n > 0:
        run(0)  # compiles (or loads) the kernel once before any thread starts
    threads = min(int(options["threads"]), max(n - 1, 1))
    if threads > 1 and n > 2:
        with ThreadPoolExecutor(max_workers=threads) as pool:
            list(pool.map(run, range(1, n)))
    else:
        for i in range(1, n):
            run(i)
    coords = {"order": (("order",), prep["orders"], {"units": "mesh orders",
                                                      "long_name": "frequency in mesh orders"}),
              "order_label": (("order",), np.array(prep["labels"]),
                              {"long_name": "fs: shaft order, fm: mesh order"})}
    needs_order = any("order" in model.output(k).dims for k in outputs)
    attrs = {"positions_per_cycle": options["positions_per_cycle"],
             "n_pts": options["n_pts"], "long_period_mesh_cycles": prep["n_cycles"],
             "coupling_length_m": float(model.compliance.coupling_length),
             "sideband_shaft": options["sideband_shaft"],
             "amplitude_reading": options["amplitude_reading"],
             "ltca_route": options["ltca_route"]}
    if errors:
        attrs["sample_errors"] = "; ".join(f"sample {i}: {m}" for i, m in sorted(errors.items()))
    return Evaluation(data=data, status=status,
                      status_meanings={STATUS_LTCA_NOT_CONVERGED: "ltca_not_converged",
                                       STATUS_TABLE_OUT_OF_RANGE: "line_load_beyond_table"},
                      coords=coords if needs_order else {}, attrs=attrs)
