"""``linear_oscillator``: damped SDOF oscillator under harmonic force, solved in closed form.

    m x'' + c x' + k x = F cos(omega t),   x(0) = x0,  x'(0) = v0

The exact response (transient + steady state) makes this plugin the oracle of every engine
test: any output at any instant is an explicit function of the random inputs.
See docs/theory/linear_oscillator.md.
"""

from __future__ import annotations

import numpy as np

from gearuq.model import Evaluation, Model, Output, Parameter, bounded_below

__all__ = ["LinearOscillator", "steady_state", "closed_form"]


def steady_state(m, k, c, force, omega):
    """Steady-state amplitude X and phase lag phi of ``X cos(omega t - phi)``.

    Parameters
    ----------
    m, k, c, force, omega : array_like
        Mass [kg], stiffness [N/m], damping [N s/m], force amplitude [N], frequency [rad/s].

    Returns
    -------
    amplitude, phase : ndarray
        ``|F| / sqrt((k - m omega^2)^2 + (c omega)^2)`` [m] and the lag [rad] (of the signed
        force, so a negative F gives a phase shifted by pi).
    """
    m, k, c, force, omega = np.broadcast_arrays(*map(np.asarray, (m, k, c, force, omega)))
    re = k - m * omega**2
    im = c * omega
    amplitude = np.abs(force) / np.hypot(re, im)
    phase = np.arctan2(im, re) + np.where(force < 0, np.pi, 0.0)
    return amplitude, phase


def closed_form(m, k, c, force, omega, x0, v0, t):
    """Exact displacement and velocity, shape ``(n_samples, n_time)``.

    The homogeneous part is written as ``exp(-a t) [u0 C(t) + (w0 + a u0) S(t)]`` with
    ``C = cos(wd t)``, ``S = sin(wd t)/wd`` and complex ``wd`` so one expression covers
    under-, critically and over-damped cases (``S -> t`` as ``wd -> 0``).
    """
    m, k, c, force, omega, x0, v0 = (np.asarray(a, float)[:, None] for a in (
        m, k, c, force, omega, x0, v0))
    t = np.asarray(t, float)[None, :]
    amp, phase = steady_state(m, k, c, force, omega)
    xp = amp * np.cos(omega * t - phase)
    vp = -amp * omega * np.sin(omega * t - phase)
    # initial values of the homogeneous part
    u0 = x0 - amp * np.cos(-phase)
    w0 = v0 + amp * omega * np.sin(-phase)
    a = c / (2.0 * m)
    wd = np.sqrt((k / m - a**2).astype(complex))
    wt = wd * t
    small = np.abs(wd) < 1e-12
    wd_safe = np.where(small, 1.0, wd)
    cos_t = np.cos(wt).real
    sin_over = np.where(small, t, (np.sin(wt) / wd_safe)).real
    # derivative of S is C, derivative of C is -wd^2 S
    wd2 = (wd**2).real
    decay = np.exp(-a * t)
    b = w0 + a * u0
    xh = decay * (u0 * cos_t + b * sin_over)
    vh = decay * (-a * (u0 * cos_t + b * sin_over) + (-u0 * wd2 * sin_over + b * cos_t))
    return xh + xp, vh + vp


class LinearOscillator(Model):
    """Damped single-degree-of-freedom oscillator under a harmonic force (closed form)."""

    name = "linear_oscillator"
    description = "damped SDOF oscillator under harmonic force, exact closed-form response"
    version = "1.0"
    time_units = "s"
    parameters = (
        Parameter("m", "kg", 1.0, 1e-9, 1e9, "mass"),
        Parameter("k", "N m-1", 1.0e4, 1e-9, 1e15, "stiffness"),
        Parameter("c", "N s m-1", 20.0, 0.0, 1e12, "viscous damping coefficient"),
        Parameter("force", "N", 10.0, -1e12, 1e12, "harmonic force amplitude F"),
        Parameter("omega", "rad s-1", 80.0, 0.0, 1e9, "forcing circular frequency"),
        Parameter("x0", "m", 0.0, -1e6, 1e6, "initial displacement"),
        Parameter("v0", "m s-1", 0.0, -1e9, 1e9, "initial velocity"),
    )
    outputs = bounded_below((
        Output("displacement", "m", ("sample", "time"), "displacement x(t)"),
        Output("velocity", "m s-1", ("sample", "time"), "velocity x'(t)"),
        Output("steady_amplitude", "m", ("sample",), "steady-state displacement amplitude"),
        Output("natural_frequency", "rad s-1", ("sample",), "undamped natural frequency"),
        Output("damping_ratio", "1", ("sample",), "damping ratio c / (2 sqrt(k m))"),
    ), ["steady_amplitude", "natural_frequency", "damping_ratio"])

    def _evaluate(self, params, t, outputs, **options):
        p = params
        data: dict[str, np.ndarray] = {}
        if {"displacement", "velocity"} & set(outputs):
            x, v = closed_form(p["m"], p["k"], p["c"], p["force"], p["omega"], p["x0"], p["v0"], t)
            data["displacement"], data["velocity"] = x, v
        data["steady_amplitude"] = steady_state(p["m"], p["k"], p["c"], p["force"], p["omega"])[0]
        data["natural_frequency"] = np.sqrt(p["k"] / p["m"])
        data["damping_ratio"] = p["c"] / (2.0 * np.sqrt(p["k"] * p["m"]))
        n = p["m"].shape[0]
        status = np.zeros(n, dtype=np.int8)
        for name in outputs:
            finite = np.isfinite(data[name].reshape(n, -1)).all(axis=1)
            status[~finite] = 3
        return Evaluation(data={k: data[k] for k in outputs}, status=status)
