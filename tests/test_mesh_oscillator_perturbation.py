"""mesh_oscillator: the multiple-scales solution against independent oracles.

- convergence order: with every small parameter scaled by eps, the first-order amplitude
  errs by O(eps) and the second-order one by O(eps^2) against periodic orbits found by
  shooting with scipy's DOP853 on a plain NumPy right-hand side (no shared code);
- linear time-invariant response (closed form), Duffing backbone and Eq. 27, the principal
  Mathieu tongue (Floquet multipliers from scipy);
- the backlash oscillator of issue 12 (exact onset band of contact loss);
- second order against first order on a strong quadratic nonlinearity, stability labels
  against numerical sweeps, the separation harmonics (Eqs. 32-35);
- the hand-written slow flow against a symbolic re-derivation (when sympy is installed).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from gearuq_plugins.mesh_oscillator import MeshOscillator
from gearuq_plugins.mesh_oscillator import slowflow as sf
from gearuq_plugins.mesh_oscillator.perturbation import frequency_response


# ------------------------------------------------------------------------------ oracle
def eq11_rhs(c: dict, omega: float):
    """Seed Eq. 11 without contact loss, written out in NumPy (the independent oracle)."""

    def f(t, y):
        u, v = y
        th = omega * t
        force = (c.get("a01", 0) * np.cos(th) + c.get("a02", 0) * np.cos(2 * th - c.get("p02", 0))
                 + (1 + c.get("a11", 0) * np.cos(th - c.get("p11", 0))
                    + c.get("a12", 0) * np.cos(2 * th - c.get("p12", 0))) * u
                 + (c.get("a20", 0) + c.get("a21", 0) * np.cos(th - c.get("p21", 0))) * u**2
                 + c.get("a30", 0) * u**3)
        load = c.get("q1", 0) * np.cos(th - c.get("r1", 0))
        return [v, load - 2 * c["mu"] * v - force]

    return f


def periodic_orbit(c: dict, omega: float, y0, tol: float = 1e-12) -> float:
    """Fundamental amplitude of the periodic orbit near ``y0`` (Newton shooting)."""
    f = eq11_rhs(c, omega)
    period = 2 * np.pi / omega

    def flow(y):
        return solve_ivp(f, (0, period), y, method="DOP853", rtol=tol, atol=tol).y[:, -1]

    y = np.array(y0, dtype=float)
    for _ in range(30):
        res = flow(y) - y
        jac = np.empty((2, 2))
        for k in range(2):
            yp = y.copy()
            yp[k] += 1e-7
            jac[:, k] = (flow(yp) - yp - res) / 1e-7
        step = np.linalg.solve(jac, -res)
        y = y + step
        if np.abs(step).max() < 1e-11:
            break
    t = np.arange(256) * period / 256
    u = solve_ivp(f, (0, period), y, method="DOP853", rtol=tol, atol=tol, t_eval=t).y[0]
    return abs(2 / 256 * np.sum(u * np.exp(-1j * omega * t)))


def coefficients(**kw) -> np.ndarray:
    """Perturbation coefficient row from keyword values (names as in slowflow.C_*)."""
    c = np.zeros(sf.N_COEF)
    c[sf.C_A00] = 1.0
    for k, v in kw.items():
        c[getattr(sf, "C_" + k.upper())] = v
    return c


def up_amplitude(c: np.ndarray, omega: float, order: int, span: float = 0.2) -> float:
    grid = np.linspace(omega - span, omega, 41)
    return float(frequency_response(c[None], grid, order=order).path("up")[0, -1])


# ------------------------------------------------------------------------------ derivation
def test_second_order_error_is_quadratic_in_eps():
    """All terms at once: forcing, load harmonic, damping, detuning, quadratic, cubic,
    periodic linear and quadratic stiffness, second excitation harmonic. Halving eps halves
    the first-order error and quarters the second-order one; a wrong coefficient in the
    second-order terms would leave an O(eps) error (ratio 2)."""
    base = dict(mu=1.0, a01=1.0, a20=1.0, a30=1.0, a11=1.0, a12=0.6, a02=0.8, q1=0.5, a21=0.9)
    phases = dict(p11=0.7, p12=-0.4, p02=0.3, r1=1.1, p21=0.5)
    errors = []
    for eps in (0.04, 0.02, 0.01):
        omega = 1.0 + 0.5 * eps
        c = coefficients(mu=eps, a01=eps, a20=eps, a30=eps, a11=eps, p11=0.7, a12=0.6 * eps,
                         p12=-0.4, a02=0.8 * eps, p02=0.3, q1=0.5 * eps, r1=1.1,
                         a21=0.9 * eps**2, p21=0.5)
        a1 = up_amplitude(c, omega, 1, 3 * eps)
        a2 = up_amplitude(c, omega, 2, 3 * eps)
        scaled = {k: eps * v for k, v in base.items()} | phases | {"a21": 0.9 * eps**2}
        exact = periodic_orbit(scaled, omega, [a2, 0.0])
        errors.append((abs(a1 - exact), abs(a2 - exact)))
    e = np.array(errors)
    ratios = e[:-1] / e[1:]
    assert np.all((ratios[:, 0] > 1.8) & (ratios[:, 0] < 2.2)), ratios
    assert ratios[-1, 1] > 3.4, ratios  # -> 4: O(eps^2)
    assert e[-1, 1] < e[-1, 0] / 100


@pytest.mark.e2e
def test_slow_flow_matches_symbolic_derivation():
    sp = pytest.importorskip("sympy")
    from gearuq_plugins.mesh_oscillator.derivation import derive

    d = derive()
    sym = d["symbols"]
    names = ["a", "gamma", "sigma", "mu", "alpha00", "alpha01", "alpha02", "q1", "alpha20",
             "alpha30", "alpha11", "alpha12", "alpha21", "Delta0", "Delta1", "Delta2",
             "phi02", "rho1", "phi11", "phi12", "phi21", "nu1", "nu2"]
    fns = {k: sp.lambdify([sym[n] for n in names], d[k]) for k in ("Ga1", "Gg1", "Ga2", "Gg2")}
    rng = np.random.default_rng(3)
    for _ in range(20):
        v = dict(zip(names, rng.uniform(-1, 1, len(names)), strict=True))
        v["a"] = abs(v["a"]) + 0.1
        c = coefficients(mu=v["mu"], a00=v["alpha00"], a01=v["alpha01"], a02=v["alpha02"],
                         p02=v["phi02"], q1=v["q1"], r1=v["rho1"], a20=v["alpha20"],
                         a30=v["alpha30"], a11=v["alpha11"], p11=v["phi11"], a12=v["alpha12"],
                         p12=v["phi12"], a21=v["alpha21"], p21=v["phi21"])
        s = np.zeros(sf.N_SEP)
        s[[sf.S_D0, sf.S_D1, sf.S_N1, sf.S_D2, sf.S_N2]] = [v["Delta0"], v["Delta1"], v["nu1"],
                                                           v["Delta2"], v["nu2"]]
        omega = 1.0 + v["sigma"]
        out = np.zeros(2)
        sf.first_order(v["a"], v["gamma"], omega, c, v["Delta0"], out)
        args = [v[n] for n in names]
        assert out[0] == pytest.approx(fns["Ga1"](*args), abs=1e-12)
        assert out[1] == pytest.approx(v["a"] * v["sigma"] + fns["Gg1"](*args), abs=1e-12)
        out[:] = 0.0
        sf.second_order(v["a"], v["gamma"], omega, c, s, out)
        assert out[0] == pytest.approx(fns["Ga2"](*args), abs=1e-12)
        assert out[1] == pytest.approx(fns["Gg2"](*args), abs=1e-12)


# ------------------------------------------------------------------------------ special cases
def test_linear_time_invariant_response():
    """f = k x: perturbation (both orders) and numerical sweeps give the linear FRF."""
    model = MeshOscillator()
    p = {"alpha_2_0": 0.0, "alpha_3_0": 0.0, "e_1": 0.0, "alpha_0_1": 0.01,
         "damping_ratio": 0.02}
    grid = np.linspace(0.97, 1.03, 13)
    exact = 0.01 / np.abs(1 - grid**2 + 2j * 0.02 * grid)
    for order, tol in ((1, 0.02), (2, 2e-3)):
        ds = model.response(p, outputs=["amplitude_up", "amplitude_down", "linear_amplitude"],
                            frequencies=grid, order=order)
        np.testing.assert_allclose(ds["linear_amplitude"].values[0], exact, rtol=1e-12)
        np.testing.assert_allclose(ds["amplitude_up"].values[0], exact, rtol=tol)
        np.testing.assert_array_equal(ds["amplitude_up"], ds["amplitude_down"])
    ds = model.response(p, outputs=["amplitude_up", "amplitude_down"], frequencies=grid,
                        method="sweep", settle_tolerance=1e-6)
    np.testing.assert_allclose(ds["amplitude_up"].values[0], exact, rtol=2e-5)
    np.testing.assert_allclose(ds["amplitude_down"].values[0], exact, rtol=2e-5)


def test_duffing_backbone_and_first_order_relation():
    """Cubic f = k x + k3 x^3 (dimensional): every first-order steady state satisfies the
    Duffing relation (Eq. 27) and the peak lies on the backbone
    omega = omega_n (1 + 3 k3 (a d)^2 / (8 k_t)), k_t the tangent stiffness at x_m."""
    from gearuq_plugins.mesh_oscillator import PolynomialForce

    k, k3, f0 = 1e8, 4e19, 100.0
    model = MeshOscillator(PolynomialForce.cubic(k, k3),
                           nominal={"mean_force": f0, "damping_ratio": 0.01,
                                    "load_harmonic": 2.25})
    grid = np.linspace(0.9, 1.3, 801)
    ds = model.response({}, outputs=["branch_amplitude", "branch_phase", "n_branches",
                                     "peak_amplitude", "peak_frequency_ratio", "alpha",
                                     "deflection_scale", "mesh_stiffness"],
                        frequencies=grid, order=1)
    x_m = ds["deflection_scale"].values[0]
    kt = k + 3 * k3 * x_m**2
    assert ds["mesh_stiffness"].values[0] == pytest.approx(kt, rel=1e-9)
    a30 = float(ds["alpha"].values[0, 3, 0])
    assert a30 == pytest.approx(k3 * x_m**2 / kt, rel=1e-9)
    q1 = 2.25 / (x_m * kt)
    a = ds["branch_amplitude"].values[0]
    sigma = grid[:, None] - 1.0
    eq27 = (0.01 * a) ** 2 + (a * sigma - 3 / 8 * a30 * a**3) ** 2 - q1**2 / 4
    assert np.abs(eq27).max() < 1e-9 * q1**2  # Newton tolerance 1e-11 on a
    peak = ds["peak_amplitude"].values[0]
    assert peak < 1.0  # no contact loss in this case (first order: loss at a = 1)
    assert peak == pytest.approx(q1 / (2 * 0.01), rel=2e-4)  # grid step 5e-4 near the top
    backbone = 1 + 3 * k3 * (peak * x_m) ** 2 / (8 * kt)
    assert abs(ds["peak_frequency_ratio"].values[0] - backbone) <= grid[1] - grid[0]
    three = ds["n_branches"].values[0] == 3
    assert three.sum() > 10  # the hardening curve folds over


def test_principal_parametric_tongue_against_floquet():
    """u'' + 2 mu u' + (1 + alpha12 cos 2 Omega T) u = 0: first-order instability for
    sigma^2 + mu^2 < (alpha12 / 4)^2, checked against Floquet multipliers."""
    from gearuq_plugins.mesh_oscillator.continuation import unforced_stability

    h, mu = 0.1, 0.01
    c = coefficients(a12=h, mu=mu)
    for sigma in (0.0, 0.015, -0.015, 0.035, -0.035, 0.06):
        omega = 1 + sigma

        def f(t, y, omega=omega):
            return [y[1], -2 * mu * y[1] - (1 + h * np.cos(2 * omega * t)) * y[0]]

        period = np.pi / omega
        mono = np.column_stack([solve_ivp(f, (0, period), e, method="DOP853", rtol=1e-11,
                                          atol=1e-12).y[:, -1] for e in np.eye(2)])
        floquet_stable = np.abs(np.linalg.eigvals(mono)).max() < 1.0
        assert bool(unforced_stability(c, omega)) == floquet_stable, sigma


def test_backlash_contact_loss_band():
    """Issue 12: u'' + 2 zeta u' + C u = F_m + F_ah Omega^2 cos(Omega T), zeta = 0.05,
    F_m = 0.1, F_ah = 0.02 loses contact where the linear amplitude exceeds F_m, exactly on
    [0.92518, 1.10316]; the perturbation onset and the numerical sweeps agree with it."""
    zeta, f_m, f_ah = 0.05, 0.1, 0.02
    # closed form: (F_ah/F_m)^2 s^2 = (1 - s)^2 + (2 zeta)^2 s, s = Omega^2
    r2 = (f_ah / f_m) ** 2
    quad = np.roots([1 - r2, 4 * zeta**2 - 2, 1])
    band = np.sort(np.sqrt(quad))
    np.testing.assert_allclose(band, [0.92518, 1.10316], atol=5e-6)
    model = MeshOscillator(load_harmonic_scaling="frequency_squared")
    p = {"alpha_0_0": 1.0, "alpha_0_1": 0.0, "alpha_2_0": 0.0, "alpha_3_0": 0.0, "e_1": 0.0,
         "q_1": f_ah / f_m, "damping_ratio": zeta}
    grid = np.linspace(0.88, 1.15, 109)
    lin = model.response(p, outputs=["linear_amplitude"], frequencies=grid)
    inside = (grid > band[0]) & (grid < band[1])
    np.testing.assert_array_equal(lin["linear_amplitude"].values[0] > 1.0, inside)
    onsets = {order: model.response(p, outputs=["amplitude_up"], frequencies=grid, order=order)
              ["onset_frequency_ratio"].values[0] for order in (1, 2)}
    # the linear part is exact up to O(eps^2) (first order) and O(eps^3) (second order):
    # measured 4.4e-3 / 1.0e-2 and 1.3e-4 / 4.1e-4
    np.testing.assert_allclose(onsets[2], band, atol=1e-3)
    assert np.all(np.abs(onsets[1] - band) > np.abs(onsets[2] - band))
    sweep = model.response(p, outputs=["amplitude_up", "amplitude_down"], frequencies=grid,
                           method="sweep", points_per_period=64)
    for which, edge in (("up", band[0]), ("down", band[1])):
        margin = sweep[f"contact_margin_{which}"].values[0]
        lost = np.flatnonzero(margin < 0)
        k = lost[0] if which == "up" else lost[-1]
        j = k - 1 if which == "up" else k + 1
        crossing = grid[j] + (grid[k] - grid[j]) * margin[j] / (margin[j] - margin[k])
        assert crossing == pytest.approx(edge, abs=2e-4), which


def test_second_order_beats_first_on_strong_quadratic_nonlinearity():
    """alpha_20 = 0.6 shifts the resonance by -5/12 alpha_20^2 a^2 (second order only); the
    maximum amplitude error against numerical sweeps is measured for both orders."""
    model = MeshOscillator()
    p = {"alpha_2_0": 0.6, "alpha_3_0": 0.0, "e_1": 0.0, "alpha_0_1": 0.012,
         "damping_ratio": 0.015, "alpha_0_0": 1.0}
    grid = np.linspace(0.92, 1.04, 49)
    num = model.response(p, outputs=["amplitude_up", "amplitude_down", "separation_up"],
                         frequencies=grid, method="sweep")
    assert num["separation_up"].values.max() == 0.0  # no contact loss: stiffness only
    # where the two sweeps disagree the response jumps inside a grid step: no comparison
    keep = np.abs(num["amplitude_up"] - num["amplitude_down"]).values[0] < 1e-3
    errs = {}
    for order in (1, 2):
        ds = model.response(p, outputs=["amplitude_up"], frequencies=grid, order=order)
        rel = (ds["amplitude_up"] - num["amplitude_up"]).values[0] / num["amplitude_up"].values[0]
        errs[order] = float(np.sqrt(np.mean(rel[keep] ** 2)))
    assert keep.sum() > 40
    assert errs[2] < 0.1 * errs[1], errs
    assert errs[2] < 0.01, errs


def test_stability_labels_follow_the_numerical_sweeps():
    """Seed Fig. 4 system: where three steady states exist, the lower and upper ones are
    stable and the middle one unstable; the numerical up and down sweeps land within 5 % of
    a stable one, and the hysteresis band of the sweeps is where the perturbation has three
    branches."""
    model = MeshOscillator()
    grid = np.linspace(0.86, 1.06, 41)
    pert = model.response({}, outputs=["branch_amplitude", "branch_stable", "n_branches",
                                       "amplitude_up", "amplitude_down"], frequencies=grid)
    num = model.response({}, outputs=["amplitude_up", "amplitude_down"], frequencies=grid,
                         method="sweep")
    three = pert["n_branches"].values[0] == 3
    assert three.sum() >= 5
    stable = pert["branch_stable"].values[0]
    assert np.all(stable[three][:, [0, 2]] == 1) and np.all(stable[three][:, 1] == 0)
    amp = pert["branch_amplitude"].values[0]
    for which in ("up", "down"):
        a_num = num[f"amplitude_{which}"].values[0][three]
        near_stable = np.abs(amp[three][:, [0, 2]] - a_num[:, None]).min(axis=1) / a_num
        assert np.all(near_stable < 0.05), which
    hysteresis = np.abs(num["amplitude_up"] - num["amplitude_down"]).values[0] > 0.05
    assert np.mean(hysteresis == three) > 0.9


def test_separation_harmonics_numerical_equals_closed_form():
    """For a pure cosine u = a cos(theta - gamma) and u_c = -1, the separation instants
    (Eqs. 32-33) reproduce the closed form (Eqs. 34-35), including Delta_2 and nu_2; with
    the separation's mean shift the numerical separated fraction is a fixed point."""
    c = coefficients(a00=0.0)
    s_cf = np.zeros(sf.N_SEP)
    z = np.zeros(3, dtype=complex)
    osc = np.zeros(sf.N_MIN_SAMPLES + 1)
    acc = np.zeros(5)
    for a, gam in ((1.2, 0.3), (1.05, -2.0), (2.0, 1.0), (0.9, 0.0)):
        mean = sf.margin_phasors(a, gam, c, 0.0, z)  # margin without any mean shift
        sf._oscillation_samples(z, osc)
        losses = sf._separation_integrals(mean, z, osc, acc)
        d0 = acc[0] / (2 * np.pi)
        d1, n1 = math.hypot(acc[1], acc[2]) / np.pi, math.atan2(acc[2], acc[1])
        d2, n2 = math.hypot(acc[3], acc[4]) / np.pi, math.atan2(acc[4], acc[3])
        sf.separation_closed_form(a, gam, c, 2, s_cf)
        np.testing.assert_allclose([d0, d1, d2], s_cf[[0, 1, 3]], atol=1e-12)
        for amp, n_num, k in ((d1, n1, sf.S_N1), (d2, n2, sf.S_N2)):
            if amp > 1e-12:  # phases where the harmonic exists
                assert math.cos(n_num - s_cf[k]) == pytest.approx(1.0, abs=1e-12)
        tau = math.acos(-1 / a) if a > 1 else math.pi
        assert s_cf[sf.S_D0] == pytest.approx(tau / math.pi - 1, abs=1e-14)
        assert losses == (1 if a > 1 else 0)
    # the mean shift S = -alpha_00 Delta_0 - (a Delta_1 / 2) cos(gamma - nu_1) solves S = G(S)
    s_num = np.zeros(sf.N_SEP)
    for a00 in (0.0, 0.7, 1.0):
        c = coefficients(a00=a00)
        sf.separation_numerical(1.3, 0.0, c, s_num)
        x = -s_num[sf.S_D0]
        tau = math.pi * (1.0 - x)
        shift = a00 * x - 0.5 * 1.3 * 2 * math.sin(tau) / math.pi
        assert x == pytest.approx(1 - math.acos(-(1.0 + shift) / 1.3) / math.pi, abs=1e-12)
        assert sf.separation_mean_shift(1.3, 0.0, c, s_num) == pytest.approx(shift, abs=1e-12)


@pytest.mark.e2e
def test_fig4_regions_and_accuracy_against_sweeps():
    """Seed Fig. 4: all four regions appear, and the second-order amplitude stays within a
    few per cent of the numerical sweeps in each region (the numbers go to the docs)."""
    model = MeshOscillator()
    grid = np.linspace(0.86, 1.1, 49)
    outs = ["amplitude_up", "amplitude_down", "region_up", "region_down"]
    pert = model.response({}, outputs=outs, frequencies=grid)
    num = model.response({}, outputs=outs, frequencies=grid, method="sweep")
    regions = np.concatenate([pert["region_up"].values[0], pert["region_down"].values[0]])
    assert set(regions) == {1, 2, 3, 4}
    err = np.concatenate([np.abs(pert[f"amplitude_{w}"] - num[f"amplitude_{w}"]).values[0]
                          / num[f"amplitude_{w}"].values[0] for w in ("up", "down")])
    same = np.concatenate([pert[f"region_{w}"].values[0] == num[f"region_{w}"].values[0]
                           for w in ("up", "down")])
    for region in (1, 2, 4):
        sel = (regions == region) & same
        assert sel.any() and err[sel].max() < 0.05, (region, err[sel].max())


def test_approximate_solution_follows_time_response():
    """Eq. 28 on the upward-sweep branch against the integrated response (region 2)."""
    model = MeshOscillator()
    t = np.linspace(0, 4 * 2 * np.pi / 0.95, 200)
    ds = model.response({"frequency_ratio": [0.95]}, t, outputs=["u", "u_perturbation"],
                        settle_tolerance=1e-5)
    diff = np.abs(ds["u"] - ds["u_perturbation"]).max().item()
    assert diff < 0.03 * np.abs(ds["u"]).max().item()


def test_onset_of_contact_loss_closed_forms():
    """The onsets found on the traced curves satisfy Eq. 37 (first order, closed form) and
    the corrected Eq. 36 (second order: amplitude at the onset for the response phase)."""
    from gearuq_plugins.mesh_oscillator.perturbation import onset_amplitude, onset_first_order

    c = coefficients(mu=0.0082, a00=2 / 3, a01=2 / 75, a20=0.25, a30=-1 / 24, e1=0.1)
    grid = np.linspace(0.85, 1.1, 101)
    first = frequency_response(c[None], grid, order=1)
    assert first.n_onsets[0] == 2
    np.testing.assert_allclose(first.onsets[0, :2, 0], onset_first_order(c)[0], atol=1e-9)
    np.testing.assert_allclose(first.onsets[0, :2, 1], 1.0, atol=1e-9)
    second = frequency_response(c[None], grid, order=2)
    on = second.onsets[0, :second.n_onsets[0]]
    assert on.shape[0] == 2
    for _omega, a, gam in on:
        assert a == pytest.approx(onset_amplitude(c, gam)[0], rel=1e-8)
        assert a < 1.0  # quadratic stiffness and e_1 bring the onset below a = 1
