"""Fidelity links: one model's parameter space mapped onto another model's inputs.

A :class:`FidelityLink` is a :class:`~gearuq.model.Model` that takes the parameters of an
expensive (high-fidelity, HF) model, maps them onto the inputs of a cheaper (low-fidelity, LF)
model, runs that model and hands back its outputs under the names of the HF outputs they stand
for. Its parameters and default space are the HF model's, so every engine can use it where it
would use the HF model, and the same :class:`~gearuq.failure.modes.LimitState` runs on both:
``failure_probability(hf, ..., method="mfis", low_fidelity=link)`` and
``multifidelity_estimate([hf, link], ...)``.

A link declares, at construction and before anything runs,

- the LF inputs its input map produces (each must be an LF parameter; the rest take the LF's
  nominal values) and the HF parameters it reads (each must be an HF parameter);
- its output map, LF output -> HF output (with an optional transform): every LF output must
  exist in LF, every HF name in HF, and no HF name twice;
- what it neglects, as plain sentences (recorded in every result).

Samples whose mapped inputs fall outside the LF model's valid ranges are not evaluated by LF:
they get status 16 (``low_fidelity_inputs_outside_valid_range``) and NaN outputs, so no sample
is lost silently. LF status codes are kept (1-15) or moved up by 16 (plugin codes, e.g. LF's
16 becomes 32) with their meanings prefixed ``low_fidelity_``.

Registered links (entry-point group ``gearuq.links``, names ``"HIGH->LOW"``) are found by
:func:`gearuq.registry.get_link`.
"""

from __future__ import annotations

import json
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from gearuq.model import (
    PLUGIN_STATUS_MIN,
    Evaluation,
    Model,
    Option,
    Output,
    status_meanings,
)

__all__ = ["FidelityLink", "LinkOutput", "LowFidelityInputs", "LinkContext",
           "STATUS_LOW_FIDELITY_RANGE"]

#: Status of a sample whose mapped inputs lie outside the low-fidelity model's valid ranges.
STATUS_LOW_FIDELITY_RANGE = PLUGIN_STATUS_MIN
#: LF plugin status codes (>= 16) are reported as ``code + _LF_SHIFT``.
_LF_SHIFT = 16


@dataclass(frozen=True)
class LowFidelityInputs:
    """What an input map returns: the LF parameters and, optionally, options and instants.

    Attributes
    ----------
    params : mapping
        LF parameter name -> array ``(n_samples,)``; exactly the names the link declared in
        ``produces``.
    options : mapping
        Declared LF options for this call (merged over the link's fixed ``low_options``).
    t : array_like, optional
        Instants of the LF call when they differ from the link's (e.g. one excitation period
        in LF's own time unit); ``None``: the link's ``t``.
    carry : mapping, optional
        Per-sample arrays (first axis ``n_samples``) the input map computed and the output
        transforms need but LF does not take (e.g. an excitation spectrum): handed to the
        transforms as ``LinkContext.carried``, restricted to the evaluated samples, so no
        transform recomputes them.
    """

    params: Mapping[str, Any]
    options: Mapping[str, Any] = field(default_factory=dict)
    t: Any = None
    carry: Mapping[str, Any] = field(default_factory=dict)


@dataclass(frozen=True)
class LinkOutput:
    """One entry of an output map: the HF output an LF output stands for.

    Attributes
    ----------
    name : str
        HF output name (the link's output carries it, with the HF's units and dims).
    transform : callable, optional
        ``transform(values, context) -> array`` shaped as the HF output's dims; ``values`` is
        the LF output over the evaluated samples, ``context`` a :class:`LinkContext`.
        ``None``: the LF values as they are (they must already have the HF dims and units).
    needs : tuple of str
        Other LF outputs the transform reads (``context.low_data``).
    """

    name: str
    transform: Callable[[np.ndarray, LinkContext], np.ndarray] | None = None
    needs: tuple[str, ...] = ()


@dataclass(frozen=True)
class LinkContext:
    """What a transform sees (every array restricted to the samples LF evaluated).

    Attributes
    ----------
    params : dict
        HF parameters (every one, nominal values filled in).
    low_params : dict
        LF parameters produced by the input map.
    low_data : dict
        Every LF output requested in this call, by LF name.
    low_coords : dict
        LF coordinate values by name.
    t, low_t : ndarray or None
        The link's instants and the LF call's instants.
    options : dict
        The link's own options.
    carried : dict
        The input map's ``carry`` arrays (see :class:`LowFidelityInputs`).
    """

    params: dict[str, np.ndarray]
    low_params: dict[str, np.ndarray]
    low_data: dict[str, np.ndarray]
    low_coords: dict[str, np.ndarray]
    t: np.ndarray | None
    low_t: np.ndarray | None
    options: dict[str, Any]
    carried: dict[str, np.ndarray] = field(default_factory=dict)


def _resolve(model: Model | str, role: str) -> Model:
    if isinstance(model, Model):
        return model
    if isinstance(model, str):
        from gearuq.registry import get_model

        return get_model(model)
    raise ValueError(f"{role}: expected a Model or a registered model name, got "
                     f"{type(model).__name__}")


def _names(items: Iterable[str] | None, what: str) -> tuple[str, ...]:
    if items is None:
        return ()
    if isinstance(items, str):
        raise ValueError(f"{what}: expected a sequence of names, got the string {items!r}")
    return tuple(items)


class FidelityLink(Model):
    """A low-fidelity model seen through the parameters and output names of a high-fidelity one.

    Parameters
    ----------
    high : Model or str
        The high-fidelity model (its parameters, default space and output names are the
        link's).
    low : Model or str
        The low-fidelity model that is run.
    input_map : callable
        ``input_map(params, **options) -> LowFidelityInputs`` (or a plain dict of LF
        parameter arrays): vectorised over samples; ``params`` holds every HF parameter
        (validated, nominal values filled in), ``options`` the link's declared options.
        Module-level functions keep the link picklable.
    produces : sequence of str
        LF parameters the input map returns (checked at construction: each must be an LF
        parameter; and at every call: the map must return exactly these).
    output_map : mapping
        LF output name -> HF output name, ``(HF name, transform)`` or a :class:`LinkOutput`.
    reads : sequence of str, optional
        HF parameters the input map uses (checked at construction; recorded as provenance).
    neglects : sequence of str
        What the LF model leaves out of the HF physics, one plain sentence each.
    low_options : mapping, optional
        Fixed declared options of the LF model (validated at construction).
    options : sequence of Option
        The link's own declared options (passed to ``input_map`` and the transforms).
    name, description, version : str, optional
        Default name ``"HIGH->LOW"``.
    also_runs : sequence of Model, optional
        Other models the input map runs (e.g. a contact analysis giving the LF model's
        excitation): recorded in the settings (provenance) next to HF and LF.

    Raises
    ------
    ValueError
        At construction: an LF output that LF does not have, an HF name that is not an HF
        output (or given twice), a produced name that is not an LF parameter, a read name that
        is not an HF parameter, bad ``low_options``; each message names the offending item
        and lists the valid ones.
    """

    def __init__(
        self,
        high: Model | str,
        low: Model | str,
        input_map: Callable[..., LowFidelityInputs | Mapping[str, Any]],
        produces: Sequence[str],
        output_map: Mapping[str, str | tuple | LinkOutput],
        *,
        reads: Sequence[str] | None = None,
        neglects: Sequence[str] = (),
        low_options: Mapping[str, Any] | None = None,
        options: Sequence[Option] = (),
        name: str | None = None,
        description: str = "",
        version: str = "1",
        also_runs: Sequence[Model] = (),
    ) -> None:
        self.high = _resolve(high, "high")
        self.low = _resolve(low, "low")
        if not callable(input_map):
            raise ValueError(f"input_map: expected a callable, got {type(input_map).__name__}")
        self.input_map = input_map
        self.name = name or f"{self.high.name}->{self.low.name}"
        self.produces = _names(produces, "produces")
        self.reads = _names(reads, "reads")
        self.neglects = tuple(str(s) for s in _names(neglects, "neglects"))
        self.output_map = self._check_output_map(output_map)
        self._check_names()
        self.low_options = dict(self.low.validate_options(low_options)) if low_options else {}
        self._fixed_low_options = dict(low_options or {})
        self.options = tuple(options)
        clash = sorted(set(self.option_names) & set(self.parameter_names))
        if clash:
            raise ValueError(f"link {self.name!r}: option name(s) {clash} are also parameters")
        self.description = description or (
            f"fidelity link: {self.low.name} seen through the parameters and outputs of "
            f"{self.high.name}")
        self.version = version
        self.also_runs = tuple(also_runs)
        for m in self.also_runs:
            if not isinstance(m, Model):
                raise ValueError(f"link {self.name!r}: also_runs holds "
                                 f"{type(m).__name__}, not a Model")
        self.time_units = self.high.time_units
        self.time_long_name = self.high.time_long_name
        self.parameters = tuple(self.high.parameters)
        self.outputs = tuple(self._declare_outputs())

    # ------------------------------------------------------------------ construction checks
    def _check_output_map(self, output_map: Mapping[str, Any]) -> dict[str, LinkOutput]:
        if not isinstance(output_map, Mapping) or not output_map:
            raise ValueError(f"link {self.name!r}: output_map must be a non-empty mapping "
                             "LF output -> HF output")
        entries: dict[str, LinkOutput] = {}
        for low_name, value in output_map.items():
            if isinstance(value, LinkOutput):
                entry = value
            elif isinstance(value, str):
                entry = LinkOutput(value)
            elif isinstance(value, tuple) and 1 <= len(value) <= 3:
                entry = LinkOutput(value[0], *value[1:])
            else:
                raise ValueError(f"link {self.name!r}: output_map[{low_name!r}] must be an HF "
                                 f"output name, (name, transform) or a LinkOutput, got "
                                 f"{value!r}")
            if entry.transform is not None and not callable(entry.transform):
                raise ValueError(f"link {self.name!r}: output_map[{low_name!r}]: transform is "
                                 "not callable")
            entries[low_name] = LinkOutput(entry.name, entry.transform, tuple(entry.needs))
        return entries

    def _check_names(self) -> None:
        low_out, high_out = self.low.output_names, self.high.output_names
        for low_name, entry in self.output_map.items():
            for item in (low_name, *entry.needs):
                if item not in low_out:
                    raise ValueError(
                        f"link {self.name!r}: output_map names {item!r}, which is not an "
                        f"output of the low-fidelity model {self.low.name!r}; valid: "
                        f"{', '.join(low_out)}")
            if entry.name not in high_out:
                raise ValueError(
                    f"link {self.name!r}: output_map maps {low_name!r} to {entry.name!r}, "
                    f"which is not an output of the high-fidelity model {self.high.name!r}; "
                    f"valid: {', '.join(high_out)}")
        targets = [e.name for e in self.output_map.values()]
        twice = sorted({t for t in targets if targets.count(t) > 1})
        if twice:
            raise ValueError(f"link {self.name!r}: HF output(s) {twice} are given by more than "
                             "one LF output; map each HF output once")
        if not self.produces:
            valid = ", ".join(self.low.parameter_names)
            raise ValueError(f"link {self.name!r}: produces is empty; name the LF parameters "
                             f"the input map returns (valid: {valid})")
        for verb, items, side, model in (("produces", self.produces, "low", self.low),
                                         ("reads", self.reads, "high", self.high)):
            for item in items:
                if item not in model.parameter_names:
                    raise ValueError(
                        f"link {self.name!r}: the input map {verb} {item!r}, which is not a "
                        f"parameter of the {side}-fidelity model {model.name!r}; valid: "
                        f"{', '.join(model.parameter_names)}")

    def _declare_outputs(self) -> list[Output]:
        outs = []
        for low_name, entry in self.output_map.items():
            meta = self.high.output(entry.name)
            outs.append(Output(meta.name, meta.units, meta.dims,
                               f"{self.low.name} ({low_name}) standing for: {meta.description}"))
        return outs

    # ------------------------------------------------------------------ metadata
    def default_space(self) -> Any:
        """The high-fidelity model's default space (the link's parameters are the HF's)."""
        return self.high.default_space()

    def settings(self) -> dict[str, Any]:
        """Both models (name, version, settings), the maps and what the link neglects."""
        from gearuq.execution.fingerprint import function_digest

        def describe(m: Model) -> dict[str, Any]:
            return {"name": m.name, "version": str(m.version), "settings": m.settings(),
                    "class": f"{type(m).__module__}.{type(m).__qualname__}"}

        def fn_name(fn: Any) -> str:
            return f"{getattr(fn, '__module__', '?')}.{getattr(fn, '__qualname__', repr(fn))}"

        return {
            "high_fidelity": describe(self.high), "low_fidelity": describe(self.low),
            "input_map": fn_name(self.input_map),
            "input_map_digest": function_digest(self.input_map).get("sha256"),
            "produces": list(self.produces), "reads": list(self.reads),
            "output_map": {k: [e.name, None if e.transform is None else fn_name(e.transform)]
                           for k, e in self.output_map.items()},
            "low_options": {k: repr(v) for k, v in sorted(self._fixed_low_options.items())},
            "neglects": list(self.neglects),
            "also_runs": [describe(m) for m in self.also_runs],
        }

    def precompile(self) -> float:
        """Compile the low-fidelity model's kernels (when it has any); seconds."""
        pre = getattr(self.low, "precompile", None)
        return float(pre()) if callable(pre) else 0.0

    # ------------------------------------------------------------------ evaluation
    def low_inputs(self, params: Mapping[str, Any], **options: Any) -> LowFidelityInputs:
        """The LF inputs of HF parameter samples (validated HF parameters; the link's
        options filled in): the input map's result, checked against ``produces``."""
        p = self.validate_params(params)
        opts = self.validate_options(options)
        return self._map_inputs(p, opts)

    def _map_inputs(self, p: dict[str, np.ndarray], opts: dict[str, Any]) -> LowFidelityInputs:
        raw = self.input_map(p, **opts)
        low = raw if isinstance(raw, LowFidelityInputs) else LowFidelityInputs(dict(raw))
        got = set(low.params)
        if got != set(self.produces):
            raise ValueError(
                f"link {self.name!r}: the input map returned {sorted(got)}, but the link "
                f"declares produces={list(self.produces)}; missing "
                f"{sorted(set(self.produces) - got)}, undeclared "
                f"{sorted(got - set(self.produces))}")
        n = next(iter(p.values())).shape[0]
        arrays = {k: np.broadcast_to(np.asarray(v, dtype=float), (n,)).copy()
                  for k, v in low.params.items()}
        carry = {k: np.asarray(v) for k, v in dict(low.carry).items()}
        for k, v in carry.items():
            if v.ndim == 0 or v.shape[0] != n:
                raise ValueError(f"link {self.name!r}: the input map's carry[{k!r}] has shape "
                                 f"{v.shape}; its first axis must be the {n} samples")
        return LowFidelityInputs(arrays, {**self._fixed_low_options, **dict(low.options)},
                                 low.t, carry)

    def _in_range(self, low_params: dict[str, np.ndarray], n: int
                  ) -> tuple[np.ndarray, list[str]]:
        ok = np.ones(n, dtype=bool)
        notes = []
        for name, values in low_params.items():
            par = self.low.parameter(name)
            bad = ~np.isfinite(values) | (values < par.lower) | (values > par.upper)
            if par.integer:
                bad |= np.isfinite(values) & (values != np.round(values))
            if bad.any():
                notes.append(f"{name}: {int(bad.sum())} sample(s) outside {par.range_text()}")
            ok &= ~bad
        return ok, notes

    def _evaluate(self, params, t, outputs, **options):
        n = next(iter(params.values())).shape[0]
        low_in = self._map_inputs(params, dict(options))
        valid, notes = self._in_range(dict(low_in.params), n)
        by_high = {e.name: (k, e) for k, e in self.output_map.items()}
        low_names = list(dict.fromkeys(
            name for o in outputs for name in (by_high[o][0], *by_high[o][1].needs)))
        status = np.zeros(n, dtype=np.int8)
        status[~valid] = STATUS_LOW_FIDELITY_RANGE
        meanings = {STATUS_LOW_FIDELITY_RANGE: "low_fidelity_inputs_outside_valid_range"}
        attrs: dict[str, Any] = {
            "high_fidelity_model": self.high.name, "low_fidelity_model": self.low.name,
            "fidelity_link": self.name, "link_neglects": json.dumps(list(self.neglects)),
        }
        if notes:
            attrs["low_fidelity_range_notes"] = "; ".join(notes)
        tt = t if t.size else None
        low_t = tt if low_in.t is None else np.asarray(low_in.t, dtype=float)
        idx = np.flatnonzero(valid)
        if idx.size == 0:  # one nominal LF run gives the shapes of the outputs' other dims
            run_idx, ok = np.zeros(1, dtype=np.int64), False
            lf_params = {k: np.array([self.low.parameter(k).nominal]) for k in low_in.params}
        else:
            run_idx, ok = idx, True
            lf_params = {k: v[idx] for k, v in low_in.params.items()}
        request = self.low.prepare(low_t, outputs=low_names, **dict(low_in.options))
        ds = self.low.evaluate(lf_params, request)
        low_data = {k: np.asarray(ds[k].values) for k in low_names}
        coords = {k: np.asarray(ds.coords[k].values) for k in ds.coords}
        if ok:
            self._carry_status(ds, idx, status, meanings)
        sub = {k: v[run_idx] for k, v in params.items()}
        ctx = LinkContext(sub, lf_params, low_data, coords, tt, low_t, dict(options),
                          {k: v[run_idx] for k, v in low_in.carry.items()})
        data, out_coords = {}, {}
        for o in outputs:
            low_name, entry = by_high[o]
            values = low_data[low_name]
            if entry.transform is not None:
                values = np.asarray(entry.transform(values, ctx), dtype=float)
            meta = self.output(o)
            shape = values.shape[1:]
            full = np.full((n, *shape), np.nan)
            if ok:
                full[idx] = values
            data[o] = full
            for dim in meta.dims[1:]:
                if dim != "time" and dim in ds.coords:
                    c = ds.coords[dim]
                    out_coords[dim] = (dim, c.values, dict(c.attrs))
        extra = {f"lf_{k}": ("sample", np.where(valid, v, np.nan),
                             {"units": self.low.parameter(k).units,
                              "long_name": f"{self.low.name} input {k} (fidelity link)"})
                 for k, v in low_in.params.items()}
        return Evaluation(data=data, status=status, status_meanings=meanings,
                          coords=out_coords, attrs=attrs, extra=extra)

    def _carry_status(self, ds: Any, idx: np.ndarray, status: np.ndarray,
                      meanings: dict[int, str]) -> None:
        """LF status codes into the link's: 1-15 kept, plugin codes moved up by 16."""
        low_status = np.asarray(ds["status"].values, dtype=np.int64)
        names = status_meanings(ds["status"])
        for code in np.unique(low_status[low_status != 0]):
            code = int(code)
            mine = code + _LF_SHIFT if code >= PLUGIN_STATUS_MIN else code
            if code >= PLUGIN_STATUS_MIN:
                meanings[mine] = f"low_fidelity_{names.get(code, f'status_{code}')}"
            status[idx[low_status == code]] = mine
