"""A fixed step without error control is refused where the explicit method is unstable on
the model (a wrong response with status 0 otherwise), with the largest step it allows."""

from __future__ import annotations

import math

import numpy as np
import pytest

import gearuq
from gearuq._firstcall import kernels_route
from gearuq.ode.tableaux import largest_stable_step, stability_polynomial, step_amplification


@pytest.mark.parametrize("method", ["rk4", "dopri5", "dop853"])
def test_stability_polynomials_match_the_exponential_to_the_methods_order(method):
    order = {"rk4": 4, "dopri5": 5, "dop853": 8}[method]
    c = stability_polynomial(method)
    taylor = [1.0 / math.factorial(j) for j in range(order + 1)]
    np.testing.assert_allclose(c[:order + 1], taylor, rtol=1e-10)
    if method == "rk4":
        assert len(c) == 5  # R(z) is the exponential's Taylor polynomial of degree 4
    if method == "dopri5":  # Hairer, Norsett and Wanner: the z^6 coefficient is 1/600
        assert len(c) == 7 and c[6] == pytest.approx(1 / 600, rel=1e-10)


def test_stability_limits_against_their_closed_forms():
    # RK4 on the imaginary axis: |R(iy)|^2 = 1 - y^6/72 + y^8/576, so y = 2 sqrt(2)
    assert largest_stable_step("rk4", [1j]) == pytest.approx(2.0 * math.sqrt(2.0), rel=1e-8)
    # RK4 on the negative real axis: R(z) = 1 at the real root of 1 + z/2 + z^2/6 + z^3/24
    root = [r.real for r in np.roots(stability_polynomial("rk4")[::-1][:-1])
            if abs(r.imag) < 1e-9 and r.real < 0]
    assert largest_stable_step("rk4", [-1.0]) == pytest.approx(-max(root), rel=1e-8)
    # a scaled eigenvalue scales the step; none gives no limit
    assert largest_stable_step("dop853", [-10.0]) == pytest.approx(
        largest_stable_step("dop853", [-1.0]) / 10.0, rel=1e-8)
    assert largest_stable_step("dopri5", [0.0, 0.5]) == math.inf  # growing modes passed over
    h = largest_stable_step("dopri5", [-1.0 + 3.0j, -2.0])
    assert np.all(step_amplification("dopri5", h, [-1.0 + 3.0j, -2.0]) <= 1.0 + 1e-9)
    assert np.any(step_amplification("dopri5", 1.01 * h, [-1.0 + 3.0j, -2.0]) > 1.0)


def test_helical_pair_refuses_an_unstable_fixed_step_and_runs_a_stable_one():
    model = gearuq.get_model("helical_pair")
    tau = np.linspace(0.0, 20.0, 21)
    with pytest.raises(ValueError, match=r"fixed_step=100 is outside its valid range "
                                         r"\(0, [0-9.]+\] for these samples: rk4's step"):
        model.response({}, tau, outputs=["v1"], method="rk4", fixed_step=100.0)
    with pytest.raises(ValueError) as refused:
        model.response({}, tau, outputs=["v1"], fixed_step=100.0)  # DOP853
    allowed = float(str(refused.value).split("(0, ")[1].split("]")[0])
    assert 4.0 < allowed < 7.0  # the pair's fastest mode near 1.2 in tau, DOP853's 6.4 / 5.96
    with kernels_route("interpreted"):  # one sample, 40 steps: no compile needed
        fixed = model.response({}, tau, outputs=["v1"], fixed_step=0.5)
        adaptive = model.response({}, tau, outputs=["v1"])
    assert int(fixed["status"][0]) == 0
    np.testing.assert_allclose(fixed["v1"].values, adaptive["v1"].values, atol=1e-4)
