"""A categorical design variable: the continuous design optimised at each level, then compared.

A categorical choice (a relief's shape, a material, a bearing type) has no gradient and often
few levels, so :func:`optimize_levels` runs :func:`optimize_design` once per level of a model
option, with one seed for all of them: the searches share their random numbers and the
confirmations see the same samples at every level (a paired comparison). The levels are then
compared on their confirmations: the best level is *decided* when its interval lies wholly
below every other level's, and, for a probability objective with the confirmation runs kept,
McNemar's exact test on the paired failures says whether the difference could be chance.
"""

from __future__ import annotations

import copy
import json
import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
import xarray as xr
from scipy import stats

from gearuq.design.measures import Probability
from gearuq.design.optimize import optimize_design
from gearuq.design.problem import DesignProblem
from gearuq.engines.common import resolve_seed

__all__ = ["optimize_levels", "paired_failures", "at_level"]


def at_level(problem: DesignProblem, option: str, level: Any) -> DesignProblem:
    """A shallow copy of ``problem`` whose model options set ``option`` to ``level``.

    Parameters
    ----------
    problem : DesignProblem
    option : str
        A model option (not checked here: the model checks it when it runs).
    level : object
        Its value.

    Returns
    -------
    DesignProblem
        The same model, space, variables and measures; ``problem`` is left unchanged.
    """
    out = copy.copy(problem)
    out.model_options = {**problem.model_options, option: level}
    return out


def _check_levels(problem: DesignProblem, option: str, levels: Sequence[Any]) -> list[Any]:
    names = [o.name for o in problem.model.options]
    if option not in names:
        raise ValueError(f"option: {option!r} is not an option of model {problem.model.name!r};"
                         f" valid: {', '.join(names) or 'none'}")
    levels = list(levels)
    if len(levels) < 2:
        raise ValueError(f"levels: {levels!r} needs at least two levels to compare")
    if len({repr(v) for v in levels}) != len(levels):
        raise ValueError(f"levels: {levels!r} repeats a level")
    choices = problem.model.option(option).choices
    bad = [v for v in levels if choices is not None and v not in choices]
    if bad:
        raise ValueError(f"levels: {bad!r} not valid for option {option!r}; valid: "
                         f"{', '.join(map(str, choices))}")
    return levels


def paired_failures(a: np.ndarray, b: np.ndarray) -> dict[str, Any]:
    """McNemar's exact test on paired failure indicators (``NaN`` = invalid, left out).

    Parameters
    ----------
    a, b : array_like of float
        ``1`` where the sample fails, ``0`` where it is safe, ``NaN`` where the run is
        invalid, for the same samples under two designs.

    Returns
    -------
    dict
        ``n`` (samples valid under both), ``only_a`` and ``only_b`` (samples failing under
        one design only) and the two-sided ``p_value`` (1 when no sample differs).
    """
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    if a.shape != b.shape:
        raise ValueError(f"paired_failures: shapes {a.shape} and {b.shape} differ; the "
                         "samples must be the same")
    ok = np.isfinite(a) & np.isfinite(b)
    fa, fb = a[ok] > 0.5, b[ok] > 0.5
    only_a, only_b = int(np.sum(fa & ~fb)), int(np.sum(~fa & fb))
    p = float(stats.binomtest(min(only_a, only_b), only_a + only_b, 0.5).pvalue) \
        if only_a + only_b else 1.0
    return {"n": int(ok.sum()), "only_a": only_a, "only_b": only_b, "p_value": p}


def _failures(problem: DesignProblem, res: xr.Dataset) -> np.ndarray | None:
    """Failure indicator per confirmation run (``NaN`` invalid), or ``None`` if not kept."""
    obj = problem.objective
    if not isinstance(obj, Probability) or "run_status" not in res:
        return None
    runs = xr.Dataset({str(k)[4:]: v for k, v in res.data_vars.items()
                       if str(k).startswith("run_")})
    g = obj.sample_values(runs)
    return np.where(np.isfinite(g), (g <= 0.0).astype(float), np.nan)


def optimize_levels(
    problem: DesignProblem,
    option: str,
    levels: Sequence[Any],
    *,
    rng: Any = None,
    confirm_problem: DesignProblem | None = None,
    confirm_options: Mapping[str, Any] | None = None,
    **kwargs: Any,
) -> xr.Dataset:
    """Optimise the continuous design at each level of a categorical model option; compare.

    Parameters
    ----------
    problem : DesignProblem
        The problem; ``option`` is set to each level in its model options (search) and in
        those of the confirmation.
    option : str
        A model option (e.g. ``"tip_relief_shape"``).
    levels : sequence
        At least two distinct valid values of ``option``.
    rng : int or None
        One seed for every level (common random numbers in the searches, the same samples in
        the confirmations).
    confirm_problem, confirm_options
        As in :func:`optimize_design`; ``option`` is set in them too.
    **kwargs
        Passed to :func:`optimize_design` (strategy, sizes, executor, ...).

    Returns
    -------
    xarray.Dataset
        The per-level results of :func:`optimize_design` stacked over a ``level`` dimension
        (``history_*`` left out: its length differs between levels), with ``best_level`` (the
        level of the least confirmed objective), ``level_decided`` (1 when the best level's
        interval lies below every other's) and, for a probability objective with
        ``keep_confirmation_runs=True``, ``paired_only_best``, ``paired_only_other`` and
        ``paired_p_value`` per level (McNemar against the best level). The words are in
        ``attrs["level_message"]``.

    Raises
    ------
    ValueError
        ``option`` not an option of the model, fewer than two levels, a repeated level or one
        outside the option's choices.
    """
    levels = _check_levels(problem, option, levels)
    seed = resolve_seed(rng)
    results, fails = [], []
    for level in levels:
        p = at_level(problem, option, level)
        cp = None if confirm_problem is None else at_level(confirm_problem, option, level)
        co = None if confirm_options is None else {**confirm_options, option: level}
        r = optimize_design(p, rng=seed, confirm_problem=cp, confirm_options=co, **kwargs)
        fails.append(_failures(p, r))
        results.append(r.drop_vars([v for v in r.data_vars if str(v).startswith("history_")]))
    out = xr.concat(results, dim=xr.DataArray([str(v) for v in levels], dims="level",
                                              name="level"),
                    data_vars="all", coords="minimal", compat="override",
                    combine_attrs="drop_conflicts")
    for key in ("message", "status_reasons", "search_history", "batches"):
        out.attrs[f"{key}_per_level"] = json.dumps([r.attrs.get(key, "") for r in results])
    return _compare(problem, out, option, levels, fails)


def _compare(problem: DesignProblem, out: xr.Dataset, option: str, levels: list[Any],
             fails: list[np.ndarray | None]) -> xr.Dataset:
    obj = problem.objective
    measure = getattr(obj, "name", None)
    if measure is not None and f"confirm_{measure}" in out:
        value = out[f"confirm_{measure}"].values
        lower, upper = out[f"confirm_{measure}_lower"].values, \
            out[f"confirm_{measure}_upper"].values
    else:  # a deterministic cost: the levels differ by their cost alone, no interval
        value = out["objective"].values
        lower = upper = value
    usable = np.array([int(s) != 5 for s in out["status"].values])
    order = np.where(usable, value, np.inf)
    best = int(np.argmin(order)) if np.any(usable) else int(np.argmin(value))
    others = [i for i in range(len(levels)) if i != best]
    decided = all(upper[best] < lower[i] for i in others)
    words = [f"best level {levels[best]!r}: {measure or 'objective'} {value[best]:.4g} "
             f"[{lower[best]:.4g}, {upper[best]:.4g}]"]
    for i in others:
        words.append(f"{levels[i]!r}: {value[i]:.4g} [{lower[i]:.4g}, {upper[i]:.4g}]")
    out["best_level"] = ((), str(levels[best]), {"long_name": "level of the least confirmed "
                                                 "objective"})
    out["level_decided"] = ((), np.int8(decided), {
        "units": "1", "long_name": "1: the best level's interval lies below every other's"})
    if fails[best] is not None:
        pairs = [paired_failures(fails[best], f) for f in fails]
        for key, name in (("only_a", "paired_only_best"), ("only_b", "paired_only_other"),
                          ("p_value", "paired_p_value")):
            out[name] = (("level",), np.array([float(p[key]) for p in pairs]), {
                "units": "1", "long_name": f"McNemar against the best level: {key}"})
        for i in others:
            words.append(f"paired against {levels[i]!r} on {pairs[i]['n']} samples: "
                         f"{pairs[i]['only_a']} fail only at the best, {pairs[i]['only_b']} "
                         f"only at {levels[i]!r} (p = {pairs[i]['p_value']:.2g})")
    words.append("decided: its interval lies below every other level's" if decided else
                 "not decided: the intervals overlap, more confirmation runs would tell")
    if not math.isfinite(float(order[best])):
        words.append("every level violates a constraint")
    out.attrs["level_message"] = "; ".join(words)
    out.attrs["level_option"] = option
    return out
