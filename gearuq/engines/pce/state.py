"""The state of a chaos expansion: its fitting settings and what a fit learns."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from gearuq.engines.pce.basis import GERMS
from gearuq.engines.pce.regression import SOLVERS

__all__ = ["METHODS", "ChaosSettings", "ChaosFit", "OutputInfo", "check_order"]

#: Fitting methods.
METHODS = ("regression", "sparse", "quadrature")


@dataclass(frozen=True)
class ChaosSettings:
    """How a chaos expansion is fitted (the estimator's hyper-parameters).

    Attributes
    ----------
    order : int or "auto"
        Total degree, or ``"auto"``: the degree in ``1..max_order`` with the smallest
        leave-one-out error (``"regression"``) or corrected leave-one-out error
        (``"sparse"``), tried upwards and stopped after two degrees without improvement.
    method : {"regression", "sparse", "quadrature"}
        Least squares, sparse least squares (hybrid LAR/OMP), or spectral projection with
        quadrature weights.
    truncation : float
        Hyperbolic q-norm of the basis, in (0, 1].
    max_order : int
        Largest degree tried by ``order="auto"``.
    solver : {"lars", "omp"}
        Greedy path of the sparse method.
    compress : int or float, optional
        PCA across the non-sample dims of each output: a number of components or an energy
        fraction in (0, 1].
    germ : {"auto", "normal"}
        Legendre germ for independent uniform marginals (``"auto"``) or Hermite everywhere.
    """

    order: int | str = "auto"
    method: str = "regression"
    truncation: float = 1.0
    max_order: int = 6
    solver: str = "lars"
    compress: int | float | None = None
    germ: str = "auto"

    def __post_init__(self) -> None:
        object.__setattr__(self, "order", check_order(self.order))
        if self.method not in METHODS:
            raise ValueError(f"method: unknown {self.method!r}; valid: {', '.join(METHODS)}")
        if self.solver not in SOLVERS:
            raise ValueError(f"solver: unknown {self.solver!r}; valid: {', '.join(SOLVERS)}")
        if self.germ not in GERMS:
            raise ValueError(f"germ: unknown {self.germ!r}; valid: {', '.join(GERMS)}")
        if self.order == "auto" and self.method == "quadrature":
            raise ValueError("order='auto' needs method 'regression' or 'sparse' (a LOO error)")
        if isinstance(self.truncation, bool) or not isinstance(self.truncation, (int, float)) \
                or not 0 < float(self.truncation) <= 1:
            raise ValueError(f"truncation: q-norm must lie in (0, 1], got {self.truncation!r}")
        if isinstance(self.max_order, bool) or not isinstance(self.max_order, (int, np.integer)) \
                or self.max_order < 1:
            raise ValueError(f"max_order: expected an integer >= 1, got {self.max_order!r}")
        c = self.compress
        if c is not None and not ((isinstance(c, float) and 0.0 < c <= 1.0) or (
                isinstance(c, (int, np.integer)) and not isinstance(c, bool) and c >= 1)):
            raise ValueError(f"compress: expected a number of components (int >= 1) or an "
                             f"energy fraction in (0, 1], got {c!r}")

    @property
    def orders(self) -> list[int]:
        """Degrees to try."""
        return list(range(1, self.max_order + 1)) if self.order == "auto" else [int(self.order)]


def check_order(order: Any) -> int | str:
    """A non-negative integer degree or ``"auto"``, or a ValueError naming ``order``."""
    if isinstance(order, str):
        if order != "auto":
            raise ValueError(f"order: expected a non-negative integer or 'auto', got {order!r}")
        return order
    if isinstance(order, (bool, np.bool_)) or not isinstance(order, (int, np.integer)):
        raise ValueError(f"order: expected a non-negative integer or 'auto', got {order!r}")
    if order < 0:
        raise ValueError(f"order: polynomial degree must be >= 0, got {order}")
    return int(order)


@dataclass(frozen=True)
class OutputInfo:
    """Labels of one fitted output: non-sample dims, their shape and coordinates, units."""

    dims: tuple[str, ...]
    shape: tuple[int, ...]
    units: str = ""
    long_name: str = ""
    coords: dict[str, tuple] = field(default_factory=dict)

    @property
    def time_dependent(self) -> bool:
        """Whether the output has a ``time`` dim."""
        return "time" in self.dims


@dataclass
class ChaosFit:
    """The fitted state of a :class:`PolynomialChaos`.

    Attributes
    ----------
    indices : ndarray (P, d)
        Multi-indices of the kept basis terms.
    coefficients : dict
        Output -> coefficients ``(P, *output shape)``.
    outputs : dict
        Output -> :class:`OutputInfo`.
    t : ndarray
        Instants of time-dependent outputs (empty otherwise).
    order : int
        Degree of the expansion (the chosen one for ``order="auto"``).
    n_evaluations, n_failed : int
        Model runs used (including failed ones and hold-out runs) and runs excluded.
    loo_error, corrected_loo_error : dict
        Output -> relative leave-one-out error of the least-squares fit on the kept basis
        (mean square over variance, variance-weighted over columns), and the same times
        Chapelle's factor ``n/(n - P) (1 + tr((Psi^T Psi)^-1))``.
    loo_error_t : dict
        Output -> LOO error per column (instant).
    holdout_error : dict
        Output -> relative error on an independent validation set (when one was given).
    compression : dict
        Output -> ``{"components", "energy_lost", "relative_error"}`` when PCA was used.
    info : dict
        Design size, basis sizes, degrees tried, wall times, rule and seed of the design.
    source : dict
        ``model``, ``model_version``, ``time_units``, ``time_long_name`` and
        ``parameters`` (name -> {"units", "description"}) of the fitted model.
    """

    indices: np.ndarray
    coefficients: dict[str, np.ndarray]
    outputs: dict[str, OutputInfo]
    t: np.ndarray
    order: int
    n_evaluations: int
    n_failed: int
    loo_error: dict[str, float]
    loo_error_t: dict[str, np.ndarray]
    corrected_loo_error: dict[str, float]
    holdout_error: dict[str, float] = field(default_factory=dict)
    compression: dict[str, dict[str, float]] = field(default_factory=dict)
    info: dict[str, Any] = field(default_factory=dict)
    source: dict[str, Any] = field(default_factory=dict)
