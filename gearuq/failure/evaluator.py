"""The evaluator every failure-probability method shares: standard space <-> physical
parameters, the limit state on model runs, and the run counts.

Every method works in the independent standard normal space ``u`` of the
:class:`~gearuq.space.ParameterSpace`: ``z = L u`` (``L`` the Cholesky factor of the Gaussian
copula's correlation, identity when independent) and ``x_j = F_j^{-1}(Phi(z_j))``. Model runs
go through :func:`gearuq.execution.evaluate_chunks` (chunked, failure-isolating, resumable with
a store), and every run is counted.

What a method must not hide is recorded here, once for all methods:

* an **invalid run** (nonzero model status, or a limit state that is NaN or infinite on valid
  outputs) is neither safe nor failed: its ``g`` is NaN, it is counted in ``n_invalid`` and its
  reason kept in ``errors``; each method then widens its interval to cover both readings;
* a **censored run** (a status the limit state names in ``censored_statuses``: its outputs
  bound the answer, the run at least as close to failure as its ``g`` reads) is invalid all
  the same, and its bound is returned beside (``g_bound``) and counted in ``n_censored``, for
  the methods that can read it (subset simulation, while it explores);
* for a **time-dependent** limit state the first-passage value ``min_t g(t)`` is returned with
  the same value on every other instant (``g_half``), from which each method estimates how
  much first-passage probability the time grid itself can miss (the check of
  :func:`gearuq.reliability`).

For a **system**, :meth:`LimitStateEvaluator.calibrate_scales` measures each component's
gradient at the origin once (``d + 1`` runs) and from then on the system's ``g`` combines the
components divided by it: the failure set is unchanged (a positive factor keeps every sign),
but each component's ``g`` reads roughly as a distance in the standard normal space, so a load
margin in newtons does not hide a deflection margin in millimetres from a method that follows
``g`` (FORM's gradient, subset simulation's level thresholds). :meth:`component` gives the
view of one component alone, and the nearest failing point seen so far is kept
(:attr:`nearest_failure`) for the methods' checks of hidden failure regions.
"""

from __future__ import annotations

import json
import math
import os
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr
from scipy import linalg, special

from gearuq.execution import AllSamplesFailedError, evaluate_chunks
from gearuq.failure.modes import System, as_limit_state, check_band_reach
from gearuq.model import Model, Request
from gearuq.runs import resolve_model_and_space
from gearuq.space import ParameterSpace

__all__ = ["LimitStateEvaluator", "ComponentView", "STATUS_LIMIT_STATE_NONFINITE",
           "STATUS_ALL_FAILED"]

#: Per-sample status given to a valid model run whose limit-state value is NaN or infinite.
STATUS_LIMIT_STATE_NONFINITE = 3
#: Per-sample status given to every sample of a design in which every model run failed.
STATUS_ALL_FAILED = 4


class LimitStateEvaluator:
    """Evaluate a limit state at points of the standard normal space, counting model runs.

    Parameters
    ----------
    model : Model or str
    space : ParameterSpace or mapping
    limit_state : LimitState, System, Band or output name
    t : array_like, optional
        Output instants (time-dependent limit states use ``min_t g(t)``).
    model_options : mapping, optional
        Declared model options.
    executor, chunk_size :
        As in :func:`gearuq.execution.evaluate_chunks`.
    store : path-like, optional
        Directory; every evaluation ``tag`` gets its own chunk store below it, so an
        interrupted run resumes where it stopped.
    engine : str
        Name recorded in the stores' fingerprints.
    seed : int, optional
        Recorded in the stores' fingerprints.
    """

    def __init__(self, model: Model | str, space: ParameterSpace | Mapping[str, Any],
                 limit_state: Any, t: Any = None, *, model_options: Mapping[str, Any] | None
                 = None, executor: Any = None, chunk_size: int | None = None,
                 store: str | os.PathLike | None = None, engine: str = "failure_probability",
                 seed: int | None = None) -> None:
        self.model, self.space = resolve_model_and_space(model, space)
        self.limit_state = as_limit_state(limit_state)
        known = set(self.model.output_names) | set(self.model.parameter_names)
        unknown = [v for v in self.limit_state.variables if v not in known]
        if unknown:
            raise ValueError(
                f"limit state {self.limit_state.name!r}: unknown output(s) "
                f"{', '.join(map(repr, unknown))} of model {self.model.name!r}; valid outputs: "
                f"{', '.join(self.model.output_names)}")
        outputs = [v for v in self.limit_state.variables if v in self.model.output_names]
        if not outputs:
            raise ValueError(f"limit state {self.limit_state.name!r} reads no model output "
                             f"(only inputs {list(self.limit_state.variables)})")
        for leaf in self.limit_state.leaves():  # a band no value can stay in, or leave
            spec = getattr(leaf, "_spec", None) or {}
            if spec.get("kind") == "band" and spec["output"] in self.model.output_names:
                meta = self.model.output(spec["output"])
                lower = -math.inf if spec["lower"] is None else float(spec["lower"])
                upper = math.inf if spec["upper"] is None else float(spec["upper"])
                check_band_reach(spec["output"], lower, upper, bool(spec["absolute"]),
                                 meta.valid_min, meta.units)
        self.request: Request = self.model.prepare(t, outputs=outputs, **dict(model_options or {}))
        for leaf in self.limit_state.leaves():  # refused before any run
            leaf.check_window(self.request.t, "of the output instants t")
        self.names = self.space.names
        self.dim = self.space.dim
        corr = self.space.correlation
        self.chol = None if corr is None else np.linalg.cholesky(corr)
        self.marginals = [self.space.marginal(n) for n in self.names]
        self.parameters = [self.model.parameter(n) for n in self.names]
        self.leaves = self.limit_state.leaves()
        self.executor, self.chunk_size = executor, chunk_size
        self.store = None if store is None else Path(store)
        self.engine, self.seed = engine, seed
        self.n_runs = 0  # samples passed to the model, re-runs of bisected chunks included
        self.worker_cpu = 0.0  # CPU seconds of model runs in worker processes
        #: evaluators of other models the method runs beside this one (MFIS's cheap model):
        #: their worker CPU counts in the method's cost
        self.companions: list[LimitStateEvaluator] = []
        self.n_points = 0  # points evaluated (each once, however often the model was called)
        self.n_invalid = 0
        #: runs the model reported valid whose limit state was NaN or inf (among n_invalid)
        self.n_limit_state_nonfinite = 0
        #: censored runs (their ``g`` an upper bound of the true one; among ``n_invalid``), and
        #: their points' bytes, by which a method recognises one again among its samples
        self.n_censored = 0
        self.censored_points: set[bytes] = set()
        self.time_dependent = False
        self._grid_fail = 0  # valid failing samples on the full grid ...
        self._grid_missed = 0  # ... of which every other instant misses the failure
        self.errors: list[str] = []
        #: leaf name -> positive divisor of its g in the system's combination (None: raw)
        self.leaf_scales: dict[str, float] | None = None
        #: (distance from the origin, point u) of the nearest valid failing run so far
        self.nearest_failure: tuple[float, np.ndarray] = (np.inf, np.zeros(self.dim))

    # ------------------------------------------------------------------ maps
    def to_correlated(self, u: np.ndarray) -> np.ndarray:
        """Correlated standard normals ``z = L u``."""
        u = np.atleast_2d(np.asarray(u, dtype=float))
        return u if self.chol is None else u @ self.chol.T

    def to_physical(self, u: Any) -> dict[str, np.ndarray]:
        """Physical parameter values of standard normal points ``u`` (n, dim)."""
        z = self.to_correlated(u)
        return {n: m.from_normal(z[:, j]) for j, (n, m) in enumerate(
            zip(self.names, self.marginals, strict=True))}

    def to_standard(self, x: Mapping[str, Any]) -> np.ndarray:
        """Standard normal points of physical values (inverse of :meth:`to_physical`)."""
        cols = []
        for n, m in zip(self.names, self.marginals, strict=True):
            p = np.clip(np.asarray(m.cdf(np.asarray(x[n], dtype=float)), dtype=float), 0, 1)
            cols.append(special.ndtri(p))
        z = np.column_stack(cols)
        if self.chol is None:
            return z
        return linalg.solve_triangular(self.chol, z.T, lower=True).T

    def _range_mask(self, x: Mapping[str, np.ndarray]) -> np.ndarray:
        n = len(next(iter(x.values())))
        ok = np.ones(n, dtype=bool)
        for name, par in zip(self.names, self.parameters, strict=True):
            ok &= (x[name] >= par.lower) & (x[name] <= par.upper)
        return ok

    def in_range(self, u: Any) -> np.ndarray:
        """Whether each point's physical values lie in the model's valid ranges."""
        return self._range_mask(self.to_physical(u))

    def _range_messages(self, u: np.ndarray, x: Mapping[str, np.ndarray]) -> list[str]:
        out = []
        for name, par in zip(self.names, self.parameters, strict=True):
            bad = (x[name] < par.lower) | (x[name] > par.upper)
            if bad.any():
                i = int(np.flatnonzero(bad)[0])
                out.append(f"parameter {name!r} = {x[name][i]:.6g} (u = {u[i]}) is "
                           f"outside the model's valid range {par.range_text()}")
        return out

    def outside_range(self, u: Any) -> list[str]:
        """Messages for points whose physical values leave the model's valid ranges."""
        u = np.atleast_2d(np.asarray(u, dtype=float))
        return self._range_messages(u, self.to_physical(u))

    # ------------------------------------------------------------------ evaluation
    def evaluate(self, u: Any, tag: str) -> dict[str, np.ndarray]:
        """Run the model at points ``u`` (n, dim) and return the limit state.

        Returns
        -------
        dict
            ``g`` (n,) system / first-passage limit-state value (NaN where invalid),
            ``g_half`` (n,) the same on every other output instant (equal to ``g`` for a
            limit state without time), ``g_bound`` (n,) a censored run's ``g``, an upper
            bound of the true value (NaN for every other run), ``leaf`` (n, n_leaves)
            component values, ``status`` (n,) int (0 = ok), ``x`` the physical points.

        Raises
        ------
        ValueError
            If a point's physical value leaves the model's valid range (names the parameter,
            the value and the range).
        """
        u = np.atleast_2d(np.asarray(u, dtype=float))
        if u.shape[1] != self.dim or not np.all(np.isfinite(u)):
            raise ValueError(f"evaluate: expected finite points of shape (n, {self.dim}), got "
                             f"{u.shape}")
        x = self.to_physical(u)  # mapped once: range check and model runs share it
        if not self._range_mask(x).all():
            bad = self._range_messages(u, x)
            p_out = {k: v for k, v in self.space.check_range(self.model).items() if v > 0}
            hint = (f"; the space puts probability {p_out} outside the valid range: truncate "
                    "the marginal(s)" if p_out else "")
            raise ValueError(f"{self.engine} ({tag}): {bad[0]}{hint}")
        n = u.shape[0]
        store = None if self.store is None else self.store / tag
        # the stored chunks are model outputs, tied to their inputs by the design's digest
        # (evaluate_chunks): neither the limit state nor the method's settings change them,
        # so a walk at another threshold with the same seed reuses every run its levels share
        fp = {"engine": self.engine, "tag": tag, "seed": self.seed}
        try:
            # small designs (a gradient, an MCMC step) are one chunk; large ones chunk by the
            # driver's default (at most 64 MB of result per chunk)
            ds = evaluate_chunks(self.model, x, self.request, executor=self.executor,
                                 chunk_size=self.chunk_size or (n if n <= 4096 else None),
                                 store=store, progress=False, fingerprint=fp)
        except AllSamplesFailedError as exc:  # every sample failed: flag them, keep going
            self.errors.append(f"{tag}: {str(exc).split(chr(10))[0][:300]}")
            self.n_runs += exc.n_evaluations
            self.n_points += n
            self.n_invalid += n
            nan = np.full(n, np.nan)
            return {"g": nan, "g_half": nan.copy(), "g_bound": nan.copy(),
                    "leaf": np.full((n, len(self.leaves)), np.nan),
                    "status": np.full(n, STATUS_ALL_FAILED, dtype=np.int8), "x": x}
        # every call to the model counts, re-runs of a chunk that raised and was bisected
        # included; samples taken from a store were paid for by the run that wrote them
        self.n_runs += int(ds.attrs.get("n_evaluations", n)) + int(
            ds.attrs.get("n_reused_samples", 0))
        self.worker_cpu += float(ds.attrs.get("worker_cpu_seconds", 0.0))
        self.n_points += n
        out = self._limit_state_values(ds, x, n, tag)
        censored = np.flatnonzero(np.isfinite(out["g_bound"]))
        self.n_censored += censored.size
        self.censored_points.update(u[i].tobytes() for i in censored)
        failing = np.flatnonzero((out["status"] == 0) & (out["g"] <= 0.0))
        if failing.size:
            r = np.linalg.norm(u[failing], axis=1)
            i = int(np.argmin(r))
            if r[i] < self.nearest_failure[0]:
                self.nearest_failure = (float(r[i]), u[failing[i]].copy())
        return out

    def _limit_state_values(self, ds: xr.Dataset, x: dict[str, np.ndarray], n: int,
                            tag: str) -> dict[str, np.ndarray]:
        status = np.asarray(ds["status"].values).astype(np.int8)
        leaf = np.column_stack([leaf.sample_values(ds) for leaf in self.leaves])
        # per instant first, then over time: a parallel system of time-dependent components
        # fails at an instant where all fail, which min over time per component cannot see
        g_t = (self.limit_state.values(ds, self.leaf_scales) if self.leaf_scales
               else self.limit_state.values(ds))
        if "time" in g_t.dims and g_t.sizes["time"] > 1:
            self.time_dependent = True
            # refined between instants as the limit state says, on the half grid alike: the
            # difference is what the grid (and its interpolation) may still miss
            g = self.limit_state.reduce_time(g_t)
            g_half = self.limit_state.reduce_time(g_t, step=2)
        else:
            if "time" in g_t.dims:
                g_t = g_t.isel(time=0)
            g = np.asarray(g_t.transpose("sample").values, dtype=float).copy()
            g_half = g.copy()
        nonfinite = (status == 0) & ~np.isfinite(g)
        if nonfinite.any():  # NaN/inf on valid outputs: an invalid sample, never a silent drop
            self.errors.append(f"{tag}: limit state non-finite (NaN or inf output) at "
                               f"{int(nonfinite.sum())} sample(s) the model reported valid")
            status[nonfinite] = STATUS_LIMIT_STATE_NONFINITE
            self.n_limit_state_nonfinite += int(nonfinite.sum())
        invalid = status != 0
        # a censored run: its g (finite) is an upper bound of the true one; kept beside
        codes = getattr(self.limit_state, "censored_statuses", ())  # a system has none
        censored = np.isin(status, codes) & np.isfinite(g)
        g_bound = np.where(censored, g, np.nan)
        g[invalid] = np.nan
        g_half[invalid] = np.nan
        leaf[invalid] = np.nan
        if invalid.any() and "failures" in ds.attrs:
            groups = json.loads(ds.attrs["failures"])
            self.errors += [f"{tag}: {len(grp['samples'])} sample(s): {grp['error'][:300]}"
                            for grp in groups]
        self.n_invalid += int(invalid.sum())
        fails = g <= 0.0
        self._grid_fail += int(fails.sum())
        self._grid_missed += int(np.sum(fails & ~(g_half <= 0.0)))
        return {"g": g, "g_half": g_half, "g_bound": g_bound, "leaf": leaf, "status": status,
                "x": x}

    def is_censored(self, u: np.ndarray) -> np.ndarray:
        """Whether each row of ``u`` is a point whose run was censored (bool per row)."""
        u = np.atleast_2d(np.asarray(u, dtype=float))
        if not self.censored_points:
            return np.zeros(u.shape[0], dtype=bool)
        return np.array([row.tobytes() in self.censored_points for row in u], dtype=bool)

    def calibrate_scales(self, step: float = 0.5) -> dict[str, float] | None:
        """Measure each component's gradient at the origin and divide its ``g`` by it.

        One design of ``d + 1`` runs (the origin and a step of ``step`` along each axis,
        backwards where forwards leaves the model's range); a no-op for a single limit state
        or when already calibrated. A component whose gradient is zero or not finite keeps
        the scale ``|g(0)|`` (or 1).

        Returns
        -------
        dict or None
            Leaf name -> scale (None for a single limit state).
        """
        if not self.is_system or self.leaf_scales is not None:
            return self.leaf_scales
        eye = np.eye(self.dim) * step
        fwd = self.in_range(eye)
        design = np.vstack([np.zeros((1, self.dim)), np.where(fwd[:, None], eye, -eye)])
        leaf = self.evaluate(design, "system_scales")["leaf"]
        slope = (leaf[1:] - leaf[0]) / np.where(fwd, step, -step)[:, None]
        scales = {}
        for k, name in enumerate(lf.name for lf in self.leaves):
            norm = float(np.linalg.norm(slope[:, k]))
            if not (math.isfinite(norm) and norm > 0):
                norm = abs(float(leaf[0, k])) if np.isfinite(leaf[0, k]) and leaf[0, k] else 1.0
            scales[name] = norm
        self.leaf_scales = scales
        return scales

    def component(self, k: int) -> ComponentView:
        """The evaluator seen through the ``k``-th component (leaf) alone."""
        if not 0 <= k < len(self.leaves):
            raise ValueError(f"component: {k} is not in 0..{len(self.leaves) - 1}")
        return ComponentView(self, k)

    @property
    def series_leaves(self) -> bool:
        """Whether the limit state is a series system whose every component fails the system
        (a top-level series system: each component's failure set lies in the system's)."""
        return isinstance(self.limit_state, System) and self.limit_state.kind == "series" \
            and all(not isinstance(c, System) for c in self.limit_state.components)

    @property
    def grid_gap_fraction(self) -> float:
        """Share of the failing runs so far whose failure every other instant misses."""
        return self._grid_missed / self._grid_fail if self._grid_fail else 0.0

    def fingerprint_settings(self) -> dict[str, Any]:
        """Description for provenance."""
        return {"limit_state": self.limit_state.to_json(), "n_leaves": len(self.leaves)}

    @property
    def is_system(self) -> bool:
        """Whether the limit state is a system of several components."""
        return isinstance(self.limit_state, System)


class ComponentView:
    """One component of a system evaluator: ``g`` is that component's value alone.

    Every other attribute (maps, counts, settings) is the parent evaluator's, so runs made
    through a view are counted once, in the parent.
    """

    def __init__(self, parent: LimitStateEvaluator, k: int) -> None:
        self.parent = parent
        self.index = k
        self.name = parent.leaves[k].name

    def __getattr__(self, name: str) -> Any:
        return getattr(self.parent, name)

    def evaluate(self, u: Any, tag: str) -> dict[str, np.ndarray]:
        """As :meth:`LimitStateEvaluator.evaluate`, ``g`` and ``g_half`` of the component."""
        res = dict(self.parent.evaluate(u, tag))
        res["g"] = res["leaf"][:, self.index].copy()
        res["g_half"] = res["g"].copy()
        res["g_bound"] = np.full_like(res["g"], np.nan)  # a bound is the whole limit state's
        return res

    def is_censored(self, u: np.ndarray) -> np.ndarray:
        """False for every row: a view reads no run at a bound (its ``g_bound`` is NaN), so
        none of its points is censored, whatever the parent counts."""
        return np.zeros(np.atleast_2d(np.asarray(u, dtype=float)).shape[0], dtype=bool)
