"""Compiled core of the LTCA: block active-set solver with a Newton loop on the contact law.

Per mesh position the contact problem (Yuan, Liu and Liu (2020), Eq. 3) is::

    g = xi + D F + chi(F) - delta >= 0,   F >= 0,   F_i g_i = 0,   sum F = P

with ``D`` block diagonal over the lines of contact (different tooth pairs do not interact;
one dense ``n x n`` block per line) and ``chi`` Weber's concave contact approach.

Newton loop (outer)
    ``chi`` is linearised at the current forces ``F0``:
    ``chi(F) ~ chi(F0) + t(F0) (F - F0)`` with the tangent compliance ``t = dchi/dF``.
    Each linearised problem is a linear complementarity problem with the SPD matrix
    ``D + diag(t)``; its exact solution is the next iterate. Converges quadratically
    (4-6 iterations to ``max |dF| <= 1e-13 P``), against 13-15 for the secant fixed point of
    version 1.
Active set (inner)
    The bordered system ``[M_AA 1; 1^T 0]`` is never formed: with the block-diagonal ``M``,
    ``x_b = M_bb^-1 1`` and ``y_b = -M_bb^-1 r_b`` per line (Cholesky, only for lines whose
    active set changed), ``delta = (P - sum y) / sum x`` and ``F = y + delta x``. Negative
    forces are dropped and penetrating points added, all at once for the first iterations
    and one at a time afterwards (which terminates like the classic single-change method).
    Cost per solve is ``sum_b n_b^3 / 3`` instead of ``(sum_b n_b)^3 / 3``.
Tangent stiffness
    At the solution ``dP / d delta = sum_b 1^T (D + diag(t))_AA^-1 1 = sum x`` (exact
    derivative of the force-deflection curve while the contact set is fixed).

Every kernel is compiled with ``nogil=True`` so that samples can run in threads.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

__all__ = ["solve_line_loads", "solve_positions"]

_BULK_ITERATIONS = 8  # active-set iterations that change several points at once


@nb.njit(cache=True, nogil=True)
def _weber(F, dL, R, h1, h2, E, nu, p_floor, chi, tan):
    """Weber's approach ``chi`` and tangent compliance ``t = dchi/dF`` per point [m, m/N].

    ``w = k0 p [ln(4 h1 h2 / a^2) - c]``, ``a^2 ~ p``: ``dw/dp = w/p - k0``. The load per
    length is floored at ``p_floor`` for unloaded points (their ``chi`` is 0); ``t`` is kept
    >= 0 so that ``D + diag(t)`` stays positive definite (it would turn negative only for a
    Hertz half-width comparable with the tooth thickness).
    """
    k0 = 2.0 * (1.0 - nu * nu) / (math.pi * E)
    c = nu / (1.0 - nu)
    for i in range(F.shape[0]):
        p = max(F[i] / dL, p_floor)
        a2 = 8.0 * p * R[i] * (1.0 - nu * nu) / (math.pi * E)
        w_over_p = k0 * (math.log(4.0 * h1[i] * h2[i] / a2) - c)
        tan[i] = max((w_over_p - k0) / dL, 0.0)
        chi[i] = w_over_p * F[i] / dL if F[i] > 0.0 else 0.0


@nb.njit(cache=True, nogil=True)
def _line_solve(D, diag, r, active, n, L, x, y):
    """Solve ``M_AA x = 1`` and ``M_AA y = -r_A`` for one line (``M = D + diag``).

    Cholesky of the active block into ``L`` (workspace), results scattered into ``x``, ``y``
    (zero on inactive points). Returns False if the block is not positive definite.
    """
    idx = np.empty(n, np.int64)
    na = 0
    for i in range(n):
        x[i] = 0.0
        y[i] = 0.0
        if active[i]:
            idx[na] = i
            na += 1
    for a in range(na):
        for c in range(a + 1):
            s = D[idx[a], idx[c]]
            if a == c:
                s += diag[idx[a]]
            for k in range(c):
                s -= L[a, k] * L[c, k]
            if a == c:
                if s <= 0.0:
                    return False
                L[a, a] = math.sqrt(s)
            else:
                L[a, c] = s / L[c, c]
    u = np.empty(na)
    v = np.empty(na)
    for a in range(na):  # forward substitution
        su = 1.0
        sv = -r[idx[a]]
        for k in range(a):
            su -= L[a, k] * u[k]
            sv -= L[a, k] * v[k]
        u[a] = su / L[a, a]
        v[a] = sv / L[a, a]
    for a in range(na - 1, -1, -1):  # back substitution
        su = u[a]
        sv = v[a]
        for k in range(a + 1, na):
            su -= L[k, a] * u[k]
            sv -= L[k, a] * v[k]
        u[a] = su / L[a, a]
        v[a] = sv / L[a, a]
    for a in range(na):
        x[idx[a]] = u[a]
        y[idx[a]] = v[a]
    return True


def line_solve_numpy(D, diag, r, active, n, L, x, y):
    """:func:`_line_solve` with LAPACK's Cholesky for the plain-Python route of the first
    calls (:mod:`gearuq._firstcall`): the loops of the compiled version cost 1 ms a call in
    Python. Same result to rounding (LAPACK sums in another order)."""
    x[:n] = 0.0
    y[:n] = 0.0
    idx = np.flatnonzero(active[:n])
    if idx.size == 0:
        return True
    m = D[np.ix_(idx, idx)] + np.diag(diag[idx])
    try:
        chol = np.linalg.cholesky(m)
    except np.linalg.LinAlgError:  # not positive definite, as the compiled version reports
        return False
    rhs = np.stack([np.ones(idx.size), -r[idx]], axis=1)
    z = np.linalg.solve(chol.T, np.linalg.solve(chol, rhs))
    x[idx] = z[:, 0]
    y[idx] = z[:, 1]
    return True


@nb.njit(cache=True, nogil=True)
def _active_set(D, diag, r, active, P, n_lines, n, F, L, x, y, dirty, max_iter):
    """Exact solution of the linear complementarity problem of one position.

    ``D`` (n_lines, n, n) blocks, ``diag`` and ``r`` (n_lines, n); ``active`` (in/out) the
    loaded set. Returns ``(delta, sum x, iterations, ok)``; ``F`` receives the forces.
    """
    delta = 0.0
    sx = 0.0
    scale = 0.0  # deflection scale P * mean compliance, for the gap tolerance
    for b in range(n_lines):
        for i in range(n):
            scale += D[b, i, i] + diag[b, i]
    scale = P * scale / (n_lines * n * n_lines * n)
    for it in range(max_iter):
        any_active = False
        for b in range(n_lines):
            if dirty[b]:
                if not _line_solve(D[b], diag[b], r[b], active[b], n, L, x[b], y[b]):
                    return delta, sx, it, False
                dirty[b] = False
            for i in range(n):
                any_active = any_active or active[b, i]
        if not any_active:  # start from the point of smallest clearance
            bmin, imin = 0, 0
            for b in range(n_lines):
                for i in range(n):
                    if r[b, i] < r[bmin, imin]:
                        bmin, imin = b, i
            active[bmin, imin] = True
            dirty[bmin] = True
            continue
        sx = 0.0
        sy = 0.0
        for b in range(n_lines):
            for i in range(n):
                sx += x[b, i]
                sy += y[b, i]
        delta = (P - sy) / sx
        bulk = it < _BULK_ITERATIONS
        # drop negative forces (all of them, or the most negative)
        worst = 0.0
        wb, wi = -1, -1
        for b in range(n_lines):
            for i in range(n):
                F[b, i] = y[b, i] + delta * x[b, i] if active[b, i] else 0.0
                if active[b, i] and F[b, i] < -1e-14 * P:
                    if bulk:
                        active[b, i] = False
                        dirty[b] = True
                    elif F[b, i] < worst:
                        worst, wb, wi = F[b, i], b, i
        if wb >= 0:
            active[wb, wi] = False
            dirty[wb] = True
        changed = wb >= 0
        for b in range(n_lines):
            changed = changed or dirty[b]
        if changed:
            continue
        # add penetrating points (all of them, or the most penetrating)
        tol_g = -1e-12 * (abs(delta) + scale)
        worst = tol_g
        for b in range(n_lines):
            for i in range(n):
                if active[b, i]:
                    continue
                g = r[b, i] - delta
                for j in range(n):
                    if active[b, j]:
                        g += D[b, i, j] * F[b, j]
                if g < tol_g:
                    if bulk:
                        active[b, i] = True
                        dirty[b] = True
                    elif g < worst:
                        worst, wb, wi = g, b, i
        if wb >= 0:
            active[wb, wi] = True
            dirty[wb] = True
            changed = True
        for b in range(n_lines):
            changed = changed or dirty[b]
        if not changed:
            for b in range(n_lines):
                for i in range(n):
                    F[b, i] = max(F[b, i], 0.0)
            return delta, sx, it + 1, True
    return delta, sx, max_iter, False


@nb.njit(cache=True, nogil=True)
def _solve_position(D, xi, dL, R, h1, h2, P, E, nu, hertz, tol, max_newton, active, F):
    """Newton loop on Weber's law around the exact active-set solve (one position).

    ``active`` and ``F`` (n_lines, n) carry the warm start in and the solution out. Returns
    ``(delta, tangent stiffness, Newton iterations, ok)``.
    """
    n_lines, n = xi.shape
    total_len = 0.0
    for b in range(n_lines):
        total_len += dL[b] * n
    p_floor = 1e-3 * P / total_len
    chi = np.zeros(n)
    tan = np.zeros(n)
    diag = np.zeros((n_lines, n))
    r = np.empty((n_lines, n))
    Fn = np.zeros((n_lines, n))
    L = np.empty((n, n))
    x = np.zeros((n_lines, n))
    y = np.zeros((n_lines, n))
    dirty = np.ones(n_lines, np.bool_)
    delta, k_t = 0.0, 0.0
    for it in range(max_newton):
        for b in range(n_lines):
            if hertz:
                _weber(F[b], dL[b], R[b], h1[b], h2[b], E, nu, p_floor, chi, tan)
            for i in range(n):
                diag[b, i] = tan[i] if hertz else 0.0
                r[b, i] = xi[b, i] + (chi[i] - tan[i] * F[b, i] if hertz else 0.0)
            dirty[b] = True
        delta, k_t, _, ok = _active_set(D, diag, r, active, P, n_lines, n, Fn, L, x, y, dirty,
                                        20 * n_lines * n + 50)
        change = 0.0
        for b in range(n_lines):
            for i in range(n):
                change = max(change, abs(Fn[b, i] - F[b, i]))
                F[b, i] = Fn[b, i]
        if not ok:
            return delta, k_t, it + 1, False
        if not hertz or change <= tol * P:
            return delta, k_t, it + 1, True
    return delta, k_t, max_newton, False


@nb.njit(cache=True, nogil=True)
def solve_positions(D, phase, pair_index, xi, dL, R, h1, h2, P, E, nu, hertz, tol, max_newton,
                    F_out, gap_out, ste, k_tan, n_iter, status):
    """Solve every mesh position in order, warm-starting each tooth pair from its last state.

    Parameters
    ----------
    D : (n_phase, n, n) influence blocks of the distinct line geometries [m/N]
    phase : (n_pos, n_lines) int, index into ``D`` (and ``dL``, ``R``...), -1 = no line
    pair_index : (n_pos, n_lines) int, tooth-pair counter (for the warm start)
    xi : (n_pos, n_lines, n) initial clearances [m]
    dL : (n_phase,) segment length; R, h1, h2 : (n_phase, n) Hertz data [m]
    P, E, nu : normal force [N], elastic constants; hertz : include Weber's approach
    tol, max_newton : Newton tolerance on ``max |dF| / P`` and iteration limit
    F_out, gap_out : (n_pos, n_lines, n) outputs (forces [N], residual gaps [m])
    ste, k_tan : (n_pos,) outputs (approach [m], tangent stiffness [N/m])
    n_iter, status : (n_pos,) outputs (Newton iterations; 0 ok, 1 not converged)
    """
    n_pos, n_lines_max, n = xi.shape
    prev_F = np.zeros((n_lines_max, n))
    prev_active = np.zeros((n_lines_max, n), np.bool_)
    prev_pair = np.full(n_lines_max, -(2**62), np.int64)
    chi = np.zeros(n)
    tan = np.zeros(n)
    for p in range(n_pos):
        lines = np.nonzero(phase[p] >= 0)[0]
        nl = lines.shape[0]
        Dp = np.empty((nl, n, n))
        xip = np.empty((nl, n))
        dLp = np.empty(nl)
        Rp = np.empty((nl, n))
        h1p = np.empty((nl, n))
        h2p = np.empty((nl, n))
        active = np.zeros((nl, n), np.bool_)
        F = np.zeros((nl, n))
        total_len = 0.0
        for a in range(nl):
            ph = phase[p, lines[a]]
            Dp[a] = D[ph]
            xip[a] = xi[p, lines[a]]
            dLp[a] = dL[ph]
            Rp[a] = R[ph]
            h1p[a] = h1[ph]
            h2p[a] = h2[ph]
            total_len += dL[ph] * n
        warm = False
        for a in range(nl):
            for q in range(n_lines_max):
                if prev_pair[q] == pair_index[p, lines[a]]:
                    warm = True
                    for i in range(n):
                        active[a, i] = prev_active[q, i]
                        F[a, i] = prev_F[q, i]
        if not warm:  # uniform line load as the first linearisation point
            for a in range(nl):
                for i in range(n):
                    F[a, i] = P * dLp[a] / total_len
        delta, kt, it, ok = _solve_position(Dp, xip, dLp, Rp, h1p, h2p, P, E, nu, hertz, tol,
                                            max_newton, active, F)
        ste[p] = delta
        k_tan[p] = kt
        n_iter[p] = it
        status[p] = 0 if ok else 1
        prev_pair[:] = -(2**62)
        for a in range(nl):
            ln = lines[a]
            prev_pair[a] = pair_index[p, ln]
            if hertz:
                _weber(F[a], dLp[a], Rp[a], h1p[a], h2p[a], E, nu, 1e-3 * P / total_len, chi,
                       tan)
            for i in range(n):
                g = xip[a, i] - delta + (chi[i] if hertz else 0.0)
                for j in range(n):
                    g += Dp[a, i, j] * F[a, j]
                F_out[p, ln, i] = F[a, i]
                gap_out[p, ln, i] = g
                prev_F[a, i] = F[a, i]
                prev_active[a, i] = F[a, i] > 0.0


@nb.njit(cache=True, nogil=True)
def solve_line_loads(D, xi, dL, R, h1, h2, loads, E, nu, hertz, tol, max_newton, F_out,
                     approach, k_tan, n_iter, status):
    """Solve one line of contact alone at prescribed line loads, for every line geometry.

    Different tooth pairs do not interact (``D`` is block diagonal over the lines), so a
    line's share of the mesh is a function of its own approach alone; this tabulates that
    function (:mod:`gearuq.gears.long_period`). Each geometry is solved at increasing loads,
    warm-started from the previous load, with the same Newton / active-set solver as
    :func:`solve_positions` (one line, ``P`` = the line load).

    Parameters
    ----------
    D : (n_phase, n, n) influence blocks [m/N]
    xi : (n_phase, n) initial clearances of each geometry [m]
    dL : (n_phase,) segment length; R, h1, h2 : (n_phase, n) Hertz data [m]
    loads : (n_load,) increasing line loads [N], > 0
    E, nu, hertz, tol, max_newton : as :func:`solve_positions`
    F_out : (n_phase, n_load, n) output forces [N]
    approach, k_tan : (n_phase, n_load) outputs: approach of the line [m] and tangent
        stiffness ``dL / d approach`` [N/m]
    n_iter, status : (n_phase, n_load) outputs (Newton iterations; 0 ok, 1 not converged)
    """
    n_phase, n = xi.shape
    for q in range(n_phase):
        Dq = np.ascontiguousarray(D[q:q + 1])
        xiq = np.ascontiguousarray(xi[q:q + 1])
        dLq = dL[q:q + 1].copy()
        Rq = np.ascontiguousarray(R[q:q + 1])
        h1q = np.ascontiguousarray(h1[q:q + 1])
        h2q = np.ascontiguousarray(h2[q:q + 1])
        active = np.zeros((1, n), np.bool_)
        F = np.zeros((1, n))
        for i in range(n):  # uniform line load as the first linearisation point
            F[0, i] = loads[0] / n
        for j in range(loads.shape[0]):
            delta, kt, it, ok = _solve_position(Dq, xiq, dLq, Rq, h1q, h2q, loads[j], E, nu,
                                                hertz, tol, max_newton, active, F)
            approach[q, j] = delta
            k_tan[q, j] = kt
            n_iter[q, j] = it
            status[q, j] = 0 if ok else 1
            for i in range(n):
                F_out[q, j, i] = F[0, i]
