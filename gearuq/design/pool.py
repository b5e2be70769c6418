"""Model runs shared across designs: a pool of batches reweighted by likelihood ratios.

When the design variables only shift input laws (``role="location"``), a run drawn at any law
serves every design: at design ``d`` its weight is ``f_d(x) / h(x)``, with ``h`` the mixture of
all the batches' laws in proportion to their sizes (the deterministic-mixture, or balance
heuristic, weights of Veach and Guibas 1995 and Owen and Zhou 2000: unbiased, and never
worse than the worst batch alone). Inputs a design does not move have the same law in every
batch and cancel from the ratio, so only the design-moved coordinates enter the weights.

The first batch is drawn with the design values spread uniformly over the bounds (its law
``h_0`` covers the whole design box, :func:`gearuq.design.variables.spread_pdf`); later batches
are drawn at designs where the weights have degenerated (their effective sample size fell
below the caller's threshold).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import xarray as xr

from gearuq.design.measures import Estimate, effective_size
from gearuq.design.variables import (
    DesignVariable,
    location_shift_pdf,
    spread_pdf,
)
from gearuq.space import ParameterSpace

__all__ = ["RunPool", "Batch"]


@dataclass
class Batch:
    """One batch of runs: where it was drawn (``None``: spread over the design box)."""

    design: np.ndarray | None
    x: np.ndarray  # (n, n_location_variables) design-moved inputs
    values: dict[str, np.ndarray]  # measure name -> per-sample value (g or output)
    seed: int
    reason: str = ""

    @property
    def size(self) -> int:
        """Number of runs."""
        return int(self.x.shape[0])


@dataclass
class RunPool:
    """Runs of all batches with their design-moved inputs and measure values.

    Parameters
    ----------
    space : ParameterSpace
        The base space (independent inputs; a copula would couple the moved inputs with the
        others and break the factorised ratio).
    variables : sequence of DesignVariable
        All of role ``"location"``.
    """

    space: ParameterSpace
    variables: Sequence[DesignVariable]
    batches: list[Batch] = field(default_factory=list)

    def __post_init__(self) -> None:
        if not self.space.independent:
            raise ValueError("likelihood-ratio reuse needs independent inputs (the space has a "
                             "copula); use strategy='crn' or 'surrogate'")
        bad = [v.name for v in self.variables if v.role != "location"]
        if bad:
            raise ValueError(f"likelihood-ratio reuse needs every design variable to shift an "
                             f"input law; {bad} set model parameters: use strategy='crn' or "
                             "'surrogate'")

    # ------------------------------------------------------------------ building
    def add(self, design: np.ndarray | None, ds: xr.Dataset, values: dict[str, np.ndarray],
            seed: int, reason: str) -> None:
        """Add a batch evaluated by the model (``ds`` holds its inputs)."""
        x = np.column_stack([np.asarray(ds[v.target].values, dtype=float)
                             for v in self.variables])
        self.batches.append(Batch(None if design is None else np.asarray(design, float),
                                  x, values, seed, reason))

    @property
    def n_runs(self) -> int:
        """Runs in the pool."""
        return sum(b.size for b in self.batches)

    def _x(self) -> np.ndarray:
        return np.vstack([b.x for b in self.batches])

    def values(self, name: str) -> np.ndarray:
        """A measure's per-sample values over all batches."""
        return np.concatenate([b.values[name] for b in self.batches])

    def _component_pdf(self, batch: Batch, x: np.ndarray) -> np.ndarray:
        if batch.design is None:
            cols = [spread_pdf(self.space, v, x[:, j]) for j, v in enumerate(self.variables)]
        else:
            cols = [location_shift_pdf(self.space, v, batch.design[j], x[:, j])
                    for j, v in enumerate(self.variables)]
        return np.prod(np.column_stack(cols), axis=1)

    def mixture_pdf(self) -> np.ndarray:
        """``h(x_i)`` of every run: the size-weighted mixture of the batches' laws."""
        x = self._x()
        n = self.n_runs
        return sum(b.size / n * self._component_pdf(b, x) for b in self.batches)

    # ------------------------------------------------------------------ estimating
    def weights(self, design: np.ndarray, h: np.ndarray | None = None) -> np.ndarray:
        """Likelihood ratios ``f_d(x_i) / h(x_i)`` of every run at ``design``."""
        x = self._x()
        f = np.prod(np.column_stack([location_shift_pdf(self.space, v, design[j], x[:, j])
                                     for j, v in enumerate(self.variables)]), axis=1)
        h = self.mixture_pdf() if h is None else h
        # h > 0 wherever a run was drawn; guard against round-off underflow in the far tails
        return np.divide(f, h, out=np.zeros_like(f), where=h > 0)

    def estimate(self, measure: Any, design: np.ndarray, confidence: float,
                 h: np.ndarray | None = None) -> Estimate:
        """A measure at ``design`` from every run, with its interval."""
        return self.estimate_all([measure], design, confidence, h)[measure.name]

    def estimate_all(self, measures: Sequence[Any], design: np.ndarray, confidence: float,
                     h: np.ndarray | None = None) -> dict[str, Estimate]:
        """Several measures at ``design`` from one set of weights."""
        w = self.weights(design, h)
        return {m.name: m.estimate(self.values(m.name), w, confidence) for m in measures}

    def ess(self, design: np.ndarray, h: np.ndarray | None = None) -> float:
        """Effective sample size of the weights at ``design``."""
        return effective_size(self.weights(design, h))
