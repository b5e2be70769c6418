"""Polynomial chaos as design -> evaluate -> fit, and Monte Carlo against the surrogate.

:func:`polynomial_chaos` draws a design (:func:`chaos_design`), evaluates it through
:func:`gearuq.execution.evaluate_chunks` (the chunked, storable, resumable path every engine
uses) and fits a :class:`~gearuq.engines.pce.surrogate.PolynomialChaos` on the result.
:func:`compare_mc_surrogate` puts a Monte Carlo reference and a surrogate side by side on one
model with one set of model options.
"""

from __future__ import annotations

import math
import os
import time
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import Any

import chaospy as cp
import numpy as np
import xarray as xr

from gearuq.engines.pce.basis import Germ, multi_indices
from gearuq.engines.pce.surrogate import ChaosSettings, PolynomialChaos
from gearuq.model import Model, Request
from gearuq.runs import (
    check_positive_int,
    merge_model_options,
    provenance,
    resolve_model_and_space,
    resolve_seed,
    route_keywords,
    space_json,
)
from gearuq.space import RULES, ParameterSpace

__all__ = ["polynomial_chaos", "chaos_design", "compare_mc_surrogate", "surrogate_reliability"]


def chaos_design(space: ParameterSpace, settings: ChaosSettings, *, n_samples: int | None,
                 rule: str, seed: int, sparse_grid: bool = False, oversampling: float = 2.0
                 ) -> tuple[dict[str, np.ndarray], np.ndarray | None, dict[str, Any]]:
    """The design of a chaos fit: physical points, quadrature weights (or None), description.

    Regression/sparse: ``n_samples`` points of ``rule`` (default ``ceil(oversampling x P)``
    with ``P`` the basis size of the largest degree, rounded up to a power of 2 for Sobol').
    Quadrature: the Gauss tensor grid, or the Smolyak sparse grid, of the germ.

    Raises
    ------
    ValueError
        Unknown rule, a bad ``n_samples``, or a regression design not larger than the basis.
    """
    germ = Germ(space, settings.germ)
    d = space.dim
    if settings.method == "quadrature" and n_samples is not None:
        # the quadrature's nodes follow from the order alone: a count would be ignored
        raise ValueError(f"n_samples={n_samples!r} does not apply to method='quadrature' (its "
                         "nodes follow from the order); leave it out, or use method="
                         "'regression' or 'sparse'")
    if settings.method == "quadrature":
        nodes, weights = cp.generate_quadrature(int(settings.order), germ.joint(),
                                                rule="gaussian", sparse=bool(sparse_grid))
        z = np.asarray(nodes, dtype=float).T.reshape(-1, d)
        info = {"rule": "smolyak" if sparse_grid else "gauss_tensor", "n_design": z.shape[0]}
        return germ.to_physical(z), np.asarray(weights, dtype=float), info
    if not isinstance(rule, str) or rule.lower() not in RULES:
        raise ValueError(f"rule: unknown sampling rule {rule!r}; valid: {', '.join(RULES)}")
    rule = rule.lower()
    orders = settings.orders
    n_terms = [multi_indices(d, p, settings.truncation).shape[0] for p in (orders[0],
                                                                           orders[-1])]
    if n_samples is None:
        if not oversampling > 0:
            raise ValueError(f"oversampling: must be positive, got {oversampling!r}")
        n = int(math.ceil(oversampling * n_terms[1]))
        if rule == "sobol":  # Sobol' balance needs a power of 2
            n = 1 << (n - 1).bit_length()
    else:
        if isinstance(n_samples, (bool, np.bool_)) or not isinstance(
                n_samples, (int, np.integer)) or n_samples < 1:
            raise ValueError(f"n_samples: expected a positive integer, got {n_samples!r}")
        n = int(n_samples)
    if settings.method == "regression" and n <= n_terms[0]:
        raise ValueError(
            f"n_samples: design of {n} samples is not larger than the basis of {n_terms[0]} "
            f"terms (order {orders[0]}, {d} parameters); give n_samples > {n_terms[0]} "
            "(typically 2-3x) or use method='sparse'")
    if settings.method == "sparse" and n < 3:
        raise ValueError(f"n_samples: sparse regression needs at least 3 samples, got {n}")
    z = germ.from_unit(space.sample_unit(n, rule, seed))
    return germ.to_physical(z), None, {"rule": rule, "n_design": n}


def _substore(store: str | os.PathLike | None, name: str) -> Path | None:
    return None if store is None else Path(store) / name


def polynomial_chaos(
    model: Model | str,
    space: ParameterSpace | Mapping[str, Any] | None,
    t: Any = None,
    *,
    order: int | str,
    method: str = "regression",
    outputs: str | Iterable[str] | None = None,
    n_samples: int | None = None,
    rule: str = "sobol",
    rng: Any = None,
    sparse_grid: bool = False,
    truncation: float = 1.0,
    compress: int | float | None = None,
    executor: Any = None,
    oversampling: float = 2.0,
    solver: str = "lars",
    max_order: int = 6,
    n_holdout: int = 0,
    germ: str = "auto",
    chunk_size: int | None = None,
    progress: bool | None = False,
    store: str | os.PathLike | None = None,
    model_options: Mapping[str, Any] | None = None,
    **options: Any,
) -> PolynomialChaos:
    # Long only by its documented keywords; the body is three calls: design, evaluate, fit.
    """Fit a polynomial chaos surrogate of ``model`` over ``space``: design, evaluate, fit.

    Parameters
    ----------
    model : Model or str
        Model instance or registered name.
    space : ParameterSpace, mapping or None
        Random inputs (names must be model parameters; the others stay nominal; ``None``:
        the model's default space).
    t : array_like, optional
        Output instants (required for time-dependent outputs); the surrogate is fitted on
        them, all instants at once.
    order : int or "auto"
        Total polynomial degree (>= 0); ``"auto"``: the degree in ``1..max_order`` with the
        smallest (corrected, for sparse) leave-one-out error on one design, tried upwards and
        stopped after two degrees without improvement (regression and sparse only).
    method : {"regression", "sparse", "quadrature"}
        Least squares, hybrid LAR/OMP sparse least squares, or spectral projection.
    outputs : str or list of str, optional
        Outputs to fit (default: all). Each has its own coefficients; design and basis are
        shared.
    n_samples : int, optional
        Design size for regression/sparse (default ``ceil(oversampling * P)`` with ``P`` the
        basis size, of the largest degree for ``order="auto"``). Regression needs
        ``n_samples > P``.
    rule : {"random", "lhs", "sobol", "halton"}
        Design rule (scrambled Sobol' by default).
    rng : int, Generator or None
        Seed of the design (the hold-out set uses ``seed + 1``). ``None`` draws a fresh
        seed; it is recorded in ``fit_info["seed"]``.
    sparse_grid : bool
        Quadrature: Smolyak sparse grid instead of the Gauss tensor grid.
    truncation, compress, solver, max_order, germ
        Fitting settings, see :class:`~gearuq.engines.pce.surrogate.ChaosSettings`.
    executor, chunk_size, progress
        Passed to :func:`gearuq.execution.evaluate_chunks`.
    oversampling : float
        Default design size over basis size for regression / sparse.
    n_holdout : int
        Size of an independent random validation set (0: none); its relative error is
        stored in ``holdout_error`` and its evaluations are counted.
    store : path-like, optional
        Directory for a durable, resumable run: the design is evaluated into
        ``store/design`` and the hold-out set into ``store/holdout`` (chunk stores of
        :func:`gearuq.execution.evaluate_chunks`); calling again with the same arguments
        (same ``rng`` seed!) reuses every stored chunk.
    model_options : mapping, optional
        Declared model options (solver/fidelity settings, see ``gearuq models NAME``); every
        engine accepts this spelling, validated before the design is drawn.
    **options
        Deprecated: model options as keywords (still accepted for one release, with a
        DeprecationWarning naming the ``model_options={...}`` spelling to use).

    Returns
    -------
    PolynomialChaos

    Raises
    ------
    ValueError
        Negative or non-integer order, unknown method/rule/solver, parameters not in the model,
        a design smaller than the basis, bad options or outputs, no valid sample.
    """
    from gearuq.execution import evaluate_chunks

    wall0 = time.perf_counter()
    model, space = resolve_model_and_space(model, space)
    pce = PolynomialChaos(space, order=order, method=method, truncation=truncation,
                          max_order=max_order, solver=solver, compress=compress, germ=germ)
    options = merge_model_options(model_options, options, "polynomial_chaos")
    request = model.prepare(t, outputs=outputs, **options)
    n_holdout = 0 if not n_holdout else check_positive_int("n_holdout", n_holdout)
    seed = resolve_seed(rng)
    design, weights, info = chaos_design(space, pce.settings_, n_samples=n_samples, rule=rule,
                                         seed=seed, sparse_grid=sparse_grid,
                                         oversampling=oversampling)
    try:
        model.validate_params(design)
    except ValueError as exc:
        raise ValueError(f"design: {exc}") from None
    fingerprint = {"engine": "polynomial_chaos", "space": space_json(space), "seed": seed,
                   **info}
    t_eval = time.perf_counter()
    ds = evaluate_chunks(model, design, request, chunk_size=chunk_size, executor=executor,
                         store=_substore(store, "design"), progress=progress,
                         fingerprint=fingerprint)
    t_eval = time.perf_counter() - t_eval
    pce.fit(ds, outputs=list(request.outputs), weights=weights)
    pce.fitted.info.update({**info, "seed": seed, "model_time_s": t_eval,
                            "options": request.options_json()})
    if n_holdout:
        xh = space.sample(n_holdout, "random", seed + 1)
        dh = evaluate_chunks(model, xh, request, executor=executor, progress=progress,
                             store=_substore(store, "holdout"),
                             fingerprint={**fingerprint, "role": "holdout"})
        pce.validate(dh, outputs=list(request.outputs))
    pce.fitted.info["wall_time_s"] = time.perf_counter() - wall0
    return pce


def surrogate_reliability(pce: PolynomialChaos, space: ParameterSpace | None, bands: Any,
                          **kwargs: Any) -> xr.Dataset:
    """Reliability from a surrogate on many samples; ``pce.reliability`` with an optional space.

    ``space`` (if given) must have the surrogate's names; it then replaces the sampling
    distribution (e.g. a shifted design for what-if studies).
    """
    return pce.reliability(bands, space=space, **kwargs)


#: Keywords of :func:`polynomial_chaos` that :func:`compare_mc_surrogate` passes to the fit;
#: any other keyword is a model option (deprecated spelling) and goes to both sides.
_FIT_KEYWORDS = frozenset({
    "order", "method", "n_samples", "rule", "sparse_grid", "truncation", "compress",
    "oversampling", "solver", "max_order", "n_holdout", "germ", "chunk_size", "progress",
})


def compare_mc_surrogate(
    model: Model | str,
    space: ParameterSpace | None,
    bands: Any,
    t: Any = None,
    *,
    n_mc: int,
    n_surrogate: int = 10**6,
    rng: int = 0,
    executor: Any = None,
    confidence: float = 0.95,
    mc: xr.Dataset | None = None,
    mc_wall_time: float | None = None,
    model_options: Mapping[str, Any] | None = None,
    **keywords: Any,
) -> xr.Dataset:
    """Monte Carlo and PCE-surrogate failure probabilities side by side, for one model.

    Model options are validated once, here, and used for both the Monte Carlo reference and
    the surrogate's design, so both sides describe the same model.

    Parameters
    ----------
    model, space, t
        As in :func:`polynomial_chaos`.
    bands
        Failure modes (see :func:`gearuq.reliability`); the outputs they name
        are fitted.
    n_mc : int
        Monte Carlo samples of the model (ignored when ``mc`` is given).
    n_surrogate : int
        Samples of the surrogate.
    rng : int
        Seed (Monte Carlo uses ``rng``, the design ``rng + 1``, the surrogate draw ``rng + 2``).
    mc, mc_wall_time : optional
        A precomputed Monte Carlo result and its wall time (reused as reference; it must
        have been computed with the same model options).
    model_options : mapping, optional
        Model options, used on both sides.
    **keywords
        Fitting settings of :func:`polynomial_chaos` (``order``, ``method`` (default
        ``"regression"``), ``n_samples``, ``rule``, ...). Deprecated: any other keyword is
        taken as a model option, with a DeprecationWarning naming the ``model_options={...}``
        spelling. A name that is both a fitting setting and an option of the model is
        refused unless ``model_options`` also holds it (then the keyword is the fit's).

    Returns
    -------
    xarray.Dataset
        Over ``approach`` (``monte_carlo``, ``pce``) and ``mode``: ``pf``, ``pf_lower``,
        ``pf_upper``; over ``approach``: ``n_model_evaluations``, ``wall_time``; over
        ``mode``: ``pce_in_mc_interval``; ``pce_loo_error``. Attributes: the shared
        ``options`` (JSON), the surrogate, its fit time, ``evaluation_ratio``. Times are for
        this machine only.

    Raises
    ------
    ValueError
        Unknown or invalid model options (before anything is evaluated), or a precomputed
        ``mc`` made with other options.
    """
    from gearuq.engines.montecarlo import monte_carlo
    from gearuq.failure.modes import as_bands
    from gearuq.failure.samples import reliability

    model, space = resolve_model_and_space(model, space)
    fit_kw, options = route_keywords("compare_mc_surrogate", model, model_options, keywords,
                                     _FIT_KEYWORDS, legacy_model_options=True)
    fit_kw.setdefault("order", 2)
    band_list = as_bands(bands)
    outs = list(dict.fromkeys(b.output for b in band_list))
    request = model.prepare(t, outputs=outs, **options)  # once, before any evaluation
    if mc is None:
        t0 = time.perf_counter()
        mc = monte_carlo(model, space, t, n_samples=n_mc, rng=rng, outputs=outs,
                         executor=executor, progress=False, model_options=options)
        mc_wall_time = time.perf_counter() - t0
    elif mc.attrs.get("options", request.options_json()) != request.options_json():
        raise ValueError(f"mc: computed with model options {mc.attrs['options']}, the "
                         f"surrogate would use {request.options_json()}; give the same options")
    rel_mc = reliability(mc, band_list, confidence=confidence)
    t0 = time.perf_counter()
    pce = polynomial_chaos(model, space, t, outputs=outs, rng=rng + 1, executor=executor,
                           **fit_kw, model_options=options)
    t_fit = time.perf_counter() - t0
    rel_pce = pce.reliability(band_list, n_samples=n_surrogate, rng=rng + 2,
                              confidence=confidence)
    return _comparison(rel_mc, rel_pce, mc, pce, outs, {
        "mc": float(mc_wall_time or math.nan), "pce": time.perf_counter() - t0,
        "fit": t_fit}, n_surrogate, confidence, model, request, space, rng)


def _comparison(rel_mc: xr.Dataset, rel_pce: xr.Dataset, mc: xr.Dataset, pce: PolynomialChaos,
                outs: list[str], wall: dict[str, float], n_surrogate: int, confidence: float,
                model: Model, request: Request, space: ParameterSpace, rng: int
                ) -> xr.Dataset:
    if "time" in rel_mc.dims:
        rel_mc = rel_mc.isel(time=-1)
        rel_pce = rel_pce.isel(time=-1)
    out = xr.Dataset(coords={"approach": ["monte_carlo", "pce"], "mode": rel_mc["mode"].values})
    for k in ("pf", "pf_lower", "pf_upper"):
        out[k] = (("approach", "mode"), np.stack([rel_mc[k].values, rel_pce[k].values]))
    out["n_model_evaluations"] = ("approach", [int(mc.sizes["sample"]), pce.n_evaluations])
    out["wall_time"] = ("approach", [wall["mc"], wall["pce"]],
                        {"units": "s", "long_name": "wall time on this machine"})
    inside = (rel_pce["pf"].values >= rel_mc["pf_lower"].values) & (
        rel_pce["pf"].values <= rel_mc["pf_upper"].values)
    out["pce_in_mc_interval"] = ("mode", inside.astype(np.int8))
    out["pce_loo_error"] = float(np.mean([pce.loo_error[o] for o in outs]))
    out.attrs.update(provenance("compare_mc_surrogate", model, request, space, rng))
    out.attrs.update({"pce": pce.description, "pce_fit_time_s": wall["fit"],
                      "n_surrogate_samples": int(n_surrogate), "confidence": confidence,
                      "evaluation_ratio": pce.n_evaluations / int(mc.sizes["sample"]),
                      **pce._status_attrs()})
    return out
