"""Multi-fidelity importance sampling: a cheap model finds where failure lives, the expensive
one is run only on draws from a density fitted there (Peherstorfer, Cui, Marzouk and Willcox
2016).

1. **Explore on the low-fidelity model** ``LF`` (any model whose parameters include every
   random parameter of the space, a surrogate or a fidelity link) and fit a defensive biasing
   density to its failure set: one family per class of :mod:`gearuq.failure.methods.biasing`
   (``biasing="gaussian"``, ``"vmfn"``, ``"quadratic"`` or an instance of
   :class:`~gearuq.failure.methods.biasing.Gaussian`, :class:`~.biasing.VMFN`,
   :class:`~.biasing.Quadratic` that owns its settings; the flat keywords still work).
2. **Widen by the measured discrepancy.** A pilot of expensive runs from the density is also
   run on ``LF``; ``delta`` is 1.5 x the largest excess of the cheap margin over the
   expensive one, ``max(g_LF, 0) - max(g_HF, 0)``, on those pairs (or the declared
   ``discrepancy``). If the density was fitted to less than ``{g_LF <= delta}``, it is
   refitted to that widened set. Under the assumption that ``g_LF <= delta`` wherever the
   expensive model fails, the expensive failure set lies inside the widened cheap one and the
   density covers it: the interval rests on that assumption, and the report's message says
   so. The pilot's defensive draws land in the bulk, where a cheap model blind to a failure
   mechanism shows it as a large excess (near its own boundary it can look perfect). A
   failing expensive draw with a larger excess contradicts the assumption: status 8. A cheap
   model that never fails gives crude Monte Carlo on the expensive model (the defensive
   component alone), status 8 and no cheap estimate (``pf_low_fidelity`` NaN).
3. **Estimate on the expensive model** (:func:`~gearuq.failure.methods.importance.sample_until`):
   the last pilot sizes the estimation stage for ``target_cov``; the estimate
   ``mean(1_F w)`` is made from fresh draws only (unbiased: stopping once the running CoV
   reaches the target leans high), interval ``pf +- z se``.

The defensive share bounds every weight by ``1 / defensive``: unbiased whatever ``LF``'s
quality, but blind, in a budget, to a failure region its density does not reach. The checks
of importance sampling set the status too (3, 6). ``n_model_runs`` counts the expensive model
only, pilots included; the cheap runs and wall times are reported apart.
"""

from __future__ import annotations

import math
import time
from collections.abc import Mapping
from typing import Any

import numpy as np
import xarray as xr

from gearuq.failure.evaluator import LimitStateEvaluator
from gearuq.failure.methods.biasing import (
    FAMILIES,
    FAMILY_SETTINGS,
    BiasingDensity,
    CheapFit,
    resolve_biasing,
)
from gearuq.failure.methods.importance import (
    PILOT_BATCH,
    draw_batch,
    sample_until,
    weight_diagnostics,
    weight_status,
)
from gearuq.failure.methods.mixtures import (
    fit_mixture,
    informative_directions,
    weighted_directions,
)
from gearuq.failure.methods.vmfn import VMFNMixture
from gearuq.failure.report import Reason, failure_report
from gearuq.model import Model, Option

__all__ = ["SETTINGS", "run_mfis", "fit_mixture", "informative_directions",
           "weighted_directions", "DISCREPANCY_FACTOR", "excess_margin"]

#: ``delta`` is this times the largest excess ``g_LF - g_HF`` measured on the pilots: a
#: sample maximum understates the bound it stands for.
DISCREPANCY_FACTOR = 1.5


def _check_model(value: Any) -> Any:
    if value is None:
        raise ValueError("low_fidelity: required for method 'mfis' (a Model or a registered "
                         "model name over the same parameter space)")
    if not isinstance(value, (Model, str)):
        raise ValueError(f"low_fidelity: expected a Model or a registered model name, got "
                         f"{type(value).__name__}")
    return value


def _check_mapping(value: Any) -> Any:
    if value is not None and not isinstance(value, Mapping):
        raise ValueError(f"low_fidelity_options: expected a mapping, got {value!r}")
    return value


def _check_times(value: Any) -> Any:
    if value is None:
        return None
    t = np.asarray(value, dtype=float)
    if t.ndim != 1 or t.size < 1 or not np.all(np.isfinite(t)) or np.any(np.diff(t) <= 0):
        raise ValueError("low_fidelity_t: expected finite, strictly increasing output instants "
                         f"(1-D), got {value!r}")
    return t


def _check_biasing(value: Any) -> Any:
    if isinstance(value, BiasingDensity) or value in FAMILIES:
        return value
    raise ValueError(f"biasing: expected one of {', '.join(map(repr, FAMILIES))} or an instance "
                     f"of {', '.join(c.__name__ for c in FAMILIES.values())}, got {value!r}")


def _check_discrepancy(value: Any) -> Any:
    if value is None or (isinstance(value, (int, float)) and not isinstance(value, bool)
                         and math.isfinite(value) and value >= 0):
        return value
    raise ValueError(f"discrepancy: expected None (measured) or a finite number >= 0, got "
                     f"{value!r}")


SETTINGS = (
    Option("low_fidelity", None, "the cheap model (Model or registered name) that explores the "
           "failure domain; its parameters must include every random parameter of the space",
           kind="any", check=_check_model, allow_none=True),
    Option("low_fidelity_options", None, "declared model options of the cheap model",
           kind="any", check=_check_mapping, allow_none=True),
    Option("low_fidelity_t", None, "output instants of the cheap model (default: the "
           "expensive model's); fewer instants make a time-dependent cheap model cheaper",
           kind="any", check=_check_times, allow_none=True),
    Option("low_fidelity_limit_state", None, "limit state on the cheap model's outputs "
           "(default: the same as the expensive model's; its g must be in the expensive g's "
           "units, the two are compared)", kind="any", allow_none=True),
    Option("biasing", "gaussian", "family of the biasing density: 'gaussian', 'vmfn', "
           "'quadratic' (settings as keywords), or an instance of biasing.Gaussian, .VMFN or "
           ".Quadratic that owns its settings", kind="any", check=_check_biasing),
    Option("discrepancy", None, "bound on g_LF - g_HF wherever the expensive model fails, in "
           "g's units: None measures it on the pilots' paired runs (1.5 x the largest excess)",
           kind="any", check=_check_discrepancy, allow_none=True),
    Option("n_samples", 500, "expensive-model samples per batch (and of each pilot)", lower=10),
    Option("target_cov", 0.1, "CoV of pf the estimation stage is sized for (by the pilot)",
           lower=1e-4, upper=1.0),
    Option("max_samples", 10_000, "largest number of expensive-model samples (pilots and "
           "estimation)", lower=10),
) + FAMILY_SETTINGS


def _low_fidelity(ev: LimitStateEvaluator, s: Mapping[str, Any], seed: int
                  ) -> LimitStateEvaluator:
    from gearuq.registry import get_model

    lf = _check_model(s["low_fidelity"])
    lf = get_model(lf) if isinstance(lf, str) else lf
    missing = [n for n in ev.names if n not in lf.parameter_names]
    if missing:
        raise ValueError(
            f"low_fidelity: model {lf.name!r} has no parameter(s) {', '.join(map(repr, missing))}"
            f" of the parameter space; its parameters: {', '.join(lf.parameter_names)}. Wrap it "
            "in a fidelity link that maps the space onto its inputs")
    limit = s["low_fidelity_limit_state"] or ev.limit_state
    t = ev.request.t if s["low_fidelity_t"] is None else s["low_fidelity_t"]
    # the cheap side runs on the same executor and chunking as the expensive one
    ev_lf = LimitStateEvaluator(lf, ev.space, limit, t,
                                model_options=s["low_fidelity_options"], executor=ev.executor,
                                chunk_size=ev.chunk_size,
                                store=None if ev.store is None else ev.store / "low_fidelity",
                                engine="failure_probability/mfis/low_fidelity", seed=seed)
    ev.companions.append(ev_lf)
    return ev_lf


def excess_margin(g_lf: np.ndarray, g_hf: np.ndarray) -> np.ndarray:
    """``max(g_LF, 0) - max(g_HF, 0)``: by how much the cheap model's safety margin exceeds
    the expensive one's. Where both fail the depths do not matter (0); where only the
    expensive model fails it is the cheap ``g`` itself, the widening that point needs."""
    return np.maximum(g_lf, 0.0) - np.maximum(g_hf, 0.0)


def _widen(ev: LimitStateEvaluator, ev_lf: LimitStateEvaluator, family: BiasingDensity,
           first: CheapFit, s: Mapping[str, Any], seed: int) -> dict[str, Any]:
    """A pilot from the density with paired cheap runs, the discrepancy bound, and the
    density refitted to the widened cheap failure set when it does not cover it (step 2)."""
    m0 = max(min(s["n_samples"], s["max_samples"] // 2), 2)
    pilot = draw_batch(ev, first.density, m0, np.random.SeedSequence([seed, 31]),
                       PILOT_BATCH, "mfis/pilot")
    e = excess_margin(ev_lf.evaluate(pilot["u"], "mfis/pilot/cheap")["g"], pilot["g"])
    e = e[np.isfinite(e)]
    measured = max(float(np.max(e, initial=0.0)), 0.0)
    delta = DISCREPANCY_FACTOR * measured if s["discrepancy"] is None else s["discrepancy"]
    fit, w_new = first, None
    if first.found_failure and delta > first.covered:
        fit = family.widened(first, ev_lf, seed + 1, delta)
        w_new = np.exp(fit.density.log_weights(pilot["u"]))
    return {"fit": fit, "pilot": pilot, "w_new": w_new, "delta": delta, "measured": measured,
            "widened": fit is not first, "n_pairs": e.size}


def run_mfis(ev: LimitStateEvaluator, s: Mapping[str, Any], seed: int, confidence: float
             ) -> xr.Dataset:
    """Multi-fidelity importance sampling; see the module docstring."""
    t0 = time.perf_counter()
    family = resolve_biasing(s)
    ev_lf = _low_fidelity(ev, s, seed)
    first = family.fit(ev_lf, seed)
    # a system's g is scaled per component, calibrated on the cheap model by its walk: the
    # expensive g takes the same scales, or the discrepancy g_LF - g_HF mixes two units
    if ev_lf.leaf_scales is not None:
        ev.leaf_scales = dict(ev_lf.leaf_scales)
    t_lf = time.perf_counter() - t0
    w = _widen(ev, ev_lf, family, first, s, seed)
    # the pilot is batch PILOT_BATCH of this stream, the estimate's fresh draws 0, 1, ...
    est = sample_until(ev, w["fit"].density, s, confidence, np.random.SeedSequence([seed, 31]),
                       "mfis", pilot=w["pilot"], w_new=w["w_new"])
    reasons = list(first.reasons)
    if est["failing_u"].shape[0] and first.found_failure:
        e = excess_margin(ev_lf.evaluate(est["failing_u"], "mfis/failing/cheap")["g"],
                          est["failing_g"])
        beyond = int(np.sum(e > w["delta"]))
        if beyond:
            reasons.append((8, f"{beyond} failing expensive run(s) exceed the cheap model's g "
                            f"by more than the bound {w['delta']:.4g} (largest excess "
                            f"{float(np.nanmax(e)):.4g}): the cheap model misses part of the "
                            "failure domain, which the density was not built to sample"))
    return _report(ev, s, family, seed, confidence, est, first, w, ev_lf, reasons, t0, t_lf)


def _assumption(w: Mapping[str, Any], user: bool) -> str:
    how = "declared" if user else (f"{DISCREPANCY_FACTOR:g} x the largest excess "
                                   f"{w['measured']:.4g} on {w['n_pairs']} paired runs")
    return (f"the interval assumes that the cheap model's g exceeds the expensive model's by "
            f"at most {w['delta']:.4g} ({how}) wherever the expensive model fails; the density "
            "covers the cheap failure set widened by that. A failure region the cheap model "
            "misses by more, where no paired run went, is beyond every check")


def _report(ev: LimitStateEvaluator, s: Mapping[str, Any], family: BiasingDensity, seed: int,
            confidence: float, est: dict[str, Any], first: CheapFit, w: dict[str, Any],
            ev_lf: LimitStateEvaluator, reasons: list[Reason], t0: float, t_lf: float
            ) -> xr.Dataset:
    fit = w["fit"]
    status, message, bound, pf, lower, upper = weight_status(
        est, s["target_cov"], "the low-fidelity model may lead away from the failure domain")
    weights, invalid = weight_diagnostics(est, "expensive-model samples")
    assumption = _assumption(w, s["discrepancy"] is not None)
    if any(c == 8 for c, _ in reasons):  # the cause first, what it did to the weights after
        reasons = [(status, message)] + reasons if status else reasons
        status, message = next(r for r in reasons if r[0] == 8)
        reasons = [r for r in reasons if r != (status, message)]
    message = f"{message}; {assumption}" if message else assumption
    mix = fit.density
    var = {
        "n_low_fidelity_runs": (np.int64(ev_lf.n_runs), "1",
                                "runs of the low-fidelity model (not in n_model_runs)"),
        "low_fidelity_wall_time": (float(t_lf), "s", "wall time of the low-fidelity exploration"),
        "high_fidelity_wall_time": (float(time.perf_counter() - t0 - t_lf), "s",
                                    "wall time of the pilots, widenings and expensive sampling"),
        "pf_low_fidelity": (first.pf, "1", "the cheap model's failure probability (subset "
                            "simulation or its importance estimate; NaN: it found no failure)"),
        "n_components": (np.int64(getattr(mix, "n_components", None) or mix.means.shape[0]), "1",
                         "components of the biasing density (defensive excluded)"),
        "n_directions": (np.int64(getattr(mix, "n_directions", ev.dim)), "1",
                         "directions in which the biasing density was fitted (standard normal "
                         "across them)"),
        "discrepancy_measured": (w["measured"], "1", "largest g_LF - g_HF on the pilots' paired "
                                 "runs (units of g)"),
        "discrepancy_bound": (w["delta"], "1", "bound on g_LF - g_HF where the expensive model "
                              "fails that the density covers (units of g)"),
        "widened": (np.int8(w["widened"]), "1", "1 where the density was refitted to the "
                    "cheap failure set widened by discrepancy_bound"),
    }
    extra = {k: ((), v, {"units": u, "long_name": n}) for k, (v, u, n) in var.items()}
    for key, name in (("pf", "the cheap model's pf by importance sampling with the density"),
                      ("cov", "its coefficient of variation"), ("ess", "its effective sample "
                                                                "size of failing draws")):
        if key in first.info and "n_fail" in first.info:
            extra[f"{key}_low_fidelity_is"] = ((), first.info[key], {"units": "1",
                                                                    "long_name": name})
    settings = {k: v.name if isinstance(v, Model) else str(v) if isinstance(
        v, BiasingDensity) else v for k, v in s.items()}
    return failure_report(
        ev, "mfis", pf=pf, pf_lower=lower, pf_upper=upper, cov=est["cov"],
        interval_kind="normal approximation pf +- z se of the importance-sampling estimator "
                      "(expensive-model runs only)",
        confidence=confidence, settings=settings, seed=seed,
        wall_time=time.perf_counter() - t0, status=status, message=message,
        reasons=reasons + invalid, grid_gap=est["grid_gap"] if ev.time_dependent else math.nan,
        pf_is_upper_bound=bound, extra={**extra, **weights}, extra_attrs={
            "low_fidelity_model": ev_lf.model.name, "defensive_share": float(mix.defensive),
            "biasing_family": str(family), "assumption": assumption,
            "biasing_density": mix.describe() if isinstance(mix, VMFNMixture)
            else "Gaussian mixture",
            **({"quadratic_fit_r2": fit.info["r2"], "tilt": fit.info["tilt"]}
               if "r2" in fit.info else {})})
