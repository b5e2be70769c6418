"""A design problem (model, space, variables, objective, constraints) and its model runs.

:class:`DesignProblem` holds what the optimiser needs and validates it once;
:func:`evaluate_design` estimates every measure at one design from a fresh Monte Carlo run
(the independent confirmation of a chosen design, or any design a user wants to check).
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable, Mapping, Sequence
from typing import Any

import numpy as np
import xarray as xr

from gearuq.design.measures import Constraint, Estimate, Moment, Probability, Quantile
from gearuq.design.variables import DesignVariable, check_variables, model_at, space_at
from gearuq.engines.montecarlo import monte_carlo
from gearuq.execution import evaluate_chunks
from gearuq.model import Model
from gearuq.registry import get_model
from gearuq.runs import provenance, resolve_seed
from gearuq.space import ParameterSpace

__all__ = ["DesignProblem", "evaluate_design"]


class DesignProblem:
    """Minimise an objective over design variables under constraints on measures.

    Parameters
    ----------
    model : Model or str
        The model (or a registered name).
    space : ParameterSpace
        Random inputs at the reference design; a location variable's target must be in it.
    variables : sequence of DesignVariable
        The design variables with their bounds.
    objective : Probability, Quantile, Moment or callable
        Minimised: a measure, or a deterministic cost ``cost(design) -> float`` of the design
        vector (order of ``variables``), e.g. ``lambda d: d[0] + d[1]``.
    constraints : sequence of Constraint
        Caps or floors on measures.
    t : array_like, optional
        Output instants (time-dependent outputs).
    model_options : mapping, optional
        Declared model options of every search run (the cheap fidelity).
    confidence : float
        Two-sided confidence level of every interval.
    run_outputs : sequence of str, optional
        Outputs computed and kept when a confirmation keeps its runs (``keep_runs``), beside
        those the measures read; default: every output of the model (costly for a model
        whose outputs differ in cost).

    Raises
    ------
    TypeError, ValueError
        Bad variables (see :func:`check_variables`), an objective that is neither a measure
        nor callable, a constraint that is not a :class:`Constraint`, two measures with the
        same name, outputs the model does not have, or a location variable whose shifted law
        leaves the model's valid range at a bound.
    """

    def __init__(
        self,
        model: Model | str,
        space: ParameterSpace,
        variables: Sequence[DesignVariable],
        objective: Any,
        constraints: Sequence[Constraint] = (),
        *,
        t: Any = None,
        model_options: Mapping[str, Any] | None = None,
        confidence: float = 0.95,
        run_outputs: Sequence[str] | None = None,
    ) -> None:
        self.model = get_model(model) if isinstance(model, str) else model
        if not isinstance(self.model, Model):
            raise TypeError(f"model: expected a Model or a name, got {type(model).__name__}")
        if not isinstance(space, ParameterSpace):
            raise TypeError(f"space: expected a ParameterSpace, got {type(space).__name__}")
        self.space = space
        self.variables = check_variables(variables, self.model, space)
        if not (isinstance(objective, (Probability, Quantile, Moment)) or callable(objective)):
            raise TypeError("objective: expected Probability, Quantile, Moment or a callable "
                            f"cost(design), got {type(objective).__name__}")
        self.objective = objective
        self.constraints = tuple(constraints)
        for c in self.constraints:
            if not isinstance(c, Constraint):
                raise TypeError(f"constraints: expected Constraint, got {type(c).__name__}")
        self.measures = self._collect_measures()
        self.outputs = self._collect_outputs()
        self.t = t
        self.model_options = dict(model_options or {})
        if not 0.0 < float(confidence) < 1.0:
            raise ValueError(f"confidence: {confidence!r} must lie in (0, 1)")
        self.confidence = float(confidence)
        names = {o.name for o in self.model.outputs}
        unknown = [o for o in (run_outputs or ()) if o not in names]
        if unknown:
            raise ValueError(f"run_outputs: {unknown} are not outputs of model "
                             f"{self.model.name!r}; outputs: {', '.join(sorted(names))}")
        self.run_outputs = None if run_outputs is None else list(
            dict.fromkeys([*self.outputs, *run_outputs]))
        self._check_ranges()

    def _collect_measures(self) -> tuple[Any, ...]:
        ms = [self.objective] if isinstance(self.objective,
                                            (Probability, Quantile, Moment)) else []
        ms += [c.measure for c in self.constraints]
        out: dict[str, Any] = {}
        for m in ms:
            if m.name in out and out[m.name] != m:
                raise ValueError(f"two different measures are named {m.name!r}; give each a "
                                 "name")
            out[m.name] = m
        return tuple(out.values())

    def _collect_outputs(self) -> list[str]:
        names = {o.name for o in self.model.outputs}
        inputs = {p.name for p in self.model.parameters}
        wanted = list(dict.fromkeys(o for m in self.measures for o in m.outputs))
        unknown = [o for o in wanted if o not in names and o not in inputs]
        if unknown:
            raise ValueError(f"measures read {unknown}, which model {self.model.name!r} does "
                             f"not have; outputs: {', '.join(sorted(names))}")
        return [o for o in wanted if o in names]

    def _check_ranges(self) -> None:
        for v in self.variables:
            if v.role != "location":
                continue
            for bound in v.bounds:
                values = {u.name: (bound if u is v else 0.5 * sum(u.bounds))
                          for u in self.variables}
                sp = space_at(self.space, self.variables, values)
                out = sp.check_range(self.model)[v.target]
                if out > 1e-9:
                    p = self.model.parameter(v.target)
                    raise ValueError(
                        f"DesignVariable {v.name!r}: at {bound:g} the law of {v.target!r} puts "
                        f"{out:.3g} of its probability outside the model's valid range "
                        f"[{p.lower:g}, {p.upper:g}]; narrow the bounds")

    # ------------------------------------------------------------------ helpers
    @property
    def names(self) -> list[str]:
        """Design variable names."""
        return [v.name for v in self.variables]

    @property
    def lower(self) -> np.ndarray:
        """Lower bounds."""
        return np.array([v.bounds[0] for v in self.variables])

    @property
    def upper(self) -> np.ndarray:
        """Upper bounds."""
        return np.array([v.bounds[1] for v in self.variables])

    @property
    def shifts_only(self) -> bool:
        """Whether every design variable only shifts an input law (reweighting applies)."""
        return all(v.role == "location" for v in self.variables) and self.space.independent

    def cost(self, design: np.ndarray) -> float:
        """The deterministic cost (for a callable objective)."""
        value = float(self.objective(np.asarray(design, dtype=float)))
        if not math.isfinite(value):
            raise ValueError(f"objective: cost({np.asarray(design).tolist()}) = {value!r} is "
                             "not finite")
        return value

    def values_of(self, ds: xr.Dataset) -> dict[str, np.ndarray]:
        """Per-sample values of every measure (g or the output; NaN for invalid runs)."""
        return {m.name: m.sample_values(ds) for m in self.measures}

    def run(self, design: np.ndarray, n: int, seed: int, *,
            model_options: Mapping[str, Any] | None = None, executor: Any = None,
            chunk_size: int | None = None, all_outputs: bool = False) -> xr.Dataset:
        """Monte Carlo at one design (same seed, same uniform draws: common random numbers)."""
        opts = self.model_options if model_options is None else dict(model_options)
        outputs = (self.run_outputs if all_outputs else self.outputs) or None
        return monte_carlo(model_at(self.model, self.variables, design),
                           space_at(self.space, self.variables, design), self.t,
                           n_samples=n, rng=seed, outputs=outputs, executor=executor,
                           chunk_size=chunk_size, progress=False, model_options=opts)

    def run_spread(self, n: int, seed: int, *, executor: Any = None,
                   chunk_size: int | None = None) -> xr.Dataset:
        """Runs whose location targets have their means drawn uniformly over the bounds."""
        rng = np.random.default_rng(np.random.SeedSequence([seed, 1]))
        design = self.space.sample(n, rule="random", rng=seed)
        for v in self.variables:
            mean = self.space.marginal(v.target).mean()
            design[v.target] = design[v.target] + rng.uniform(*v.bounds, size=n) - mean
        request = self.model.prepare(self.t, outputs=self.outputs or None,
                                     **self.model_options)
        ds = evaluate_chunks(self.model, design, request, executor=executor,
                             chunk_size=chunk_size, progress=False)
        ds.attrs.update(provenance("design/spread", self.model, request, self.space, seed,
                                   n_samples=n))
        return ds


def evaluate_design(
    problem: DesignProblem,
    design: Any,
    *,
    n_samples: int,
    rng: Any = None,
    model_options: Mapping[str, Any] | None = None,
    executor: Any = None,
    chunk_size: int | None = None,
    keep_runs: bool = False,
) -> xr.Dataset:
    """Every measure of a problem at one design, from one fresh Monte Carlo run.

    Parameters
    ----------
    problem : DesignProblem
    design : array_like or mapping
        One value per design variable.
    n_samples : int
        Model runs.
    rng : int or None
        Seed (``None``: fresh; recorded in ``attrs["seed"]``).
    model_options : mapping, optional
        Model options (default: the problem's; pass the expensive fidelity to confirm).
    executor, chunk_size
        As in :func:`gearuq.monte_carlo`.
    keep_runs : bool
        Also keep the runs' outputs (``run_<output>`` over ``sample``, and ``time`` where
        the output has it) and their ``run_status``.

    Returns
    -------
    xarray.Dataset
        Per measure ``<name>``, ``<name>_lower``, ``<name>_upper`` (intervals at the problem's
        confidence: Clopper-Pearson for probabilities, order statistics for quantiles, normal
        for moments) and ``<name>_ess``; per constraint its verdict in
        ``attrs["constraint_verdicts"]`` (JSON); ``n_model_runs``, ``n_invalid``.
    """
    seed = resolve_seed(rng)
    d = _design_vector(problem, design)
    ds = problem.run(d, int(n_samples), seed, model_options=model_options, executor=executor,
                     chunk_size=chunk_size, all_outputs=keep_runs)
    values = problem.values_of(ds)
    ests = {m.name: m.estimate(values[m.name], None, problem.confidence)
            for m in problem.measures}
    out = estimates_dataset(problem, d, ests, ds, seed)
    if keep_runs:
        for name in [*(o.name for o in problem.model.outputs if o.name in ds), "status"]:
            out[f"run_{name}"] = ds[name].compute()
    out.attrs["model_options"] = json.dumps(
        problem.model_options if model_options is None else dict(model_options), default=repr)
    return out


def _design_vector(problem: DesignProblem, design: Any) -> np.ndarray:
    if isinstance(design, Mapping):
        design = [design[n] for n in problem.names]
    d = np.asarray(design, dtype=float).reshape(-1)
    if d.size != len(problem.variables):
        raise ValueError(f"design: expected {len(problem.variables)} values "
                         f"({', '.join(problem.names)}), got {d.size}")
    out = (d < problem.lower) | (d > problem.upper)
    if np.any(out):
        j = int(np.argmax(out))
        raise ValueError(f"design: {problem.names[j]}={float(d[j])!r} is outside its bounds "
                         f"[{problem.lower[j]:g}, {problem.upper[j]:g}]")
    return d


def estimates_dataset(problem: DesignProblem, design: np.ndarray,
                      ests: Mapping[str, Estimate], ds: xr.Dataset, seed: int) -> xr.Dataset:
    """Label estimates at one design as a Dataset (see :func:`evaluate_design`)."""
    data: dict[str, Any] = {}
    for v, x in zip(problem.variables, design, strict=True):
        data[f"design_{v.name}"] = ((), float(x), {"units": v.units, "long_name":
                                                   f"design value of {v.name} ({v.target})"})
    for m in problem.measures:
        e = ests[m.name]
        for suffix, value in (("", e.value), ("_lower", e.lower), ("_upper", e.upper)):
            data[f"{m.name}{suffix}"] = ((), float(value), {"units": m.units,
                                                          "long_name": f"{m.kind} {m.name}"
                                                          + (f" ({suffix[1:]} end)" if suffix
                                                             else "")})
        data[f"{m.name}_ess"] = ((), float(e.ess), {"units": "1", "long_name":
                                                    "effective sample size behind it"})
    n_invalid = int(np.sum(np.asarray(ds["status"].values) != 0))
    data["n_model_runs"] = ((), np.int64(ds.sizes["sample"]), {"units": "1"})
    data["n_invalid"] = ((), np.int64(n_invalid), {"units": "1"})
    out = xr.Dataset(data)
    verdicts = {c.measure.name: c.verdict(ests[c.measure.name]) for c in problem.constraints}
    out.attrs.update(provenance("design/evaluate_design", problem.model, None, problem.space,
                                seed))
    out.attrs["constraint_verdicts"] = json.dumps(verdicts)
    out.attrs["confidence"] = problem.confidence
    return out


Cost = Callable[[np.ndarray], float]
