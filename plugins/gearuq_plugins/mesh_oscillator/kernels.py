"""Compiled right-hand sides of the nondimensional mesh oscillator for ``gearuq.ode``.

Every kernel integrates ``u'' + 2 mu u' + C(u, theta) f(u, theta) = F(theta)`` in the
nondimensional time ``T = omega_n t`` with the mesh phase ``theta``; they differ only in how
``f`` is represented:

``expanded`` (EP Eqs. 11-12)
    ``f = sum_i [alpha_{i,0} + sum_r alpha_{i,r} cos(r theta - phi_{i,r})] u^i`` with contact
    while ``u >= u_c = -1 + sum_r e_r cos(r theta - psi_r)``; exact for polynomial forces.
``segments``
    ``f = sum_j kappa_j(theta) max(u - c_j(theta), 0)^p_j`` (linear, Hertzian and piecewise
    linear contact with partial contact loss); ``kappa_j`` and ``c_j`` are Fourier series.
``table``
    load-deflection table: nodes ``(u_l(theta), P_l)`` with ``P_0 = 0`` at the unloaded
    deflection, cubic Hermite in ``u`` on the node slopes (tangent stiffnesses), linear from
    the unloaded deflection to the first load, linear extrapolation above the last load;
    nodes and slopes are Fourier series in ``theta``.

The excitation frequency is piecewise constant in time (a *schedule* of segments, each an
integer number of excitation periods so that ``theta`` restarts at 0 with each segment):
one integration runs a whole frequency sweep, continuing from the previous state. The
switching function of contact loss (``u - u_c``, or one per contact segment) is located by
the integrator; with ``freeze_sides=True`` the contact state of every stage is the one at the
step start (docs/ode.md).

Common layout of the coefficient vector ``p`` (per sample)::

    p[0] n_switch  p[1] offset of the schedule  p[2] mu  p[3] F0 (nondimensional mean load)
    p[4] offset of the load harmonics  p[5] number of load harmonics R_q  p[6] exponent k
    load harmonics: q_1..q_Rq, rho_1..rho_Rq       (amplitude q_r Omega^k)
    kernel block (see ``*_layout`` functions)
    schedule: K, t_start[K], omega[K]
    frozen sides (n_switch values, appended by the integrator)

EP: Eritenel and Parker (2013), the paper this model follows (docs/models.md).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

H_NSWITCH = 0
H_SCHED = 1
H_MU = 2
H_F0 = 3
H_QOFF = 4
H_NQ = 5
H_QEXP = 6
H_BLOCK = 7  # first entry of the kernel block
#: Kernel kinds.
KIND_EXPANDED = 0
KIND_SEGMENTS = 1
KIND_TABLE = 2


@njit(cache=True, inline="always")
def schedule(t: float, p: np.ndarray) -> tuple[float, float]:
    """Excitation frequency and phase ``theta`` at time ``t`` (binary search of the segment)."""
    off = int(p[H_SCHED])
    k_seg = int(p[off])
    lo = 0
    hi = k_seg - 1
    while lo < hi:  # last segment with t_start <= t
        mid = (lo + hi + 1) // 2
        if p[off + 1 + mid] <= t:
            lo = mid
        else:
            hi = mid - 1
    om = p[off + 1 + k_seg + lo]
    return om, om * (t - p[off + 1 + lo])


@njit(cache=True, inline="always")
def external_load(theta: float, om: float, p: np.ndarray) -> float:
    """Nondimensional applied load ``F0 + sum_r q_r Omega^k cos(r theta - rho_r)``."""
    off = int(p[H_QOFF])
    nq = int(p[H_NQ])
    load = p[H_F0]
    if nq == 0:
        return load
    scale = 1.0 if p[H_QEXP] == 0.0 else om ** p[H_QEXP]
    for r in range(nq):
        load += scale * p[off + r] * math.cos((r + 1) * theta - p[off + nq + r])
    return load


@njit(cache=True, inline="always")
def fourier(theta: float, p: np.ndarray, off: int, nh: int) -> float:
    """``p[off] + sum_r (p[off+2r-1] cos(r theta) + p[off+2r] sin(r theta))``, r = 1..nh."""
    val = p[off]
    if nh == 0:
        return val
    c1 = math.cos(theta)
    s1 = math.sin(theta)
    cr, sr = c1, s1
    for r in range(nh):
        val += p[off + 1 + 2 * r] * cr + p[off + 2 + 2 * r] * sr
        cr, sr = cr * c1 - sr * s1, sr * c1 + cr * s1
    return val


@njit(cache=True, inline="always")
def contact_side(g: float, side: float) -> bool:
    """Contact decided by the frozen side of the switching function (state when unknown)."""
    if side > 0.0:
        return True
    if side < 0.0:
        return False
    return g >= 0.0


# ------------------------------------------------------------------------- expanded (Eq. 11)
@njit(cache=True, inline="always")
def _expanded_force(u: float, theta: float, p: np.ndarray) -> tuple[float, float]:
    """Expanded force ``f(u, theta)`` (without the separation) and the boundary ``u_c``.

    Block: ``n_order N, n_harm R, alpha[(N+1)(R+1)], phi[(N+1)(R+1)], e[R], psi[R]``.
    """
    b = H_BLOCK
    n_ord = int(p[b])
    n_h = int(p[b + 1])
    a_off = b + 2
    nn = (n_ord + 1) * (n_h + 1)
    f = 0.0
    upow = 1.0
    for i in range(n_ord + 1):
        coef = p[a_off + i * (n_h + 1)]
        for r in range(1, n_h + 1):
            amp = p[a_off + i * (n_h + 1) + r]
            if amp != 0.0:
                coef += amp * math.cos(r * theta - p[a_off + nn + i * (n_h + 1) + r])
        f += coef * upow
        upow *= u
    e_off = a_off + 2 * nn
    uc = -1.0
    for r in range(1, n_h + 1):
        amp = p[e_off + r - 1]
        if amp != 0.0:
            uc += amp * math.cos(r * theta - p[e_off + n_h + r - 1])
    return f, uc


@njit(cache=True)
def rhs_expanded(t: float, y: np.ndarray, p: np.ndarray, dydt: np.ndarray) -> None:
    """EP Eq. 11 with the contact side frozen per step (``freeze_sides=True``)."""
    om, theta = schedule(t, p)
    f, uc = _expanded_force(y[0], theta, p)
    side = p[p.size - 1]
    contact = contact_side(y[0] - uc, side)
    dydt[0] = y[1]
    dydt[1] = external_load(theta, om, p) - 2.0 * p[H_MU] * y[1] - (f if contact else 0.0)


@njit(cache=True)
def switch_expanded(t: float, y: np.ndarray, p: np.ndarray, g: np.ndarray) -> None:
    """Contact-loss switching function ``u - u_c(theta)``."""
    om, theta = schedule(t, p)
    f, uc = _expanded_force(y[0], theta, p)
    g[0] = y[0] - uc


# ------------------------------------------------------------------------- segments
@njit(cache=True, inline="always")
def _segment_term(u: float, theta: float, p: np.ndarray, j: int) -> tuple[float, float]:
    """Stiffness and clearance of contact segment ``j``: block
    ``n_seg, H, then per segment: exponent, kappa[2H+1], clearance[2H+1]``."""
    b = H_BLOCK
    nh = int(p[b + 1])
    width = 1 + 2 * (2 * nh + 1)
    off = b + 2 + j * width
    kappa = fourier(theta, p, off + 1, nh)
    clear = fourier(theta, p, off + 2 + 2 * nh, nh)
    return kappa, clear


@njit(cache=True)
def rhs_segments(t: float, y: np.ndarray, p: np.ndarray, dydt: np.ndarray) -> None:
    """Sum of power-law contact segments, each switched by its own frozen side."""
    om, theta = schedule(t, p)
    b = H_BLOCK
    n_seg = int(p[b])
    nh = int(p[b + 1])
    width = 1 + 2 * (2 * nh + 1)
    n_sw = int(p[H_NSWITCH])
    u = y[0]
    f = 0.0
    for j in range(n_seg):
        kappa, clear = _segment_term(u, theta, p, j)
        if contact_side(u - clear, p[p.size - n_sw + j]):
            expo = p[b + 2 + j * width]
            gap = u - clear
            if expo == 1.0:
                f += kappa * gap
            else:  # a stage beyond the frozen kink must not take a power of a negative gap
                f += kappa * (gap if gap > 0.0 else 0.0) ** expo
    dydt[0] = y[1]
    dydt[1] = external_load(theta, om, p) - 2.0 * p[H_MU] * y[1] - f


@njit(cache=True)
def switch_segments(t: float, y: np.ndarray, p: np.ndarray, g: np.ndarray) -> None:
    """One switching function ``u - c_j(theta)`` per contact segment."""
    om, theta = schedule(t, p)
    n_seg = int(p[H_BLOCK])
    for j in range(n_seg):
        kappa, clear = _segment_term(y[0], theta, p, j)
        g[j] = y[0] - clear


# ------------------------------------------------------------------------- table
@njit(cache=True, inline="always")
def _table_node(theta: float, p: np.ndarray, l: int) -> tuple[float, float, float]:
    """Load, deflection and slope of node ``l``: block
    ``n_nodes L, H, P[L], then per node: u[2H+1], slope[2H+1]`` (node 0: unloaded)."""
    b = H_BLOCK
    n_nodes = int(p[b])
    nh = int(p[b + 1])
    width = 2 * (2 * nh + 1)
    off = b + 2 + n_nodes + l * width
    return p[b + 2 + l], fourier(theta, p, off, nh), fourier(theta, p, off + 2 * nh + 1, nh)


@njit(cache=True, inline="always")
def table_force(u: float, theta: float, p: np.ndarray) -> float:
    """Force of the load-deflection table at ``(u, theta)`` for ``u`` above the unloaded
    deflection (the caller handles contact)."""
    n_nodes = int(p[H_BLOCK])
    p0, u0, s0 = _table_node(theta, p, 0)
    p1, u1, s1 = _table_node(theta, p, 1)
    if u <= u1:  # linear from the unloaded deflection to the first load
        return p1 * (u - u0) / (u1 - u0)
    for l in range(1, n_nodes - 1):
        p2, u2, s2 = _table_node(theta, p, l + 1)
        if u <= u2:
            h = u2 - u1
            x = (u - u1) / h
            h00 = (1.0 + 2.0 * x) * (1.0 - x) ** 2
            h10 = x * (1.0 - x) ** 2
            h01 = x * x * (3.0 - 2.0 * x)
            h11 = x * x * (x - 1.0)
            return h00 * p1 + h10 * h * s1 + h01 * p2 + h11 * h * s2
        p1, u1, s1 = p2, u2, s2
    return p1 + s1 * (u - u1)  # above the last load: tangent extrapolation


@njit(cache=True)
def rhs_table(t: float, y: np.ndarray, p: np.ndarray, dydt: np.ndarray) -> None:
    """Load-deflection table force with the contact side frozen per step."""
    om, theta = schedule(t, p)
    b = H_BLOCK
    nh = int(p[b + 1])
    u0 = fourier(theta, p, b + 2 + int(p[b]), nh)
    contact = contact_side(y[0] - u0, p[p.size - 1])
    f = table_force(y[0], theta, p) if contact else 0.0
    dydt[0] = y[1]
    dydt[1] = external_load(theta, om, p) - 2.0 * p[H_MU] * y[1] - f


@njit(cache=True)
def switch_table(t: float, y: np.ndarray, p: np.ndarray, g: np.ndarray) -> None:
    """Contact-loss switching function ``u - u_0(theta)``."""
    om, theta = schedule(t, p)
    b = H_BLOCK
    g[0] = y[0] - fourier(theta, p, b + 2 + int(p[b]), int(p[b + 1]))


KERNELS = {
    KIND_EXPANDED: ("rhs_expanded", "switch_expanded"),
    KIND_SEGMENTS: ("rhs_segments", "switch_segments"),
    KIND_TABLE: ("rhs_table", "switch_table"),
}
