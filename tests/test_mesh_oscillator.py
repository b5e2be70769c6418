"""mesh_oscillator (Eritenel and Parker (2013)): contract, inputs, force-deflection functions and
expansion.

Oracles: closed-form Taylor coefficients of Hertzian contact, the mean deflection of a linear
mesh with periodic stiffness, the LTCA's own force interpolation
(``gearuq.gears.ltca.force_at_deflection``) for the table kernel, and NumPy twins of the
compiled right-hand sides.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from gearuq.testing import check_model
from gearuq_plugins.mesh_oscillator import (
    ContactSegment,
    LoadDeflectionTable,
    MeshOscillator,
    Periodic,
    PolynomialForce,
    SegmentForce,
    TableFamily,
)
from gearuq_plugins.mesh_oscillator.expansion import expand, mean_deflection

ONE = np.ones(1)


def hertz_table(n_phase: int = 16, loads=(200.0, 500.0, 1000.0, 2000.0, 4000.0)):
    """Exact load-deflection table of f = K(phase) (x - g(phase))^1.5 with its tangents."""
    phase = np.arange(n_phase) / n_phase
    stiff = 2e11 * (1.0 + 0.1 * np.cos(2 * np.pi * phase))
    g = 1e-7 * np.cos(2 * np.pi * phase + 0.3)
    loads = np.asarray(loads)
    x = g + (loads[:, None] / stiff) ** (2 / 3)
    tangent = 1.5 * stiff * (x - g) ** 0.5
    return LoadDeflectionTable(loads, phase, x, g, tangent), stiff, g


# ------------------------------------------------------------------------------ contract
def test_conformance_nondimensional():
    ds = check_model(MeshOscillator(), np.linspace(0.0, 6.0, 7),
                     options={"n_frequencies": 21})
    assert ds["branch_amplitude"].dims == ("sample", "frequency", "branch")
    assert ds["frequency"].attrs["units"] == "1"
    assert set(np.unique(ds["region_up"].values)) <= {1, 2, 3, 4}


def test_conformance_dimensional_table():
    table, _, _ = hertz_table()
    model = MeshOscillator(table, nominal={"mean_force": 1500.0, "mass": 0.5})
    ds = check_model(model, np.linspace(0.0, 4.0, 5), options={"n_frequencies": 15})
    np.testing.assert_allclose(ds["dte_amplitude_up"], ds["amplitude_up"]
                               * ds["deflection_scale"], rtol=1e-12)
    assert ds["mesh_force"].attrs["units"] == "N"


def test_outputs_without_time_need_no_t():
    model = MeshOscillator()
    ds = model.response({"damping_ratio": [0.01, 0.02]}, outputs=["peak_amplitude"],
                        n_frequencies=41)
    assert "time" not in ds.dims and ds["peak_amplitude"].dims == ("sample",)
    # more damping, lower peak (linear theory: peak ~ alpha_0_1 / (2 mu))
    assert ds["peak_amplitude"].values[0] > ds["peak_amplitude"].values[1]


# ------------------------------------------------------------------------------ bad input
def test_bad_inputs_raise_clear_errors():
    model = MeshOscillator()
    with pytest.raises(ValueError, match="damping_ratio"):
        model.response({"damping_ratio": [-0.01]}, outputs=["peak_amplitude"])
    with pytest.raises(ValueError, match="frequencies"):
        model.response({}, outputs=["peak_amplitude"], frequencies=[0.9, 0.0, 1.1])
    with pytest.raises(ValueError, match="frequencies"):
        model.response({}, outputs=["peak_amplitude"], frequencies=[-1.0, 1.0])
    with pytest.raises(ValueError, match="frequency_min"):
        model.response({}, outputs=["peak_amplitude"], frequency_min=0.0)
    with pytest.raises(ValueError, match="frequency_units"):
        model.response({}, outputs=["peak_amplitude"], frequency_units="Hz")
    with pytest.raises(ValueError, match="order"):
        model.response({}, outputs=["peak_amplitude"], order=3)
    with pytest.raises(ValueError, match="method='perturbation'"):
        model.response({}, outputs=["branch_amplitude"], method="sweep", n_frequencies=3)
    with pytest.raises(ValueError, match="nominal"):
        MeshOscillator(nominal={"no_such": 1.0})


def test_force_table_must_be_periodic_and_monotone():
    x = np.linspace(0.0, 4e-5, 9)
    phase = np.linspace(0.0, 1.0, 9)
    good = 1e8 * np.maximum(x[:, None] - 5e-6 * (1 + np.cos(2 * np.pi * phase)), 0.0)
    table = LoadDeflectionTable.from_force_table(x, phase, good)
    assert table.loads.size == 8
    not_periodic = good.copy()
    not_periodic[:, -1] *= 1.01
    with pytest.raises(ValueError, match="not periodic"):
        LoadDeflectionTable.from_force_table(x, phase, not_periodic)
    not_monotone = good.copy()
    not_monotone[6, 3] = not_monotone[5, 3] * 0.9
    with pytest.raises(ValueError, match="not monotone in deflection at phase 0.375"):
        LoadDeflectionTable.from_force_table(x, phase, not_monotone)
    with pytest.raises(ValueError, match="phase"):
        LoadDeflectionTable.from_force_table(x, phase[:-1], good[:, :-1])
    loads = np.array([100.0, 200.0])
    defl = np.array([[1e-6] * 4, [0.9e-6] * 4])  # deflection falls as the load rises
    with pytest.raises(ValueError, match="not monotone in load"):
        LoadDeflectionTable(loads, np.arange(4) / 4, defl, np.zeros(4))
    with pytest.raises(ValueError, match="stiffness k_1"):
        PolynomialForce.linear(-1.0)
    with pytest.raises(ValueError, match="stiffness"):
        ContactSegment(Periodic(1.0, (2.0,)), 0.0)


# ------------------------------------------------------------------------------ expansion
def test_hertz_taylor_coefficients_closed_form():
    """f = K (x - g)^{3/2}: alpha_00 = 2/3, alpha_20 = 1/4, alpha_30 = -1/24 whatever K, F0
    (d^i f / dx^i at x_m over beta_10 d^{1-i} / i!); these are the seed's Fig. 4 values."""
    force = SegmentForce.hertz(3e10, 2e-6)
    f0 = np.array([50.0, 5e3])
    ex = expand(force, mass=np.ones(2), mean_force=f0, damping_ratio=0.02 * np.ones(2),
                load_harmonic=np.zeros(2), load_phase=np.zeros(2))
    np.testing.assert_allclose(ex.alpha[:, :, 0], [[2 / 3, 1, 1 / 4, -1 / 24]] * 2,
                               rtol=1e-9)
    np.testing.assert_allclose(ex.mean_deflection, 2e-6 + (f0 / 3e10) ** (2 / 3), rtol=1e-10)
    np.testing.assert_allclose(ex.stiffness, 1.5 * 3e10 * (f0 / 3e10) ** (1 / 3), rtol=1e-9)
    # the truncated series misses f at u = -1 by alpha_00 - 1 + 1/4 + 1/24 = -1/24 (of k d)
    np.testing.assert_allclose(ex.error, (1 / 24) / (2 / 3), rtol=1e-6)


def test_linear_periodic_mesh_closed_form():
    """f = k(t) (x - g(t)): x_m = (F0 + mean(k g)) / mean(k) (Eq. 4), alpha_{1,r} = k_r / k_0,
    e_r = g_r / d, and every phase relative to the first excitation harmonic (Eq. 14)."""
    k = Periodic(2e8, (3e7,), (1e7,))
    g = Periodic(1e-6, (2e-6,), (-1e-6,))
    force = SegmentForce.linear(k, g)
    f0 = 2e3
    ex = expand(force, mass=ONE, mean_force=f0 * ONE, damping_ratio=0.01 * ONE,
                load_harmonic=0 * ONE, load_phase=0 * ONE, harmonics=3)
    kg_mean = 1e-6 * 2e8 + 0.5 * (3e7 * 2e-6 + 1e7 * -1e-6)  # mean of k(t) g(t)
    x_m = (f0 + kg_mean) / 2e8
    assert ex.mean_deflection[0] == pytest.approx(x_m, rel=1e-10)
    d = x_m - 1e-6
    assert ex.scale[0] == pytest.approx(d, rel=1e-10)
    assert ex.alpha[0, 1, 1] == pytest.approx(math.hypot(3e7, 1e7) / 2e8, rel=1e-10)
    assert ex.e[0, 0] == pytest.approx(math.hypot(2e-6, 1e-6) / d, rel=1e-10)
    # B_0(t) = k(t) (x_m - g(t)): its first harmonic sets the phase reference Phi_01
    phase = np.arange(64) / 64
    b0 = k(phase) * (x_m - g(phase))
    c1 = np.sum(b0 * np.exp(-2j * np.pi * phase)) / 64
    assert ex.phase_reference[0] == pytest.approx(-np.angle(c1), abs=1e-12)
    assert ex.alpha[0, 0, 1] == pytest.approx(2 * abs(c1) / (2e8 * d), rel=1e-10)
    phi_k = -np.angle(3e7 - 1e7j)  # k_1 cos(t) + k_1' sin(t) = |k_1| cos(t - phi)
    assert ex.phi[0, 1, 1] == pytest.approx(
        (phi_k + np.angle(c1) + np.pi) % (2 * np.pi) - np.pi, abs=1e-10)
    assert ex.error[0] < 1e-12  # linear in x: the expansion is exact


def test_cubic_force_expansion_is_exact():
    force = PolynomialForce.cubic(1e8, -2e17)
    ex = expand(force, mass=ONE, mean_force=500.0 * ONE, damping_ratio=0.02 * ONE,
                load_harmonic=0 * ONE, load_phase=0 * ONE)
    x = ex.mean_deflection[0]
    assert 1e8 * x - 2e17 * x**3 == pytest.approx(500.0, rel=1e-12)
    kt = 1e8 - 6e17 * x**2
    d = x
    np.testing.assert_allclose(ex.alpha[0, :, 0], [500 / (kt * d), 1.0, -6e17 * x * d / kt,
                                                   -2e17 * d**2 / kt], rtol=1e-9)
    assert ex.error[0] < 1e-9


def test_table_taylor_matches_analytic_force():
    """A Hertzian table with exact tangents: Hermite interpolation and the least-squares
    expansion reproduce the analytic coefficients closely."""
    table, stiff, g = hertz_table(n_phase=32, loads=np.geomspace(50.0, 8000.0, 12))
    f0 = np.array([1000.0, 3000.0])
    ex = expand(table, mass=np.ones(2), mean_force=f0, damping_ratio=0.02 * np.ones(2),
                load_harmonic=np.zeros(2), load_phase=np.zeros(2), method="taylor")
    ref = expand(SegmentForce.hertz(Periodic(2e11, (2e10,)), Periodic(0.0, (1e-7 * np.cos(0.3),),
                                                                       (-1e-7 * np.sin(0.3),))),
                 mass=np.ones(2), mean_force=f0, damping_ratio=0.02 * np.ones(2),
                 load_harmonic=np.zeros(2), load_phase=np.zeros(2))
    np.testing.assert_allclose(ex.mean_deflection, ref.mean_deflection, rtol=2e-4)
    np.testing.assert_allclose(ex.alpha[:, :2, :2], ref.alpha[:, :2, :2], rtol=0.02, atol=2e-3)
    fit = expand(table, mass=np.ones(2), mean_force=f0, damping_ratio=0.02 * np.ones(2),
                 load_harmonic=np.zeros(2), load_phase=np.zeros(2), method="fit")
    assert fit.method == "fit" and np.all(fit.error < 0.05)


def test_table_kernel_matches_ltca_interpolation():
    """The compiled table force equals gearuq.gears.ltca.force_at_deflection (same data,
    an independent implementation of the Hermite interpolation) at the table phases."""
    import xarray as xr

    from gearuq.gears.ltca import force_at_deflection
    from gearuq_plugins.mesh_oscillator import kernels

    table, _, _ = hertz_table(n_phase=16)
    fd = xr.Dataset({"ste": (("load", "position"), table.deflection * 1e6),
                     "lpms_tangent": (("load", "position"), table.tangent_stiffness * 1e-6),
                     "ste_at_zero_load": ("position", table.unloaded_deflection * 1e6)},
                    coords={"load": table.loads})
    delta = np.linspace(-0.2, 7.0, 60)  # um, from out of contact to near the top load
    ref = force_at_deflection(fd, delta).values
    x_m, d, km = np.array([4e-6]), np.array([3e-6]), np.array([5e8])
    kind, block, _ = table.kernel_block(x_m, d, km, np.zeros(1), None, None)
    p = np.zeros(kernels.H_BLOCK + block.shape[1])
    p[kernels.H_BLOCK:] = block[0]
    for j, ph in enumerate(table.phase):
        theta = 2 * np.pi * ph
        u0 = kernels.fourier(theta, p, kernels.H_BLOCK + 2 + int(p[kernels.H_BLOCK]),
                             int(p[kernels.H_BLOCK + 1]))
        for i, dl in enumerate(delta):
            u = (dl * 1e-6 - x_m[0]) / d[0]
            mine = kernels.table_force(u, theta, p) * km[0] * d[0] if u >= u0 else 0.0
            if np.isfinite(ref[j, i]):
                assert mine == pytest.approx(ref[j, i], rel=1e-8, abs=1e-6)


def test_family_interpolates_between_members():
    t1, _, _ = hertz_table()
    t2 = LoadDeflectionTable(t1.loads, t1.phase, t1.deflection * 1.2,
                             t1.unloaded_deflection, t1.tangent_stiffness / 1.2)
    fam = TableFamily((t1, t2), (0.0, 10e-6), name="relief")
    assert fam.parameters[0].name == "relief"
    mid = fam.member({"relief": 5e-6})
    np.testing.assert_allclose(mid.deflection, t1.deflection * 1.1, rtol=1e-12)
    model = MeshOscillator(fam, nominal={"mean_force": 1000.0})
    ds = model.response({"relief": [0.0, 10e-6]}, outputs=["mean_deflection"])
    m1 = mean_deflection(t1, np.array([1000.0]))[0]
    m2 = mean_deflection(t2, np.array([1000.0]))[0]
    np.testing.assert_allclose(ds["mean_deflection"].values, [m1, m2], rtol=1e-9)


def test_ltca_force_deflection_source():
    """The LTCA of Yuan, Liu and Liu's pair over one mesh cycle: a valid monotone table whose mean
    tangent stiffness is the LTCA's mean tangent mesh stiffness at the mean load."""
    from gearuq.gears.geometry import seed002_pair

    pair = seed002_pair()
    loads = np.array([1e3, 3e3, 6e3, 1e4])
    table = LoadDeflectionTable.from_ltca(pair, loads, positions_per_cycle=8, n_pts=8)
    ex = expand(table, mass=ONE, mean_force=np.array([6e3]), damping_ratio=0.03 * ONE,
                load_harmonic=0 * ONE, load_phase=0 * ONE, method="taylor")
    # at a load node the Hermite tangent is the LTCA tangent stiffness itself
    mean_tangent = table.tangent_stiffness[2].mean()
    assert ex.mean_deflection[0] == pytest.approx(table.deflection[2].mean(), rel=0.02)
    assert ex.stiffness[0] == pytest.approx(mean_tangent, rel=0.03)
    assert 0.0 < ex.alpha[0, 0, 1] < 0.5  # the excitation harmonic of a perfect pair


def test_long_separation_is_flagged_not_dropped():
    """A sweep path out of contact for more than max_separation of the period gets status 17
    (the theory assumes short separations); its numbers are kept."""
    model = MeshOscillator()
    kw = {"outputs": ["amplitude_down", "separation_down"], "frequency_min": 0.86,
          "frequency_max": 1.1, "n_frequencies": 25}
    ok = model.response({}, **kw)
    worst = ok["separation_down"].values.max()
    assert ok["status"].item() == 0 and 0.3 < worst < 0.5
    flagged = model.response({}, max_separation=0.3, **kw)
    assert flagged["status"].item() == 17
    assert "separation_beyond_validity" in flagged["status"].attrs["flag_meanings"]
    np.testing.assert_array_equal(flagged["amplitude_down"], ok["amplitude_down"])
