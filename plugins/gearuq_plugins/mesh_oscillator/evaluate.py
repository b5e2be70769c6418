"""Assembly of the ``mesh_oscillator`` outputs: frequency responses, expansion, time responses.

Each group is computed only when one of its outputs is asked for; the frequency responses
need no ``t`` (their grid is the ``frequency`` coordinate, set by options).

EP: Eritenel and Parker (2013), the paper this model follows (docs/models.md).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from gearuq.model import Evaluation
from gearuq_plugins.mesh_oscillator import slowflow as sf
from gearuq_plugins.mesh_oscillator.model import (
    _EXPANSION_OUTPUTS,
    _PERTURBATION_ONLY,
    _TIME_OUTPUTS,
    BRANCHES,
    STATUS_CURVE,
    STATUS_FORCE_PEAK,
    STATUS_MEANINGS,
    STATUS_REASONS,
    STATUS_SEPARATION,
    STATUS_UNSETTLED,
    MeshOscillator,
    System,
)

_FREQUENCY_OUTPUTS = {
    "amplitude_up", "amplitude_down", "separation_up", "separation_down", "region_up",
    "region_down", "linear_amplitude", "branch_amplitude", "branch_phase", "branch_stable",
    "n_branches", "peak_amplitude", "peak_frequency_ratio", "dte_amplitude_up",
    "dte_amplitude_down", "peak_dte_amplitude",
}


def frequency_values(options: dict[str, Any]) -> np.ndarray:
    """The frequency grid of the options (explicit, or min/max/n)."""
    if options["frequencies"] is not None:
        return np.asarray(options["frequencies"], dtype=float)
    lo, hi, k = options["frequency_min"], options["frequency_max"], options["n_frequencies"]
    if k > 1 and not hi > lo:
        raise ValueError(f"frequency_max={hi!r} must exceed frequency_min={lo!r}")
    return np.linspace(lo, hi, k) if k > 1 else np.array([lo])


def omega_grid(model: MeshOscillator, system: System, values: np.ndarray,
               units: str) -> np.ndarray:
    """Nondimensional grid ``Omega`` per sample, shape (n, K)."""
    n = system.mu.size
    if units == "ratio":
        return np.broadcast_to(values, (n, values.size)).copy()
    if not model.dimensional:
        raise ValueError("frequency_units='Hz' needs a dimensional model (MeshOscillator("
                         "force=...)); valid here: 'ratio'")
    wn = system.expansion.natural_frequency
    return 2.0 * math.pi * values[None, :] / wn[:, None]


def linear_amplitude(coefs: np.ndarray, omega: np.ndarray) -> np.ndarray:
    """Amplitude of the linear time-invariant response of Eq. 11 (only alpha_{1,0} = 1)."""
    q = coefs[:, sf.C_Q1, None] * omega ** coefs[:, sf.C_QEXP, None]
    force = q * np.exp(-1j * coefs[:, sf.C_R1, None]) - coefs[:, sf.C_A01, None]
    with np.errstate(divide="ignore", invalid="ignore"):  # undamped at resonance: inf
        return np.abs(force / (1.0 - omega**2 + 2j * coefs[:, sf.C_MU, None] * omega))


def backbone_shift(coefs: np.ndarray, amplitude: np.ndarray) -> np.ndarray:
    """Shift of the natural frequency by the stiffness nonlinearity at amplitude ``a`` (the
    second-order backbone): ``(3/8 alpha_{3,0} - 5/12 alpha_{2,0}^2) a^2``, shape of
    ``amplitude`` (n, K). Zero when ``alpha_{2,0} = alpha_{3,0} = 0``."""
    kappa = 0.375 * coefs[:, sf.C_A30] - (5.0 / 12.0) * coefs[:, sf.C_A20] ** 2
    return kappa[:, None] * amplitude**2


def regions(amplitude: np.ndarray, separation: np.ndarray, coefs: np.ndarray,
            omega: np.ndarray, tolerance: float, onset: float) -> np.ndarray:
    """Response regions of EP Fig. 4 (docs/theory/mesh_oscillator.md, section 9).

    1: in contact, the stiffness nonlinearity engaged by the vibration changes the linear
    amplitude by at most ``tolerance``; 2: in contact, by more (nonlinear stiffness,
    partial contact loss); 3: total contact loss starting (at most ``onset`` of the period
    out of contact); 4: developed total contact loss.

    Regions 1 and 2 are judged by the system, not by the distance of the solution from the
    exact linear amplitude (which would count the approximation error of a perturbation
    solution as nonlinearity): the linear system whose natural frequency is the backbone
    frequency ``1 + delta(a)`` at the response amplitude (:func:`backbone_shift`) is
    compared with the linear system, at the same frequency and forcing. Without quadratic
    and cubic stiffness ``delta = 0`` and region 2 does not exist (as in the seed).
    """
    om = np.asarray(omega, dtype=float)
    mu = coefs[:, sf.C_MU, None]
    shifted = (1.0 + backbone_shift(coefs, np.nan_to_num(amplitude))) ** 2
    lin = np.abs(1.0 - om**2 + 2j * mu * om)
    equivalent = np.abs(shifted - om**2 + 2j * mu * om)
    with np.errstate(divide="ignore", invalid="ignore"):
        dev = np.abs(lin / equivalent - 1.0) > tolerance
    reg = np.where(dev, 2, 1)
    reg = np.where(separation > 0.0, 3, reg)
    return np.where(separation > onset, 4, reg).astype(np.int8)


#: Deflection points (per sample, over ``0 < u <= u_top``) at which the tangent stiffness is
#: checked for the force maximum, and the reach checked after a failed sweep (units of d).
N_PEAK_CHECK = 48
FAILED_SWEEP_REACH = 5.0


def peak_top(amplitude: np.ndarray, coefs: np.ndarray) -> np.ndarray:
    """Largest deflection ``u`` of the first-order solution (Eq. 28 at ``psi = 0``, where the
    fundamental peaks): ``a - alpha_{2,0} a^2 / 3 + alpha_{3,0} a^3 / 32``, shape of
    ``amplitude`` (n, K)."""
    a20 = coefs[:, sf.C_A20, None]
    a30 = coefs[:, sf.C_A30, None]
    return amplitude - a20 * amplitude**2 / 3.0 + a30 * amplitude**3 / 32.0


def beyond_force_maximum(model: MeshOscillator, system: System,
                         u_top: np.ndarray) -> np.ndarray:
    """Whether the tangent stiffness ``df/dx`` drops to 0 or below anywhere on
    ``x_m < x <= x_m + d u_top`` (any mesh phase), per sample.

    Beyond the maximum of the force-deflection function the restoring force decreases with
    the deflection: the expansion about ``x_m`` and the steady states of the multiple-scales
    solution are meaningless there, and a time integration may escape (step-size
    underflow). Dimensional models check the exact force; the nondimensional model its
    series ``sum_i i alpha_i(theta) u^(i-1)``.
    """
    n = system.mu.size
    top = np.where(np.isfinite(u_top), u_top, 0.0)
    out = np.zeros(n, dtype=bool)
    live = np.flatnonzero(top > 0.0)
    if live.size == 0:
        return out
    frac = np.arange(1, N_PEAK_CHECK + 1) / N_PEAK_CHECK
    u = top[live, None] * frac[None, :]  # (m, N)
    if model.dimensional:
        from gearuq_plugins.mesh_oscillator.expansion import _phases

        ex = system.expansion
        phase = _phases(model.force)
        x = ex.mean_deflection[live, None] + ex.scale[live, None] * u
        x = np.broadcast_to(x[:, None, :], (live.size, phase.size, N_PEAK_CHECK))
        values = (None if system.values is None
                  else {k: v[live] for k, v in system.values.items()})
        tangent = model.force.derivatives(np.ascontiguousarray(x), phase, 1, values)[1]
    else:
        theta = 2.0 * np.pi * np.arange(16) / 16.0
        alpha, phi = system.alpha[live], system.phi[live]
        tangent = np.zeros((live.size, theta.size, N_PEAK_CHECK))
        for i in range(1, alpha.shape[1]):
            coef = alpha[:, i, 0, None] + sum(
                alpha[:, i, r, None] * np.cos(r * theta[None, :] - phi[:, i, r, None])
                for r in range(1, alpha.shape[2]))
            tangent += i * coef[:, :, None] * u[:, None, :] ** (i - 1)
    out[live] = (tangent <= 0.0).any(axis=(1, 2))
    return out


def _branches(res: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Lower / middle / upper branch (by amplitude) of every grid point."""
    amp = np.where(np.isnan(res.amplitude), np.inf, res.amplitude)
    order = np.argsort(amp, axis=2)
    count = np.maximum(res.count, 1)
    pick = np.stack([np.zeros_like(count), count // 2, count - 1], axis=2)
    idx = np.take_along_axis(order, pick, axis=2)
    take = [np.take_along_axis(x, idx, axis=2) for x in (res.amplitude, res.phase,
                                                           res.stable)]
    return take[0], take[1], take[2]


def _perturbation(model, system, grids, options, out, extra, coords, status):
    from gearuq_plugins.mesh_oscillator.perturbation import frequency_response

    coefs = system.coefficients()
    res = frequency_response(coefs, grids, order=options["order"],
                             separation=options["separation"])
    bad = ~np.isin(res.status, (0, 4))  # ok or unforced
    status[bad] = STATUS_CURVE
    for which in ("up", "down"):
        out[f"amplitude_{which}"] = res.path(which)
        out[f"separation_{which}"] = np.maximum(-res.path(which, "separation")[..., sf.S_D0],
                                                0.0)
    worst = np.fmax(np.nanmax(out["separation_up"], axis=1, initial=0.0),
                    np.nanmax(out["separation_down"], axis=1, initial=0.0))
    status[(status == 0) & (worst > options["max_separation"])] = STATUS_SEPARATION
    top = np.fmax(np.nanmax(peak_top(out["amplitude_up"], coefs), axis=1, initial=-np.inf),
                  np.nanmax(peak_top(out["amplitude_down"], coefs), axis=1, initial=-np.inf))
    status[np.isin(status, (0, STATUS_CURVE, STATUS_SEPARATION))
           & beyond_force_maximum(model, system, top)] = STATUS_FORCE_PEAK
    out["branch_amplitude"], out["branch_phase"], stable = _branches(res)
    out["branch_stable"] = stable.astype(np.int8)
    out["n_branches"] = res.count.astype(np.int16)
    onset = res.onsets[:, :, 0]
    first = np.where(res.n_onsets > 0, onset[:, 0], np.nan)
    last = np.take_along_axis(onset, np.maximum(res.n_onsets - 1, 0)[:, None], 1)[:, 0]
    last = np.where(res.n_onsets > 0, last, np.nan)
    coords["onset"] = ("onset", ["first", "last"], {"long_name": "onset of contact loss "
                                                    "along the response curve"})
    extra["onset_frequency_ratio"] = (("sample", "onset"), np.stack([first, last], axis=1),
                                      {"units": "1", "long_name": "Omega where total contact "
                                       "loss starts or ends on the traced curve (NaN: none)"})
    extra["trace_points"] = ("sample", res.n_points, {"units": "1",
                                                      "long_name": "points of the traced "
                                                      "response curve"})
    losses = np.stack([res.path(w, "separation")[..., sf.S_LOSSES] for w in ("up", "down")])
    losses = np.where(np.isnan(losses), 0.0, losses).max(axis=(0, 2))
    extra["contact_losses_per_period"] = ("sample", losses, {
        "units": "1", "long_name": "largest number of contact losses per period on the "
        "sweep paths (the closed-form separation assumes at most one)"})


def settle_schedule(mu: np.ndarray, omega_max: np.ndarray, options: dict[str, Any],
                    status: np.ndarray) -> np.ndarray:
    """Settle periods per sample, capped at ``max_settle_periods``.

    Without damping (or with very little) a transient never decays: the estimate
    ``ln(1/tol) Omega / (2 pi mu)`` is infinite (about 1.3 million periods per frequency
    with the floor mu = 1e-6), so the settle time is capped and the samples whose transient
    cannot decay within the cap are flagged (:data:`STATUS_UNSETTLED`).
    """
    from gearuq_plugins.mesh_oscillator import sweeps

    n = mu.size
    cap = options["max_settle_periods"]
    if options["settle_periods"] is not None:
        wanted = np.full(n, options["settle_periods"], dtype=np.int64)
        short = mu <= 0.0
    else:
        wanted = sweeps.settle_periods(mu, omega_max, options["settle_tolerance"])
        short = (mu <= 0.0) | (wanted > cap)
    status[(status == 0) & short] = STATUS_UNSETTLED
    return np.minimum(wanted, cap)


def _sweep(model, system, grids, params, options, out, extra, status):
    from gearuq_plugins.mesh_oscillator import sweeps
    from gearuq_plugins.mesh_oscillator.timedomain import initial_linear, time_problem

    n = grids.shape[0]
    problem = time_problem(model, system, options)
    settle = settle_schedule(system.mu, grids.max(axis=1), options, status)
    rows = np.vstack([problem.rows, problem.rows])
    both = sweeps.OscillatorProblem(problem.kind, rows, problem.n_switch)
    omegas = np.vstack([grids, grids[:, ::-1]])
    coefs = system.coefficients()
    y0 = np.vstack([initial_linear(coefs, grids[:, 0]), initial_linear(coefs, grids[:, -1])])
    res = sweeps.integrate_schedule(both, omegas, np.concatenate([settle, settle]),
                                    options["measure_periods"], options["points_per_period"],
                                    y0, rtol=options["rtol"], atol=options["atol"],
                                    method=options["ode_method"])
    st = np.maximum(res.status[:n], res.status[n:])
    status[st != 0] = st[st != 0]
    # deflection beyond the force maximum: reached by a measured sample, or the likely cause
    # of a failed integration (escape) when the force has a maximum within reach
    with np.errstate(invalid="ignore"):
        top = np.nanmax(np.where(np.isfinite(res.samples), res.samples, -np.inf)
                        .reshape(2, n, -1), axis=(0, 2))
    top = np.where(st != 0, np.fmax(top, FAILED_SWEEP_REACH), top)
    status[beyond_force_maximum(model, system, top)] = STATUS_FORCE_PEAK
    out["amplitude_up"] = res.amplitude[:n]
    out["amplitude_down"] = res.amplitude[n:, ::-1]
    out["separation_up"] = res.separation[:n]
    out["separation_down"] = res.separation[n:, ::-1]
    spread = np.maximum(res.unsettled[:n], res.unsettled[n:, ::-1])
    extra["sweep_unsettled"] = (("sample", "frequency"), spread, {
        "units": "1", "long_name": "spread of the per-period amplitudes over the measured "
        "periods / amplitude (transient left)"})
    extra["ode_steps"] = ("sample", res.n_steps[:n] + res.n_steps[n:],
                          {"units": "1", "long_name": "accepted integrator steps, both sweeps"})
    extra["contact_margin_up"] = (("sample", "frequency"), res.margin[:n], {
        "units": "1", "long_name": "smallest u - u_c over a period, upward sweep"})
    extra["contact_margin_down"] = (("sample", "frequency"), res.margin[n:, ::-1], {
        "units": "1", "long_name": "smallest u - u_c over a period, downward sweep"})


def _frequency_block(model, system, params, outputs, options, out, extra, coords, status):
    values = frequency_values(options)
    grids = omega_grid(model, system, values, options["frequency_units"])
    coords["frequency"] = ("frequency", values, {
        "units": "1" if options["frequency_units"] == "ratio" else "Hz",
        "long_name": "mesh frequency / natural frequency" if options["frequency_units"]
        == "ratio" else "mesh frequency"})
    coords["branch"] = ("branch", list(BRANCHES), {})
    if options["method"] == "perturbation":
        _perturbation(model, system, grids, options, out, extra, coords, status)
    else:
        wanted = sorted(_PERTURBATION_ONLY & set(outputs))
        if wanted:
            raise ValueError(f"outputs {wanted} need method='perturbation' (a time "
                             "integration finds only the stable response it lands on)")
        _sweep(model, system, grids, params, options, out, extra, status)
    coefs = system.coefficients()
    lin = linear_amplitude(coefs, grids)
    out["linear_amplitude"] = lin
    for which in ("up", "down"):
        out[f"region_{which}"] = regions(out[f"amplitude_{which}"], out[f"separation_{which}"],
                                         coefs, grids, options["region_tolerance"],
                                         options["onset_separation"])
    best = np.fmax(out["amplitude_up"], out["amplitude_down"])
    k = np.nanargmax(np.where(np.isnan(best), -np.inf, best), axis=1)
    out["peak_amplitude"] = best[np.arange(best.shape[0]), k]
    out["peak_frequency_ratio"] = grids[np.arange(best.shape[0]), k]
    if model.dimensional:
        d = system.expansion.scale
        out["dte_amplitude_up"] = out["amplitude_up"] * d[:, None]
        out["dte_amplitude_down"] = out["amplitude_down"] * d[:, None]
        out["peak_dte_amplitude"] = out["peak_amplitude"] * d


def _expansion_block(system, options, out, coords):
    ex = system.expansion
    out.update({
        "mean_deflection": ex.mean_deflection, "deflection_scale": ex.scale,
        "natural_frequency": ex.natural_frequency, "mesh_stiffness": ex.stiffness,
        "secant_stiffness": ex.secant_stiffness, "expansion_error": ex.error,
        "alpha": ex.alpha, "alpha_phase": ex.phi,
    })
    coords["order"] = ("order", np.arange(ex.alpha.shape[1]), {"long_name": "Taylor order i"})
    coords["harmonic"] = ("harmonic", np.arange(ex.alpha.shape[2]),
                          {"long_name": "Fourier harmonic r"})


def evaluate(model: MeshOscillator, params: dict[str, np.ndarray], t: np.ndarray,
             outputs: list[str], options: dict[str, Any]) -> Evaluation:
    """Compute the requested outputs of every sample (see :mod:`.model`)."""
    from gearuq_plugins.mesh_oscillator.timedomain import time_block

    n = next(iter(params.values())).shape[0]
    system = model.system(params, options)
    out: dict[str, np.ndarray] = {}
    extra: dict[str, tuple] = {}
    coords: dict[str, tuple] = {}
    status = np.zeros(n, dtype=np.int8)
    attrs: dict[str, Any] = {"model_settings": model.settings(),
                             "nondimensionalisation": "Eritenel and Parker (2013) Eqs. 11-14, "
                             "docs/theory/mesh_oscillator.md"}
    if _FREQUENCY_OUTPUTS & set(outputs):
        _frequency_block(model, system, params, outputs, options, out, extra, coords, status)
    if model.dimensional and (_EXPANSION_OUTPUTS & set(outputs)):
        _expansion_block(system, options, out, coords)
    if _TIME_OUTPUTS & set(outputs):
        time_block(model, system, params, t, outputs, options, out, extra, status)
    if model.dimensional:
        attrs["expansion_method"] = system.expansion.method
    reasons = [f"{k}: {v}" for k, v in STATUS_REASONS.items() if np.any(status == k)]
    if reasons:
        attrs["status_reasons"] = "; ".join(reasons)
    return Evaluation(data={k: out[k] for k in outputs}, status=status,
                      status_meanings=STATUS_MEANINGS, coords=coords, attrs=attrs,
                      extra=extra)
