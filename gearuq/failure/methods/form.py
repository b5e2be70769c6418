"""FORM and SORM in the standard normal space of a :class:`~gearuq.space.ParameterSpace`.

FORM looks for the design point ``u*``, the point of the failure domain ``G(u) <= 0`` nearest
the origin of the independent standard normal space, with the improved HLRF algorithm
(Zhang and Der Kiureghian 1995): the HLRF step direction, a merit function
``m(u) = |u|^2 / 2 + c |G(u)|`` with ``c = 2 max(|u|, |u_HLRF|) / |grad G|`` and Armijo
backtracking. Gradients are batched finite differences: one design of ``d`` (forward) or ``2d``
(central) points evaluated as one chunk through the executor; a point that would leave the
model's valid range is replaced by the opposite one-sided difference. Several starting points
(the origin, then points on the +- axes and in random directions) find several design points
when the limit state has them; the report says so and adds the series-system FORM estimate
over all of them.

``beta = |u*|`` (negative when the origin fails), ``pf_FORM = Phi(-beta)``; importance factors
``gamma^2`` with ``gamma = L^-T alpha / |L^-T alpha|`` (Der Kiureghian 2005), and parameter
sensitivities ``d beta / d mean_i`` and ``d beta / d std_i`` for a shift and a scaling of each
marginal about its mean (``d beta / d theta = alpha . d u / d theta`` at fixed ``x*``).

SORM fits the principal curvatures ``kappa_i`` of the limit state at ``u*`` from a central
finite-difference Hessian (``2 d^2`` runs) rotated into the tangent plane, and reports the
formulas of Breitung (1984), Hohenbichler and Rackwitz (1988) and Tvedt (1990). All work with
correlated inputs, because the correlation is inside the map from ``u`` to ``x``.
"""

from __future__ import annotations

import json
import math
import time
from collections.abc import Mapping
from typing import Any

import numpy as np
import xarray as xr
from scipy import linalg, stats

from gearuq.failure.evaluator import LimitStateEvaluator
from gearuq.failure.report import Reason, failure_report
from gearuq.model import Option

__all__ = ["FORM_SETTINGS", "SORM_SETTINGS", "run_form", "design_point_search",
           "sorm_probabilities", "resolve_starts", "search_reasons", "check_starts",
           "no_design_point_reason", "hidden_mode_notes", "PROBE_RADII"]

def check_starts(value: Any) -> Any:
    if isinstance(value, str) and value == "auto":
        return value
    if isinstance(value, (bool, np.bool_)) or not float(value).is_integer() or int(value) < 1:
        raise ValueError(f"n_starts must be 'auto' or an integer >= 1, got {value!r}")
    return int(value)


FORM_SETTINGS = (
    Option("n_starts", "auto", "starting points of the design-point search: 'auto' = the "
           "origin and 12 (d = 2) or 20 (d = 3) evenly spread directions, the +- axes and 4 "
           "random directions (d = 4, 5), else 10 random directions; an integer n: the "
           "origin, then the +- axes when n > 2d, else random directions", kind="any",
           check=check_starts),
    Option("start_radius", 3.0, "radius of the extra starting points (standard normal space)",
           lower=0.0),
    Option("fd_step", 1e-4, "finite-difference step in the standard normal space (raise it "
           "for noisy models, e.g. ODE solutions)", lower=1e-12, upper=1.0),
    Option("fd_scheme", "forward", "finite differences: forward (d runs) or central (2d)",
           choices=("forward", "central")),
    Option("tol_u", 1e-4, "convergence: |u - (alpha.u) alpha| below this", lower=1e-14,
           upper=1.0),
    Option("tol_g", 1e-4, "convergence: |G| below this times |G(start)|", lower=1e-14,
           upper=1.0),
    Option("max_iter", 50, "iterations per starting point", lower=1),
    Option("max_line_search", 8, "Armijo step halvings per iteration", lower=0),
    Option("distinct", 0.1, "two design points differ if further apart than this times "
           "max(1, beta)", lower=0.0),
)
SORM_SETTINGS = FORM_SETTINGS + (
    Option("hessian_step", 1e-3, "finite-difference step of the Hessian (standard space)",
           lower=1e-8, upper=1.0),
    Option("formula", "tvedt", "SORM formula reported as pf",
           choices=("tvedt", "hohenbichler", "breitung")),
)

_NOT_STATISTICAL = ("none: FORM/SORM are asymptotic approximations without a statistical "
                    "interval; their error is checked against references in docs/reliability.md")


# =========================================================================== gradients
def _gradient(ev: LimitStateEvaluator, u: np.ndarray, g_u: float | None, s: Mapping[str, Any],
              tag: str) -> tuple[float, np.ndarray, str]:
    """Value (when ``g_u`` is None) and finite-difference gradient at ``u``: one design.

    Returns ``(g(u), grad, error)``; ``error`` is non-empty when a point failed.
    """
    d, h = ev.dim, s["fd_step"]
    steps = np.eye(d) * h
    if s["fd_scheme"] == "central":
        plus, minus = u + steps, u - steps
        ok_p, ok_m = ev.in_range(plus), ev.in_range(minus)
        pts = [plus, minus]
        kind = np.where(ok_p & ok_m, 0, np.where(ok_p, 1, np.where(ok_m, -1, 9)))
    else:
        plus = u + steps
        ok_p = ev.in_range(plus)
        minus = u - steps
        pts = [np.where(ok_p[:, None], plus, minus)]
        kind = np.where(ok_p, 1, np.where(ev.in_range(minus), -1, 9))
    if np.any(kind == 9):
        j = int(np.flatnonzero(kind == 9)[0])
        msg = ev.outside_range((u + steps)[j:j + 1]) + ev.outside_range((u - steps)[j:j + 1])
        raise ValueError(f"FORM gradient at u = {u}: both finite-difference points of "
                         f"{ev.names[j]!r} leave the model's valid range ({msg[0]}); lower "
                         "fd_step or truncate the marginal")
    head = [] if g_u is not None else [u[None, :]]
    design = np.vstack(head + pts)
    res = ev.evaluate(design, tag)
    g = res["g"]
    if g_u is None:
        g_u, g = float(g[0]), g[1:]
    if not np.all(np.isfinite(g)) or not math.isfinite(g_u):
        return g_u, np.full(d, np.nan), (f"model failed at the design of {tag} near u = {u} "
                                         f"(x = {_x_text(ev, u)})")
    if s["fd_scheme"] == "central":
        gp, gm = g[:d], g[d:]
        grad = np.where(kind == 0, (gp - gm) / (2 * h),
                        np.where(kind == 1, (gp - g_u) / h, (g_u - gm) / h))
    else:
        grad = np.where(kind == 1, (g - g_u) / h, (g_u - g) / h)
    return g_u, grad, ""


def _x_text(ev: LimitStateEvaluator, u: np.ndarray) -> str:
    x = ev.to_physical(u[None, :])
    return ", ".join(f"{n}={x[n][0]:.6g}" for n in ev.names)


# =========================================================================== iHLRF
def design_point_search(ev: LimitStateEvaluator, u0: np.ndarray, s: Mapping[str, Any],
                        tag: str, g0: float | None = None) -> dict[str, Any]:
    """iHLRF search from ``u0`` (see :func:`_ihlrf`); a search that fails from a start where
    the limit state already fails, by leaving the model's valid range, says so first: the
    surface ``g = 0`` may not exist (a failure probability near 1, or a mis-signed g).
    """
    start: dict[str, float] = {}
    try:
        return _ihlrf(ev, u0, s, tag, g0, start)
    except ValueError as exc:
        g0 = start.get("g", g0)
        if g0 is not None and g0 <= 0 and "valid range" in str(exc):
            raise ValueError(
                f"FORM: g = {g0:.4g} <= 0 already at the start u = {np.asarray(u0)} (the mean "
                "point): the search for the surface g = 0 left the model's valid range, so "
                "the failure probability may be near 1 or the limit state mis-signed (failing "
                f"where it should be safe); Monte Carlo answers the former. {exc}") from None
        raise


def _ihlrf(ev: LimitStateEvaluator, u0: np.ndarray, s: Mapping[str, Any], tag: str,
           g0: float | None = None, start: dict[str, float] | None = None) -> dict[str, Any]:
    """iHLRF search from ``u0`` (its first ``g`` kept in ``start["g"]``).

    Returns
    -------
    dict
        ``u``, ``g``, ``grad``, ``converged`` (bool), ``iterations``, ``error`` (str).
    """
    u = np.asarray(u0, dtype=float).copy()
    g, grad, err = _gradient(ev, u, g0, s, f"{tag}/it0")
    if start is not None:
        start["g"] = g
    out = {"u": u, "g": g, "grad": grad, "converged": False, "iterations": 0, "error": err,
           "g_start": g}
    if err:
        return out
    scale = abs(g) if g != 0 else 1.0
    for it in range(1, s["max_iter"] + 1):
        norm = float(np.linalg.norm(grad))
        if not norm > 0:
            out["error"] = f"zero gradient at u = {u}; the limit state is flat there"
            return out
        alpha = -grad / norm
        if abs(g) <= s["tol_g"] * scale and np.linalg.norm(u - (alpha @ u) * alpha) <= s["tol_u"]:
            out.update(u=u, g=g, grad=grad, converged=True, iterations=it - 1)
            return out
        u_hlrf = ((grad @ u - g) / norm**2) * grad
        direction = u_hlrf - u
        c = 2.0 * max(np.linalg.norm(u), np.linalg.norm(u_hlrf)) / norm + 1e-12
        merit = 0.5 * u @ u + c * abs(g)
        slope = (u + c * math.copysign(1.0, g) * grad) @ direction
        step, u_new, g_new = 1.0, u, g
        for _ in range(s["max_line_search"] + 1):
            u_try = u + step * direction
            g_try = float(ev.evaluate(u_try[None, :], f"{tag}/it{it}/step{step:g}")["g"][0])
            if math.isfinite(g_try):
                u_new, g_new = u_try, g_try
                if 0.5 * u_try @ u_try + c * abs(g_try) <= merit + 0.5 * step * min(slope, 0.0):
                    break
            step *= 0.5
        if u_new is u:
            out.update(error=f"model failed at every line-search point from u = {u}")
            return out
        u, g = u_new, g_new
        g, grad, err = _gradient(ev, u, g, s, f"{tag}/it{it}/grad")
        out.update(u=u, g=g, grad=grad, iterations=it)
        if err:
            out["error"] = err
            return out
    return out


def _distinct(points: list[dict[str, Any]], tol: float) -> list[dict[str, Any]]:
    """Converged design points, nearest first, duplicates removed."""
    found: list[dict[str, Any]] = []
    for p in sorted(points, key=lambda p: abs(p["beta"])):
        if all(np.linalg.norm(p["u"] - q["u"]) > tol * max(1.0, abs(q["beta"]))
               for q in found):
            found.append(p)
    return found


def _series_form(found: list[dict[str, Any]]) -> float:
    """Series-system FORM over several design points: ``P(union_i alpha_i . U >= beta_i)``."""
    betas = np.array([p["beta"] for p in found])
    alphas = np.array([p["u"] / p["beta"] for p in found])
    return series_linear_probability(alphas, betas)


def series_linear_probability(alphas: np.ndarray, betas: np.ndarray,
                              n_directions: int = 200_000) -> float:
    """``P(union_i {alpha_i . U >= beta_i})`` for ``U`` standard normal: deterministic.

    The half-spaces depend on ``U`` only through its projection on the span of the
    ``alpha_i`` (rank ``r``), ``W ~ N(0, I_r)``. In polar form ``W = R e``, ``R^2 ~ chi^2_r``,
    a direction ``e`` fails from radius ``rho(e) = min_{i: a_i . e > 0} beta_i / (a_i . e)``
    on, so ``P = E_e[P(chi^2_r >= rho(e)^2)]``. For ``r <= 2`` the average over directions is
    an adaptive quadrature over the angle (exact to 1e-10); for ``r > 2`` it is taken over
    a fixed, antithetic set of directions (same answer at every call, error ~1e-3 relative).
    A multivariate normal cdf with a random (Genz) method, as before, gave 2.8e-3 to 3.3e-3
    from call to call on a singular correlation.
    """
    alphas = np.atleast_2d(np.asarray(alphas, dtype=float))
    betas = np.asarray(betas, dtype=float)
    if np.any(betas <= 0):  # the origin fails: the rays are not tails; not computed
        return math.nan
    _, sv, vt = np.linalg.svd(alphas, full_matrices=False)
    rank = int(np.sum(sv > 1e-10 * sv[0]))
    a = alphas @ vt[:rank].T  # coordinates of each alpha in the span, (k, r)

    def tail(e: np.ndarray) -> np.ndarray:
        proj = e @ a.T  # (m, k)
        with np.errstate(divide="ignore", invalid="ignore"):
            rho = np.where(proj > 0, betas[None, :] / proj, np.inf).min(axis=1)
        return np.where(np.isfinite(rho), stats.chi2.sf(rho**2, rank), 0.0)

    if rank == 1:
        return float(tail(np.array([[1.0], [-1.0]])).mean())
    if rank == 2:
        from scipy import integrate

        # breakpoints where the governing half-space changes: the alpha directions and the
        # angles where two of them give the same radius are all inside the grid below
        angles = np.sort(np.concatenate([np.arctan2(a[:, 1], a[:, 0]) % (2 * np.pi),
                                         np.linspace(0.0, 2 * np.pi, 65)]))
        total = 0.0
        for lo, hi in zip(angles[:-1], angles[1:], strict=True):
            if hi - lo < 1e-14:
                continue
            val, _ = integrate.quad(
                lambda th: float(tail(np.array([[math.cos(th), math.sin(th)]]))[0]), lo, hi,
                epsabs=1e-13, epsrel=1e-10, limit=200)
            total += val
        return float(total / (2 * np.pi))
    rng = np.random.default_rng(20241124)  # fixed: the same directions at every call
    e = rng.standard_normal((n_directions // 2, rank))
    e /= np.linalg.norm(e, axis=1, keepdims=True)
    return float(np.concatenate([tail(e), tail(-e)]).mean())


# =========================================================================== sensitivities
def _sensitivities(ev: LimitStateEvaluator, u_star: np.ndarray, beta: float
                   ) -> tuple[np.ndarray, np.ndarray]:
    """``d beta / d mean_i`` and ``d beta / d std_i`` (location shift / scaling of marginal i)."""
    alpha = u_star / beta
    weight = alpha if ev.chol is None else linalg.solve_triangular(ev.chol.T, alpha, lower=False)
    z = ev.to_correlated(u_star)[0]
    x = ev.to_physical(u_star[None, :])
    d_mean, d_std = np.empty(ev.dim), np.empty(ev.dim)
    for i, (n, m) in enumerate(zip(ev.names, ev.marginals, strict=True)):
        xi = float(x[n][0])
        dens = float(m.pdf(xi)) / float(stats.norm.pdf(z[i]))
        d_mean[i] = -weight[i] * dens
        d_std[i] = -weight[i] * dens * (xi - m.mean()) / m.std()
    return d_mean, d_std


# =========================================================================== SORM
def _hessian(ev: LimitStateEvaluator, u: np.ndarray, g_u: float, h: float, tag: str
             ) -> tuple[np.ndarray, np.ndarray]:
    """Central finite-difference Hessian and gradient at ``u``: one design of ``2 d^2`` points."""
    d = ev.dim
    eye = np.eye(d) * h
    pts = [u + eye, u - eye]
    pairs = [(i, j) for i in range(d) for j in range(i + 1, d)]
    for si, sj in ((1, 1), (1, -1), (-1, 1), (-1, -1)):
        pts += [np.array([u + si * eye[i] + sj * eye[j] for i, j in pairs]).reshape(-1, d)]
    design = np.vstack(pts)
    if not ev.in_range(design).all():
        raise ValueError(f"SORM Hessian at the design point: {ev.outside_range(design)[0]}; "
                         "lower hessian_step or truncate the marginal")
    g = ev.evaluate(design, tag)["g"]
    if not np.all(np.isfinite(g)):
        raise _ModelFailure(f"model failed in the Hessian design around u = {u}")
    gp, gm = g[:d], g[d:2 * d]
    grad = (gp - gm) / (2 * h)
    hess = np.diag((gp - 2 * g_u + gm) / h**2)
    n_p = len(pairs)
    blocks = [g[2 * d + k * n_p: 2 * d + (k + 1) * n_p] for k in range(4)]
    for k, (i, j) in enumerate(pairs):
        hess[i, j] = hess[j, i] = (blocks[0][k] - blocks[1][k] - blocks[2][k] + blocks[3][k]) \
            / (4 * h * h)
    return hess, grad


class _ModelFailure(RuntimeError):
    pass


def curvatures(hess: np.ndarray, grad: np.ndarray) -> np.ndarray:
    """Principal curvatures of ``G = 0`` at the design point (positive: failure domain curves
    away from the origin, smaller Pf)."""
    norm = np.linalg.norm(grad)
    alpha = -grad / norm
    q, _ = np.linalg.qr(np.column_stack([alpha, np.eye(alpha.size)]))
    tangent = q[:, 1:alpha.size]
    return np.linalg.eigvalsh(tangent.T @ hess @ tangent / norm)


def sorm_probabilities(beta: float, kappa: np.ndarray) -> dict[str, float]:
    """Breitung, Hohenbichler-Rackwitz and Tvedt (three-term) Pf from ``beta`` and curvatures.

    A formula whose square-root argument is not positive returns NaN (invalid there).
    """
    kappa = np.asarray(kappa, dtype=float)
    phi, tail = stats.norm.pdf(beta), stats.norm.sf(beta)

    def prod_root(x: np.ndarray) -> float:
        return float(np.prod(x ** -0.5)) if np.all(x > 0) else math.nan

    breitung_factor = prod_root(1 + beta * kappa)
    psi = phi / tail
    out = {"breitung": tail * breitung_factor,
           "hohenbichler": tail * prod_root(1 + psi * kappa)}
    shifted = prod_root(1 + (beta + 1) * kappa)
    complex_factor = complex(np.prod((1 + (beta + 1j) * kappa) ** -0.5))
    core = beta * tail - phi
    a1 = tail * breitung_factor
    a2 = core * (breitung_factor - shifted)
    a3 = (beta + 1) * core * (breitung_factor - complex_factor.real)
    out["tvedt"] = a1 + a2 + a3 if math.isfinite(breitung_factor + shifted) else math.nan
    return out


# =========================================================================== driver
def run_form(ev: LimitStateEvaluator, s: Mapping[str, Any], seed: int, confidence: float,
             *, second_order: bool = False) -> xr.Dataset:
    """FORM (or SORM) with multiple starting points; the report of the nearest design point."""
    t0 = time.perf_counter()
    s = resolve_starts(ev, s)
    found, starts = form_design_points(ev, s, seed)
    method = "sorm" if second_order else "form"
    common = {"interval_kind": _NOT_STATISTICAL, "confidence": confidence, "settings": s,
              "seed": seed}
    start_vars = {
        "start_converged": (("start",), np.array([r["converged"] for r in starts], np.int8),
                            {"units": "1", "long_name": "1 if the search from this start "
                             "converged"}),
        "start_iterations": (("start",), np.array([r["iterations"] for r in starts]),
                             {"units": "1", "long_name": "iHLRF iterations per start"}),
        "start_beta": (("start",), np.array([r["beta"] for r in starts]),
                       {"units": "1", "long_name": "beta found from each start"}),
    }
    if not found:
        code, msg = no_design_point_reason(starts, s)
        errors = sorted({r["error"] for r in starts if r["error"]})
        return failure_report(ev, method, pf=math.nan, status=code, message=msg,
                              wall_time=time.perf_counter() - t0, extra=start_vars,
                              extra_attrs={"start_errors": json.dumps(errors[:20])},
                              **common)
    best = found[0]
    beta = best["beta"]
    pf_form = float(stats.norm.sf(beta))
    d_mean, d_std = _sensitivities(ev, best["u"], beta)
    extra = {**start_vars,
             "pf_form": ((), pf_form, {"units": "1", "long_name": "Phi(-beta) of the nearest "
                                       "design point"}),
             "dbeta_dmean": (("parameter",), d_mean, {"units": "per parameter unit", "long_name":
                             "d beta / d mean_i (shift of marginal i)"}),
             "dbeta_dstd": (("parameter",), d_std, {"units": "per parameter unit", "long_name":
                            "d beta / d std_i (scaling of marginal i about its mean)"}),
             "dpf_dmean": (("parameter",), -stats.norm.pdf(beta) * d_mean,
                           {"units": "per parameter unit", "long_name": "d pf_FORM / d mean_i"}),
             "dpf_dstd": (("parameter",), -stats.norm.pdf(beta) * d_std,
                          {"units": "per parameter unit", "long_name": "d pf_FORM / d std_i"})}
    message, attrs, pf_multi = "", {}, math.nan
    if len(found) > 1:
        pf_multi = _series_form(found)
        extra["pf_multi_design_points"] = ((), pf_multi, {"units": "1", "long_name": (
            "series-system FORM over all design points found, 1 - Phi_k(beta; R), "
            "R_ij = alpha_i . alpha_j")})
        message = (f"the starting points found {len(found)} different design points (beta = "
                   f"{', '.join(format(p['beta'], '.4g') for p in found)}); pf is the "
                   f"series FORM over all of them, {pf_multi:.4g} (the nearest alone: "
                   f"{pf_form:.4g})")
        attrs["multiple_design_points"] = len(found)
    reasons: list[Reason] = search_reasons(starts, len(found))
    status = 0 if best["converged"] else 1
    pf = pf_multi if len(found) > 1 and math.isfinite(pf_multi) else pf_form
    if second_order:
        if len(found) > 1:
            reasons.append((8, f"SORM corrects the nearest of {len(found)} design points only; "
                            f"the series FORM over all of them is {pf_multi:.4g}"))
        try:
            pf, sorm_vars, sorm_status, sorm_msg = _sorm(ev, best, s)
        except _ModelFailure as exc:
            return failure_report(ev, method, pf=math.nan, status=2, message=str(exc),
                                  wall_time=time.perf_counter() - t0, design_points=found,
                                  extra=extra, **common)
        extra.update(sorm_vars)
        status = max(status, sorm_status)
        message = "; ".join(m for m in (message, sorm_msg) if m)
    return failure_report(ev, method, pf=pf, status=status, message=message, reasons=reasons,
                          wall_time=time.perf_counter() - t0, design_points=found, extra=extra,
                          extra_attrs=attrs, **common)


def no_design_point_reason(starts: list[dict[str, Any]], s: Mapping[str, Any]
                           ) -> tuple[int, str]:
    """Why no start converged, in one sentence, and what to use instead.

    Returns ``(status, sentence)``: status 2 when the model failed at every start, else 1.
    """
    n = len(starts)
    failed = sum(1 for r in starts if r["error"].startswith("model failed"))
    flat = sum(1 for r in starts if r["error"].startswith("zero gradient"))
    cycling = [r for r in starts if not r["error"]]
    parts = []
    if cycling:
        ratios = [abs(r["g"]) / abs(r["g_start"]) for r in cycling
                  if math.isfinite(r["g"]) and r["g_start"]]
        best = f" (the closest reached |G| = {min(ratios):.2g} |G(start)|)" if ratios else ""
        parts.append(f"{len(cycling)} ran out of max_iter={s['max_iter']} iterations without "
                     f"settling on a point of G = 0{best}")
    if flat:
        parts.append(f"{flat} stopped where the limit state is flat (zero gradient)")
    if failed:
        parts.append(f"{failed} stopped where the model failed (attrs start_errors)")
    if failed == n:
        advice = "the model fails near the failure domain: look at its errors first"
    elif cycling:
        advice = ("a limit state that is kinked, windowed or made of several modes makes the "
                  "design-point iteration cycle: use subset simulation (method='subset')")
    else:
        advice = ("the limit state gives FORM no gradient to follow: use subset simulation "
                  "(method='subset')")
    sentence = (f"FORM found no design point: of its {n} starts, " + ", ".join(parts)
                + f"; {advice}")
    return (2 if failed == n else 1), sentence


def resolve_starts(ev: LimitStateEvaluator, s: Mapping[str, Any]) -> dict[str, Any]:
    """Settings with ``n_starts`` resolved ('auto': by the dimension)."""
    n = s["n_starts"]
    if n == "auto":
        n = 13 if ev.dim == 2 else 21 if ev.dim == 3 else 2 * ev.dim + 5 if ev.dim <= 5 else 11
    return {**s, "n_starts": n}


def search_reasons(starts: list[dict[str, Any]], n_found: int) -> list[Reason]:
    """Status 8 when the multi-start search may have missed design points (Good-Turing:
    a design point reached by one start only, or a start that did not converge), or when
    the probes for hidden failure regions found one (``starts[0]["hidden_notes"]``)."""
    reached = [r["design_point"] for r in starts if r["converged"]]
    counts = np.bincount(np.asarray(reached, dtype=int), minlength=n_found) if reached else \
        np.zeros(n_found, dtype=int)
    singles = int(np.sum(counts == 1))
    lost = sum(1 for r in starts if not r["converged"])
    hidden: list[Reason] = [(8, note) for note in (starts[0].get("hidden_notes", [])
                                                     if starts else [])]
    if len(starts) == 1:
        return [(8, "one FORM start: other design points, if any, were not looked for "
                 "(n_starts='auto' or more)")] + hidden
    if singles == 0 and lost == 0:
        return hidden
    parts = []
    if singles:
        parts.append(f"{singles} of {n_found} design point(s) were reached by one start only "
                     f"(Good-Turing: a further start finds a new one with probability about "
                     f"{singles / max(len(reached), 1):.2f})")
    if lost:
        parts.append(f"{lost} of {len(starts)} start(s) did not converge and may lead to "
                     "a design point not found")
    return [(8, "the design-point search may have missed failure regions: " + "; ".join(parts)
             + "; raise n_starts or check with subset simulation")] + hidden


def form_design_points(ev: LimitStateEvaluator, s: Mapping[str, Any], seed: int
                       ) -> tuple[list[dict[str, Any]], list[dict[str, Any]]]:
    """Run the iHLRF search from every start; return the distinct converged design points
    (nearest first) and the per-start records."""
    rng = np.random.default_rng(np.random.SeedSequence([seed, 7]))
    ev.calibrate_scales()  # a system: components in any units weigh alike in its g
    starts = []
    directions = []
    g_origin = None
    spread = _spread_directions(ev.dim, s["n_starts"] - 1, rng)
    for k in range(s["n_starts"]):
        if k == 0:
            u0 = np.zeros(ev.dim)
        elif spread is not None:
            u0 = s["start_radius"] * spread[k - 1]
        elif k <= 2 * ev.dim and s["n_starts"] > 2 * ev.dim:
            # all +-axes when there are starts for all of them: a spread random directions
            # may not give; fewer starts than axes go in random directions instead
            u0 = np.zeros(ev.dim)
            u0[(k - 1) // 2] = s["start_radius"] * (1.0 if k % 2 else -1.0)
        else:
            direction = rng.standard_normal(ev.dim)
            u0 = s["start_radius"] * direction / np.linalg.norm(direction)
        if k:
            directions.append(u0 / max(float(np.linalg.norm(u0)), 1e-300))
        rec = design_point_search(ev, u0, s, f"form/start{k}")
        if k == 0 and math.isfinite(rec["g_start"]):
            g_origin = rec["g_start"]
        sign = -1.0 if (g_origin is not None and g_origin <= 0) else 1.0
        rec["beta"] = sign * float(np.linalg.norm(rec["u"]))
        starts.append(rec)
    converged = [r for r in starts if r["converged"]]
    origin_safe = g_origin is not None and g_origin > 0
    if origin_safe and ev.series_leaves:
        converged += _component_points(ev, s)
    found = _distinct(converged, s["distinct"])
    if origin_safe and found and directions:
        found, notes = _probe_hidden_regions(ev, s, found, np.array(directions))
        # kept with the starts, so every method built on this search reports them
        starts[0]["hidden_notes"] = hidden_mode_notes(found, notes, ev)
    for r in starts:  # which design point each converged start reached (-1: none)
        r["design_point"] = -1
        if r["converged"]:
            dist = [np.linalg.norm(r["u"] - q["u"]) for q in found]
            r["design_point"] = int(np.argmin(dist))
    return found, starts


def _component_points(ev: LimitStateEvaluator, s: Mapping[str, Any]) -> list[dict[str, Any]]:
    """Each component's own design point (a search from the origin on its ``g`` alone).

    In a series system every component's failure set lies in the system's, so its design
    point is one of the system's, whatever the units of its ``g``; a search on the system's
    ``g`` (a minimum) can be led past it by a component in larger or smaller units.
    """
    out = []
    for k, leaf in enumerate(ev.leaves):
        rec = design_point_search(ev.component(k), np.zeros(ev.dim), s, f"form/component{k}")
        if rec["converged"] and math.isfinite(rec["g_start"]) and rec["g_start"] > 0:
            rec["beta"] = float(np.linalg.norm(rec["u"]))
            rec["source"] = f"component {leaf.name}"
            out.append(rec)
    return out


#: Radii of the probes for hidden failure regions, in units of the nearest design point's
#: beta: inside it (a failing probe there proves a nearer failure point) and beyond it (a
#: failing probe that no design point's half-space explains is a region the starts missed).
PROBE_RADII = (0.95, 1.1, 1.25)


def _explained(found: list[dict[str, Any]], points: np.ndarray) -> np.ndarray:
    """Whether the half-space of some design point found (FORM's picture) holds each point,
    within 2 % of its beta (the search's own tolerance and its finite differences)."""
    alphas = np.array([p["u"] / p["beta"] for p in found])
    betas = np.array([p["beta"] for p in found])
    return np.any(points @ alphas.T >= 0.98 * betas[None, :], axis=1)


def _probe_hidden_regions(ev: LimitStateEvaluator, s: Mapping[str, Any],
                          found: list[dict[str, Any]], directions: np.ndarray
                          ) -> tuple[list[dict[str, Any]], list[str]]:
    """Look for failure that the design points found do not explain; search from it.

    Probes along the start directions at :data:`PROBE_RADII` times the nearest beta
    (``3 (n_starts - 1)`` runs per round), together with the nearest failing run seen so far.
    A failing point outside every found design point's half-space starts a new search; a new
    design point found that way is kept with ``source = "probe"`` (the starts missed it: a
    hidden mode). A curved limit state sends the search back to a known design point, which
    is not a hidden mode and ends the probing. Returns the design points and, in words, the
    failing points FORM's picture still does not explain.
    """
    for rnd in range(3):
        beta = found[0]["beta"]
        pts = np.vstack([r * beta * directions for r in PROBE_RADII])
        pts = pts[ev.in_range(pts)]
        if pts.size == 0:
            return found, []
        res = ev.evaluate(pts, f"form/probe{rnd}")
        failing = pts[(res["status"] == 0) & (res["g"] <= 0.0)]
        r_seen, u_seen = ev.nearest_failure
        if math.isfinite(r_seen):
            failing = np.vstack([failing, u_seen[None, :]])
        unexplained = failing[~_explained(found, failing)] if failing.size else failing
        if unexplained.size == 0:
            return found, []
        u0 = unexplained[int(np.argmin(np.linalg.norm(unexplained, axis=1)))]
        rec = design_point_search(ev, u0, s, f"form/probe{rnd}/search")
        if not rec["converged"]:
            return found, [
                f"a failing point at distance {np.linalg.norm(u0):.3g} from the origin lies "
                f"outside every design point's half-space and the search from it did not "
                f"converge (a kink where margins in different units meet?): the failure "
                f"region there is not in pf"]
        rec["beta"] = float(np.linalg.norm(rec["u"]))
        rec["source"] = "probe"
        rec["probe_point"] = u0
        merged = _distinct(found + [rec], s["distinct"])
        if not any(p is rec for p in merged):
            # back to a known design point: the failing point stays outside FORM's picture
            # (a strongly curved boundary, or a mode the search slides off at a kink)
            angle = math.degrees(math.acos(np.clip(
                u0 @ found[0]["u"] / (np.linalg.norm(u0) * found[0]["beta"]), -1.0, 1.0)))
            return found, [
                f"a failing point at distance {np.linalg.norm(u0):.3g} from the origin, "
                f"{angle:.0f} degrees from the nearest design point, lies outside every "
                f"design point's half-space, and the search from it slid back to a known "
                f"design point: the design points miss failure there and pf may be low"]
        found = merged
    return found, []


def hidden_mode_notes(found: list[dict[str, Any]], notes: list[str],
                      ev: LimitStateEvaluator) -> list[str]:
    """In words: design points only the probes found, and failure they leave unexplained."""
    hidden = [p for p in found if p.get("source") == "probe"]
    advice = ("write it as a SeriesSystem of its components, which are then analysed one by "
              "one" if not ev.is_system else "check the components' units and limits")
    out = [f"{note}; {advice}" for note in notes]
    if hidden:
        betas = ", ".join(f"{p['beta']:.3g}" for p in hidden)
        out.append(f"no start reached the design point(s) at beta = {betas}: a failing point "
                   f"that none of the others explains led to them, so the limit state has "
                   f"modes its starts do not see (a minimum of margins in different units?); "
                   f"they are included, but others may hide the same way: {advice}")
    return out


def _spread_directions(dim: int, n: int, rng: np.random.Generator) -> np.ndarray | None:
    """Evenly spread unit directions in 2 or 3 dimensions (randomly rotated), else None.

    In the plane ``n`` equally spaced angles, in space a Fibonacci lattice: every sector of
    the sphere gets a start, where the +- axes and a few random directions can leave a
    design point's basin without one (the four-branch system lost one of four that way in a
    third of the seeds).
    """
    if dim not in (2, 3) or n < 2 * dim + 2:
        return None
    if dim == 2:
        angle = rng.uniform(0.0, 2 * np.pi) + 2 * np.pi * np.arange(n) / n
        return np.column_stack([np.cos(angle), np.sin(angle)])
    i = np.arange(n) + 0.5
    z = 1.0 - 2.0 * i / n
    phi = np.pi * (3.0 - np.sqrt(5.0)) * i
    r = np.sqrt(1.0 - z * z)
    pts = np.column_stack([r * np.cos(phi), r * np.sin(phi), z])
    q, _ = np.linalg.qr(rng.standard_normal((3, 3)))
    return pts @ q.T


def _sorm(ev: LimitStateEvaluator, best: dict[str, Any], s: Mapping[str, Any]
          ) -> tuple[float, dict[str, tuple], int, str]:
    """Curvatures and the three SORM formulas at the nearest design point."""
    hess, grad = _hessian(ev, best["u"], best["g"], s["hessian_step"], "sorm/hessian")
    kappa = curvatures(hess, grad)
    probs = sorm_probabilities(best["beta"], kappa)
    status, msg = 0, ""
    if not math.isfinite(probs[s["formula"]]):
        status = 5
        msg = (f"SORM {s['formula']} is not defined here (1 + beta kappa <= 0 for some "
               f"curvature, kappa = {kappa}); the failure domain curves too strongly towards "
               "the origin: use importance sampling or subset simulation")
    out = {f"pf_{k}": ((), v, {"units": "1", "long_name": f"SORM ({k}) failure probability"})
           for k, v in probs.items()}
    out["curvature"] = (("curvature",), kappa, {"units": "1", "long_name": (
        "principal curvatures of G = 0 at the design point (standard normal space; positive: "
        "curving away from the origin)")})
    return probs[s["formula"]], out, status, msg
