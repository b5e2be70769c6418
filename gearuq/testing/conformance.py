"""Conformance checker that every plugin's tests call: ``check_model(model)``."""

from __future__ import annotations

import math
import pickle
import tempfile
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from gearuq.model import Model, Option


def _inside_draws(model: Model, n: int, rng: np.random.Generator) -> dict[str, np.ndarray]:
    """Draws inside each parameter's valid range, near nominal (the plugin's typical use)."""
    out = {}
    for p in model.parameters:
        lo = p.lower if math.isfinite(p.lower) else p.nominal - abs(p.nominal) - 1.0
        hi = p.upper if math.isfinite(p.upper) else p.nominal + abs(p.nominal) + 1.0
        # stay within +-5 % of nominal where the range allows, to keep solvers cheap
        span = 0.05 * abs(p.nominal) if p.nominal != 0 else min(0.05, 0.01 * (hi - lo))
        a, b = max(lo, p.nominal - span), min(hi, p.nominal + span)
        draw = rng.uniform(a, b, n) if b > a else np.full(n, p.nominal)
        out[p.name] = np.clip(np.round(draw), lo, hi) if p.integer else draw
    return out


def check_model(
    model: Model,
    t: Any = None,
    *,
    n_samples: int = 3,
    seed: int = 0,
    options: dict[str, Any] | None = None,
    roundtrip: bool = True,
    route: str = "compiled",
) -> xr.Dataset:
    """Assert that ``model`` honours the gearuq plugin contract.

    Checks metadata (names, units, ranges, nominal inside range), declared options (Option
    instances with descriptions, defaults valid, an unknown option refused by name), the
    default space (its names are parameters and its draws are valid), the Dataset schema of
    ``response`` (dims, units attrs, inputs over ``sample``, ``status``), nominal filling,
    output restriction, sample independence (a sub-batch gives the same numbers), errors for
    unknown parameters, out-of-range values and unknown outputs, a pickle round trip of the
    model and its prepared request (as worker processes receive them), and the netCDF round
    trip.

    Parameters
    ----------
    model : Model
        The model instance to check.
    t : array_like, optional
        Output instants for time-dependent outputs (default ``linspace(0, 1, 5)``).
    n_samples : int
        Number of random in-range samples to evaluate.
    seed : int
        Seed of those samples.
    options : dict, optional
        Options passed to ``response``.
    roundtrip : bool
        Also save and load the result through netCDF.
    route : {"compiled", "interpreted", "auto"}
        The route of every numba kernel's call during the check
        (:func:`gearuq.kernels_route`). The check compares calls bit for bit, and a kernel's
        interpreted and compiled routes agree only to rounding: under ``"auto"`` a small
        first call from an empty cache runs interpreted and a later one compiled, so the
        comparison would see the route change, not the model. One route holds throughout.

    Returns
    -------
    xarray.Dataset
        The response on the random samples (for further plugin-specific checks).

    Raises
    ------
    AssertionError
        With a message naming the violated part of the contract.
    """
    from gearuq._firstcall import kernels_route

    with kernels_route(route):
        return _check_model(model, t, n_samples=n_samples, seed=seed, options=options,
                            roundtrip=roundtrip)


def _check_model(model: Model, t: Any, *, n_samples: int, seed: int,
                 options: dict[str, Any] | None, roundtrip: bool) -> xr.Dataset:
    """:func:`check_model` under the route its caller set."""
    from gearuq import io

    options = options or {}
    for attr in ("name", "description", "version"):
        assert isinstance(getattr(model, attr, None), str) and getattr(model, attr), (
            f"model metadata {attr!r} missing or not a string")
    assert model.parameters, "model declares no parameters"
    assert model.outputs, "model declares no outputs"
    names = [p.name for p in model.parameters]
    assert len(set(names)) == len(names), f"duplicate parameter names {names}"
    for p in model.parameters:
        assert p.units, f"parameter {p.name!r} has no units"
        assert p.lower <= p.nominal <= p.upper, f"parameter {p.name!r} nominal outside range"
    clash = set(names) & {o.name for o in model.outputs}
    assert not clash, f"names used both as parameter and output: {sorted(clash)}"
    for o in model.outputs:
        assert o.units, f"output {o.name!r} has no units"
        assert o.dims[0] == "sample", f"output {o.name!r} dims must start with 'sample'"
    _check_options(model, names)
    if t is None and any(o.time_dependent for o in model.outputs):
        t = np.linspace(0.0, 1.0, 5)
    _check_default_space(model)

    rng = np.random.default_rng(seed)
    draws = _inside_draws(model, n_samples, rng)
    ds = model.response(draws, t, **options)
    assert isinstance(ds, xr.Dataset), "response must return an xarray.Dataset"
    assert ds.sizes.get("sample") == n_samples, "wrong sample dimension size"
    for p in model.parameters:
        assert p.name in ds, f"input {p.name!r} missing from the result"
        assert ds[p.name].dims == ("sample",), f"input {p.name!r} not over 'sample'"
        np.testing.assert_array_equal(ds[p.name].values, draws[p.name])
        assert ds[p.name].attrs.get("units") == p.units, f"input {p.name!r} units attr"
    for o in model.outputs:
        assert o.name in ds, f"output {o.name!r} missing"
        assert ds[o.name].dims == o.dims, f"output {o.name!r} dims {ds[o.name].dims} != {o.dims}"
        assert ds[o.name].attrs.get("units") == o.units, f"output {o.name!r} units attr"
    assert "status" in ds and ds["status"].dims == ("sample",), "status variable missing"
    assert ds["status"].dtype.kind == "i", "status must be integer"
    ok = ds["status"].values == 0
    for o in model.outputs:
        vals = ds[o.name].values.reshape(n_samples, -1)[ok]
        assert np.all(np.isfinite(vals)), f"output {o.name!r} non-finite in a status-0 sample"
    for key in ("model", "model_version", "gearuq_version"):
        assert key in ds.attrs, f"provenance attr {key!r} missing"
    if "time" in ds.dims:
        assert "units" in ds["time"].attrs, "time coordinate has no units"

    # nominal filling: no params -> one sample at nominal values
    nominal = model.response({}, t, **options)
    assert nominal.sizes["sample"] == 1
    for p in model.parameters:
        assert float(nominal[p.name][0]) == p.nominal

    # outputs restriction keeps only what was asked
    first = model.outputs[0].name
    only = model.response(draws, t, outputs=[first], **options)
    others = [o.name for o in model.outputs[1:] if o.name in only.data_vars]
    assert not others, f"outputs=[{first!r}] still returned {others}"
    np.testing.assert_allclose(only[first].values, ds[first].values, rtol=1e-12, atol=0,
                               err_msg="restricting outputs changed the values")

    # sample independence: evaluating one sample alone gives the same numbers
    single = model.response({k: v[-1:] for k, v in draws.items()}, t, **options)
    for o in model.outputs:
        np.testing.assert_allclose(single[o.name].values[0], ds[o.name].values[-1],
                                   rtol=1e-9, atol=1e-12 * float(
                                       np.nanmax(np.abs(ds[o.name].values)) or 1.0),
                                   err_msg=f"output {o.name!r} depends on the other samples")

    # bad input must raise clear errors
    for bad, what in (
        ({"__nope__": [1.0]}, "__nope__"),
        ({names[0]: [np.nan]}, names[0]),
    ):
        try:
            model.response(bad, t, **options)
        except ValueError as exc:
            assert what in str(exc), f"error message {exc!s} does not name {what!r}"
        else:
            raise AssertionError(f"no ValueError for bad input {bad}")
    for p in model.parameters:
        if math.isfinite(p.upper):
            try:
                model.response({p.name: [p.upper * 2 + 1.0]}, t, **options)
            except ValueError as exc:
                assert p.name in str(exc), f"out-of-range message does not name {p.name!r}"
            else:
                raise AssertionError(f"no ValueError for {p.name} above its range")
            break
    try:
        model.response(draws, t, outputs=["__no_output__"], **options)
    except ValueError as exc:
        assert "__no_output__" in str(exc)
    else:
        raise AssertionError("no ValueError for an unknown output")

    # the model and its prepared request travel to worker processes by (cloud)pickle
    import cloudpickle

    request = model.prepare(t, **options)
    clone = pickle.loads(cloudpickle.dumps(model))
    again = clone.evaluate(draws, pickle.loads(pickle.dumps(request)))
    for o in model.outputs:
        np.testing.assert_array_equal(again[o.name].values, ds[o.name].values,
                                      err_msg=f"output {o.name!r} differs after a pickle "
                                              "round trip of the model")

    if roundtrip:
        with tempfile.TemporaryDirectory() as tmp:
            path = io.save(ds, Path(tmp) / "r.nc")
            back = io.load(path)
            xr.testing.assert_identical(back[list(ds.data_vars)].drop_attrs(deep=True),
                                        ds.drop_attrs(deep=True))
            assert back.attrs["model"] == ds.attrs["model"]
    return ds


def _check_options(model: Model, parameter_names: list[str]) -> None:
    """Declared options: Option instances, unique names, defaults valid, unknown refused."""
    opts = getattr(model, "options", ())
    assert isinstance(opts, tuple), "model.options must be a tuple of Option"
    names = []
    for o in opts:
        assert isinstance(o, Option), f"model.options holds {o!r}, not an Option"
        assert o.description, f"option {o.name!r} has no description"
        names.append(o.name)
    assert len(set(names)) == len(names), f"duplicate option names {names}"
    clash = set(names) & set(parameter_names)
    assert not clash, f"names used both as parameter and option: {sorted(clash)}"
    defaults = model.validate_options({})
    assert set(defaults) == set(names), "validate_options({}) must fill every default"
    try:
        model.prepare(None if not any(o.time_dependent for o in model.outputs) else [0.0],
                      __no_option__=1)
    except ValueError as exc:
        assert "__no_option__" in str(exc), f"unknown-option message {exc!s} does not name it"
    else:
        raise AssertionError("no ValueError for an unknown option")


def _check_default_space(model: Model) -> None:
    """A declared default space names model parameters and draws valid values."""
    space = model.default_space()
    if space is None:
        return
    from gearuq.space import ParameterSpace

    assert isinstance(space, ParameterSpace), "default_space() must return a ParameterSpace"
    unknown = [k for k in space.names if k not in model.parameter_names]
    assert not unknown, f"default_space() names unknown parameters {unknown}"
    draws = space.sample(64, rng=0)
    model.validate_params(draws)  # raises with the parameter name if a draw is invalid
