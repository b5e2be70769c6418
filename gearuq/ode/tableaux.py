"""Butcher tableaux of the integrator's methods, and the per-method constants.

The tableaux are stored as sparse rows (CSR: pointer, column, value), so that one stage loop
serves every method without multiplying by the many zeros of DOP853. Values: Dormand and
Prince 5(4) as in Hairer's DOPRI5, Hairer's DOP853 (as distributed with scipy.integrate), and
the classical RK4.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

#: Valid values of ``method``; ``"rk4"`` requires ``fixed_step``.
METHODS = ("dopri5", "dop853", "rk4")
DOPRI5 = 0
DOP853 = 1
RK4 = 2
METHOD_CODE = {"dopri5": DOPRI5, "dop853": DOP853, "rk4": RK4}

# Per method: stages kept in K (rows), the row of f(t_new, y_new), rows of the full dense
# output, the order q of the step-size controller (err^(1/q)), Hairer's step-ratio limits
# [fac1, fac2] and the PI constant beta.
N_STAGES = {DOPRI5: 7, DOP853: 16, RK4: 5}
END_STAGE = {DOPRI5: 6, DOP853: 12, RK4: 4}
DENSE_ROWS = {DOPRI5: 4, DOP853: 7, RK4: 3}
ORDER = {DOPRI5: 5, DOP853: 8, RK4: 4}
FAC_MIN = {DOPRI5: 0.2, DOP853: 0.333, RK4: 0.2}
FAC_MAX = {DOPRI5: 10.0, DOP853: 6.0, RK4: 10.0}
PI_BETA = {DOPRI5: 0.04, DOP853: 0.0, RK4: 0.0}


def _csr(rows: tuple) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Return (ptr, idx, val) of a tuple of rows, each a tuple of (column, value) pairs."""
    ptr = [0]
    idx: list[int] = []
    val: list[float] = []
    for row in rows:
        for col, v in row:
            idx.append(col)
            val.append(v)
        ptr.append(len(idx))
    return (np.array(ptr, dtype=np.int64), np.array(idx, dtype=np.int64),
            np.array(val, dtype=np.float64))


# Dormand-Prince 5(4) (Hairer's DOPRI5). Stage 6 is f(t + h, y_new) (FSAL).
DOPRI5_C = np.array([0.0, 1 / 5, 3 / 10, 4 / 5, 8 / 9, 1.0, 1.0])
_DOPRI5_A = (
    (),
    ((0, 1 / 5),),
    ((0, 3 / 40), (1, 9 / 40)),
    ((0, 44 / 45), (1, -56 / 15), (2, 32 / 9)),
    ((0, 19372 / 6561), (1, -25360 / 2187), (2, 64448 / 6561), (3, -212 / 729)),
    ((0, 9017 / 3168), (1, -355 / 33), (2, 46732 / 5247), (3, 49 / 176), (4, -5103 / 18656)),
)
_DOPRI5_B = (((0, 35 / 384), (2, 500 / 1113), (3, 125 / 192), (4, -2187 / 6784), (5, 11 / 84)),)
# Difference of the 5th- and 4th-order weights (error estimate), on stages 0..6.
_DOPRI5_E = (((0, -71 / 57600), (2, 71 / 16695), (3, -71 / 1920), (4, 17253 / 339200),
              (5, -22 / 525), (6, 1 / 40)),)
# Hairer's dense-output coefficients d1..d7 (CONTD5), on stages 0..6.
_DOPRI5_D = (((0, -12715105075 / 11282082432), (2, 87487479700 / 32700410799),
              (3, -10690763975 / 1880347072), (4, 701980252875 / 199316789632),
              (5, -1453857185 / 822651844), (6, 69997945 / 29380423)),)

# Classical RK4; stage 4 is f(t + h, y_new), used for the Hermite interpolant and as the next
# step's first stage.
RK4_C = np.array([0.0, 0.5, 0.5, 1.0, 1.0])
_RK4_A = ((), ((0, 0.5),), ((1, 0.5),), ((2, 1.0),))
_RK4_B = (((0, 1 / 6), (1, 1 / 3), (2, 1 / 3), (3, 1 / 6)),)

# DOP853 (Hairer's dop853.f, the values as distributed with scipy.integrate). Stages 0..11 are
# the method, stage 12 is f(t + h, y_new), stages 13..15 are the extra dense-output stages.
DOP853_C = np.array([
    0.0, 0.05260015195876773, 0.0789002279381516, 0.1183503419072274, 0.2816496580927726,
    0.3333333333333333, 0.25, 0.3076923076923077, 0.6512820512820513, 0.6,
    0.8571428571428571, 1.0, 1.0, 0.1, 0.2, 0.7777777777777778,
])
_DOP853_A = (
    (),
    ((0, 0.05260015195876773),),
    ((0, 0.0197250569845379), (1, 0.0591751709536137),),
    ((0, 0.02958758547680685), (2, 0.08876275643042054),),
    ((0, 0.2413651341592667), (2, -0.8845494793282861), (3, 0.924834003261792),),
    ((0, 0.037037037037037035), (3, 0.17082860872947386), (4, 0.12546768756682242),),
    ((0, 0.037109375), (3, 0.17025221101954405), (4, 0.06021653898045596), (5, -0.017578125),),
    ((0, 0.03709200011850479), (3, 0.17038392571223998), (4, 0.10726203044637328),
     (5, -0.015319437748624402), (6, 0.008273789163814023),),
    ((0, 0.6241109587160757), (3, -3.3608926294469414), (4, -0.868219346841726),
     (5, 27.59209969944671), (6, 20.154067550477894), (7, -43.48988418106996),),
    ((0, 0.47766253643826434), (3, -2.4881146199716677), (4, -0.590290826836843),
     (5, 21.230051448181193), (6, 15.279233632882423), (7, -33.28821096898486),
     (8, -0.020331201708508627),),
    ((0, -0.9371424300859873), (3, 5.186372428844064), (4, 1.0914373489967295),
     (5, -8.149787010746927), (6, -18.52006565999696), (7, 22.739487099350505),
     (8, 2.4936055526796523), (9, -3.0467644718982196),),
    ((0, 2.273310147516538), (3, -10.53449546673725), (4, -2.0008720582248625),
     (5, -17.9589318631188), (6, 27.94888452941996), (7, -2.8589982771350235),
     (8, -8.87285693353063), (9, 12.360567175794303), (10, 0.6433927460157636),),
    ((0, 0.054293734116568765), (5, 4.450312892752409), (6, 1.8915178993145003),
     (7, -5.801203960010585), (8, 0.3111643669578199), (9, -0.1521609496625161),
     (10, 0.20136540080403034), (11, 0.04471061572777259),),
    ((0, 0.056167502283047954), (6, 0.25350021021662483), (7, -0.2462390374708025),
     (8, -0.12419142326381637), (9, 0.15329179827876568), (10, 0.00820105229563469),
     (11, 0.007567897660545699), (12, -0.008298),),
    ((0, 0.03183464816350214), (5, 0.028300909672366776), (6, 0.053541988307438566),
     (7, -0.05492374857139099), (10, -0.00010834732869724932), (11, 0.0003825710908356584),
     (12, -0.00034046500868740456), (13, 0.1413124436746325),),
    ((0, -0.42889630158379194), (5, -4.697621415361164), (6, 7.683421196062599),
     (7, 4.06898981839711), (8, 0.3567271874552811), (12, -0.0013990241651590145),
     (13, 2.9475147891527724), (14, -9.15095847217987),),
)
_DOP853_B = (
    ((0, 0.054293734116568765), (5, 4.450312892752409), (6, 1.8915178993145003),
     (7, -5.801203960010585), (8, 0.3111643669578199), (9, -0.1521609496625161),
     (10, 0.20136540080403034), (11, 0.04471061572777259),),
)
_DOP853_E3 = (
    ((0, -0.18980075407240762), (5, 4.450312892752409), (6, 1.8915178993145003),
     (7, -5.801203960010585), (8, -0.4226823213237919), (9, -0.1521609496625161),
     (10, 0.20136540080403034), (11, 0.02265179219836082),),
)
_DOP853_E5 = (
    ((0, 0.01312004499419488), (5, -1.2251564463762044), (6, -0.4957589496572502),
     (7, 1.6643771824549864), (8, -0.35032884874997366), (9, 0.3341791187130175),
     (10, 0.08192320648511571), (11, -0.022355307863886294),),
)
_DOP853_D = (
    ((0, -8.428938276109013), (5, 0.5667149535193777), (6, -3.0689499459498917),
     (7, 2.38466765651207), (8, 2.117034582445028), (9, -0.871391583777973),
     (10, 2.2404374302607883), (11, 0.6315787787694688), (12, -0.08899033645133331),
     (13, 18.148505520854727), (14, -9.194632392478356), (15, -4.436036387594894),),
    ((0, 10.427508642579134), (5, 242.28349177525817), (6, 165.20045171727028),
     (7, -374.5467547226902), (8, -22.113666853125306), (9, 7.733432668472264),
     (10, -30.674084731089398), (11, -9.332130526430229), (12, 15.697238121770845),
     (13, -31.139403219565178), (14, -9.35292435884448), (15, 35.81684148639408),),
    ((0, 19.985053242002433), (5, -387.0373087493518), (6, -189.17813819516758),
     (7, 527.8081592054236), (8, -11.57390253995963), (9, 6.8812326946963),
     (10, -1.0006050966910838), (11, 0.7777137798053443), (12, -2.778205752353508),
     (13, -60.19669523126412), (14, 84.32040550667716), (15, 11.99229113618279),),
    ((0, -25.69393346270375), (5, -154.18974869023643), (6, -231.5293791760455),
     (7, 357.6391179106141), (8, 93.40532418362432), (9, -37.45832313645163),
     (10, 104.0996495089623), (11, 29.8402934266605), (12, -43.53345659001114),
     (13, 96.32455395918828), (14, -39.17726167561544), (15, -149.72683625798564),),
)

D5_A_PTR, D5_A_IDX, D5_A_VAL = _csr(_DOPRI5_A)
D5_B_PTR, D5_B_IDX, D5_B_VAL = _csr(_DOPRI5_B)
D5_E_PTR, D5_E_IDX, D5_E_VAL = _csr(_DOPRI5_E)
D5_D_PTR, D5_D_IDX, D5_D_VAL = _csr(_DOPRI5_D)
R4_A_PTR, R4_A_IDX, R4_A_VAL = _csr(_RK4_A)
R4_B_PTR, R4_B_IDX, R4_B_VAL = _csr(_RK4_B)
D8_A_PTR, D8_A_IDX, D8_A_VAL = _csr(_DOP853_A)
D8_B_PTR, D8_B_IDX, D8_B_VAL = _csr(_DOP853_B)
D8_E3_PTR, D8_E3_IDX, D8_E3_VAL = _csr(_DOP853_E3)
D8_E5_PTR, D8_E5_IDX, D8_E5_VAL = _csr(_DOP853_E5)
D8_D_PTR, D8_D_IDX, D8_D_VAL = _csr(_DOP853_D)


# ------------------------------------------------------------------ linear stability
_A_ROWS = {DOPRI5: _DOPRI5_A, DOP853: _DOP853_A, RK4: _RK4_A}
_B_ROW = {DOPRI5: _DOPRI5_B[0], DOP853: _DOP853_B[0], RK4: _RK4_B[0]}


def stability_polynomial(method: str) -> np.ndarray:
    """Coefficients ``c_0 .. c_s`` of the method's stability function ``R(z) = sum c_j z^j``.

    One step of an explicit Runge-Kutta method on ``y' = lambda y`` multiplies ``y`` by
    ``R(h lambda) = 1 + z b^T (I - z A)^-1 1`` (Hairer and Wanner, Solving ODEs II, IV.2),
    a polynomial for an explicit ``A``: ``c_0 = 1``, ``c_{j+1} = b^T A^j 1``. The step is
    linearly stable where ``|R(z)| <= 1``. Built from the same tableau the kernels run.
    """
    code = METHOD_CODE[method]
    b_row = _B_ROW[code]
    s = max(col for col, _ in b_row) + 1  # stages the step's solution uses
    a = np.zeros((s, s))
    for i, row in enumerate(_A_ROWS[code][:s]):
        for col, value in row:
            a[i, col] = value
    b = np.zeros(s)
    for col, value in b_row:
        b[col] = value
    coef, power = [1.0], np.ones(s)
    for _ in range(s):
        coef.append(float(b @ power))
        power = a @ power
    return np.array(coef)


def step_amplification(method: str, h: Any, eigenvalues: np.ndarray) -> np.ndarray:
    """``|R(h lambda)|`` of one step for each eigenvalue (see :func:`stability_polynomial`)."""
    poly = stability_polynomial(method)[::-1]  # numpy's order: highest power first
    return np.abs(np.polyval(poly, h * np.asarray(eigenvalues, dtype=complex)))


def largest_stable_step(method: str, eigenvalues: np.ndarray, growth: float = 1e-12) -> float:
    """The largest ``h`` with ``|R(h lambda)| <= 1 + growth`` on ``[0, h]`` for every
    eigenvalue given.

    ``eigenvalues``: of a linear(ised) system, each with a real part <= 0 (an eigenvalue
    with a positive real part grows in the true solution too, and is passed over); ``inf``
    when none is nonzero. ``growth``: the spurious growth a step may add (``2^(1/N) - 1``
    keeps it below a factor 2 over ``N`` steps). Found on a grid of ``h |lambda|`` in steps
    of 1/200 up to 20, then bisected to 1e-10 relative: the region's first boundary along
    each ray.
    """
    lam = np.asarray(eigenvalues, dtype=complex).ravel()
    lam = lam[(lam.real <= 0.0) & (np.abs(lam) > 0.0)]
    if lam.size == 0:
        return math.inf

    def unstable(h: np.ndarray) -> np.ndarray:
        return step_amplification(method, h[:, None], lam[None, :]) > 1.0 + growth

    scale = 1.0 / float(np.abs(lam).max())
    grid = np.arange(1, 4001) * (scale / 200.0)
    bad = unstable(grid).any(axis=1)
    if not bad.any():
        return float(grid[-1])
    k = int(np.argmax(bad))
    lo, hi = (float(grid[k - 1]) if k else 0.0), float(grid[k])
    while hi - lo > 1e-10 * hi:
        mid = 0.5 * (lo + hi)
        if unstable(np.array([mid])).any():
            hi = mid
        else:
            lo = mid
    return lo
