"""Line sampling on problems with exact answers: exact lines, coverage over seeds, run counts.

Oracles written without the method: closed forms of the normal and chi-square laws (a half
space, two opposite half spaces, a parabola by one-dimensional quadrature, a cylinder's
exterior ``|P u| > r``), and a counter inside the model for the run count.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import integrate, stats

import gearuq
from gearuq.failure.modes import LimitState, SeriesSystem

DIM = 20
TALLY = {"runs": 0}


def _named(u: dict) -> np.ndarray:
    return np.column_stack([u[f"u{j}"] for j in range(DIM)])


def _space(dim: int = DIM) -> gearuq.ParameterSpace:
    return gearuq.ParameterSpace.normal(**{f"u{j}": (0.0, 1.0) for j in range(dim)})


# a unit vector with weight on four inputs, and a second one orthogonal to it
ALPHA = np.zeros(DIM)
ALPHA[[0, 3, 7, 11]] = [0.5, -0.5, 0.5, 0.5]
SECOND = np.zeros(DIM)
SECOND[[1, 3, 7, 12]] = [0.5, 0.5, 0.5, 0.5]


def _linear(**u):
    TALLY["runs"] += int(np.size(u["u0"]))
    return 3.5 - _named(u) @ ALPHA


def _two_sided(**u):
    s = _named(u) @ ALPHA
    return {"g1": 3.0 - s, "g2": 3.4 + s}


def _parabola(**u):
    a, b = _named(u) @ ALPHA, _named(u) @ SECOND
    return 4.0 - a - 0.05 * (b - 0.2) ** 2


CYLINDER_R = 3.2


def _cylinder(**u):
    x = _named(u)
    return CYLINDER_R - np.hypot(x @ ALPHA, x @ SECOND)


def _model(fn, outputs=("g",)) -> gearuq.FunctionModel:
    return gearuq.FunctionModel(fn, [f"u{j}" for j in range(DIM)], list(outputs),
                                name=fn.__name__.strip("_"))


def _run(fn, rng, outputs=("g",), limit_state="g", **settings):
    return gearuq.failure_probability(_model(fn, outputs), _space(), limit_state,
                                      method="line_sampling", rng=rng, executor="serial",
                                      **settings)


def _parabola_pf() -> float:
    """P(a >= 4 - 0.05 (b - 0.2)^2), a and b independent standard normals."""
    def density(b: float) -> float:
        return stats.norm.pdf(b) * stats.norm.sf(4.0 - 0.05 * (b - 0.2) ** 2)
    return integrate.quad(density, -12, 12, points=[0.2], limit=200, epsabs=1e-15)[0]


def test_exact_lines_bracket_the_half_space_and_count_every_run() -> None:
    TALLY["runs"] = 0
    rep = _run(_linear, 1, n_lines=40, direction=ALPHA)
    exact = stats.norm.sf(3.5)
    # every line crosses once at t = 3.5: the bracket readings hold the exact value
    assert float(rep["pf_lower"]) <= exact <= float(rep["pf_upper"])
    assert float(rep["pf"]) == pytest.approx(exact, rel=2e-3)
    assert int(rep["n_lines_by_crossings"].sel(crossings="1")) == 40
    assert int(rep["status"]) == 0
    assert int(rep["n_model_runs"]) == TALLY["runs"]
    assert float(np.std(rep["line_pf"])) < 1e-3 * exact


@pytest.mark.e2e
def test_runs_counted_with_form_direction_and_resume_from_store(tmp_path) -> None:
    TALLY["runs"] = 0
    rep = _run(_linear, 5, n_lines=30, direction="form", store=tmp_path)
    assert int(rep["n_model_runs"]) == TALLY["runs"] > 30 * 9
    assert abs(float(rep["direction"].values[0] @ ALPHA)) == pytest.approx(1.0, abs=1e-4)
    again = _run(_linear, 5, n_lines=30, direction="form", store=tmp_path)
    assert float(again["pf"]) == float(rep["pf"])


def test_two_sided_series_system_finds_both_crossings() -> None:
    system = SeriesSystem([LimitState.output("g1"), LimitState.output("g2")])
    rep = _run(_two_sided, 2, outputs=("g1", "g2"), limit_state=system, n_lines=30,
               direction=ALPHA)
    exact = stats.norm.sf(3.0) + stats.norm.sf(3.4)
    assert float(rep["pf_lower"]) <= exact <= float(rep["pf_upper"])
    assert float(rep["pf"]) == pytest.approx(exact, rel=2e-3)
    assert int(rep["n_lines_by_crossings"].sel(crossings="2")) == 30


@pytest.mark.e2e
@pytest.mark.parametrize("case", ["tilted half space", "parabola"])
def test_coverage_over_twenty_seeds(case: str) -> None:
    """Status-0 intervals of 100 lines hold the exact Pf in >= 18 of 20 seeds."""
    if case == "parabola":
        fn, exact, direction = _parabola, _parabola_pf(), ALPHA
    else:  # the line direction 12 degrees off the half space's normal
        angle = math.radians(12)
        fn, exact = _linear, stats.norm.sf(3.5)
        direction = math.cos(angle) * ALPHA + math.sin(angle) * SECOND
    held = ok = 0
    errors = []
    for seed in range(20):
        rep = _run(fn, 100 + seed, n_lines=100, direction=direction)
        if int(rep["status"]) == 0:
            ok += 1
            held += float(rep["pf_lower"]) <= exact <= float(rep["pf_upper"])
        errors.append((float(rep["pf"]) - exact) / (float(rep["cov_pf"]) * exact))
    assert ok >= 18 and held >= 18, (case, ok, held)
    # the reported CoV is the scatter's: standardised errors have unit spread and zero mean
    assert 0.6 < float(np.std(errors)) < 1.5, errors
    assert abs(float(np.mean(errors))) < 0.7, errors


def test_cylinder_exterior_radial_lines_are_exact() -> None:
    """|P u| > r in a 2-D subspace of 20 dims: Pf = exp(-r^2 / 2) (chi-square, 2 dof)."""
    exact = math.exp(-CYLINDER_R**2 / 2)
    rep = _run(_cylinder, 3, n_lines=40, direction=np.vstack([ALPHA, SECOND]))
    assert float(rep["pf_lower"]) <= exact <= float(rep["pf_upper"])
    assert float(rep["pf"]) == pytest.approx(exact, rel=3e-3)
    assert int(rep["n_lines_by_crossings"].sel(crossings="2")) == 40
    assert int(rep["status"]) == 0
    assert "radial" in rep.attrs["line_kind"]


def test_cylinder_subspace_found_by_the_gradient_probe() -> None:
    rep = _run(_cylinder, 4, n_lines=40, direction="gradient", subspace_dim=2, n_probe=3)
    basis = rep["direction"].values
    plane = np.vstack([ALPHA, SECOND])
    # the probe's plane is the cylinder's: projecting its rows on the plane keeps them whole
    assert np.linalg.norm(basis @ plane.T, axis=1) == pytest.approx([1.0, 1.0], abs=1e-3)
    assert float(rep["pf"]) == pytest.approx(math.exp(-CYLINDER_R**2 / 2), rel=3e-3)


def test_straight_lines_across_a_cylinder_are_flagged() -> None:
    """One direction in the cylinder's plane is unbiased but a few lines carry it: status 3
    (the per-line CoV is about 8 at r = 3.2)."""
    rep = _run(_cylinder, 6, n_lines=100, direction=ALPHA)
    assert int(rep["status"]) == 3
    assert float(rep["n_effective_lines"]) < 30
    assert "effective lines" in gearuq.describe_status(rep)


def test_no_failing_line_is_an_upper_bound() -> None:
    rep = _run(_linear, 7, n_lines=20, direction=ALPHA, c_max=3.0)
    assert int(rep["status"]) == 4 and int(rep["pf_is_upper_bound"]) == 1
    assert float(rep["pf"]) >= stats.norm.sf(3.0) >= stats.norm.sf(3.5)


def _corner(**u):
    """Fails where the line's coordinate s >= 2 and u1 >= 3: only origins with u1 >= 3
    (0.13 %) meet it; P = Phi(-2) Phi(-3) = 3.1e-5."""
    return np.maximum(2.0 - _named(u) @ ALPHA, 3.0 - u["u1"])


def test_lines_that_all_miss_do_not_exclude_a_failure_set() -> None:
    """20 lines along ALPHA, none of whose origins has u1 >= 3: no crossing, status 4, and
    pf_upper must still hold the true 3.1e-5 (the mass beyond c_max alone, about 1e-15,
    did not): 20 lines can all miss a set that 16 % of origins reach."""
    truth = stats.norm.sf(2.0) * stats.norm.sf(3.0)
    rep = _run(_corner, 9, n_lines=20, direction=ALPHA)
    assert int(rep["status"]) == 4 and int(rep["pf_is_upper_bound"]) == 1
    assert float(rep["pf_upper"]) >= truth
    assert float(rep["pf_upper"]) == pytest.approx(1.0 - 0.025 ** (1.0 / 20.0), rel=1e-9)
    assert "did not exclude one" in gearuq.describe_status(rep)


def test_more_than_two_crossings_are_flagged() -> None:
    def _bands(**u):
        s = _named(u) @ ALPHA
        return np.minimum(np.abs(s - 2.5) - 0.5, 3.5 + s)  # fails on [2, 3] and below -3.5

    rep = _run(_bands, 8, n_lines=20, direction=ALPHA, n_grid=16)
    exact = stats.norm.cdf(3.0) - stats.norm.cdf(2.0) + stats.norm.sf(3.5)
    assert int(rep["status"]) == 8
    assert int(rep["n_lines_by_crossings"].sel(crossings=">2")) == 20
    assert float(rep["pf"]) == pytest.approx(exact, rel=2e-3)


@pytest.mark.parametrize("bad, match", [
    ({"direction": np.ones(3)}, "20 numbers per row"),
    ({"direction": {"nope": 1.0}}, "unknown parameter"),
    ({"direction": "sideways"}, "'form', 'pilot' or 'gradient'"),
    ({"direction": "form", "subspace_dim": 2}, "subspace_dim"),
    ({"n_lines": 1}, "n_lines"),
])
def test_bad_settings_name_the_setting(bad: dict, match: str) -> None:
    with pytest.raises(ValueError, match=match):
        _run(_linear, 0, **bad)


def _cubic(**u):
    s = _named(u) @ ALPHA
    return 3.5 - s - 0.3 * (s - 3.5) ** 3  # decreasing, one root at 3.5: Pf = Phi(-3.5)


def test_unrefined_crossings_say_so_and_their_brackets_stay_in_the_interval() -> None:
    rep = _run(_cubic, 9, n_lines=20, direction=ALPHA, max_iter=1)
    exact = stats.norm.sf(3.5)
    assert int(rep["status"]) == 1
    assert "not bracketed to root_tol" in gearuq.describe_status(rep)
    assert float(rep["pf_lower"]) <= exact <= float(rep["pf_upper"])
    assert float(rep["pf_upper"]) - float(rep["pf_lower"]) > 0.05 * exact  # the brackets


def _nan_beyond(**u):
    s = _named(u) @ ALPHA
    return np.where(s > 4.5, np.nan, 3.5 - s)  # the model gives no answer deep in failure


def test_invalid_runs_read_both_ways() -> None:
    rep = _run(_nan_beyond, 10, n_lines=20, direction=ALPHA)
    exact = stats.norm.sf(3.5)
    assert int(rep["status"]) == 6 and int(rep["n_invalid"]) > 0
    # pf reads the unknown cells (t > 4) as safe: below the truth; the upper end covers it
    assert float(rep["pf"]) < exact <= float(rep["pf_upper"])
    assert float(rep["pf"]) == pytest.approx(stats.norm.cdf(4.0) - stats.norm.cdf(3.5),
                                             rel=2e-3)


def test_pilot_direction_points_to_the_failure_set() -> None:
    TALLY["runs"] = 0
    rep = _run(_linear, 11, n_lines=100, direction="pilot")
    cosine = float(rep["direction"].values[0] @ ALPHA)
    assert cosine > 0.7, cosine  # the mean of the worst pilot draws leans towards alpha
    assert int(rep["n_probe_runs"]) == 300
    assert int(rep["n_model_runs"]) == TALLY["runs"]
    exact = stats.norm.sf(3.5)
    assert float(rep["pf_lower"]) <= exact <= float(rep["pf_upper"])
    # 30 degrees off: a few lines carry the estimate, and the run says so
    assert (int(rep["status"]) == 3) == (float(rep["n_effective_lines"]) < 30)


def test_line_law_masses_against_closed_forms() -> None:
    """k = 1: the normal law; k = 2: |t| Rayleigh, P(|T| > r) = exp(-r^2 / 2); far tails
    keep their digits."""
    from gearuq.failure.methods.line_sampling import line_mass

    a = np.array([3.5, -np.inf, -1.0, -9.0, 20.0])
    b = np.array([np.inf, -3.5, 2.0, -8.0, np.inf])
    normal = [stats.norm.sf(3.5), stats.norm.sf(3.5), stats.norm.cdf(2) - stats.norm.cdf(-1),
              stats.norm.cdf(-8) - stats.norm.cdf(-9), stats.norm.sf(20)]
    assert line_mass(a, b, 1) == pytest.approx(normal, rel=1e-10)
    radial = line_mass(np.array([5.33, -np.inf, 30.0, -2.0]),
                       np.array([np.inf, -5.33, np.inf, 2.0]), 2)
    expected = [0.5 * math.exp(-5.33**2 / 2)] * 2 + [0.5 * math.exp(-450.0),
                                                     1 - math.exp(-2.0)]
    assert radial == pytest.approx(expected, rel=1e-10)


def test_a_failed_end_counts_its_tail_in_every_reading():
    """A line whose ends at -c_max and c_max both fail: the mass beyond them is failed in the
    estimate and in both readings, so ``low <= est <= high`` and the exact ``2 Phi(-0.5)``
    lies between them (the upper reading once left a failed end's tail out and fell below
    the estimate)."""
    from gearuq.failure.methods.line_sampling import _search_chunk

    class Straight:
        dim = 2

        def evaluate(self, u: np.ndarray, tag: str = "") -> dict[str, np.ndarray]:
            return {"g": 0.25 - u[:, 0] ** 2}  # fails for |t| > 0.5 along e_1

    s = {"c_max": 1.0, "n_grid": 5, "root_tol": 1e-6, "max_iter": 60}
    out = _search_chunk(Straight(), np.zeros((1, 2)), np.array([[1.0, 0.0]]), s, 1, "t")
    exact = 2.0 * stats.norm.sf(0.5)
    assert out["low"][0] <= out["est"][0] <= out["high"][0]
    # to rounding: the refined brackets' safe ends sit within root_tol of the roots
    assert out["low"][0] <= exact * (1 + 1e-12) and exact <= out["high"][0]
    assert out["est"][0] == pytest.approx(exact, rel=1e-6)
