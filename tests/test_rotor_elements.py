"""Rotor finite elements against closed forms and published rotors (no shared code).

Oracles: the Timoshenko frequency equation of a simply supported beam, Euler-Bernoulli and
bar/torsion closed forms, Przemieniecki's closed-form Timoshenko stiffness matrix, static
beam formulas, Friswell et al. (2010) Example 5.9.1 and rigid-body kinematics of the mesh.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import scipy.linalg as sla

from gearuq.rotor.assembly import Rotor
from gearuq.rotor.bearing import BearingElement
from gearuq.rotor.disk import DiskElement
from gearuq.rotor.element import Material
from gearuq.rotor.examples import friswell_example
from gearuq.rotor.mesh import HelicalMeshElement
from gearuq.rotor.modal import campbell, complex_modes
from gearuq.rotor.shaft import ShaftLine, TimoshenkoShaftElement

E, G, RHO, D, L = 211e9, 81.2e9, 7810.0, 0.05, 1.5
NU = E / (2 * G) - 1
KAPPA = 6 * (1 + NU) / (7 + 6 * NU)  # Cowper, solid circle
AREA = math.pi * D**2 / 4
INERTIA = math.pi * D**4 / 64


def timoshenko_simply_supported(n: int) -> float:
    """Root of (rho A w^2 - kGA k^2)(rho I w^2 - EI k^2 - kGA) = (kGA k)^2, k = n pi / L."""
    k = n * math.pi / L
    kga = KAPPA * G * AREA
    a = RHO * AREA * RHO * INERTIA
    b = -(RHO * AREA * (E * INERTIA * k**2 + kga) + kga * k**2 * RHO * INERTIA)
    c = kga * k**2 * (E * INERTIA * k**2 + kga) - (kga * k) ** 2
    return math.sqrt((-b - math.sqrt(b * b - 4 * a * c)) / (2 * a))


def plane_frequencies(n_el: int, dofs: tuple[int, ...], fixed: list[tuple[int, int]],
                      n: int = 4, **kw) -> np.ndarray:
    """Lowest frequencies of a uniform shaft restricted to some local DOFs, some fixed."""
    shaft = ShaftLine.from_sections([L], [D], n_el)
    rotor = Rotor(shaft.elements(**kw), shafts=[shaft])
    local = np.arange(rotor.n_dof) % 6
    keep = np.flatnonzero(np.isin(local, dofs))
    drop = [6 * node + d for node, d in fixed]
    keep = np.setdiff1d(keep, drop)
    K, M = rotor.K(), rotor.M()
    w2 = sla.eigh(K[np.ix_(keep, keep)], M[np.ix_(keep, keep)], eigvals_only=True)
    w2 = w2[w2 > 1.0]  # drop rigid-body modes (free-free), keep every elastic one
    return np.sqrt(w2[:n])


def test_published_timoshenko_values_follow_from_the_frequency_equation():
    np.testing.assert_allclose([timoshenko_simply_supported(n) for n in range(1, 5)],
                               [284.616, 1133.912, 2534.573, 4465.465], atol=6e-4)


@pytest.mark.parametrize("plane", [(0, 4), (1, 3)], ids=["xz", "yz"])
def test_simply_supported_timoshenko_within_0p1_percent(plane):
    ref = np.array([284.616, 1133.912, 2534.573, 4465.465])
    w = plane_frequencies(32, plane, [(0, plane[0]), (32, plane[0])])
    assert np.max(np.abs(w / ref - 1)) < 1e-3
    assert np.all(w >= ref * (1 - 1e-6))  # consistent mass: upper bounds


def test_bending_convergence_orders():
    """Euler-Bernoulli (Hermite cubics): order 4. Timoshenko IIE: monotone, order -> 2."""
    eb_ref = np.array([(n * math.pi / L) ** 2 * math.sqrt(E * INERTIA / (RHO * AREA))
                       for n in range(1, 4)])
    tim_ref = np.array([timoshenko_simply_supported(n) for n in range(1, 4)])
    errs_eb, errs_t = [], []
    for n_el in (8, 16, 32):
        fixed = [(0, 0), (n_el, 0)]
        errs_eb.append(plane_frequencies(n_el, (0, 4), fixed, 3, shear=False,
                                         rotary_inertia=False) / eb_ref - 1)
        errs_t.append(plane_frequencies(n_el, (0, 4), fixed, 3) / tim_ref - 1)
    order_eb = np.log2(np.asarray(errs_eb[1]) / np.asarray(errs_eb[2]))
    order_t = np.log2(np.asarray(errs_t[:-1]) / np.asarray(errs_t[1:]))
    np.testing.assert_allclose(order_eb, 4.0, atol=0.1)
    # shear-dominated interpolation once Phi = 12EI/(kGA Le^2) > 1: between 2 and 4
    assert np.all(order_t > 2.0) and np.all(order_t < 3.6)
    assert np.all(order_t[1] < order_t[0])


@pytest.mark.parametrize("dof,modulus", [(2, E), (5, G)], ids=["axial", "torsion"])
def test_free_free_axial_and_torsion_against_closed_form(dof, modulus):
    ref = np.array([n * math.pi / L * math.sqrt(modulus / RHO) for n in range(1, 4)])
    errs = []
    for n_el in (60, 120):
        w = plane_frequencies(n_el, (dof,), [], 3)
        errs.append(w / ref - 1)
    assert np.max(np.abs(errs[1])) < 1e-3
    np.testing.assert_allclose(np.log2(errs[0] / errs[1]), 2.0, atol=0.05)


def test_timoshenko_stiffness_equals_przemieniecki_closed_form():
    el = TimoshenkoShaftElement(0, 0.3, 0.08, 0.02)
    EI, Le, phi = el.material.E * el.second_moment, el.length, el.shear_parameter
    c = EI / ((1 + phi) * Le**3)
    k = c * np.array([
        [12, 6 * Le, -12, 6 * Le],
        [6 * Le, (4 + phi) * Le**2, -6 * Le, (2 - phi) * Le**2],
        [-12, -6 * Le, 12, -6 * Le],
        [6 * Le, (2 - phi) * Le**2, -6 * Le, (4 + phi) * Le**2],
    ])
    K = el.K()
    np.testing.assert_allclose(K[np.ix_([0, 4, 6, 10], [0, 4, 6, 10])], k, rtol=1e-12)
    s = np.diag([1.0, -1.0, 1.0, -1.0])  # y-z plane uses (y, -theta_x)
    np.testing.assert_allclose(K[np.ix_([1, 3, 7, 9], [1, 3, 7, 9])], s @ k @ s, rtol=1e-12)
    np.testing.assert_allclose(K, K.T, atol=1e-6 * np.abs(K).max())


def test_cantilever_tip_deflection_is_exact_with_one_element():
    """P L^3 / (3 E I) + P L / (kappa G A): the element is exact for nodal loads."""
    el = TimoshenkoShaftElement(0, 0.4, 0.06)
    free = [6, 7, 8, 9, 10, 11]
    K = el.K()[np.ix_(free, free)]
    u = np.linalg.solve(K, np.array([1000.0, 0, 0, 0, 0, 0]))
    I_, A_ = el.second_moment, el.area
    ref = 1000 * 0.4**3 / (3 * E * I_) + 1000 * 0.4 / (el.shear_coefficient * G * A_)
    assert u[0] == pytest.approx(ref, rel=1e-12)
    assert u[4] == pytest.approx(1000 * 0.4**2 / (2 * E * I_), rel=1e-12)  # theta_y = dx/dz


def test_mass_and_gyroscopic_matrices_reproduce_rigid_body_inertia():
    el = TimoshenkoShaftElement(0, 0.25, 0.07, 0.03)
    M, Gm = el.M(), el.G()
    tx = np.zeros(12)
    tx[[0, 6]] = 1.0
    assert tx @ M @ tx == pytest.approx(el.mass, rel=1e-12)
    spin = np.zeros(12)
    spin[[5, 11]] = 1.0
    assert spin @ M @ spin == pytest.approx(el.material.rho * el.polar_moment * el.length,
                                            rel=1e-12)
    Le = el.length
    tilt_y = np.zeros(12)     # rigid rotation about y: x = z, theta_y = 1
    tilt_y[[4, 10]] = 1.0
    tilt_y[6] = Le
    tilt_x = np.zeros(12)     # rigid rotation about x: y = -z, theta_x = 1
    tilt_x[[3, 9]] = 1.0
    tilt_x[7] = -Le
    ip = el.material.rho * el.polar_moment * Le
    assert tilt_x @ Gm @ tilt_y == pytest.approx(ip, rel=1e-12)
    np.testing.assert_allclose(Gm, -Gm.T, atol=1e-15)


def test_disk_from_geometry_matches_friswell():
    d1 = DiskElement.from_geometry(2, 0.07, 0.05, 0.28)
    d2 = DiskElement.from_geometry(4, 0.07, 0.05, 0.35)
    np.testing.assert_allclose([d1.mass, d1.diametral_inertia, d1.polar_inertia],
                               [32.590, 0.17809, 0.32956], rtol=2e-5)
    np.testing.assert_allclose([d2.mass, d2.diametral_inertia, d2.polar_inertia],
                               [51.525, 0.42358, 0.80508], rtol=2e-5)


def test_friswell_example_5_9_1_at_0_and_4000_rpm():
    rotor = friswell_example()
    still = complex_modes(rotor, 0.0, n_modes=6)
    # the published values are truncated to two decimals (ROSS prints 716.7863)
    np.testing.assert_allclose(still.frequency, [86.66, 86.66, 274.31, 274.31, 650.41, 716.78],
                               atol=1e-2)
    spinning = complex_modes(rotor, 4000 * math.pi / 30, n_modes=6)
    np.testing.assert_allclose(spinning.frequency,
                               [85.39, 87.80, 251.78, 294.71, 600.18, 650.41], atol=1e-2)
    # backward whirl below, forward above each split pair; 650.41 is the torsional mode
    assert spinning.whirl_label()[:5] == ["backward", "forward", "backward", "forward",
                                          "backward"]
    assert spinning.kind[5] == "torsional"


def test_campbell_dataset_splits_with_speed():
    ds = campbell(friswell_example(), np.linspace(0, 4000 * math.pi / 30, 5), n_modes=4,
                  excitation_orders=(1.0,))
    f = ds["frequency"].values
    assert f.shape == (5, 4)
    assert np.all(np.diff(f[:, 0]) < 0) and np.all(np.diff(f[:, 1]) > 0)
    assert ds["frequency"].attrs["units"] == "rad s-1"


def test_bad_geometry_raises_with_names():
    with pytest.raises(ValueError, match="length"):
        TimoshenkoShaftElement(0, 0.0, 0.05)
    with pytest.raises(ValueError, match="outer_diameter"):
        TimoshenkoShaftElement(0, 0.1, -0.05)
    with pytest.raises(ValueError, match="inner_diameter"):
        TimoshenkoShaftElement(0, 0.1, 0.05, 0.05)
    with pytest.raises(ValueError, match=r"lengths\[1\]"):
        ShaftLine.from_sections([0.1, 0.0], [0.05, 0.05])
    with pytest.raises(ValueError, match=r"outer_diameters\[0\]"):
        ShaftLine.from_sections([0.1, 0.1], [0.0, 0.05])
    with pytest.raises(ValueError, match="not a node"):
        ShaftLine.from_sections([0.1, 0.1], [0.05, 0.05]).node_at(0.3)
    shaft = ShaftLine.from_sections([0.1, 0.1], [0.05, 0.05])
    with pytest.raises(ValueError, match="outside the shafts"):
        Rotor(shaft.elements() + [BearingElement(7, 1e8, 1e8)], shafts=[shaft])
    with pytest.raises(ValueError, match="rho"):
        Material("x", 1e9, 4e8, -1.0)
    with pytest.raises(ValueError, match="kxx"):
        BearingElement(0, -1.0, 1.0)


# ---------------------------------------------------------------------------------- mesh
def _mesh(**kw) -> HelicalMeshElement:
    args = dict(pinion_node=0, gear_node=1, base_radius_pinion=0.09, base_radius_gear=0.13,
                pressure_angle=math.radians(21.0), base_helix_angle=math.radians(17.0),
                centre_line_angle=math.radians(30.0))
    return HelicalMeshElement(**{**args, **kw})


def _rigid_motion(mesh: HelicalMeshElement, translation, rotation) -> np.ndarray:
    """Nodal DOFs of a rigid motion of the whole gearbox (pinion at 0, gear at a e_c)."""
    a = (mesh.base_radius_pinion + mesh.base_radius_gear) / math.cos(mesh.pressure_angle)
    e_c = np.array([math.cos(mesh.centre_line_angle), math.sin(mesh.centre_line_angle), 0.0])
    u = []
    for centre in (np.zeros(3), a * e_c):
        u += list(np.asarray(translation) + np.cross(rotation, centre)) + list(rotation)
    return np.array(u)


@pytest.mark.parametrize("helix_sign,drive_sign,offset",
                         [(1, 1, 0.0), (-1, 1, 0.0), (1, -1, 0.0), (1, 1, 0.02), (-1, -1, -0.03)])
def test_mesh_direction_is_unit_and_rigid_motions_give_no_deflection(helix_sign, drive_sign,
                                                                       offset):
    # a contact point off the mid-face plane (contact_offset) moves both arms alike
    mesh = _mesh(helix_sign=helix_sign, drive_sign=drive_sign, contact_offset=offset)
    v = mesh.direction_vector()
    assert np.linalg.norm(v[:3]) == pytest.approx(1.0, abs=1e-15)
    assert np.linalg.norm(v[6:9]) == pytest.approx(1.0, abs=1e-15)
    rng = np.random.default_rng(3)
    for _ in range(6):
        u = _rigid_motion(mesh, rng.normal(size=3), rng.normal(size=3))
        assert abs(v @ u) < 1e-14 * np.abs(u).max()
    # the gears turning together (kinematic rotation) keeps the mesh closed too
    kin = np.zeros(12)
    kin[5], kin[11] = 1.0 / mesh.base_radius_pinion, -1.0 / mesh.base_radius_gear
    assert abs(v @ kin) < 1e-15


def test_seed_moment_arms_fail_a_rigid_rotation_about_the_poa_normal():
    """Seed Eq. 8 (base-circle arms) gives delta = T1T2 sin(beta_b) per rad of rotation."""
    mesh = _mesh(moment_arm="base_circle")
    f = mesh.frame()
    axis = np.cross(f["t"], [0.0, 0.0, 1.0])      # e_r: normal to the plane of action
    u = _rigid_motion(mesh, np.zeros(3), axis)
    a = mesh.pressure_angle
    t1t2 = (mesh.base_radius_pinion + mesh.base_radius_gear) * math.tan(a)
    assert abs(mesh.direction_vector() @ u) == pytest.approx(
        t1t2 * math.sin(mesh.base_helix_angle), rel=1e-12)


def test_seed_form_reproduces_eq8_entries():
    bb, a, rp, rg = math.radians(17.0), math.radians(21.0), 0.09, 0.13
    mesh = HelicalMeshElement(0, 1, rp, rg, a, bb, moment_arm="base_circle")
    cb, sb, sp, cp = math.cos(bb), math.sin(bb), math.sin(a), math.cos(a)
    eq8 = [cb * sp, cb * cp, -sb, rp * sb * sp, rp * sb * cp, rp * cb,
           -cb * sp, -cb * cp, sb, rg * sb * sp, rg * sb * cp, rg * cb]
    np.testing.assert_allclose(mesh.direction_vector(), eq8, atol=1e-15)


def test_mesh_force_moments_about_the_shaft_axes():
    """A mesh force F along n loads each shaft with the torque F r_b cos(beta_b)."""
    mesh = _mesh()
    v = mesh.direction_vector()
    cb = math.cos(mesh.base_helix_angle)
    assert v[5] == pytest.approx(mesh.base_radius_pinion * cb, rel=1e-14)
    assert v[11] == pytest.approx(mesh.base_radius_gear * cb, rel=1e-14)
    te = mesh.transmission_error_vector()
    assert np.count_nonzero(te) == 2 and te[5] == v[5]
    K = _mesh(stiffness=5e8).K()
    np.testing.assert_allclose(K, 5e8 * np.outer(v, v))
    assert np.linalg.matrix_rank(K) == 1


def test_mesh_bad_inputs():
    with pytest.raises(ValueError, match="base_radius_gear"):
        _mesh(base_radius_gear=0.0)
    with pytest.raises(ValueError, match="helix_sign"):
        _mesh(helix_sign=0)
    with pytest.raises(ValueError, match="gear_node"):
        _mesh(gear_node=0)
