"""Compiled path following of the steady-state response curve of the slow flow.

The steady states of the slow flow (:mod:`.slowflow`) form a curve in ``(a, gamma, Omega)``.
It may fold (hardening, softening, contact loss), so it is traced by pseudo-arclength
continuation from below the lowest grid frequency to above the highest, in the scaled
coordinates ``y = (a / a_scale, gamma / pi, Omega / Omega_span)`` (predictor along the
tangent, Newton-chord corrector on the bordered system). The curve has a corner where
contact loss starts or ends (the separation harmonics grow like the square root of the
depth of separation: the kink of EP Fig. 4, region 3); it is crossed explicitly by solving
for the onset point (margin 0) and a point just across it.

Every solution at a grid frequency is then found where the traced curve crosses it (cubic
Hermite guess along the segment, Newton-chord refinement at fixed ``Omega``), so all branches
(one or three, or more) come out with their position along the curve, which decides the path
of an upward or downward sweep. Stability follows from the eigenvalues of the slow-flow
Jacobian with respect to ``(a, gamma)`` (EP Eq. 38), by finite differences, so the
dependence of the separation harmonics on ``(a, gamma)`` is included.

Limits: an isolated branch (isola) not connected to the low-frequency end is not found; the
trace starts below the lowest grid frequency, which must lie where the response is
single-valued (the start is checked against the linear solution).

EP: Eritenel and Parker (2013), the paper this model follows (docs/models.md).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from gearuq_plugins.mesh_oscillator.slowflow import (
    C_A01,
    C_A12,
    C_MU,
    C_R1,
    N_SEP,
    S_MARGIN,
    SEP_MARGIN_ONLY,
    load_harmonic,
    slow_flow,
)

#: First 16 hex digits of the sha256 of ``slowflow.py``. Its functions are compiled into the
#: cached kernels of this file, and numba's cache notices changes to this file only: a change
#: to ``slowflow.py`` must come with a new value here, which invalidates the stale entries
#: (tests/test_mesh_oscillator_validity.py checks the value).
SLOWFLOW_DIGEST = "ad11dc697ff67962"

#: Trace status codes (per sample).
TRACE_OK = 0
TRACE_START_FAILED = 1
TRACE_STEP_UNDERFLOW = 2
TRACE_TOO_MANY_POINTS = 3
TRACE_UNFORCED = 4
TRACE_GRID_MISSED = 5

_FD_REL = 1e-7
#: Step (scaled arclength) below which a failing step near the onset is taken as a corner.
_CORNER_STEP = 1e-4
#: Largest |contact margin| at which a corner is looked for.
_CORNER_MARGIN = 2e-2
#: Largest traced amplitude, in units of the amplitude scale (the linear peak).
_A_MAX = 50.0
# Constant arguments of kernel-to-kernel calls are passed as np.int64(...) / np.bool_(...):
# numba compiles a callee once per distinct literal constant it is called with (60 and 40, True
# and False: a second copy of the callee and of everything it calls), and a typed value is one
# signature for all. The values, and so the results, are the same.
#: Continuation step sizes in scaled arclength.
H_START = 0.01
H_MIN = 1e-7
H_MAX = 0.08


@njit(cache=True, nogil=True)
def _g(a, gam, om, c, order, mode, s, g):
    """Residual with ``a < 0`` mapped to ``(|a|, gamma + pi)`` (the same motion)."""
    if a < 0.0:
        slow_flow(-a, gam + math.pi, om, c, order, mode, s, g)
        g[0] = -g[0]
        g[1] = -g[1]
    else:
        slow_flow(a, gam, om, c, order, mode, s, g)


@njit(cache=True, nogil=True)
def forcing_phasor(c, om):
    """Complex first-harmonic forcing ``q_1 Omega^k e^{-i rho_1} - alpha_{0,1}`` of Eq. 11."""
    q = load_harmonic(c, om)
    return complex(q * math.cos(c[C_R1]) - c[C_A01], -q * math.sin(c[C_R1]))


@njit(cache=True, nogil=True)
def linear_solution(c, om):
    """Amplitude and phase of the linear time-invariant response (only alpha_{1,0} = 1)."""
    den = complex(1.0 - om * om, 2.0 * c[C_MU] * om)
    if den == 0.0:  # undamped, at resonance: unbounded
        return math.inf, 0.0
    z = forcing_phasor(c, om) / den
    return abs(z), -math.atan2(z.imag, z.real)


@njit(cache=True, nogil=True)
def jacobian(a, gam, om, c, order, mode, g0, jac, s, work):
    """Residual ``g0`` and Jacobian ``jac[i, k] = dG_i / d(a, gamma, Omega)_k`` (forward
    differences; 4 evaluations of the slow flow)."""
    _g(a, gam, om, c, order, mode, s, g0)
    ha = _FD_REL * max(abs(a), 1e-3)
    hg = _FD_REL
    hw = _FD_REL * max(abs(om), 1.0)
    _g(a + ha, gam, om, c, order, mode, s, work)
    jac[0, 0] = (work[0] - g0[0]) / ha
    jac[1, 0] = (work[1] - g0[1]) / ha
    _g(a, gam + hg, om, c, order, mode, s, work)
    jac[0, 1] = (work[0] - g0[0]) / hg
    jac[1, 1] = (work[1] - g0[1]) / hg
    _g(a, gam, om + hw, c, order, mode, s, work)
    jac[0, 2] = (work[0] - g0[0]) / hw
    jac[1, 2] = (work[1] - g0[1]) / hw
    _g(a, gam, om, c, order, mode, s, work)  # leave the separation data of the point in s


@njit(cache=True, nogil=True)
def stable_from_jacobian(a, jac, c_mu):
    """1 when the slow flow ``(da/dT, dgamma/dT = G_gamma / a)`` is stable at a steady state
    with Jacobian ``jac`` (``G_gamma = 0`` there, so ``d(G_gamma/a) = dG_gamma / a``)."""
    j00 = jac[0, 0]
    j01 = jac[0, 1]
    j10 = jac[1, 0] / a
    j11 = jac[1, 1] / a
    trace = j00 + j11
    det = j00 * j11 - j01 * j10
    # without damping the slow flow is conservative: the trace is 0 up to the finite-
    # difference error (relative 1e-7 of the eigenvalues +-i sqrt(det)), and a centre
    # (det > 0) is neutrally stable, the state a sweep stays on
    tol = 1e-4 * math.sqrt(abs(det)) if c_mu <= 0.0 else 0.0
    return 1 if (trace < tol and det > 0.0) else 0


@njit(cache=True, nogil=True)
def newton_fixed_omega(a, gam, om, c, order, mode, maxit):
    """Solve ``G(a, gamma; Omega) = 0`` by damped Newton (finite-difference Jacobian).

    Returns ``(a, gamma, converged)``; ``a`` is kept positive.
    """
    s = np.empty(N_SEP)
    g = np.empty(2)
    jac = np.empty((2, 3))
    work = np.empty(2)
    for _ in range(maxit):
        jacobian(a, gam, om, c, order, mode, g, jac, s, work)
        det = jac[0, 0] * jac[1, 1] - jac[0, 1] * jac[1, 0]
        if det == 0.0 or not math.isfinite(det):
            return a, gam, False
        da = -(jac[1, 1] * g[0] - jac[0, 1] * g[1]) / det
        dg = -(-jac[1, 0] * g[0] + jac[0, 0] * g[1]) / det
        # limit the step (the separation terms have square-root kinks at the onset)
        lim = 0.5 * max(abs(a), 1e-3)
        scale = 1.0
        if abs(da) > lim:
            scale = lim / abs(da)
        if abs(dg) * scale > 0.5:
            scale = 0.5 / abs(dg)
        a += scale * da
        gam += scale * dg
        if a < 0.0:
            a = -a
            gam += math.pi
        if abs(da) <= 1e-11 * (1.0 + abs(a)) and abs(dg) <= 1e-11 and scale == 1.0:
            return a, gam, True
    return a, gam, False


@njit(cache=True, nogil=True)
def _chord_fixed_omega(a, gam, om, c, order, mode, jac, maxit):
    """Newton-chord at fixed ``Omega`` with a given Jacobian (1 evaluation per iteration)."""
    s = np.empty(N_SEP)
    g = np.empty(2)
    det = jac[0, 0] * jac[1, 1] - jac[0, 1] * jac[1, 0]
    if det == 0.0 or not math.isfinite(det):
        return a, gam, False
    for _ in range(maxit):
        _g(a, gam, om, c, order, mode, s, g)
        da = -(jac[1, 1] * g[0] - jac[0, 1] * g[1]) / det
        dg = -(-jac[1, 0] * g[0] + jac[0, 0] * g[1]) / det
        a += da
        gam += dg
        if abs(da) <= 1e-10 * (1.0 + abs(a)) and abs(dg) <= 1e-10:
            return a, gam, True
    return a, gam, False


@njit(cache=True, nogil=True)
def _tangent(jac, sa, sw, t):
    """Unit null vector, in scaled coordinates, of the 2 x 3 Jacobian."""
    # columns in scaled coordinates: d/d(a/sa) = sa d/da, d/d(gamma/pi), d/d(Omega/sw)
    r00, r01, r02 = jac[0, 0] * sa, jac[0, 1] * math.pi, jac[0, 2] * sw
    r10, r11, r12 = jac[1, 0] * sa, jac[1, 1] * math.pi, jac[1, 2] * sw
    t[0] = r01 * r12 - r02 * r11
    t[1] = r02 * r10 - r00 * r12
    t[2] = r00 * r11 - r01 * r10
    n = math.sqrt(t[0] ** 2 + t[1] ** 2 + t[2] ** 2)
    if n == 0.0 or not math.isfinite(n):
        return False
    for k in range(3):
        t[k] /= n
    return True


@njit(cache=True, nogil=True)
def _det3(m00, m01, m02, m10, m11, m12, m20, m21, m22):
    return (m00 * (m11 * m22 - m12 * m21) - m01 * (m10 * m22 - m12 * m20)
            + m02 * (m10 * m21 - m11 * m20))


@njit(cache=True, nogil=True)
def _solve3(m, r, x):
    """Solve the 3 x 3 system ``m x = r`` by Cramer's rule; False when singular."""
    det = _det3(m[0, 0], m[0, 1], m[0, 2], m[1, 0], m[1, 1], m[1, 2], m[2, 0], m[2, 1],
                m[2, 2])
    if det == 0.0 or not math.isfinite(det):
        return False
    x[0] = _det3(r[0], m[0, 1], m[0, 2], r[1], m[1, 1], m[1, 2], r[2], m[2, 1], m[2, 2]) / det
    x[1] = _det3(m[0, 0], r[0], m[0, 2], m[1, 0], r[1], m[1, 2], m[2, 0], r[2], m[2, 2]) / det
    x[2] = _det3(m[0, 0], m[0, 1], r[0], m[1, 0], m[1, 1], r[1], m[2, 0], m[2, 1], r[2]) / det
    return True


@njit(cache=True, nogil=True)
def _bordered(jac, sa, sw, t, m, norms):
    """Row-scaled bordered matrix ``[dG/dy; t]`` in scaled coordinates."""
    for i in range(2):
        r0, r1, r2 = jac[i, 0] * sa, jac[i, 1] * math.pi, jac[i, 2] * sw
        n = math.sqrt(r0 * r0 + r1 * r1 + r2 * r2)
        if n == 0.0 or not math.isfinite(n):
            return False
        norms[i] = n
        m[i, 0], m[i, 1], m[i, 2] = r0 / n, r1 / n, r2 / n
    for k in range(3):
        m[2, k] = t[k]
    return True


@njit(cache=True, nogil=True)
def _correct(pred, t, jac0, c, order, mode, sa, sw, y, maxit, full):
    """Corrector of ``G(y) = 0``, ``t . (y - pred) = 0``: Newton-chord with the Jacobian
    ``jac0`` of the previous point, or full Newton (``full``); returns the iterations used,
    or -1 when it does not converge."""
    m = np.empty((3, 3))
    norms = np.empty(2)
    r = np.empty(3)
    dy = np.empty(3)
    s = np.empty(N_SEP)
    g = np.empty(2)
    jac = np.empty((2, 3))
    work = np.empty(2)
    jac[:, :] = jac0
    if not _bordered(jac, sa, sw, t, m, norms):
        return -1
    for k in range(3):
        y[k] = pred[k]
    for it in range(maxit):
        if full:
            jacobian(y[0] * sa, y[1] * math.pi, y[2] * sw, c, order, mode, g, jac, s, work)
            if not _bordered(jac, sa, sw, t, m, norms):
                return -1
        else:
            _g(y[0] * sa, y[1] * math.pi, y[2] * sw, c, order, mode, s, g)
        r[0] = -g[0] / norms[0]
        r[1] = -g[1] / norms[1]
        r[2] = -(t[0] * (y[0] - pred[0]) + t[1] * (y[1] - pred[1]) + t[2] * (y[2] - pred[2]))
        if not _solve3(m, r, dy):
            return -1
        step = math.sqrt(dy[0] ** 2 + dy[1] ** 2 + dy[2] ** 2)
        if not math.isfinite(step) or step > 0.5:
            return -1
        for k in range(3):
            y[k] += dy[k]
        if step < 1e-10:
            return it + 1
    return -1


@njit(cache=True, nogil=True)
def _margin(y, c, order, mode, sa, sw):
    """Contact margin (min of u - u_c over a period) at the scaled point ``y``."""
    s = np.empty(N_SEP)
    g = np.empty(2)
    _g(y[0] * sa, y[1] * math.pi, y[2] * sw, c, order, mode, s, g)
    return s[S_MARGIN]


@njit(cache=True, nogil=True)
def _solve_with_margin(y, target, c, order, mode, sa, sw, maxit):
    """Newton on ``G(y) = 0``, ``margin(y) = target`` (3 x 3, finite differences), in place."""
    s = np.empty(N_SEP)
    g0 = np.empty(2)
    gp = np.empty(2)
    m = np.empty((3, 3))
    r = np.empty(3)
    dy = np.empty(3)
    for _ in range(maxit):
        _g(y[0] * sa, y[1] * math.pi, y[2] * sw, c, order, mode, s, g0)
        m0 = s[S_MARGIN]
        for k in range(3):
            h = _FD_REL * max(abs(y[k]), 1e-3)
            y[k] += h
            _g(y[0] * sa, y[1] * math.pi, y[2] * sw, c, order, mode, s, gp)
            y[k] -= h
            m[0, k] = (gp[0] - g0[0]) / h
            m[1, k] = (gp[1] - g0[1]) / h
            m[2, k] = (s[S_MARGIN] - m0) / h
        r[0] = -g0[0]
        r[1] = -g0[1]
        r[2] = target - m0
        for i in range(3):  # row scaling
            nrm = math.sqrt(m[i, 0] ** 2 + m[i, 1] ** 2 + m[i, 2] ** 2)
            if nrm == 0.0 or not math.isfinite(nrm):
                return False
            for k in range(3):
                m[i, k] /= nrm
            r[i] /= nrm
        if not _solve3(m, r, dy):
            return False
        step = math.sqrt(dy[0] ** 2 + dy[1] ** 2 + dy[2] ** 2)
        if not math.isfinite(step) or step > 0.5:
            return False
        for k in range(3):
            y[k] += dy[k]
        if step < 1e-11:
            return True
    return False


@njit(cache=True, nogil=True)
def _cross_corner(y, t, side, c, order, mode, sa, sw, p0, p1):
    """Step over the corner of the curve where contact loss starts or ends.

    ``side`` is the sign of the contact margin on the incoming part of the curve and ``t``
    the incoming tangent. ``p0`` receives the onset point (margin 0, solved on the smooth
    contact-side flow where the separation harmonics vanish) and ``p1`` a point just across
    it (small margin of the opposite sign); returns False when either solve fails.
    """
    for k in range(3):
        p0[k] = y[k]
    if not _solve_with_margin(p0, 0.0, c, order, mode | SEP_MARGIN_ONLY, sa, sw, 40):
        return False
    for eta in (1e-5, 1e-4, 1e-3):
        for k in range(3):  # start just beyond the onset, along the incoming direction
            p1[k] = p0[k] + 10.0 * eta * t[k]
        if _solve_with_margin(p1, -side * eta, c, order, mode, sa, sw, 40):
            return True
    return False


@njit(cache=True, nogil=True)
def _store(tr, n, y, c, order, mode, sa, sw, sep_mode):
    """Store point ``n`` of the trace (state, separation data, Jacobian, tangent later)."""
    pts, seps, jacs, stab = tr
    a = y[0] * sa
    gam = y[1] * math.pi
    om = y[2] * sw
    s = np.empty(N_SEP)
    g = np.empty(2)
    work = np.empty(2)
    jacobian(a, gam, om, c, order, sep_mode, g, jacs[n], s, work)
    _g(a, gam, om, c, order, mode, s, g)
    pts[n, 0] = a
    pts[n, 1] = gam
    pts[n, 2] = om
    seps[n, :] = s
    stab[n] = stable_from_jacobian(a, jacs[n], c[C_MU])


@njit(cache=True, nogil=True)
def trace_curve(c, order, mode, om_lo, om_hi, from_high, sa, tr, tans):
    """Trace the steady-state curve across the window ``[om_lo, om_hi]``.

    Starts at ``om_lo`` going up (or at ``om_hi`` going down when ``from_high``) and stops
    where the curve leaves the window on either side. ``tr = (pts, seps, jacs, stable)``
    receives ``(a, gamma, Omega)``, the separation data, the Jacobian and the stability of
    every point, ``tans`` the scaled unit tangents. Returns ``(n_points, status, exit)``
    with ``exit`` -1 (left the window below ``om_lo``), +1 (above ``om_hi``), 2 (undamped:
    the amplitude grows without bound along the backbone) or 0.
    """
    pts = tr[0]
    jacs = tr[2]
    max_pts = pts.shape[0]
    sw = max(om_hi - om_lo, 1e-6)
    om_start = om_hi if from_high else om_lo
    if abs(forcing_phasor(c, om_start)) == 0.0:
        return 0, TRACE_UNFORCED, 0
    a_lin, g_lin = linear_solution(c, om_start)
    a0, g0, ok = newton_fixed_omega(a_lin, g_lin, om_start, c, order, mode, np.int64(60))
    if not ok:
        return 0, TRACE_START_FAILED, 0
    y = np.array([a0 / sa, g0 / math.pi, om_start / sw])
    y_new = np.empty(3)
    pred = np.empty(3)
    p0 = np.empty(3)
    p1 = np.empty(3)
    t_new = np.empty(3)
    _store(tr, np.int64(0), y, c, order, mode, sa, sw, mode)
    if not _tangent(jacs[0], sa, sw, tans[0]):
        return 0, TRACE_START_FAILED, 0
    if (tans[0, 2] < 0.0) != from_high:
        tans[0] *= -1.0
    n = np.int64(1)  # typed, not the literal 1: one signature of _store (see the top)
    h = H_START
    while True:
        t = tans[n - 1]
        if h < _CORNER_STEP and n >= 2:
            m_here = tr[1][n - 1, S_MARGIN]
            # a corner only when the margin is small and shrinking (approaching the onset)
            if abs(m_here) <= _CORNER_MARGIN and abs(m_here) < abs(tr[1][n - 2, S_MARGIN]):
                # incoming side: the margin of the last point clearly off the onset
                side = 1.0 if m_here > 0.0 else -1.0
                for back in range(n - 1, -1, -1):
                    if abs(tr[1][back, S_MARGIN]) > 1e-3:
                        side = 1.0 if tr[1][back, S_MARGIN] > 0.0 else -1.0
                        break
                if not _cross_corner(y, t, side, c, order, mode, sa, sw, p0, p1):
                    return n, TRACE_STEP_UNDERFLOW, 0
                # the onset point, with the smooth contact-side Jacobian, then across it
                _store(tr, n, p0, c, order, mode, sa, sw, mode | SEP_MARGIN_ONLY)
                tans[n] = t
                _store(tr, n + 1, p1, c, order, mode, sa, sw, mode)
                if not _tangent(jacs[n + 1], sa, sw, t_new):
                    return n, TRACE_STEP_UNDERFLOW, 0
                if (p1[0] - p0[0]) * t_new[0] + (p1[1] - p0[1]) * t_new[1] + (
                        p1[2] - p0[2]) * t_new[2] < 0.0:
                    t_new *= -1.0
                tans[n + 1] = t_new
                n += 2
                for k in range(3):
                    y[k] = p1[k]
                h = _CORNER_STEP
                continue
        if h < H_MIN:
            return n, TRACE_STEP_UNDERFLOW, 0
        for k in range(3):
            pred[k] = y[k] + h * t[k]
        its = _correct(pred, t, jacs[n - 1], c, order, mode, sa, sw, y_new, np.int64(12),
                       np.bool_(False))
        grow = 1.5 if its <= 4 else (1.2 if its <= 6 else (0.6 if its >= 9 else 1.0))
        if its < 0:  # the chord failed: full Newton before giving up the step size
            its = _correct(pred, t, jacs[n - 1], c, order, mode, sa, sw, y_new, np.int64(12),
                           np.bool_(True))
            grow = 1.3 if its <= 4 else 1.0
        accepted = False
        if its >= 0:
            if y_new[0] < 0.0:  # the same motion with a > 0
                y_new[0] = -y_new[0]
                y_new[1] += 1.0
            _store(tr, n, y_new, c, order, mode, sa, sw, mode)
            if _tangent(jacs[n], sa, sw, t_new):
                dot = t[0] * t_new[0] + t[1] * t_new[1] + t[2] * t_new[2]
                if dot < 0.0:
                    t_new *= -1.0
                    dot = -dot
                accepted = dot > 0.95
        if not accepted:
            h *= 0.5
            continue
        tans[n] = t_new
        for k in range(3):
            y[k] = y_new[k]
        n += 1
        if y[2] * sw > om_hi:
            return n, TRACE_OK, 1
        if y[2] * sw < om_lo:
            return n, TRACE_OK, -1
        if y[0] > _A_MAX:  # amplitude beyond any physical meaning (scale: the linear peak)
            if c[C_MU] <= 0.0:  # undamped: the branch runs up the backbone to infinity
                return n, TRACE_OK, 2
            return n, TRACE_STEP_UNDERFLOW, 0
        if n >= max_pts - 2:
            return n, TRACE_TOO_MANY_POINTS, 0
        h = min(grow * h, H_MAX)


@njit(cache=True, nogil=True)
def _wrap(x):
    return (x + math.pi) % (2.0 * math.pi) - math.pi


@njit(cache=True, nogil=True)
def _hermite_guess(tr, tans, j, om, sa, sw):
    """(a, gamma) where the cubic Hermite arc between points j and j+1 reaches ``om``."""
    pts = tr[0]
    y0 = np.array([pts[j, 0] / sa, pts[j, 1] / math.pi, pts[j, 2] / sw])
    y1 = np.array([pts[j + 1, 0] / sa, pts[j + 1, 1] / math.pi, pts[j + 1, 2] / sw])
    length = math.sqrt(((y1 - y0) ** 2).sum())
    m0 = tans[j] * length
    m1 = tans[j + 1] * length
    target = om / sw
    dw = y1[2] - y0[2]
    x = 0.5 if dw == 0.0 else min(max((target - y0[2]) / dw, 0.0), 1.0)
    for _ in range(8):  # Newton on the Omega component of the Hermite arc
        h00 = 2 * x**3 - 3 * x**2 + 1
        h10 = x**3 - 2 * x**2 + x
        h01 = -2 * x**3 + 3 * x**2
        h11 = x**3 - x**2
        w = h00 * y0[2] + h10 * m0[2] + h01 * y1[2] + h11 * m1[2]
        dwdx = ((6 * x**2 - 6 * x) * y0[2] + (3 * x**2 - 4 * x + 1) * m0[2]
                + (-6 * x**2 + 6 * x) * y1[2] + (3 * x**2 - 2 * x) * m1[2])
        if dwdx == 0.0:
            break
        x_new = min(max(x - (w - target) / dwdx, 0.0), 1.0)
        if abs(x_new - x) < 1e-14:
            break
        x = x_new
    h00 = 2 * x**3 - 3 * x**2 + 1
    h10 = x**3 - 2 * x**2 + x
    h01 = -2 * x**3 + 3 * x**2
    h11 = x**3 - x**2
    ya = h00 * y0[0] + h10 * m0[0] + h01 * y1[0] + h11 * m1[0]
    yg = h00 * y0[1] + h10 * m0[1] + h01 * y1[1] + h11 * m1[1]
    return ya * sa, yg * math.pi, x


@njit(cache=True, nogil=True)
def solve_on_grid(c, order, mode, tr, tans, n_pts, brk, grid, sa, sw, sol):
    """Every solution at each grid frequency, from the crossings of the traced curve.

    ``sol = (a, gamma, position, stable, separation, count)`` with shapes
    ``(n_grid, max_solutions[, N_SEP])``; ``position`` is the place along the curve (segment
    index + fraction), which orders the branches for sweep paths. Points ``brk - 1`` and
    ``brk`` are not joined (the curve was traced in two pieces).
    """
    pts, seps, jacs, stab = tr
    sol_a, sol_g, sol_par, sol_stable, sol_sep, n_sol = sol
    max_b = sol_a.shape[1]
    s = np.empty(N_SEP)
    g = np.empty(2)
    jac = np.empty((2, 3))
    work = np.empty(2)
    n_sol[:] = 0
    for j in range(n_pts - 1):
        if j + 1 == brk:
            continue
        w0 = pts[j, 2]
        w1 = pts[j + 1, 2]
        k0 = np.searchsorted(grid, min(w0, w1))
        k1 = np.searchsorted(grid, max(w0, w1), side="right")
        for k in range(k0, k1):
            om = grid[k]
            a, gam, frac = _hermite_guess(tr, tans, j, om, sa, sw)
            near = j if frac < 0.5 else j + 1
            a, gam, ok = _chord_fixed_omega(a, gam, om, c, order, mode, jacs[near], 8)
            if not ok:
                a, gam, ok = newton_fixed_omega(a, gam, om, c, order, mode, np.int64(40))
            if a < 0.0:
                a = -a
                gam += math.pi
            dup = False
            for b in range(n_sol[k]):
                if (abs(sol_a[k, b] - a) <= 1e-7 * (1.0 + a)
                        and abs(_wrap(sol_g[k, b] - gam)) <= 1e-6):
                    dup = True
            if dup or n_sol[k] >= max_b:
                continue
            b = n_sol[k]
            sol_a[k, b] = a
            sol_g[k, b] = _wrap(gam)
            sol_par[k, b] = j + frac
            if stab[j] == stab[j + 1]:
                sol_stable[k, b] = stab[j]
                _g(a, gam, om, c, order, mode, s, g)
            else:
                jacobian(a, gam, om, c, order, mode, g, jac, s, work)
                sol_stable[k, b] = stable_from_jacobian(a, jac, c[C_MU])
            sol_sep[k, b, :] = s
            n_sol[k] += 1


@njit(cache=True, nogil=True)
def sweep_paths(sol_par, sol_stable, n_sol, up, down):
    """Index of the solution an upward (``up``) and downward (``down``) sweep lands on.

    Upward: at each frequency the stable solution with the smallest curve position not before
    the previous one (the sweep follows the curve and jumps forward past a fold); downward:
    the mirror image. Falls back to the nearest solution along the curve when no stable one is
    ahead (e.g. an amplitude-modulated regime, which the steady-state theory cannot follow).
    """
    kg = n_sol.shape[0]
    for direction in range(2):
        prev = -1e300 if direction == 0 else 1e300
        for kk in range(kg):
            k = kk if direction == 0 else kg - 1 - kk
            best = -1
            for b in range(n_sol[k]):
                ahead = (sol_par[k, b] >= prev - 1e-9 if direction == 0
                         else sol_par[k, b] <= prev + 1e-9)
                if sol_stable[k, b] == 1 and ahead:
                    closer = (sol_par[k, b] < sol_par[k, best] if direction == 0
                              else sol_par[k, b] > sol_par[k, best])
                    if best < 0 or closer:
                        best = b
            if best < 0:
                for b in range(n_sol[k]):
                    if best < 0 or abs(sol_par[k, b] - prev) < abs(sol_par[k, best] - prev):
                        best = b
            if direction == 0:
                up[k] = best
            else:
                down[k] = best
            if best >= 0:
                prev = sol_par[k, best]


@njit(cache=True, nogil=True)
def onset_points(c, order, mode, tr, n_pts, brk, out):
    """Points of the traced curve where the contact margin changes sign (EP Eqs. 36-37).

    Each is refined by the Illinois (regula falsi) method on ``Omega`` with Newton solves on
    the smooth contact-side flow at fixed ``Omega``. Fills ``out[i] = (Omega, a, gamma)`` and
    returns the count.
    """
    pts, seps, jacs, stab = tr
    s = np.empty(N_SEP)
    g = np.empty(2)
    flow = mode | SEP_MARGIN_ONLY
    n_on = 0
    for j in range(n_pts - 1):
        if j + 1 == brk:
            continue
        m0 = seps[j, S_MARGIN]
        m1 = seps[j + 1, S_MARGIN]
        if (m0 > 0.0) == (m1 > 0.0) or n_on >= out.shape[0]:
            continue
        w0, w1 = pts[j, 2], pts[j + 1, 2]
        f0, f1 = m0, m1
        om = w0
        a, gam = pts[j, 0], pts[j, 1]
        side = 0
        for _ in range(60):
            om = (w0 * f1 - w1 * f0) / (f1 - f0) if f1 != f0 else 0.5 * (w0 + w1)
            dw = pts[j + 1, 2] - pts[j, 2]
            frac = (om - pts[j, 2]) / dw if dw != 0.0 else 0.0
            ag = pts[j, 0] + frac * (pts[j + 1, 0] - pts[j, 0])
            gg = pts[j, 1] + frac * (pts[j + 1, 1] - pts[j, 1])
            a, gam, ok = newton_fixed_omega(ag, gg, om, c, order, flow, np.int64(40))
            _g(a, gam, om, c, order, flow, s, g)
            fm = s[S_MARGIN]
            if abs(fm) < 1e-12 or abs(w1 - w0) < 1e-13:
                break
            if (fm > 0.0) == (f0 > 0.0):
                w0, f0 = om, fm
                if side == -1:
                    f1 *= 0.5
                side = -1
            else:
                w1, f1 = om, fm
                if side == 1:
                    f0 *= 0.5
                side = 1
        out[n_on, 0] = om
        out[n_on, 1] = a
        out[n_on, 2] = gam
        n_on += 1
    return n_on


@njit(cache=True, nogil=True)
def unforced_stability(c, om):
    """Stability of the trivial solution without forcing (principal parametric resonance):
    first-order growth rate ``-mu + sqrt((alpha_{1,2}/4)^2 - sigma^2)``."""
    sig = om - 1.0
    disc = (0.25 * c[C_A12]) ** 2 - sig * sig
    growth = -c[C_MU] + (math.sqrt(disc) if disc > 0.0 else 0.0)
    return 1 if growth < 0.0 else 0


@njit(cache=True, nogil=True)
def _trace_window(c, order, mode, om_lo, om_hi, sa, max_pts):
    """The curve across the window, in one piece or, when the piece started at the low end
    leaves the window on the left (a branch bent out of it by softening) or fails, joined
    with a piece traced down from the high end (reversed, so that the curve position still
    runs from low to high frequency). Returns ``(tr, tans, n, brk, status)``."""
    tr = (np.empty((max_pts, 3)), np.empty((max_pts, N_SEP)), np.empty((max_pts, 2, 3)),
          np.zeros(max_pts, np.int64))
    tans = np.empty((max_pts, 3))
    n_a, status, side = trace_curve(c, order, mode, om_lo, om_hi, np.bool_(False), sa, tr,
                                     tans)
    if status == TRACE_UNFORCED or (status == TRACE_OK and side == 1):
        return tr, tans, n_a, -1, status
    trb = (np.empty((max_pts, 3)), np.empty((max_pts, N_SEP)), np.empty((max_pts, 2, 3)),
           np.zeros(max_pts, np.int64))
    tansb = np.empty((max_pts, 3))
    n_b, status_b, side_b = trace_curve(c, order, mode, om_lo, om_hi, np.bool_(True), sa, trb,
                                         tansb)
    n_b = min(n_b, max_pts - n_a)
    for k in range(n_b):  # append the second piece reversed
        src = n_b - 1 - k
        tr[0][n_a + k] = trb[0][src]
        tr[1][n_a + k] = trb[1][src]
        tr[2][n_a + k] = trb[2][src]
        tr[3][n_a + k] = trb[3][src]
        tans[n_a + k] = -tansb[src]
    if status == TRACE_OK and side != 0 and status_b == TRACE_OK:
        status = TRACE_OK
    elif status_b != TRACE_OK:
        status = status_b
    return tr, tans, n_a + n_b, n_a, status


@njit(cache=True, nogil=True)
def sample_response(c, order, mode, grid, max_pts, sol, up, down, onsets):
    """Whole perturbation frequency response of one sample on an increasing grid.

    Returns ``(status, n_onsets, n_points)``.
    """
    sol_a, sol_g, sol_par, sol_stable, sol_sep, n_sol = sol
    lo = grid[0]
    hi = grid[-1]
    margin = 0.02 * (hi - lo) + 1e-9
    om_lo = lo - margin
    om_hi = hi + margin
    sw = max(om_hi - om_lo, 1e-6)
    a_lin, _ = linear_solution(c, 1.0)
    if not math.isfinite(a_lin):  # undamped: scale as with 1 % damping
        a_lin = abs(forcing_phasor(c, 1.0)) / 0.02
    sa = min(max(a_lin, 1e-6), 10.0)
    tr, tans, n_pts, brk, status = _trace_window(c, order, mode, om_lo, om_hi, sa, max_pts)
    if status == TRACE_UNFORCED:
        for k in range(grid.shape[0]):
            n_sol[k] = 1
            sol_a[k, 0] = 0.0
            sol_g[k, 0] = 0.0
            sol_par[k, 0] = 0.0
            sol_stable[k, 0] = unforced_stability(c, grid[k])
            sol_sep[k, 0, :] = 0.0
            sol_sep[k, 0, S_MARGIN] = 1.0
            up[k] = 0
            down[k] = 0
        return status, 0, 0
    if n_pts < 2:
        return status, 0, n_pts
    solve_on_grid(c, order, mode, tr, tans, n_pts, brk, grid, sa, sw, sol)
    sweep_paths(sol_par, sol_stable, n_sol, up, down)
    n_on = onset_points(c, order, mode, tr, n_pts, brk, onsets)
    if status == TRACE_OK:
        for k in range(grid.shape[0]):
            if n_sol[k] == 0:
                status = TRACE_GRID_MISSED
    return status, n_on, n_pts


@njit(cache=True, nogil=True)
def batch_response(coefs, order, mode, grids, max_pts, sol, up, down, onsets, n_onsets,
                   status, n_points):
    """:func:`sample_response` for every row of ``coefs`` (one thread runs one block)."""
    sol_a, sol_g, sol_par, sol_stable, sol_sep, n_sol = sol
    for i in range(coefs.shape[0]):
        st, n_on, n_p = sample_response(
            coefs[i], order, mode, grids[i], max_pts,
            (sol_a[i], sol_g[i], sol_par[i], sol_stable[i], sol_sep[i], n_sol[i]),
            up[i], down[i], onsets[i])
        status[i] = st
        n_onsets[i] = n_on
        n_points[i] = n_p
