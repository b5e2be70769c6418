"""The FE rotor of a stage: bending frequencies against an independent beam calculation."""

from __future__ import annotations

import math

import numpy as np
import pytest
import scipy.linalg

from gearuq.gears.stage import Bearing, GearStage, Shaft
from gearuq.rotor.modal import undamped_modes
from gearuq.rotor.stage import stage_rotor


def _ritz_frequencies(L, d, E, rho, m, J, zg, n_terms=40):
    """Pinned-pinned Rayleigh beam (Euler-Bernoulli with the section's rotary inertia) with a
    rigid disk (mass m, diametral inertia J) at zg: Rayleigh-Ritz on sin(k pi z / L), written
    for this test (no gearuq code). Shear deformation is left out (Timoshenko lowers the
    frequencies by a further ~E/(kappa G) times the rotary-inertia correction)."""
    A, I = math.pi * d**2 / 4, math.pi * d**4 / 64
    k = np.arange(1, n_terms + 1) * math.pi / L
    K = np.diag(E * I * k**4 * L / 2)
    M = np.diag(rho * A * np.full(n_terms, L / 2) + rho * I * k**2 * L / 2)
    phi, dphi = np.sin(k * zg), k * np.cos(k * zg)
    M = M + m * np.outer(phi, phi) + J * np.outer(dphi, dphi)
    w2 = scipy.linalg.eigh(K, M, eigvals_only=True)
    return np.sqrt(np.sort(w2)) / (2 * math.pi)


def test_shaft_bending_frequencies_against_ritz_beam():
    # slender 600 x 20 mm shafts on very stiff bearings at the ends, mesh stiffness 0: each
    # shaft bends as a pinned-pinned beam carrying its gear body
    L, d = 600.0, 20.0
    shaft = Shaft(sections=((L, d, 0.0),), gear_position=200.0,
                  bearings=(Bearing(0.0, 1e5, 1e5), Bearing(L, 1e5, 0.0)))
    stage = GearStage(normal_module=1.0, teeth=(30, 45), normal_pressure_angle=20.0,
                      helix_angle=0.0, face_width=(10.0, 10.0), pinion_shaft=shaft,
                      wheel_shaft=shaft)
    rotor = stage_rotor(stage, 0.0, max_element_length=0.01)
    f = undamped_modes(rotor).omega / (2 * math.pi)
    lateral = np.sort(f[f > 1.0])
    # gear body of the pinion: annulus, bore 20 mm, outer sqrt((df^2 + da^2)/2), width 10 mm
    p = stage.pair
    E, rho = 206e9, 7850.0
    for da, df in ((p.da1, p.df1),):
        D, b, bore = math.sqrt(0.5 * (df**2 + da**2)), 0.010, 0.020
        m = rho * math.pi / 4 * (D**2 - bore**2) * b
        J = m * ((D**2 + bore**2) / 16 + b**2 / 12)
        ref = _ritz_frequencies(L * 1e-3, d * 1e-3, E, rho, m, J, 0.2)
        # the pinion shaft's first bending pair (x and y) is in the rotor's spectrum
        # (Timoshenko vs Rayleigh beam at L/d = 30: shear lowers them by < 0.5 %)
        for mode, tol in ((0, 2e-3), (1, 5e-3)):
            nearest = lateral[np.argmin(abs(lateral - ref[mode]))]
            assert ref[mode] * (1 - tol) <= nearest <= ref[mode] * (1 + 1e-4)


def test_paper_stage_rotor_matches_the_paper_rotor():
    from gearuq.rotor.examples import seed002_rotor

    stage = GearStage.example("yuan_liu_liu")
    k = 7.0e8
    ours = undamped_modes(stage_rotor(stage, k)).omega[1:16]
    paper = undamped_modes(seed002_rotor(k, drive_inertia=0.03, load_inertia=0.03)).omega[1:16]
    # same rotor, finer elements (<= 20 mm instead of 13 per shaft)
    np.testing.assert_allclose(ours, paper, rtol=2e-3)


def test_rotor_needs_shafts():
    stage = GearStage(normal_module=2.0, teeth=(27, 79), normal_pressure_angle=20.0,
                      helix_angle=22.0, face_width=(30.0, 28.0))
    with pytest.raises(ValueError, match=r"needs \[pinion_shaft\] and \[wheel_shaft\]"):
        stage_rotor(stage, 1e8)
