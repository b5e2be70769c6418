"""Taylor-Fourier expansion of the force-deflection function and the nondimensional system.

Eritenel and Parker (2013) Eqs. 3-14, re-derived in docs/theory/mesh_oscillator.md:

1. mean deflection ``x_m``: ``mean_phase f(x_m, phase) = F_0`` (Eq. 4; ``f`` increasing in
   ``x``, so the root is unique and bracketed);
2. Taylor coefficients ``B_i(phase) = (1/i!) d^i f/dx^i (x_m, phase)`` (Eq. 3), or, for
   kinked functions (tables, several contact segments), the coefficients of the
   least-squares polynomial of the same order over the vibration window
   ``|x - x_m| <= w d`` in contact, constrained through ``f(x_m)`` so that the mean of
   ``B_0`` is still ``F_0`` (the elimination of ``F_0`` in Eq. 9 needs it);
3. Fourier series ``B_i = beta_{i,0} + sum_r beta_{i,r} cos(r xi t - Phi_{i,r})`` (Eq. 5) and
   ``g = g_0 + sum_r g_r cos(r xi t - Psi_r)`` (Eq. 10);
4. nondimensional parameters (Eq. 13): ``d = x_m - g_0``, ``omega_n^2 = beta_{1,0} / m``,
   ``alpha_{i,r} = beta_{i,r} d^{i-1} / beta_{1,0}``, ``e_r = g_r / d``,
   ``q_r = F_r / (d beta_{1,0})``, and phases relative to the first excitation harmonic,
   ``phi_{i,r} = Phi_{i,r} - r Phi_{0,1}`` (Eq. 14 prints ``- Phi_{0,1}`` for every ``r``;
   a time shift moves the ``r``-th harmonic by ``r`` times the first one's phase).

The expansion error is the largest difference between ``f`` and its truncated series over
the vibration window in contact, relative to the mean load ``F_0``.

EP: Eritenel and Parker (2013), the paper this model follows (docs/models.md).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from gearuq_plugins.mesh_oscillator import slowflow as sf
from gearuq_plugins.mesh_oscillator.forces import ForceDeflection

#: Phase samples per mesh cycle for analytic force-deflection functions.
N_PHASE = 64
#: Deflection samples of the fit window and of the expansion-error check.
N_WINDOW = 41


@dataclass
class Expansion:
    """Expansion of the force-deflection function of ``n`` samples.

    Attributes
    ----------
    mean_deflection, scale, unloaded_mean : ndarray (n,)
        ``x_m``, ``d = x_m - g_0`` and ``g_0`` [m].
    stiffness : ndarray (n,)
        Mean tangent mesh stiffness ``beta_{1,0}`` [N/m].
    secant_stiffness : ndarray (n,)
        ``F_0 / d`` [N/m] (``alpha_{0,0} = secant / tangent``).
    natural_frequency : ndarray (n,)
        ``omega_n = sqrt(beta_{1,0} / m)`` [rad/s].
    alpha, phi : ndarray (n, order + 1, harmonics + 1)
        Nondimensional Taylor-Fourier coefficients and phases (``phi_{0,1} = 0``).
    e, psi : ndarray (n, harmonics)
        Harmonics ``r = 1..`` of the unloaded deflection over ``d`` and their phases.
    q, rho : ndarray (n, 1)
        First harmonic of the applied load over ``d beta_{1,0}`` and its phase.
    mu : ndarray (n,)
        Damping ratio.
    phase_reference : ndarray (n,)
        ``Phi_{0,1}`` [rad]: the nondimensional phase is ``theta = 2 pi phase - Phi_{0,1}``.
    error : ndarray (n,)
        Expansion error (relative to ``F_0``).
    method : str
        ``"taylor"`` or ``"fit"``.
    """

    mean_deflection: np.ndarray
    scale: np.ndarray
    unloaded_mean: np.ndarray
    stiffness: np.ndarray
    secant_stiffness: np.ndarray
    natural_frequency: np.ndarray
    alpha: np.ndarray
    phi: np.ndarray
    e: np.ndarray
    psi: np.ndarray
    q: np.ndarray
    rho: np.ndarray
    mu: np.ndarray
    phase_reference: np.ndarray
    error: np.ndarray
    method: str

    def coefficients(self, q_exponent: float = 0.0) -> np.ndarray:
        """Coefficient vectors of the perturbation solution (``slowflow.C_*``), (n, N_COEF).

        Terms beyond the perturbation's reach (``alpha_{i,0}``, i > 3; harmonics r > 2 of
        the excitation and linear stiffness, r > 1 of the quadratic one) are left out.
        """
        return coefficient_rows(self.alpha, self.phi, self.e, self.psi, self.q, self.rho,
                                self.mu, q_exponent)


def coefficient_rows(alpha, phi, e, psi, q, rho, mu, q_exponent=0.0) -> np.ndarray:
    """Perturbation coefficient rows from nondimensional arrays (see :class:`Expansion`)."""
    n = alpha.shape[0]
    c = np.zeros((n, sf.N_COEF))

    def get(arr, i, r):
        return arr[:, i, r] if i < arr.shape[1] and r < arr.shape[2] else 0.0

    c[:, sf.C_MU] = mu
    c[:, sf.C_A00] = get(alpha, 0, 0)
    c[:, sf.C_A01] = get(alpha, 0, 1)
    for (ca, cp, i, r) in ((sf.C_A02, sf.C_P02, 0, 2), (sf.C_A11, sf.C_P11, 1, 1),
                           (sf.C_A12, sf.C_P12, 1, 2), (sf.C_A21, sf.C_P21, 2, 1)):
        c[:, ca] = get(alpha, i, r)
        c[:, cp] = get(phi, i, r)
    c[:, sf.C_A20] = get(alpha, 2, 0)
    c[:, sf.C_A30] = get(alpha, 3, 0)
    if e.shape[1] >= 1:
        c[:, sf.C_E1] = e[:, 0]
        c[:, sf.C_PSI1] = psi[:, 0]
    if e.shape[1] >= 2:
        c[:, sf.C_E2] = e[:, 1]
        c[:, sf.C_PSI2] = psi[:, 1]
    c[:, sf.C_Q1] = q[:, 0]
    c[:, sf.C_R1] = rho[:, 0]
    c[:, sf.C_QEXP] = q_exponent
    return c


def _phases(force: ForceDeflection) -> np.ndarray:
    natural = force.natural_phases()
    return np.arange(N_PHASE) / N_PHASE if natural is None else np.asarray(natural)


def mean_deflection(force: ForceDeflection, mean_force: np.ndarray,
                    values: Mapping[str, np.ndarray] | None = None,
                    phase: np.ndarray | None = None) -> np.ndarray:
    """EP Eq. 4: ``x_m`` with ``mean_phase f(x_m, phase) = F_0`` per sample [m].

    Bisection on a bracket grown from the largest unloaded deflection (``f`` is increasing
    in ``x``), polished by Newton steps with the tangent stiffness.
    """
    f0 = np.asarray(mean_force, dtype=float)
    n = f0.size
    ph = _phases(force) if phase is None else phase
    g = force.unloaded(ph, n, values)

    def mean_f(x: np.ndarray, order: int = 0) -> np.ndarray:
        xx = np.broadcast_to(x[:, None, None], (n, ph.size, 1))
        return force.derivatives(xx, ph, order, values)[:, :, :, 0].mean(axis=2)

    lo = g.max(axis=1)
    scale = np.maximum(np.abs(lo), 1e-9) + 1e-9
    hi = lo + scale
    for _ in range(200):
        short = mean_f(hi)[0] < f0
        if not short.any():
            break
        hi = np.where(short, lo + 2.0 * (hi - lo), hi)
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        below = mean_f(mid)[0] < f0
        lo = np.where(below, mid, lo)
        hi = np.where(below, hi, mid)
    x = 0.5 * (lo + hi)
    for _ in range(3):
        val, slope = mean_f(x, 1)
        step = np.where(slope > 0.0, (val - f0) / np.where(slope > 0, slope, 1.0), 0.0)
        x = np.clip(x - step, lo - (hi - lo), hi + (hi - lo))
    return x


def _fourier(samples: np.ndarray, n_harm: int) -> tuple[np.ndarray, np.ndarray]:
    """Amplitudes and phases ``(..., n_harm + 1)`` of ``b_0 + sum b_r cos(r theta - Phi_r)``
    from samples on a uniform grid (last axis)."""
    n = samples.shape[-1]
    spec = np.fft.rfft(samples, axis=-1) / n
    amp = np.zeros(samples.shape[:-1] + (n_harm + 1,))
    pha = np.zeros_like(amp)
    amp[..., 0] = spec[..., 0].real
    top = min(n_harm, n // 2)
    for r in range(1, top + 1):
        factor = 1.0 if (n % 2 == 0 and r == n // 2) else 2.0
        amp[..., r] = factor * np.abs(spec[..., r])
        pha[..., r] = -np.angle(spec[..., r])
    return amp, pha


def _taylor(force, x_m, ph, order, values):
    n = x_m.size
    xx = np.broadcast_to(x_m[:, None, None], (n, ph.size, 1))
    der = force.derivatives(xx, ph, order, values)[..., 0]  # (order+1, n, n_phase)
    fact = np.array([math.factorial(i) for i in range(order + 1)], dtype=float)
    return np.moveaxis(der / fact[:, None, None], 0, 1)  # (n, order+1, n_phase)


def _window(x_m, d, g, width):
    """Deflections of the vibration window in contact, (n, n_phase, N_WINDOW), and mask."""
    s = np.linspace(-width, width, N_WINDOW)
    x = x_m[:, None, None] + d[:, None, None] * s[None, None, :]
    x = np.broadcast_to(x, (x_m.size, g.shape[1], N_WINDOW))
    return x, x >= g[:, :, None]


def _fit(force, x_m, d, g, ph, order, values, width):
    """Least-squares Taylor-like coefficients through ``f(x_m)`` over the window."""
    n = x_m.size
    x, mask = _window(x_m, d, g, width)
    f = force.force(x, ph, values)
    b0 = _taylor(force, x_m, ph, 0, values)[:, 0, :]  # f(x_m, phase)
    u = (x - x_m[:, None, None]) / d[:, None, None]
    powers = np.stack([u**i for i in range(1, order + 1)], axis=-1)  # (n, P, W, order)
    w = mask.astype(float)
    a = np.einsum("npwi,npw,npwj->npij", powers, w, powers)
    rhs = np.einsum("npwi,npw,npw->npi", powers, w, (f - b0[:, :, None]) / d[:, None, None])
    a = a + 1e-14 * np.eye(order)[None, None] * np.trace(a, axis1=2, axis2=3)[..., None, None]
    coef = np.linalg.solve(a, rhs[..., None])[..., 0]  # in units of force / d per u^i
    out = np.empty((n, order + 1, ph.size))
    out[:, 0, :] = b0
    for i in range(1, order + 1):
        out[:, i, :] = coef[:, :, i - 1] * d[:, None] / d[:, None] ** i
    return out


def _series_error(force, b, x_m, d, g, ph, values, width, harmonics, f0):
    """Largest |f - truncated series| over the window in contact, relative to F_0."""
    amp, pha = _fourier(b, harmonics)
    theta = 2.0 * math.pi * ph
    trunc = amp[..., :1] + sum(amp[..., r:r + 1] * np.cos(r * theta - pha[..., r:r + 1])
                               for r in range(1, harmonics + 1))  # (n, order+1, n_phase)
    x, mask = _window(x_m, d, g, width)
    dx = x - x_m[:, None, None]
    series = sum(trunc[:, i, :, None] * dx**i for i in range(b.shape[1]))
    exact = force.force(x, ph, values)
    err = np.where(mask, np.abs(series - exact), 0.0).max(axis=(1, 2))
    return err / np.abs(f0)


def expand(force: ForceDeflection, *, mass: np.ndarray, mean_force: np.ndarray,
           damping_ratio: np.ndarray, load_harmonic: np.ndarray, load_phase: np.ndarray,
           order: int = 3, harmonics: int = 2, method: str = "auto", window: float = 1.0,
           values: Mapping[str, np.ndarray] | None = None) -> Expansion:
    """Expand ``f`` and build the nondimensional system of every sample.

    Parameters
    ----------
    force : ForceDeflection
        The force-deflection function (or family).
    mass, mean_force, damping_ratio, load_harmonic, load_phase : ndarray (n,)
        Equivalent mass [kg], mean mesh force ``F_0`` [N], damping ratio, amplitude [N] and
        phase [rad] of the first harmonic of the applied load (at the mesh frequency).
    order : int
        Taylor order ``n`` (>= 1).
    harmonics : int
        Fourier harmonics ``p`` kept (>= 1).
    method : {"auto", "taylor", "fit"}
        Derivatives at ``x_m`` or a least-squares fit over the vibration window; ``"auto"``
        takes derivatives for smooth functions and fits kinked ones.
    window : float
        Half-width of the fit and error window in units of ``d``.
    values : dict, optional
        Per-sample family values.
    """
    if method not in ("auto", "taylor", "fit"):
        raise ValueError(f"expansion={method!r}: valid 'auto', 'taylor', 'fit'")
    if method == "auto":
        method = "taylor" if force.smooth else "fit"
    f0 = np.asarray(mean_force, dtype=float)
    n = f0.size
    ph = _phases(force)
    x_m = mean_deflection(force, f0, values, ph)
    g = force.unloaded(ph, n, values)
    g_amp, g_pha = _fourier(g, harmonics)
    d = x_m - g_amp[:, 0]
    if np.any(d <= 0.0):
        i = int(np.argmin(d))
        raise ValueError(f"mean_force={f0[i]!r} N gives no mean deflection above the unloaded "
                         f"transmission error (sample {i}); valid: > 0 N")
    if method == "taylor":
        b = _taylor(force, x_m, ph, order, values)
    else:
        b = _fit(force, x_m, d, g, ph, order, values, window)
    amp, pha = _fourier(b, harmonics)  # (n, order+1, harmonics+1)
    k1 = amp[:, 1, 0]
    if np.any(k1 <= 0.0):
        raise ValueError("the mean tangent stiffness beta_{1,0} is not positive for some "
                         "sample: the force-deflection function is not increasing at x_m")
    ref = pha[:, 0, 1] if harmonics >= 1 else np.zeros(n)
    ref = np.where(amp[:, 0, 1] > 1e-12 * np.abs(f0), ref, 0.0)
    r = np.arange(harmonics + 1)
    powers = d[:, None] ** (np.arange(order + 1) - 1)[None, :]
    alpha = amp * powers[:, :, None] / k1[:, None, None]
    phi = _wrap(pha - r[None, None, :] * ref[:, None, None])
    phi[:, :, 0] = 0.0
    e = g_amp[:, 1:] / d[:, None]
    psi = _wrap(g_pha[:, 1:] - r[None, 1:] * ref[:, None])
    q = (np.asarray(load_harmonic, dtype=float) / (d * k1))[:, None]
    rho = _wrap(np.asarray(load_phase, dtype=float) - ref)[:, None]
    err = _series_error(force, b, x_m, d, g, ph, values, window, harmonics, f0)
    return Expansion(
        mean_deflection=x_m, scale=d, unloaded_mean=g_amp[:, 0], stiffness=k1,
        secant_stiffness=f0 / d, natural_frequency=np.sqrt(k1 / np.asarray(mass, float)),
        alpha=alpha, phi=phi, e=e, psi=psi, q=q, rho=rho,
        mu=np.asarray(damping_ratio, dtype=float), phase_reference=ref, error=err,
        method=method)


def _wrap(x: np.ndarray) -> np.ndarray:
    return (np.asarray(x) + np.pi) % (2.0 * np.pi) - np.pi
