"""Compiled right-hand side of the nondimensional 10-DOF helical-pair equations.

State ``y = [q_0..q_9, q_0'..q_9']`` with DOF order
``x_p, y_p, z_p, swing_p, torsion_p, x_g, y_g, z_g, swing_g, torsion_g`` (all as lengths over
the length scale L; rotations as pitch-radius arc lengths). Per-sample coefficient vector
``p`` (layout below) is built in ``__init__._coefficients``. See docs/theory/helical_pair.md.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from gearuq_plugins.helical_pair.layout import (
    I_B5,
    I_BETA,
    I_CPHI,
    I_EPS0,
    I_EPSA,
    I_ETA,
    I_G,
    I_HARM,
    I_MU,
    I_NHARM,
    I_OMEGA,
    I_PHI,
    I_S,
    I_SPHI,
    I_V,
    I_XI,
    I_ZETA,
    N_COEF,
    N_DOF,
)


@njit(cache=True, inline="always")
def dead_zone(x: float, b: float) -> float:
    """Backlash function f(x) = x - b (x > b), 0 (|x| <= b), x + b (x < -b)."""
    if x > b:
        return x - b
    if x < -b:
        return x + b
    return 0.0


@njit(cache=True, inline="always")
def excitation(tau: float, p: np.ndarray) -> tuple[float, float, float]:
    """kappa = k(tau)/k_m, eps = e/L and d eps/d tau from one sin/cos pair of Omega tau.

    kappa is the seed form 1 + s cos(Omega tau) or the Fourier series of Eq. 6 (harmonics by
    the angle-addition recurrence); the error phase enters through precomputed cos/sin(phi).
    """
    om = p[I_OMEGA]
    c1 = np.cos(om * tau)
    s1 = np.sin(om * tau)
    nh = int(p[I_NHARM])
    if nh == 0:
        kappa = 1.0 + p[I_S] * c1
    else:
        kappa = 1.0
        cj, sj = c1, s1
        for j in range(nh):
            kappa += p[I_HARM + 2 * j] * cj + p[I_HARM + 2 * j + 1] * sj
            cj, sj = cj * c1 - sj * s1, sj * c1 + cj * s1
    ea = p[I_EPSA]
    eps = p[I_EPS0] + ea * (s1 * p[I_CPHI] + c1 * p[I_SPHI])
    deps = ea * om * (c1 * p[I_CPHI] - s1 * p[I_SPHI])
    return kappa, eps, deps


@njit(cache=True, inline="always")
def mesh_deflection(y: np.ndarray, p: np.ndarray, eps: float, deps: float) -> tuple[float, float]:
    """Nondimensional mesh deflection d = v.q - eps and its rate."""
    d = -eps
    dd = -deps
    for i in range(N_DOF):
        d += p[I_V + i] * y[i]
        dd += p[I_V + i] * y[N_DOF + i]
    return d, dd


@njit(cache=True, inline="always")
def set_rates(i: int, y: np.ndarray, p: np.ndarray, fm: float, fz: float,
              dydt: np.ndarray) -> None:
    """Equation of motion of DOF i: q' = dq, dq' = g - eta f(q) - xi dq - v mu F_mesh.

    ``fz`` is the support dead-zone value f(q_i) and ``fm`` the nondimensional mesh force;
    both right-hand sides (state-decided and frozen-side branches) share this line.
    """
    dq = y[N_DOF + i]
    dydt[i] = dq
    dydt[N_DOF + i] = (p[I_G + i] - p[I_ETA + i] * fz - p[I_XI + i] * dq
                       - p[I_V + i] * p[I_MU + i] * fm)


@njit(cache=True)
def rhs(tau: float, y: np.ndarray, p: np.ndarray, dydt: np.ndarray) -> None:
    """dy/dtau of the nondimensional equations of motion."""
    kappa, eps, deps = excitation(tau, p)
    d, dd = mesh_deflection(y, p, eps, deps)
    fm = kappa * dead_zone(d, p[I_B5]) + 2.0 * p[I_ZETA] * dd
    for i in range(N_DOF):
        set_rates(i, y, p, fm, dead_zone(y[i], p[I_BETA + i]), dydt)


@njit(cache=True, inline="always")
def dead_zone_sided(x: float, b: float, side_hi: float, side_lo: float) -> float:
    """Dead zone evaluated on the branch given by the frozen sides of x - b and x + b.

    The sides come from the integrator (``freeze_sides=True``): they are constant within a
    step, so every Runge-Kutta stage uses one smooth branch even if a stage overshoots the
    kink. A side of 0 (unknown, g exactly 0) falls back to the state.
    """
    if side_hi > 0.0:
        return x - b
    if side_lo < 0.0:
        return x + b
    if side_hi < 0.0 and side_lo > 0.0:
        return 0.0
    return dead_zone(x, b)


@njit(cache=True)
def rhs_sides(tau: float, y: np.ndarray, p: np.ndarray, dydt: np.ndarray) -> None:
    """dy/dtau like :func:`rhs`, branches taken from the frozen sides ``p[N_COEF + k]``."""
    kappa, eps, deps = excitation(tau, p)
    d, dd = mesh_deflection(y, p, eps, deps)
    s = N_COEF
    fm = kappa * dead_zone_sided(d, p[I_B5], p[s], p[s + 1]) + 2.0 * p[I_ZETA] * dd
    for i in range(N_DOF):
        fz = dead_zone_sided(y[i], p[I_BETA + i], p[s + 2 + 2 * i], p[s + 3 + 2 * i])
        set_rates(i, y, p, fm, fz, dydt)


@njit(cache=True)
def switch(tau: float, y: np.ndarray, p: np.ndarray, g: np.ndarray) -> None:
    """Switching functions: kinks of the mesh and support dead zones (1.0 where inactive)."""
    # only d is needed here: one sin instead of the rhs's sin/cos pair
    d = -(p[I_EPS0] + p[I_EPSA] * np.sin(p[I_OMEGA] * tau + p[I_PHI]))
    for i in range(N_DOF):
        d += p[I_V + i] * y[i]
    b5 = p[I_B5]
    if b5 > 0.0:
        g[0] = d - b5
        g[1] = d + b5
    else:  # zero backlash: f(d) = d is linear, no kink
        g[0] = 1.0
        g[1] = 1.0
    for i in range(N_DOF):
        b = p[I_BETA + i]
        if b > 0.0 and p[I_ETA + i] != 0.0:
            g[2 + 2 * i] = y[i] - b
            g[3 + 2 * i] = y[i] + b
        else:
            g[2 + 2 * i] = 1.0
            g[3 + 2 * i] = 1.0
