"""The von Mises-Fisher-Nakagami biasing density and multi-fidelity importance sampling with
cross-entropy exploration: a proper density, and intervals that hold on a shell-like failure
set with a known Pf ~ 1e-6 in 20 and 60 dimensions."""

from __future__ import annotations

import functools
import math

import numpy as np
import pytest
from scipy import special, stats

import gearuq
from gearuq.failure.api import failure_probability
from gearuq.failure.methods.vmfn import VMFNMixture, fit_vmfn, sample_vmf


def _random_mixture(r: int, d: int, rng: np.random.Generator) -> VMFNMixture:
    mu = rng.standard_normal((2, r))
    mu /= np.linalg.norm(mu, axis=1, keepdims=True)
    basis = np.linalg.qr(rng.standard_normal((d, r)))[0]
    return VMFNMixture(mu, np.array([2.0, 0.5]), np.array([1.5, 3.0]), np.array([4.0, 9.0]),
                       np.array([0.3, 0.7]), 0.1, basis)


@pytest.mark.e2e
@pytest.mark.parametrize(("r", "d"), [(1, 3), (2, 5), (3, 3), (7, 10)])
def test_the_weights_of_its_own_draws_average_one(r, d):
    """``E_h[phi / h] = 1`` holds only if sampler and density agree and both are normalised
    (the vMF constant, the Nakagami density, the 1 / R^(r-1) Jacobian, the complement)."""
    rng = np.random.default_rng(r * 10 + d)
    mix = _random_mixture(r, d, rng)
    w = np.exp(mix.log_weights(mix.sample(200_000, rng)))
    assert abs(w.mean() - 1.0) <= 4.0 * w.std() / math.sqrt(w.size)
    assert w.max() <= 1.0 / mix.defensive + 1e-9  # the defensive bound


@pytest.mark.parametrize(("r", "kappa"), [(3, 2.0), (10, 25.0), (2, 0.7)])
def test_vmf_draws_have_the_mean_resultant_of_the_density(r, kappa):
    """``E[a . mu] = I_{r/2}(kappa) / I_{r/2-1}(kappa)`` for the von Mises-Fisher density."""
    rng = np.random.default_rng(5)
    mu = np.zeros(r)
    mu[0] = 1.0
    a = sample_vmf(mu, kappa, 100_000, rng)
    assert np.allclose(np.linalg.norm(a, axis=1), 1.0)
    exact = special.ive(r / 2.0, kappa) / special.ive(r / 2.0 - 1.0, kappa)
    proj = a @ mu
    assert abs(proj.mean() - exact) <= 4.0 * proj.std() / math.sqrt(proj.size)


def test_uniform_directions_give_no_concentration():
    """Directions with no preferred mean (a shell) are fitted as uniform (``kappa`` near 0),
    not with the ``r / sqrt(n)`` a plain maximum-likelihood estimate gets from noise."""
    rng = np.random.default_rng(2)
    d = 40
    g = rng.standard_normal((300, d))
    u = 10.0 * g / np.linalg.norm(g, axis=1, keepdims=True)
    mix = fit_vmfn(u, None, np.eye(d), 0.05, 1, 0)
    assert mix.n_components == 1
    assert float(mix.kappa[0]) < 0.5 * d / math.sqrt(300)


def _shell(*, c: float, **x: np.ndarray) -> np.ndarray:
    return c - sum(np.asarray(v, dtype=float) ** 2 for v in x.values())


def _shell_problem(d: int, lf_factor: float):
    c = float(stats.chi2.isf(1e-6, d))
    names = [f"x{i}" for i in range(d)]
    hf = gearuq.FunctionModel(functools.partial(_shell, c=c), names, ["g"], name="shell")
    lf = gearuq.FunctionModel(functools.partial(_shell, c=lf_factor * c), names, ["g"],
                              name="shell_lf")
    space = gearuq.ParameterSpace.normal(**{n: (0.0, 1.0) for n in names})
    return hf, lf, space


@pytest.mark.e2e  # 20 seeds x 3 cases of a full MFIS run each: coverage, not a unit check
@pytest.mark.parametrize(("d", "lf_factor"), [(20, 0.95), (60, 0.95), (60, 1.05)])
def test_shell_intervals_hold_over_twenty_seeds(d, lf_factor):
    """``P(|u|^2 >= chi2_d^-1(1 - 1e-6)) = 1e-6`` exactly; the cheap model's shell is 5 %
    too small or too large in ``|u|^2``. Over 20 seeds: at least 17 of the 95 % intervals hold
    the exact value (16 or fewer happens with probability 1.6 % at the nominal level), the
    mean is within 3 standard errors, and each run needs at most 1000 expensive runs (crude
    Monte Carlo: 1e8 for a 10 % CoV)."""
    hf, lf, space = _shell_problem(d, lf_factor)
    reps = [failure_probability(hf, space, "g", method="mfis", low_fidelity=lf, rng=seed,
                                executor="serial", biasing="vmfn", explore="ce",
                                subspace="full", n_per_level=500, lf_refine=1, n_refine=500,
                                n_samples=200, max_samples=1000, target_cov=0.1,
                                defensive=0.05) for seed in range(20)]
    pf = np.array([float(r["pf"]) for r in reps])
    holds = [float(r["pf_lower"]) <= 1e-6 <= float(r["pf_upper"]) for r in reps]
    assert sum(holds) >= 17, (holds, pf)
    assert abs(pf.mean() - 1e-6) <= 3.0 * pf.std(ddof=1) / math.sqrt(pf.size)
    for r in reps:
        assert int(r["n_model_runs"]) <= 1000
        assert int(r["n_low_fidelity_runs"]) > 0
        assert np.isfinite(float(r["pf_low_fidelity_is"]))


def test_cross_entropy_exploration_needs_the_vmfn_family():
    hf, lf, space = _shell_problem(4, 1.0)
    with pytest.raises(ValueError, match="explore: 'ce' needs biasing='vmfn'"):
        failure_probability(hf, space, "g", method="mfis", low_fidelity=lf, explore="ce")
    with pytest.raises(ValueError, match="biasing"):
        failure_probability(hf, space, "g", method="mfis", low_fidelity=lf, biasing="nope")


# --------------------------------------------------------------- quadratic tilting
from gearuq.failure.methods.quadratic import fit_quadratic, tilted_gaussian  # noqa: E402

#: Eigenvalues of the ellipsoidal shell: a few dominant directions (as the rotor's pitch
#: germ, whose failing samples' second moment has eigenvalues 26, 8, 6, 5, 3.9, ...) and 50
#: minor ones.
_LAM = np.r_[[26.0, 8.0, 6.0, 5.0, 3.9, 3.9, 3.1, 2.8, 2.0, 1.9], np.full(50, 0.5)]
_C = 680.0


def _ellipsoid(**x: np.ndarray) -> np.ndarray:
    return _C - sum(lam * np.asarray(x[f"x{i}"], dtype=float) ** 2
                    for i, lam in enumerate(_LAM))


def _ellipsoid_pf(n: int = 400_000) -> float:
    """``P(sum lam_i u_i^2 >= C)``: the 50 equal minor terms are ``0.5 chi2_50`` exactly
    (scipy), the 10 dominant ones integrated by importance sampling (CoV about 0.5 %)."""
    rng = np.random.default_rng(0)
    lam = _LAM[:10]
    s = np.sqrt(np.maximum(lam / 3.0, 1.0))
    z = rng.standard_normal((n, 10)) * s
    log_w = -0.5 * np.sum(z**2, axis=1) + 0.5 * np.sum((z / s) ** 2, axis=1) + np.log(s).sum()
    rest = _C - np.sum(lam * z**2, axis=1)
    p = np.where(rest <= 0, 1.0, stats.chi2.sf(np.maximum(rest, 0.0) / 0.5, 50))
    return float(np.mean(p * np.exp(log_w)))


def test_quadratic_fit_and_tilt_recover_the_form_and_the_saddle_point():
    rng = np.random.default_rng(1)
    d = 6
    a = rng.standard_normal((d, d))
    a = a @ a.T / d
    b = rng.standard_normal(d)
    u = 1.5 * rng.standard_normal((400, d))
    q = np.einsum("ni,ij,nj->n", u, a, u) + u @ b + 0.7
    a_fit, b_fit, c0, r2 = fit_quadratic(u, q, ridge=0.0)
    assert np.allclose(a_fit, a, atol=1e-8) and np.allclose(b_fit, b, atol=1e-8)
    assert c0 == pytest.approx(0.7) and r2 == pytest.approx(1.0)
    mu, sigma, t = tilted_gaussian(a, b, 0.7, 40.0)
    # the tilted Gaussian is N((I - 2tA)^-1 t b, (I - 2tA)^-1) and puts E[Q] on the level
    assert np.allclose(np.linalg.inv(sigma), np.eye(d) - 2 * t * a)
    assert np.allclose(mu, t * sigma @ b)
    assert np.trace(a @ sigma) + mu @ a @ mu + b @ mu + 0.7 == pytest.approx(40.0, rel=1e-6)


@pytest.mark.slow
def test_tilted_gaussian_holds_an_ellipsoidal_shell_at_1e_6_in_60_dimensions():
    """The shell ``sum lam_i u_i^2 >= C`` with unequal ``lam`` (Pf 1.19e-6): the
    von Mises-Fisher-Nakagami family fails here in 60 dimensions (measured: degenerate
    weights), the tilted Gaussian of the fitted quadratic does not. Over 20 seeds with a
    cheap model whose shell is 5 % too small: at least 17 of the 95 % intervals hold the
    reference, the mean is within 3 standard errors, no run has heavy-tailed weights."""
    ref = _ellipsoid_pf()
    names = [f"x{i}" for i in range(60)]
    hf = gearuq.FunctionModel(_ellipsoid, names, ["g"], name="ellipsoid")
    lf = gearuq.FunctionModel(lambda **x: _ellipsoid(**x) - 0.05 * _C, names, ["g"],
                              name="ellipsoid_lf")
    space = gearuq.ParameterSpace.normal(**{n: (0.0, 1.0) for n in names})
    reps = [failure_probability(hf, space, "g", method="mfis", low_fidelity=lf, rng=seed,
                                executor="serial", biasing="quadratic", n_fit=2400,
                                n_samples=250, max_samples=1000, target_cov=0.15,
                                defensive=0.05) for seed in range(20)]
    pf = np.array([float(r["pf"]) for r in reps])
    holds = [float(r["pf_lower"]) <= ref <= float(r["pf_upper"]) for r in reps]
    assert sum(holds) >= 17, (holds, pf / ref)
    assert abs(pf.mean() - ref) <= 3.0 * pf.std(ddof=1) / math.sqrt(pf.size)
    for r in reps:
        assert float(r["pareto_k"]) < 0.7
        assert int(r["n_model_runs"]) <= 1000
        assert float(r.attrs["quadratic_fit_r2"]) > 0.999
