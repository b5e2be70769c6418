"""Compiled right-hand side of the reduced geared rotor for :func:`gearuq.ode.solve_batch`.

State ``y = [eta_0..eta_{n-1}, eta'_0..eta'_{n-1}]`` (modal coordinates of the retained
modes). The mesh approach is algebraic (static correction of the dropped modes)::

    delta = delta_m - h_res r,   delta_m = psi . eta + delta_res
    r = F - k_bar delta,   F = k delta - ke (contact), 0 (separated), k delta - ke + k b (back)

which is solved per branch in closed form; the two switching functions
``g0 = k delta_m - ke (1 - h_res k_bar)`` (contact) and
``g1 = k delta_m - (ke - k b)(1 - h_res k_bar)`` (back flank) do not depend on the branch.
``k(t)`` and ``(k e)(t)`` are Fourier series of the long period (angle-addition recurrence).

Coefficient vector ``p`` (layout written by :func:`gearuq.rotor.time_integration.pack`)::

    [n, nh, w0, k_bar, h_res, delta_res, backlash,
     w^2 (n), D (n*n, column-major, D = C_r + Omega G_r), psi (n), f_load (n),
     k_c (nh+1), k_s (nh+1), ke_c (nh+1), ke_s (nh+1)]      (+ 2 frozen sides)

with ``x(t) = x_c[0] + sum_j (x_c[j] cos(j w0 t) + x_s[j] sin(j w0 t))``.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

HEADER = 7


@njit(cache=True, inline="always")
def _series(t: float, p: np.ndarray) -> tuple[float, float]:
    """``k(t)`` and ``(k e)(t)`` from their Fourier coefficients."""
    n = int(p[0])
    nh = int(p[1])
    w0 = p[2]
    base = HEADER + n + n * n + 2 * n
    m = nh + 1
    c1 = math.cos(w0 * t)
    s1 = math.sin(w0 * t)
    k = p[base]
    ke = p[base + 2 * m]
    cj, sj = c1, s1
    for j in range(1, m):
        k += p[base + j] * cj + p[base + m + j] * sj
        ke += p[base + 2 * m + j] * cj + p[base + 3 * m + j] * sj
        cj, sj = cj * c1 - sj * s1, sj * c1 + cj * s1
    return k, ke


@njit(cache=True, inline="always")
def _mesh_delta_m(y: np.ndarray, p: np.ndarray) -> float:
    n = int(p[0])
    dm = p[5]
    off = HEADER + n + n * n
    for i in range(n):
        dm += p[off + i] * y[i]
    return dm


@njit(cache=True, inline="always")
def _remainder(dm: float, k: float, ke: float, p: np.ndarray, side0: float, side1: float
               ) -> float:
    """``r = F - k_bar delta`` on the branch given by the sides of g0 and g1."""
    kbar, hres, b = p[3], p[4], p[6]
    if side0 > 0.0:                       # contact
        d = (dm + hres * ke) / (1.0 + hres * (k - kbar))
        return k * d - ke - kbar * d
    if side1 < 0.0:                       # back-flank contact
        d = (dm + hres * (ke - k * b)) / (1.0 + hres * (k - kbar))
        return k * d - ke + k * b - kbar * d
    d = dm / (1.0 - hres * kbar)          # separated
    return -kbar * d


@njit(cache=True, inline="always")
def _rates(y: np.ndarray, p: np.ndarray, r: float, dydt: np.ndarray) -> None:
    n = int(p[0])
    w2 = HEADER
    D = HEADER + n
    psi = HEADER + n + n * n
    fl = psi + n
    for i in range(n):
        dydt[i] = y[n + i]
        dydt[n + i] = p[fl + i] - p[w2 + i] * y[i] - p[psi + i] * r
    # column by column (D stored column-major): each rate subtracts its terms in the order
    # j = 0, 1, ... as a row-wise loop would, bit for bit, and the loop over i vectorises
    for j in range(n):
        v = y[n + j]
        col = D + j * n
        for i in range(n):
            dydt[n + i] -= p[col + i] * v


@njit(cache=True, inline="always")
def _switches(dm: float, k: float, ke: float, p: np.ndarray) -> tuple[float, float]:
    one = 1.0 - p[4] * p[3]
    g0 = k * dm - ke * one
    b = p[6]
    g1 = k * dm - (ke - k * b) * one if b < 1e300 else 1.0
    return g0, g1


@njit(cache=True, error_model="numpy")
def rhs(t: float, y: np.ndarray, p: np.ndarray, dydt: np.ndarray) -> None:
    """dy/dt with the branch decided by the state."""
    k, ke = _series(t, p)
    dm = _mesh_delta_m(y, p)
    g0, g1 = _switches(dm, k, ke, p)
    _rates(y, p, _remainder(dm, k, ke, p, 1.0 if g0 > 0.0 else -1.0,
                            -1.0 if g1 < 0.0 else 1.0), dydt)


@njit(cache=True, error_model="numpy")
def rhs_sides(t: float, y: np.ndarray, p: np.ndarray, dydt: np.ndarray) -> None:
    """dy/dt with the branch from the integrator's frozen sides ``p[-2:]``."""
    k, ke = _series(t, p)
    dm = _mesh_delta_m(y, p)
    s0, s1 = p[p.size - 2], p[p.size - 1]
    if s0 == 0.0 or s1 == 0.0:
        g0, g1 = _switches(dm, k, ke, p)
        s0 = 1.0 if g0 > 0.0 else -1.0
        s1 = -1.0 if g1 < 0.0 else 1.0
    _rates(y, p, _remainder(dm, k, ke, p, s0, s1), dydt)


@njit(cache=True, error_model="numpy")
def switch(t: float, y: np.ndarray, p: np.ndarray, g: np.ndarray) -> None:
    """Switching functions: loss of contact (g0) and back-flank contact (g1)."""
    k, ke = _series(t, p)
    dm = _mesh_delta_m(y, p)
    g0, g1 = _switches(dm, k, ke, p)
    g[0] = g0
    g[1] = g1
