"""Monte Carlo / Latin hypercube / quasi-Monte Carlo evaluation of a model over a space.

:func:`monte_carlo` draws the whole design once from one integer seed, evaluates the model on
it in chunks through an executor (:mod:`gearuq.execution`) and returns every sample with its
provenance. :func:`estimate_mean` turns the samples into a mean with standard error,
confidence interval and coefficients of variation.
"""

from __future__ import annotations

import os
from collections.abc import Iterable, Mapping
from typing import Any

import numpy as np
import xarray as xr
from scipy import stats

from gearuq._checks import check_bool
from gearuq.execution import evaluate_chunks
from gearuq.model import Model
from gearuq.runs import (
    check_positive_int,
    merge_model_options,
    provenance,
    resolve_model_and_space,
    resolve_seed,
    space_json,
)
from gearuq.space import RULES, ParameterSpace

__all__ = ["monte_carlo", "estimate_mean", "resolve_seed", "resolve_model_and_space",
           "draw_design"]


def draw_design(model: Model, space: ParameterSpace, n_samples: int, rule: str,
                seed: int) -> dict[str, np.ndarray]:
    """Draw a design once and check it against the model's valid ranges.

    Raises
    ------
    ValueError
        Unknown rule, or draws outside the model's valid range (the message gives the
        probability mass outside the range and how to truncate).
    """
    if not isinstance(rule, str) or rule.lower() not in RULES:
        raise ValueError(f"rule: unknown sampling rule {rule!r}; valid: {', '.join(RULES)}")
    from gearuq.execution.driver import _fmt_bytes, available_memory

    # the design is drawn whole (a store bounds the outputs' memory, not the design's): one
    # that cannot be held is refused by name instead of numpy's MemoryError
    need = float(n_samples) * len(model.parameter_names) * 8 * 2  # draws and their copy
    available = available_memory()
    if need > available:
        raise ValueError(f"n_samples: {n_samples} samples of {len(model.parameter_names)} "
                         f"parameters need about {_fmt_bytes(need)} for the design alone, more "
                         f"than the {_fmt_bytes(available)} of memory available; "
                         "run fewer samples (several runs with their own seeds pool)")
    design = space.sample(n_samples, rule=rule.lower(), rng=seed)
    try:
        model.validate_params(design)
    except ValueError as exc:
        outside = {k: p for k, p in space.check_range(model).items() if p > 0}
        hint = ""
        if outside:
            hint = ("; probability outside the valid range: "
                    + ", ".join(f"{k}: {p:.3g}" for k, p in outside.items())
                    + ". Truncate the distribution (truncnormal, or "
                    "ParameterSpace.around_nominal(..., outside='truncate'))")
        raise ValueError(f"{exc}{hint}") from None
    return design


def monte_carlo(
    model: Model | str,
    space: ParameterSpace | Mapping[str, Any],
    t: Any = None,
    *,
    n_samples: int,
    rule: str = "random",
    rng: Any = None,
    outputs: str | Iterable[str] | None = None,
    executor: Any = None,
    chunk_size: int | None = None,
    store: str | os.PathLike | None = None,
    progress: bool | None = None,
    memory_limit: float | None = None,
    model_options: Mapping[str, Any] | None = None,
    **options: Any,
) -> xr.Dataset:
    """Evaluate a model on ``n_samples`` draws of a parameter space.

    Parameters
    ----------
    model : Model or str
        A model instance or a registered model name.
    space : ParameterSpace, mapping or None
        Random parameters (a mapping is passed to :class:`ParameterSpace`; ``None`` takes
        the model's ``default_space()``). Model parameters not in the space take their
        nominal values.
    t : array_like, optional
        Output instants (required for time-dependent outputs).
    n_samples : int
        Number of samples (> 0).
    rule : {"random", "lhs", "sobol", "halton"}
        Sampling rule: crude Monte Carlo, Latin hypercube, scrambled Sobol' (use a power of 2)
        or scrambled Halton.
    rng : int, numpy.random.Generator or None
        Seed. ``None`` draws a seed from OS entropy; the seed used is always recorded in
        ``attrs["seed"]`` and reproduces the run.
    outputs : str or list of str, optional
        Outputs to compute and keep (default: all).
    executor : optional
        ``"serial"``, ``"processes"``, a dask ``Client`` or scheduler address, a
        ``concurrent.futures.Executor``; see :func:`gearuq.execution.resolve_executor`.
        ``None`` chooses from a timed first chunk (the choice and reason are recorded).
        Results are bit-identical whatever the executor and chunk size.
    chunk_size : int, optional
        Samples per chunk (default :func:`gearuq.execution.default_chunk_size`).
    store : path-like, optional
        Directory for a durable run: each finished chunk is written there (by the worker
        that computed it), an interrupted run resumes from it when called again with the
        same arguments (same ``rng`` seed!), and the result is loaded lazily from it, so
        memory stays bounded whatever ``n_samples``. See :func:`gearuq.execution.evaluate_chunks`.
    progress : bool, optional
        Progress bar: ``True`` always, ``False`` never, ``None`` only for runs past 2 s.
    memory_limit : float, optional
        Bytes an in-memory result may take (default 60 % of the available memory); a larger
        run without ``store`` is refused before it starts.
    model_options : mapping, optional
        Declared model options (solver/fidelity settings, see ``gearuq models NAME``); every
        engine accepts this spelling, validated before the design is drawn.
    **options
        Deprecated: model options as keywords (still accepted for one release, with a
        DeprecationWarning naming the ``model_options={...}`` spelling to use).

    Returns
    -------
    xarray.Dataset
        Inputs, outputs and ``status`` over ``sample`` (``0..n-1``) and ``time``; attributes
        ``gearuq_version``, ``model``, ``model_version``, ``engine="monte_carlo"``, ``space``
        (JSON), ``rule``, ``seed``, ``n_samples``, ``chunk_size``, ``executor``, ``options``
        (JSON), ``created`` (UTC ISO 8601), ``n_failed`` (samples with nonzero status) and,
        if chunks raised, ``errors`` (JSON).

    Raises
    ------
    ValueError
        Space parameters unknown to the model, ``n_samples`` not a positive integer, an
        unknown rule, draws outside the model's valid range, or bad outputs/``t``.

    Examples
    --------
    >>> import numpy as np, gearuq
    >>> m = gearuq.FunctionModel(lambda a, b: a + b, ["a", "b"], ["y"], name="sum")
    >>> space = gearuq.ParameterSpace.normal(a=(1.0, 0.1), b=(2.0, 0.2))
    >>> ds = monte_carlo(m, space, n_samples=100, rng=1, executor="serial")
    >>> ds.sizes["sample"], ds.attrs["seed"]
    (100, 1)
    """
    model, space = resolve_model_and_space(model, space)
    n_samples = check_positive_int("n_samples", n_samples)
    options = merge_model_options(model_options, options, "monte_carlo")
    request = model.prepare(t, outputs=outputs, **options)
    seed = resolve_seed(rng)
    rule = rule.lower() if isinstance(rule, str) else rule
    design = draw_design(model, space, n_samples, rule, seed)
    ds = evaluate_chunks(
        model, design, request, chunk_size=chunk_size, executor=executor, store=store,
        progress=progress, memory_limit=memory_limit,
        fingerprint={"engine": "monte_carlo", "space": space_json(space), "rule": rule,
                     "seed": seed},
    )
    ds.attrs.update(provenance("monte_carlo", model, request, space, seed, rule=rule,
                               n_samples=n_samples))
    return ds


def estimate_mean(
    ds: xr.Dataset, var: str, confidence: float = 0.95, *, ok_only: bool = True
) -> xr.Dataset:
    """Sample mean of ``ds[var]`` with standard error, confidence interval and CoVs.

    The standard error ``s / sqrt(n)`` assumes independent samples (``rule="random"``). For
    LHS and QMC designs it is conservative; use independent replicates for their error.

    Parameters
    ----------
    ds : xarray.Dataset
        A result with dim ``sample`` (and a ``status`` variable).
    var : str
        Variable to average over ``sample`` (other dims such as ``time`` are kept).
    confidence : float
        Two-sided confidence level of the Student-t interval.
    ok_only : bool
        Use only samples with ``status == 0`` (default).

    Returns
    -------
    xarray.Dataset
        ``mean``, ``std`` (sample standard deviation), ``sem`` (standard error), ``ci_lower``,
        ``ci_upper``, ``cov`` (std / |mean| of the variable), ``rel_se`` (sem / |mean|,
        the coefficient of variation of the estimator) and ``n`` (samples used).
    """
    if var not in ds:
        raise ValueError(f"no variable {var!r}; available: {', '.join(map(str, ds.data_vars))}")
    if not 0 < confidence < 1:
        raise ValueError(f"confidence: must lie in (0, 1), got {confidence}")
    ok_only = check_bool("ok_only", ok_only)
    x = ds[var]
    if "sample" not in x.dims:
        raise ValueError(f"variable {var!r} has no 'sample' dimension")
    if ok_only and "status" in ds:
        x = x.where(ds["status"] == 0)
    # one pass over a lazily loaded (stored) result: the three reductions share its reads
    red = xr.Dataset({"n": x.count("sample"), "mean": x.mean("sample"),
                      "std": x.std("sample", ddof=1)}).compute()
    n, mean, std = red["n"], red["mean"], red["std"]
    if int(n.max()) < 2:
        flagged = int((ds["status"] != 0).sum()) if ok_only and "status" in ds else 0
        raise ValueError(
            f"estimate_mean: {int(n.max())} valid value(s) of {var!r} in {ds.sizes['sample']} "
            f"samples ({flagged} with a nonzero status); a mean with an interval needs at "
            "least 2")
    sem = std / np.sqrt(n)
    q = xr.apply_ufunc(lambda k: stats.t.ppf(0.5 + confidence / 2, np.maximum(k - 1, 1)), n)
    out = xr.Dataset({
        "mean": mean,
        "std": std,
        "sem": sem,
        "ci_lower": mean - q * sem,
        "ci_upper": mean + q * sem,
        "cov": std / abs(mean),
        "rel_se": sem / abs(mean),
        "n": n,
    })
    out.attrs.update({"variable": var, "confidence": confidence,
                      "units": str(ds[var].attrs.get("units", ""))})
    return out
