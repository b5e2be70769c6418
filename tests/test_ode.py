"""Tests of gearuq.ode: accuracy against closed forms, convergence order, switching surfaces
(exact dead-zone oracle), failure statuses, input validation and the on-disk kernel cache.

All right-hand sides are module-level ``@njit(cache=True)`` functions so that the file
compiles them once per machine. The oracles run on the kernels' plain-Python route by default
and on the compiled kernels under ``e2e`` (:data:`ROUTES`).
"""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest
from numba import njit
from scipy.optimize import brentq

from gearuq import kernels_route, ode
from gearuq.ode import (
    STATUS_NONFINITE,
    STATUS_OK,
    STATUS_STEP_LIMIT,
    STATUS_STEP_UNDERFLOW,
    solve_batch,
)

REPO = Path(__file__).resolve().parents[1]

#: The routes the oracles below run on. By default the kernels' plain-Python route: the same
#: source executed as Python (tests/test_firstcall.py holds it equal to the compiled kernel).
#: The variants these tests use (dopri5, dop853 and rk4 without events, dopri5 with re-taken
#: steps) are compiled by no model the default suite runs, 6-12 s of CPU each from an empty
#: numba cache, so their compiled route runs under ``e2e`` (docs/benchmarks.md, "First
#: minutes, twelfth round").
ROUTES = ["interpreted", pytest.param("compiled", marks=pytest.mark.e2e)]


def _solve(route, *args, **kw):
    """``solve_batch`` on ``route`` (``"interpreted"`` or ``"compiled"``)."""
    with kernels_route(route):
        return solve_batch(*args, interpreted_cpu=0.0, **kw)

# --------------------------------------------------------------------------------------------
# Right-hand sides
# --------------------------------------------------------------------------------------------


@njit(cache=True)
def dz_rhs(t, y, p, d):
    """m x'' + c x' + k f(x) = F0 + F cos(W t), f the dead zone of half-width b.

    p = [m, c, k, b, F0, F, W]; with b = 0 this is the linear forced oscillator.
    """
    x = y[0]
    b = p[3]
    if x > b:
        fx = x - b
    elif x < -b:
        fx = x + b
    else:
        fx = 0.0
    d[0] = y[1]
    d[1] = (p[4] + p[5] * math.cos(p[6] * t) - p[1] * y[1] - p[2] * fx) / p[0]


@njit(cache=True)
def dz_rhs_frozen(t, y, p, d):
    """dz_rhs taking its branch from the frozen sides p[7] (g = x - b), p[8] (g = x + b)."""
    x = y[0]
    b = p[3]
    up = p[7]
    lo = p[8]
    if up == 0.0 or lo == 0.0:  # side not known yet: decide from the state
        up = 1.0 if x > b else -1.0
        lo = 1.0 if x > -b else -1.0
    if up > 0.0:
        fx = x - b
    elif lo < 0.0:
        fx = x + b
    else:
        fx = 0.0
    d[0] = y[1]
    d[1] = (p[4] + p[5] * math.cos(p[6] * t) - p[1] * y[1] - p[2] * fx) / p[0]


@njit(cache=True)
def dz_switch(t, y, p, g):
    g[0] = y[0] - p[3]
    g[1] = y[0] + p[3]


@njit(cache=True)
def quad_rhs(t, y, p, d):
    """y' = a y^2, and NaN from t > t_nan on: p = [a, t_nan]."""
    d[0] = p[0] * y[0] * y[0]
    if t > p[1]:
        d[0] = math.nan


@njit(cache=True)
def level_switch(t, y, p, g):
    g[0] = y[0] - p[7]


@njit(cache=True)
def zero_division_rhs(t, y, p, d):
    """Raises ZeroDivisionError under numba's default error model once t > p[0]."""
    z = 0.0 if t > p[0] else 1.0
    d[0] = 1.0 / z


@njit(cache=True, error_model="numpy")
def zero_division_rhs_numpy(t, y, p, d):
    z = 0.0 if t > p[0] else 1.0
    d[0] = 1.0 / z


def not_jitted(t, y, p, d):
    d[0] = 0.0


# --------------------------------------------------------------------------------------------
# Closed-form references
# --------------------------------------------------------------------------------------------


def linear_exact(t, t0, x0, v0, zeta, omega, force, big_omega):
    """x'' + 2 zeta omega x' + omega^2 x = F cos(Omega t), x(t0) = x0, x'(t0) = v0."""
    a = omega**2 - big_omega**2
    bb = 2 * zeta * omega * big_omega
    den = a * a + bb * bb
    X, Y = force * a / den, force * bb / den

    def xp(s):
        return X * np.cos(big_omega * s) + Y * np.sin(big_omega * s)

    def vp(s):
        return big_omega * (-X * np.sin(big_omega * s) + Y * np.cos(big_omega * s))

    s_ = zeta * omega
    wd = omega * math.sqrt(1 - zeta**2)
    A = x0 - xp(t0)
    B = (v0 - vp(t0) + s_ * A) / wd
    tau = t - t0
    e = np.exp(-s_ * tau)
    return e * (A * np.cos(wd * tau) + B * np.sin(wd * tau)) + xp(t)


class DeadZoneExact:
    """Exact solution of m x'' + c x' + k f(x) = F0 + F cos(W t) with the dead zone f.

    Between switching instants the equation is linear: outside |x| <= b a damped oscillator
    about a shifted equilibrium, inside a damped free mass. Each piece is closed form; the
    next switching instant is bracketed on a grid of 1/200 of the shortest time scale, with an
    extra check at every extremum of x so that a grazing excursion across |x| = b is not
    stepped over, and is then found by brentq to 1e-15.
    """

    def __init__(self, m, c, k, b, F0, F, W):
        self.m, self.c, self.k, self.b, self.F0, self.F, self.W = m, c, k, b, F0, F, W
        self.wn = math.sqrt(k / m)
        self.zeta = c / (2 * m * self.wn)
        assert 0 < self.zeta < 1
        self.wd = self.wn * math.sqrt(1 - self.zeta**2)
        bb = c * W
        a = k - m * W**2  # outside: (k - m W^2) X + c W Y = F, -c W X + (k - m W^2) Y = 0
        self.Xo, self.Yo = F * a / (a * a + bb * bb), F * bb / (a * a + bb * bb)
        a = -m * W**2  # inside: -m W^2 X + c W Y = F, -c W X - m W^2 Y = 0
        self.Xd, self.Yd = F * a / (a * a + bb * bb), F * bb / (a * a + bb * bb)
        self.dt = min(2 * math.pi / W, 2 * math.pi / self.wn, m / c) / 200.0
        self.pieces: list = []

    def _particular(self, region, t):
        cw, sw = np.cos(self.W * t), np.sin(self.W * t)
        if region == 0:
            return (self.F0 / self.c * t + self.Xd * cw + self.Yd * sw,
                    self.F0 / self.c + self.W * (-self.Xd * sw + self.Yd * cw))
        return ((self.F0 + region * self.k * self.b) / self.k + self.Xo * cw + self.Yo * sw,
                self.W * (-self.Xo * sw + self.Yo * cw))

    def _piece(self, region, ts, xs, vs):
        xp0, vp0 = self._particular(region, ts)
        if region == 0:
            a = self.c / self.m
            c2 = -(vs - vp0) / a
            c1 = xs - xp0 - c2

            def f(t):
                e = np.exp(-a * (np.asarray(t) - ts))
                xp, vp = self._particular(0, np.asarray(t))
                return c1 + c2 * e + xp, -a * c2 * e + vp

            return f
        s, wd = self.zeta * self.wn, self.wd
        A = xs - xp0
        B = (vs - vp0 + s * A) / wd

        def f(t):
            tau = np.asarray(t) - ts
            e, co, si = np.exp(-s * tau), np.cos(wd * tau), np.sin(wd * tau)
            xp, vp = self._particular(region, np.asarray(t))
            xh = e * (A * co + B * si)
            return xh + xp, -s * xh + e * wd * (-A * si + B * co) + vp

        return f

    def _next_switch(self, region, f, ts, t_end):
        b = self.b
        if region == 1:
            surfaces = [(lambda t: f(t)[0] - b, 1.0)]
        elif region == -1:
            surfaces = [(lambda t: f(t)[0] + b, -1.0)]
        else:
            surfaces = [(lambda t: f(t)[0] - b, -1.0), (lambda t: f(t)[0] + b, 1.0)]
        kw = {"xtol": 1e-15, "rtol": 1e-15, "maxiter": 200}
        a = ts
        while a < t_end:
            hi = min(a + self.dt, t_end)
            lo = a
            if a == ts:
                # The piece starts on its surface: begin where g is strictly inside (at a
                # grazing entry the velocity is so small that rounding decides at first).
                lo = a + 1e-12 * self.dt
                for g, inside in surfaces:
                    while np.sign(g(lo)) == -inside and lo < hi:
                        lo = a + 10.0 * (lo - a)
            best = None
            for g, inside in surfaces:
                if np.sign(g(hi)) == -inside:
                    root = brentq(g, lo, hi, **kw)
                elif f(lo)[1] * f(hi)[1] < 0:
                    t_ext = brentq(lambda t: f(t)[1], lo, hi, **kw)
                    if np.sign(g(t_ext)) != -inside:
                        continue
                    root = brentq(g, lo, t_ext, **kw)
                else:
                    continue
                best = root if best is None else min(best, root)
            if best is not None:
                return best
            a = hi
        return None

    def solve(self, x0, v0, t0, t_end):
        region = 1 if x0 > self.b else (-1 if x0 < -self.b else 0)
        ts, xs, vs = t0, x0, v0
        self.pieces = []
        while True:
            f = self._piece(region, ts, xs, vs)
            tn = self._next_switch(region, f, ts, t_end)
            if tn is None:
                self.pieces.append((ts, t_end, f))
                return self
            self.pieces.append((ts, tn, f))
            xs, vs = (float(v) for v in f(tn))
            region = (1 if xs > 0 else -1) if region == 0 else 0
            ts = tn

    @property
    def n_switches(self):
        return len(self.pieces) - 1

    def __call__(self, t):
        t = np.asarray(t, dtype=float)
        x = np.full_like(t, np.nan)
        for ts, te, f in self.pieces:
            mask = (t >= ts) & (t <= te)
            if mask.any():
                x[mask] = f(t[mask])[0]
        return x


# Reference dead-zone case: preload F0 and harmonic load, starting at rest in the dead zone.
DZ_PAR = np.array([1.0, 0.1, 1.0, 0.5, 0.1, 1.0, 1.2])
DZ_T = np.linspace(0.0, 60.0, 601)


@pytest.fixture(scope="module")
def dz_exact():
    ex = DeadZoneExact(*DZ_PAR).solve(0.0, 0.0, 0.0, DZ_T[-1])
    return ex, ex(DZ_T)


# --------------------------------------------------------------------------------------------
# 1. Linear oscillator against its closed form
# --------------------------------------------------------------------------------------------


@pytest.mark.e2e
@pytest.mark.parametrize("method", ["dopri5", "dop853"])
def test_linear_oscillator_closed_form_batch_with_per_sample_t_eval(method):
    rng = np.random.default_rng(1)
    n = 6
    zeta = rng.uniform(0.01, 0.3, n)
    omega = rng.uniform(0.5, 3.0, n)
    force = rng.uniform(0.0, 2.0, n)
    big_omega = rng.uniform(0.3, 2.5, n)
    y0 = rng.uniform(-1, 1, (n, 2))
    t0 = rng.uniform(0.0, 2.0, n)
    # Per-sample output instants: each sample its own start and spacing.
    t_eval = t0[:, None] + np.linspace(0.0, 1.0, 51)[None, :] * rng.uniform(10, 30, n)[:, None]
    params = np.column_stack([np.ones(n), 2 * zeta * omega, omega**2, np.zeros(n), np.zeros(n),
                              force, big_omega])
    res = solve_batch(dz_rhs, y0, params, t_eval, t0=t0, method=method, rtol=1e-10,
                      atol=1e-12, parallel=False)
    assert (res.status == STATUS_OK).all()
    for i in range(n):
        exact = linear_exact(t_eval[i], t0[i], y0[i, 0], y0[i, 1], zeta[i], omega[i], force[i],
                             big_omega[i])
        assert np.abs(res.y[i, :, 0] - exact).max() < 1e-8
    assert res.y[:, 0, :] == pytest.approx(y0, abs=0)  # the first instant is t0 itself
    assert (res.n_steps > 0).all() and (res.n_rhs > res.n_steps).all()
    assert (res.n_events == 0).all()


# --------------------------------------------------------------------------------------------
# 2. Convergence order
# --------------------------------------------------------------------------------------------

_OSC = np.array([[1.0, 0.2, 4.0, 0.0, 0.0, 1.5, 1.3]])  # zeta = 0.05, omega = 2, F = 1.5
_OSC_T = np.linspace(0.0, 10.0, 41)  # includes instants between the fixed steps


def _osc_error(route, **kw):
    res = _solve(route, dz_rhs, np.array([[1.0, 0.0]]), _OSC, _OSC_T, parallel=False, **kw)
    exact = linear_exact(_OSC_T, 0.0, 1.0, 0.0, 0.05, 2.0, 1.5, 1.3)
    return np.abs(res.y[0, :, 0] - exact).max()


@pytest.mark.parametrize(
    ("method", "order", "n_steps"),
    [("dopri5", 5, (40, 80, 160, 320)), ("dop853", 8, (16, 20, 25, 32)),
     ("rk4", 4, (80, 160, 320, 640))],
)
@pytest.mark.parametrize("route", ROUTES)
def test_fixed_step_global_order(method, order, n_steps, route):
    h = np.array([10.0 / k for k in n_steps])
    err = np.array([_osc_error(route, method=method, fixed_step=hk) for hk in h])
    slope = np.polyfit(np.log(h), np.log(err), 1)[0]
    assert abs(slope - order) < 0.5, (err, slope)
    if method == "dopri5":
        assert 32 / 1.5 < err[0] / err[1] < 32 * 1.5  # halving h divides the error by ~2^5


@pytest.mark.parametrize("method", ["dopri5", "dop853"])
@pytest.mark.parametrize("route", ROUTES)
def test_adaptive_error_decreases_with_rtol(method, route):
    rtols = [10.0**-k for k in range(3, 11)]
    err = [_osc_error(route, method=method, rtol=r, atol=r * 1e-3) for r in rtols]
    assert all(e2 < e1 for e1, e2 in zip(err, err[1:], strict=False)), err
    assert err[-1] < 1e-8


# --------------------------------------------------------------------------------------------
# 3. Dead zone: exact piecewise oracle
# --------------------------------------------------------------------------------------------


def test_oracle_matches_the_linear_closed_form_outside_the_dead_zone():
    # A preload F0 = 8 keeps x above b: a linear oscillator about x = (F0 + k b) / k = 2.1.
    ex = DeadZoneExact(1.0, 0.2, 4.0, 0.1, 8.0, 1.5, 1.3).solve(3.1, 0.0, 0.0, 10.0)
    exact = 2.1 + linear_exact(_OSC_T, 0.0, 1.0, 0.0, 0.05, 2.0, 1.5, 1.3)
    assert ex.n_switches == 0
    assert np.abs(ex(_OSC_T) - exact).max() < 1e-12


@pytest.mark.e2e
@pytest.mark.parametrize("rtol", [1e-6, 1e-8])
def test_deadzone_with_switch_matches_exact_solution(dz_exact, rtol):
    ex, x_exact = dz_exact
    scale = np.abs(x_exact).max()
    kw = {"method": "dopri5", "rtol": rtol, "atol": rtol * 1e-3, "parallel": False}
    with_sw = solve_batch(dz_rhs, np.zeros((1, 2)), DZ_PAR[None], DZ_T, switch=dz_switch,
                          n_switch=2, **kw)
    without = solve_batch(dz_rhs, np.zeros((1, 2)), DZ_PAR[None], DZ_T, **kw)
    err_sw = np.abs(with_sw.y[0, :, 0] - x_exact).max()
    err_plain = np.abs(without.y[0, :, 0] - x_exact).max()
    assert err_sw < 50 * rtol * scale, err_sw / (rtol * scale)
    # Stepping across the kinks instead costs one to three orders of magnitude of accuracy.
    assert err_plain > 20 * err_sw, err_plain / err_sw
    assert with_sw.n_events[0] == ex.n_switches
    assert with_sw.status[0] == STATUS_OK


@pytest.mark.e2e
@pytest.mark.parametrize("method", ["dopri5", "dop853"])
@pytest.mark.parametrize("rtol", [1e-6, 1e-8, 1e-10])
def test_deadzone_frozen_sides_match_exact_solution(dz_exact, method, rtol):
    ex, x_exact = dz_exact
    scale = np.abs(x_exact).max()
    res = solve_batch(dz_rhs_frozen, np.zeros((1, 2)), DZ_PAR[None], DZ_T, method=method,
                      rtol=rtol, atol=rtol * 1e-3, switch=dz_switch, n_switch=2,
                      freeze_sides=True, parallel=False)
    err = np.abs(res.y[0, :, 0] - x_exact).max()
    assert err < 50 * rtol * scale, err / (rtol * scale)
    assert res.n_events[0] == ex.n_switches


def _grazing_case(excess):
    """Start on the periodic orbit inside the dead zone (F0 = 0) whose peak is b (1 + excess)."""
    m, c, k, b, W = 1.0, 0.1, 1.0, 0.5, 1.2
    amplitude = 0.3
    F = amplitude * W * math.sqrt((m * W) ** 2 + c * c)
    ex = DeadZoneExact(m, c, k, b, 0.0, F, W)
    centre = b * (1 + excess) - amplitude
    x0 = centre + ex.Xd
    v0 = W * ex.Yd
    return np.array([m, c, k, b, 0.0, F, W]), np.array([x0, v0]), ex


@pytest.mark.e2e
@pytest.mark.parametrize("excess", [-1e-6, 1e-6])
@pytest.mark.parametrize("frozen", [False, True])
def test_grazing_orbit(excess, frozen):
    par, y0, ex = _grazing_case(excess)
    t = np.linspace(0.0, 40.0, 401)
    ex.solve(y0[0], y0[1], 0.0, t[-1])
    x_exact = ex(t)
    # The orbit reaches x = b (1 + excess) once per forcing period.
    peak = ex(np.linspace(0.0, t[-1], 200_001)).max()
    assert abs(peak - 0.5 * (1 + excess)) < 5e-8
    rtol = 1e-8
    res = solve_batch(dz_rhs_frozen if frozen else dz_rhs, y0[None], par[None], t, rtol=rtol,
                      atol=rtol * 1e-3, switch=dz_switch, n_switch=2, freeze_sides=frozen,
                      parallel=False)
    assert res.status[0] == STATUS_OK
    assert np.abs(res.y[0, :, 0] - x_exact).max() < 50 * rtol * np.abs(x_exact).max()
    # Touching from inside is no event; excursions of 1e-6 b may or may not be seen.
    if excess < 0:
        assert res.n_events[0] == 0
    assert res.n_events[0] <= 2 * ex.n_switches


@pytest.mark.e2e
@pytest.mark.parametrize("method", ["dopri5", "dop853"])
def test_short_excursions_inside_long_steps_are_found(method):
    # x = cos t crosses the level cos(0.1) twice around every maximum, 0.2 apart: far less
    # than the step sizes (dop853 takes steps near 1 here), so only the interior samples and
    # the parabola check see these excursions.
    level = math.cos(0.1)
    params = np.array([[1.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, level]])
    res = solve_batch(dz_rhs, np.array([[1.0, 0.0]]), params, [0.0, 20.0], method=method,
                      rtol=1e-6, switch=level_switch, n_switch=1, parallel=False)
    crossings = [0.1] + [2 * math.pi * k + d for k in (1, 2, 3) for d in (-0.1, 0.1)]
    assert res.n_events[0] == sum(c <= 20.0 for c in crossings) == 7
    assert res.y[0, -1, 0] == pytest.approx(math.cos(20.0), abs=1e-5)


# --------------------------------------------------------------------------------------------
# 4. Failure statuses
# --------------------------------------------------------------------------------------------


@pytest.mark.parametrize("route", ROUTES)
def test_blow_up_sample_fails_alone(route):
    t = np.linspace(0.0, 2.0, 21)
    params = np.array([[-1.0, 1e300], [1.0, 1e300], [-1.0, 1e300]])
    res = _solve(route, quad_rhs, np.ones((3, 1)), params, t, rtol=1e-8, atol=1e-10,
                 parallel=False)
    assert res.status[0] == STATUS_OK and res.status[2] == STATUS_OK
    assert res.status[1] in (STATUS_NONFINITE, STATUS_STEP_UNDERFLOW)
    assert np.abs(res.y[0, :, 0] - 1 / (1 + t)).max() < 1e-8  # y' = -y^2: y = 1 / (1 + t)
    before = t < 0.95
    assert np.isfinite(res.y[1, before, 0]).all()
    assert np.abs(res.y[1, before, 0] - 1 / (1 - t[before])).max() < 1e-5
    # The numerical solution blows up within a few rtol of t = 1 (not necessarily before it).
    assert np.isnan(res.y[1, t > 1.05, 0]).all()


@pytest.mark.parametrize("route", ROUTES)
def test_nan_from_rhs_gives_nonfinite_status(route):
    t = np.linspace(0.0, 2.0, 21)
    params = np.array([[-1.0, 1.05], [-1.0, 1e300]])
    for kw in ({}, {"fixed_step": 0.01}, {"method": "dop853"}):
        res = _solve(route, quad_rhs, np.ones((2, 1)), params, t, parallel=False, **kw)
        assert res.status.tolist() == [STATUS_NONFINITE, STATUS_OK], kw
        assert np.isfinite(res.y[0, t <= 1.0, 0]).all()
        assert np.isnan(res.y[0, t > 1.1, 0]).all()
        assert np.abs(res.y[0, t <= 1.0, 0] - 1 / (1 + t[t <= 1.0])).max() < 1e-5


@pytest.mark.parametrize("route", ROUTES)
def test_fixed_step_overflow_gives_nonfinite_status(route):
    res = _solve(route, quad_rhs, np.ones((1, 1)), np.array([[1.0, 1e300]]), [0.0, 0.5, 3.0],
                 fixed_step=0.01, parallel=False)
    assert res.status[0] == STATUS_NONFINITE
    assert res.y[0, 1, 0] == pytest.approx(2.0, rel=1e-6) and np.isnan(res.y[0, 2, 0])


@pytest.mark.e2e  # numba's error model: the compiled route only (see ROUTES)
def test_exception_in_rhs_is_reported_and_numpy_error_model_avoids_it():
    params = np.array([[0.5], [5.0]])
    with pytest.raises(RuntimeError, match="error_model='numpy'"):
        solve_batch(zero_division_rhs, np.zeros((2, 1)), params, [0.0, 1.0], parallel=False)
    res = solve_batch(zero_division_rhs_numpy, np.zeros((2, 1)), params, [0.0, 0.4, 1.0],
                      parallel=False)
    assert res.status.tolist() == [STATUS_NONFINITE, STATUS_OK]
    assert res.y[0, 1, 0] == pytest.approx(0.4) and np.isnan(res.y[0, 2, 0])


@pytest.mark.parametrize("route", ROUTES)
def test_step_limit(route):
    t = np.linspace(0.0, 50.0, 11)
    params = np.array([[1.0, 0.0, 400.0, 0.0, 0.0, 0.0, 0.0],   # omega = 20: many steps
                       [1.0, 0.0, 0.01, 0.0, 0.0, 0.0, 0.0]])   # omega = 0.1: few steps
    res = _solve(route, dz_rhs, np.array([[1.0, 0.0], [1.0, 0.0]]), params, t, max_steps=200,
                 rtol=1e-8, parallel=False)
    assert res.status.tolist() == [STATUS_STEP_LIMIT, STATUS_OK]
    assert res.n_steps[0] + res.n_rejected[0] <= 200
    reached = np.isfinite(res.y[0, :, 0])
    assert reached[0] and not reached[-1]
    assert reached.sum() == np.argmin(reached)  # finite rows first, then NaN
    assert np.abs(res.y[1, :, 0] - np.cos(0.1 * t)).max() < 1e-6


# --------------------------------------------------------------------------------------------
# 5. Stored subset, parallel = serial, result object
# --------------------------------------------------------------------------------------------


def _dz_batch(route="compiled", **kw):
    rng = np.random.default_rng(3)
    n = 8
    params = np.tile(DZ_PAR, (n, 1))
    params[:, 4] = rng.uniform(0.0, 0.2, n)
    params[:, 5] = rng.uniform(0.5, 1.5, n)
    y0 = rng.uniform(-1, 1, (n, 2))
    return _solve(route, dz_rhs, y0, params, DZ_T[:301], switch=dz_switch, n_switch=2, **kw)


@pytest.mark.parametrize("route", ROUTES)
def test_saved_subset_is_the_full_solution_s_columns(route):
    full = _dz_batch(route, parallel=False)
    velocity = _dz_batch(route, parallel=False, save=[1])
    assert velocity.y.shape == full.y.shape[:2] + (1,)
    assert np.array_equal(velocity.y[:, :, 0], full.y[:, :, 1])
    assert (full.n_events > 0).all()


@pytest.mark.e2e  # threads run the compiled kernel only (see ROUTES)
def test_parallel_and_serial_are_identical():
    full = _dz_batch(parallel=False)
    par = _dz_batch(parallel=True)
    assert np.array_equal(par.y, full.y)
    for name in ("status", "n_steps", "n_rejected", "n_rhs", "n_events"):
        assert np.array_equal(getattr(par, name), getattr(full, name)), name
    assert (full.n_events > 0).all()


def test_result_settings_and_status_codes():
    res = _dz_batch("interpreted", parallel=False, rtol=1e-7, atol=np.array([1e-9, 1e-8]))
    settings = res.settings()
    json.dumps(settings)
    assert settings["method"] == "dopri5" and settings["rtol"] == 1e-7
    assert settings["atol"] == [1e-9, 1e-8] and settings["n_switch"] == 2
    assert res.ok.all()
    model = pytest.importorskip("gearuq.model")
    for name in ("STATUS_OK", "STATUS_STEP_LIMIT", "STATUS_STEP_UNDERFLOW", "STATUS_NONFINITE"):
        assert getattr(ode, name) == getattr(model, name)


# --------------------------------------------------------------------------------------------
# 6. Input validation
# --------------------------------------------------------------------------------------------

_Y0 = np.zeros((2, 2))
_P = np.tile(DZ_PAR, (2, 1))
_T = np.linspace(0.0, 1.0, 5)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"rtol": 0.0}, "rtol"),
        ({"rtol": -1e-6}, "rtol"),
        ({"atol": -1.0}, "atol"),
        ({"atol": np.ones(3)}, "atol"),
        ({"t_eval": np.array([0.0, 2.0, 1.0])}, "t_eval.*increasing"),
        ({"t_eval": np.zeros((3, 5))}, "t_eval"),
        ({"t0": 0.5}, "before t0"),
        ({"t0": np.zeros(3)}, "t0"),
        ({"y0": np.zeros(2)}, "y0"),
        ({"y0": np.array([[0.0, 0.0], [np.nan, 0.0]])}, "y0.*sample 1"),
        ({"params": np.zeros((3, 7))}, "params"),
        ({"params": np.array([DZ_PAR, DZ_PAR * np.inf])}, "params.*sample 1"),
        ({"method": "rk45"}, "dopri5, dop853, rk4"),
        ({"method": "rk4"}, "fixed_step"),
        ({"n_switch": 2}, "switch"),
        ({"switch": dz_switch}, "n_switch"),
        ({"freeze_sides": True}, "freeze_sides"),
        ({"save": [0, 2]}, "save"),
        ({"max_step": 0.0}, "max_step"),
        ({"first_step": -1.0}, "first_step"),
        ({"max_steps": 0}, "max_steps"),
        ({"fixed_step": -0.1}, "fixed_step"),
    ],
)
def test_bad_inputs_raise_value_error_naming_the_argument(kwargs, match):
    args = {"y0": _Y0, "params": _P, "t_eval": _T}
    args.update(kwargs)
    y0, params, t_eval = args.pop("y0"), args.pop("params"), args.pop("t_eval")
    with pytest.raises(ValueError, match=match):
        solve_batch(dz_rhs, y0, params, t_eval, **args)


def test_non_numba_rhs_raises_type_error():
    with pytest.raises(TypeError, match="rhs must be a numba @njit function"):
        solve_batch(not_jitted, _Y0, _P, _T)


# --------------------------------------------------------------------------------------------
# 7. On-disk cache: a second process loads the kernel instead of compiling it
# --------------------------------------------------------------------------------------------

_CACHE_SCRIPT = textwrap.dedent(
    """
    import json, sys, time
    t0 = time.perf_counter()
    import numpy as np
    from numba import njit
    from gearuq import ode

    @njit(cache=True)
    def rhs(t, y, p, d):
        d[0] = y[1]
        d[1] = -p[0] * y[0]

    t1 = time.perf_counter()
    res = ode.solve_batch(rhs, np.array([[1.0, 0.0]]), np.array([[4.0]]),
                          np.linspace(0.0, 1.0, 3), parallel=False)
    t2 = time.perf_counter()
    kernel = ode.get_kernel("dopri5", "none")
    from gearuq.ode import kernel as kernel_module
    print(json.dumps({
        "variants": sorted("/".join(map(str, k)) for k in kernel_module._KERNELS),
        "kernel_hits": sum(kernel.stats.cache_hits.values()),
        "kernel_misses": sum(kernel.stats.cache_misses.values()),
        "rhs_hits": sum(rhs.stats.cache_hits.values()),
        "first_call_s": t2 - t1, "import_s": t1 - t0,
        "y_end": float(res.y[0, -1, 0]),
    }))
    """
)


def _run_cache_script(tmp_path: Path, env_extra: dict | None = None) -> dict:
    script = tmp_path / "cache_probe.py"
    script.write_text(_CACHE_SCRIPT)
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([str(REPO), env.get("PYTHONPATH", "")])
    env.update(env_extra or {})
    out = subprocess.run([sys.executable, str(script)], capture_output=True, text=True,
                         env=env, timeout=600, check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


@pytest.mark.e2e  # two fresh interpreters (1.9 s of CPU)
def test_second_process_loads_kernel_from_cache(tmp_path):
    _run_cache_script(tmp_path)  # compiles (or loads) and writes the cache
    second = _run_cache_script(tmp_path)
    assert second["kernel_hits"] == 1 and second["kernel_misses"] == 0, second
    assert second["rhs_hits"] == 1, second
    assert second["variants"] == ["0/0"], second  # only the variant the call used
    assert second["y_end"] == pytest.approx(math.cos(2.0), abs=1e-6)


@pytest.mark.slow
def test_cold_compile_versus_cached_load(tmp_path):
    env = {"NUMBA_CACHE_DIR": str(tmp_path / "numba_cache")}
    cold = _run_cache_script(tmp_path, env)
    warm = _run_cache_script(tmp_path, env)
    assert cold["kernel_misses"] == 1 and warm["kernel_hits"] == 1
    assert warm["first_call_s"] < 0.2 * cold["first_call_s"], (cold, warm)
    print(f"first solve_batch call: cold {cold['first_call_s']:.2f} s, "
          f"cached {warm['first_call_s']:.3f} s")
