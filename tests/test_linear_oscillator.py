"""The analytic oracle plugin against an independent numerical solution and its own identities."""

import numpy as np
import pytest
from scipy.integrate import solve_ivp

import gearuq
from gearuq.testing import check_model


@pytest.fixture(scope="module")
def model():
    return gearuq.get_model("linear_oscillator")


def test_conformance(model):
    check_model(model, np.linspace(0, 0.5, 11), n_samples=4)


@pytest.mark.parametrize("zeta", [0.0, 0.05, 0.999999, 1.0, 1.000001, 3.0])
def test_closed_form_matches_numerical_integration(model, zeta):
    m, k, force, omega, x0, v0 = 2.0, 5.0e3, 7.0, 31.0, 1e-3, -0.2
    c = 2 * zeta * np.sqrt(k * m)
    t = np.linspace(0, 1.0, 201)
    ds = model.response(dict(m=m, k=k, c=c, force=force, omega=omega, x0=x0, v0=v0), t)

    def rhs(tt, y):
        return [y[1], (force * np.cos(omega * tt) - c * y[1] - k * y[0]) / m]

    ref = solve_ivp(rhs, (0, 1.0), [x0, v0], t_eval=t, method="DOP853", rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(ds["displacement"][0], ref.y[0], atol=1e-10)
    np.testing.assert_allclose(ds["velocity"][0], ref.y[1], atol=1e-8)


def test_initial_conditions_and_steady_state(model):
    t = np.array([0.0, 50.0])  # transient decayed at zeta = 0.1 after 5000 periods
    ds = model.response({"x0": [0.01, -0.02], "v0": [1.0, 0.0], "force": [10.0, -3.0]}, t)
    np.testing.assert_allclose(ds["displacement"][:, 0], [0.01, -0.02], atol=1e-15)
    np.testing.assert_allclose(ds["velocity"][:, 0], [1.0, 0.0], atol=1e-12)
    m, k, c, omega = 1.0, 1.0e4, 20.0, 80.0
    amp = np.abs([10.0, -3.0]) / np.hypot(k - m * omega**2, c * omega)
    np.testing.assert_allclose(ds["steady_amplitude"], amp, rtol=1e-14)
    # the long-time envelope over one period equals the steady amplitude
    tt = np.linspace(50.0, 50.0 + 2 * np.pi / omega, 4001)
    x = model.response({"force": [10.0]}, tt)["displacement"].values[0]
    assert abs(x.max() - amp[0]) < 1e-6 * amp[0]


def test_bad_input(model):
    with pytest.raises(ValueError, match="'m'.*outside valid range"):
        model.response({"m": [1.0, -1.0]}, [0.0])
    with pytest.raises(ValueError, match="t: empty"):
        model.response({}, [])
    with pytest.raises(ValueError, match="unknown parameter.*'mass'"):
        model.response({"mass": [1.0]}, [0.0])
