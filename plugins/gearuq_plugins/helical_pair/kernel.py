"""Compiled right-hand side of the nondimensional 10-DOF helical-pair equations.

State ``y = [q_0..q_9, q_0'..q_9']`` with DOF order
``x_p, y_p, z_p, swing_p, torsion_p, x_g, y_g, z_g, swing_g, torsion_g`` (all as lengths over
the length scale L; rotations as pitch-radius arc lengths). The per-sample coefficient vector
``p`` (layout in ``layout.py``) is built by ``physics.coefficients``. See
docs/theory/helical_pair.md.

Three functions reach the integrator: ``rhs`` (branches decided by the state), ``rhs_sides``
(branches taken from the sides the integrator freezes at the step start) and ``switch`` (the
switching functions). The small helpers are inlined (``inline="always"``) into each of them:
one copy per call site, which numba types once per function.
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
    I_GATE,
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
    S_CLIP_HI,
    S_CLIP_LO,
    S_MESH_HI,
    S_MESH_LO,
    S_SUPPORT,
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

    kappa is Li, Hu and Han's form 1 + s cos(Omega tau) or the Fourier series of Eq. 6 (harmonics by
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
def branch(x: float, b: float, side_hi: float, side_lo: float) -> int:
    """Branch of a dead zone: +1 (x > b), -1 (x < -b), 0 (inside), from frozen sides.

    The sides of ``x - b`` and ``x + b`` come from the integrator (``freeze_sides=True``):
    they are constant within a step, so every Runge-Kutta stage uses one smooth branch even if
    a stage overshoots the kink. A side of 0 (unknown, g exactly 0) falls back to the state.
    """
    if side_hi > 0.0:
        return 1
    if side_lo < 0.0:
        return -1
    if side_hi < 0.0 and side_lo > 0.0:
        return 0
    if x > b:
        return 1
    if x < -b:
        return -1
    return 0


@njit(cache=True, inline="always")
def dead_zone_on(x: float, b: float, side: int) -> float:
    """Dead-zone value on a given branch (see :func:`branch`)."""
    if side > 0:
        return x - b
    if side < 0:
        return x + b
    return 0.0


@njit(cache=True, inline="always")
def clipped(force: float, flank: int, clip_side: float) -> float:
    """Flank force limited to compression: >= 0 on the drive flank, <= 0 on the back flank.

    ``clip_side`` is the frozen side of the force itself (0: unknown, decide from the value).
    """
    if flank > 0:
        if clip_side > 0.0:
            return force
        if clip_side < 0.0:
            return 0.0
        return max(force, 0.0)
    if flank < 0:
        if clip_side < 0.0:
            return force
        if clip_side > 0.0:
            return 0.0
        return min(force, 0.0)
    return 0.0


@njit(cache=True, inline="always")
def mesh_force(kappa: float, d: float, dd: float, p: np.ndarray) -> float:
    """Nondimensional mesh force with its branch decided by the state.

    Default (``p[I_GATE] == 0``): kappa f(d) + 2 zeta d', the damping acting at all times as
    in Li, Hu and Han. Gated: no force inside the backlash, and in contact the flank force is
    clipped to compression (the teeth can push, not pull).
    """
    b5 = p[I_B5]
    damping = 2.0 * p[I_ZETA] * dd
    if p[I_GATE] == 0.0:
        return kappa * dead_zone(d, b5) + damping
    if d > b5:
        return max(kappa * (d - b5) + damping, 0.0)
    if d < -b5:
        return min(kappa * (d + b5) + damping, 0.0)
    return 0.0


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


@njit(cache=True, error_model="numpy")
def rhs(tau: float, y: np.ndarray, p: np.ndarray, dydt: np.ndarray) -> None:
    """dy/dtau of the nondimensional equations of motion (branches from the state)."""
    kappa, eps, deps = excitation(tau, p)
    d, dd = mesh_deflection(y, p, eps, deps)
    fm = mesh_force(kappa, d, dd, p)
    for i in range(N_DOF):
        set_rates(i, y, p, fm, dead_zone(y[i], p[I_BETA + i]), dydt)


@njit(cache=True, error_model="numpy")
def rhs_sides(tau: float, y: np.ndarray, p: np.ndarray, dydt: np.ndarray) -> None:
    """dy/dtau like :func:`rhs`, branches taken from the frozen sides ``p[N_COEF + k]``."""
    kappa, eps, deps = excitation(tau, p)
    d, dd = mesh_deflection(y, p, eps, deps)
    s = N_COEF
    b5 = p[I_B5]
    flank = branch(d, b5, p[s + S_MESH_HI], p[s + S_MESH_LO])
    if p[I_GATE] == 0.0:
        fm = kappa * dead_zone_on(d, b5, flank) + 2.0 * p[I_ZETA] * dd
    else:
        clip_side = p[s + S_CLIP_HI] if flank > 0 else p[s + S_CLIP_LO]
        fm = clipped(kappa * dead_zone_on(d, b5, flank) + 2.0 * p[I_ZETA] * dd, flank,
                     clip_side)
    for i in range(N_DOF):
        b = p[I_BETA + i]
        k = s + S_SUPPORT + 2 * i
        fz = dead_zone_on(y[i], b, branch(y[i], b, p[k], p[k + 1]))
        set_rates(i, y, p, fm, fz, dydt)


@njit(cache=True, error_model="numpy")
def switch(tau: float, y: np.ndarray, p: np.ndarray, g: np.ndarray) -> None:
    """Switching functions: kinks of the mesh and support dead zones (1.0 where inactive).

    With the gated mesh (``p[I_GATE] != 0``) two more: the drive- and back-flank forces,
    whose sign changes are the kinks of the clipping to compression; ``g`` then holds
    ``N_SWITCH_GATED`` values, else ``N_SWITCH``.
    """
    b5 = p[I_B5]
    gated = p[I_GATE] != 0.0
    if gated:
        kappa, eps, deps = excitation(tau, p)
        d, dd = mesh_deflection(y, p, eps, deps)
        damping = 2.0 * p[I_ZETA] * dd
        g[S_CLIP_HI] = kappa * (d - b5) + damping
        g[S_CLIP_LO] = kappa * (d + b5) + damping
    else:
        # only d is needed here: one sin instead of the rhs's sin/cos pair
        d = -(p[I_EPS0] + p[I_EPSA] * np.sin(p[I_OMEGA] * tau + p[I_PHI]))
        for i in range(N_DOF):
            d += p[I_V + i] * y[i]
    if b5 > 0.0 or gated:
        # (gated: contact at d = 0 switches the damping on even without backlash)
        g[S_MESH_HI] = d - b5
        g[S_MESH_LO] = d + b5
    else:  # zero backlash: f(d) = d is linear, no kink
        g[S_MESH_HI] = 1.0
        g[S_MESH_LO] = 1.0
    for i in range(N_DOF):
        b = p[I_BETA + i]
        k = S_SUPPORT + 2 * i
        if b > 0.0 and p[I_ETA + i] != 0.0:
            g[k] = y[i] - b
            g[k + 1] = y[i] + b
        else:
            g[k] = 1.0
            g[k + 1] = 1.0
