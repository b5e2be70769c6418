"""Slow-flow equations of the multiple-scales solution near primary resonance (compiled).

The nondimensional equation of motion (Eritenel and Parker (2013) Eqs. 11-12, derived in
docs/theory/mesh_oscillator.md) is written ``u'' + 2 mu u' + (1 + H) f(u, T) = F(T)`` with the
separation function ``H = C - 1`` (0 in contact, -1 out of contact). Near ``Omega = 1`` the
response is ``u = a cos(Omega T - gamma) + ...`` and the amplitude ``a`` and phase ``gamma``
obey the reconstituted slow flow

    da/dT       = Ga1(a, gamma) + Ga2(a, gamma)
    a dgamma/dT = Gg1(a, gamma) + Gg2(a, gamma)

(first-order terms Ga1, Gg1 = EP Eq. 25 plus the principal parametric term alpha_{1,2};
second-order terms Ga2, Gg2 = EP Eq. 30 plus the terms the paper drops or excludes; the
derivation is reproduced symbolically by ``gearuq_plugins.mesh_oscillator.derivation``).
Steady states (EP Eqs. 26, 31) are the roots of ``G = 0``.

Everything here is numba-compiled (``cache=True``, ``nogil=True``) and scalar: the
continuation in :mod:`.perturbation` calls these functions thousands of times per sample.

EP: Eritenel and Parker (2013), the paper this model follows (docs/models.md).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

# ----------------------------------------------------------------------------- coefficients
# Layout of the per-sample coefficient vector ``c`` (nondimensional, EP Eq. 13 notation).
C_MU = 0  # damping ratio mu
C_A00 = 1  # alpha_{0,0}: mean load / (k d)
C_A01 = 2  # alpha_{0,1}: first excitation harmonic (phase reference, phi_{0,1} = 0)
C_A02 = 3  # alpha_{0,2}
C_P02 = 4  # phi_{0,2}
C_Q1 = 5  # q_1: first harmonic of the external load
C_R1 = 6  # rho_1
C_QEXP = 7  # exponent k of the load harmonic scaling q_1 Omega^k (0 or 2)
C_A20 = 8  # alpha_{2,0}: quadratic stiffness
C_A30 = 9  # alpha_{3,0}: cubic stiffness
C_A11 = 10  # alpha_{1,1}: first harmonic of the linear stiffness
C_P11 = 11
C_A12 = 12  # alpha_{1,2}: second harmonic of the linear stiffness (principal parametric)
C_P12 = 13
C_A21 = 14  # alpha_{2,1}: first harmonic of the quadratic stiffness
C_P21 = 15
C_E1 = 16  # e_1: first harmonic of the unloaded deflection (contact boundary)
C_PSI1 = 17
C_E2 = 18  # e_2 (used by the numerical separation only)
C_PSI2 = 19
N_COEF = 20

COEF_NAMES = (
    "mu", "alpha_0_0", "alpha_0_1", "alpha_0_2", "phi_0_2", "q_1", "rho_1", "q_exponent",
    "alpha_2_0", "alpha_3_0", "alpha_1_1", "phi_1_1", "alpha_1_2", "phi_1_2", "alpha_2_1",
    "phi_2_1", "e_1", "psi_1", "e_2", "psi_2",
)

#: Separation modes: EP Eqs. 34-35 (one contact loss per period) or Eqs. 32-33 (numerical).
SEP_CLOSED_FORM = 0
SEP_NUMERICAL = 1
#: Added to a mode: compute the contact margin but leave the separation harmonics at zero
#: (the smooth contact-side slow flow, used to locate the onset of contact loss).
SEP_MARGIN_ONLY = 2
#: Samples of one period used to find the smallest contact margin (then refined by Newton).
N_MIN_SAMPLES = 64
#: Largest number of Illinois iterations for the separation's mean shift in the numerical
#: separation (it converges in about ten; the bound only guards the loop).
N_SEP_PASSES = 60

# Layout of the separation vector ``s`` filled by the separation functions.
S_D0 = 0  # Delta_0 (mean of H, <= 0): minus the fraction of the period out of contact
S_D1 = 1  # Delta_1
S_N1 = 2  # nu_1
S_D2 = 3  # Delta_2
S_N2 = 4  # nu_2
S_MARGIN = 5  # smallest contact margin min(u - u_c) over the period (< 0: contact lost)
S_LOSSES = 6  # number of separate contact losses per period
N_SEP = 7


@njit(cache=True, nogil=True)
def load_harmonic(c: np.ndarray, omega: float) -> float:
    """Effective first load harmonic ``q_1 Omega^k`` (k = 0 constant, 2 inertial forcing)."""
    k = c[C_QEXP]
    if k == 0.0:
        return c[C_Q1]
    return c[C_Q1] * omega**k


@njit(cache=True, nogil=True)
def separation_closed_form(a: float, gam: float, c: np.ndarray, order: int,
                           s: np.ndarray) -> None:
    """Harmonics of the separation function for once-per-period contact loss (Eqs. 34-35).

    Contact holds where ``u - u_c = R cos(psi - nu') + m >= 0`` with ``u`` the first-order
    solution (fundamental plus the mean shift ``-alpha_{2,0} a^2 / 2`` of Eq. 28),
    ``u_c = -1 + e_1 cos(Omega T - psi_1)``, ``R = |a e^{i gamma} - e_1 e^{i psi_1}|`` and
    ``m = 1 - alpha_{2,0} a^2 / 2``. EP print ``alpha_{2,0} a / 2`` in Eq. 35; the mean
    shift of Eq. 28 is quadratic in ``a`` (docs/theory/mesh_oscillator.md). At first order the
    EP set ``alpha_{2,0} = e_1 = 0`` (they give no secular term): contact loss at ``a = 1``.
    """
    if order == 1:
        re = a * math.cos(gam)
        im = a * math.sin(gam)
        m = 1.0
    else:
        e1 = c[C_E1]
        re = a * math.cos(gam) - e1 * math.cos(c[C_PSI1])
        im = a * math.sin(gam) - e1 * math.sin(c[C_PSI1])
        m = 1.0 - 0.5 * c[C_A20] * a * a
    r = math.hypot(re, im)
    s[S_MARGIN] = m - r
    for k in range(S_MARGIN):
        s[k] = 0.0
    s[S_LOSSES] = 0.0
    if r <= m:  # always in contact
        return
    x = -m / r
    if x >= 1.0:  # never in contact (free flight): the expansion is meaningless there
        tau = 0.0
    else:
        tau = math.acos(x)  # contact for |psi - nu'| <= tau
    nu = math.atan2(im, re)
    s[S_D0] = tau / math.pi - 1.0
    s[S_D1] = 2.0 / math.pi * math.sin(tau)
    s[S_N1] = nu
    d2 = 1.0 / math.pi * math.sin(2.0 * tau)
    # amplitudes are kept >= 0 (Delta_2 < 0 for tau > pi/2 is the phase shifted by pi)
    s[S_D2] = abs(d2)
    s[S_N2] = 2.0 * nu if d2 >= 0.0 else 2.0 * nu + math.pi
    s[S_LOSSES] = 1.0


@njit(cache=True, nogil=True)
def separation_mean_shift(a: float, gam: float, c: np.ndarray, s: np.ndarray) -> float:
    """Mean deflection caused by contact loss: minus the mean of ``H f~(u)``.

    Averaging the equation of motion over a period, ``mean(u) = -mean(H f~) - ...``; with
    ``H = Delta_0 + Delta_1 cos(theta - nu_1) + ...`` and ``f~ = alpha_{0,0} + a cos(theta -
    gamma) + ...`` the separation contributes ``-alpha_{0,0} Delta_0 - (a Delta_1 / 2)
    cos(gamma - nu_1)``. EP Eq. 28 keeps only the first term (``Delta_1`` is ordered one
    order smaller); for a short separation ``Delta_1 ~ 2 |Delta_0|`` and the two nearly cancel
    (the force lost near the contact boundary is small), so the first alone has the wrong
    sign once ``a > alpha_{0,0}`` (docs/theory/mesh_oscillator.md, section 4).
    """
    return -c[C_A00] * s[S_D0] - 0.5 * a * s[S_D1] * math.cos(gam - s[S_N1])


@njit(cache=True, nogil=True)
def margin_phasors(a: float, gam: float, c: np.ndarray, shift: float,
                   z: np.ndarray) -> float:
    """Harmonics of the contact margin ``u(theta) - u_c(theta)`` of the approximate solution.

    ``u`` is the first-order solution (EP Eq. 28 with every first-order term: fundamental,
    alpha_{2,0} mean shift and second harmonic, alpha_{3,0} third harmonic, and the
    non-resonant responses to alpha_{1,1}, alpha_{1,2}, alpha_{0,2}) plus the separation's
    mean shift ``shift`` (:func:`separation_mean_shift`);
    ``u_c = -1 + e_1 cos(theta - psi_1) + e_2 cos(2 theta - psi_2)``. Returns the
    mean and fills ``z[k-1]`` (complex) so that the margin is
    ``mean + Re(sum_k z[k-1] exp(i k theta))``, ``theta = Omega T``.
    """
    a20 = c[C_A20]
    a11 = c[C_A11]
    eg = complex(math.cos(gam), -math.sin(gam))  # exp(-i gamma)
    z[0] = a * eg - c[C_E1] * complex(math.cos(c[C_PSI1]), -math.sin(c[C_PSI1]))
    z[1] = (a20 * a * a / 6.0 * eg * eg
            + a * a11 / 6.0 * eg * complex(math.cos(c[C_P11]), -math.sin(c[C_P11]))
            + c[C_A02] / 3.0 * complex(math.cos(c[C_P02]), -math.sin(c[C_P02]))
            - c[C_E2] * complex(math.cos(c[C_PSI2]), -math.sin(c[C_PSI2])))
    z[2] = (c[C_A30] * a**3 / 32.0 * eg * eg * eg
            + a * c[C_A12] / 16.0 * eg * complex(math.cos(c[C_P12]), -math.sin(c[C_P12])))
    return (1.0 - 0.5 * a20 * a * a + shift
            - 0.5 * a * a11 * math.cos(gam - c[C_P11]))


@njit(cache=True, nogil=True)
def approximate_solution(a: float, gam: float, c: np.ndarray, shift: float,
                         theta: float) -> float:
    """First-order approximate solution ``u(theta)`` (EP Eq. 28 and the first-order terms
    listed in :func:`margin_phasors`, with the separation's mean shift ``shift`` from
    :func:`separation_mean_shift`), ``theta = Omega T``."""
    z = np.empty(3, dtype=np.complex128)
    mean = margin_phasors(a, gam, c, shift, z)
    val = mean
    for k in range(3):
        e = complex(math.cos((k + 1) * theta), math.sin((k + 1) * theta))
        val += (z[k] * e).real
    return val + contact_boundary(c, theta)


@njit(cache=True, nogil=True)
def contact_boundary(c: np.ndarray, theta: float) -> float:
    """Nondimensional contact boundary ``u_c = -1 + e_1 cos(theta - psi_1) + e_2 cos(...)``."""
    return (-1.0 + c[C_E1] * math.cos(theta - c[C_PSI1])
            + c[C_E2] * math.cos(2.0 * theta - c[C_PSI2]))


@njit(cache=True, nogil=True)
def _margin_value(mean: float, z: np.ndarray, theta: float) -> float:
    val = mean
    for k in range(3):
        kk = k + 1.0
        val += (z[k] * complex(math.cos(kk * theta), math.sin(kk * theta))).real
    return val


@njit(cache=True, nogil=True)
def _margin_derivs(mean: float, z: np.ndarray, theta: float) -> tuple[float, float, float]:
    """Margin and its first two derivatives in ``theta``."""
    val = mean
    d1 = 0.0
    d2 = 0.0
    for k in range(3):
        kk = k + 1.0
        e = z[k] * complex(math.cos(kk * theta), math.sin(kk * theta))
        val += e.real
        d1 -= kk * e.imag
        d2 -= kk * kk * e.real
    return val, d1, d2


@njit(cache=True, nogil=True)
def _root_in(mean: float, z: np.ndarray, lo: float, hi: float) -> float:
    """Zero of the margin in a sign-change bracket ``[lo, hi]`` (Newton kept in the bracket,
    bisection when it leaves it), so the separation instants are smooth in ``(a, gamma)``."""
    f_lo = _margin_value(mean, z, lo)
    x = 0.5 * (lo + hi)
    for _ in range(60):
        f, d1, d2 = _margin_derivs(mean, z, x)
        if f == 0.0:
            return x
        if (f < 0.0) == (f_lo < 0.0):
            lo, f_lo = x, f
        else:
            hi = x
        x_new = x - f / d1 if d1 != 0.0 else 0.5 * (lo + hi)
        if not lo < x_new < hi:
            x_new = 0.5 * (lo + hi)
        if abs(x_new - x) < 1e-15 or hi - lo < 1e-15:
            return x_new
        x = x_new
    return x


@njit(cache=True, nogil=True)
def _extremum_in(mean: float, z: np.ndarray, lo: float, hi: float, x: float) -> float:
    """Stationary point of the margin in ``[lo, hi]`` by Newton on the derivative."""
    for _ in range(30):
        f, d1, d2 = _margin_derivs(mean, z, x)
        if d2 == 0.0:
            break
        x_new = min(max(x - d1 / d2, lo), hi)
        if abs(x_new - x) < 1e-15:
            break
        x = x_new
    return x


@njit(cache=True, nogil=True)
def _oscillation_samples(z: np.ndarray, osc: np.ndarray) -> None:
    """``osc[j] = Re(sum_k z_k e^{ik theta_j})`` on ``theta_j = 2 pi j / n``, j = 0..n (one
    complex rotation per sample, renormalised every 16 samples)."""
    n = osc.size - 1
    step = complex(math.cos(2.0 * math.pi / n), math.sin(2.0 * math.pi / n))
    w = complex(1.0, 0.0)
    for j in range(n + 1):
        if j % 16 == 0:
            w = complex(math.cos(2.0 * math.pi * j / n), math.sin(2.0 * math.pi * j / n))
        w2 = w * w
        osc[j] = (z[0] * w).real + (z[1] * w2).real + (z[2] * w2 * w).real
        w *= step


@njit(cache=True, nogil=True)
def _margin_roots(mean: float, z: np.ndarray, osc: np.ndarray, roots: np.ndarray) -> int:
    """All zeros of the margin over one period, sorted, and the count.

    Sign changes between :data:`N_MIN_SAMPLES` samples are refined by safeguarded Newton; a
    dip below zero (or a peak above) between two samples of the same sign is found from the
    refined extremum next to a sampled local minimum (maximum), so no short separation is
    missed. The margin is a trigonometric polynomial of degree 3: at most 6 zeros.
    """
    n = osc.size - 1
    dth = 2.0 * math.pi / n
    m = osc + mean
    n_r = 0
    for j in range(n):
        if (m[j] < 0.0) != (m[j + 1] < 0.0) and n_r < roots.size:
            roots[n_r] = _root_in(mean, z, j * dth, (j + 1) * dth)
            n_r += 1
    for j in range(n):  # hidden dips / peaks around sampled extrema of one sign
        mp = m[j - 1] if j > 0 else m[n - 1]
        mn = m[j + 1]
        is_min = m[j] <= mp and m[j] <= mn and m[j] >= 0.0 and mp >= 0.0 and mn >= 0.0
        is_max = m[j] >= mp and m[j] >= mn and m[j] < 0.0 and mp < 0.0 and mn < 0.0
        if not (is_min or is_max) or n_r + 2 > roots.size:
            continue
        lo = (j - 1) * dth
        hi = (j + 1) * dth
        x = _extremum_in(mean, z, lo, hi, j * dth)
        fx = _margin_value(mean, z, x)
        if (is_min and fx < 0.0) or (is_max and fx >= 0.0):
            for r in (_root_in(mean, z, lo, x), _root_in(mean, z, x, hi)):
                roots[n_r] = r % (2.0 * math.pi)
                n_r += 1
    for i in range(1, n_r):  # insertion sort: at most 8 values (np.sort costs seconds of
        key = roots[i]        # compilation for nothing here)
        k = i - 1
        while k >= 0 and roots[k] > key:
            roots[k + 1] = roots[k]
            k -= 1
        roots[k + 1] = key
    return n_r


@njit(cache=True, nogil=True)
def _margin_min(mean: float, z: np.ndarray, osc: np.ndarray) -> float:
    """Smallest value of the margin over a period (sampled, then refined by Newton)."""
    n = osc.size - 1
    jmin = 0
    for j in range(n):
        if osc[j] < osc[jmin]:
            jmin = j
    vmin = mean + osc[jmin]
    dth = 2.0 * math.pi / n
    x = _extremum_in(mean, z, (jmin - 1) * dth, (jmin + 1) * dth, jmin * dth)
    return min(vmin, _margin_value(mean, z, x))


@njit(cache=True, nogil=True)
def _separation_integrals(mean: float, z: np.ndarray, osc: np.ndarray,
                          acc: np.ndarray) -> int:
    """Integrals of Eqs. 32-33 for the margin ``mean + Re(sum_k z_k e^{ik theta})``.

    Fills ``acc = (int H, int H cos, int H sin, int H cos 2, int H sin 2)`` over one period
    (``H = -1`` out of contact) from the separation instants and returns the number of
    contact losses.
    """
    for k in range(5):
        acc[k] = 0.0
    th = np.empty(8)
    n_r = _margin_roots(mean, z, osc, th)
    if n_r == 0:
        if mean + z[0].real + z[1].real + z[2].real < 0.0:  # never in contact
            acc[0] = -2.0 * math.pi
            return 1
        return 0
    losses = 0
    for i in range(n_r):
        ta = th[i]
        tb = th[i + 1] if i + 1 < n_r else th[0] + 2.0 * math.pi
        if tb - ta <= 0.0 or _margin_value(mean, z, 0.5 * (ta + tb)) >= 0.0:
            continue
        losses += 1
        # H = -1 on [ta, tb]
        acc[0] -= tb - ta
        acc[1] -= math.sin(tb) - math.sin(ta)
        acc[2] += math.cos(tb) - math.cos(ta)
        acc[3] -= 0.5 * (math.sin(2.0 * tb) - math.sin(2.0 * ta))
        acc[4] += 0.5 * (math.cos(2.0 * tb) - math.cos(2.0 * ta))
    return losses


@njit(cache=True, nogil=True)
def separation_numerical(a: float, gam: float, c: np.ndarray, s: np.ndarray) -> None:
    """Harmonics of the separation function from the separation instants (Eqs. 32-33).

    The contact margin ``u(theta) - u_c(theta)`` of the approximate solution is a
    trigonometric polynomial; all its zeros over one period are located (any number of
    contact losses per period). The separation's own mean shift
    ``S = -alpha_{0,0} Delta_0 - (a / 2) (Delta_1 cos nu_1 cos gamma + Delta_1 sin nu_1
    sin gamma)`` (:func:`separation_mean_shift`) depends on the separation: it solves
    ``S = G(S)``. ``phi(S) = G(S) - S`` is positive below ``-a/pi`` and negative above
    ``alpha_{0,0} + a/pi`` (``0 <= -Delta_0 <= 1``, ``|mean(H cos)| <= 1/pi``): the root is
    bracketed from ``S = 0`` and ``S = G(0)`` (or those bounds) and found by the Illinois
    method (plain fixed-point passes oscillate near the onset, where ``G`` is steep).
    """
    z = np.empty(3, dtype=np.complex128)
    acc = np.empty(5)
    osc = np.empty(N_MIN_SAMPLES + 1)
    two_pi = 2.0 * math.pi
    mean0 = margin_phasors(a, gam, c, 0.0, z)
    _oscillation_samples(z, osc)
    a00 = c[C_A00]
    cg = math.cos(gam)
    sg = math.sin(gam)
    # one call site of the (large) integrals in a loop keeps the compiled code small
    x = x_pos = f_pos = x_neg = f_neg = 0.0
    have_pos = False
    have_neg = False
    side = 0
    losses = 0
    for it in range(N_SEP_PASSES + 3):
        losses = _separation_integrals(mean0 + x, z, osc, acc)
        g = -(a00 * acc[0] + a * (cg * acc[1] + sg * acc[2])) / two_pi
        fx = g - x
        if abs(fx) <= 1e-15:
            break  # acc holds the integrals at the final x (S = 0: in contact throughout)
        if fx > 0.0:
            if have_neg and side == 1:  # Illinois: the same end kept twice
                f_neg *= 0.5
            x_pos, f_pos, have_pos, side = x, fx, True, 1
        else:
            if have_pos and side == -1:
                f_pos *= 0.5
            x_neg, f_neg, have_neg, side = x, fx, True, -1
        if have_pos and have_neg:
            if abs(x_neg - x_pos) <= 1e-15:
                break
            x = (x_pos * f_neg - x_neg * f_pos) / (f_neg - f_pos)
        elif it == 0:
            x = g  # the fixed-point step: usually across the root
        elif fx > 0.0:  # a point where phi < 0 for certain
            x = a00 + a / math.pi + 1e-9
        else:  # a point where phi > 0 for certain
            x = -a / math.pi - 1e-9
    s[S_D0] = acc[0] / two_pi
    # H = sum Delta_r cos(r theta - nu_r): Delta_r cos nu_r = (1/pi) int H cos(r theta) etc.
    s[S_D1] = math.hypot(acc[1], acc[2]) / math.pi
    s[S_N1] = math.atan2(acc[2], acc[1])
    s[S_D2] = math.hypot(acc[3], acc[4]) / math.pi
    s[S_N2] = math.atan2(acc[4], acc[3])
    # the margin reported is the one without the mean shift, as in the closed form, so that
    # the onset of contact loss (margin 0) is where the separation starts
    s[S_MARGIN] = _margin_min(mean0, z, osc)
    s[S_LOSSES] = float(losses)


@njit(cache=True, nogil=True)
def separation(a: float, gam: float, omega: float, c: np.ndarray, order: int, mode: int,
               s: np.ndarray) -> None:
    """Fill ``s`` with the separation harmonics (closed form or numerical)."""
    if mode & SEP_NUMERICAL:
        separation_numerical(a, gam, c, s)
    else:
        separation_closed_form(a, gam, c, order, s)
    if mode & SEP_MARGIN_ONLY:
        for k in range(S_MARGIN):
            s[k] = 0.0


@njit(cache=True, nogil=True)
def first_order(a: float, gam: float, omega: float, c: np.ndarray, d0: float,
                out: np.ndarray) -> None:
    """First-order slow flow: ``out = (da/dT, a dgamma/dT)`` (EP Eq. 25 + alpha_{1,2})."""
    sig = omega - 1.0
    q = load_harmonic(c, omega)
    a01 = c[C_A01]
    r1 = c[C_R1]
    par = 0.25 * a * c[C_A12]
    p12 = c[C_P12]
    out[0] = (-c[C_MU] * a - 0.5 * a01 * math.sin(gam) + 0.5 * q * math.sin(gam - r1)
              - par * math.sin(2.0 * gam - p12))
    out[1] = (a * sig - 0.5 * d0 * a - 0.375 * c[C_A30] * a**3 - 0.5 * a01 * math.cos(gam)
              + 0.5 * q * math.cos(gam - r1) - par * math.cos(2.0 * gam - p12))


@njit(cache=True, nogil=True)
def second_order(a: float, gam: float, omega: float, c: np.ndarray, s: np.ndarray,
                 out: np.ndarray) -> None:
    """Second-order terms: ``out += (Ga2, Gg2)`` (EP Eq. 30 and the terms it omits).

    Grouped by physical origin; each line is one term of the symbolic derivation (the
    harmonic pairs combined). EP's Eq. 30 is the subset with alpha_{1,1} = alpha_{1,2} =
    alpha_{0,2} = 0 and without the two ``Delta_0 q_1`` terms.
    """
    sig = omega - 1.0
    mu = c[C_MU]
    a00 = c[C_A00]
    a01 = c[C_A01]
    a02 = c[C_A02]
    p02 = c[C_P02]
    q = load_harmonic(c, omega)
    r1 = c[C_R1]
    a20 = c[C_A20]
    a30 = c[C_A30]
    a11 = c[C_A11]
    p11 = c[C_P11]
    a12 = c[C_A12]
    p12 = c[C_P12]
    a21 = c[C_A21]
    p21 = c[C_P21]
    d0 = s[S_D0]
    d1 = s[S_D1]
    n1 = s[S_N1]
    d2 = s[S_D2]
    n2 = s[S_N2]
    a2 = a * a
    a3 = a2 * a
    sg, cg = math.sin(gam), math.cos(gam)
    sq, cq = math.sin(gam - r1), math.cos(gam - r1)
    s12, c12 = math.sin(2.0 * gam - p12), math.cos(2.0 * gam - p12)
    # ---- da/dT
    ga = 0.375 * mu * a30 * a3  # damping x cubic stiffness
    ga += (a01 * sg - q * sq) * (0.28125 * a30 * a2 + 0.25 * sig)  # forcing x (cubic, detuning)
    ga += -0.25 * mu * a01 * cg + 0.25 * mu * q * cq  # forcing x damping
    ga += -0.375 * d0 * a01 * sg - 0.125 * d0 * q * sq  # mean separation x forcing
    ga += -0.5 * d1 * a00 * math.sin(gam - n1)  # mean load acting through Delta_1
    ga += -0.25 * d2 * a * math.sin(2.0 * gam - n2)  # Delta_2 parametric term
    ga += -0.125 * a2 * a21 * math.sin(gam - p21)  # periodic quadratic stiffness
    # linear stiffness harmonics alpha_{1,1} (second-order parametric) and alpha_{1,2}
    ga += 0.125 * a * a11 * a11 * math.sin(2.0 * gam - 2.0 * p11)
    ga += (5.0 / 24.0) * a2 * a11 * a20 * math.sin(gam - p11)
    ga += 0.5 * d0 * a00 * a11 * math.sin(gam - p11)
    ga += -(1.0 / 12.0) * a02 * a11 * math.sin(gam - p02 + p11)
    ga += (0.25 * sig - 0.25 * d0 + (5.0 / 64.0) * a30 * a2) * a * a12 * s12
    ga += -0.0625 * a01 * a12 * math.sin(gam - p12) + 0.0625 * q * a12 * math.sin(gam - p12 + r1)
    ga += -(1.0 / 6.0) * a * a02 * a20 * math.sin(2.0 * gam - p02)  # alpha_{0,2} x quadratic
    # ---- a dgamma/dT
    gg = 0.5 * mu * mu * a + 0.125 * d0 * d0 * a + (15.0 / 256.0) * a30 * a30 * a2 * a3
    gg += (5.0 / 12.0) * a20 * a20 * a3 - 0.1875 * d0 * a30 * a3 + d0 * a00 * a20 * a
    gg += (a01 * cg - q * cq) * (0.09375 * a30 * a2 + 0.25 * sig)
    gg += 0.25 * mu * a01 * sg - 0.25 * mu * q * sq
    gg += -0.375 * d0 * a01 * cg - 0.125 * d0 * q * cq
    gg += -0.5 * d1 * a00 * math.cos(gam - n1)
    gg += -0.25 * d2 * a * math.cos(2.0 * gam - n2)
    gg += -0.375 * a2 * a21 * math.cos(gam - p21)
    gg += (1.0 / 12.0) * a * a11 * a11 + 0.125 * a * a11 * a11 * math.cos(2.0 * gam - 2.0 * p11)
    gg += 0.625 * a2 * a11 * a20 * math.cos(gam - p11)
    gg += 0.5 * d0 * a00 * a11 * math.cos(gam - p11)
    gg += -(1.0 / 12.0) * a02 * a11 * math.cos(gam - p02 + p11)
    gg += -(3.0 / 64.0) * a * a12 * a12
    gg += (0.25 * sig - 0.25 * d0 - (1.0 / 32.0) * a30 * a2) * a * a12 * c12
    gg += -0.0625 * a01 * a12 * math.cos(gam - p12) + 0.0625 * q * a12 * math.cos(gam - p12 + r1)
    gg += -(1.0 / 6.0) * a * a02 * a20 * math.cos(2.0 * gam - p02)
    out[0] += ga
    out[1] += gg


@njit(cache=True, nogil=True)
def slow_flow(a: float, gam: float, omega: float, c: np.ndarray, order: int, mode: int,
              s: np.ndarray, out: np.ndarray) -> None:
    """``out = (da/dT, a dgamma/dT)`` at ``(a, gamma)``; ``s`` receives the separation data.

    ``order`` 1: EP Eq. 25 (the separation enters through Delta_0 only); 2: reconstituted
    first + second order (EP Eqs. 25 + 30). ``mode``: :data:`SEP_CLOSED_FORM` or
    :data:`SEP_NUMERICAL`.
    """
    separation(a, gam, omega, c, order, mode, s)
    first_order(a, gam, omega, c, s[S_D0], out)
    if order >= 2:
        second_order(a, gam, omega, c, s, out)
