"""The dynamic factor ``kv`` of the ``mesh_oscillator`` plugin against closed forms.

K_v = largest mesh force over the output instants (after settling) / the static mesh force
(the mean load). Oracles written from the equation of motion, not from the plugin's code:

- a linear, time-invariant mesh with a harmonic transmission-error excitation
  ``alpha_0_1 cos(Omega T)``: in contact ``u'' + 2 mu u' + u = -alpha_0_1 cos(Omega T)``, so the
  force ``alpha_0_0 + alpha_0_1 cos + u`` oscillates about the mean load with the amplitude
  ``alpha_0_1 Omega sqrt(Omega^2 + 4 mu^2) / |1 - Omega^2 + 2 i mu Omega|``;
- the dimensional linear mesh ``m x'' + c x' + k x = F_0 + F_1 cos(xi t)``: the force
  ``k x`` has the amplitude ``F_1 / |1 - Omega^2 + 2 i mu Omega|`` about F_0;
- no excitation (the Hertzian example of Eritenel and Parker included): K_v = 1; and
  K_v -> 1 in the quasi-static limit.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from gearuq import get_model

LINEAR = {"alpha_2_0": 0.0, "alpha_3_0": 0.0, "e_1": 0.0, "alpha_0_0": 1.0}


def _one_period(omega: float, points: int = 2001) -> np.ndarray:
    """Output instants over one mesh period of the frequency ratio ``omega``."""
    return np.linspace(0.0, 2.0 * math.pi / omega, points)


@pytest.mark.parametrize("omega", [0.5, 0.93, 1.0, 1.3, 2.5])
def test_kv_of_a_linear_mesh_with_transmission_error_excitation(omega):
    mu, a01 = 0.04, 0.03
    ds = get_model("mesh_oscillator").response(
        {**LINEAR, "alpha_0_1": a01, "damping_ratio": mu, "frequency_ratio": omega},
        _one_period(omega), outputs=["kv"], settle_tolerance=1e-9)
    assert ds["status"].values[0] == 0 and ds["kv"].dims == ("sample",)
    exact = 1.0 + a01 * omega * math.hypot(omega, 2 * mu) / abs(1 - omega**2
                                                                 + 2j * mu * omega)
    assert ds["kv"].values[0] - 1.0 == pytest.approx(exact - 1.0, rel=1e-5)


def test_kv_of_a_dimensional_linear_mesh_under_a_load_harmonic():
    """The dimensional route (the exact force, in newtons, over F_0)."""
    from gearuq_plugins.mesh_oscillator import PolynomialForce

    k, mass, f0, f1, mu = 2e8, 0.5, 4000.0, 60.0, 0.03  # stays in contact: K_v < 2
    model = get_model("mesh_oscillator", force=PolynomialForce.linear(k))
    for omega in (0.7, 1.0, 1.6):
        ds = model.response({"mass": mass, "mean_force": f0, "load_harmonic": f1,
                             "damping_ratio": mu, "frequency_ratio": omega},
                            _one_period(omega), outputs=["kv", "mesh_force"],
                            settle_tolerance=1e-9)
        exact = 1.0 + f1 / f0 / abs(1 - omega**2 + 2j * mu * omega)
        assert ds["status"].values[0] == 0
        assert ds["kv"].values[0] == pytest.approx(exact, rel=1e-6)
        assert ds["kv"].values[0] == pytest.approx(ds["mesh_force"].values[0].max() / f0)


def test_kv_is_one_without_excitation_and_in_the_quasi_static_limit():
    model = get_model("mesh_oscillator")
    # no excitation, Eritenel and Parker's Hertzian coefficients kept: the mesh stays static
    for omega in (0.4, 1.0, 3.0):
        ds = model.response({"alpha_0_1": 0.0, "e_1": 0.0, "frequency_ratio": omega},
                            _one_period(omega, 201), outputs=["kv"])
        assert ds["status"].values[0] == 0
        assert ds["kv"].values[0] == pytest.approx(1.0, abs=1e-12)
    # quasi-static: the excitation's force amplitude vanishes as Omega sqrt(Omega^2 + 4 mu^2)
    omega, mu, a01 = 0.01, 0.04, 0.03
    ds = model.response({**LINEAR, "alpha_0_1": a01, "damping_ratio": mu,
                         "frequency_ratio": omega}, _one_period(omega), outputs=["kv"],
                        settle_tolerance=1e-9)
    assert 1.0 < ds["kv"].values[0] < 1.0 + 3.0 * a01 * omega * math.hypot(omega, 2 * mu)


def test_kv_from_a_window_shorter_than_a_period_is_flagged():
    """A window shorter than one mesh period gives a lower bound: status 20, not a value
    passed off as the dynamic factor; no instants at all is refused."""
    model = get_model("mesh_oscillator")
    p = {**LINEAR, "alpha_0_1": 0.03, "damping_ratio": 0.04,
         "frequency_ratio": np.array([1.0, 1.0])}
    full = model.response(p, _one_period(1.0), outputs=["kv"], settle_tolerance=1e-9)
    short = model.response(p, _one_period(1.0)[:600], outputs=["kv"], settle_tolerance=1e-9)
    assert np.all(full["status"].values == 0) and np.all(short["status"].values == 20)
    assert "kv_window_short" in short["status"].attrs["flag_meanings"]
    assert np.all(short["kv"].values <= full["kv"].values + 1e-12)
    with pytest.raises(ValueError, match=r"t: kv is the largest mesh force"):
        model.response(p, [0.0], outputs=["kv"])
