"""Python front end of the batched integrator: one argument validation, then the kernel.

:func:`solve_batch` validates every argument once (:func:`_validate`, which returns a
:class:`_Problem` of normalised arrays), picks the compiled variant for the method and the
event treatment (``kernel.get_kernel``), runs it serially or in threads over sample blocks,
and returns an :class:`ODEResult`.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .constants import RTOL_MIN, STATUS_OK
from .tableaux import METHODS


@contextmanager
def quiet_numba_logging() -> Iterator[None]:
    """Keep numba's compiler from formatting debug log records while it compiles.

    chaospy and numpoly call ``logging.basicConfig(level=DEBUG)`` on import, which sets the
    root logger to DEBUG (with a handler writing to os.devnull); numba's compiler then
    formats and writes some 10^5 debug records per kernel, a quarter of a cold compile.
    This raises the ``numba`` logger to WARNING for the duration, but only when nobody has
    set that logger's level (NOTSET) and the effective level is below WARNING.
    """
    logger = logging.getLogger("numba")
    if logger.level != logging.NOTSET or logger.getEffectiveLevel() >= logging.WARNING:
        yield
        return
    logger.setLevel(logging.WARNING)
    try:
        yield
    finally:
        logger.setLevel(logging.NOTSET)


def numba_version() -> str:
    """The numba version (for provenance)."""
    import numba

    return numba.__version__


@dataclass
class ODEResult:
    """Outputs of :func:`solve_batch`.

    Attributes
    ----------
    y : ndarray, shape (n_samples, n_t, n_save)
        States at the output instants, only the components listed in ``save``. NaN after
        the instant at which a sample failed.
    t : ndarray, shape (n_t,) or (n_samples, n_t)
        The output instants as given.
    status : ndarray of int8, shape (n_samples,)
        ``STATUS_OK`` (0), ``STATUS_STEP_LIMIT`` (1), ``STATUS_STEP_UNDERFLOW`` (2) or
        ``STATUS_NONFINITE`` (3), see :data:`STATUS_MEANINGS`.
    n_steps, n_rejected, n_rhs, n_events : ndarray of int64, shape (n_samples,)
        Accepted steps, rejected steps (error test or non-finite stage), calls of ``rhs``
        and registered sign changes of switching functions.
    method : str
    rtol : float
    atol : float or ndarray
    save : ndarray of int64
        State indices stored in ``y``.
    options : dict
        The remaining settings (see :meth:`settings`).
    """

    y: np.ndarray
    t: np.ndarray
    status: np.ndarray
    n_steps: np.ndarray
    n_rejected: np.ndarray
    n_rhs: np.ndarray
    n_events: np.ndarray
    method: str
    rtol: float
    atol: float | np.ndarray
    save: np.ndarray
    options: dict[str, Any] = field(default_factory=dict)

    @property
    def ok(self) -> np.ndarray:
        """Boolean mask of the samples that reached the last output instant."""
        return self.status == STATUS_OK

    def settings(self) -> dict[str, Any]:
        """Return the solver settings as a JSON-serialisable dict (for provenance)."""
        atol = self.atol.tolist() if isinstance(self.atol, np.ndarray) else float(self.atol)
        return {
            "solver": "gearuq.ode.solve_batch",
            "method": self.method,
            "rtol": float(self.rtol),
            "atol": atol,
            "save": self.save.tolist(),
            **self.options,
            "numba_version": numba_version(),
        }


def _fail(name: str, value: Any, expected: str) -> ValueError:
    """The ValueError for an invalid argument: its name, its value and what is valid."""
    text = repr(value)
    if len(text) > 80:
        text = text[:77] + "..."
    return ValueError(f"solve_batch: {name}={text} is invalid: {expected}")


def _check_numba_function(fn: Any, name: str) -> None:
    """Raise a TypeError unless ``fn`` is a numba function (dispatcher or cfunc)."""
    from numba.core.ccallback import CFunc
    from numba.core.registry import CPUDispatcher

    if not isinstance(fn, CPUDispatcher | CFunc):
        raise TypeError(
            f"solve_batch: {name} must be a numba @njit function "
            f"{name}(t, y, p, out) -> None writing into out, got {type(fn).__name__}"
        )


def _probe(fn: Any, name: str, t: float, y: np.ndarray, p: np.ndarray, n_out: int,
           compiled: bool = True) -> np.ndarray:
    """Call fn once from Python so that signature problems surface as a clear TypeError
    (its Python function when the call runs interpreted: nothing compiles then)."""
    from numba.core.errors import TypingError

    out = np.zeros(n_out)
    call = fn if compiled or not hasattr(fn, "py_func") else fn.py_func
    try:
        with np.errstate(all="ignore"):
            ret = call(float(t), np.ascontiguousarray(y, dtype=np.float64),
                       np.ascontiguousarray(p, dtype=np.float64), out)
    except TypingError as exc:
        raise TypeError(
            f"solve_batch: {name} does not compile for "
            f"{name}(t: float64, y: float64[::1], p: float64[::1], out: float64[::1]) -> None:"
            f"\n{exc}"
        ) from exc
    if ret is not None:
        raise TypeError(
            f"solve_batch: {name} returned {type(ret).__name__}; it must return None and "
            "write its values into its last argument"
        )
    return out


def _as_float_array(x: Any, name: str) -> np.ndarray:
    """x as a C-contiguous float64 array (0-d kept), or a ValueError naming ``name``."""
    try:
        a = np.asarray(x, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise _fail(name, x, "must be convertible to a float64 array") from exc
    # ascontiguousarray would turn a 0-d array into shape (1,): keep scalars as they are.
    return a if a.ndim == 0 else np.ascontiguousarray(a)


def _first_bad_row(a: np.ndarray) -> int:
    """Index of the first row of ``a`` with a non-finite entry."""
    return int(np.nonzero(~np.isfinite(a).reshape(a.shape[0], -1).all(axis=1))[0][0])




@dataclass
class _Problem:
    """Validated and normalised arguments of :func:`solve_batch`."""

    y0: np.ndarray  # (n_samples, n_state)
    params: np.ndarray  # (n_samples, n_par), C-contiguous
    t_eval: np.ndarray  # as given (for the result)
    te2: np.ndarray  # (1 or n_samples, n_t), C-contiguous
    t0: np.ndarray  # (n_samples,)
    atol_given: np.ndarray  # 0-d or (n_state,)
    atol: np.ndarray  # (n_state,)
    fixed_h: float  # 0.0: adaptive
    save: np.ndarray  # int64 state indices

    @property
    def n_samples(self) -> int:
        return self.y0.shape[0]


def _validate_arrays(y0: Any, params: Any, t_eval: Any, t0: Any) -> tuple[np.ndarray, ...]:
    """y0 (n, n_state), params (n, n_par), t_eval (as given and 2-d) and t0 (n,), checked."""
    y0a = _as_float_array(y0, "y0")
    if y0a.ndim != 2 or y0a.shape[0] < 1 or y0a.shape[1] < 1:
        raise _fail("y0", f"array of shape {y0a.shape}",
                    "must have shape (n_samples, n_state) with both >= 1 "
                    "(use y0[None, :] for a single sample)")
    n_samples = y0a.shape[0]
    if not np.isfinite(y0a).all():
        i = _first_bad_row(y0a)
        raise _fail("y0", f"row {i}", f"must be finite, sample {i} has {y0a[i].tolist()}")
    pa = _as_float_array(params, "params")
    if pa.ndim == 1 and n_samples == 1:
        pa = pa[None, :]
    if pa.ndim != 2 or pa.shape[0] != n_samples:
        raise _fail("params", f"array of shape {pa.shape}",
                    f"must have shape (n_samples={n_samples}, n_par)")
    if not np.isfinite(pa).all():
        i = _first_bad_row(pa)
        raise _fail("params", f"row {i}", f"must be finite, sample {i} has {pa[i].tolist()}")
    te = _as_float_array(t_eval, "t_eval")
    te2 = _output_instants(te, n_samples)
    t0a = _as_float_array(t0, "t0")
    if t0a.ndim == 0:
        t0a = np.full(n_samples, float(t0a))
    if t0a.shape != (n_samples,):
        raise _fail("t0", f"array of shape {t0a.shape}", f"must be a float or shape ({n_samples},)")
    if not np.isfinite(t0a).all():
        raise _fail("t0", t0, "must be finite")
    first_out = te2[:, 0] if te2.shape[0] == n_samples else np.full(n_samples, te2[0, 0])
    if (first_out < t0a).any():
        i = int(np.nonzero(first_out < t0a)[0][0])
        raise _fail("t_eval", te, f"starts at {first_out[i]!r} before t0={t0a[i]!r} "
                    f"(sample {i}); output instants must be >= t0")
    return y0a, np.ascontiguousarray(pa), te, te2, t0a


def _output_instants(te: np.ndarray, n_samples: int) -> np.ndarray:
    """t_eval as a C-contiguous (1 or n_samples, n_t) array, finite and strictly increasing."""
    if te.ndim == 1:
        te2 = te[None, :]
    elif te.ndim == 2 and te.shape[0] == n_samples:
        te2 = te
    else:
        raise _fail("t_eval", f"array of shape {te.shape}",
                    f"must have shape (n_t,) or (n_samples={n_samples}, n_t)")
    if te2.shape[1] < 1:
        raise _fail("t_eval", te, "must hold at least one output instant")
    if not np.isfinite(te2).all():
        raise _fail("t_eval", te, "must be finite")
    if te2.shape[1] > 1 and not (np.diff(te2, axis=1) > 0).all():
        row = int(np.nonzero(~(np.diff(te2, axis=1) > 0).all(axis=1))[0][0])
        where = "" if te.ndim == 1 else f" (sample {row})"
        raise _fail("t_eval", te, f"must be strictly increasing{where}")
    return np.ascontiguousarray(te2)


def _validate_steps(rtol: Any, atol: Any, n_state: int, max_step: Any, first_step: Any,
                    max_steps: Any, fixed_step: Any) -> tuple[np.ndarray, np.ndarray, float]:
    """Tolerances and step settings; returns (atol as given, atol per state, fixed step or 0)."""
    if not (isinstance(rtol, int | float | np.floating) and RTOL_MIN <= rtol < 1.0):
        raise _fail("rtol", rtol, f"must be a float in [{RTOL_MIN:.3g}, 1)")
    atol_a = _as_float_array(atol, "atol")
    if atol_a.ndim == 0:
        atol_vec = np.full(n_state, float(atol_a))
    elif atol_a.shape == (n_state,):
        atol_vec = atol_a.copy()
    else:
        raise _fail("atol", atol, f"must be a float or shape (n_state={n_state},)")
    if not (np.isfinite(atol_vec).all() and (atol_vec >= 0).all()):
        raise _fail("atol", atol, "must be finite and >= 0")
    if not (isinstance(max_step, int | float | np.floating) and max_step > 0):
        raise _fail("max_step", max_step, "must be > 0 (np.inf for no bound)")
    if not (isinstance(first_step, int | float | np.floating) and math.isfinite(first_step)
            and first_step >= 0):
        raise _fail("first_step", first_step, "must be finite and >= 0 (0 = automatic)")
    if isinstance(max_steps, bool) or not isinstance(max_steps, int | np.integer) or max_steps < 1:
        raise _fail("max_steps", max_steps, "must be an integer >= 1")
    if fixed_step is None:
        return atol_a, atol_vec, 0.0
    if not (isinstance(fixed_step, int | float | np.floating) and math.isfinite(fixed_step)
            and fixed_step > 0):
        raise _fail("fixed_step", fixed_step, "must be a finite float > 0, or None")
    return atol_a, atol_vec, float(fixed_step)


def _validate_switching(switch: Any, n_switch: Any, freeze_sides: Any) -> None:
    """switch, n_switch and freeze_sides agree with each other."""
    if isinstance(n_switch, bool) or not isinstance(n_switch, int | np.integer) or n_switch < 0:
        raise _fail("n_switch", n_switch, "must be an integer >= 0")
    if n_switch > 0 and switch is None:
        raise _fail("n_switch", n_switch, "> 0 needs switch=, the function filling g")
    if switch is not None and n_switch == 0:
        raise _fail("n_switch", n_switch, "must give the number of switching functions (>= 1) "
                    "when switch= is passed")
    if switch is not None:
        _check_numba_function(switch, "switch")
    if not isinstance(freeze_sides, bool | np.bool_):
        raise _fail("freeze_sides", freeze_sides, "must be True or False")
    if freeze_sides and switch is None:
        raise _fail("freeze_sides", freeze_sides, "needs switch= and n_switch > 0")


def _validate_save(save: Any, n_state: int) -> np.ndarray:
    """State indices to store, as int64 (default: all)."""
    if save is None:
        return np.arange(n_state, dtype=np.int64)
    save_a = np.asarray(save)
    if save_a.ndim == 0:
        save_a = save_a[None]
    if (save_a.ndim != 1 or save_a.size < 1 or not np.issubdtype(save_a.dtype, np.integer)
            or (save_a < 0).any() or (save_a >= n_state).any()):
        raise _fail("save", save, f"must be a 1-d array of state indices in [0, {n_state})")
    return np.ascontiguousarray(save_a, dtype=np.int64)


def _validate(rhs: Any, y0: Any, params: Any, t_eval: Any, t0: Any, method: Any, rtol: Any,
              atol: Any, max_step: Any, first_step: Any, max_steps: Any, fixed_step: Any,
              switch: Any, n_switch: Any, save: Any, freeze_sides: Any,
              compiled: bool = True) -> _Problem:
    """Every argument of :func:`solve_batch`, checked once; the user functions probed
    (compiled, or as Python functions when ``compiled`` is False)."""
    _check_numba_function(rhs, "rhs")
    if not isinstance(method, str) or method not in METHODS:
        raise _fail("method", method, f"must be one of {', '.join(METHODS)}")
    if method == "rk4" and fixed_step is None:
        raise _fail("method", method, "'rk4' has no error estimate: use it with fixed_step=h")
    y0a, pa, te, te2, t0a = _validate_arrays(y0, params, t_eval, t0)
    n_state = y0a.shape[1]
    atol_a, atol_vec, fixed_h = _validate_steps(rtol, atol, n_state, max_step, first_step,
                                                max_steps, fixed_step)
    _validate_switching(switch, n_switch, freeze_sides)
    save_a = _validate_save(save, n_state)
    # probe the user functions from Python (clear errors instead of numba tracebacks)
    p_probe = pa[0]
    if switch is not None:
        if freeze_sides:
            p_probe = np.concatenate([pa[0], np.zeros(int(n_switch))])
        g_probe = _probe(switch, "switch", t0a[0], y0a[0], p_probe, int(n_switch), compiled)
        if freeze_sides:
            p_probe[pa.shape[1]:] = np.sign(g_probe)
    _probe(rhs, "rhs", t0a[0], y0a[0], p_probe, n_state, compiled)
    return _Problem(y0=y0a, params=pa, t_eval=te, te2=te2, t0=t0a, atol_given=atol_a,
                    atol=atol_vec, fixed_h=fixed_h, save=save_a)


def solve_batch(
    rhs: Any,
    y0: Any,
    params: Any,
    t_eval: Any,
    *,
    t0: float | Any = 0.0,
    method: str = "dopri5",
    rtol: float = 1e-6,
    atol: float | Any = 1e-9,
    max_step: float = np.inf,
    first_step: float = 0.0,
    max_steps: int = 1_000_000,
    fixed_step: float | None = None,
    switch: Any = None,
    n_switch: int = 0,
    save: Any = None,
    parallel: bool = True,
    freeze_sides: bool = False,
    interpreted_cpu: float | None = None,
) -> ODEResult:
    """Integrate many independent ODE samples with an embedded Runge-Kutta method.

    Sample ``i`` solves ``y' = rhs(t, y, params[i])``, ``y(t0_i) = y0[i]`` and is stored at
    its output instants by dense output (the steps are chosen by the error control alone,
    not by the output grid).

    Parameters
    ----------
    rhs : numba dispatcher
        ``@njit`` function ``rhs(t, y, p, dydt) -> None`` writing dy/dt into ``dydt``. It
        must compile for ``(float64, float64[::1], float64[::1], float64[::1])``. Decorate
        it with ``cache=True`` to skip its compilation in later processes, and with
        ``error_model="numpy"`` so that a division by zero yields inf/nan (that sample then
        stops with ``STATUS_NONFINITE``) instead of raising and aborting the batch.
    y0 : array_like, shape (n_samples, n_state)
        Initial states; must be finite.
    params : array_like, shape (n_samples, n_par)
        Row ``i`` is passed to ``rhs`` as ``p`` for sample ``i`` (``n_par`` may be 0).
    t_eval : array_like, shape (n_t,) or (n_samples, n_t)
        Output instants, strictly increasing, shared or per sample. The integration of a
        sample ends at its last instant.
    t0 : float or array_like of shape (n_samples,), optional
        Start time(s), not after the first output instant.
    method : {"dopri5", "dop853", "rk4"}, optional
        ``"rk4"`` only with ``fixed_step``.
    rtol : float, optional
        Relative tolerance, in [100 eps, 1).
    atol : float or array_like of shape (n_state,), optional
        Absolute tolerance(s), >= 0. The local error of component k is kept below
        ``atol[k] + rtol * |y_k|`` in Hairer's RMS norm.
    max_step : float, optional
        Upper bound of the step size (> 0). Also the way to bound how far a pair of
        switching-surface crossings can hide inside one step (see Notes).
    first_step : float, optional
        Initial step; 0 selects Hairer's automatic estimate.
    max_steps : int, optional
        Bound on step attempts per sample (accepted, rejected and event re-takes); a sample
        that reaches it stops with ``STATUS_STEP_LIMIT``.
    fixed_step : float, optional
        Step size of fixed-step mode (no error control, dense output still used at
        ``t_eval``; the last step is shortened to end at ``t_eval[-1]``).
    switch : numba dispatcher, optional
        ``@njit`` function ``switch(t, y, p, g) -> None`` writing the ``n_switch`` values of
        the switching functions into ``g``. Steps are cut at their sign changes.
    n_switch : int, optional
        Number of switching functions; required > 0 with ``switch``.
    save : array_like of int, optional
        State indices to store (default: all). Only these are interpolated and returned.
    parallel : bool, optional
        Run blocks of samples in parallel threads (one per core; the compiled kernel
        releases the GIL). Results are bit-identical
        to ``parallel=False`` because samples do not interact.
    freeze_sides : bool, optional
        With ``switch``: pass ``rhs`` and ``switch`` a parameter vector extended by
        ``n_switch`` entries, ``p[n_par + k]`` = side of switching function k at the start
        of the current step (+1.0 or -1.0; 0.0 while unknown because g was exactly 0). They
        stay constant within a step and flip only at located crossings. An ``rhs`` that
        picks its branch from them (falling back to the state when the side is 0) sees one
        smooth vector field per step, so no Runge-Kutta stage straddles a surface; see
        docs/ode.md for why this matters most for dop853.
    interpreted_cpu : float, optional
        The caller's estimate of the CPU seconds the batch costs with the kernel, ``rhs``
        and ``switch`` run as plain Python (:mod:`gearuq._firstcall`). When given, and the
        variant is neither compiled in this process nor in numba's cache, a batch whose
        estimate fits the per-process allowance (2 s) runs uncompiled, to rounding the same
        result; later and larger calls compile. None (default): always compiled.

    Returns
    -------
    ODEResult

    Raises
    ------
    ValueError
        On invalid arguments; the message names the argument, its value and the valid range.
    TypeError
        When ``rhs`` or ``switch`` is not a numba function of the required signature.
    RuntimeError
        When ``rhs`` or ``switch`` raised inside the kernel (e.g. ZeroDivisionError under
        numba's default error model); use ``@njit(error_model="numpy")`` to avoid it.

    Notes
    -----
    A sample that fails keeps the outputs computed before the failure; later rows of ``y``
    are NaN and ``status`` tells why. Failures never raise and never affect other samples.

    Event location finds a crossing when a switching function has changed sign at the end
    of a step, at one of its interpolated quarter points, or at the extremum of the parabola
    through three samples where g comes close to the surface. A touch that does not cross
    (grazing) is not an event; an excursion across the surface and back that falls between
    two samples and is not revealed by the parabola is missed, which only a smaller
    ``max_step`` prevents. The number of events counts sign changes (two surfaces crossed at
    once count two).
    """
    from . import kernel as _kernel

    events = "none" if switch is None else ("frozen" if freeze_sides else "retake")
    kernel, compiled = None, True
    if interpreted_cpu is not None and method in METHODS:
        kernel, route = _kernel.first_call_route(method, events).choose(
            float(interpreted_cpu), ())
        compiled = route == "compiled"
    with quiet_numba_logging():  # (compiles rhs, switch and the kernel on first use)
        prob = _validate(rhs, y0, params, t_eval, t0, method, rtol, atol, max_step, first_step,
                         max_steps, fixed_step, switch, n_switch, save, freeze_sides,
                         compiled)
        if compiled:
            kernel = _kernel.get_kernel(method, events)
        no_switch = _kernel.no_switch(compiled) if switch is None else None
    n_samples = prob.n_samples
    out = np.full((n_samples, prob.te2.shape[1], prob.save.size), np.nan)
    status = np.zeros(n_samples, dtype=np.int8)
    counts = np.zeros((n_samples, 4), dtype=np.int64)
    args = (rhs, switch if switch is not None else no_switch, prob.y0, prob.params,
            prob.t0, prob.te2, prob.save, out, float(rtol), prob.atol, float(max_step),
            float(first_step), int(max_steps), prob.fixed_h, int(n_switch), status, counts)
    # the plain-Python kernel holds the GIL: threads would only add overhead
    n_threads = _kernel.default_threads(n_samples, parallel and compiled)
    try:
        if n_threads > 1:
            _kernel.run_threads(kernel, args, n_samples, n_threads)
        else:
            kernel(*args)
    except Exception as exc:
        # Only user code can raise in the kernel (numba's default error model raises
        # ZeroDivisionError on float division by zero), and it aborts the whole batch.
        raise RuntimeError(
            f"solve_batch: rhs or switch raised {type(exc).__name__}: {exc}. An exception in "
            "the compiled kernel aborts the whole batch: compile rhs and switch with "
            "@njit(error_model='numpy') so that a division by zero gives inf/nan and only "
            "that sample stops, with STATUS_NONFINITE."
        ) from exc
    return ODEResult(
        y=out, t=prob.t_eval, status=status,
        n_steps=counts[:, 0].copy(), n_rejected=counts[:, 1].copy(),
        n_rhs=counts[:, 2].copy(), n_events=counts[:, 3].copy(),
        method=method, rtol=float(rtol),
        atol=float(prob.atol_given) if prob.atol_given.ndim == 0 else prob.atol,
        save=prob.save,
        options={
            "max_step": float(max_step),
            "first_step": float(first_step),
            "max_steps": int(max_steps),
            "fixed_step": None if fixed_step is None else float(fixed_step),
            "n_switch": int(n_switch),
            "freeze_sides": bool(freeze_sides),
            "parallel": bool(parallel),
            "rhs": getattr(rhs, "__qualname__", repr(rhs)),
            "switch": None if switch is None else getattr(switch, "__qualname__", repr(switch)),
        },
    )


#: The variants the built-in models use by default (``helical_pair``: DOP853, frozen sides).
DEFAULT_VARIANTS = (("dop853", "frozen"),)


def precompile(variants: Any = DEFAULT_VARIANTS) -> dict[str, float]:
    """Compile kernel variants ahead of their first use (or load them from the disk cache).

    A cold compile of one variant takes seconds (docs/ode.md); run this once after
    installing (for instance from an install script) so that the first integration in every
    later process only loads the cached machine code.

    Parameters
    ----------
    variants : sequence of (method, events)
        ``method`` in :data:`METHODS`, ``events`` in {"none", "retake", "frozen"}.

    Returns
    -------
    dict
        ``"method/events"`` -> seconds spent compiling or loading.
    """
    import time

    from . import kernel as _kernel

    times = {}
    with quiet_numba_logging():
        for method, events in variants:
            if method not in METHODS:
                raise _fail("method", method, f"must be one of {', '.join(METHODS)}")
            if events not in _kernel.EVENT_TREATMENTS:
                valid = ", ".join(_kernel.EVENT_TREATMENTS)
                raise _fail("events", events, f"must be one of {valid}")
            start = time.perf_counter()
            _kernel.get_kernel(method, events)
            times[f"{method}/{events}"] = time.perf_counter() - start
    return times
