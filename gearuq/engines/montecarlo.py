"""Monte Carlo / Latin hypercube / quasi-Monte Carlo evaluation of a model over a space.

:func:`monte_carlo` draws the whole design once from one integer seed, evaluates the model on
it in chunks through an executor (:mod:`gearuq.execution`) and returns every sample with its
provenance. :func:`estimate_mean` turns the samples into a mean with standard error,
confidence interval and coefficients of variation.
"""

from __future__ import annotations

import json
import os
from collections.abc import Iterable, Mapping
from datetime import datetime, timezone
from typing import Any

import numpy as np
import xarray as xr
from scipy import stats

from gearuq._version import __version__
from gearuq.execution import default_chunk_size, evaluate_chunks
from gearuq.model import Model
from gearuq.space import RULES, ParameterSpace

__all__ = ["monte_carlo", "estimate_mean", "resolve_seed"]

_MAX_SEED = 2**63 - 1


def resolve_seed(rng: Any = None) -> int:
    """Integer seed to record for a run.

    Parameters
    ----------
    rng : int, numpy.random.Generator, numpy.random.SeedSequence or None
        An int in ``[0, 2**63 - 1]`` is used as is. ``None`` draws one from fresh OS entropy
        (``SeedSequence``); a Generator or SeedSequence gives one deterministically. Either
        way the recorded seed alone reproduces the design.
    """
    if rng is None:
        return int(np.random.SeedSequence().entropy % _MAX_SEED)
    if isinstance(rng, np.random.Generator):
        return int(rng.integers(0, _MAX_SEED))
    if isinstance(rng, np.random.SeedSequence):
        return int(rng.generate_state(1, np.uint64)[0] % _MAX_SEED)
    if isinstance(rng, (bool, np.bool_)) or not isinstance(rng, (int, np.integer)):
        raise ValueError(f"rng: expected an int seed, a numpy Generator or None, got {rng!r}")
    if not 0 <= rng <= _MAX_SEED:
        raise ValueError(f"rng: seed must lie in [0, 2**63 - 1], got {rng}")
    return int(rng)


def _resolve_model(model: Any) -> Model:
    if isinstance(model, str):
        from gearuq.registry import get_model

        model = get_model(model)
    if not isinstance(model, Model):
        raise TypeError(
            f"model: expected a gearuq Model or a registered model name, got "
            f"{type(model).__name__}"
        )
    return model


def resolve_model_and_space(model: Any, space: Any) -> tuple[Any, ParameterSpace]:
    """Resolve a model (instance or registered name) and a space (or a mapping of marginals).

    Raises
    ------
    TypeError
        If ``space`` is neither a ParameterSpace nor a mapping.
    ValueError
        If the space has parameters the model does not know (the message lists both sets).
    """
    model = _resolve_model(model)
    if not isinstance(space, ParameterSpace):
        if isinstance(space, Mapping):
            space = ParameterSpace(space)
        else:
            raise TypeError(f"space: expected a ParameterSpace, got {type(space).__name__}")
    unknown = [k for k in space.names if k not in model.parameter_names]
    if unknown:
        raise ValueError(
            f"space parameter(s) {', '.join(map(repr, unknown))} not in model {model.name!r}; "
            f"model parameters: {', '.join(model.parameter_names)}"
        )
    return model, space


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
    **options: Any,
) -> xr.Dataset:
    """Evaluate a model on ``n_samples`` draws of a parameter space.

    Parameters
    ----------
    model : Model or str
        A model instance or a registered model name.
    space : ParameterSpace or mapping
        Random parameters (a mapping is passed to :class:`ParameterSpace`). Model parameters
        not in the space take their nominal values.
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
        Results are bit-identical whatever the executor and chunk size.
    chunk_size : int, optional
        Samples per chunk (default :func:`gearuq.execution.default_chunk_size`).
    store : path-like, optional
        Directory for a durable run: each finished chunk is written there and an interrupted
        run resumes from it when called again with the same arguments (same ``rng`` seed!).
    progress : bool, optional
        Progress bar: ``True`` always, ``False`` never, ``None`` only for runs past 2 s.
    **options
        Model options (solver/fidelity settings), passed to ``model.response``.

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
    if isinstance(n_samples, (bool, np.bool_)) or not isinstance(n_samples, (int, np.integer)):
        raise ValueError(f"n_samples: expected a positive integer, got {n_samples!r}")
    if n_samples <= 0:
        raise ValueError(f"n_samples: must be positive, got {n_samples}")
    n_samples = int(n_samples)
    if not isinstance(rule, str) or rule.lower() not in RULES:
        raise ValueError(f"rule: unknown sampling rule {rule!r}; valid: {', '.join(RULES)}")
    rule = rule.lower()
    names = model.validate_outputs(outputs)
    need_time = any(model.output(o).time_dependent for o in names)
    t_arr = model.validate_time(t) if (need_time or t is not None) else None
    seed = resolve_seed(rng)
    chunk_size = default_chunk_size(n_samples) if chunk_size is None else chunk_size

    design = space.sample(n_samples, rule=rule, rng=seed)
    try:
        model.validate_params(design)
    except ValueError as exc:
        outside = {k: p for k, p in space.check_range(model).items() if p > 0}
        hint = ""
        if outside:
            hint = (
                "; probability outside the valid range: "
                + ", ".join(f"{k}: {p:.3g}" for k, p in outside.items())
                + ". Truncate the distribution (truncnormal, or "
                "ParameterSpace.around_nominal(..., outside='truncate'))"
            )
        raise ValueError(f"{exc}{hint}") from None

    try:
        space_json = space.to_json()
    except ValueError:
        space_json = repr(space)
    options_json = json.dumps(options, sort_keys=True, default=repr)
    ds = evaluate_chunks(
        model,
        design,
        t_arr,
        names,
        options,
        chunk_size=chunk_size,
        executor=executor,
        store=store,
        progress=progress,
        fingerprint={"engine": "monte_carlo", "space": space_json, "rule": rule, "seed": seed},
    )
    ds.attrs.update({
        "gearuq_version": __version__,
        "model": model.name,
        "model_version": str(model.version),
        "engine": "monte_carlo",
        "space": space_json,
        "rule": rule,
        "seed": seed,
        "n_samples": n_samples,
        "chunk_size": int(ds.attrs.get("chunk_size", chunk_size)),
        "executor": str(ds.attrs.get("executor", "")),
        "options": options_json,
        "model_settings": json.dumps(model.settings(), sort_keys=True, default=repr),
        "created": datetime.now(timezone.utc).isoformat(timespec="seconds"),
        "n_failed": int(np.count_nonzero(ds["status"].values)),
    })
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
    x = ds[var]
    if "sample" not in x.dims:
        raise ValueError(f"variable {var!r} has no 'sample' dimension")
    if ok_only and "status" in ds:
        x = x.where(ds["status"] == 0)
    n = x.count("sample")
    mean = x.mean("sample")
    std = x.std("sample", ddof=1)
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
