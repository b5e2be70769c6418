"""Reliability benchmark problems with reference failure probabilities.

Each problem is a vectorised function (module level, so models built on it pickle), a ready
:class:`~gearuq.model.FunctionModel` factory, its :class:`~gearuq.space.ParameterSpace` and a
reference answer computed **without** any gearuq engine (closed form or one-dimensional
quadrature), or a published value where no closed form exists.

=====================  ================================  =======================================
problem                inputs                            reference
=====================  ================================  =======================================
linear, 100-D          x1..x100 ~ N(0, 1)                g = 3.5 sqrt(100) - sum(x):
                                                         beta = 3.5, Pf = Phi(-3.5) = 2.326e-4
offset                 x1, x2 ~ N(0, 1)                  g = 4.5 - x1: Pf = Phi(-4.5) = 3.398e-6
resistance-load        R lognormal (mean 10, std 1),     g = R - S: Pf by 1-D quadrature
                       S ~ N(5, 1.5), optional copula    (2.349e-3 independent)
oscillator             m, c1, c2, r, F1, t1 normal       g = 3r - |2F1/(m w0^2) sin(w0 t1/2)|:
                       (Echard et al. 2011)              Pf = 2.86e-2 (2e7 MC: 2.858e-2 +- 4e-5)
parabola, 2 design     u1, u2 ~ N(0, 1)                  g = 5 - u2 - 0.5 (u1 - 0.1)^2 (Der
points                                                   Kiureghian and Dakessian 1998): Pf by
                                                         1-D quadrature (3.0e-3)
four-branch, by        x1, x2 ~ N(0, 1)                  outputs g1..g4 of the four branches
branch                                                   (series system): Pf = 4.4573e-3
jump                   x1, x2 ~ N(0, 1)                  g = 3.5 - x1 - 1.5 [x2 > 1]: a
                                                         discontinuous response, Pf closed form
two mechanisms         x1, x2 ~ N(0, 1)                  g = min(3 - x1, 3.2 - x2): Pf = 1 -
                                                         Phi(3) Phi(3.2) = 2.036e-3; cheap model
                                                         g = 2.9 - x1 sees one mechanism
random-phase process   X1, X2 ~ N(0, 1)                  y(t) = X1 sin(w t) + X2 cos(w t):
                                                         stationary Gaussian, exact out-crossing
                                                         rate and exact first passage
Gaussian process       A_k, B_k ~ N(0, 1)                y(t) = sum_k s_k (A_k cos w_k t + B_k
(K harmonics)                                            sin w_k t): spectral moments m0, m2
modes in units         u1, u2 ~ N(0, 1)                  min of two linear margins scaled by
                                                         factors (units): Pf by 1-D quadrature
ridge                  x1..x6 ~ N(0, 1)                  a thin wedge along x1 = x2 (chains do
                                                         not mix): Pf by 1-D quadrature
=====================  ================================  =======================================
"""

from __future__ import annotations

import functools
import math
from typing import TYPE_CHECKING, Any

import numpy as np
from scipy import integrate, stats

from gearuq.testing.problems import FOUR_BRANCH_K, FOUR_BRANCH_PF, standard_normal_space

if TYPE_CHECKING:
    from gearuq.model import FunctionModel
    from gearuq.space import ParameterSpace

__all__ = [
    "linear_sum", "linear_sum_model", "LINEAR_100D_BETA", "LINEAR_100D_PF",
    "offset", "offset_model", "offset_space", "OFFSET_PF",
    "resistance_load", "resistance_load_model", "resistance_load_space", "resistance_load_pf",
    "oscillator", "oscillator_model", "oscillator_space", "OSCILLATOR_PF",
    "OSCILLATOR_PF_MC", "OSCILLATOR_PF_MC_SE",
    "parabola", "parabola_model", "parabola_pf", "PARABOLA_PF",
    "four_branch_components", "four_branch_components_model", "FOUR_BRANCH_PF",
    "jump", "jump_model", "JUMP_PF",
    "exponential_sum_model", "exponential_sum_space", "EXPONENTIAL_SUM_LEVEL",
    "helical_pair_problem", "HELICAL_PAIR_LEVEL", "HELICAL_PAIR_PF", "HELICAL_PAIR_PF_INTERVAL",
    "HELICAL_PAIR_T", "HELICAL_PAIR_GRID_LEVEL", "HELICAL_PAIR_GRID_PF",
    "HELICAL_PAIR_GRID_PF_INTERVAL", "geared_rotor_problem", "geared_rotor_reference",
    "geared_rotor_space", "geared_rotor_model", "GEARED_ROTOR_OPTIONS",
    "GEARED_ROTOR_LOW_FIDELITY_OPTIONS", "GEARED_ROTOR_LEVEL", "GEARED_ROTOR_PF",
    "GEARED_ROTOR_PF_INTERVAL", "geared_rotor_mfis_settings", "geared_rotor_line_reference",
    "GEARED_ROTOR_LINE_SETTINGS", "GEARED_ROTOR_LINE_PF", "GEARED_ROTOR_LINE_PF_INTERVAL",
    "EXPONENTIAL_SUM_PF", "nan_tail_model", "NAN_TAIL_PF",
    "random_phase", "random_phase_model", "random_phase_rate", "random_phase_first_passage",
    "gaussian_process", "gaussian_process_model", "gaussian_process_moments",
    "rice_rate_gaussian", "reliability_problems",
    "unit_modes_model", "unit_modes_pf", "unit_modes_limit_state", "UNIT_MODES_BETAS",
    "UNIT_MODES_ANGLE", "HELICAL_PAIR_DEEP_LEVEL", "HELICAL_PAIR_DEEP_PF", "ridge_model",
    "ridge_pf", "RIDGE_K", "RIDGE_B",
    "two_mechanisms", "one_mechanism", "two_mechanisms_model", "one_mechanism_model",
    "TWO_MECHANISMS_BETAS", "TWO_MECHANISMS_PF",
]


# =========================================================================== linear 100-D
LINEAR_100D_BETA = 3.5
#: Phi(-3.5).
LINEAR_100D_PF = float(stats.norm.sf(LINEAR_100D_BETA))


def linear_sum(*x: Any, beta: float = LINEAR_100D_BETA) -> np.ndarray:
    """``g = beta sqrt(n) - sum(x)`` (failure ``g <= 0``; exact ``Pf = Phi(-beta)``)."""
    return beta * math.sqrt(len(x)) - sum(np.asarray(v, dtype=float) for v in x)


def _linear_named(*, dim: int, beta: float, **x: np.ndarray) -> np.ndarray:
    return linear_sum(*(x[f"x{i + 1}"] for i in range(dim)), beta=beta)


def linear_sum_model(dim: int = 100, beta: float = LINEAR_100D_BETA) -> FunctionModel:
    """The linear limit state in ``dim`` standard normal inputs, output ``g``."""
    from gearuq.model import FunctionModel

    return FunctionModel(functools.partial(_linear_named, dim=int(dim), beta=float(beta)),
                         [f"x{i + 1}" for i in range(int(dim))], ["g"], name=f"linear_{dim}d",
                         description=f"g = {beta:g} sqrt({dim}) - sum(x)")


# =========================================================================== offset
#: Phi(-4.5) = 3.398e-6.
OFFSET_PF = float(stats.norm.sf(4.5))


def offset(x1: Any, x2: Any) -> np.ndarray:
    """``g = 4.5 - x1`` (``x2`` is inert; it makes the problem two-dimensional)."""
    return 4.5 - np.asarray(x1, dtype=float) + 0.0 * np.asarray(x2, dtype=float)


def offset_model() -> FunctionModel:
    """``g = 4.5 - x1`` as a model with inputs x1, x2."""
    from gearuq.model import FunctionModel

    return FunctionModel(offset, ["x1", "x2"], ["g"], name="offset", description="g = 4.5 - x1")


def offset_space() -> ParameterSpace:
    """x1, x2 independent standard normal."""
    return standard_normal_space(2)


# =========================================================================== resistance-load
R_MEAN, R_STD = 10.0, 1.0
S_MEAN, S_STD = 5.0, 1.5


def resistance_load(R: Any, S: Any) -> np.ndarray:  # noqa: N803 - the usual symbols
    """``g = R - S``."""
    return np.asarray(R, dtype=float) - np.asarray(S, dtype=float)


def resistance_load_model() -> FunctionModel:
    """``g = R - S`` as a model."""
    from gearuq.model import FunctionModel, Parameter

    return FunctionModel(resistance_load, [Parameter("R", "1", R_MEAN, 0.0),
                                           Parameter("S", "1", S_MEAN)], ["g"],
                         name="resistance_load", description="g = R - S")


def resistance_load_space(rho: float = 0.0) -> ParameterSpace:
    """R lognormal (mean 10, std 1), S normal (5, 1.5); ``rho`` = correlation of the
    underlying normals (Gaussian copula)."""
    from gearuq.space import ParameterSpace

    corr = None if rho == 0 else {("R", "S"): float(rho)}
    return ParameterSpace({"R": {"dist": "lognormal", "mean": R_MEAN, "std": R_STD},
                           "S": {"dist": "normal", "mean": S_MEAN, "std": S_STD}}, corr)


def resistance_load_pf(rho: float = 0.0) -> float:
    """``P(R <= S)`` by one-dimensional quadrature over the standard normal of S.

    Given ``z_S``, ``z_R ~ N(rho z_S, 1 - rho^2)`` and ``R <= s`` iff
    ``z_R <= Phi^-1(F_R(s))``, so ``Pf = int phi(z) Phi((Phi^-1(F_R(s(z))) - rho z) /
    sqrt(1 - rho^2)) dz`` with ``s(z) = 5 + 1.5 z``.
    """
    sigma = math.sqrt(math.log(1 + (R_STD / R_MEAN) ** 2))
    mu = math.log(R_MEAN) - sigma**2 / 2

    def integrand(z: float) -> float:
        s = S_MEAN + S_STD * z
        if s <= 0:
            return 0.0
        z_r = (math.log(s) - mu) / sigma  # Phi^-1(F_R(s)) for a lognormal
        return stats.norm.pdf(z) * stats.norm.cdf((z_r - rho * z) / math.sqrt(1 - rho**2))

    val, _ = integrate.quad(integrand, -12, 12, epsabs=1e-15, epsrel=1e-11, limit=400,
                            points=[0.0, 2.0, 3.0, 4.0])
    return float(val)


# =========================================================================== oscillator
#: Published reference (Echard et al. 2011; Schueremans and Van Gemert 2005).
OSCILLATOR_PF = 2.86e-2
#: 2e7 Monte Carlo draws (the issue's reference) and its standard error.
OSCILLATOR_PF_MC = 2.858e-2
OSCILLATOR_PF_MC_SE = 4e-5
_OSC = {"m": (1.0, 0.05), "c1": (1.0, 0.1), "c2": (0.1, 0.01), "r": (0.5, 0.05),
        "F1": (1.0, 0.2), "t1": (1.0, 0.2)}


def oscillator(m: Any, c1: Any, c2: Any, r: Any, F1: Any, t1: Any) -> np.ndarray:  # noqa: N803
    """Non-linear undamped oscillator: ``g = 3r - |2 F1/(m w0^2) sin(w0 t1 / 2)|``."""
    w0 = np.sqrt((c1 + c2) / m)
    return 3.0 * r - np.abs(2.0 * F1 / (m * w0**2) * np.sin(w0 * t1 / 2.0))


def oscillator_model() -> FunctionModel:
    """The oscillator as a model (m, c1, c2 positive)."""
    from gearuq.model import FunctionModel, Parameter

    params = [Parameter(k, "1", mu, 0.0 if k in ("m", "c1", "c2") else -math.inf)
              for k, (mu, _) in _OSC.items()]
    return FunctionModel(oscillator, params, ["g"], name="oscillator",
                         description="non-linear undamped oscillator (Echard et al. 2011)")


def oscillator_space() -> ParameterSpace:
    """Six independent normals (Echard et al. 2011, Table 4)."""
    from gearuq.space import ParameterSpace

    return ParameterSpace.normal(**_OSC)


# =========================================================================== parabola
PARABOLA_B, PARABOLA_KAPPA, PARABOLA_E = 5.0, 0.5, 0.1


def parabola(u1: Any, u2: Any) -> np.ndarray:
    """``g = b - u2 - kappa (u1 - e)^2`` with two design points (b=5, kappa=0.5, e=0.1)."""
    u1 = np.asarray(u1, dtype=float)
    return PARABOLA_B - np.asarray(u2, dtype=float) - PARABOLA_KAPPA * (u1 - PARABOLA_E) ** 2


def parabola_model() -> FunctionModel:
    """The parabolic limit state as a model with inputs u1, u2."""
    from gearuq.model import FunctionModel

    return FunctionModel(parabola, ["u1", "u2"], ["g"], name="parabola",
                         description="g = 5 - u2 - 0.5 (u1 - 0.1)^2 (two design points)")


def parabola_pf() -> float:
    """``int phi(u1) Phi(kappa (u1 - e)^2 - b) du1``."""
    def f(u: float) -> float:
        return stats.norm.pdf(u) * stats.norm.cdf(PARABOLA_KAPPA * (u - PARABOLA_E) ** 2
                                                 - PARABOLA_B)

    val, _ = integrate.quad(f, -15, 15, epsabs=1e-15, epsrel=1e-12, limit=400,
                            points=[-3.0, 0.1, 3.0])
    return float(val)


PARABOLA_PF = parabola_pf()


# =========================================================================== four-branch
def four_branch_components(x1: Any, x2: Any, k: float = FOUR_BRANCH_K
                           ) -> tuple[np.ndarray, ...]:
    """The four branches ``(g1, g2, g3, g4)`` of the four-branch series system."""
    x1 = np.asarray(x1, dtype=float)
    x2 = np.asarray(x2, dtype=float)
    spread = 3.0 + 0.1 * (x1 - x2) ** 2
    along = (x1 + x2) / math.sqrt(2.0)
    return spread - along, spread + along, (x1 - x2) + k, (x2 - x1) + k


def four_branch_components_model(k: float = FOUR_BRANCH_K) -> FunctionModel:
    """Outputs g1..g4 (each fails at g_i <= 0); the series system is Pf = 4.4573e-3."""
    from gearuq.model import FunctionModel

    return FunctionModel(functools.partial(four_branch_components, k=float(k)), ["x1", "x2"],
                         ["g1", "g2", "g3", "g4"], name="four_branch_components",
                         description="the four branches of the four-branch system")


# =========================================================================== jump
def jump(x1: Any, x2: Any) -> np.ndarray:
    """``g = 3.5 - x1 - 1.5 [x2 > 1]``: the margin drops by 1.5 where x2 exceeds 1."""
    x1 = np.asarray(x1, dtype=float)
    return 3.5 - x1 - 1.5 * (np.asarray(x2, dtype=float) > 1.0)


#: ``Phi(1) Phi(-3.5) + Phi(-1) Phi(-2)``.
JUMP_PF = float(stats.norm.cdf(1.0) * stats.norm.sf(3.5) + stats.norm.sf(1.0) * stats.norm.sf(2.0))


def jump_model() -> FunctionModel:
    """The discontinuous limit state as a model with inputs x1, x2."""
    from gearuq.model import FunctionModel

    return FunctionModel(jump, ["x1", "x2"], ["g"], name="jump",
                         description="g = 3.5 - x1 - 1.5 [x2 > 1] (discontinuous)")


# =========================================================================== random phase
def random_phase(X1: Any, X2: Any, t: Any, omega: float = 1.0) -> dict[str, np.ndarray]:  # noqa: N803
    """``y = X1 sin(w t) + X2 cos(w t)`` and ``dy = dy/dt``: stationary, Gaussian, m0 = 1,
    m2 = w^2."""
    x1 = np.asarray(X1, dtype=float)[:, None]
    x2 = np.asarray(X2, dtype=float)[:, None]
    wt = omega * np.asarray(t, dtype=float)[None, :]
    return {"y": x1 * np.sin(wt) + x2 * np.cos(wt),
            "dy": omega * (x1 * np.cos(wt) - x2 * np.sin(wt))}


def random_phase_model(omega: float = 1.0) -> FunctionModel:
    """The random-phase process as a time-dependent model (outputs y, dy)."""
    from gearuq.model import FunctionModel

    return FunctionModel(functools.partial(random_phase, omega=float(omega)), ["X1", "X2"],
                         ["y", "dy"], name="random_phase", time_dependent=True,
                         description=f"y = X1 sin({omega:g} t) + X2 cos({omega:g} t)")


def random_phase_rate(level: float, omega: float = 1.0) -> float:
    """Up-crossing rate of ``level``: ``(w / 2 pi) exp(-level^2 / 2)`` (Rice)."""
    return omega / (2 * math.pi) * math.exp(-level * level / 2)


def random_phase_first_passage(level: float, duration: float, omega: float = 1.0) -> float:
    """Exact ``P(max_{0<=t<=T} y(t) >= level)`` for ``level > 0``.

    ``y = A cos(w t - theta)`` with ``A`` Rayleigh and ``theta`` uniform, independent. Over
    the phase window ``[-theta, w T - theta]`` the largest cosine is 1 if the window holds a
    multiple of 2 pi, else the larger end value ``M``; ``P(A M >= a) = exp(-a^2 / (2 M^2))``.
    """
    span = omega * duration
    if span >= 2 * math.pi:
        return math.exp(-level * level / 2)

    def given_theta(theta: float) -> float:
        start, end = -theta, span - theta
        if math.floor(end / (2 * math.pi)) > math.floor(start / (2 * math.pi)) or \
                math.isclose(start % (2 * math.pi), 0.0):
            peak = 1.0
        else:
            peak = max(math.cos(start), math.cos(end))
        return math.exp(-level * level / (2 * peak * peak)) if peak > 0 else 0.0

    val, _ = integrate.quad(given_theta, 0.0, 2 * math.pi, limit=400, epsabs=1e-14,
                            epsrel=1e-11, points=[span, math.pi / 2, 3 * math.pi / 2,
                                                  span + math.pi / 2, span + 3 * math.pi / 2])
    return float(val / (2 * math.pi))


# =========================================================================== Gaussian process
def gaussian_process(t: Any, *, scales: tuple[float, ...], omegas: tuple[float, ...],
                     **coef: np.ndarray) -> dict[str, np.ndarray]:
    """``y = sum_k s_k (A_k cos w_k t + B_k sin w_k t)`` and its time derivative."""
    t = np.asarray(t, dtype=float)[None, :]
    y = 0.0
    dy = 0.0
    for k, (s, w) in enumerate(zip(scales, omegas, strict=True)):
        a = np.asarray(coef[f"A{k + 1}"], dtype=float)[:, None]
        b = np.asarray(coef[f"B{k + 1}"], dtype=float)[:, None]
        y = y + s * (a * np.cos(w * t) + b * np.sin(w * t))
        dy = dy + s * w * (-a * np.sin(w * t) + b * np.cos(w * t))
    return {"y": y, "dy": dy}


_GP_SCALES = (1.0, 0.6, 0.3)
_GP_OMEGAS = (1.0, 2.3, 4.1)


def gaussian_process_model(scales: tuple[float, ...] = _GP_SCALES,
                           omegas: tuple[float, ...] = _GP_OMEGAS) -> FunctionModel:
    """The K-harmonic stationary Gaussian process as a model (inputs A_k, B_k ~ N(0, 1))."""
    from gearuq.model import FunctionModel

    names = [f"{c}{k + 1}" for k in range(len(scales)) for c in ("A", "B")]
    return FunctionModel(functools.partial(gaussian_process, scales=tuple(scales),
                                           omegas=tuple(omegas)), names, ["y", "dy"],
                         name="gaussian_process", time_dependent=True,
                         description="stationary Gaussian process, sum of random harmonics")


def gaussian_process_moments(scales: tuple[float, ...] = _GP_SCALES,
                             omegas: tuple[float, ...] = _GP_OMEGAS) -> tuple[float, float]:
    """Spectral moments ``m0 = sum s_k^2`` and ``m2 = sum s_k^2 w_k^2``."""
    s = np.asarray(scales, dtype=float)
    w = np.asarray(omegas, dtype=float)
    return float(np.sum(s**2)), float(np.sum(s**2 * w**2))


def rice_rate_gaussian(level: float, m0: float, m2: float) -> float:
    """Rice's up-crossing rate of a zero-mean stationary Gaussian process,
    ``nu+ = (1 / 2 pi) sqrt(m2 / m0) exp(-u^2 / (2 m0))``."""
    return math.sqrt(m2 / m0) / (2 * math.pi) * math.exp(-level * level / (2 * m0))


# =========================================================================== curved tail
#: Level of ``g = c - sum of eight Exp(1)``: Pf = P(Gamma(8, 1) >= c) = 5.2e-6.
EXPONENTIAL_SUM_LEVEL = 27.0
EXPONENTIAL_SUM_PF = float(stats.gamma.sf(EXPONENTIAL_SUM_LEVEL, 8))


def _exponential_sum(level: float, **x: np.ndarray) -> np.ndarray:
    return level - sum(np.asarray(v, dtype=float) for v in x.values())


def exponential_sum_model(n: int = 8, level: float = EXPONENTIAL_SUM_LEVEL) -> FunctionModel:
    """``g = level - sum(x_i)``, ``x_i`` i.i.d. Exp(1): in the standard normal space the
    failure domain curves towards the origin (a curved tail). Exact ``Pf = Gamma(n).sf``."""
    from gearuq.model import FunctionModel

    return FunctionModel(functools.partial(_exponential_sum, float(level)),
                         [f"x{i + 1}" for i in range(n)], ["g"], name="exponential_sum",
                         description=f"g = {level:g} - sum of {n} Exp(1)")


def exponential_sum_space(n: int = 8) -> ParameterSpace:
    """``n`` independent Exp(1) inputs (gamma, shape 1, scale 1)."""
    from gearuq.space import ParameterSpace

    return ParameterSpace({f"x{i + 1}": {"kind": "gamma", "shape": 1.0, "scale": 1.0}
                           for i in range(n)})


# =========================================================================== invalid runs
#: ``P(x1 >= 3)``: the truth whatever the model returns where it fails.
NAN_TAIL_PF = float(stats.norm.sf(3.0))


def _nan_tail(x1: Any, x2: Any) -> np.ndarray:
    g = 3.0 - np.asarray(x1, dtype=float) + 0.0 * np.asarray(x2, dtype=float)
    return np.where(np.asarray(x1) > 3.2, np.nan, g)


def nan_tail_model() -> FunctionModel:
    """``g = 3 - x1``, but NaN where ``x1 > 3.2``: half the failure domain gives no answer.

    A method that drops the NaN samples reports about half the true Pf ``Phi(-3)``."""
    from gearuq.model import FunctionModel

    return FunctionModel(_nan_tail, ["x1", "x2"], ["g"], name="nan_tail",
                         description="g = 3 - x1, NaN where x1 > 3.2")


# ============================================ two failure mechanisms, a cheap model of one
#: Margins of the two mechanisms: ``g = min(3 - x1, 3.2 - x2)``.
TWO_MECHANISMS_BETAS = (3.0, 3.2)
#: ``1 - Phi(3) Phi(3.2)`` = 2.036e-3 (independent inputs, exact); the second mechanism is
#: 34 % of it.
TWO_MECHANISMS_PF = float(1.0 - stats.norm.cdf(TWO_MECHANISMS_BETAS[0])
                          * stats.norm.cdf(TWO_MECHANISMS_BETAS[1]))


def two_mechanisms(x1: Any, x2: Any) -> np.ndarray:
    """``g = min(3 - x1, 3.2 - x2)``: two failure mechanisms on independent inputs."""
    b1, b2 = TWO_MECHANISMS_BETAS
    return np.minimum(b1 - np.asarray(x1, dtype=float), b2 - np.asarray(x2, dtype=float))


def one_mechanism(x1: Any, x2: Any) -> np.ndarray:
    """The partially informative cheap model of :func:`two_mechanisms`: the first mechanism
    only, 0.1 on the safe side of it too little, blind to the second (a third of Pf)."""
    return TWO_MECHANISMS_BETAS[0] - 0.1 - np.asarray(x1, dtype=float) + 0.0 * np.asarray(x2)


def two_mechanisms_model() -> FunctionModel:
    """:func:`two_mechanisms` as a model with inputs x1, x2 and output ``g``."""
    from gearuq.model import FunctionModel

    return FunctionModel(two_mechanisms, ["x1", "x2"], ["g"], name="two_mechanisms",
                         description="g = min(3 - x1, 3.2 - x2)")


def one_mechanism_model() -> FunctionModel:
    """:func:`one_mechanism` as a model (the cheap model of :func:`two_mechanisms_model`)."""
    from gearuq.model import FunctionModel

    return FunctionModel(one_mechanism, ["x1", "x2"], ["g"], name="one_mechanism",
                         description="g = 2.9 - x1 (blind to the second mechanism)")


# =========================================================================== the gear model
#: Peak dynamic mesh force level [N] of the helical-pair rare-event case.
HELICAL_PAIR_LEVEL = 76_220.0
#: Output instants of the case: tau in [100, 200] every 0.05 (about 114 instants per mesh
#: period); the peak between them is taken by a parabola through each local maximum
#: (``first_passage="parabola"``): within 0.2 N of the continuous-time peak on 100 draws
#: about the failure domain (against 0.0025 instants), where the plain maximum over the old
#: grid (one instant per time unit, 5.7 per mesh period) was up to 190 N low.
HELICAL_PAIR_T = np.linspace(100.0, 200.0, 2001)
#: P(continuous-time peak of mesh_force over tau in [100, 200] >= 76 220 N), the model's
#: default space and options: importance sampling with every weight bounded by 2 (half the
#: standard normal, half a broad normal about the failure region; 1.2 x 10^5 runs, 9495
#: failing, CoV 2.1 %, :mod:`gearuq.testing.helical_pair_reference`), 95 % normal interval;
#: crude Monte Carlo on independent draws agrees (``helical_pair_problem()["source"]``).
HELICAL_PAIR_PF = 7.92e-5
HELICAL_PAIR_PF_INTERVAL = (7.60e-5, 8.25e-5)

#: The earlier case: the largest mesh force on the instants tau = 0, 1, ..., 200 within
#: [100, 200] at 76 200 N (aliased: see :func:`helical_pair_problem`), from the same
#: bounded-weight runs (8319 failing, CoV 2.3 %). The earlier crude-MC reference, 1.11e-4
#: [9.69e-5, 1.27e-4] from 2 x 10^6 runs (222 failures), was 1.5 of its own standard errors
#: above it.
HELICAL_PAIR_GRID_LEVEL = 76_200.0
HELICAL_PAIR_GRID_PF = 9.94e-5
HELICAL_PAIR_GRID_PF_INTERVAL = (9.49e-5, 1.04e-4)


_PEAK_SOURCE = ("importance sampling with weights <= 2, 1.2 x 10^5 runs (CoV 2.1 %); crude MC "
                "on independent draws: 2 x 10^6 runs, 178 failures, 8.90e-5 [7.64e-5, 1.03e-4]")
_GRID_SOURCE = ("importance sampling with weights <= 2, 1.2 x 10^5 runs (CoV 2.3 %); crude MC: "
                "2 x 10^6 runs, 222 failures, 1.11e-4 [9.69e-5, 1.27e-4]; on the peak case's "
                "2 x 10^6 draws 216 failures, 1.08e-4 [9.41e-5, 1.23e-4]")


#: The deep level of the aliased grid case [N] and its estimate: four groups of ten pooled
#: subset runs gave 3.0e-8, 1.5e-8, 2.2e-8 and 2.7e-8 (docs/reliability.md); their mean. An
#: estimate from one method, not a reference: a coverage row on it is indicative only.
HELICAL_PAIR_DEEP_LEVEL = 76_300.0
HELICAL_PAIR_DEEP_PF = 2.35e-8
_DEEP_SOURCE = ("mean of four groups of ten pooled subset-simulation runs (3.0e-8, 1.5e-8, "
                "2.2e-8, 2.7e-8); not checkable by crude Monte Carlo (~5e9 runs)")


def helical_pair_problem(variant: str = "peak") -> dict[str, Any]:
    """The helical pair's peak mesh force at Pf ~ 1e-4 with its reference.

    Parameters
    ----------
    variant : {"peak", "grid", "deep"}
        ``"peak"``: the continuous-time peak (parabola through the local maxima on
        :data:`HELICAL_PAIR_T`) at :data:`HELICAL_PAIR_LEVEL`. ``"grid"``: the earlier case,
        the largest value on ``tau = 0, 1, ..., 200`` at 76 200 N. Its mesh force peaks are
        sharp (curvature ~7e4 N per tau^2) and the grid has 5.7 instants per mesh period, so
        the grid maximum depends on where the instants fall on the peaks: up to 190 N low,
        and with a pattern that moves with every parameter that shifts the response's phase
        (aliasing fingers in the failure set); kept to show what that does to the methods.
        ``"deep"``: the same grid at 76 300 N (Pf ~ 2e-8, the README's old level), where
        subset simulation's chains do not mix; its value is the mean of four pooled groups
        of ten subset runs (no method can check it: crude MC would need ~5e9 runs).

    Not in :func:`reliability_problems` (it needs the plugin and ~1 ms per run); the
    reference's own interval is in the ``"pf_interval"`` entry: a method's interval is judged
    against the point value, as for the 2e7-sample oscillator reference.
    """
    from gearuq.failure.modes import LimitState
    from gearuq.registry import get_model

    model = get_model("helical_pair")
    if variant == "peak":
        limit = LimitState.upper("mesh_force", HELICAL_PAIR_LEVEL, window=(100.0, 200.0),
                                 first_passage="parabola")
        return {"model": model, "space": model.default_space(), "limit_state": limit,
                "t": HELICAL_PAIR_T, "pf": HELICAL_PAIR_PF,
                "pf_interval": HELICAL_PAIR_PF_INTERVAL,
                "source": _PEAK_SOURCE}
    if variant == "deep":
        limit = LimitState.upper("mesh_force", HELICAL_PAIR_DEEP_LEVEL, window=(100.0, 200.0))
        return {"model": model, "space": model.default_space(), "limit_state": limit,
                "t": np.linspace(0.0, 200.0, 201), "pf": HELICAL_PAIR_DEEP_PF,
                "pf_interval": (math.nan, math.nan), "source": _DEEP_SOURCE}
    if variant == "grid":
        limit = LimitState.upper("mesh_force", HELICAL_PAIR_GRID_LEVEL, window=(100.0, 200.0))
        return {"model": model, "space": model.default_space(), "limit_state": limit,
                "t": np.linspace(0.0, 200.0, 201), "pf": HELICAL_PAIR_GRID_PF,
                "pf_interval": HELICAL_PAIR_GRID_PF_INTERVAL,
                "source": _GRID_SOURCE}
    raise ValueError(f"variant: {variant!r} is not 'peak', 'grid' or 'deep'")


# =========================================================================== all of them
def reliability_problems() -> dict[str, dict[str, Any]]:
    """The static problems by name: ``{"model", "space", "limit_state", "pf", "source"}``."""
    from gearuq.failure.modes import LimitState, SeriesSystem
    from gearuq.testing.problems import four_branch_model

    return {
        "linear_100d": {"model": linear_sum_model(), "space": standard_normal_space(100),
                        "limit_state": "g", "pf": LINEAR_100D_PF, "source": "exact"},
        "offset": {"model": offset_model(), "space": offset_space(), "limit_state": "g",
                   "pf": OFFSET_PF, "source": "exact"},
        "resistance_load": {"model": resistance_load_model(),
                            "space": resistance_load_space(), "limit_state": "g",
                            "pf": resistance_load_pf(), "source": "1-D quadrature"},
        "oscillator": {"model": oscillator_model(), "space": oscillator_space(),
                       "limit_state": "g", "pf": OSCILLATOR_PF_MC,
                       "source": "2e7 Monte Carlo (+- 4e-5)"},
        "four_branch": {"model": four_branch_model(), "space": standard_normal_space(2),
                        "limit_state": "g", "pf": FOUR_BRANCH_PF, "source": "1-D quadrature"},
        "four_branch_system": {
            "model": four_branch_components_model(), "space": standard_normal_space(2),
            "limit_state": SeriesSystem([LimitState.output(f"g{i}") for i in range(1, 5)]),
            "pf": FOUR_BRANCH_PF, "source": "1-D quadrature"},
        "parabola": {"model": parabola_model(),
                     "space": _named_normals(["u1", "u2"]), "limit_state": "g",
                     "pf": PARABOLA_PF, "source": "1-D quadrature"},
        "jump": {"model": jump_model(), "space": standard_normal_space(2), "limit_state": "g",
                 "pf": JUMP_PF, "source": "exact"},
        "exponential_sum": {"model": exponential_sum_model(), "space": exponential_sum_space(),
                            "limit_state": "g", "pf": EXPONENTIAL_SUM_PF,
                            "source": "exact (gamma tail)"},
        "nan_tail": {"model": nan_tail_model(), "space": standard_normal_space(2),
                     "limit_state": "g", "pf": NAN_TAIL_PF, "source": "exact"},
        "two_mechanisms": {"model": two_mechanisms_model(), "space": standard_normal_space(2),
                           "limit_state": "g", "pf": TWO_MECHANISMS_PF, "source": "exact",
                           "low_fidelity": one_mechanism_model()},
    }


def _named_normals(names: list[str]) -> ParameterSpace:
    from gearuq.space import ParameterSpace

    return ParameterSpace.normal(**{n: (0.0, 1.0) for n in names})


# ======================================================================= the geared rotor
#: Options of the geared rotor in its rare-event case: the speed range on 40 speeds with 2 mesh
#: harmonics (the headline study's cheap model; 160 speeds and 3 harmonics by default), so that
#: 20 seeds of 1000 rotor runs fit in half an hour on 2 cores. The same physics on a coarser
#: grid: Pearson 1.0000 with the default's ``dte_rms_max``, at most 0.36 um below it.
GEARED_ROTOR_OPTIONS = {"n_speeds": 40, "range_mesh_harmonics": 2}
#: The cheap model of the case for multi-fidelity importance sampling: 20 speeds, 1 harmonic
#: (about 0.55 of a run of the case: the loaded tooth contact analysis is a fixed cost).
GEARED_ROTOR_LOW_FIDELITY_OPTIONS = {"n_speeds": 20, "range_mesh_harmonics": 1}
#: Limit on ``dte_rms_max`` [m] of the case.
GEARED_ROTOR_LEVEL = 60e-6
#: P(dte_rms_max >= 60 um) of the case, from :func:`geared_rotor_reference` (seed 77): 10^4
#: rotor runs from the tilted normal of a quadratic form fitted to 2400 runs of the case's
#: rotor itself, 3542 failing, CoV 4.5 %, Pareto k -0.61, largest weight 0.4 % of the
#: estimate; 95 % normal interval.
GEARED_ROTOR_PF = 7.12e-7
GEARED_ROTOR_PF_INTERVAL = (6.49e-7, 7.76e-7)
_ROTOR_SOURCE = ("importance sampling from the tilted normal of a quadratic form fitted to the "
                 "case's rotor itself: 10^4 runs (plus 2400 for the fit), CoV 4.5 %, Pareto "
                 "k -0.61")


def geared_rotor_space() -> ParameterSpace:
    """The headline space of the geared rotor: its pitch germ, tip-relief tolerance and torque.

    58 independent standard normals ``pitch_xi_{p,g}_{1..29}`` (the germ of each gear's random
    cumulative pitch deviations), ``tip_relief_amount`` uniform on 37-47 um (the 42 um design
    relief with a +-5 um drawing tolerance) and ``torque`` lognormal with mean 1000 N m and
    CoV 10 %.
    """
    from gearuq.space import ParameterSpace

    germ = {f"pitch_xi_{gear}_{k}": {"dist": "normal", "mean": 0.0, "std": 1.0}
            for gear in ("p", "g") for k in range(1, 30)}
    return ParameterSpace({
        "torque": {"dist": "lognormal", "mean": 1000.0, "std": 100.0},
        "tip_relief_amount": {"dist": "uniform", "lower": 37.0, "upper": 47.0},
        **germ})


def geared_rotor_model() -> Any:
    """The geared rotor of Yuan, Liu and Liu (2020) at ISO 1328-1 grade 6."""
    from gearuq.registry import get_model

    return get_model("geared_rotor").with_nominal(iso_grade=6)


def geared_rotor_problem() -> dict[str, Any]:
    """The geared rotor's largest RMS DTE over 25-8000 rpm at Pf ~ 1e-6, with its reference.

    ``dte_rms_max >= GEARED_ROTOR_LEVEL`` over :func:`geared_rotor_space` (60 inputs), the
    rotor at :data:`GEARED_ROTOR_OPTIONS`. The reference comes from
    :func:`geared_rotor_reference` (see ``"source"``); like the helical pair's, it is not in
    :func:`reliability_problems` (about 0.1 s per run).
    """
    from gearuq.failure.modes import LimitState

    return {"model": geared_rotor_model(), "space": geared_rotor_space(),
            "limit_state": LimitState.upper("dte_rms_max", GEARED_ROTOR_LEVEL),
            "model_options": dict(GEARED_ROTOR_OPTIONS), "pf": GEARED_ROTOR_PF,
            "pf_interval": GEARED_ROTOR_PF_INTERVAL, "source": _ROTOR_SOURCE}


def geared_rotor_mfis_settings(level: float = GEARED_ROTOR_LEVEL,
                               low_fidelity_options: Any = None) -> dict[str, Any]:
    """MFIS settings of the rotor at Pf ~ 1e-6, as the headline study and the benchmark run it.

    The cheap model (the same rotor with ``low_fidelity_options``; default
    :data:`GEARED_ROTOR_LOW_FIDELITY_OPTIONS`) has its ``dte_rms_max^2`` fitted as a
    quadratic form on 2400 runs (the form has 1891 coefficients in 60 inputs); the rotor then
    runs in batches of 200 from the tilted normal of that form (5 % defensive), up to 1000
    runs or a CoV of 0.15. ``level`` [m] is the limit X of ``g = X - dte_rms_max`` (the
    response offset).
    """
    options = GEARED_ROTOR_LOW_FIDELITY_OPTIONS if low_fidelity_options is None \
        else low_fidelity_options
    return {"low_fidelity": geared_rotor_model(), "low_fidelity_options": dict(options),
            "biasing": "quadratic", "response_offset": level, "n_fit": 2400,
            "n_samples": 200, "max_samples": 1000, "target_cov": 0.15, "defensive": 0.05}


def geared_rotor_reference(n_samples: int = 10_000, seed: int = 77, executor: Any = "processes",
                           chunk_size: int = 250) -> Any:
    """The reference of :func:`geared_rotor_problem`: one long importance-sampling run.

    The quadratic form of ``dte_rms_max^2`` is fitted to 2400 runs of the case's rotor itself
    (not of a cheaper model), and ``n_samples`` rotor runs are drawn from the exponentially
    tilted normal of that form (:mod:`gearuq.failure.methods.quadratic`), 5 % defensive.
    Returns the report (``pf``, ``pf_lower``, ``pf_upper``, ``cov_pf``).
    """
    from gearuq.failure.api import failure_probability

    p = geared_rotor_problem()
    settings = {**geared_rotor_mfis_settings(GEARED_ROTOR_LEVEL, p["model_options"]),
                "n_samples": 1000, "max_samples": n_samples, "target_cov": 1e-4}
    return failure_probability(p["model"], p["space"], p["limit_state"], method="mfis",
                               rng=seed, executor=executor, chunk_size=chunk_size,
                               model_options=p["model_options"], **settings)


#: Line-sampling settings of :func:`geared_rotor_line_reference`: radial lines in the
#: 2-dimensional subspace found by 4 gradient probes (a cylinder's exterior, the in-phase
#: once-per-revolution pitch wave of both gears), grid of 7 points over [-8, 8].
GEARED_ROTOR_LINE_SETTINGS = {"direction": "gradient", "subspace_dim": 2, "n_probe": 4,
                              "probe_std": 1.5, "probe_step": 0.05, "c_max": 8.0,
                              "n_grid": 7, "root_tol": 1e-3, "chunk_lines": 50}

#: P(dte_rms_max >= 60 um) of :func:`geared_rotor_problem` by :func:`geared_rotor_line_reference`
#: (seed 2030, 2 batches): 200 radial lines, every one crossing twice, per-line CoV 0.078,
#: 2444 rotor runs (244 for the probe), CoV 0.55 %; 95 % normal interval of the lines' mean.
#: It shares no estimator code with MFIS (the batches alone: 7.30e-7 and 7.27e-7).
GEARED_ROTOR_LINE_PF = 7.28e-7
GEARED_ROTOR_LINE_PF_INTERVAL = (7.19e-7, 7.37e-7)


def geared_rotor_line_reference(n_batches: int = 2, lines_per_batch: int = 100,
                                seed: int = 2030, store: Any = None,
                                executor: Any = "serial", confidence: float = 0.95) -> Any:
    """An independent reference of :func:`geared_rotor_problem` by line sampling.

    It shares no estimator code with MFIS (:mod:`gearuq.failure.methods.line_sampling`):
    the first batch finds the important subspace by finite-difference gradients of ``g`` at
    4 random points (``4 x 61`` runs; the leading two singular vectors, the third and fourth
    singular values saying how close to 2-dimensional the set is) and runs its lines; the
    other batches reuse that subspace with their own seeds. The batches' lines are i.i.d.,
    so they are pooled into one mean with its normal interval.

    Parameters
    ----------
    n_batches, lines_per_batch : int
        Independent runs of ``lines_per_batch`` lines each (seeds ``seed + b``).
    store : path-like, optional
        Directory; batch ``b`` is stored under ``store/batch{b}``, every step of it as its
        own chunk store, so an interrupted reference resumes where it stopped.
    executor : str or executor
        As in :func:`gearuq.failure_probability`.
    confidence : float
        Two-sided level of the interval.

    Returns
    -------
    xarray.Dataset
        ``pf``, ``pf_lower``, ``pf_upper``, ``cov_pf``, ``n_lines``, ``n_model_runs``,
        ``cpu_time`` (this process's CPU seconds), ``n_lines_by_crossings``, ``line_pf`` and
        the ``direction`` rows; ``attrs["batch_status"]`` lists each batch's status line.
    """
    import time
    from pathlib import Path

    import xarray as xr

    from gearuq.failure.api import failure_probability
    from gearuq.failure.methods.line_sampling import line_estimate
    from gearuq.failure.report import describe_status

    p = geared_rotor_problem()
    cpu0 = time.process_time()
    settings = dict(GEARED_ROTOR_LINE_SETTINGS)
    reports = []
    for b in range(n_batches):
        rep = failure_probability(
            p["model"], p["space"], p["limit_state"], method="line_sampling", rng=seed + b,
            executor=executor, store=None if store is None else Path(store) / f"batch{b}",
            model_options=p["model_options"], n_lines=lines_per_batch, **settings)
        reports.append(rep)
        settings["direction"] = rep["direction"].values  # the first batch's probe, kept
    est, low, high = (np.concatenate([r[v].values for r in reports])
                      for v in ("line_pf", "line_pf_lower", "line_pf_upper"))
    e = line_estimate(est, low, high, confidence)
    first = reports[0]
    scalar = {"units": "1"}
    out = xr.Dataset({
        "pf": ((), e["pf"], {**scalar, "long_name": "failure probability (mean of the lines)"}),
        "pf_lower": ((), e["pf_lower"], {**scalar, "long_name": "lower end of the interval"}),
        "pf_upper": ((), e["pf_upper"], {**scalar, "long_name": "upper end of the interval"}),
        "cov_pf": ((), e["se"] / e["pf"] if e["pf"] > 0 else math.inf, {
            **scalar, "long_name": "coefficient of variation of pf"}),
        "n_lines": ((), np.int64(est.size), scalar),
        "n_effective_lines": ((), e["n_effective"], scalar),
        "n_model_runs": ((), np.int64(sum(int(r["n_model_runs"]) for r in reports)), {
            **scalar, "long_name": "rotor runs, the gradient probe's included"}),
        "n_probe_runs": first["n_probe_runs"],
        "cpu_time": ((), time.process_time() - cpu0, {"units": "s", "long_name": (
            "CPU seconds of this process (0 for batches read back from the store)")}),
        "n_lines_by_crossings": sum(r["n_lines_by_crossings"] for r in reports),
        "line_pf": (("line",), est, {**scalar, "long_name": "each line's failure probability"}),
        "direction": first["direction"],
    })
    out.attrs.update({
        "method": "line_sampling", "confidence": float(confidence), "seed": seed,
        "settings": repr({**GEARED_ROTOR_LINE_SETTINGS, "lines_per_batch": lines_per_batch,
                          "n_batches": n_batches}),
        "direction_source": first.attrs.get("direction_source", ""),
        "probe_singular_values": first.attrs.get("probe_singular_values", ""),
        "batch_status": " | ".join(describe_status(r) for r in reports),
        "interval_kind": first.attrs["interval_kind"]})
    return out


# =========================================================================== modes in units
#: Distances of the two modes of :func:`unit_modes_model` (standard normal space).
UNIT_MODES_BETAS = (3.0, 3.5)
#: Angle between the two modes' directions (radians): neither orthogonal nor aligned.
UNIT_MODES_ANGLE = 1.2


def _unit_modes(u1: Any, u2: Any, *, scales: tuple[float, float], betas: tuple[float, float],
                angle: float) -> dict[str, np.ndarray]:
    a1 = np.array([1.0, 0.0])
    a2 = np.array([math.cos(angle), math.sin(angle)])
    u1 = np.asarray(u1, dtype=float)
    u2 = np.asarray(u2, dtype=float)
    g1 = scales[0] * (betas[0] - (a1[0] * u1 + a1[1] * u2))
    g2 = scales[1] * (betas[1] - (a2[0] * u1 + a2[1] * u2))
    return {"g1": g1, "g2": g2, "g": np.minimum(g1, g2)}


def unit_modes_model(scales: tuple[float, float] = (1e3, 1e-3),
                     betas: tuple[float, float] = UNIT_MODES_BETAS,
                     angle: float = UNIT_MODES_ANGLE) -> FunctionModel:
    """Two linear failure modes in different units: a load margin and a deflection margin.

    Outputs ``g1 = s1 (beta1 - a1.u)``, ``g2 = s2 (beta2 - a2.u)`` (``u1, u2`` standard
    normal, ``a1 = (1, 0)``, ``a2`` at ``angle`` from it) and their minimum ``g``, the same
    series system written as one limit state. The factors ``scales`` change the units, never
    the failure set: the reference is :func:`unit_modes_pf` whatever they are.
    """
    from gearuq.model import FunctionModel

    fn = functools.partial(_unit_modes, scales=tuple(map(float, scales)),
                           betas=tuple(map(float, betas)), angle=float(angle))
    return FunctionModel(fn, ["u1", "u2"], ["g1", "g2", "g"],
                         name=f"unit_modes_{scales[0]:g}_{scales[1]:g}",
                         description="two linear failure modes in different units")


def unit_modes_pf(betas: tuple[float, float] = UNIT_MODES_BETAS,
                  angle: float = UNIT_MODES_ANGLE) -> float:
    """``P(a1.U >= beta1 or a2.U >= beta2)``: one minus a bivariate normal cdf with
    correlation ``cos(angle)``, by one-dimensional quadrature over ``a1.U``."""
    rho = math.cos(angle)
    s = math.sqrt(1.0 - rho * rho)

    def safe_density(z: float) -> float:  # density of a1.U = z times P(a2.U < beta2 | z)
        return stats.norm.pdf(z) * stats.norm.cdf((betas[1] - rho * z) / s)

    safe, _ = integrate.quad(safe_density, -12.0, betas[0], epsabs=1e-14, epsrel=1e-12,
                             limit=200)
    return float(1.0 - safe)


def unit_modes_limit_state(as_system: bool = True) -> Any:
    """The series system of ``g1`` and ``g2`` (or, ``as_system=False``, the output ``g``)."""
    from gearuq.failure.modes import LimitState, SeriesSystem

    if not as_system:
        return "g"
    return SeriesSystem([LimitState.output("g1"), LimitState.output("g2")])


# =========================================================================== a thin ridge
#: Sharpness and distance of :func:`ridge_model` (Pf = 2.16e-5).
RIDGE_K, RIDGE_B = 10.0, 3.0


def _ridge(x1: Any, x2: Any, x3: Any, x4: Any, x5: Any, x6: Any, *, k: float, b: float
           ) -> np.ndarray:
    along = (np.asarray(x1, dtype=float) + x2) / math.sqrt(2.0)
    across = (np.asarray(x1, dtype=float) - x2) / math.sqrt(2.0)
    return b - along + k * math.sqrt(2.0) * np.abs(across) + 0.0 * np.asarray(x3)


def ridge_model(k: float = RIDGE_K, b: float = RIDGE_B) -> FunctionModel:
    """A failure set that is a thin wedge along the diagonal ``x1 = x2``, four inert inputs.

    ``g = b - (x1 + x2)/sqrt2 + k sqrt2 |x1 - x2|/sqrt2``, six standard normal inputs: the
    shape of the helical pair's peak mesh force (a tent in the two face widths, the other
    inputs nearly inert), where component-wise Markov chains cannot follow the ridge and
    subset simulation's levels do not mix. Reference :func:`ridge_pf`.
    """
    from gearuq.model import FunctionModel

    return FunctionModel(functools.partial(_ridge, k=float(k), b=float(b)),
                         [f"x{i}" for i in range(1, 7)], ["g"], name=f"ridge_{k:g}_{b:g}",
                         description="a thin failure wedge along x1 = x2 (six inputs)")


def ridge_pf(k: float = RIDGE_K, b: float = RIDGE_B) -> float:
    """``E_c[Phi(-(b + k sqrt2 |c|))]`` over ``c ~ N(0, 1)``: one-dimensional quadrature."""
    def integrand(c: float) -> float:
        return 2.0 * stats.norm.pdf(c) * stats.norm.sf(b + k * math.sqrt(2.0) * c)

    val, _ = integrate.quad(integrand, 0.0, 12.0, epsabs=1e-16, epsrel=1e-11, limit=200)
    return float(val)
