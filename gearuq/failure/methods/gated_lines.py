"""Line sampling behind a gate: ``P(F and gate)`` with no importance weight along the lines.

The line sampling of :mod:`gearuq.failure.methods.line_sampling` (Koutsourelakis,
Pradlwarter and Schueller, Probabilistic Engineering Mechanics 19 (2004) 409-417), radial in
a ``k``-dimensional subspace (``k`` orthonormal columns ``B``), for a failure set reached
through that subspace and an event known without the model (a **gate**: inspection's
acceptance of a gear pair's pitch, a function of its germ). A line goes through the standard
normal point ``u`` with its component in the subspace removed, along a unit direction ``e``
uniform in the subspace, ``u(t) = (I - B B^T) u + t e``, ``|t|`` chi with ``k`` degrees of
freedom and either sign, so that ``u(t)`` has the standard normal law. Each line's
probability

    p_i = mass of {t : g(u(t)) <= 0 and gate(u(t))}

is an unbiased estimate of ``P(F and gate)`` whatever the subspace, the lines are i.i.d. and
the interval is the normal one of their mean, as in line sampling; no term carries a weight,
so no density can put a few draws in charge of the estimate. A subspace that serves the
failure set poorly shows as a large spread of the ``p_i`` (the effective number of lines
``(sum p)^2 / sum p^2``, status 3 below :data:`~gearuq.failure.methods.line_sampling.
MIN_EFFECTIVE_LINES`), never as a bias.

The gate is exact along each line at the cost of vectorised gate calls only: it is evaluated
on ``gate_points`` points over ``[-c_max, c_max]`` and each change of its verdict is bisected
to ``1e-9``; the model runs only on the accepted pieces (a line whose accepted set is empty
costs no run). On each piece the limit state is evaluated at the piece's ends and the points
of ``t_grid`` inside it; a cell whose ends differ in failure state holds a crossing refined to
``root_tol`` by the safeguarded secant of line sampling, all lines of a chunk in lockstep.
Beyond ``c_max`` a line keeps the failure state of its end (the gate is not looked at there);
the interval's upper end counts that tail as failed whenever the end is safe. What the grids
cannot see (two crossings, or two changes of the gate, inside one cell) is not looked for;
lines with more than two crossings are counted and flagged (status 8).

**Directions drawn towards the failure set.** Where the failure set is reached through a
narrow cone of directions (the rotor's K_v: a light load together with large pitch
amplitudes), uniform directions leave a few lines carrying the estimate: the line's
probability is a chi tail at its crossing, which moves by a factor of about 50 for a 10 %
change of the crossing near ``t = 7``. ``direction_means`` (``L`` vectors ``m_l`` of the
subspace's coordinates) draws each line's axis from the defensive mixture

    h(e) = a U(e) + (1 - a) / (2L) sum_l [PN(e; m_l) + PN(-e; m_l)]

(``U`` uniform on the unit sphere, ``PN(.; m)`` the projected normal: the law of ``w / |w|``
for ``w ~ N(m, I_k)``, symmetrised since a line covers ``e`` and ``-e``), and the estimate
is the mean of ``w_i p_i`` with ``w_i = U(e_i) / h(e_i) <= 1 / a``: unbiased whatever the
means, the interval the normal one of i.i.d. bounded terms, the effective number of lines
computed on the ``w_i p_i``. ``PN(e; m) = (2 pi)^(-k/2) exp(-|m|^2 / 2) I_k(e . m)`` with
``I_k(b) = int_0^inf r^(k-1) exp(-r^2 / 2 + b r) dr``, summed on a fine grid in ``r``
(:func:`projected_normal_logpdf`; equal to ``Gamma(k) exp(b^2 / 4) D_-k(-b)``, a parabolic
cylinder function, to 1e-12 in the tests).

**Origins drawn where the rest of the failure set lives.** Where the inputs outside the
subspace decide how far a line must go (a light load and low damping shorten every line of
the pitch harmonic), ``origin_density`` draws each line's origin from a defensive mixture
that moves only coordinates orthogonal to the subspace
(:func:`~gearuq.failure.methods.subspace.subspace_density` on such columns): the origin's
weight ``phi / h`` depends on those coordinates alone, is at most ``1 / a``, and multiplies
the line's term, so the mean stays unbiased and the terms bounded.

Invalid runs (NaN) make their cells unknown: ``pf`` reads them as safe, the interval's upper
end as failed (status 6). ``P(F | gate) = P(F and gate) / P(gate)`` with ``P(gate)`` counted
(:func:`~gearuq.failure.methods.subspace.gate_probability`,
:func:`~gearuq.failure.methods.subspace.given_gate`).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np
from scipy import special

from gearuq.failure.methods.line_sampling import (
    MIN_EFFECTIVE_LINES,
    _lines,
    _reasons,
    _refine,
    line_estimate,
    line_mass,
    no_crossing_upper,
)

__all__ = ["gated_line_sampling", "gate_pieces", "projected_normal_logpdf"]

#: ``limit(u) -> (g, ok)`` of :mod:`gearuq.failure.methods.subspace`.
Limit = Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]]
#: ``gate(u) -> bool mask`` of :mod:`gearuq.failure.methods.subspace`.
Gate = Callable[[np.ndarray], np.ndarray]


class _Runs:
    """The limit as :func:`~gearuq.failure.methods.line_sampling._refine` calls it
    (``evaluate(u, tag)["g"]``, NaN where invalid), counting the model runs."""

    def __init__(self, limit: Limit) -> None:
        self.limit, self.n_runs = limit, 0

    def evaluate(self, u: np.ndarray, tag: str = "") -> dict[str, np.ndarray]:
        if len(u) == 0:
            return {"g": np.zeros(0)}
        g, ok = self.limit(u)
        self.n_runs += len(u)
        return {"g": np.where(np.asarray(ok, bool), np.asarray(g, float), np.nan)}


def gate_pieces(gate: Gate | None, origins: np.ndarray, dirs: np.ndarray, c_max: float,
                gate_points: int = 401) -> list[list[tuple[float, float]]]:
    """The accepted pieces ``[(a, b), ...]`` of each line within ``[-c_max, c_max]``.

    The gate on ``gate_points`` points of each line, each change of its verdict bisected to
    1e-9 (60 vectorised gate calls, whatever the number of lines).
    """
    n = len(origins)
    if gate is None:
        return [[(-c_max, c_max)] for _ in range(n)]
    ts = np.linspace(-c_max, c_max, int(gate_points))
    pts = origins[:, None, :] + ts[None, :, None] * dirs[:, None, :]
    inside = np.asarray(gate(pts.reshape(-1, origins.shape[1])), bool).reshape(n, ts.size)
    line, cell = np.nonzero(inside[:, :-1] != inside[:, 1:])
    lo, hi = ts[cell], ts[cell + 1]
    lo_in = inside[line, cell]
    for _ in range(60):
        if line.size == 0 or np.max(hi - lo) <= 1e-9:
            break
        mid = 0.5 * (lo + hi)
        same = np.asarray(gate(origins[line] + mid[:, None] * dirs[line]), bool) == lo_in
        lo, hi = np.where(same, mid, lo), np.where(same, hi, mid)
    edges = 0.5 * (lo + hi)
    pieces: list[list[tuple[float, float]]] = [[] for _ in range(n)]
    for i in range(n):
        own = edges[line == i]
        bounds = np.concatenate([[-c_max], own, [c_max]])
        # pieces alternate between the verdicts; the first has the verdict at -c_max
        for j in range(int(not inside[i, 0]), bounds.size - 1, 2):
            if bounds[j + 1] > bounds[j]:
                pieces[i].append((float(bounds[j]), float(bounds[j + 1])))
    return pieces


def _line_points(pieces: list[list[tuple[float, float]]], t_grid: np.ndarray
                 ) -> list[list[np.ndarray]]:
    """Per line and piece, the piece's ends and the grid points inside it, in order."""
    return [[np.unique(np.concatenate([[a, b], t_grid[(t_grid > a) & (t_grid < b)]]))
             for a, b in line] for line in pieces]


def _search(runs: _Runs, origins: np.ndarray, dirs: np.ndarray,
            pieces: list[list[tuple[float, float]]], s: dict[str, Any], k: int
            ) -> dict[str, np.ndarray]:
    """Each line's probability of failure inside its accepted pieces, with its readings."""
    n, c_max = len(origins), s["c_max"]
    points = _line_points(pieces, s["t_grid"])
    owner = np.concatenate([np.full(p.size, i) for i, line in enumerate(points) for p in line]
                           + [np.zeros(0, int)]).astype(int)
    ts = np.concatenate([p for line in points for p in line] + [np.zeros(0)])
    g_all = runs.evaluate(origins[owner] + ts[:, None] * dirs[owner], "grid")["g"]
    est, low, high = np.zeros(n), np.zeros(n), np.zeros(n)
    crossings, invalid = np.zeros(n, int), np.zeros(n, bool)
    cells: list[tuple[int, float, float, float, float]] = []
    tail = float(line_mass(np.array(c_max), np.array(np.inf), k))
    at = 0
    for i, line in enumerate(points):
        for p in line:
            g = g_all[at:at + p.size]
            at += p.size
            valid, fail = np.isfinite(g), g <= 0
            mass = line_mass(p[:-1], p[1:], k)
            both = valid[:-1] & valid[1:]
            whole = float(np.sum(mass[both & fail[:-1] & fail[1:]]))
            est[i] += whole
            low[i] += whole
            high[i] += whole + float(np.sum(mass[~both]))
            invalid[i] |= not valid.all()
            for j in np.flatnonzero(both & (fail[:-1] != fail[1:])):
                cells.append((i, p[j], p[j + 1], g[j], g[j + 1]))
            for end in (0, -1):  # the tail beyond +-c_max keeps the end's state
                if abs(p[end]) >= c_max:
                    failed = bool(valid[end] and fail[end])
                    est[i] += tail if failed else 0.0
                    low[i] += tail if failed else 0.0
                    high[i] += tail
    unconverged = np.zeros(n, int)
    if cells:
        line, a, b, ga, gb = (np.array(c) for c in zip(*cells, strict=True))
        line = line.astype(int)
        crossings += np.bincount(line, minlength=n)
        r = _refine(runs, origins[line], dirs[line], a, b, ga, gb, s, "root")
        left_fails = ga <= 0

        def failing_part(x: np.ndarray) -> np.ndarray:
            return np.where(left_fails, line_mass(a, x, k), line_mass(x, b, k))

        np.add.at(est, line, failing_part(r["root"]))
        np.add.at(low, line, failing_part(np.where(left_fails, r["lo"], r["hi"])))
        np.add.at(high, line, failing_part(np.where(left_fails, r["hi"], r["lo"])))
        np.add.at(unconverged, line, (~r["converged"]).astype(int))
    return {"est": est, "low": low, "high": high, "n_crossings": crossings,
            "n_unconverged": unconverged, "any_invalid": invalid,
            "n_pieces": np.array([len(line) for line in pieces])}


def projected_normal_logpdf(e: np.ndarray, mean: np.ndarray) -> np.ndarray:
    """Log density on the unit sphere of ``w / |w|``, ``w ~ N(mean, I_k)``, at unit ``e``.

    Parameters
    ----------
    e : ndarray (n, k)
        Unit vectors.
    mean : ndarray (k,)
        Mean of the normal that is projected (0: the uniform law on the sphere).

    Returns
    -------
    ndarray (n,)
        ``log PN(e; mean)`` with respect to the sphere's surface measure.
    """
    e, mean = np.atleast_2d(np.asarray(e, float)), np.asarray(mean, float)
    k = e.shape[1]
    # the integrand r^(k-1) exp(-r^2/2 + b r) peaks at r* = (b + sqrt(b^2 + 4(k-1))) / 2 with
    # a width below 1; a 4001-point trapezoid over [0, r* + 14] vanishes at both ends, so it
    # is accurate to rounding (the smooth integrand's error falls faster than any power);
    # 1000 directions at a time keep the grid to 32 MB
    out = np.empty(len(e))
    for start in range(0, len(e), 1000):
        b = e[start:start + 1000] @ mean
        peak = 0.5 * (b + np.sqrt(b * b + 4.0 * (k - 1)))
        r = np.linspace(0.0, 1.0, 4001)[None, :] * (peak + 14.0)[:, None]
        with np.errstate(divide="ignore"):
            log_f = (k - 1) * np.log(r) - 0.5 * r * r + b[:, None] * r
        top = np.max(log_f, axis=1, keepdims=True)
        f = np.exp(log_f - top)
        step = r[:, 1] - r[:, 0]
        out[start:start + 1000] = top[:, 0] + np.log(
            step * (np.sum(f, axis=1) - 0.5 * (f[:, 0] + f[:, -1])))
    return -0.5 * k * np.log(2.0 * np.pi) - 0.5 * float(mean @ mean) + out


def _uniform_logpdf(k: int) -> float:
    """Log density of the uniform law on the unit sphere of R^k: Gamma(k/2) / (2 pi^(k/2))."""
    return float(special.gammaln(0.5 * k) - math.log(2.0) - 0.5 * k * math.log(math.pi))


def _axes(means: np.ndarray | None, defensive: float, n: int, k: int,
          rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """Unit directions in the subspace's coordinates and their weights ``U / h`` (1 if
    ``means`` is None: uniform directions)."""
    if means is None:
        w = rng.standard_normal((n, k))
        return w / np.linalg.norm(w, axis=1, keepdims=True), np.ones(n)
    pick = rng.integers(0, len(means), n)
    moved = rng.random(n) >= defensive
    w = rng.standard_normal((n, k)) + np.where(moved[:, None], means[pick], 0.0)
    e = w / np.linalg.norm(w, axis=1, keepdims=True)
    log_u = _uniform_logpdf(k)
    pn = np.mean([np.exp(projected_normal_logpdf(s * e, m) - log_u)
                  for m in means for s in (1.0, -1.0)], axis=0)
    return e, 1.0 / (defensive + (1.0 - defensive) * pn)


def gated_line_sampling(limit: Limit, basis: np.ndarray, *, n_lines: int, seed: int,
                        gate: Gate | None = None, t_grid: np.ndarray | None = None,
                        gate_points: int = 401, root_tol: float = 1e-3, max_iter: int = 40,
                        chunk_lines: int = 50, confidence: float = 0.95,
                        direction_means: np.ndarray | None = None,
                        direction_defensive: float = 0.3,
                        origin_density: Any = None) -> dict[str, Any]:
    """``P(F and gate)`` by radial line sampling in ``span(basis)`` behind a gate.

    Parameters
    ----------
    limit : callable
        ``limit(u) -> (g, ok)`` on standard normal draws ``u`` ``(n, d)``; failure ``g <= 0``.
    basis : ndarray (d, k)
        Orthonormal columns of the subspace the lines run in (``k >= 1``; ``k = 1``: the
        classic straight lines, ``t`` standard normal).
    n_lines : int
        Independent lines (at least 2).
    seed : int
        Seed; chunk ``c`` draws from ``SeedSequence([seed, 43, c])``.
    gate : callable, optional
        ``gate(u) -> bool``, known without the model; default: no gate.
    t_grid : ndarray, optional
        Points along a line where the limit state is evaluated (inside the accepted
        pieces); ``c_max = max |t_grid|``. Default ``linspace(-8, 8, 9)``.
    gate_points : int
        Points per line where the gate is looked at before its changes are bisected.
    root_tol, max_iter : float, int
        Width of a crossing's final bracket and the refinement's steps.
    chunk_lines : int
        Lines searched together (one model design per step).
    confidence : float
        Two-sided level of the normal interval of the mean.
    direction_means : ndarray (L, k), optional
        Means of the projected normals the line directions are drawn from (in the
        subspace's coordinates, the columns of ``basis``); default: uniform directions.
    direction_defensive : float
        Share ``a`` of uniform directions in that mixture, in (0, 1): every line's weight
        is at most ``1 / a``.
    origin_density : Mixture, optional
        Density the lines' origins are drawn from (:class:`~gearuq.failure.methods.
        importance.Mixture` with a defensive share, e.g. of
        :func:`~gearuq.failure.methods.subspace.subspace_density`), differing from the
        standard normal only orthogonally to ``basis``; default: the standard normal.

    Returns
    -------
    dict
        ``pf``, ``lower``, ``upper`` (of ``P(F and gate)``), ``se``, ``cov``,
        ``n_effective``, ``status`` (0: the interval is vouched for; else the first reason's
        code), ``message``, ``runs``, ``n_lines``, ``lines_gated_out`` (lines with no
        accepted point: no run), ``lines_by_crossings`` (0, 1, 2, more), ``max_weight``, and
        the per-line arrays ``line_pf``, ``line_pf_lower``, ``line_pf_upper`` (each line's
        probability, unweighted), ``line_weight`` and ``line_crossings``.

    Raises
    ------
    ValueError
        A basis that is not orthonormal columns, or a setting outside its range.
    """
    basis = np.atleast_2d(np.asarray(basis, dtype=float))
    d, k = basis.shape
    if not 1 <= k <= d or not np.allclose(basis.T @ basis, np.eye(k), atol=1e-8):
        raise ValueError(f"basis of shape {basis.shape} is outside its valid range: (d, k) "
                         "orthonormal columns, 1 <= k <= d")
    t_grid = np.linspace(-8.0, 8.0, 9) if t_grid is None else np.asarray(t_grid, float)
    for name, value, ok, valid in (
            ("n_lines", n_lines, int(n_lines) == n_lines and n_lines >= 2, "integers >= 2"),
            ("t_grid", t_grid, t_grid.ndim == 1 and t_grid.size >= 2
             and bool(np.all(np.isfinite(t_grid))) and np.ptp(t_grid) > 0,
             "a finite 1-D array of at least 2 distinct points"),
            ("gate_points", gate_points, int(gate_points) == gate_points and gate_points >= 3,
             "integers >= 3"),
            ("root_tol", root_tol, 0 < root_tol <= 1, "(0, 1]"),
            ("chunk_lines", chunk_lines, int(chunk_lines) == chunk_lines and chunk_lines >= 1,
             "integers >= 1"),
            ("confidence", confidence, 0 < confidence < 1, "(0, 1)"),
            ("direction_defensive", direction_defensive, 0 < direction_defensive < 1,
             "(0, 1)")):
        if not ok:
            raise ValueError(f"{name}={value!r} is outside its valid range: {valid}")
    means = None
    if direction_means is not None:
        means = np.atleast_2d(np.asarray(direction_means, dtype=float))
        if means.shape[1] != k or not np.all(np.isfinite(means)):
            raise ValueError(f"direction_means of shape {means.shape} is outside its valid "
                             f"range: finite (L, {k}) means in the subspace's coordinates")
    if origin_density is not None and not (
            np.allclose(origin_density.means @ basis, 0.0, atol=1e-10)
            and np.allclose((origin_density.covs - np.eye(d)) @ basis, 0.0, atol=1e-10)
            and origin_density.defensive > 0):
        raise ValueError("origin_density is outside its valid range: a defensive mixture "
                         "that moves only coordinates orthogonal to basis (its weight must "
                         "not depend on the line's coordinate)")
    c_max = float(np.max(np.abs(t_grid)))
    s = {"c_max": c_max, "t_grid": np.unique(np.clip(t_grid, -c_max, c_max)),
         "n_grid": t_grid.size, "root_tol": float(root_tol), "max_iter": int(max_iter)}
    runs, parts = _Runs(limit), []
    rows = basis.T
    for c, start in enumerate(range(0, int(n_lines), int(chunk_lines))):
        rng = np.random.default_rng(np.random.SeedSequence([seed, 43, c]))
        m = min(int(chunk_lines), int(n_lines) - start)
        origins, _ = _lines(rows, m, rng)
        axes, weight = _axes(means, float(direction_defensive), m, k, rng)
        if origin_density is not None:
            drawn = origin_density.sample(m, rng)
            origins = drawn - (drawn @ basis) @ rows
            weight = weight * np.exp(origin_density.log_weights(drawn))
        dirs = axes @ rows
        pieces = gate_pieces(gate, origins, dirs, c_max, gate_points)
        parts.append({**_search(runs, origins, dirs, pieces, s, k), "weight": weight})
    lines = {key: np.concatenate([p[key] for p in parts]) for key in parts[0]}
    w = lines["weight"]
    e = line_estimate(w * lines["est"], w * lines["low"], w * lines["high"], confidence)
    reasons = _reasons(lines, e["pf"], e["n_effective"], s)
    if lines["est"].size < MIN_EFFECTIVE_LINES and not reasons:
        # the effective-lines rule allows half the lines, which says little for a handful
        reasons.append((1, f"only {lines['est'].size} lines: too few for the normal interval "
                        f"of their mean to be trusted (at least {MIN_EFFECTIVE_LINES:.0f})"))
    counts = np.bincount(np.minimum(lines["n_crossings"], 3), minlength=4)
    pf, upper = e["pf"], e["pf_upper"]
    if pf == 0.0:  # lines that all missed do not exclude a set only a few origins reach
        upper = max(upper, no_crossing_upper(w.size, float(np.max(w)), confidence))
    return {"pf": pf, "lower": e["pf_lower"], "upper": upper, "se": e["se"],
            "cov": e["se"] / pf if pf > 0 else math.inf, "n_effective": e["n_effective"],
            "status": reasons[0][0] if reasons else 0,
            "message": "; ".join(m for _, m in reasons) or (
                f"{lines['est'].size} i.i.d. lines, "
                + ("no weights" if means is None and origin_density is None else
                   f"weights at most {float(np.max(w)):.3g}")
                + ": the normal interval of their mean holds by the central limit theorem"),
            "runs": runs.n_runs, "n_lines": int(lines["est"].size),
            "lines_gated_out": int(np.sum(lines["n_pieces"] == 0)),
            "lines_by_crossings": counts.tolist(), "line_pf": lines["est"],
            "line_pf_lower": lines["low"], "line_pf_upper": lines["high"],
            "line_weight": w, "max_weight": float(np.max(w)),
            "line_crossings": lines["n_crossings"]}
