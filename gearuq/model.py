"""The plugin contract: parameter/output metadata, the ``Model`` base class and ``FunctionModel``.

A model maps parameter samples to responses. Every model, built-in plugin or user function,
answers ``response(params, t, *, outputs=None, **options)`` with an :class:`xarray.Dataset`
that has the dimension ``sample`` (and ``time`` for time-dependent outputs), the inputs as
variables over ``sample``, units in ``attrs["units"]`` and a per-sample ``status`` flag.
"""

from __future__ import annotations

import dataclasses
import inspect
import math
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import xarray as xr

from gearuq._version import __version__

#: Status codes shared by every model. Plugins may add codes >= 16 (``PLUGIN_STATUS_MIN``)
#: with their own meanings; 5-15 are kept free for future shared codes.
STATUS_OK = 0
STATUS_STEP_LIMIT = 1
STATUS_STEP_UNDERFLOW = 2
STATUS_NONFINITE = 3
STATUS_MODEL_ERROR = 4
PLUGIN_STATUS_MIN = 16
STATUS_MEANINGS: dict[int, str] = {
    STATUS_OK: "ok",
    STATUS_STEP_LIMIT: "step_limit_reached",
    STATUS_STEP_UNDERFLOW: "step_size_underflow",
    STATUS_NONFINITE: "non_finite_state",
    STATUS_MODEL_ERROR: "model_error",
}


@dataclass(frozen=True)
class Parameter:
    """Metadata of one model input.

    Parameters
    ----------
    name : str
        Identifier used as key in ``params`` and as variable name in results.
    units : str
        UDUNITS-style unit string ("m", "kg m-3", "1" for dimensionless).
    nominal : float
        Value used when the caller does not give the parameter.
    lower, upper : float
        Closed valid range; ``-inf``/``inf`` for open ends.
    description : str
        One-line meaning, with its source where it comes from a paper or standard.
    integer : bool
        Only whole numbers are valid (numbers of teeth, harmonic orders).
    """

    name: str
    units: str
    nominal: float
    lower: float = -math.inf
    upper: float = math.inf
    description: str = ""
    integer: bool = False

    def __post_init__(self) -> None:
        if not self.name.isidentifier():
            raise ValueError(f"parameter name {self.name!r} is not a valid identifier")
        if not self.lower <= self.nominal <= self.upper:
            raise ValueError(
                f"parameter {self.name!r}: nominal {self.nominal!r} outside its valid range "
                f"[{self.lower}, {self.upper}]"
            )

    def range_text(self) -> str:
        """Return the valid range as ``[lower, upper] units``."""
        return f"[{self.lower:g}, {self.upper:g}] {self.units}"

    def with_nominal(self, value: float) -> Parameter:
        """This parameter with nominal ``value``, its range widened to hold it (a stage or a
        configuration sets nominal values the default range may not reach)."""
        v = float(value)
        return dataclasses.replace(self, nominal=v, lower=min(self.lower, v),
                                   upper=max(self.upper, v))


@dataclass(frozen=True)
class Output:
    """Metadata of one model response.

    Parameters
    ----------
    name : str
        Variable name in the result Dataset.
    units : str
        Unit string.
    dims : tuple of str
        Dimensions of the variable, always starting with ``"sample"``.
    description : str
        One-line meaning.
    valid_min : float, optional
        The smallest value the output can take (0 for an amplitude, an RMS or a
        peak-to-peak value), written as the CF attribute ``valid_min`` of the result
        variable. A failure band that every value, or no value, of the output leaves is
        refused against it (:meth:`gearuq.failure.Band.check_reach`).
    """

    name: str
    units: str
    dims: tuple[str, ...] = ("sample", "time")
    description: str = ""
    valid_min: float | None = None

    def __post_init__(self) -> None:
        if not self.dims or self.dims[0] != "sample":
            raise ValueError(
                f"output {self.name!r}: dims must start with 'sample', got {self.dims}")

    @property
    def time_dependent(self) -> bool:
        """Whether the output has a ``time`` dimension."""
        return "time" in self.dims


def bounded_below(outputs: Sequence[Output], names: Sequence[str], valid_min: float = 0.0
                  ) -> tuple[Output, ...]:
    """``outputs`` with ``valid_min`` set on those named (amplitudes, RMS values, fractions).

    Raises
    ------
    ValueError
        If a name is not among ``outputs`` (a declaration's typo).
    """
    known = {o.name for o in outputs}
    unknown = [n for n in names if n not in known]
    if unknown:
        raise ValueError(f"bounded_below: {unknown} are not among the outputs {sorted(known)}")
    chosen = set(names)
    return tuple(dataclasses.replace(o, valid_min=float(valid_min)) if o.name in chosen else o
                 for o in outputs)


_OPTION_KINDS = {"float": float, "int": int, "bool": bool, "str": str, "any": object}


@dataclass(frozen=True)
class Option:
    """Metadata of one model option (solver or fidelity setting), declared like a parameter.

    Options are validated once, at the call site (:meth:`Model.prepare`), before any design is
    drawn: an unknown name or a bad value raises a ValueError that lists the valid options.
    Unlike parameters, options are the same for every sample of a run.

    Parameters
    ----------
    name : str
        Keyword used in ``response(..., name=value)``.
    default : object
        Value used when the caller does not give the option.
    description : str
        One-line meaning (shown by ``gearuq models NAME``).
    kind : {"float", "int", "bool", "str", "any"} or type, optional
        Value type; inferred from ``default`` when omitted (``bool`` before ``int``). Integers
        are accepted for ``float`` options; ``"any"`` accepts every value that ``check``
        accepts (tables, arrays).
    choices : tuple, optional
        The only valid values.
    lower, upper : float
        Closed valid range of numeric options (``inf`` allowed as a value when the bound is
        open, e.g. ``max_step = inf``).
    allow_none : bool
        ``None`` is a valid value (meaning given in ``description``).
    units : str
        Unit of a numeric option ("" when dimensionless or not numeric).
    check : callable, optional
        ``check(value) -> value`` for ``kind="any"``; raises ValueError on a bad value.
    """

    name: str
    default: Any
    description: str = ""
    kind: Any = None
    choices: tuple | None = None
    lower: float = -math.inf
    upper: float = math.inf
    allow_none: bool = False
    units: str = ""
    check: Callable[[Any], Any] | None = field(default=None, compare=False)

    def __post_init__(self) -> None:
        if not self.name.isidentifier():
            raise ValueError(f"option name {self.name!r} is not a valid identifier")
        kind = self.kind
        if kind is None:
            if self.default is None:
                raise ValueError(f"option {self.name!r}: give kind= when the default is None")
            kind = next(k for k, tp in (("bool", bool), ("int", int), ("float", float),
                                        ("str", str), ("any", object))
                        if isinstance(self.default, tp))
        elif isinstance(kind, type):
            kind = {bool: "bool", int: "int", float: "float", str: "str"}.get(kind, "any")
        if kind not in _OPTION_KINDS:
            raise ValueError(f"option {self.name!r}: kind {kind!r} not in {list(_OPTION_KINDS)}")
        object.__setattr__(self, "kind", kind)
        if self.choices is not None:
            object.__setattr__(self, "choices", tuple(self.choices))
        self.validate(self.default, "declaration")

    def valid_text(self) -> str:
        """Human-readable description of the valid values."""
        if self.choices is not None:
            text = "one of " + ", ".join(map(repr, self.choices))
        elif self.kind in ("int", "float") and (math.isfinite(self.lower)
                                                or math.isfinite(self.upper)):
            text = f"{self.kind} in [{self.lower:g}, {self.upper:g}]"
            text += f" {self.units}" if self.units else ""
        else:
            text = {"any": "see description"}.get(self.kind, self.kind)
        return text + (" or None" if self.allow_none else "")

    def validate(self, value: Any, where: str = "") -> Any:
        """Return ``value`` converted to the option's type, or raise a ValueError naming it."""
        where = f"{where}: " if where else ""

        def bad(reason: str) -> ValueError:
            return ValueError(f"{where}option {self.name!r}: {reason} (got {value!r}; valid: "
                              f"{self.valid_text()})")

        if value is None:
            if self.allow_none:
                return None
            raise bad("None is not allowed")
        if self.kind == "bool":
            if not isinstance(value, (bool, np.bool_)):
                raise bad("expected True or False")
            value = bool(value)
        elif self.kind in ("int", "float"):
            if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, float,
                                                                            np.integer,
                                                                            np.floating)):
                raise bad(f"expected a number ({self.kind})")
            if self.kind == "int":
                if isinstance(value, (float, np.floating)) and not float(value).is_integer():
                    raise bad("expected a whole number")
                value = int(value)
            else:
                value = float(value)
                if math.isnan(value):
                    raise bad("NaN is not a valid value")
            if not self.lower <= value <= self.upper:
                raise bad("outside the valid range")
        elif self.kind == "str":
            if not isinstance(value, str):
                raise bad("expected a string")
        elif self.check is not None:
            try:
                value = self.check(value)
            except (TypeError, ValueError) as exc:
                raise bad(str(exc)) from None
        if self.choices is not None and value not in self.choices:
            raise bad("not one of the choices")
        return value


@dataclass(frozen=True, eq=False)
class Request:
    """A validated evaluation request: what to compute, at which instants, with which options.

    Made by :meth:`Model.prepare` once per call, before any design is drawn; engines and the
    execution layer carry it to every chunk (it pickles) and fingerprint it for stores.

    Attributes
    ----------
    model : str
        Name of the model that prepared it.
    outputs : tuple of str
        Requested outputs, in declaration order of the request.
    t : ndarray or None
        Output instants (``None`` when no time-dependent output was asked and no ``t`` given).
    options : dict
        Every declared option, defaults filled in.
    """

    model: str
    outputs: tuple[str, ...]
    t: np.ndarray | None
    options: Mapping[str, Any]

    @property
    def needs_time(self) -> bool:
        """Whether ``t`` was given (time-dependent outputs need it)."""
        return self.t is not None

    def fingerprint(self) -> dict[str, Any]:
        """JSON-able description (arrays by shape and SHA-256 digest)."""
        return {
            "model": self.model,
            "outputs": list(self.outputs),
            "t": None if self.t is None else array_digest(self.t),
            "options": {k: _jsonable_value(v) for k, v in sorted(self.options.items())},
        }

    def options_json(self) -> str:
        """The options as a JSON string (for provenance attributes)."""
        import json

        return json.dumps(self.fingerprint()["options"], sort_keys=True)


def array_digest(a: Any) -> dict[str, Any]:
    """Shape, dtype and SHA-256 of an array (a JSON-able stand-in for fingerprints)."""
    import hashlib

    arr = np.ascontiguousarray(np.asarray(a))
    return {"shape": list(arr.shape), "dtype": str(arr.dtype),
            "sha256": hashlib.sha256(arr.tobytes()).hexdigest()}


def _jsonable_value(v: Any) -> Any:
    """A JSON-able form of an option value (arrays digested, floats kept exactly)."""
    if v is None or isinstance(v, (bool, int, str)):
        return v
    if isinstance(v, float):
        return v if math.isfinite(v) else repr(v)
    if isinstance(v, (np.integer, np.floating, np.bool_)):
        return _jsonable_value(v.item())
    if isinstance(v, np.ndarray):
        return array_digest(v)
    if isinstance(v, Mapping):
        return {str(k): _jsonable_value(x) for k, x in sorted(v.items(), key=lambda kv: str(kv[0]))}
    if isinstance(v, (list, tuple)):
        return [_jsonable_value(x) for x in v]
    to_dict = getattr(v, "to_dict", None)
    if callable(to_dict):
        return {"type": type(v).__name__, "value": _jsonable_value(to_dict())}
    return {"type": type(v).__name__, "repr": repr(v)}


@dataclass
class Evaluation:
    """What a model's ``_evaluate`` hands back to :meth:`Model.response`.

    Attributes
    ----------
    data : dict
        Output name -> array shaped as the output's dims.
    status : ndarray of int
        Per-sample status code (0 = ok).
    status_meanings : dict
        Extra code -> meaning entries beyond :data:`STATUS_MEANINGS`.
    coords : dict
        Extra coordinates (name -> (dims, values, attrs)) such as ``dof`` labels.
    attrs : dict
        Extra Dataset attributes (solver settings, statistics).
    extra : dict
        Extra per-sample diagnostic variables (name -> (dims, values, attrs)).
    """

    data: dict[str, np.ndarray]
    status: np.ndarray
    status_meanings: dict[int, str] = field(default_factory=dict)
    coords: dict[str, tuple] = field(default_factory=dict)
    attrs: dict[str, Any] = field(default_factory=dict)
    extra: dict[str, tuple] = field(default_factory=dict)

    def __post_init__(self) -> None:
        low = sorted(c for c in self.status_meanings if int(c) < PLUGIN_STATUS_MIN)
        if low:
            raise ValueError(f"status codes {low} of a plugin: plugin codes start at "
                             f"{PLUGIN_STATUS_MIN} (0-{PLUGIN_STATUS_MIN - 1} are shared: "
                             f"{STATUS_MEANINGS})")


class Model:
    """Base class of every gearuq model.

    Subclasses set the class attributes ``name``, ``description``, ``version``,
    ``parameters``, ``outputs`` (and ``time_units``) and implement :meth:`_evaluate`. The
    base class validates the inputs, fills nominal values and assembles the Dataset, so every
    model answers the same contract.
    """

    name: str = "model"
    description: str = ""
    version: str = "0"
    parameters: tuple[Parameter, ...] = ()
    outputs: tuple[Output, ...] = ()
    #: Declared solver/fidelity options (validated by :meth:`prepare`).
    options: tuple[Option, ...] = ()
    time_units: str = "s"
    time_long_name: str = "time"
    #: True when ``response`` already uses every core (e.g. a compiled kernel that runs
    #: sample blocks in threads): engines then evaluate serially unless told otherwise.
    internally_parallel: bool = False

    # ----------------------------------------------------------------- metadata helpers
    @property
    def parameter_names(self) -> list[str]:
        """Names of the model parameters in declaration order."""
        return [p.name for p in self.parameters]

    @property
    def output_names(self) -> list[str]:
        """Names of the model outputs in declaration order."""
        return [o.name for o in self.outputs]

    def parameter(self, name: str) -> Parameter:
        """Return the metadata of parameter ``name``."""
        for p in self.parameters:
            if p.name == name:
                return p
        raise ValueError(
            f"model {self.name!r} has no parameter {name!r}; "
            f"valid: {', '.join(self.parameter_names)}"
        )

    def output(self, name: str) -> Output:
        """Return the metadata of output ``name``."""
        for o in self.outputs:
            if o.name == name:
                return o
        raise ValueError(
            f"model {self.name!r} has no output {name!r}; valid: {', '.join(self.output_names)}"
        )

    def nominal(self) -> dict[str, float]:
        """Nominal parameter values as a dict."""
        return {p.name: p.nominal for p in self.parameters}

    @property
    def option_names(self) -> list[str]:
        """Names of the declared options."""
        return [o.name for o in self.options]

    def option(self, name: str) -> Option:
        """Return the metadata of option ``name``."""
        for o in self.options:
            if o.name == name:
                return o
        raise ValueError(
            f"model {self.name!r} has no option {name!r}; valid: "
            f"{', '.join(self.option_names) or 'none (this model takes no options)'}"
        )

    def settings(self) -> dict[str, Any]:
        """Model construction options, recorded as provenance (override in subclasses)."""
        return {}

    #: Parameters whose nominal values :meth:`with_nominal` changed (name -> value).
    nominal_overrides: Mapping[str, float] = {}

    def with_nominal(self, **values: float) -> Model:
        """A copy of this model whose listed parameters have other nominal values.

        The nominal value is what every engine uses for a parameter outside the parameter
        space: ``rotor.with_nominal(iso_grade=6)`` is the rotor at ISO grade 6 for studies
        whose space leaves the grade out. Values are validated like samples (name, range,
        whole numbers); the overrides enter the model's store fingerprint and provenance
        (``nominal_overrides``), so a store of the original model is never reused for them.
        """
        import copy
        from dataclasses import replace

        checked = self.validate_params({k: [v] for k, v in values.items()})
        new = copy.copy(self)
        new.parameters = tuple(replace(p, nominal=float(checked[p.name][0]))
                               if p.name in values else p for p in self.parameters)
        new.nominal_overrides = {**self.nominal_overrides,
                                 **{k: float(checked[k][0]) for k in values}}
        return new

    def default_space(self) -> Any:
        """The model's documented default random inputs (a ParameterSpace), or ``None``."""
        return None

    # ----------------------------------------------------------------- validation
    def validate_params(self, params: Mapping[str, Any] | None) -> dict[str, np.ndarray]:
        """Check names, shapes, finiteness and ranges; fill nominal values.

        Returns a dict with every parameter as a float array of one common length.
        """
        if params is not None and not hasattr(params, "keys"):
            raise TypeError(f"params: expected a mapping parameter name -> values (a dict, "
                            f"an xarray.Dataset), got {_brief(params)} "
                            f"({type(params).__name__})")
        params = dict(params or {})
        unknown = sorted(set(params) - set(self.parameter_names))
        if unknown:
            raise ValueError(
                f"model {self.name!r}: unknown parameter(s) {', '.join(map(repr, unknown))}; "
                f"valid: {', '.join(self.parameter_names)}"
            )
        arrays = {k: self._numeric(k, v) for k, v in params.items()}
        lengths = {k: a.shape[0] for k, a in arrays.items() if a.ndim == 1}
        for k, a in arrays.items():
            if a.ndim > 1:
                raise ValueError(f"parameter {k!r}: expected a 1-D array, got shape {a.shape}")
        sizes = set(lengths.values())
        if len(sizes) > 1:
            raise ValueError(f"parameters have different lengths: {lengths}")
        n = sizes.pop() if sizes else 1
        if n == 0:
            raise ValueError("parameters are empty: at least one sample is needed")
        out: dict[str, np.ndarray] = {}
        for p in self.parameters:
            a = arrays.get(p.name)
            a = np.full(n, p.nominal) if a is None else np.broadcast_to(a, (n,)).astype(float)
            bad = ~np.isfinite(a)
            if bad.any():
                i = int(np.flatnonzero(bad)[0])
                raise ValueError(f"parameter {p.name!r}: non-finite value {a[i]} at sample {i}")
            if p.integer and np.any(a != np.round(a)):
                i = int(np.flatnonzero(a != np.round(a))[0])
                raise ValueError(
                    f"parameter {p.name!r}: value {a[i]:g} at sample {i} is not a whole number "
                    f"(valid: integers in {p.range_text()})"
                )
            outside = (a < p.lower) | (a > p.upper)
            if outside.any():
                i = int(np.flatnonzero(outside)[0])
                raise ValueError(
                    f"parameter {p.name!r}: value {a[i]:g} at sample {i} outside valid range "
                    f"{p.range_text()} ({int(outside.sum())} sample(s) outside)"
                )
            out[p.name] = np.ascontiguousarray(a)
        return out

    def _numeric(self, name: str, value: Any) -> np.ndarray:
        """Parameter ``name``'s values as a float array, or a ValueError naming it."""
        try:
            a = np.asarray(value)
            if a.dtype.kind in "iuf":
                return np.asarray(a, dtype=float)
            # text, complex, None, mixed lists: look at the values as given, one by one (a
            # complex cast to float would silently drop its imaginary part)
            items = np.asarray(value, dtype=object)
        except (TypeError, ValueError) as exc:
            raise ValueError(f"parameter {name!r}: cannot read {_brief(value)} as an array of "
                             f"numbers ({exc}); {self._valid_numbers(name)}") from None
        for i, v in enumerate(items.ravel()):
            if isinstance(v, (int, float, np.integer, np.floating)) and not isinstance(
                    v, (bool, np.bool_)):
                continue
            if isinstance(v, (complex, np.complexfloating)):
                kind = "a complex number"
            elif isinstance(v, (str, bytes, np.str_, np.bytes_)):
                kind = "text"
            else:
                kind = f"of type {type(v).__name__}"
            v = v.item() if isinstance(v, np.generic) else v
            where = "" if items.ndim == 0 else f" at sample {i}"
            raise ValueError(f"parameter {name!r}: value {_brief(v)}{where} is {kind}, not a "
                             f"real number; {self._valid_numbers(name)}")
        return items.astype(float)

    def _valid_numbers(self, name: str) -> str:
        return f"valid: real numbers in {self.parameter(name).range_text()}"

    def validate_time(self, t: Any) -> np.ndarray:
        """Return ``t`` as a non-empty, finite, non-decreasing 1-D float array (a repeated
        instant is answered by an exact copy of its value)."""
        if t is None:
            if any(o.time_dependent for o in self.outputs):
                raise ValueError("t: this model has time-dependent outputs; give output instants")
            return np.zeros(0)
        if isinstance(t, (str, bytes)):
            raise TypeError(f"t: expected an array of output instants (real numbers), got the "
                            f"string {t!r}; e.g. numpy.linspace(0.0, 10.0, 101)")
        try:
            t = np.atleast_1d(np.asarray(t, dtype=float))
        except (TypeError, ValueError):
            raise TypeError(f"t: expected an array of output instants (real numbers), got "
                            f"{_brief(t)} ({type(t).__name__})") from None
        if t.ndim != 1:
            raise ValueError(f"t: expected a 1-D array of instants, got shape {t.shape}")
        if t.size == 0:
            raise ValueError("t: empty time array; give at least one output instant")
        if not np.all(np.isfinite(t)):
            raise ValueError("t: contains non-finite values")
        if np.any(np.diff(t) < 0):
            raise ValueError("t: instants must be sorted in increasing order")
        return t

    def validate_outputs(self, outputs: str | Iterable[str] | None) -> list[str]:
        """Return the requested output names (all when ``None``), rejecting unknown ones."""
        if outputs is None:
            return self.output_names
        if isinstance(outputs, str):
            outputs = [outputs]
        try:
            outputs = list(dict.fromkeys(outputs))
        except TypeError:
            raise TypeError(f"outputs: expected an output name or a list of names, got "
                            f"{_brief(outputs)} ({type(outputs).__name__}); valid names: "
                            f"{', '.join(self.output_names)}") from None
        wrong = [o for o in outputs if not isinstance(o, str)]
        if wrong:
            raise TypeError(f"outputs: names are text, got {_brief(wrong[0])} "
                            f"({type(wrong[0]).__name__}); valid names: "
                            f"{', '.join(self.output_names)}")
        unknown = [o for o in outputs if o not in self.output_names]
        if unknown:
            raise ValueError(
                f"model {self.name!r} has no output(s) {', '.join(map(repr, unknown))}; "
                f"valid: {', '.join(self.output_names)}"
            )
        if not outputs:
            raise ValueError("outputs: empty selection; ask for at least one output")
        return outputs

    def validate_options(self, options: Mapping[str, Any] | None) -> dict[str, Any]:
        """Check option names and values; return every declared option with defaults filled.

        Raises
        ------
        ValueError
            For an unknown option (the message lists the valid ones) or a bad value (the
            message names the option, the value and the valid values).
        """
        options = dict(options or {})
        unknown = sorted(set(options) - set(self.option_names))
        if unknown:
            valid = ", ".join(f"{o.name} ({o.valid_text()})" for o in self.options)
            raise ValueError(
                f"model {self.name!r}: unknown option(s) {', '.join(map(repr, unknown))}; "
                f"valid: {valid or 'none (this model takes no options)'}"
            )
        checked = {o.name: o.validate(options.get(o.name, o.default), f"model {self.name!r}")
                   for o in self.options}
        self.check_option_combination(checked)
        return checked

    def check_option_combination(self, options: Mapping[str, Any]) -> None:
        """Refuse options that are valid one by one but not together (a range whose ends
        cross, say), before any design is drawn. The default accepts every combination.

        Parameters
        ----------
        options : mapping
            Every declared option, defaults filled, each value already valid.

        Raises
        ------
        ValueError
            Naming the options and values that do not go together.
        """

    # ----------------------------------------------------------------- the contract
    def prepare(
        self, t: Any = None, *, outputs: str | Iterable[str] | None = None, **options: Any
    ) -> Request:
        """Validate outputs, output instants and options once; return a :class:`Request`.

        Engines call this at the call site, before any design is drawn, and carry the
        request to every chunk; :meth:`response` is ``evaluate(params, prepare(...))``.

        Parameters
        ----------
        t : array_like, optional
            Output instants (in :attr:`time_units`); required for time-dependent outputs.
        outputs : str or list of str, optional
            Outputs to compute and keep (default: all).
        **options
            Declared model options (see :attr:`options`; ``gearuq models NAME`` lists them).

        Raises
        ------
        ValueError
            Unknown or empty outputs, missing/unsorted/non-finite ``t``, unknown options or
            option values outside their valid set.
        """
        names = self.validate_outputs(outputs)
        clash = sorted(set(names) & set(self.parameter_names))
        if clash:
            raise ValueError(f"model {self.name!r}: output name(s) {clash} are also parameter "
                             "names; a result cannot hold both")
        opts = self.validate_options(options)
        need_time = any(self.output(o).time_dependent for o in names)
        tt = self.validate_time(t) if (need_time or t is not None) else None
        return Request(model=self.name, outputs=tuple(names), t=tt, options=opts)

    def evaluate(self, params: Mapping[str, Any] | None, request: Request) -> xr.Dataset:
        """Evaluate a prepared request on parameter samples (the chunk-level entry point).

        Parameters
        ----------
        params : mapping
            Parameter name -> array ``(n_samples,)``; validated here (names, ranges).
        request : Request
            From :meth:`prepare` of this model.
        """
        if not isinstance(request, Request) or request.model != self.name:
            raise ValueError(
                f"request: expected a Request prepared by model {self.name!r}, got "
                f"{getattr(request, 'model', type(request).__name__)!r}")
        p = self.validate_params(params)
        names = list(request.outputs)
        tt = np.zeros(0) if request.t is None else request.t
        ev = self._evaluate(p, tt, names, **request.options)
        return self._assemble(p, tt, names, ev, request.options)

    def response(
        self,
        params: Mapping[str, Any] | None,
        t: Any = None,
        *,
        outputs: str | Iterable[str] | None = None,
        **options: Any,
    ) -> xr.Dataset:
        """Evaluate the model on parameter samples.

        Parameters
        ----------
        params : mapping
            Parameter name -> array of shape ``(n_samples,)`` (scalars broadcast). Missing
            names take nominal values; unknown names or out-of-range values raise ValueError.
        t : array_like
            Output instants (in :attr:`time_units`); required for time-dependent outputs.
        outputs : str or list of str, optional
            Outputs to compute and keep (default: all).
        **options
            Declared model options (solver/fidelity settings; see :attr:`options`).

        Returns
        -------
        xarray.Dataset
            Inputs and outputs over ``sample`` (and ``time``), a ``status`` flag per sample.
        """
        return self.evaluate(params, self.prepare(t, outputs=outputs, **options))

    def _evaluate(
        self, params: dict[str, np.ndarray], t: np.ndarray, outputs: list[str], **options: Any
    ) -> Evaluation:
        """Compute the requested outputs; implemented by every model."""
        raise NotImplementedError

    def _time_attrs(self, options: Mapping[str, Any]) -> dict[str, str]:
        return {"units": self.time_units, "long_name": self.time_long_name}

    def _assemble(
        self,
        p: dict[str, np.ndarray],
        t: np.ndarray,
        names: list[str],
        ev: Evaluation,
        options: Mapping[str, Any],
    ) -> xr.Dataset:
        n = next(iter(p.values())).shape[0] if p else ev.status.shape[0]
        coords: dict[str, Any] = {"sample": ("sample", np.arange(n))}
        if any(self.output(o).time_dependent for o in names):
            coords["time"] = ("time", t, self._time_attrs(options))
        for k, (dims, values, attrs) in ev.coords.items():
            coords[k] = (dims, values, attrs)
        # one Dataset construction: assigning variables one by one re-merges the whole
        # Dataset each time (quadratic in the number of variables, ~6 ms per variable)
        data: dict[str, Any] = {}
        for par in self.parameters:
            data[par.name] = ("sample", p[par.name], {
                "units": par.units, "long_name": par.description, "role": "input",
            })
        for o in names:
            meta = self.output(o)
            attrs = {"units": meta.units, "long_name": meta.description, "role": "output"}
            if meta.valid_min is not None:
                attrs["valid_min"] = float(meta.valid_min)
            data[o] = (meta.dims, np.asarray(ev.data[o]), attrs)
        for k, (dims, values, attrs) in ev.extra.items():
            data[k] = (dims, values, {**attrs, "role": "diagnostic"})
        data["status"] = ("sample", np.asarray(ev.status, dtype=np.int8),
                          status_attrs(ev.status_meanings))
        ds = xr.Dataset(data, coords=coords)
        ds.attrs.update({
            "gearuq_version": __version__,
            "model": self.name,
            "model_version": str(self.version),
            "outputs": " ".join(names),
        })
        if options:
            import json

            ds.attrs["options"] = json.dumps(
                {k: _jsonable_value(v) for k, v in sorted(options.items())}, sort_keys=True)
        ds.attrs.update({k: _attr_value(v) for k, v in ev.attrs.items()})
        return ds


def status_attrs(extra: Mapping[int, str] | None = None) -> dict[str, Any]:
    """CF-style flag attributes of a ``status`` variable."""
    meanings = {**STATUS_MEANINGS, **(extra or {})}
    codes = sorted(meanings)
    return {
        "long_name": "per-sample solver status (0 = ok)",
        "units": "1",
        "flag_values": np.array(codes, dtype=np.int8),
        "flag_meanings": " ".join(meanings[c].replace(" ", "_") for c in codes),
        "role": "status",
    }


def status_meanings(status: Any) -> dict[int, str]:
    """Code -> name of a ``status`` flag variable, the inverse of :func:`status_attrs`.

    Parameters
    ----------
    status : xarray.DataArray or mapping
        A result's ``status`` variable, or its attributes (CF ``flag_values`` and
        ``flag_meanings``).

    Returns
    -------
    dict
        ``{code: name}`` with the names as stored (words joined by underscores); empty for a
        variable without flags.
    """
    attrs = getattr(status, "attrs", status)
    codes = np.atleast_1d(attrs.get("flag_values", []))
    names = str(attrs.get("flag_meanings", "")).split()
    return {int(c): name for c, name in zip(codes, names, strict=False)}


def _brief(value: Any, limit: int = 60) -> str:
    """``repr(value)`` shortened for an error message."""
    text = repr(value)
    return text if len(text) <= limit else text[: limit - 3] + "..."


def _attr_value(v: Any) -> Any:
    """Convert an attribute to a netCDF-safe type (no bool/None/dict)."""
    if isinstance(v, bool):
        return int(v)
    if v is None:
        return "none"
    if isinstance(v, (dict, list, tuple)) and not all(isinstance(x, (int, float)) for x in v):
        import json

        return json.dumps(v, default=str)
    return v


# --------------------------------------------------------------------------- FunctionModel
def _as_parameter(p: Parameter | str | tuple) -> Parameter:
    if isinstance(p, Parameter):
        return p
    if isinstance(p, str):
        return Parameter(p, "1", 0.0)
    if isinstance(p, tuple):
        try:
            return Parameter(*p)
        except TypeError:
            raise TypeError(f"parameters: {p!r}: a tuple is (name, units, nominal[, lower, "
                            f"upper[, description]]); got {len(p)} item(s)") from None
    raise TypeError(f"parameters: expected Parameter, name or tuple, got {type(p).__name__}")


def _as_output(o: Output | str, time_dependent: bool) -> Output:
    if isinstance(o, Output):
        return o
    if isinstance(o, str):
        return Output(o, "1", ("sample", "time") if time_dependent else ("sample",))
    raise TypeError(f"outputs: expected Output or name, got {type(o).__name__}")


class FunctionModel(Model):
    """Wrap a plain vectorised Python function as a gearuq model.

    Parameters
    ----------
    fn : callable
        ``fn(**params)`` or, if it accepts an argument named ``t``, ``fn(t=t, **params)``;
        each parameter arrives as an array of shape ``(n,)``. It returns one array (for a
        single output), a tuple of arrays in output order, or a dict name -> array. Arrays are
        shaped ``(n,)`` or ``(n, n_time)``. Non-finite results are flagged per sample with
        status ``non_finite_state``, never dropped.
    parameters : sequence of Parameter, str or tuple
        Inputs; a bare name means a dimensionless, unbounded input with nominal 0.
    outputs : sequence of Output or str
        Responses; bare names get units "1".
    name, description, version : str
        Metadata shown by ``gearuq models``.
    time_dependent : bool
        Default dims for outputs given by name only.
    time_units : str
        Unit of ``t``.
    options : sequence of Option
        Keyword options of ``fn`` that callers may set (validated like any model's options
        and passed to ``fn``).

    Examples
    --------
    >>> import numpy as np, gearuq
    >>> ishigami = gearuq.FunctionModel(
    ...     lambda x1, x2, x3: np.sin(x1) + 7 * np.sin(x2) ** 2 + 0.1 * x3**4 * np.sin(x1),
    ...     ["x1", "x2", "x3"], ["y"], name="ishigami")
    >>> float(ishigami.response({"x1": [0.0], "x2": [0.0], "x3": [0.0]})["y"][0])
    0.0
    """

    def __init__(
        self,
        fn: Callable[..., Any],
        parameters: Sequence[Parameter | str | tuple],
        outputs: Sequence[Output | str],
        *,
        name: str = "function",
        description: str = "user function",
        version: str = "0",
        time_dependent: bool = False,
        time_units: str = "s",
        options: Sequence[Option] = (),
    ) -> None:
        self.fn = fn
        self.name = name
        self.description = description
        self.version = version
        self.time_units = time_units
        self.parameters = tuple(_as_parameter(p) for p in parameters)
        self.outputs = tuple(_as_output(o, time_dependent) for o in outputs)
        self.options = tuple(options)
        if not self.parameters or not self.outputs:
            raise ValueError("FunctionModel needs at least one parameter and one output")
        for what, names in (("parameters", [p.name for p in self.parameters]),
                            ("outputs", [o.name for o in self.outputs])):
            twice = sorted({n for n in names if names.count(n) > 1})
            if twice:
                raise ValueError(f"FunctionModel {name!r}: {what}: duplicate name(s) {twice}")
        clash = sorted({p.name for p in self.parameters} & {o.name for o in self.outputs})
        if clash:
            raise ValueError(f"FunctionModel {name!r}: names {clash} are given both as "
                             "parameters and as outputs; rename the outputs")
        try:
            sig = inspect.signature(fn)
        except (TypeError, ValueError):  # a builtin or extension: called as documented
            self._wants_t = False
            return
        self._wants_t = "t" in sig.parameters
        takes_any = any(q.kind is inspect.Parameter.VAR_KEYWORD for q in sig.parameters.values())
        keywords = {n for n, q in sig.parameters.items()
                    if q.kind in (inspect.Parameter.POSITIONAL_OR_KEYWORD,
                                  inspect.Parameter.KEYWORD_ONLY)}
        missing = [p.name for p in self.parameters if p.name not in keywords]
        if missing and not takes_any:
            raise ValueError(
                f"FunctionModel {name!r}: fn takes ({', '.join(sig.parameters)}) but is called "
                f"with the parameters by name; it has no argument for {missing}")

    def _evaluate(self, params, t, outputs, **options):
        kwargs = dict(params)
        if self._wants_t:
            kwargs["t"] = t
        raw = self.fn(**kwargs, **options)
        names = self.output_names
        if isinstance(raw, Mapping):
            absent = [k for k in outputs if k not in raw]
            if absent:
                raise ValueError(f"FunctionModel {self.name!r}: fn returned the keys "
                                 f"{sorted(map(str, raw))}; the declared output(s) {absent} "
                                 "are missing")
            values = {k: np.asarray(raw[k], dtype=float) for k in outputs}
        elif isinstance(raw, tuple):
            if len(raw) != len(names):
                raise ValueError(f"function returned {len(raw)} outputs, declared {len(names)}")
            values = {k: np.asarray(v, dtype=float) for k, v in zip(names, raw, strict=True)}
        else:
            if len(names) != 1:
                raise ValueError(f"function returned one array, declared outputs {names}")
            values = {names[0]: np.asarray(raw, dtype=float)}
        n = next(iter(params.values())).shape[0]
        status = np.zeros(n, dtype=np.int8)
        data = {}
        for k in outputs:
            meta = self.output(k)
            shape = (n, t.size) if meta.time_dependent else (n,)
            if values[k].shape != shape:
                # numpy would broadcast one value to every sample (or instant): refused
                raise ValueError(
                    f"FunctionModel {self.name!r}: output {k!r} has shape {values[k].shape}, "
                    f"expected {shape} (one value per sample"
                    + (", per output instant)" if meta.time_dependent else
                       "; a time series needs the output declared time-dependent)"))
            v = values[k].astype(float)
            status[~np.isfinite(v.reshape(n, -1)).all(axis=1)] = STATUS_NONFINITE
            data[k] = v
        return Evaluation(data=data, status=status)
