"""Compiled right-hand side of the nondimensional 10-DOF helical-pair equations.

State ``y = [q_0..q_9, q_0'..q_9']`` with DOF order
``x_p, y_p, z_p, swing_p, torsion_p, x_g, y_g, z_g, swing_g, torsion_g`` (all as lengths over
the length scale L; rotations as pitch-radius arc lengths). Per-sample coefficient vector
``p`` (layout below) is built in ``__init__._coefficients``. See docs/theory/helical_pair.md.
"""

from __future__ import annotations

import numpy as np
from gearuq_plugins.helical_pair.layout import (
    I_B5,
    I_BETA,
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
    I_V,
    I_XI,
    I_ZETA,
    N_COEF,
    N_DOF,
)
from numba import njit


@njit(cache=True, inline="always")
def dead_zone(x: float, b: float) -> float:
    """Backlash function f(x) = x - b (x > b), 0 (|x| <= b), x + b (x < -b)."""
    if x > b:
        return x - b
    if x < -b:
        return x + b
    return 0.0


@njit(cache=True, inline="always")
def stiffness_factor(tau: float, p: np.ndarray) -> float:
    """k(tau) / k_m: seed form 1 + s cos(Omega tau), or a Fourier series (Eq. 6)."""
    om = p[I_OMEGA]
    nh = int(p[I_NHARM])
    if nh == 0:
        return 1.0 + p[I_S] * np.cos(om * tau)
    kappa = 1.0
    for j in range(nh):
        h = (j + 1) * om * tau
        kappa += p[I_HARM + 2 * j] * np.cos(h) + p[I_HARM + 2 * j + 1] * np.sin(h)
    return kappa


@njit(cache=True, inline="always")
def mesh_deflection(tau: float, y: np.ndarray, p: np.ndarray) -> tuple[float, float]:
    """Nondimensional mesh deflection d = v.q - eps(tau) and its rate."""
    ph = p[I_OMEGA] * tau + p[I_PHI]
    d = -(p[I_EPS0] + p[I_EPSA] * np.sin(ph))
    dd = -p[I_EPSA] * p[I_OMEGA] * np.cos(ph)
    for i in range(N_DOF):
        d += p[I_V + i] * y[i]
        dd += p[I_V + i] * y[N_DOF + i]
    return d, dd


@njit(cache=True)
def rhs(tau: float, y: np.ndarray, p: np.ndarray, dydt: np.ndarray) -> None:
    """dy/dtau of the nondimensional equations of motion."""
    d, dd = mesh_deflection(tau, y, p)
    fm = stiffness_factor(tau, p) * dead_zone(d, p[I_B5]) + 2.0 * p[I_ZETA] * dd
    for i in range(N_DOF):
        q = y[i]
        dq = y[N_DOF + i]
        dydt[i] = dq
        dydt[N_DOF + i] = (
            p[I_G + i]
            - p[I_ETA + i] * dead_zone(q, p[I_BETA + i])
            - p[I_XI + i] * dq
            - p[I_V + i] * p[I_MU + i] * fm
        )


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
    d, dd = mesh_deflection(tau, y, p)
    s = N_COEF
    fm = stiffness_factor(tau, p) * dead_zone_sided(d, p[I_B5], p[s], p[s + 1]) \
        + 2.0 * p[I_ZETA] * dd
    for i in range(N_DOF):
        q = y[i]
        dq = y[N_DOF + i]
        dydt[i] = dq
        dydt[N_DOF + i] = (
            p[I_G + i]
            - p[I_ETA + i] * dead_zone_sided(q, p[I_BETA + i], p[s + 2 + 2 * i],
                                             p[s + 3 + 2 * i])
            - p[I_XI + i] * dq
            - p[I_V + i] * p[I_MU + i] * fm
        )


@njit(cache=True)
def switch(tau: float, y: np.ndarray, p: np.ndarray, g: np.ndarray) -> None:
    """Switching functions: kinks of the mesh and support dead zones (1.0 where inactive)."""
    d, _ = mesh_deflection(tau, y, p)
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
