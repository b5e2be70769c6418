"""Line sampling (Koutsourelakis, Pradlwarter and Schueller 2004), searched on both sides.

Pf is the mean over independent lines of the exact probability of failure along each line
(Koutsourelakis, Pradlwarter and Schueller, "Reliability of structures in high dimensions,
part I", Probabilistic Engineering Mechanics 19 (2004) 409-417). A line goes through a
standard normal point ``u`` with its component in an important subspace ``B`` (``k``
orthonormal rows) removed, along a unit direction ``e`` of that subspace:
``u(t) = (I - B^T B) u + t e``.

* ``k = 1`` (the classic method): ``e = alpha``, the important direction, and ``t`` is
  standard normal;
* ``k >= 2`` (radial lines, for a failure set that surrounds the origin of the subspace, e.g.
  the exterior of a cylinder ``|P u| > r``): ``e`` is uniform on the unit sphere of the
  subspace and ``t`` has the density ``|t|^(k-1) exp(-t^2/2) / (2^(k/2) Gamma(k/2))``
  (``|t|`` is chi with ``k`` degrees of freedom, either sign), so that ``t e`` is exactly
  standard normal in the subspace. A fixed straight direction cannot serve such a set: the
  scatter orthogonal to it makes a few lines carry the estimate (per-line CoV about 500 at
  Pf 7e-7 for a 2-D circle's exterior), while a radial line crosses it once on each side.

Either way ``u(t)`` has the standard normal law, so each line's failure probability
``p_i = P(g(u(t)) <= 0 | line)`` is an unbiased estimate of Pf whatever the direction, and the
lines are i.i.d.: the interval is the normal one of their mean (the direction's quality shows
in the spread of the ``p_i``, reported).

Along each line ``g`` is evaluated on a grid of ``n_grid`` points over ``[-c_max, c_max]``
(both sides of the hyperplane); every cell whose ends differ in sign holds a crossing, refined
to ``root_tol`` by a safeguarded secant (regula falsi with a bisection whenever the bracket did
not halve in two steps, in Brent's family), all lines of a chunk in lockstep so that one model
design serves one step. ``p_i`` is the mass of the failing cells and tails. What the grid
cannot see (two crossings inside one cell) is not looked for; lines with more than two
crossings (the failure set not convex along the line) are counted and flagged. Beyond
``c_max`` a line is taken to keep the sign of its end; the upper end of the interval adds the
mass beyond ``c_max`` of every safe end (a line with no crossing contributes this bound).

An invalid run (nonzero status, NaN) makes its cells unknown: ``pf`` reads them as safe, the
interval's upper end as failed. Each step is one deterministic design given the seed and the
earlier steps, so with a store an interrupted run resumes where it stopped.

The direction: given (a vector, a mapping parameter -> component, or ``k`` rows), ``"form"``
(the design point of one FORM search from the origin), ``"pilot"`` (the mean of the worst
share of a widened pilot) or ``"gradient"`` (the leading ``subspace_dim`` left singular
vectors of finite-difference gradients of ``g`` at a few random points: for a limit state
that depends on ``|P u|`` the gradients all lie in the rows of ``P``).
"""

from __future__ import annotations

import math
import time
from collections.abc import Mapping
from typing import Any

import numpy as np
import xarray as xr
from scipy import special, stats

from gearuq.failure.evaluator import LimitStateEvaluator
from gearuq.failure.methods.form import FORM_SETTINGS, design_point_search
from gearuq.failure.report import Reason, failure_report
from gearuq.model import Option

__all__ = ["SETTINGS", "run_line_sampling", "line_mass", "important_subspace", "no_crossing_upper",
           "line_estimate", "MIN_EFFECTIVE_LINES"]

#: Fewer effective lines than this (and than half the lines), ``(sum p_i)^2 / sum p_i^2``,
#: and the normal interval of the mean is not trusted (status 3): a few lines carry it.
MIN_EFFECTIVE_LINES = 30.0


def _check_direction(value: Any) -> Any:
    if isinstance(value, str):
        if value not in ("form", "pilot", "gradient"):
            raise ValueError(f"direction: {value!r} is not 'form', 'pilot' or 'gradient' (or "
                             "a vector, a mapping parameter -> component, or rows)")
        return value
    if isinstance(value, Mapping):
        return {str(k): float(v) for k, v in value.items()}
    arr = np.asarray(value, dtype=float)
    if arr.ndim not in (1, 2) or arr.size == 0 or not np.all(np.isfinite(arr)):
        raise ValueError(f"direction: expected a finite vector or rows of numbers, got shape "
                         f"{arr.shape}")
    return arr


SETTINGS = (
    Option("n_lines", 200, "independent lines", lower=2),
    Option("direction", "form", "important direction: 'form', 'pilot', 'gradient', a vector "
           "(one number per parameter, standard normal space), a mapping parameter -> "
           "component, or k rows spanning a subspace (radial lines)", kind="any",
           check=_check_direction),
    Option("subspace_dim", 1, "dimension k of the subspace found by direction='gradient' "
           "(k >= 2: radial lines)", lower=1),
    Option("c_max", 8.0, "crossings are looked for along the line in [-c_max, c_max]",
           lower=1.0, upper=38.0),
    Option("n_grid", 9, "bracketing grid points along each line over [-c_max, c_max]",
           lower=3),
    Option("root_tol", 1e-3, "width of a crossing's final bracket along the line",
           lower=1e-9, upper=1.0),
    Option("max_iter", 40, "root-finding steps per crossing", lower=1),
    Option("chunk_lines", 100, "lines searched together (one model design per step)",
           lower=1),
    Option("n_probe", 3, "random points of direction='gradient' (d + 1 runs each), or "
           "100 x this many pilot draws for direction='pilot'", lower=1),
    Option("probe_std", 1.5, "standard deviation of the probe / pilot points", lower=0.1,
           upper=10.0),
    Option("probe_step", 0.05, "finite-difference step of direction='gradient'",
           lower=1e-8, upper=1.0),
)


# =========================================================================== the line's law
def line_mass(a: np.ndarray, b: np.ndarray, k: int) -> np.ndarray:
    """Probability of ``t`` in ``[a, b]`` under the line's law of :mod:`this module
    <gearuq.failure.methods.line_sampling>` (``k = 1``: standard normal; ``k >= 2``: ``|t|``
    chi with ``k`` degrees of freedom, either sign with probability 1/2).

    Parameters
    ----------
    a, b : ndarray
        Ends (``a <= b``; ``+-inf`` allowed).
    k : int
        Dimension of the subspace.
    """
    def beyond(t: np.ndarray) -> np.ndarray:  # P(T > t) for t >= 0, exact in the far tail
        return 0.5 * special.gammaincc(0.5 * k, 0.5 * np.minimum(t * t, 1e300))

    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    # by the symmetry about 0 each case is a difference (or complement) of upper tails, so a
    # mass of 1e-300 far out keeps its digits
    return np.where(a >= 0, beyond(np.abs(a)) - beyond(np.abs(b)),
                    np.where(b <= 0, beyond(np.abs(b)) - beyond(np.abs(a)),
                             1.0 - beyond(np.abs(a)) - beyond(np.abs(b))))


# =========================================================================== the direction
def _orthonormal_rows(rows: np.ndarray, what: str) -> np.ndarray:
    q, r = np.linalg.qr(np.atleast_2d(rows).T)
    if np.min(np.abs(np.diag(r))) < 1e-10 * max(np.max(np.abs(np.diag(r))), 1e-300):
        raise ValueError(f"direction: the rows of {what} are linearly dependent")
    # QR may flip a row's sign; a single direction keeps the given orientation
    q = q.T
    if q.shape[0] == 1 and float(q[0] @ np.atleast_2d(rows)[0]) < 0:
        q = -q
    return q


def important_subspace(ev: LimitStateEvaluator, s: Mapping[str, Any], seed: int
                       ) -> tuple[np.ndarray, dict[str, Any]]:
    """Orthonormal rows ``B`` (k, dim) of the important subspace, and how they were found.

    Raises
    ------
    ValueError
        A given direction of the wrong length, an unknown parameter name, a zero vector, or
        ``subspace_dim > 1`` with ``'form'`` or ``'pilot'``.
    """
    d, how = s["direction"], {}
    if isinstance(d, str) and d != "gradient" and s["subspace_dim"] != 1:
        raise ValueError(f"subspace_dim: {s['subspace_dim']} needs direction='gradient' or "
                         f"given rows; direction={d!r} gives one direction")
    if isinstance(d, Mapping):
        unknown = sorted(set(d) - set(ev.names))
        if unknown:
            raise ValueError(f"direction: unknown parameter(s) {unknown}; valid: "
                             f"{', '.join(ev.names)}")
        d = np.array([d.get(n, 0.0) for n in ev.names])
    if isinstance(d, np.ndarray):
        rows = np.atleast_2d(d)
        if rows.shape[1] != ev.dim or rows.shape[0] > ev.dim:
            raise ValueError(f"direction: expected {ev.dim} numbers per row (one per "
                             f"parameter) and at most {ev.dim} rows, got shape {d.shape}")
        if not np.all(np.linalg.norm(rows, axis=1) > 0):
            raise ValueError("direction: a zero vector has no direction")
        return _orthonormal_rows(rows, "direction"), {"direction_source": "given"}
    if d == "form":
        fs = {o.name: o.default for o in FORM_SETTINGS}
        rec = design_point_search(ev, np.zeros(ev.dim), fs, "line_sampling/form")
        norm = float(np.linalg.norm(rec["u"]))
        if rec["converged"] and norm > 0:
            return rec["u"][None] / norm, {"direction_source": (
                f"FORM design point from the origin (beta {norm:.4g})")}
        how["direction_note"] = ("FORM from the origin did not converge "
                                 f"({rec.get('error', '')}); the pilot's direction was used")
        d = "pilot"
    if d == "pilot":
        return _pilot_direction(ev, s, seed), {**how, "direction_source": (
            f"mean of the lowest-g 5 % (or the failing) of {100 * s['n_probe']} pilot draws of "
            f"N(0, {s['probe_std']:g}^2 I)")}
    return _gradient_subspace(ev, s, seed)


def _pilot_direction(ev: LimitStateEvaluator, s: Mapping[str, Any], seed: int) -> np.ndarray:
    rng = np.random.default_rng(np.random.SeedSequence([seed, 31]))
    u = s["probe_std"] * rng.standard_normal((100 * s["n_probe"], ev.dim))
    g = ev.evaluate(u, "line_sampling/pilot")["g"]
    ok = np.isfinite(g)
    if not ok.any():
        raise ValueError("direction='pilot': every pilot run was invalid; give a direction")
    order = np.argsort(np.where(ok, g, np.inf))
    n_worst = max(int(np.sum(ok & (g <= 0))), int(math.ceil(0.05 * ok.sum())), 1)
    mean = u[order[:n_worst]].mean(axis=0)
    if not np.linalg.norm(mean) > 0:
        raise ValueError("direction='pilot': the worst pilot draws average to the origin; "
                         "give a direction")
    return mean[None] / np.linalg.norm(mean)


def _gradient_subspace(ev: LimitStateEvaluator, s: Mapping[str, Any], seed: int
                       ) -> tuple[np.ndarray, dict[str, Any]]:
    """Leading left singular vectors of forward-difference gradients at random points."""
    k, m, h = s["subspace_dim"], s["n_probe"], s["probe_step"]
    if k > min(m, ev.dim):
        raise ValueError(f"subspace_dim: {k} exceeds n_probe ({m}) or the dimension "
                         f"({ev.dim}); the gradients span at most that many directions")
    rng = np.random.default_rng(np.random.SeedSequence([seed, 37]))
    centres = s["probe_std"] * rng.standard_normal((m, ev.dim))
    design = np.vstack([np.vstack([c, c + h * np.eye(ev.dim)]) for c in centres])
    g = ev.evaluate(design, "line_sampling/gradient")["g"].reshape(m, ev.dim + 1)
    grads = (g[:, 1:] - g[:, :1]) / h
    if not np.all(np.isfinite(grads)):
        raise ValueError("direction='gradient': a probe run was invalid; give a direction or "
                         "move the probe (probe_std, seed)")
    left, sing, _ = np.linalg.svd(grads.T, full_matrices=False)
    rows = left[:, :k].T
    if k == 1 and float(np.mean(grads @ rows[0])) > 0:
        rows = -rows  # towards decreasing g, i.e. towards failure
    return rows, {"direction_source": (f"leading {k} singular vector(s) of {m} "
                                       "finite-difference gradients of g"),
                  "probe_singular_values": _json_list(sing / sing[0])}


def _json_list(values: np.ndarray) -> str:
    """Rounded numbers as a short text for the report's attributes."""
    return "[" + ", ".join(f"{v:.4g}" for v in np.asarray(values, dtype=float)) + "]"


# =========================================================================== the search
def _lines(basis: np.ndarray, n: int, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """Origins (the normal point with its subspace component removed) and unit directions."""
    u = rng.standard_normal((n, basis.shape[1]))
    origins = u - (u @ basis.T) @ basis
    if basis.shape[0] == 1:
        return origins, np.repeat(basis, n, axis=0)
    w = rng.standard_normal((n, basis.shape[0]))
    return origins, (w / np.linalg.norm(w, axis=1, keepdims=True)) @ basis


def _refine(ev: LimitStateEvaluator, origins: np.ndarray, dirs: np.ndarray, lo: np.ndarray,
            hi: np.ndarray, g_lo: np.ndarray, g_hi: np.ndarray, s: Mapping[str, Any], tag: str
            ) -> dict[str, np.ndarray]:
    """Shrink brackets ``[lo, hi]`` holding one change of failure state to ``root_tol``.

    Secant (regula falsi) steps, kept ``root_tol / 2`` inside the bracket so that a step next
    to the root lands across it, and a bisection whenever the bracket did not halve in two
    steps: the width falls below the tolerance in at most about ``2 log2(w / tol)`` steps.
    A run that is invalid ends its bracket's refinement where it is (the root stays inside).
    """
    tol = s["root_tol"]
    lo, hi, g_lo, g_hi = (np.array(a, dtype=float) for a in (lo, hi, g_lo, g_hi))
    width_before = np.full((2, lo.size), np.inf)  # widths one and two steps ago
    stopped = np.zeros(lo.size, dtype=bool)
    for it in range(s["max_iter"]):
        idx = np.flatnonzero(~stopped & (hi - lo > tol))
        if idx.size == 0:
            break
        a, b, ga, gb = lo[idx], hi[idx], g_lo[idx], g_hi[idx]
        with np.errstate(invalid="ignore", divide="ignore"):
            x = a - ga * (b - a) / (gb - ga)
        bisect = ~np.isfinite(x) | (b - a > 0.5 * width_before[1, idx])
        x = np.where(bisect, 0.5 * (a + b), x)
        inset = np.minimum(0.5 * tol, 0.25 * (b - a))
        x = np.clip(x, a + inset, b - inset)
        gx = ev.evaluate(origins[idx] + x[:, None] * dirs[idx], f"{tag}/root{it}")["g"]
        width_before[1, idx], width_before[0, idx] = width_before[0, idx], b - a
        ok = np.isfinite(gx)
        stopped[idx[~ok]] = True
        like_lo = ok & ((gx <= 0) == (ga <= 0))
        like_hi = ok & ~like_lo
        lo[idx[like_lo]], g_lo[idx[like_lo]] = x[like_lo], gx[like_lo]
        hi[idx[like_hi]], g_hi[idx[like_hi]] = x[like_hi], gx[like_hi]
    with np.errstate(invalid="ignore", divide="ignore"):
        root = lo - g_lo * (hi - lo) / (g_hi - g_lo)
    root = np.where(np.isfinite(root), np.clip(root, lo, hi), 0.5 * (lo + hi))
    return {"lo": lo, "hi": hi, "root": root, "converged": hi - lo <= tol,
            "invalid_step": stopped}


def _search_chunk(ev: LimitStateEvaluator, origins: np.ndarray, dirs: np.ndarray,
                  s: Mapping[str, Any], k: int, tag: str) -> dict[str, np.ndarray]:
    """Each line's failure probability: its estimate and the ends of its two readings.

    ``est`` takes each crossing at its interpolated root and unknown (invalid) cells as safe;
    ``low`` takes every refined bracket as safe, ``high`` as failed, with unknown cells and
    the mass beyond a safe end at ``c_max`` as failed.
    """
    n = origins.shape[0]
    grid = np.linspace(-s["c_max"], s["c_max"], s["n_grid"])
    pts = origins[:, None, :] + grid[None, :, None] * dirs[:, None, :]
    g = ev.evaluate(pts.reshape(-1, ev.dim), f"{tag}/grid")["g"].reshape(n, grid.size)
    valid, fail = np.isfinite(g), g <= 0
    cell_mass = line_mass(grid[:-1], grid[1:], k)[None, :].repeat(n, axis=0)
    both = valid[:, :-1] & valid[:, 1:]
    cross = both & (fail[:, :-1] != fail[:, 1:])
    whole = both & fail[:, :-1] & fail[:, 1:]
    est = np.sum(np.where(whole, cell_mass, 0.0), axis=1)
    low = est.copy()
    high = est + np.sum(np.where(~both, cell_mass, 0.0), axis=1)
    tail = float(line_mass(np.array(s["c_max"]), np.array(np.inf), k))
    for end in (0, -1):  # beyond -c_max and c_max: the sign of the end, failed in the bound
        est += np.where(valid[:, end] & fail[:, end], tail, 0.0)
        low += np.where(valid[:, end] & fail[:, end], tail, 0.0)
        high += tail
    line, cell = np.nonzero(cross)
    out = {"n_crossings": cross.sum(axis=1), "n_unconverged": np.zeros(n, dtype=int)}
    if line.size:
        r = _refine(ev, origins[line], dirs[line], grid[cell], grid[cell + 1],
                    g[line, cell], g[line, cell + 1], s, tag)
        left_fails = fail[line, cell]  # the failing side of the cell: its left or right end
        edge_l, edge_r = grid[cell], grid[cell + 1]

        def failing_part(at: np.ndarray) -> np.ndarray:
            return np.where(left_fails, line_mass(edge_l, at, k), line_mass(at, edge_r, k))

        np.add.at(est, line, failing_part(r["root"]))
        np.add.at(low, line, failing_part(np.where(left_fails, r["lo"], r["hi"])))
        np.add.at(high, line, failing_part(np.where(left_fails, r["hi"], r["lo"])))
        np.add.at(out["n_unconverged"], line, (~r["converged"]).astype(int))
    out.update({"est": est, "low": low, "high": high, "any_invalid": ~valid.all(axis=1)})
    return out


# =========================================================================== the estimate
def run_line_sampling(ev: LimitStateEvaluator, s: Mapping[str, Any], seed: int,
                      confidence: float) -> xr.Dataset:
    """Line sampling: the mean of the lines' failure probabilities, with a normal interval."""
    t0 = time.perf_counter()
    basis, how = important_subspace(ev, s, seed)
    k = basis.shape[0]
    probe_runs = ev.n_runs
    parts = []
    for c, start in enumerate(range(0, s["n_lines"], s["chunk_lines"])):
        rng = np.random.default_rng(np.random.SeedSequence([seed, 41, c]))
        origins, dirs = _lines(basis, min(s["chunk_lines"], s["n_lines"] - start), rng)
        parts.append(_search_chunk(ev, origins, dirs, s, k, f"line_sampling/chunk{c}"))
    lines = {key: np.concatenate([p[key] for p in parts]) for key in parts[0]}
    return _report(ev, s, seed, confidence, basis, how, lines, probe_runs, t0)


def line_estimate(est: np.ndarray, low: np.ndarray, high: np.ndarray, confidence: float
                  ) -> dict[str, float]:
    """Pf, its standard error and interval from i.i.d. line probabilities.

    Parameters
    ----------
    est, low, high : ndarray, shape (n_lines,)
        Each line's failure probability and the lower and upper ends of its readings
        (brackets and unknown cells read safe / failed; :func:`run_line_sampling`).
    confidence : float
        Two-sided level of the normal interval of the mean.

    Returns
    -------
    dict
        ``pf``, ``se``, ``pf_lower`` (the mean of ``low`` minus ``z`` times its standard
        error, at least 0), ``pf_upper`` (of ``high``, plus), ``n_effective``
        (``(sum est)^2 / sum est^2``).
    """
    z = float(stats.norm.isf(0.5 * (1.0 - float(confidence))))
    root_n = math.sqrt(est.size)
    se, se_low, se_high = (float(np.std(v, ddof=1)) / root_n for v in (est, low, high))
    square = float(np.sum(est**2))
    return {"pf": float(np.mean(est)), "se": se,
            "pf_lower": max(float(np.mean(low)) - z * se_low, 0.0),
            "pf_upper": float(np.mean(high)) + z * se_high,
            "n_effective": float(np.sum(est)) ** 2 / square if square > 0 else 0.0}


def no_crossing_upper(n_lines: int, largest_term: float, confidence: float) -> float:
    """Upper end of pf when none of ``n_lines`` i.i.d. lines met failure.

    Each line's term lies in ``[0, largest_term]`` (its failing mass, at most 1, times its
    weight). That none of ``n`` was positive bounds the share of lines that would be by
    ``1 - ((1 - confidence) / 2)^(1/n)`` at the one-sided level of the two-sided interval
    (the rule of three's exact form), so pf is at most that share times the largest term:
    a failure set that only a few origins reach is not excluded by lines that missed it
    (the mass beyond ``c_max`` alone, the bound before, excluded it).
    """
    share = 1.0 - (0.5 * (1.0 - float(confidence))) ** (1.0 / int(n_lines))
    return float(share * largest_term)


def _reasons(lines: Mapping[str, np.ndarray], pf: float, n_eff: float, s: Mapping[str, Any]
             ) -> list[Reason]:
    """What the run cannot vouch for, in words."""
    n = lines["est"].size
    reasons: list[Reason] = []
    if pf == 0.0:
        reasons.append((4, f"no line of {n} crosses into failure within |t| <= "
                        f"{s['c_max']:g}: pf is an upper bound, the share of lines that "
                        f"{n} lines could all miss (1 - (alpha/2)^(1/{n})) times the largest "
                        "a line can carry, plus the mass beyond c_max; the lines found no "
                        "failure set, they did not exclude one"))
    elif n_eff < min(MIN_EFFECTIVE_LINES, 0.5 * n):
        reasons.append((3, f"{n_eff:.1f} effective lines of {n} ((sum p)^2 / sum p^2) carry "
                        "the estimate: the direction serves this failure set poorly and the "
                        "normal interval of the mean is not trustworthy; give a better "
                        "direction (or k rows for a set around the origin) or more lines"))
    many = int(np.sum(lines["n_crossings"] > 2))
    if many:
        reasons.append((8, f"{many} of {n} lines cross the limit state more than twice: the "
                        "failure set is not convex along the direction, and two crossings "
                        f"closer than the grid spacing {2 * s['c_max'] / (s['n_grid'] - 1):.3g}"
                        " would be missed; raise n_grid"))
    unconverged = int(lines["n_unconverged"].sum())
    if unconverged:
        reasons.append((1, f"{unconverged} crossing(s) not bracketed to root_tol "
                        f"{s['root_tol']:g} in {s['max_iter']} steps (or an invalid run "
                        "stopped them): their brackets are counted in the interval"))
    bad = int(lines["any_invalid"].sum())
    if bad:
        reasons.append((6, f"{bad} of {n} lines met an invalid model run: pf reads the "
                        "unknown cells as safe, the interval's upper end as failed"))
    return reasons


def _report(ev: LimitStateEvaluator, s: Mapping[str, Any], seed: int, confidence: float,
            basis: np.ndarray, how: Mapping[str, Any], lines: Mapping[str, np.ndarray],
            probe_runs: int, t0: float) -> xr.Dataset:
    e = line_estimate(lines["est"], lines["low"], lines["high"], confidence)
    pf, se, lower, upper, n_eff = (e[key] for key in ("pf", "se", "pf_lower", "pf_upper",
                                                      "n_effective"))
    reasons = _reasons(lines, pf, n_eff, s)
    bound = pf == 0.0
    counts = np.bincount(np.minimum(lines["n_crossings"], 3), minlength=4)
    n = lines["est"].size
    if bound:
        upper = max(upper, no_crossing_upper(n, 1.0, confidence))
    extra = {
        "line_pf": (("line",), lines["est"], {"units": "1", "long_name": (
            "failure probability along each line (its mean is pf; its spread shows how well "
            "the direction serves the failure set)")}),
        "line_pf_lower": (("line",), lines["low"], {"units": "1", "long_name": (
            "lower end of each line's probability (brackets and unknown cells read safe)")}),
        "line_pf_upper": (("line",), lines["high"], {"units": "1", "long_name": (
            "upper end of each line's probability (brackets, unknown cells and the mass "
            "beyond a safe end at c_max read failed)")}),
        "line_crossings": (("line",), lines["n_crossings"].astype(np.int16), {
            "units": "1", "long_name": "changes of failure state found along each line"}),
        "n_lines_by_crossings": (("crossings",), counts.astype(np.int64), {
            "units": "1", "long_name": "lines with 0, 1, 2 and more than 2 (last) crossings"}),
        "direction": (("subspace", "parameter"), basis, {"units": "1", "long_name": (
            "orthonormal rows of the important subspace (standard normal space); one row: "
            "the line direction alpha, k rows: radial lines")}),
        "n_effective_lines": ((), n_eff, {"units": "1", "long_name":
                              "(sum p_i)^2 / sum p_i^2 of the lines' probabilities"}),
        "n_probe_runs": ((), np.int64(probe_runs), {"units": "1", "long_name":
                         "model runs spent finding the direction"}),
    }
    settings = {key: (v.tolist() if isinstance(v, np.ndarray) else v) for key, v in s.items()}
    kind = (f"normal, mean of {n} i.i.d. line probabilities (lower end from brackets read safe,"
            " upper from brackets, unknown cells and the mass beyond c_max read failed)")
    rep = failure_report(
        ev, "line_sampling", pf=upper if bound else pf, pf_lower=lower, pf_upper=upper,
        cov=se / pf if pf > 0 else math.inf, interval_kind=kind, confidence=confidence,
        settings=settings, seed=seed, wall_time=time.perf_counter() - t0, reasons=reasons,
        pf_is_upper_bound=bound, extra=extra,
        extra_attrs={**how, "line_kind": "straight (alpha)" if basis.shape[0] == 1 else
                     f"radial in a {basis.shape[0]}-dimensional subspace"})
    return rep.assign_coords(parameter=("parameter", np.array(ev.names, dtype=str)),
                             crossings=("crossings", np.array(["0", "1", "2", ">2"])))
