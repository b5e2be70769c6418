"""Location of switching-surface crossings within a Runge-Kutta step (compiled).

A step's dense-output interpolant u(theta) is searched for the first sign change of the
switching functions g(t, u): :func:`scan_crossing` samples g at the quarter points of the
step (and at the predicted extremum of g where a component comes close to its surface),
:func:`first_root` locates the earliest root among the components that changed sign, each
by Brent's method (:func:`root_bracket`) to a bracket that keeps one end strictly past the
surface. See docs/ode.md for the algorithm and its limits (grazing contacts).
"""

from __future__ import annotations

import math

from numba import njit

from .constants import EPS, ROOT_XTOL_REL
from .stages import dense_eval


@njit(error_model="numpy", inline="always")
def sgn(x):
    """Sign as -1, 0, +1; NaN gives 0 (an unknown side never triggers an event)."""
    if x > 0.0:
        return 1
    if x < 0.0:
        return -1
    return 0


@njit(error_model="numpy", inline="always")
def g_at(switch, R, m, y, t, h, p, tau, ym, g):
    """g(tau, u(tau)) on the interpolant of the step [t, t + h]; writes g, returns nothing."""
    dense_eval(R, m, y, (tau - t) / h, ym)
    switch(tau, ym, p, g)


@njit(error_model="numpy")
def scan_crossing(switch, R, m, y, t, hs, p, t_base, g_base, t_new, g1, sgn_known, n_switch,
                  ym, gs, ga, gb, gw):
    """Whether a switching function changes sign in (t_base, t_new] of the current step.

    g is sampled on the interpolant at the quarter points of (t_base, t_new] and at the end
    (gs rows 0..4, row 0 = g_base). Where the parabola through three consecutive samples of a
    component that keeps its side has its extremum between them and comes within a quarter
    of the way to the surface, g is sampled once more at that extremum: that catches an
    excursion across the surface and back between two samples.

    Returns ``(found, ta, tb)``: the first sample interval [ta, tb] with a sign change, its
    end values of g in ``ga`` and ``gb``.
    """
    span = t_new - t_base
    for s in range(n_switch):
        gs[0, s] = g_base[s]
        gs[4, s] = g1[s]
    for k in range(1, 4):
        g_at(switch, R, m, y, t, hs, p, t_base + 0.25 * k * span, ym, gw)
        for s in range(n_switch):
            gs[k, s] = gw[s]
    # First quarter with a sign change.
    kc = 5
    for k in range(1, 5):
        for s in range(n_switch):
            sg = sgn(gs[k, s])
            if sgn_known[s] != 0 and sg != 0 and sg != sgn_known[s]:
                kc = k
                break
        if kc < 5:
            break
    ta = t_base + 0.25 * (kc - 1) * span
    tb = t_new if kc >= 4 else t_base + 0.25 * kc * span
    found = kc < 5
    if found:
        for s in range(n_switch):
            ga[s] = gs[kc - 1, s]
            gb[s] = gs[kc, s]
    # Excursions between samples, before the first quarter with a sign change.
    for k in range(1, min(kc - 1, 4)):
        for s in range(n_switch):
            side = sgn_known[s]
            if side == 0:
                continue
            # Distances to the surface (positive on the current side) at samples k-1, k, k+1.
            a0 = gs[k - 1, s] * side
            a1 = gs[k, s] * side
            a2 = gs[k + 1, s] * side
            c1 = 0.5 * (a2 - a0)
            c2 = 0.5 * (a0 + a2) - a1
            if not (a0 > 0.0 and a1 > 0.0 and a2 > 0.0 and c2 > 0.0):
                continue
            uv = -c1 / (2.0 * c2)  # minimum of the parabola, in quarters from sample k
            if abs(uv) > 1.0 or a1 - c1 * c1 / (4.0 * c2) >= 0.25 * min(a0, a1, a2):
                continue
            tv = t_base + 0.25 * (k + uv) * span
            if found and tv >= tb:
                continue
            g_at(switch, R, m, y, t, hs, p, tv, ym, gw)
            if sgn(gw[s]) == -side:
                found = True
                ta = t_base + 0.25 * (k - 1) * span
                tb = tv
                for q in range(n_switch):
                    ga[q] = gs[k - 1, q]
                    gb[q] = gw[q]
    return found, ta, tb


@njit(error_model="numpy")
def first_root(switch, R, m, y, t, hs, p, ta, tb, sgn_known, n_switch, ym, ga, gb, gw, dt_ok):
    """The earliest root in [ta, tb] among the components whose sign differs at ta and tb.

    Returns ``(comp, tb)``: the component whose root comes first (-1: none) and the end of
    its root bracket that lies past the surface. A root closer than ``dt_ok`` to the end of
    its bracket is accepted without a search.
    """
    xtol = ROOT_XTOL_REL * hs
    first = -1
    for s in range(n_switch):
        sg = sgn(gb[s])
        if sgn_known[s] == 0 or sg == 0 or sg == sgn_known[s]:
            continue
        if sgn(ga[s]) == -sgn_known[s]:
            # Already past the surface at ta (possible only at t_base, e.g. two surfaces that
            # coincide): its root is at ta, within the tolerance of an earlier one.
            hi = ta
        else:
            # Probe just before tb first: after a step has been cut at a root, that root lies
            # within tolerance of the step end, and the probe confirms it without a search.
            tp = tb - max(0.5 * (xtol + 4.0 * EPS * abs(tb)), dt_ok)
            if tp <= ta:
                hi = tb
            else:
                g_at(switch, R, m, y, t, hs, p, tp, ym, gw)
                fp = gw[s]
                if sgn(fp) != -sgn_known[s]:
                    hi = tb
                else:
                    _lo, hi = root_bracket(switch, R, m, y, t, hs, p, ym, gw, s, sgn_known[s],
                                           ta, ga[s], tp, fp, xtol)
        if first < 0 or hi < tb:
            first = s
            if hi < tb:
                # Later components only need to be searched before this root.
                tb = hi
                g_at(switch, R, m, y, t, hs, p, tb, ym, gb)
    return first, tb


@njit(error_model="numpy")
def root_bracket(switch, R, m, y, t, h, p, ym, gw, comp, old, ta, fa, tb, fb, xtol):
    """Brent's method (port of scipy's brentq.c) for switching component ``comp``.

    On entry g_comp(ta) lies on side ``old`` (or is zero) and g_comp(tb) strictly on the other
    side. An exact zero counts as "not yet crossed" (it is replaced by a tiny value of sign
    ``old``), so the bracket always keeps one end strictly on the new side. Returns
    ``(lo, hi)``: lo on the old side, hi on the new side, |hi - lo| <= xtol + 4 ulp(t).
    """
    tiny = old * 1e-300
    if fa == 0.0:
        fa = tiny
    xpre = ta
    xcur = tb
    fpre = fa
    fcur = fb
    xblk = 0.0
    fblk = 0.0
    spre = 0.0
    scur = 0.0
    for _ in range(200):
        if (fpre > 0.0) != (fcur > 0.0):
            xblk = xpre
            fblk = fpre
            spre = xcur - xpre
            scur = spre
        if abs(fblk) < abs(fcur):
            xpre = xcur
            xcur = xblk
            xblk = xpre
            fpre = fcur
            fcur = fblk
            fblk = fpre
        delta = 0.5 * (xtol + 4.0 * EPS * abs(xcur))
        sbis = 0.5 * (xblk - xcur)
        if abs(sbis) < delta:
            break
        if abs(spre) > delta and abs(fcur) < abs(fpre):
            if xpre == xblk:
                stry = -fcur * (xcur - xpre) / (fcur - fpre)
            else:
                dpre = (fpre - fcur) / (xpre - xcur)
                dblk = (fblk - fcur) / (xblk - xcur)
                stry = -fcur * (fblk * dblk - fpre * dpre) / (dblk * dpre * (fblk - fpre))
            if 2.0 * abs(stry) < min(abs(spre), 3.0 * abs(sbis) - delta):
                spre = scur
                scur = stry
            else:
                spre = sbis
                scur = sbis
        else:
            spre = sbis
            scur = sbis
        xpre = xcur
        fpre = fcur
        if abs(scur) > delta:
            xcur += scur
        else:
            xcur += delta if sbis > 0.0 else -delta
        g_at(switch, R, m, y, t, h, p, xcur, ym, gw)
        fcur = gw[comp]
        if fcur == 0.0 or not math.isfinite(fcur):
            fcur = tiny
    # xcur and xblk are on opposite sides; report which one is past the surface.
    if sgn(fcur) == old:
        return xcur, xblk
    return xblk, xcur


@njit(error_model="numpy")
def overshoot_tol(K, kf, y, atol, rtol, hs):
    """How far past a surface a step may end: the time in which y moves by one tolerance unit.

    1 / RMS(f_i / (atol_i + rtol |y_i|)) with f = K[kf] = f(t_new, y): ending that far past a
    jump of rhs of the size of f costs about one unit of the local error tolerance, and far
    less at a kink (O(overshoot^2)). Capped at 1e-3 * hs for a state at rest.
    """
    n = y.size
    s = 0.0
    for i in range(n):
        r = K[kf, i] / max(atol[i] + rtol * abs(y[i]), 1e-300)
        s += r * r
    cap = 1e-3 * hs
    if s * cap * cap <= n:
        return cap
    return math.sqrt(n / s)


