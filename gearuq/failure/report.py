"""The one report form of every failure-probability method, and its status table.

Every method returns the same labelled Dataset: ``pf``, its interval ``pf_lower``/``pf_upper``
(what kind is in ``attrs["interval_kind"]``), ``cov_pf``, ``beta`` with its interval,
``n_model_runs``, ``n_invalid``, ``wall_time``, a ``status`` flag with its reasons in words,
the method settings and, where relevant, the design point(s) in physical and standard space
with importance factors.

``status`` 0 means the method vouches for its interval at the stated confidence. Any other value
names what it could not vouch for (:data:`REPORT_STATUS`); several reasons can hold at once,
``status`` is then the method's own (or the first found) and ``attrs["status_reasons"]`` lists
them all. Two checks are made here for every method: invalid model runs (the interval must
cover both readings of them) and, for a first-passage limit state, the time grid; a third
for a model that is a surrogate which says it is not usable (status 9).

:class:`ReportStatus` names the codes (an ``IntEnum``: the integers stay what they were) and
:func:`describe_status` renders ``"status N: meaning"`` for a code or a report, the way a
study or the command line prints it; the report itself carries the same words in
``attrs["status_text"]``.
"""

from __future__ import annotations

import enum
import json
import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
import xarray as xr
from scipy import linalg, stats

from gearuq.failure.evaluator import LimitStateEvaluator
from gearuq.runs import provenance

__all__ = ["failure_report", "REPORT_STATUS", "STATUS_TEXT", "Reason", "ReportStatus",
           "describe_status"]


class ReportStatus(enum.IntEnum):
    """The codes of a failure-probability report's ``status`` (0: the method vouches).

    An ``IntEnum``: ``ReportStatus(int(report["status"]))`` names a report's code, compares
    equal to the integer, and :attr:`meaning` gives its words (:data:`STATUS_TEXT`).
    """

    OK = 0
    NOT_CONVERGED = 1
    MODEL_FAILURE = 2
    WEIGHTS_DEGENERATE = 3
    UPPER_BOUND_ONLY = 4
    APPROXIMATION_INVALID = 5
    INVALID_SAMPLES = 6
    TIME_GRID_TOO_COARSE = 7
    FAILURE_REGIONS_MAY_BE_MISSED = 8
    SURROGATE_NOT_USABLE = 9

    @property
    def meaning(self) -> str:
        """What the status says to a user, in words."""
        return STATUS_TEXT[int(self)]


#: Meaning of the report's ``status`` flag (short name).
REPORT_STATUS = {int(s): s.name.lower() for s in ReportStatus}

#: What each status says to a user, in words (docs/reliability.md has the table).
STATUS_TEXT = {
    0: "the interval holds the failure probability at the stated confidence",
    1: "the method stopped before its accuracy target (iterations, samples or CoV target); "
       "the estimate and interval are those reached so far",
    2: "the model (or the limit state on its outputs) failed where the method needed it; no "
       "estimate",
    3: "the importance weights are degenerate (a few samples carry the estimate): the "
       "interval is not trustworthy",
    4: "no failure was observed: pf is an upper bound, not an estimate",
    5: "an approximation (SORM formula) is not valid for this limit state",
    6: "some model runs were invalid (nonzero status, NaN or inf): the interval is widened to "
       "cover both readings (all invalid safe, all invalid failed), pf counts them as safe",
    7: "the output time grid may miss first passages between instants: refine t",
    8: "the method may have missed part of the failure domain (design points or failure "
       "regions it did not find): the estimate may be low",
    9: "the model is a surrogate that does not reproduce what it replaces (its corrected "
       "leave-one-out error is near 1): the result is not usable",
}

#: A reason the method could not vouch for its answer: (status code, message in words).
Reason = tuple[int, str]


def _invalid_reason(ev: LimitStateEvaluator, reasons: Sequence[Reason]) -> list[Reason]:
    if ev.n_invalid == 0 or any(code in (2, 6) for code, _ in reasons):
        return []
    return [(6, f"{ev.n_invalid} of {ev.n_points} model runs were invalid{_whose(ev)}; this "
             "method's interval does not account for them")]


def _whose(ev: LimitStateEvaluator) -> str:
    """Which invalid runs the limit state made so (the model ran; g was NaN or inf)."""
    n = getattr(ev, "n_limit_state_nonfinite", 0)
    if not n:
        return ""
    if n == ev.n_invalid:
        return (" - not by the model, which ran: the limit state returned NaN or inf at every "
                "one of them")
    return f" ({n} of them valid model runs where the limit state returned NaN or inf)"


def _grid_reason(grid_gap: float, pf: float, pf_upper: float) -> list[Reason]:
    """Status 7 when the half-grid loss is larger than half the interval's upper width."""
    if not (math.isfinite(grid_gap) and grid_gap > 0):
        return []
    width = pf_upper - pf if math.isfinite(pf_upper) and math.isfinite(pf) else 0.0
    if grid_gap <= 0.5 * width:
        return []
    rel = grid_gap / pf if pf > 0 else math.inf
    return [(7, f"dropping every other output instant loses {grid_gap:.3g} of pf "
             f"({rel:.0%}), more than half the interval's width: the grid itself may miss "
             "about as much; refine the output instants t (or check with "
             "gearuq.failure.first_passage and the derivative output)")]


def _surrogate_reason(ev: LimitStateEvaluator) -> list[Reason]:
    """Status 9 when the model is a surrogate that says it is not usable."""
    check = getattr(ev.model, "surrogate_status", None)  # a fitted PolynomialChaos has it
    if check is None:
        return []
    code, message = check()
    return [(9, message)] if code else []


def failure_report(
    ev: LimitStateEvaluator,
    method: str,
    *,
    pf: float,
    pf_lower: float = math.nan,
    pf_upper: float = math.nan,
    cov: float = math.nan,
    interval_kind: str,
    confidence: float,
    settings: Mapping[str, Any],
    seed: int | None,
    wall_time: float,
    status: int = 0,
    message: str = "",
    reasons: Sequence[Reason] = (),
    grid_gap: float = math.nan,
    pf_is_upper_bound: bool = False,
    design_points: Sequence[Mapping[str, Any]] | None = None,
    extra: Mapping[str, tuple] | None = None,
    extra_attrs: Mapping[str, Any] | None = None,
) -> xr.Dataset:
    """The one report form of every reliability method.

    Parameters
    ----------
    ev : LimitStateEvaluator
        Gives the model, space, limit state, run counts and errors.
    method : str
        Method name.
    pf, pf_lower, pf_upper, cov : float
        Estimate, interval (NaN when the method has none) and coefficient of variation.
    interval_kind : str
        What the interval is (recorded in the attrs).
    design_points : list of dict, optional
        Each with ``u`` (dim,), ``beta``; physical values, alpha and importance factors are
        derived here.
    extra : mapping, optional
        Method-specific variables ``name -> (dims, values, attrs)``.

    Returns
    -------
    xarray.Dataset
        See the module docstring; scalars ``pf``, ``pf_lower``, ``pf_upper``, ``cov_pf``,
        ``beta``, ``beta_lower``, ``beta_upper``, ``n_model_runs``, ``n_invalid``,
        ``wall_time``, ``status``, ``pf_is_upper_bound``.
    """
    all_reasons: list[Reason] = ([(int(status), message or STATUS_TEXT[int(status)])]
                                 if status else [])
    all_reasons += [r for r in reasons if r[0]]
    all_reasons += _invalid_reason(ev, all_reasons)
    all_reasons += _surrogate_reason(ev)
    if ev.n_points and ev.n_invalid == ev.n_points and not any(c == 2 for c, _ in all_reasons):
        all_reasons.insert(0, (2, f"all {ev.n_points} model runs failed{_whose(ev)}: no "
                               "estimate is possible (see attrs errors)"))
        pf = pf_lower = pf_upper = cov = math.nan
        pf_is_upper_bound = False
    all_reasons += _grid_reason(grid_gap, pf, pf_upper)
    if (np.isfinite(pf_upper) and pf_upper > 1.0) or (np.isfinite(pf_lower) and pf_lower < 0.0):
        # a normal approximation on too few samples: the ends are clipped to [0, 1], and the
        # interval is not vouched for (status 1, said in words)
        all_reasons.append((1, f"the interval [{pf_lower:.3g}, {pf_upper:.3g}] reached beyond "
                               "[0, 1] (a normal approximation on too few samples) and is "
                               "clipped; it is not vouched for: give the method more samples"))
        pf_lower, pf_upper = max(float(pf_lower), 0.0), min(float(pf_upper), 1.0)
    note = message if not status else ""  # information that is no reason (status 0)
    status = all_reasons[0][0] if all_reasons else 0
    message = "; ".join([m for m in (note,) if m] + [m for _, m in all_reasons])
    beta, beta_lo, beta_up = (float(stats.norm.isf(p)) if np.isfinite(p) else math.nan
                              for p in (pf, pf_upper, pf_lower))
    flag = {"units": "1", "flag_values": np.array(sorted(REPORT_STATUS), dtype=np.int8),
            "flag_meanings": " ".join(REPORT_STATUS[k] for k in sorted(REPORT_STATUS))}
    data: dict[str, Any] = {
        "pf": ((), float(pf), {"units": "1", "long_name": "failure probability estimate"}),
        "pf_lower": ((), float(pf_lower), {"units": "1", "long_name":
                     "lower end of the interval of pf (see attrs interval_kind)"}),
        "pf_upper": ((), float(pf_upper), {"units": "1", "long_name":
                     "upper end of the interval of pf (see attrs interval_kind)"}),
        "cov_pf": ((), float(cov), {"units": "1", "long_name":
                   "coefficient of variation of the pf estimator"}),
        "beta": ((), beta, {"units": "1", "long_name": "generalised reliability index "
                            "-Phi^-1(pf)"}),
        "beta_lower": ((), beta_lo, {"units": "1", "long_name": "-Phi^-1(pf_upper)"}),
        "beta_upper": ((), beta_up, {"units": "1", "long_name": "-Phi^-1(pf_lower)"}),
        "n_model_runs": ((), np.int64(ev.n_runs), {"units": "1", "long_name":
                         "model evaluations (samples) used, all stages included"}),
        "n_invalid": ((), np.int64(ev.n_invalid), {"units": "1", "long_name":
                      "model evaluations with nonzero status (counted, never dropped "
                      "silently; see attrs errors)"}),
        "wall_time": ((), float(wall_time), {"units": "s", "long_name": "wall-clock time"}),
        "status": ((), np.int8(status), {**flag, "long_name": "outcome of the method"}),
        "pf_is_upper_bound": ((), np.int8(pf_is_upper_bound), {
            "units": "1", "long_name": "1 where no failure was observed and pf is the upper "
            "end of the interval, not an estimate"}),
    }
    coords: dict[str, Any] = {}
    if design_points:
        data.update(_design_point_vars(ev, design_points))
        coords["parameter"] = ("parameter", np.array(ev.names, dtype=str))
        coords["design_point"] = ("design_point", np.arange(len(design_points)))
    if getattr(ev, "n_censored", 0):
        data["n_censored"] = ((), np.int64(ev.n_censored), {"units": "1", "long_name": (
            "invalid runs whose g is an upper bound of the true value (the limit state's "
            "censored_statuses; among n_invalid)")})
    if math.isfinite(grid_gap):
        data["pf_grid_gap"] = ((), float(grid_gap), {"units": "1", "long_name": (
            "first-passage pf on the output instants minus the same on every other instant: "
            "estimates what the grid itself can miss")})
    for k, v in (extra or {}).items():
        data[k] = v
    out = xr.Dataset(data, coords=coords)
    out.attrs.update(provenance("failure_probability", ev.model, ev.request, ev.space, seed,
                                method=method, settings=dict(settings)))
    out.attrs.update({
        "method": method,
        "interval_kind": interval_kind,
        "confidence": float(confidence),
        "limit_state": ev.limit_state.to_json(),
        "failure_definition": "a sample fails where the limit state g <= 0 (boundary fails); "
                              "time-dependent g: first passage, min over the output instants",
        "message": message or REPORT_STATUS[int(status)],
        "status_text": f"status {int(status)}: {STATUS_TEXT[int(status)]}",
        "status_meanings": json.dumps({str(k): v for k, v in STATUS_TEXT.items()}),
        "status_reasons": json.dumps([{"status": c, "meaning": REPORT_STATUS[c],
                                       "message": m} for c, m in all_reasons]),
    })
    if ev.errors:
        out.attrs["errors"] = json.dumps(ev.errors[:50])
    out.attrs.update(dict(extra_attrs or {}))
    return out


def _design_point_vars(ev: LimitStateEvaluator, design_points: Sequence[Mapping[str, Any]]
                       ) -> dict[str, Any]:
    """Design points in both spaces, alpha and importance factors per design point."""
    u = np.array([np.asarray(dp["u"], dtype=float) for dp in design_points])
    betas = np.array([float(dp["beta"]) for dp in design_points])
    x = ev.to_physical(u)
    xs = np.column_stack([x[n] for n in ev.names])
    with np.errstate(invalid="ignore", divide="ignore"):
        alpha = u / np.linalg.norm(u, axis=1, keepdims=True)
    # importance of the physical parameters: gamma = L^-T alpha / |L^-T alpha| (Der Kiureghian)
    gamma = alpha if ev.chol is None else linalg.solve_triangular(
        ev.chol.T, alpha.T, lower=False).T
    with np.errstate(invalid="ignore", divide="ignore"):
        gamma = gamma / np.linalg.norm(gamma, axis=1, keepdims=True)
    dims = ("design_point", "parameter")
    units = "; ".join(f"{n}: {ev.model.parameter(n).units}" for n in ev.names)
    return {
        "beta_design_point": (("design_point",), betas, {
            "units": "1", "long_name": "distance of the design point from the origin"}),
        "design_point_u": (dims, u, {"units": "1", "long_name":
                           "design point in the independent standard normal space"}),
        "design_point_x": (dims, xs, {"units": units, "long_name":
                           "design point in physical parameters (units per parameter)"}),
        "alpha": (dims, alpha, {"units": "1", "long_name":
                  "unit vector u*/beta towards the design point (independent normal space)"}),
        "importance_factor": (dims, gamma**2, {"units": "1", "long_name": (
            "importance factors gamma^2 of the physical parameters, gamma = L^-T alpha / "
            "|L^-T alpha| (equals alpha^2 for independent inputs); they sum to 1")}),
    }




def _flag_meanings(status: xr.DataArray) -> dict[int, str]:
    """``flag_values`` -> ``flag_meanings`` of a CF flag variable (words, not underscores)."""
    from gearuq.model import status_meanings

    return {c: name.replace("_", " ") for c, name in status_meanings(status).items()}


def describe_status(result: xr.Dataset | xr.DataArray | int, *, details: bool = True) -> str:
    """The status of a result in words: the one line every study and command prints.

    Parameters
    ----------
    result : xarray.Dataset, xarray.DataArray or int
        A failure-probability report (scalar ``status``, reasons in ``attrs``), a report
        status code (:class:`ReportStatus`), any result with a per-sample ``status`` variable
        (a model's or an engine's, CF ``flag_values`` and ``flag_meanings``), or that
        ``status`` variable itself.
    details : bool
        For a report with a nonzero status, append what the method itself said (its
        ``status_reasons``, else ``attrs["message"]``) after the meaning.

    Returns
    -------
    str
        For a report or a code: ``"status 0: the interval holds ..."`` or ``"status 3: the
        importance weights are degenerate ... (two draws carry 60 %)"``. For per-sample
        status: ``"status: all 400 samples ok"``, or ``"status: 3 of 400 samples failed:
        2 x 1 (step limit reached), 1 x 3 (non finite state)"``.

    Raises
    ------
    TypeError
        If ``result`` is neither a Dataset, a DataArray nor an integer code.
    ValueError
        If it holds no ``status`` variable, or a code is not a report status.
    """
    if isinstance(result, (int, np.integer)) and not isinstance(result, bool):
        return _report_status_line(int(result), {}, details=False)
    if isinstance(result, xr.Dataset):
        if "status" not in result:
            raise ValueError("result: holds no 'status' variable to describe; variables: "
                             + ", ".join(map(str, result.data_vars)))
        status, attrs = result["status"], result.attrs
    elif isinstance(result, xr.DataArray):
        status, attrs = result, {}
    else:
        raise TypeError(f"result: expected an xarray Dataset or DataArray or a status code, "
                        f"got {type(result).__name__}")
    if status.ndim == 0:  # one outcome: a failure-probability report
        return _report_status_line(int(status.values), attrs, details=details)
    values = np.asarray(status.values).ravel()
    bad = values[values != 0]
    what = "samples" if "sample" in status.dims else "values"
    if bad.size == 0:
        return f"status: all {values.size} {what} ok"
    meanings = _flag_meanings(status)
    codes, counts = np.unique(bad, return_counts=True)
    parts = ", ".join(f"{n} x {int(c)} ({meanings.get(int(c), 'no meaning recorded')})"
                      for c, n in zip(codes, counts, strict=True))
    return f"status: {bad.size} of {values.size} {what} failed: {parts}"


def _report_status_line(code: int, attrs: Mapping[str, Any], *, details: bool) -> str:
    """``"status N: meaning (what the method said)"`` for one report status."""
    if code not in STATUS_TEXT:
        raise ValueError(f"status: {code!r} is not a report status; valid codes: "
                         f"{sorted(STATUS_TEXT)}")
    text = f"status {code}: {STATUS_TEXT[code]}"
    if not (details and code):
        return text
    try:
        reasons = json.loads(attrs.get("status_reasons", "[]"))
    except (TypeError, ValueError):
        reasons = []
    words = "; ".join(str(r["message"]) + (f" [status {r['status']}]"
                                           if int(r["status"]) != code else "")
                      for r in reasons) or str(attrs.get("message", ""))
    if words and words not in (REPORT_STATUS[code], STATUS_TEXT[code]):
        text += f" ({words})"
    return text
