"""Importance sampling that moves the input law in a few directions only, behind a gate.

A failure set may depend on many inputs yet be *reached* through a few: the geared rotor's
largest dynamic factor needs little damping, a light load and one or two tooth-to-tooth
pitch waves, while the other 55 pitch coordinates only modify it. A biasing density fitted
in all ``d`` dimensions estimates a mean and a covariance from a few hundred points, puts
noise of order ``sqrt(d / n)`` in every direction, and the log-weights' variance grows with
``d``: in 61 dimensions the mixture's weights degenerated (one draw carried 60 % of the
estimate). Here the density differs from the standard normal only in the span of ``k``
orthonormal columns ``B`` (``k`` of 3-6):

    h(u) = a phi_d(u) + (1 - a) N(u; B m, I + B (C - I_k) B^T),

so ``phi_d / h = 1 / (a + (1 - a) N_k(B^T u; m, C) / phi_k(B^T u))`` depends on the ``k``
coordinates ``B^T u`` alone and is bounded by ``1 / a`` (the defensive share, Hesterberg
1995): the estimator ``mean(1_F w)`` is a mean of bounded terms and its normal interval is a
plain central limit theorem. ``m`` and ``C`` come from multi-level cross-entropy steps
(Rubinstein and Kroese 2004) on a model, usually a cheap one: unbiasedness never depends on
how well they were fitted, only the variance does.

A **gate** is an event of the inputs known without the model (inspection's acceptance of a
gear's pitch, a function of its germ): draws outside it contribute zero and cost no model
run, and ``P(F | gate) = P(F and gate) / P(gate)`` with ``P(gate)`` counted on millions of
vectorised standard normal draws (:func:`gate_probability`), whose error is carried into the
interval. The input law conditioned on the gate is thus sampled exactly, whatever the
density does in the gated coordinates.

**Centred groups.** A failure set may depend on the *length* of a few coordinates only (an
amplitude, whatever its phase: the rotor's tooth-to-tooth pitch harmonics, each a (cos, sin)
plane of the germ): in that plane the failure set is an annulus, and a mean shift reaches one
phase of it (a missing-mode bias: the draws never see the others). Since the input law and
such a failure set are both invariant under rotations in the group, so is the ideal biasing
density, and the cross-entropy fit may be restricted to it: in each group of ``centred``
coordinates the moved component has mean 0 and covariance ``s I`` (its variance inflated
equally in every direction of the group, uncoupled from the others), ``s`` the weighted mean
square of the failing points' coordinates there. The weights keep their bound ``1 / a``.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np
from scipy import stats

from gearuq.failure.methods.importance import Mixture, weight_status, weighted_estimate

__all__ = ["subspace_density", "gated_batch", "fit_subspace_density", "subspace_estimate",
           "gate_probability", "given_gate"]

#: ``limit(u) -> (g, ok)``: the limit state (failure ``g <= 0``) and a validity mask of the
#: model runs, for standard normal draws ``u`` of shape ``(n, d)``.
Limit = Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]]
#: ``gate(u) -> bool mask``: the event known without the model.
Gate = Callable[[np.ndarray], np.ndarray]


def _check_basis(basis: np.ndarray) -> np.ndarray:
    basis = np.atleast_2d(np.asarray(basis, dtype=float))
    d, k = basis.shape
    if not 1 <= k <= d:
        raise ValueError(f"basis of shape {basis.shape} is outside its valid range: (d, k) "
                         "with 1 <= k <= d")
    if not np.allclose(basis.T @ basis, np.eye(k), atol=1e-8):
        raise ValueError("basis columns are not orthonormal; valid: B^T B = I_k")
    return basis


def subspace_density(basis: np.ndarray, mean: np.ndarray, cov: np.ndarray,
                     defensive: float) -> Mixture:
    """The defensive mixture that differs from the standard normal only in ``span(basis)``.

    Parameters
    ----------
    basis : ndarray (d, k)
        Orthonormal columns ``B``.
    mean : ndarray (k,) or (L, k)
        Mean ``m`` of the moved component in the coordinates ``B^T u`` (or of ``L``
        components of equal share).
    cov : ndarray (k, k) or (L, k, k)
        Its covariance ``C`` in those coordinates (symmetric positive definite).
    defensive : float
        Share ``a`` of the standard normal component, in (0, 1): every weight is at most
        ``1 / a``.

    Returns
    -------
    Mixture
    """
    basis = _check_basis(basis)
    d, k = basis.shape
    if not 0.0 < defensive < 1.0:
        raise ValueError(f"defensive={defensive!r} is outside its valid range (0, 1)")
    means = np.asarray(mean, dtype=float).reshape(-1, k)
    covs = np.asarray(cov, dtype=float).reshape(-1, k, k)
    full = np.eye(d)[None] + basis[None] @ (covs - np.eye(k)[None]) @ basis.T[None]
    return Mixture(means @ basis.T, full, np.ones(len(means)), defensive)


def gated_batch(limit: Limit, density: Mixture, n: int, seed: Any,
                gate: Gate | None = None) -> dict[str, np.ndarray]:
    """``n`` draws of ``density``, the model run on those inside the gate only.

    Returns the batch form of :func:`~gearuq.failure.methods.importance.weighted_estimate`
    (``u``, ``w = phi / h``, ``g`` (``+inf`` outside the gate, NaN where invalid), boolean
    ``fail``, ``invalid``, ``gap``) and ``runs``, the model runs made.
    """
    rng = np.random.default_rng(seed)
    u = density.sample(int(n), rng)
    inside = np.ones(len(u), bool) if gate is None else np.asarray(gate(u), bool)
    g = np.full(len(u), np.inf)
    ok = np.ones(len(u), bool)
    if inside.any():
        g_in, ok_in = limit(u[inside])
        g[inside] = np.where(ok_in, g_in, np.nan)
        ok[inside] = ok_in
    fail = ok & (g <= 0.0)
    return {"u": u, "w": np.exp(density.log_weights(u)), "g": g, "fail": fail,
            "invalid": ~ok, "gap": np.zeros(len(u), bool), "runs": np.int64(inside.sum())}


def _moments(v: np.ndarray, omega: np.ndarray, min_std: float,
             centred: tuple[tuple[int, ...], ...] = ()) -> tuple[np.ndarray, np.ndarray]:
    """Weighted mean and covariance of the projected points, shrunk towards ``I_k`` by
    ``k + 1`` pseudo-points and kept within ``[min_std^2, 3^2]`` in every direction; in each
    group of ``centred`` coordinates, mean 0 and covariance ``s I`` uncoupled from the rest
    (``s``: the weighted mean square there, pooled over the group's ``g`` coordinates, so
    shrunk towards 1 by 2 pseudo-points against ``g ess`` values: a full shrinkage would
    pull an inflated variance halfway back to 1 at every level of a dozen failing points,
    and cross-entropy would not progress)."""
    k = v.shape[1]
    total = omega.sum()
    ess = total**2 / np.sum(omega**2)
    mu = omega @ v / total
    lam = (k + 1.0) / (ess + k + 1.0)
    grouped = [i for group in centred for i in group]
    mu[grouped] = 0.0
    c = v - mu
    s = (c * omega[:, None]).T @ c / total
    s = (1.0 - lam) * s + lam * np.eye(k)
    for group in centred:
        idx = list(group)
        square = float(np.mean(np.sum(v[:, idx] ** 2, axis=1) * omega) / np.mean(omega))
        square /= len(idx)
        lam_g = 2.0 / (ess * len(idx) + 2.0)
        s[idx, :], s[:, idx] = 0.0, 0.0
        s[idx, idx] = (1.0 - lam_g) * square + lam_g
    val, vec = np.linalg.eigh(0.5 * (s + s.T))
    return mu, (vec * np.clip(val, min_std**2, 9.0)) @ vec.T


def _check_groups(centred: Any, k: int) -> tuple[tuple[int, ...], ...]:
    groups = tuple(tuple(int(i) for i in group) for group in (centred or ()))
    flat = [i for group in groups for i in group]
    if any(not 0 <= i < k for i in flat) or len(set(flat)) != len(flat) or not all(groups):
        raise ValueError(f"centred={centred!r} is outside its valid range: disjoint non-empty "
                         f"groups of column indices 0..{k - 1} of the basis")
    return groups


def fit_subspace_density(limit: Limit, basis: np.ndarray, *, n_per_level: int, seed: int,
                         gate: Gate | None = None, p0: float = 0.1, defensive: float = 0.1,
                         min_std: float = 0.3, max_levels: int = 12,
                         start: tuple[np.ndarray, np.ndarray] | None = None,
                         keep_levels: bool = False,
                         centred: Any = None) -> tuple[Mixture, dict[str, Any]]:
    """Multi-level cross-entropy in ``span(basis)``: the density that reaches ``g <= 0``.

    Level ``l`` draws ``n_per_level`` points of the current density, sets ``gamma_l`` to
    the ``p0`` quantile of ``g`` (at least 0), and refits ``(m, C)`` to the projections
    ``B^T u`` of the points with ``g <= gamma_l``, weighted by ``phi / h``; it stops once
    ``gamma_l = 0`` (the density was fitted to the failure set itself) or after
    ``max_levels``. The points are not used in any estimate.

    Parameters
    ----------
    limit, gate :
        The model's limit state on standard normal draws and the gate (module docstring).
    basis : ndarray (d, k)
        Orthonormal directions the density may move in.
    n_per_level : int
        Draws per level (>= 20).
    seed : int
        Level ``l`` draws from ``SeedSequence([seed, l])``.
    p0 : float
        Share of each level's draws that defines its threshold, in (0, 0.5).
    defensive : float
        Share of the standard normal in every density, in (0, 1).
    min_std : float
        Smallest standard deviation of the moved component in any direction of the subspace.
    max_levels : int
        Largest number of levels.
    start : (mean, cov), optional
        The first level's component (default: the standard normal).
    keep_levels : bool
        Return the mixture, in equal shares, of the components fitted at every level (the
        balance heuristic of multiple importance sampling, Veach and Guibas 1995; Owen and
        Zhou 2000) rather than the last one alone. The last level's component sits where
        the failing points of its level were; a failure set that also reaches towards the
        origin, where the input law has more mass, gets density from the earlier levels,
        and a failing draw there no longer carries a large weight. The weights stay bounded
        by ``1 / defensive`` and depend on ``B^T u`` only. Off by default: on the geared
        rotor's K_v it spread the draws over the levels and lowered the effective sample
        size (1.2 against 4.9 of the last level alone; docs/benchmarks.md).
    centred : sequence of sequences of int, optional
        Groups of columns of ``basis`` in which the moved component stays centred and
        isotropic (module docstring, "Centred groups"): for a failure set that depends on
        the length of those coordinates, not their direction.

    Returns
    -------
    (Mixture, dict)
        The density and ``{"levels": [gamma_l], "runs": model runs, "reached": gamma = 0,
        "mean", "cov": the last level's component}``.
    """
    basis = _check_basis(basis)
    k = basis.shape[1]
    groups = _check_groups(centred, k)
    if int(n_per_level) != n_per_level or n_per_level < 20:
        raise ValueError(f"n_per_level={n_per_level!r} is outside its valid range: integers "
                         ">= 20")
    if not 0.0 < p0 < 0.5:
        raise ValueError(f"p0={p0!r} is outside its valid range (0, 0.5)")
    mean, cov = start if start is not None else (np.zeros(k), np.eye(k))
    density = subspace_density(basis, mean, cov, defensive)
    levels, runs, reached, fitted = [], 0, False, []
    for level in range(int(max_levels)):
        bt = gated_batch(limit, density, n_per_level, np.random.SeedSequence([seed, level]),
                         gate)
        runs += int(bt["runs"])
        g = np.where(np.isnan(bt["g"]), np.inf, bt["g"])
        gamma = max(float(np.quantile(g, p0)), 0.0)
        if not math.isfinite(gamma):
            raise RuntimeError(f"cross-entropy level {level}: fewer than {p0:.0%} of the draws "
                               "passed the gate with a valid run; no level can be set")
        levels.append(gamma)
        omega = np.where(g <= gamma, bt["w"], 0.0)
        mean, cov = _moments(bt["u"] @ basis, omega, min_std, groups)
        fitted.append((mean, cov))
        density = subspace_density(basis, mean, cov, defensive)
        if gamma == 0.0:
            reached = True
            break
    if keep_levels and len(fitted) > 1:
        density = subspace_density(basis, np.array([m for m, _ in fitted]),
                                   np.array([c for _, c in fitted]), defensive)
    return density, {"levels": levels, "runs": runs, "reached": reached,
                     "mean": mean, "cov": cov}


def subspace_estimate(limit: Limit, density: Mixture, *, n: int, seed: int,
                      gate: Gate | None = None, batch: int = 250, confidence: float = 0.95,
                      target_cov: float = 0.2, min_ess: float = 0.0) -> dict[str, Any]:
    """``P(F and gate)`` from ``n`` fresh draws of ``density`` (batches of ``batch``).

    Returns the dict of :func:`~gearuq.failure.methods.importance.weighted_estimate`
    (``pf``, ``lower``, ``upper``, ``cov``, ``ess``, ``max_share``, ``pareto_k``, ...) with
    ``runs``, ``status`` and ``message`` (:func:`~gearuq.failure.methods.importance.
    weight_status`: 0 when the weights vouch for the interval, otherwise what they cannot
    vouch for, in words; 3 where it would be 0 or 1 with fewer than ``min_ess`` effective
    failing draws) and ``lower_one_sided``: ``(1 - confidence) pf``, a lower bound of
    ``P(F and gate)`` at ``confidence`` by Markov's inequality (the estimate is unbiased and
    non-negative, the density drawn afresh), which holds whatever the status says.
    """
    if int(n) != n or n < 2:
        raise ValueError(f"n={n!r} is outside its valid range: integers >= 2")
    batches, done, b = [], 0, 0
    while done < n:
        m = min(int(batch), int(n) - done)
        batches.append(gated_batch(limit, density, m, np.random.SeedSequence([seed, 7, b]),
                                   gate))
        done, b = done + m, b + 1
    z = float(stats.norm.isf((1.0 - confidence) / 2.0))
    est = weighted_estimate(batches, z)
    # the weights are bounded by 1 / defensive, so their variance is finite whatever the
    # Pareto shape of a few hundred of them says: only the effective sample size and the
    # largest share decide whether the central limit theorem has set in
    status, message, _, _, _, _ = weight_status(
        {**est, "capped": True, "pareto_k": math.nan}, target_cov,
        "the density does not reach the failure set")
    if status == 0 and est["n_invalid"]:
        status, message = 6, (f"{est['n_invalid']} of {est['n']} model runs were invalid: the "
                              "interval reads them as safe at its lower end, failed at its "
                              "upper end")
    if status in (0, 1) and est["ess"] < min_ess:
        status, message = 3, (f"{est['ess']:.1f} effective failing draws of {est['n_fail']}, "
                              f"fewer than min_ess = {min_ess:g}: a sum of so few heavy terms "
                              "understates its own variance, so the interval is not vouched "
                              "for")
    # Markov's inequality on an unbiased, non-negative estimate: P(pf_hat >= pf / alpha) <=
    # alpha, so alpha pf_hat is a lower bound at 1 - alpha that holds however poorly the
    # density fits (invalid runs read as safe: pf_hat then estimates P(F and valid) <= P(F))
    lower_one_sided = (1.0 - confidence) * est["pf"]
    return {**est, "runs": int(sum(int(bt["runs"]) for bt in batches)), "status": status,
            "message": message or "weights bounded: the interval holds by the central limit "
            "theorem on the failure set the density reaches (a failure region that neither "
            "its fit nor its defensive draws reached is seen by no weight diagnostic; "
            "lower_one_sided holds regardless)", "lower_one_sided": lower_one_sided}


def gate_probability(gate: Gate, dim: int, n: int = 2_000_000, seed: int = 0,
                     chunk: int = 250_000) -> tuple[float, float]:
    """``P(gate)`` under the standard normal and its standard error, counted on ``n`` draws."""
    if int(n) != n or n < 1000:
        raise ValueError(f"n={n!r} is outside its valid range: integers >= 1000")
    rng = np.random.default_rng(seed)
    hits, done = 0, 0
    while done < n:
        m = min(chunk, int(n) - done)
        hits += int(np.count_nonzero(gate(rng.standard_normal((m, int(dim))))))
        done += m
    p = hits / n
    return p, math.sqrt(p * (1.0 - p) / n)


def given_gate(est: dict[str, Any], p_gate: float, se_gate: float,
               confidence: float = 0.95) -> dict[str, float]:
    """``P(F | gate)`` from ``P(F and gate)`` and a counted ``P(gate)``.

    The interval divides the joint one's ends by ``P(gate)``'s upper and lower ends (at the
    same ``z``): it holds whenever both hold, the error of a count of millions adding about
    ``z se_gate / P(gate)`` relatively. ``lower_one_sided`` (Markov's bound of
    :func:`subspace_estimate`), where ``est`` has it, is divided likewise.
    """
    if not 0.0 < p_gate <= 1.0:
        raise ValueError(f"p_gate={p_gate!r} is outside its valid range (0, 1]")
    z = float(stats.norm.isf((1.0 - confidence) / 2.0))
    out = {"pf": est["pf"] / p_gate, "lower": est["lower"] / (p_gate + z * se_gate),
           "upper": est["upper"] / max(p_gate - z * se_gate, 1e-300),
           "cov": est["cov"], "p_gate": p_gate}
    if "lower_one_sided" in est:
        out["lower_one_sided"] = est["lower_one_sided"] / (p_gate + z * se_gate)
    return out
