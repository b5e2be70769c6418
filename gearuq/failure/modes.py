"""Failure modes: allowed bands, limit states ``g <= 0`` and systems of them.

A :class:`Band` is an allowed interval ``[lower, upper]`` on one output (the limits are safe;
``absolute=True`` applies it to ``|value|``).

A :class:`LimitState` is a function ``g`` of a result's variables (model outputs, or inputs)
whose **failure side is inclusive**: a sample fails where ``g <= 0``. This differs on purpose
from a :class:`Band`, whose limits are safe: with ``g = max(x, 0)`` and
``x`` standard normal, ``P(g <= 0) = 0.5`` and a limit state reports exactly that.

Three ways to make one:

* ``LimitState.output("g")`` — the output *is* the limit-state function (the usual form of
  analytic benchmark models);
* ``LimitState.upper("mesh_force", 5e4)`` / ``LimitState.lower("r", 0.2)`` — a threshold on an
  output (``g = limit - value`` resp. ``value - limit``), with ``absolute=True`` for ``|value|``
  and ``select={"dof": ...}`` for outputs with extra dims;
* ``LimitState(fn, ["R", "S"])`` — any vectorised function of several variables,
  ``g = fn(R=..., S=...)``.

Time-dependent responses give ``g(t)`` over the output instants (optionally restricted to a
``window``); engines that need one number per sample take the **first-passage** value
``min_t g(t)``: a sample fails in the window if it fails at any output instant. This is the
limit state of the running maximum of the response; how far a time grid can be from the
continuous-time answer is discussed in :mod:`gearuq.failure.outcrossing`. With
``first_passage="parabola"`` the minimum is also taken **between** the instants: every local
minimum of ``g`` on the instants is refined by the vertex of the parabola through it and its
two neighbours (:func:`first_passage_min`). Without it, a response whose peaks are narrow
against the instants' spacing has a ``min_t g`` that depends on where the instants fall on each
peak: the failure set in parameter space then has thin "aliasing" fingers that move with every
parameter that shifts the response's phase against the grid.

Systems combine limit states per instant (then over time): a :class:`SeriesSystem` fails when
any component fails (``g = min g_i``), a :class:`ParallelSystem` when all fail
(``g = max g_i``), and :func:`cut_set_system` is a series system of parallel cut sets. The
combined ``g`` has exactly the system's failure indicator as its sign, so every engine works on
systems; active-learning Kriging additionally learns each component separately
(:meth:`System.combine` returns which component governs each sample).

Input that could mean two things is refused with the reason: a bare list of limit states
(series or parallel?), a mapping ``{output: number}`` (upper or lower limit?), an output with
extra dims and no ``select``.
"""


from __future__ import annotations

import json
import math
from collections.abc import Callable, Iterable, Mapping, Sequence
from typing import Any

import numpy as np
import xarray as xr

__all__ = ["Band", "LimitState", "System", "SeriesSystem", "ParallelSystem", "cut_set_system",
           "as_limit_state", "as_bands", "first_passage_min", "FIRST_PASSAGE"]

#: How the first-passage value ``min_t g(t)`` is taken: over the output instants only, or
#: refined between them by a parabola through every local minimum and its two neighbours.
FIRST_PASSAGE = ("grid", "parabola")


def first_passage_min(g: Any, t: Any, how: str = "grid") -> np.ndarray:
    """``min_t g(t)`` per row of ``g`` (n, n_t) over the instants ``t`` (n_t,).

    Parameters
    ----------
    g : array_like (n, n_t)
        Limit-state values; a row holding a NaN gives NaN (neither safe nor failed).
    t : array_like (n_t,)
        Increasing instants (any spacing).
    how : {"grid", "parabola"}
        ``"grid"``: the smallest value on the instants. ``"parabola"``: every interior local
        minimum ``g_i`` (not above either neighbour) is replaced by the vertex value of the
        parabola through it and its two neighbours, ``g_i - b^2 / (4 a)`` with ``a`` half the
        parabola's second derivative and ``b`` its slope at ``t_i``, and the smallest of these
        and of the instants' values is returned. Never above the grid value; exact for a
        parabola; for a smooth peak of curvature ``g''`` sampled every ``h`` the grid value is
        off by up to ``g'' h^2 / 8``, the vertex by ``O(g''' h^3)``. A minimum at the first or
        last instant (the edge of a window) stays as sampled: nothing is known beyond it.

    Raises
    ------
    ValueError
        For an unknown ``how``, or instants that do not match the time axis of ``g`` or do
        not increase.
    """
    if how not in FIRST_PASSAGE:
        raise ValueError(f"first_passage: {how!r} is not one of {', '.join(FIRST_PASSAGE)}")
    g = np.atleast_2d(np.asarray(g, dtype=float))
    nan = np.isnan(g).any(axis=1)
    out = np.min(g, axis=1)
    out[nan] = np.nan
    if how == "grid" or g.shape[1] < 3:
        return out
    t = np.asarray(t, dtype=float)
    if t.shape != (g.shape[1],) or not np.all(np.diff(t) > 0):
        raise ValueError(f"first_passage: instants t must increase and number {g.shape[1]} "
                         f"(the time axis of g), got shape {t.shape}")
    h1 = np.diff(t)[:-1]
    h2 = np.diff(t)[1:]
    gl, gc, gr = g[:, :-2], g[:, 1:-1], g[:, 2:]
    with np.errstate(invalid="ignore", divide="ignore"):
        d1 = (gc - gl) / h1
        d2 = (gr - gc) / h2
        a = (d2 - d1) / (h1 + h2)  # half the parabola's second derivative
        b = (d1 * h2 + d2 * h1) / (h1 + h2)  # its slope at t_i
        local = (gc <= gl) & (gc <= gr) & (a > 0)
        vertex = np.where(local, gc - b * b / (4.0 * np.where(local, a, 1.0)), np.inf)
    refined = np.minimum(out, np.min(vertex, axis=1))
    refined[nan] = np.nan
    return refined


# =========================================================================== Band

def time_window(value: Any, name: str) -> tuple[float, float]:
    """``value`` as a closed time window ``(t0, t1)`` of finite numbers with ``t0 <= t1``.

    Parameters
    ----------
    value : pair of real numbers
        The window's first and last instant.
    name : str
        What the caller calls it, for the error message (``"time"``, ``"window"``...).

    Raises
    ------
    TypeError
        If ``value`` is not a pair (a single number, a string, a mapping...).
    ValueError
        If an end is not a finite real number, or the window is reversed.
    """
    if isinstance(value, (str, bytes, Mapping)) or not isinstance(value, (Sequence, np.ndarray)):
        raise TypeError(f"{name}: expected a pair (t0, t1) of instants, got {value!r} "
                        f"({type(value).__name__})")
    if len(value) != 2:
        raise TypeError(f"{name}: expected a pair (t0, t1) of instants, got {len(value)} "
                        f"values {value!r}")
    ends = []
    for which, end in zip(("t0", "t1"), value, strict=True):
        try:
            number = float(end)
        except (TypeError, ValueError):
            raise ValueError(f"{name}: {which} = {end!r} is not a real number; valid: a pair "
                             "(t0, t1) of finite instants with t0 <= t1") from None
        if not math.isfinite(number):
            raise ValueError(f"{name}: {which} = {end!r} is not finite; valid: a pair (t0, t1) "
                             "of finite instants with t0 <= t1")
        ends.append(number)
    if ends[0] > ends[1]:
        raise ValueError(f"{name}: ({ends[0]:g}, {ends[1]:g}) is reversed; valid: a pair "
                         "(t0, t1) with t0 <= t1")
    return ends[0], ends[1]


def check_band_reach(output: str, lower: float, upper: float, absolute: bool,
                     valid_min: float | None, units: str = "") -> None:
    """The check of :meth:`Band.check_reach`, on a band's numbers (see there)."""
    if valid_min is None or not math.isfinite(float(valid_min)):
        return
    low = float(valid_min)
    if absolute:
        if low < 0.0:  # |value| >= 0 only; an upper <= 0 is refused when the band is made
            return
    unit = f" {units}" if units and units != "1" else ""
    what = f"|{output}|" if absolute else output
    if upper < low:
        raise ValueError(
            f"Band on {output!r}: upper={upper:g} is below every value {what} can take "
            f"({what} >= {low:g}{unit}): every sample would fail; give an upper above "
            f"{low:g}")
    if upper == math.inf and lower <= low:
        raise ValueError(
            f"Band on {output!r}: lower={lower:g} is at or below every value {what} can "
            f"take ({what} >= {low:g}{unit}) and the band has no upper limit: no sample can "
            f"fail; give a lower above {low:g} or an upper")


def _limit(output: str, side: str, value: Any, default: float) -> float:
    """A band limit as a float (``None``: open), or an error naming the side and value."""
    if value is None:
        return default
    if isinstance(value, (str, bytes, bool)):
        raise ValueError(f"Band on {output!r}: {side}={value!r} is not a number")
    try:
        return float(value)
    except (TypeError, ValueError):
        raise ValueError(f"Band on {output!r}: {side}={value!r} is not a number") from None


class Band:
    """Allowed interval on one model output: the limit state of a failure mode.

    Parameters
    ----------
    output : str
        Name of the output variable in the result Dataset.
    lower, upper : float, optional
        Closed band limits in the output's units; ``None`` (or -inf/+inf) leaves a side open.
        At least one side must be given and ``lower < upper``.
    name : str, optional
        Label of the failure mode (default: the output name, with ``|...|`` for absolute bands).
    absolute : bool
        Apply the band to ``|value|`` (vibration amplitudes, signed deflections).
    select : mapping, optional
        ``xarray`` label selection applied to the output first, e.g. ``{"dof": "x1"}``. Dims
        other than ``sample`` and ``time`` that remain after selection expand the band into one
        mode per element, labelled ``"name[dof=x1]"``.

    Notes
    -----
    A sample fails at an instant when ``value < lower`` or ``value > upper`` (``|value|`` when
    ``absolute``); a value equal to a limit is safe.
    """

    __slots__ = ("output", "lower", "upper", "name", "absolute", "select")

    def __init__(
        self,
        output: str,
        lower: float | None = None,
        upper: float | None = None,
        *,
        name: str | None = None,
        absolute: bool = False,
        select: Mapping[str, Any] | None = None,
    ) -> None:
        if not isinstance(output, str) or not output:
            raise ValueError(f"Band: output must be a non-empty string, got {output!r}")
        lo, up = (_limit(output, side, value, default) for side, value, default in
                  (("lower", lower, -math.inf), ("upper", upper, math.inf)))
        if math.isnan(lo) or math.isnan(up):
            raise ValueError(f"Band on {output!r}: limits must not be NaN (lower={lower}, "
                             f"upper={upper})")
        if lo >= up:
            raise ValueError(
                f"Band on {output!r}: lower={lo:g} must be < upper={up:g}"
            )
        if lo == -math.inf and up == math.inf:
            raise ValueError(f"Band on {output!r}: both sides open; give lower and/or upper")
        if absolute and up <= 0:
            raise ValueError(
                f"Band on {output!r}: absolute band needs upper > 0 (|value| >= 0), got {up:g}"
            )
        if absolute and up == math.inf and lo <= 0:
            raise ValueError(
                f"Band on {output!r}: absolute band with lower={lo:g} and no upper: |value| >= 0 "
                "never falls below it, so no sample can fail; give a lower above 0 or an upper")
        if name is not None and (not isinstance(name, str) or not name):
            raise ValueError(f"Band on {output!r}: name must be a non-empty string")
        self.output = output
        self.lower = lo
        self.upper = up
        self.absolute = bool(absolute)
        self.select = dict(select) if select else {}
        self.name = name if name is not None else (f"|{output}|" if absolute else output)

    def check_reach(self, valid_min: float | None, units: str = "") -> None:
        """Refuse a band that every value of its output leaves, or that none can leave.

        Parameters
        ----------
        valid_min : float or None
            The smallest value the output takes (its ``valid_min``; ``None``: unknown,
            nothing to check).
        units : str
            The output's units, for the message.

        Raises
        ------
        ValueError
            When ``upper`` lies below ``valid_min`` (every sample would fail: a failure
            probability of 1 that only restates the typo), or when the band is open above
            and ``lower`` is at or below ``valid_min`` (no sample can fail).
        """
        check_band_reach(self.output, self.lower, self.upper, self.absolute, valid_min, units)

    # ------------------------------------------------------------------ helpers
    def __repr__(self) -> str:
        parts = [repr(self.output)]
        if self.lower > -math.inf:
            parts.append(f"lower={self.lower!r}")
        if self.upper < math.inf:
            parts.append(f"upper={self.upper!r}")
        parts.append(f"name={self.name!r}")
        if self.absolute:
            parts.append("absolute=True")
        if self.select:
            parts.append(f"select={self.select!r}")
        return f"Band({', '.join(parts)})"

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Band):
            return NotImplemented
        return all(getattr(self, s) == getattr(other, s) for s in self.__slots__)

    def __hash__(self) -> int:
        return hash((self.output, self.lower, self.upper, self.name, self.absolute))

    def describe(self) -> str:
        """Human-readable safe set, e.g. ``"-1 <= |y| <= 2"``."""
        v = f"|{self.output}|" if self.absolute else self.output
        if self.lower > -math.inf and self.upper < math.inf:
            return f"{self.lower:g} <= {v} <= {self.upper:g}"
        if self.lower > -math.inf:
            return f"{v} >= {self.lower:g}"
        return f"{v} <= {self.upper:g}"

    def fails(self, values: Any) -> np.ndarray:
        """Boolean failure indicator of ``values`` (True = outside the band).

        Raises
        ------
        ValueError
            If ``values`` contains NaN (a NaN is neither safe nor failed).
        """
        v = np.asarray(values, dtype=float)
        if np.isnan(v).any():
            raise ValueError(
                f"Band {self.name!r}: {int(np.isnan(v).sum())} NaN value(s); a NaN is neither "
                "safe nor failed"
            )
        if self.absolute:
            v = np.abs(v)
        return (v < self.lower) | (v > self.upper)

    def pf_from_distribution(self, dist: Any) -> float:
        """Probability of leaving the band under a (frozen scipy) distribution of the output.

        Uses ``cdf``/``sf`` tails separately so small probabilities keep full precision.
        """
        pf = 0.0
        if self.absolute:
            pf += float(dist.sf(self.upper)) + float(dist.cdf(-self.upper))
            if self.lower > 0:
                pf += float(dist.cdf(self.lower)) - float(dist.cdf(-self.lower))
        else:
            if self.upper < math.inf:
                pf += float(dist.sf(self.upper))
            if self.lower > -math.inf:
                pf += float(dist.cdf(self.lower))
        return min(max(pf, 0.0), 1.0)


def as_bands(bands: Any) -> list[Band]:
    if isinstance(bands, Band):
        return [bands]
    out: list[Band] = []
    if isinstance(bands, Mapping):
        for key, spec in bands.items():
            if isinstance(spec, Band):
                out.append(spec)
            elif isinstance(spec, Mapping):
                valid = ("lower", "upper", "name", "absolute", "select")
                unknown = sorted(str(k) for k in spec if k not in valid)
                if unknown:
                    raise ValueError(f"bands[{key!r}]: unknown key(s) {unknown}; valid: "
                                     f"{', '.join(valid)}")
                out.append(Band(key, **spec))
            elif isinstance(spec, Sequence) and not isinstance(spec, str) and len(spec) == 2:
                out.append(Band(key, spec[0], spec[1]))
            else:
                raise ValueError(
                    f"bands[{key!r}]: expected (lower, upper), a Band or a dict of Band "
                    f"arguments, got {spec!r}"
                )
    elif isinstance(bands, Iterable) and not isinstance(bands, str):
        for b in bands:
            if not isinstance(b, Band):
                raise ValueError(f"bands: expected Band objects, got {type(b).__name__}")
            out.append(b)
    else:
        raise ValueError(
            "bands: expected a Band, a list of Bands or a dict {output: (lower, upper)}"
        )
    if not out:
        raise ValueError("bands: empty; give at least one band")
    return out


class _GFunction:
    """What a limit state and a system share: ``g`` over the result, reduced per sample."""

    #: How ``min_t g(t)`` is taken (one of :data:`FIRST_PASSAGE`).
    first_passage = "grid"

    def values(self, ds: xr.Dataset) -> xr.DataArray:  # pragma: no cover - abstract
        raise NotImplementedError

    def sample_values(self, ds: xr.Dataset) -> np.ndarray:
        """One ``g`` per sample: the first-passage value ``min_t g(t)`` for time-dependent g.

        NaN where any instant of ``g`` is NaN (a NaN is neither safe nor failed).
        """
        return self.reduce_time(self.values(ds))

    def reduce_time(self, g: xr.DataArray, step: int = 1) -> np.ndarray:
        """``min_t g(t)`` per sample of ``g`` over every ``step``-th instant, taken as
        :attr:`first_passage` says (:func:`first_passage_min`); ``g`` without time as is."""
        if "time" not in g.dims:
            return np.asarray(g.transpose("sample").values, dtype=float)
        g = g.isel(time=slice(0, None, step)).transpose("sample", "time")
        return first_passage_min(g.values, g["time"].values, self.first_passage)

    def fails(self, ds: xr.Dataset) -> xr.DataArray:
        """Boolean failure indicator ``g <= 0`` over sample (and time)."""
        return self.values(ds) <= 0.0


def _censored_statuses(value: Sequence[int] | None) -> tuple[int, ...]:
    """The censored statuses as sorted distinct ints (nonzero, within the int8 of a status)."""
    if value is None:
        return ()
    if isinstance(value, (str, bytes)) or not isinstance(value, (int, np.integer, Iterable)):
        raise ValueError(f"LimitState: censored_statuses must be model status codes in "
                         f"1..127 (an int or a sequence of them), got {value!r}")
    items = [value] if isinstance(value, (int, np.integer)) else list(value)
    for code in items:
        if (isinstance(code, bool) or not isinstance(code, (int, np.integer))
                or not 0 < int(code) <= 127):
            raise ValueError(f"LimitState: censored_statuses must be model status codes in "
                             f"1..127, got {code!r} in {value!r}")
    return tuple(sorted({int(c) for c in items}))


class LimitState(_GFunction):
    """A limit-state function ``g`` of result variables; failure where ``g <= 0``.

    Parameters
    ----------
    function : callable
        Vectorised ``function(**{var: array}) -> array``; receives every variable named in
        ``variables`` as an array over ``sample`` (and ``time`` for time-dependent outputs,
        broadcast as xarray does).
    variables : str or sequence of str
        Names of the result variables (outputs, or inputs) that ``function`` takes.
    name : str, optional
        Label (default: ``"g(" + variables + ")"``).
    window : (float, float), optional
        Closed time window ``[t0, t1]``; instants outside it are ignored.
    select : mapping, optional
        ``xarray`` label selection applied to every variable first (``{"dof": "x1"}``).
    description : str, optional
        Human-readable definition (recorded in results).
    first_passage : {"grid", "parabola"}
        How a time-dependent ``g`` is reduced to ``min_t g(t)``: over the output instants, or
        refined between them by a parabola through every local minimum
        (:func:`first_passage_min`: the continuous-time peak of a smooth response).
    censored_statuses : sequence of int, optional
        Nonzero model statuses under which the outputs still bound the answer: the run is at
        least as close to failure as its ``g`` reads (``g`` an upper bound of the true value;
        for :meth:`upper`, an output that is a lower bound of its true value, such as a
        resonance peak located only from below). Such a run stays invalid (counted and
        flagged, never a silent value); subset simulation reads it at its bound while it
        explores instead of as failed, and a bound at or below 0 is a failure whatever the
        true value (:ref:`reliability: censored runs <censored-runs>`). Declaring a status
        whose outputs are not such a bound makes that reading wrong.

    Notes
    -----
    Use the constructors :meth:`output`, :meth:`upper` and :meth:`lower` for the common cases;
    they record a JSON definition that a result can be traced back to.
    """

    def __init__(
        self,
        function: Callable[..., Any],
        variables: str | Sequence[str],
        *,
        name: str | None = None,
        window: tuple[float, float] | None = None,
        select: Mapping[str, Any] | None = None,
        description: str | None = None,
        first_passage: str = "grid",
        censored_statuses: Sequence[int] | None = None,
    ) -> None:
        if not callable(function):
            raise ValueError(f"LimitState: function must be callable, got {function!r}")
        names = [variables] if isinstance(variables, str) else list(variables)
        if not names or not all(isinstance(v, str) and v for v in names):
            raise ValueError(f"LimitState: variables must be non-empty names, got {variables!r}")
        if len(set(names)) != len(names):
            raise ValueError(f"LimitState: duplicate variable names in {names}")
        if window is not None:
            window = time_window(window, "LimitState: window")
        if name is not None and (not isinstance(name, str) or not name):
            raise ValueError(f"LimitState: name must be a non-empty string, got {name!r}")
        if first_passage not in FIRST_PASSAGE:
            raise ValueError(f"LimitState: first_passage must be one of "
                             f"{', '.join(FIRST_PASSAGE)}, got {first_passage!r}")
        self.censored_statuses = _censored_statuses(censored_statuses)
        self.first_passage = first_passage
        self.function = function
        self.variables = tuple(names)
        self.window = window
        self.select = dict(select) if select else {}
        self.name = name or f"g({', '.join(names)})"
        self.description = description or (
            f"{getattr(function, '__qualname__', repr(function))}({', '.join(names)}) <= 0")
        self._spec: dict[str, Any] = {"kind": "function", "function": getattr(
            function, "__qualname__", repr(function)), "variables": list(names)}

    # ------------------------------------------------------------------ constructors
    @classmethod
    def output(cls, name: str, **kwargs: Any) -> LimitState:
        """The output ``name`` is the limit-state function itself (failure ``g <= 0``)."""
        ls = cls(_identity, name, name=kwargs.pop("name", name),
                 description=f"{name} <= 0", **kwargs)
        ls._spec = {"kind": "output", "output": name}
        return ls

    @classmethod
    def upper(cls, output: str, limit: float, *, absolute: bool = False,
              **kwargs: Any) -> LimitState:
        """Failure when the output reaches ``limit`` or above: ``g = limit - value``.

        With ``absolute=True``, ``g = limit - |value|`` (vibration amplitudes).
        """
        limit = _finite(limit, "limit")
        v = f"|{output}|" if absolute else output
        fn = _UpperLimit(limit, bool(absolute))
        ls = cls(fn, output, name=kwargs.pop("name", f"{v} >= {limit:g}"),
                 description=f"g = {limit:g} - {v}; fails where {v} >= {limit:g}", **kwargs)
        ls._spec = {"kind": "upper", "output": output, "limit": limit, "absolute": absolute}
        return ls

    @classmethod
    def lower(cls, output: str, limit: float, **kwargs: Any) -> LimitState:
        """Failure when the output reaches ``limit`` or below: ``g = value - limit``."""
        limit = _finite(limit, "limit")
        fn = _LowerLimit(limit)
        ls = cls(fn, output, name=kwargs.pop("name", f"{output} <= {limit:g}"),
                 description=f"g = {output} - {limit:g}; fails where {output} <= {limit:g}",
                 **kwargs)
        ls._spec = {"kind": "lower", "output": output, "limit": limit}
        return ls

    @classmethod
    def from_band(cls, band: Any) -> LimitState:
        """The limit state of a :class:`Band` (leaving the band fails).

        ``g = min(value - lower, upper - value)`` (``|value|`` for absolute bands). Unlike the
        band, a value exactly on a limit now **fails**; for continuous outputs this changes
        nothing.
        """
        fn = _BandDistance(band.lower, band.upper, band.absolute)
        ls = cls(fn, band.output, name=band.name, select=band.select or None,
                 description=f"leaves the band {band.describe()} (limits fail)")
        ls._spec = {"kind": "band", "output": band.output, "lower": _json_num(band.lower),
                    "upper": _json_num(band.upper), "absolute": band.absolute}
        return ls

    # ------------------------------------------------------------------ description
    @property
    def outputs(self) -> tuple[str, ...]:
        """The result variables this limit state reads (alias of :attr:`variables`)."""
        return self.variables

    def leaves(self) -> list[LimitState]:
        """The component limit states (just this one)."""
        return [self]

    def to_dict(self) -> dict[str, Any]:
        """JSON-able definition (recorded in every result)."""
        out = {"name": self.name, **self._spec, "description": self.description}
        if self.window is not None:
            out["window"] = list(self.window)
        if self.select:
            out["select"] = {k: str(v) for k, v in self.select.items()}
        if self.first_passage != "grid":
            out["first_passage"] = self.first_passage
        if self.censored_statuses:
            out["censored_statuses"] = list(self.censored_statuses)
        return out

    def to_json(self) -> str:
        """:meth:`to_dict` as a JSON string."""
        return json.dumps(self.to_dict(), sort_keys=True)

    def __repr__(self) -> str:
        return f"LimitState({self.name!r}: {self.description})"

    # ------------------------------------------------------------------ evaluation
    def check(self, ds: xr.Dataset) -> None:
        """Raise a ValueError if a variable is missing or has an unsupported shape."""
        missing = [v for v in self.variables if v not in ds.variables]
        if missing:
            outs = [k for k, v in ds.data_vars.items() if v.attrs.get("role") == "output"]
            raise ValueError(
                f"limit state {self.name!r}: variable(s) {', '.join(map(repr, missing))} not "
                f"in the result; available outputs: {', '.join(outs or map(str, ds.data_vars))}")

    def check_window(self, t: Any, of: str) -> None:
        """Refuse a window reaching outside the instants ``t`` (a first passage there would
        be missed); ``of`` says whose instants they are. No window: nothing to check."""
        if self.window is None or t is None or np.size(t) == 0:
            return
        t0, t1 = float(np.min(t)), float(np.max(t))
        tol = 1e-9 * max(1.0, abs(t0), abs(t1))
        if self.window[0] < t0 - tol or self.window[1] > t1 + tol:
            raise ValueError(
                f"limit state {self.name!r}: window [{self.window[0]:g}, {self.window[1]:g}] "
                f"reaches outside the instants [{t0:g}, {t1:g}] {of}; a first passage in the "
                "part without instants would be missed. Extend t or narrow the window")

    def values(self, ds: xr.Dataset) -> xr.DataArray:
        """``g`` over ``sample`` (and ``time`` inside the window) as a DataArray.

        Raises
        ------
        ValueError
            Missing variables, a failed ``select``, extra dims other than ``sample`` and
            ``time`` left after selection, or a window that holds no output instant.
        """
        self.check(ds)
        args = {}
        for var in self.variables:
            da = ds[var]
            if self.select:
                try:
                    da = da.sel({k: v for k, v in self.select.items() if k in da.dims})
                except (KeyError, ValueError) as exc:
                    raise ValueError(f"limit state {self.name!r}: select={self.select!r} "
                                     f"failed on {var!r} with dims {da.dims}: {exc}") from exc
            extra = [d for d in da.dims if d not in ("sample", "time")]
            if extra:
                raise ValueError(
                    f"limit state {self.name!r}: variable {var!r} has extra dim(s) {extra}; "
                    f"choose one element with select={{{extra[0]!r}: ...}} (or build a system "
                    "over the elements) - which element fails is otherwise ambiguous")
            if self.window is not None and "time" in da.dims:
                self.check_window(da["time"].values, f"of {var!r}")
                da = da.sel(time=slice(*self.window))
                if da.sizes["time"] == 0:
                    raise ValueError(f"limit state {self.name!r}: window {self.window} holds "
                                     f"no output instant of {var!r}")
            args[var] = da
        if self.window is not None and not any("time" in a.dims for a in args.values()):
            raise ValueError(f"limit state {self.name!r}: window={self.window} applies to "
                             f"nothing: {', '.join(map(repr, args))} has no time dimension; "
                             "leave the window out")
        g = self.function(**args)
        ref = max(args.values(), key=lambda a: a.ndim)
        if not isinstance(g, xr.DataArray):
            values = np.asarray(g, dtype=float)
            if values.shape != ref.shape:
                # numpy would broadcast a scalar (or fail on a wrong length) far from here
                raise ValueError(
                    f"limit state {self.name!r}: its function returned shape {values.shape}; "
                    f"it must return one value per sample{' and instant' if ref.ndim > 1 else ''}"
                    f" (shape {ref.shape}, as its argument {ref.name!r}), e.g. by numpy "
                    "operations on its arguments")
            g = xr.DataArray(values, dims=ref.dims, coords=ref.coords)
        elif g.sizes.get("sample") != ref.sizes["sample"]:
            raise ValueError(f"limit state {self.name!r}: its function returned dims "
                             f"{dict(g.sizes)}; it must keep the {ref.sizes['sample']} samples "
                             "of its arguments (dim 'sample')")
        return g.astype(float).rename(self.name)


# --------------------------------------------------------------------------- helpers
def _identity(**kw: Any) -> Any:
    return next(iter(kw.values()))


class _UpperLimit:
    """``limit - value`` (picklable, module level)."""

    def __init__(self, limit: float, absolute: bool) -> None:
        self.limit, self.absolute = limit, absolute

    def __call__(self, **kw: Any) -> Any:
        v = next(iter(kw.values()))
        return self.limit - (abs(v) if self.absolute else v)


class _LowerLimit:
    """``value - limit``."""

    def __init__(self, limit: float) -> None:
        self.limit = limit

    def __call__(self, **kw: Any) -> Any:
        return next(iter(kw.values())) - self.limit


class _BandDistance:
    """Signed distance into a band: ``min(value - lower, upper - value)``."""

    def __init__(self, lower: float, upper: float, absolute: bool) -> None:
        self.lower, self.upper, self.absolute = lower, upper, absolute

    def __call__(self, **kw: Any) -> Any:
        v = next(iter(kw.values()))
        v = abs(v) if self.absolute else v
        parts = []
        if self.lower > -math.inf:
            parts.append(v - self.lower)
        if self.upper < math.inf:
            parts.append(self.upper - v)
        return parts[0] if len(parts) == 1 else np.minimum(parts[0], parts[1])


def _finite(value: Any, what: str) -> float:
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"{what}: expected a number, got {value!r}") from None
    if not math.isfinite(v):
        raise ValueError(f"{what}: must be finite, got {value!r}")
    return v


def _json_num(v: float) -> Any:
    return v if math.isfinite(v) else None


# =========================================================================== systems
class System(_GFunction):
    """A system of limit states, combined per instant.

    Parameters
    ----------
    components : sequence of LimitState or System
        At least two components (nested systems allowed).
    kind : {"series", "parallel"}
        Series: fails when any component fails (``g = min g_i``); parallel: fails when all
        fail at the same instant (``g = max g_i``).
    name : str, optional
        Label (default: ``"series(a, b)"``).
    first_passage : {"grid", "parabola"}
        How the system's ``g(t)`` (combined per instant) is reduced to ``min_t g(t)``
        (:func:`first_passage_min`); the components' settings apply to their own values.

    Notes
    -----
    A system reads no run as censored: a component's ``censored_statuses`` (recorded in its
    definition) apply to that component used alone, and through a system its runs with those
    statuses are invalid like any other (the methods' invalid readings and counts apply).
    """

    def __init__(self, components: Sequence[Any], kind: str, *, name: str | None = None,
                 first_passage: str = "grid") -> None:
        if kind not in ("series", "parallel"):
            raise ValueError(f"System: kind must be 'series' or 'parallel', got {kind!r}")
        if first_passage not in FIRST_PASSAGE:
            raise ValueError(f"{kind} system: first_passage must be one of "
                             f"{', '.join(FIRST_PASSAGE)}, got {first_passage!r}")
        self.first_passage = first_passage
        comps = [as_limit_state(c) for c in components]
        if len(comps) < 2:
            raise ValueError(f"{kind} system: needs at least two components, got {len(comps)}")
        names = [c.name for c in self._flatten(comps)]
        if len(set(names)) != len(names):
            raise ValueError(f"{kind} system: component names must be distinct, got {names}; "
                             "give each limit state a name=...")
        self.components = tuple(comps)
        self.kind = kind
        self.name = name or f"{kind}({', '.join(c.name for c in comps)})"

    @staticmethod
    def _flatten(comps: Sequence[Any]) -> list[LimitState]:
        out: list[LimitState] = []
        for c in comps:
            out.extend(c.leaves())
        return out

    @property
    def variables(self) -> tuple[str, ...]:
        """Every result variable read by a component."""
        return tuple(dict.fromkeys(v for leaf in self.leaves() for v in leaf.variables))

    outputs = variables

    @property
    def description(self) -> str:
        """Human-readable definition."""
        return f"{self.kind} system of {', '.join(c.name for c in self.components)}"

    def leaves(self) -> list[LimitState]:
        """Component limit states in depth-first order."""
        return self._flatten(self.components)

    def to_dict(self) -> dict[str, Any]:
        """JSON-able definition."""
        out = {"name": self.name, "kind": self.kind,
               "components": [c.to_dict() for c in self.components]}
        if self.first_passage != "grid":
            out["first_passage"] = self.first_passage
        return out

    def to_json(self) -> str:
        """:meth:`to_dict` as a JSON string."""
        return json.dumps(self.to_dict(), sort_keys=True)

    def __repr__(self) -> str:
        return f"{type(self).__name__}({self.name!r})"

    def check(self, ds: xr.Dataset) -> None:
        """Check every component against a result."""
        for leaf in self.leaves():
            leaf.check(ds)

    def values(self, ds: xr.Dataset, scales: Mapping[str, float] | None = None
               ) -> xr.DataArray:
        """System ``g`` per sample and instant (min for series, max for parallel).

        ``scales`` (leaf name -> positive number) divides each component's ``g`` before they
        are combined: the failure set is the same (a positive factor keeps every sign), but
        a component in newtons no longer hides one in millimetres from a method that follows
        the system's ``g`` (its gradient, its level thresholds).
        """
        parts = [c.values(ds, scales) if isinstance(c, System)
                 else c.values(ds) / float(scales[c.name]) if scales else c.values(ds)
                 for c in self.components]
        parts = xr.broadcast(*parts)
        stacked = xr.concat(parts, dim="_component", coords="minimal", compat="override")
        g = stacked.min("_component", skipna=False) if self.kind == "series" \
            else stacked.max("_component", skipna=False)
        return g.rename(self.name)

    def combine(self, leaf_values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """System ``g`` from per-leaf scalar values, and the governing leaf of each sample.

        Parameters
        ----------
        leaf_values : ndarray, shape (n, n_leaves)
            Columns in :meth:`leaves` order.

        Returns
        -------
        g : ndarray (n,)
            Series: min over components, parallel: max (recursively).
        governing : ndarray of int (n,)
            Index of the leaf whose value is ``g`` (the component that decides the sample).
        """
        leaf_values = np.asarray(leaf_values, dtype=float)
        col = 0
        gs, idx = [], []
        for c in self.components:
            k = len(c.leaves())
            block = leaf_values[:, col:col + k]
            if isinstance(c, System):
                g_c, i_c = c.combine(block)
            else:
                g_c, i_c = block[:, 0], np.zeros(block.shape[0], dtype=int)
            gs.append(g_c)
            idx.append(i_c + col)
            col += k
        g_all = np.column_stack(gs)
        pick = np.argmin(g_all, axis=1) if self.kind == "series" else np.argmax(g_all, axis=1)
        rows = np.arange(g_all.shape[0])
        return g_all[rows, pick], np.column_stack(idx)[rows, pick]


class SeriesSystem(System):
    """Fails when any component fails (``g = min g_i`` per instant)."""

    def __init__(self, components: Sequence[Any], *, name: str | None = None,
                 first_passage: str = "grid") -> None:
        super().__init__(components, "series", name=name, first_passage=first_passage)


class ParallelSystem(System):
    """Fails when every component fails at the same instant (``g = max g_i``)."""

    def __init__(self, components: Sequence[Any], *, name: str | None = None,
                 first_passage: str = "grid") -> None:
        super().__init__(components, "parallel", name=name, first_passage=first_passage)


def cut_set_system(cut_sets: Sequence[Sequence[Any]], *, name: str | None = None) -> System:
    """A series system of parallel cut sets: fails when every member of some cut set fails.

    Parameters
    ----------
    cut_sets : sequence of sequences
        Each inner sequence is one (minimal) cut set of limit states; a cut set of one member
        is that limit state itself. The same limit state may appear in several cut sets only
        if it is the same object (its name must be unique per object).
    """
    if isinstance(cut_sets, (str, LimitState, System)) or not len(cut_sets):
        raise ValueError("cut_set_system: expected a non-empty list of cut sets (lists of limit "
                         "states)")
    parts: list[Any] = []
    for i, cut in enumerate(cut_sets):
        if isinstance(cut, (str, LimitState, System)):
            raise ValueError(f"cut_set_system: cut set #{i} must be a list of limit states, "
                             f"got {cut!r}")
        members = [as_limit_state(c) for c in cut]
        if not members:
            raise ValueError(f"cut_set_system: cut set #{i} is empty")
        parts.append(members[0] if len(members) == 1 else ParallelSystem(
            members, name=f"cut{i + 1}"))
    if len(parts) == 1:
        if isinstance(parts[0], System):
            return parts[0]
        raise ValueError("cut_set_system: a single one-member cut set is a limit state, not a "
                         "system; use it directly")
    return _SharedSeries(parts, name=name or "cut_sets")


class _SharedSeries(System):
    """Series system whose parallel components may share leaves (cut sets)."""

    def __init__(self, components: Sequence[Any], *, name: str | None = None) -> None:
        comps = [as_limit_state(c) for c in components]
        if len(comps) < 2:
            raise ValueError("cut_set_system: needs at least two cut sets")
        self.components = tuple(comps)
        self.kind = "series"
        self.name = name or f"series({', '.join(c.name for c in comps)})"


def as_limit_state(spec: Any) -> LimitState | System:
    """Turn a user's limit-state argument into a :class:`LimitState` or :class:`System`.

    Accepts a LimitState, a System, a :class:`Band` (leaving it fails,
    the limits included) or an output name (the output is ``g``).

    Raises
    ------
    ValueError
        For input that could mean two things: a list/tuple (series or parallel? use
        :class:`SeriesSystem` / :class:`ParallelSystem`), a mapping (an upper or a lower
        limit? use :meth:`LimitState.upper` / :meth:`LimitState.lower`), or anything else.
    """
    if isinstance(spec, (LimitState, System)):
        return spec
    if isinstance(spec, Band):
        return LimitState.from_band(spec)
    if isinstance(spec, str):
        if not spec:
            raise ValueError("limit state: empty output name")
        return LimitState.output(spec)
    if isinstance(spec, Mapping):
        raise ValueError(
            f"limit state {spec!r} is ambiguous: is each number an upper or a lower limit? "
            "Use LimitState.upper(output, limit) or LimitState.lower(output, limit) (or a Band "
            "with gearuq.reliability)")
    if isinstance(spec, (list, tuple)):
        raise ValueError(
            f"limit state: a {type(spec).__name__} of {len(spec)} limit states is ambiguous "
            "(series or parallel?); wrap it in SeriesSystem([...]) or ParallelSystem([...]), "
            "or cut_set_system([[...], ...])")
    raise ValueError(
        f"limit state: expected a LimitState, a System, a Band or an output name, got "
        f"{type(spec).__name__} {spec!r}")
