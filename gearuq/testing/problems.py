"""Analytic UQ test problems with their exact answers.

Each problem comes as three pieces that share no code with the engines they test:

* the vectorised function itself (``ishigami(x1, x2, x3)``), module level so that models built
  on it pickle;
* its exact answers, as a function of the problem constants (``ishigami_exact(a, b)``) and,
  for the standard constants, as module constants (``ISHIGAMI_S1``);
* a ready model and space (``ishigami_model()``, ``ishigami_space()``), and
  :func:`benchmark_problems` with every pair by name.

================  ==========================  ===================================================
problem           inputs                      exact answers
================  ==========================  ===================================================
Ishigami          x1..x3 ~ U[-pi, pi]         mean, variance, first-order, second-order and
                                              total Sobol' indices (a = 7, b = 0.1 by default)
Sobol' G          x1..xd ~ U[0, 1]            mean 1, variance, first-order, second-order and
                                              total indices for any a_i >= 0
linear            x1..xn ~ N(0, 1)            g = beta - sum(x)/sqrt(n): Pf = Phi(-beta),
                                              reliability index beta
four-branch       x1, x2 ~ N(0, 1)            series system with k = 6/sqrt(2):
                                              Pf = 4.45733e-3 (quadrature)
================  ==========================  ===================================================

Derivations
-----------
Ishigami, ``y = sin x1 + a sin^2 x2 + b x3^4 sin x1`` with ``x_i ~ U[-pi, pi]``: with
``E[sin^2] = 1/2``, ``E[sin^4] = 3/8``, ``E[x^4] = pi^4/5`` and ``E[x^8] = pi^8/9``,

    mean = a/2,
    V1 = (1 + b pi^4/5)^2 / 2,  V2 = a^2/8,  V3 = 0,
    V13 = b^2 pi^8 (1/18 - 1/50) = 8 b^2 pi^8 / 225,  V12 = V23 = V123 = 0,
    V = a^2/8 + b pi^4/5 + b^2 pi^8/18 + 1/2.

Sobol' G, ``y = prod_i (|4 x_i - 2| + a_i)/(1 + a_i)``: each factor has mean 1 and variance
``V_i = 1/(3 (1 + a_i)^2)``; the Sobol' decomposition is the product expansion, so
``V = prod(1 + V_i) - 1``, ``S_i = V_i / V``, ``S_ij = V_i V_j / V`` and
``ST_i = V_i prod_{j != i}(1 + V_j) / V``.

Four-branch, in rotated coordinates ``u = (x1 + x2)/sqrt 2``, ``v = (x1 - x2)/sqrt 2`` (again
independent standard normals): the first two branches are ``3 + 0.2 v^2 -+ u``, the last two
``sqrt(2) v + k`` and ``k - sqrt(2) v``. Failure is ``|v| >= k/sqrt 2`` or
``|u| >= 3 + 0.2 v^2``, so

    Pf = 2 Phi(-k/sqrt 2) + int_{-k/sqrt 2}^{k/sqrt 2} phi(v) 2 Phi(-(3 + 0.2 v^2)) dv,

a smooth one-dimensional integral that adaptive quadrature gives to ~1e-17 absolute
(:func:`four_branch_pf`); with ``k = 6/sqrt 2``, ``Pf = 4.457331e-3``, which the commonly
quoted reference 4.4573e-3 matches to its printed digits (the tests also check it against
10^7 Monte Carlo draws).
"""

from __future__ import annotations

import functools
import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
from scipy import integrate, stats

if TYPE_CHECKING:  # the model and space classes are imported inside the factories
    from gearuq.model import FunctionModel
    from gearuq.space import ParameterSpace

__all__ = [
    "SobolAnswer",
    "ishigami", "ishigami_exact", "ishigami_model", "ishigami_space",
    "ISHIGAMI_A", "ISHIGAMI_B", "ISHIGAMI_MEAN", "ISHIGAMI_VARIANCE", "ISHIGAMI_S1",
    "ISHIGAMI_ST",
    "g_function", "g_function_exact", "g_function_model", "g_function_space", "G_FUNCTION_A",
    "linear_limit_state", "linear_limit_state_pf", "linear_limit_state_model",
    "standard_normal_space", "LINEAR_BETA", "LINEAR_PF",
    "four_branch", "four_branch_pf", "four_branch_model", "FOUR_BRANCH_K", "FOUR_BRANCH_PF",
    "benchmark_problems",
]


@dataclass(frozen=True)
class SobolAnswer:
    """Exact moments and Sobol' indices of an analytic function.

    Attributes
    ----------
    mean, variance : float
        Of the output.
    S1, ST : ndarray, shape (d,)
        First-order and total indices, in input order.
    S2 : ndarray, shape (d, d)
        Second-order (closed pairwise interaction) indices ``S_ij`` for ``i != j``,
        symmetric, NaN on the diagonal.
    """

    mean: float
    variance: float
    S1: np.ndarray
    ST: np.ndarray
    S2: np.ndarray


# =========================================================================== Ishigami
#: Standard Ishigami constants (Ishigami and Homma 1990; Sobol' and Levitan 1999).
ISHIGAMI_A = 7.0
ISHIGAMI_B = 0.1


def ishigami(x1: Any, x2: Any, x3: Any, a: float = ISHIGAMI_A, b: float = ISHIGAMI_B
             ) -> np.ndarray:
    """Ishigami function ``sin x1 + a sin^2 x2 + b x3^4 sin x1`` (inputs U[-pi, pi])."""
    x1, x2, x3 = (np.asarray(x, dtype=float) for x in (x1, x2, x3))
    return np.sin(x1) + a * np.sin(x2) ** 2 + b * x3**4 * np.sin(x1)


def ishigami_exact(a: float = ISHIGAMI_A, b: float = ISHIGAMI_B) -> SobolAnswer:
    """Exact mean, variance and Sobol' indices of the Ishigami function (see module notes)."""
    pi4 = math.pi**4
    pi8 = math.pi**8
    v1 = 0.5 * (1.0 + b * pi4 / 5.0) ** 2
    v2 = a * a / 8.0
    v13 = 8.0 * b * b * pi8 / 225.0
    variance = a * a / 8.0 + b * pi4 / 5.0 + b * b * pi8 / 18.0 + 0.5
    s2 = np.zeros((3, 3))
    s2[0, 2] = s2[2, 0] = v13 / variance
    np.fill_diagonal(s2, np.nan)
    return SobolAnswer(
        mean=a / 2.0, variance=variance,
        S1=np.array([v1, v2, 0.0]) / variance,
        ST=np.array([v1 + v13, v2, v13]) / variance,
        S2=s2,
    )


_ISHIGAMI = ishigami_exact()
#: Exact answers for a = 7, b = 0.1.
ISHIGAMI_MEAN: float = _ISHIGAMI.mean
ISHIGAMI_VARIANCE: float = _ISHIGAMI.variance
ISHIGAMI_S1: np.ndarray = _ISHIGAMI.S1
ISHIGAMI_ST: np.ndarray = _ISHIGAMI.ST


def ishigami_model(a: float = ISHIGAMI_A, b: float = ISHIGAMI_B) -> FunctionModel:
    """The Ishigami function as a model with inputs x1, x2, x3 and output y."""
    from gearuq.model import FunctionModel

    return FunctionModel(functools.partial(ishigami, a=a, b=b), ["x1", "x2", "x3"], ["y"],
                         name="ishigami", description=f"Ishigami function (a={a:g}, b={b:g})")


def ishigami_space() -> ParameterSpace:
    """Independent U[-pi, pi] inputs x1, x2, x3."""
    from gearuq.space import ParameterSpace

    return ParameterSpace.uniform(**{f"x{i}": (-math.pi, math.pi) for i in (1, 2, 3)})


# =========================================================================== Sobol' G
#: A common eight-dimensional choice of G-function coefficients (the surrogate benchmark's).
G_FUNCTION_A: tuple[float, ...] = (0.0, 1.0, 4.5, 9.0, 99.0, 99.0, 99.0, 99.0)


def _check_g_coefficients(a: Sequence[float]) -> np.ndarray:
    a = np.asarray(a, dtype=float)
    if a.ndim != 1 or a.size == 0 or not np.all(np.isfinite(a)) or np.any(a < 0):
        raise ValueError(f"a: expected a non-empty 1-D sequence of finite values >= 0, got {a}")
    return a


def g_function(*x: Any, a: Sequence[float] = G_FUNCTION_A) -> np.ndarray:
    """Sobol' G-function ``prod_i (|4 x_i - 2| + a_i)/(1 + a_i)`` of ``len(a)`` inputs."""
    a = _check_g_coefficients(a)
    if len(x) != a.size:
        raise ValueError(f"g_function: got {len(x)} inputs for {a.size} coefficients a")
    y = np.ones(np.broadcast(*x).shape) if x else np.ones(())
    for xi, ai in zip(x, a, strict=True):
        y = y * (np.abs(4.0 * np.asarray(xi, dtype=float) - 2.0) + ai) / (1.0 + ai)
    return y


def g_function_exact(a: Sequence[float] = G_FUNCTION_A) -> SobolAnswer:
    """Exact mean (1), variance and Sobol' indices of the G-function (see module notes)."""
    a = _check_g_coefficients(a)
    partial = 1.0 / (3.0 * (1.0 + a) ** 2)
    variance = float(np.prod(1.0 + partial) - 1.0)
    others = np.array([np.prod(np.delete(1.0 + partial, i)) for i in range(a.size)])
    s2 = np.outer(partial, partial) / variance
    np.fill_diagonal(s2, np.nan)
    return SobolAnswer(mean=1.0, variance=variance, S1=partial / variance,
                       ST=partial * others / variance, S2=s2)


def _g_function_named(*, a: tuple[float, ...], **x: np.ndarray) -> np.ndarray:
    return g_function(*(x[f"x{i + 1}"] for i in range(len(a))), a=a)


def g_function_model(a: Sequence[float] = G_FUNCTION_A) -> FunctionModel:
    """The G-function as a model with inputs x1..xd (d = len(a)) and output y."""
    from gearuq.model import FunctionModel

    a = tuple(float(v) for v in _check_g_coefficients(a))
    return FunctionModel(functools.partial(_g_function_named, a=a),
                         [f"x{i + 1}" for i in range(len(a))], ["y"], name="g_function",
                         description=f"Sobol' G-function, a = {list(a)}")


def g_function_space(dim: int = len(G_FUNCTION_A)) -> ParameterSpace:
    """Independent U[0, 1] inputs x1..x{dim}."""
    from gearuq.space import ParameterSpace

    return ParameterSpace.uniform(**{f"x{i + 1}": (0.0, 1.0) for i in range(int(dim))})


# =========================================================================== linear
#: Reliability index of the standard linear limit state.
LINEAR_BETA = 3.0
#: Its failure probability Phi(-3).
LINEAR_PF = float(stats.norm.cdf(-LINEAR_BETA))


def linear_limit_state(*x: Any, beta: float = LINEAR_BETA) -> np.ndarray:
    """Linear limit state ``beta - sum(x_i)/sqrt(n)`` in standard normals (fails at g <= 0)."""
    if not x:
        raise ValueError("linear_limit_state: give at least one input")
    total = sum(np.asarray(xi, dtype=float) for xi in x)
    return beta - total / math.sqrt(len(x))


def linear_limit_state_pf(beta: float = LINEAR_BETA) -> float:
    """Exact ``Pf = Phi(-beta)`` (the sum of n standard normals over sqrt(n) is standard)."""
    return float(stats.norm.cdf(-beta))


def _linear_named(*, dim: int, beta: float, **x: np.ndarray) -> np.ndarray:
    return linear_limit_state(*(x[f"x{i + 1}"] for i in range(dim)), beta=beta)


def linear_limit_state_model(dim: int = 2, beta: float = LINEAR_BETA) -> FunctionModel:
    """The linear limit state as a model with inputs x1..x{dim} and output g."""
    from gearuq.model import FunctionModel

    if int(dim) != dim or dim < 1:
        raise ValueError(f"dim: expected an integer >= 1, got {dim!r}")
    return FunctionModel(functools.partial(_linear_named, dim=int(dim), beta=float(beta)),
                         [f"x{i + 1}" for i in range(int(dim))], ["g"],
                         name="linear_limit_state",
                         description=f"g = {beta:g} - sum(x)/sqrt({int(dim)}), failure g <= 0")


def standard_normal_space(dim: int = 2) -> ParameterSpace:
    """Independent standard normal inputs x1..x{dim}."""
    from gearuq.space import ParameterSpace

    return ParameterSpace.normal(**{f"x{i + 1}": (0.0, 1.0) for i in range(int(dim))})


# =========================================================================== four-branch
#: Branch offset of the standard four-branch series system.
FOUR_BRANCH_K = 6.0 / math.sqrt(2.0)


def four_branch(x1: Any, x2: Any, k: float = FOUR_BRANCH_K) -> np.ndarray:
    """Four-branch series system limit state (failure ``g <= 0``), inputs standard normal.

    ``g = min{3 + 0.1 (x1 - x2)^2 -+ (x1 + x2)/sqrt 2, (x1 - x2) + k, (x2 - x1) + k}``.
    """
    x1 = np.asarray(x1, dtype=float)
    x2 = np.asarray(x2, dtype=float)
    spread = 3.0 + 0.1 * (x1 - x2) ** 2
    along = (x1 + x2) / math.sqrt(2.0)
    return np.minimum.reduce([spread - along, spread + along, (x1 - x2) + k, (x2 - x1) + k])


def four_branch_pf(k: float = FOUR_BRANCH_K) -> float:
    """Failure probability of :func:`four_branch` by one-dimensional adaptive quadrature.

    See the module notes for the reduction; absolute accuracy ~1e-17.
    """
    if not k > 0:
        raise ValueError(f"k: expected a positive branch offset, got {k!r}")
    edge = k / math.sqrt(2.0)

    def inner(v: float) -> float:
        return stats.norm.pdf(v) * 2.0 * stats.norm.cdf(-(3.0 + 0.2 * v * v))

    band, _ = integrate.quad(inner, -edge, edge, epsabs=1e-16, epsrel=1e-12)
    return float(2.0 * stats.norm.cdf(-edge) + band)


#: Exact failure probability for k = 6/sqrt(2) (4.457331e-3).
FOUR_BRANCH_PF = four_branch_pf()


def four_branch_model(k: float = FOUR_BRANCH_K) -> FunctionModel:
    """The four-branch system as a model with inputs x1, x2 and output g."""
    from gearuq.model import FunctionModel

    return FunctionModel(functools.partial(four_branch, k=float(k)), ["x1", "x2"], ["g"],
                         name="four_branch",
                         description=f"four-branch series system (k={k:.6g}), failure g <= 0")


# =========================================================================== all of them
def benchmark_problems() -> dict[str, tuple[FunctionModel, ParameterSpace]]:
    """The standard problems by name: ``(model, space)`` with the default constants.

    Keys: ``"ishigami"``, ``"g_function"``, ``"linear"`` (two inputs, beta = 3),
    ``"four_branch"``.
    """
    return {
        "ishigami": (ishigami_model(), ishigami_space()),
        "g_function": (g_function_model(), g_function_space()),
        "linear": (linear_limit_state_model(), standard_normal_space(2)),
        "four_branch": (four_branch_model(), standard_normal_space(2)),
    }
