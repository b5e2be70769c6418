"""Analytic design benchmarks with published optima, and the strategies measured on them.

Youn and Choi, "An investigation of nonlinearity of reliability-based design optimization
approaches", Journal of Mechanical Design 126(3) (2004) 403-411, two variables, three
constraints: minimise ``d1 + d2`` subject to ``P(g_j(X) <= 0) <= Phi(-2)``,
``X_i ~ N(d_i, 0.6)``, ``0 <= d_i <= 10``, with ``g1 = X1^2 X2 / 20 - 1``,
``g2 = (X1 + X2 - 5)^2 / 30 + (X1 - X2 - 12)^2 / 120 - 1`` and
``g3 = 80 / (X1^2 + 8 X2 + 5) - 1``. Published optimum (FORM-based):
``d* = (3.660, 3.609)``, ``f = 7.269``, ``beta = (2.0, 2.0, 4.436)``.

Kuschel and Rackwitz, "Two basic problems in reliability-based structural optimization",
Mathematical Methods of Operations Research 46(3) (1997) 309-333, the short column: minimise
the section ``b h`` (``5 <= b <= 15``, ``15 <= h <= 25``) subject to
``P(g <= 0) <= 0.00621`` (``beta = 2.5``), ``g = 1 - 4 M / (b h^2 Y) - P^2 / (b h Y)^2``,
``P ~ N(500, 100)``, ``M ~ N(2000, 400)`` correlated 0.5, ``Y`` lognormal of mean 5 and
standard deviation 0.5; ``b`` and ``h`` are deterministic (model parameters, not shifted
laws). Published optimum ``(b, h) = (8.668, 25.0)``, ``f = 216.7`` (as the test suite of the
Dakota toolkit quotes it beside its own reproduction).

Run ``python -m gearuq.design.benchmarks [n_samples] [seeds]`` for the table of
docs/design.md: each strategy's optimum, its distance to the exact-probability optimum and the
model runs it spent.
"""

from __future__ import annotations

import sys
import time
from typing import Any

import numpy as np
from scipy import stats

from gearuq.design.measures import Constraint, Probability
from gearuq.design.optimize import optimize_design
from gearuq.design.problem import DesignProblem
from gearuq.design.variables import DesignVariable
from gearuq.failure.modes import LimitState
from gearuq.model import FunctionModel
from gearuq.space import ParameterSpace

__all__ = ["youn_choi_problem", "YOUN_CHOI_PUBLISHED", "YOUN_CHOI_EXACT", "compare_strategies",
           "short_column_problem", "SHORT_COLUMN_PUBLISHED"]

#: The published optimum (Youn and Choi 2004, beta_t = 2, standard deviation 0.6).
YOUN_CHOI_PUBLISHED = {"d": (3.660, 3.609), "f": 7.269, "beta": (2.0, 2.0, 4.436)}
#: The optimum with exact probabilities (one-dimensional quadrature of P(g1 <= 0) and
#: P(g2 <= 0), SLSQP to 1e-12; computed for this benchmark): the FORM optimum's probabilities
#: are 0.02299 and 0.02320 instead of Phi(-2) = 0.02275.
YOUN_CHOI_EXACT = {"d": (3.66064, 3.61438), "f": 7.27502}


def _youn_choi(X1: np.ndarray, X2: np.ndarray) -> dict[str, np.ndarray]:  # noqa: N803
    return {"g1": X1**2 * X2 / 20 - 1,
            "g2": (X1 + X2 - 5) ** 2 / 30 + (X1 - X2 - 12) ** 2 / 120 - 1,
            "g3": 80 / (X1**2 + 8 * X2 + 5) - 1}


def youn_choi_problem(beta_target: float = 2.0, sigma: float = 0.6) -> DesignProblem:
    """The problem of Youn and Choi (2004) (design box 2.5-7.5, which holds the optimum)."""
    model = FunctionModel(_youn_choi, ["X1", "X2"], ["g1", "g2", "g3"], name="youn_choi",
                          description="Youn and Choi (2004): two variables, three constraints")
    space = ParameterSpace.normal(X1=(5.0, sigma), X2=(5.0, sigma))
    variables = [DesignVariable("d1", 2.5, 7.5, target="X1"),
                 DesignVariable("d2", 2.5, 7.5, target="X2")]
    cap = float(stats.norm.cdf(-beta_target))
    cons = [Constraint(Probability(LimitState.output(f"g{i}"), name=f"pf{i}"), upper=cap)
            for i in (1, 2, 3)]
    return DesignProblem(model, space, variables, _cost, cons)


def _cost(d: np.ndarray) -> float:
    return float(d[0] + d[1])


#: The published optimum of the short column (Kuschel and Rackwitz 1997, beta_t = 2.5).
SHORT_COLUMN_PUBLISHED = {"d": (8.668, 25.0), "f": 216.7, "pf_cap": 0.00621}


def _short_column(b: np.ndarray, h: np.ndarray, P: np.ndarray, M: np.ndarray,  # noqa: N803
                  Y: np.ndarray) -> dict[str, np.ndarray]:  # noqa: N803
    return {"g": 1.0 - 4.0 * M / (b * h**2 * Y) - (P / (b * h * Y)) ** 2}


def short_column_problem(pf_cap: float = SHORT_COLUMN_PUBLISHED["pf_cap"]) -> DesignProblem:
    """The short column of Kuschel and Rackwitz (1997): minimise ``b h`` under a cap on
    ``P(g <= 0)``; ``b`` and ``h`` set model parameters (``role="parameter"``)."""
    model = FunctionModel(
        _short_column,
        [("b", "1", 10.0, 1.0, 30.0, "section width"), ("h", "1", 20.0, 1.0, 50.0,
                                                         "section depth"),
         ("P", "1", 500.0, -np.inf, np.inf, "axial force"),
         ("M", "1", 2000.0, -np.inf, np.inf, "bending moment"),
         ("Y", "1", 5.0, 0.0, np.inf, "yield stress")],
        ["g"], name="short_column",
        description="Kuschel and Rackwitz (1997): short column under bending and axial load")
    space = ParameterSpace(
        {"P": {"dist": "normal", "mean": 500.0, "std": 100.0},
         "M": {"dist": "normal", "mean": 2000.0, "std": 400.0},
         "Y": {"dist": "lognormal", "mean": 5.0, "std": 0.5}},
        correlation={("P", "M"): 0.5})
    variables = [DesignVariable("b", 5.0, 15.0, role="parameter"),
                 DesignVariable("h", 15.0, 25.0, role="parameter")]
    cons = [Constraint(Probability(LimitState.output("g"), name="pf"), upper=pf_cap)]
    return DesignProblem(model, space, variables, _area, cons)


def _area(d: np.ndarray) -> float:
    return float(d[0] * d[1])


def compare_strategies(n_samples: int = 20_000, seeds: Any = (0, 1, 2),
                       strategies: Any = ("reweight", "surrogate", "crn", "nested")
                       ) -> list[dict[str, Any]]:
    """Each strategy on Youn and Choi's problem: optimum, error, runs, wall time per seed."""
    rows = []
    exact = np.array(YOUN_CHOI_EXACT["d"])
    for strategy in strategies:
        for seed in seeds:
            t0 = time.perf_counter()
            r = optimize_design(youn_choi_problem(), strategy=strategy, n_samples=n_samples,
                                rng=seed, confirm_samples=0, grid=11, executor="serial")
            d = np.array([float(r["design_d1"]), float(r["design_d2"])])
            rows.append({"strategy": strategy, "seed": seed, "d1": d[0], "d2": d[1],
                         "error": float(np.max(np.abs(d - exact))),
                         "runs": int(r["n_model_runs_search"]),
                         "wall": time.perf_counter() - t0})
    return rows


def main(argv: list[str] | None = None) -> int:
    """Print the comparison table."""
    argv = sys.argv[1:] if argv is None else argv
    n = int(argv[0]) if argv else 20_000
    seeds = range(int(argv[1])) if len(argv) > 1 else range(3)
    print("strategy   seed  d1      d2      max|d - d_exact|  runs      wall [s]")
    for row in compare_strategies(n, tuple(seeds)):
        print(f"{row['strategy']:<10} {row['seed']:>4}  {row['d1']:.4f}  {row['d2']:.4f}  "
              f"{row['error']:.4f}            {row['runs']:<9} {row['wall']:.1f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
