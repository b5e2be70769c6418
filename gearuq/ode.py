"""Fast batched adaptive Runge-Kutta integration of many independent ODE samples.

Each sample ``i`` is the initial-value problem ``y' = rhs(t, y, params[i])``,
``y(t0[i]) = y0[i]``, integrated on its own with its own step-size control and written at
the output instants ``t_eval`` by the method's dense output. The outer loop over samples runs
in a compiled numba kernel, optionally in parallel threads over sample blocks (the kernel
releases the GIL); a failing sample never
raises, it records a status code and keeps what it computed.

Methods
-------
``"dopri5"``
    Dormand-Prince 5(4), FSAL, Hairer's 4th-order continuous extension (Hairer, Norsett and
    Wanner, *Solving ODEs I*, II.5 and II.6; code ``DOPRI5``), with Hairer's PI step-size
    controller (beta = 0.04).
``"dop853"``
    Hairer's DOP853: 8th-order solution, 5th/3rd-order combined error estimator, 7th-order
    dense output built from three extra stages only in steps that need it.
``"rk4"``
    The classical 4th-order method, fixed step only (``fixed_step=``); cubic Hermite dense
    output.

How ``rhs`` reaches the compiled kernel
---------------------------------------
The kernel takes ``rhs`` and ``switch`` as numba *first-class function* arguments typed by
the explicit signature ``void(float64, float64[::1], float64[::1], float64[::1])``. The
kernel is therefore compiled once for every right-hand side and cached on disk
(``cache=True``); a new ``rhs`` only costs the compilation of ``rhs`` itself. Passing a
dispatcher as a plain (specialising) argument was tried first: numba 0.68 keys such
specialisations by the dispatcher object, so every process misses the cache, recompiles and
adds a new cache file. The price of the function pointer is that ``rhs`` is not inlined
into the integrator; docs/ode.md gives the measured cost.

Switching surfaces
------------------
With ``switch`` and ``n_switch > 0`` the kernel watches ``n_switch`` switching functions
``g(t, y, p)``. When a component changes sign within a step (tested at the step end, at the
interpolated quarter points, and at the predicted extremum of g where g comes close to the
surface), the first root is located on the dense-output interpolant by Brent's method and
the step is re-taken so that it ends just past the root (re-located on the re-taken step
until it ends within a tolerance of it). This keeps the order of the method for
piecewise-smooth right-hand sides (dead zones, backlash, clearances). With
``freeze_sides=True`` the rhs can read the side of every surface from ``p`` and evaluate all
stages of a step on one side; the trial step is then smooth, error-tested as it is and
truncated at the root on its own interpolant, which halves the cost per event. See
docs/ode.md for the measured accuracy and the limits (grazing contacts).
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass, field
from typing import Any

import numba
import numpy as np
from numba import carray, njit, types
from numba.core.extending import intrinsic

__all__ = [
    "ODEResult",
    "solve_batch",
    "METHODS",
    "STATUS_OK",
    "STATUS_STEP_LIMIT",
    "STATUS_STEP_UNDERFLOW",
    "STATUS_NONFINITE",
    "STATUS_MEANINGS",
]

# Status codes; the same values as gearuq.model (checked by the tests). They are repeated
# here rather than imported so that importing the integrator does not import xarray.
STATUS_OK = 0
STATUS_STEP_LIMIT = 1
STATUS_STEP_UNDERFLOW = 2
STATUS_NONFINITE = 3
STATUS_MEANINGS: dict[int, str] = {
    STATUS_OK: "ok",
    STATUS_STEP_LIMIT: "step_limit_reached",
    STATUS_STEP_UNDERFLOW: "step_size_underflow",
    STATUS_NONFINITE: "non_finite_state",
}

#: Valid values of ``method``; ``"rk4"`` requires ``fixed_step``.
METHODS = ("dopri5", "dop853", "rk4")
_METHOD_CODE = {"dopri5": 0, "dop853": 1, "rk4": 2}
_DOPRI5 = 0
_DOP853 = 1
_RK4 = 2

_EPS = float(np.finfo(np.float64).eps)
#: Smallest rtol accepted: below this the error estimate is dominated by rounding.
RTOL_MIN = 100.0 * _EPS
#: A step below this fraction of |t| counts as a step-size underflow.
_HMIN_REL = 1e-14
#: Root of a switching function: bracket width target relative to the step (plus 4 ulp of t).
_ROOT_XTOL_REL = 1e-12


# --------------------------------------------------------------------------------------------
# Butcher tableaux, stored as sparse rows (CSR) so that one generic stage loop serves every
# method without multiplying by the many zeros of DOP853.
# --------------------------------------------------------------------------------------------

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
_DOPRI5_C = np.array([0.0, 1 / 5, 3 / 10, 4 / 5, 8 / 9, 1.0, 1.0])
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
_RK4_C = np.array([0.0, 0.5, 0.5, 1.0, 1.0])
_RK4_A = ((), ((0, 0.5),), ((1, 0.5),), ((2, 1.0),))
_RK4_B = (((0, 1 / 6), (1, 1 / 3), (2, 1 / 3), (3, 1 / 6)),)

# DOP853 (Hairer's dop853.f, the values as distributed with scipy.integrate). Stages 0..11 are
# the method, stage 12 is f(t + h, y_new), stages 13..15 are the extra dense-output stages.
_DOP853_C = np.array([
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

_D5_A_PTR, _D5_A_IDX, _D5_A_VAL = _csr(_DOPRI5_A)
_D5_B_PTR, _D5_B_IDX, _D5_B_VAL = _csr(_DOPRI5_B)
_D5_E_PTR, _D5_E_IDX, _D5_E_VAL = _csr(_DOPRI5_E)
_D5_D_PTR, _D5_D_IDX, _D5_D_VAL = _csr(_DOPRI5_D)
_R4_A_PTR, _R4_A_IDX, _R4_A_VAL = _csr(_RK4_A)
_R4_B_PTR, _R4_B_IDX, _R4_B_VAL = _csr(_RK4_B)
_D8_A_PTR, _D8_A_IDX, _D8_A_VAL = _csr(_DOP853_A)
_D8_B_PTR, _D8_B_IDX, _D8_B_VAL = _csr(_DOP853_B)
_D8_E3_PTR, _D8_E3_IDX, _D8_E3_VAL = _csr(_DOP853_E3)
_D8_E5_PTR, _D8_E5_IDX, _D8_E5_VAL = _csr(_DOP853_E5)
_D8_D_PTR, _D8_D_IDX, _D8_D_VAL = _csr(_DOP853_D)


# --------------------------------------------------------------------------------------------
# Compiled building blocks. They are plain @njit (no cache): they are compiled into, and
# cached with, the two entry points below, which are the only functions numba has to load.
# --------------------------------------------------------------------------------------------

@intrinsic
def _f64_ptr(typingctx, address):
    """Reinterpret an integer address as a float64 pointer (for numba.carray)."""
    sig = types.CPointer(types.float64)(types.uintp)

    def codegen(context, builder, signature, args):
        return builder.inttoptr(args[0], context.get_value_type(types.CPointer(types.float64)))

    return sig, codegen


@njit(error_model="numpy")
def _view1(buf, offset, n):
    """1-d view of buf[offset:offset + n] without a reference count (see the note below)."""
    return carray(_f64_ptr(buf.ctypes.data + 8 * offset), n)


@njit(error_model="numpy")
def _view2(buf, offset, n0, n1):
    """2-d C-contiguous view of n0 * n1 elements of buf from offset, without a reference count."""
    return carray(_f64_ptr(buf.ctypes.data + 8 * offset), (n0, n1))


# Performance note: the hot loops index 2-d arrays as K[j, i] and never take row views such
# as K[j]. Every view increments and decrements the array's reference count with an atomic
# instruction. For the same reason the work arrays of a sample are views made with
# numba.carray into one buffer: such arrays carry no reference count (meminfo NULL), so passing
# them to rhs/switch (first-class function calls incref and decref every array argument)
# costs no atomic operation. Before this, NRT_incref/NRT_decref took ~45 % of the run time,
# and the counts of arrays shared between threads made the parallel loop no faster than the
# serial one.

@njit(error_model="numpy")
def _combine(out, base, h, K, ptr, idx, val, row):
    """out = base + h * sum_q val[q] * K[idx[q]] over the sparse row ``row``.

    The update runs stage by stage over contiguous rows of K so that it vectorises.
    """
    n = out.size
    for i in range(n):
        out[i] = base[i]
    for q in range(ptr[row], ptr[row + 1]):
        a = h * val[q]
        j = idx[q]
        for i in range(n):
            out[i] += a * K[j, i]


@njit(error_model="numpy")
def _lincomb_row(R, r, h, K, ptr, idx, val, row):
    """R[r] = h * sum_q val[q] * K[idx[q]] over the sparse row ``row``."""
    n = K.shape[1]
    for i in range(n):
        R[r, i] = 0.0
    for q in range(ptr[row], ptr[row + 1]):
        a = h * val[q]
        j = idx[q]
        for i in range(n):
            R[r, i] += a * K[j, i]


@njit(error_model="numpy")
def _lincomb(out, h, K, ptr, idx, val, row):
    """out = h * sum_q val[q] * K[idx[q]] over the sparse row ``row``."""
    n = out.size
    for i in range(n):
        out[i] = 0.0
    for q in range(ptr[row], ptr[row + 1]):
        a = h * val[q]
        j = idx[q]
        for i in range(n):
            out[i] += a * K[j, i]


@njit(error_model="numpy")
def _eval_into(rhs, t, y, p, f, K, s):
    """K[s] = rhs(t, y); rhs writes into the scratch vector f, which is copied (no view)."""
    rhs(t, y, p, f)
    for i in range(f.size):
        K[s, i] = f[i]


@njit(error_model="numpy")
def _copy_into(dst, src):
    for i in range(src.size):
        dst[i] = src[i]
    return dst


@njit(error_model="numpy")
def _row_finite(K, s):
    for i in range(K.shape[1]):
        if not math.isfinite(K[s, i]):
            return False
    return True


@njit(error_model="numpy")
def _stages(rhs, t, y, p, h, K, yt, f, s_lo, s_hi, c, ptr, idx, val):
    """Evaluate stages s_lo..s_hi-1 into the rows of K (stage 0 must already hold f(t, y))."""
    for s in range(s_lo, s_hi):
        _combine(yt, y, h, K, ptr, idx, val, s)
        _eval_into(rhs, t + c[s] * h, yt, p, f, K, s)


@njit(error_model="numpy")
def _all_finite(x):
    for i in range(x.size):
        if not math.isfinite(x[i]):
            return False
    return True


@njit(error_model="numpy")
def _sgn(x):
    """Sign as -1, 0, +1; NaN gives 0 (an unknown side never triggers an event)."""
    if x > 0.0:
        return 1
    if x < 0.0:
        return -1
    return 0


@njit(error_model="numpy")
def _step(rhs, method, t, t_new, y, p, h, K, yt, f, ynew, ev, atol, rtol, want_err):
    """One Runge-Kutta step of size h from (t, y), K[0] = f(t, y) on entry.

    Writes y_new; for dopri5 also K[6] = f(t_new, y_new) (FSAL). Returns (err, n_rhs) with
    err the scaled error norm (Hairer's), or 0 when ``want_err`` is false.
    """
    n = y.size
    err = 0.0
    if method == _DOPRI5:
        _stages(rhs, t, y, p, h, K, yt, f, 1, 6, _DOPRI5_C, _D5_A_PTR, _D5_A_IDX, _D5_A_VAL)
        _combine(ynew, y, h, K, _D5_B_PTR, _D5_B_IDX, _D5_B_VAL, 0)
        # t_new rather than t + h so that the last step ends exactly on t_eval[-1].
        _eval_into(rhs, t_new, ynew, p, f, K, 6)
        nf = 6
        if want_err:
            _lincomb(ev, h, K, _D5_E_PTR, _D5_E_IDX, _D5_E_VAL, 0)
            s = 0.0
            for i in range(n):
                sk = atol[i] + rtol * max(abs(y[i]), abs(ynew[i]))
                # atol = 0 and y = 0: a zero error counts as 0, any other as huge.
                r = ev[i] / max(sk, 1e-300)
                s += r * r
            err = math.sqrt(s / n)
    elif method == _DOP853:
        _stages(rhs, t, y, p, h, K, yt, f, 1, 12, _DOP853_C, _D8_A_PTR, _D8_A_IDX, _D8_A_VAL)
        _combine(ynew, y, h, K, _D8_B_PTR, _D8_B_IDX, _D8_B_VAL, 0)
        nf = 11
        if want_err:
            # Hairer's combined estimator: |h| * e5^2 / sqrt(e5^2 + 0.01 e3^2) (dop853.f).
            _lincomb(ev, 1.0, K, _D8_E5_PTR, _D8_E5_IDX, _D8_E5_VAL, 0)
            _lincomb(yt, 1.0, K, _D8_E3_PTR, _D8_E3_IDX, _D8_E3_VAL, 0)
            e5 = 0.0
            e3 = 0.0
            for i in range(n):
                sk = max(atol[i] + rtol * max(abs(y[i]), abs(ynew[i])), 1e-300)
                r5 = ev[i] / sk
                r3 = yt[i] / sk
                e5 += r5 * r5
                e3 += r3 * r3
            deno = e5 + 0.01 * e3
            if deno <= 0.0:
                deno = 1.0
            err = abs(h) * e5 * math.sqrt(1.0 / (n * deno))
    else:
        _stages(rhs, t, y, p, h, K, yt, f, 1, 4, _RK4_C, _R4_A_PTR, _R4_A_IDX, _R4_A_VAL)
        _combine(ynew, y, h, K, _R4_B_PTR, _R4_B_IDX, _R4_B_VAL, 0)
        nf = 3
    return err, nf


@njit(error_model="numpy")
def _dense_prepare(rhs, method, t, y, p, h, K, yt, f, ynew, kf, R, full):
    """Fill the rows of the interpolant of the step [t, t + h].

    All three methods share the form
    ``u(t + theta h) = y + theta*(R0 + (1-theta)*(R1 + theta*(R2 + (1-theta)*(R3 + ...))))``.
    R0..R2 of dop853 and rk4 are the cubic Hermite interpolant (cheap); ``full`` adds the
    four 7th-order rows of dop853, which cost three extra rhs calls. Returns (rows, n_rhs).
    """
    n = y.size
    if method == _DOPRI5:
        for i in range(n):
            d = ynew[i] - y[i]
            b = h * K[0, i] - d
            R[0, i] = d
            R[1, i] = b
            R[2, i] = d - h * K[6, i] - b
        _lincomb_row(R, 3, h, K, _D5_D_PTR, _D5_D_IDX, _D5_D_VAL, 0)
        return 4, 0
    for i in range(n):
        d = ynew[i] - y[i]
        R[0, i] = d
        R[1, i] = h * K[0, i] - d
        R[2, i] = 2.0 * d - h * (K[kf, i] + K[0, i])
    if method == _DOP853 and full:
        _stages(rhs, t, y, p, h, K, yt, f, 13, 16, _DOP853_C, _D8_A_PTR, _D8_A_IDX, _D8_A_VAL)
        for r in range(4):
            _lincomb_row(R, 3 + r, h, K, _D8_D_PTR, _D8_D_IDX, _D8_D_VAL, r)
        return 7, 3
    return 3, 0


@njit(error_model="numpy")
def _dense_eval(R, m, y, theta, out):
    """Evaluate the interpolant with m rows at theta in [0, 1] (all components).

    Horner over the rows with the component loop innermost, so that it vectorises.
    """
    n = y.size
    om = 1.0 - theta
    for i in range(n):
        out[i] = R[m - 1, i]
    for r in range(m - 2, -1, -1):
        # After an even row the factor is (1 - theta), after an odd row theta.
        f = om if r % 2 == 0 else theta
        for i in range(n):
            out[i] = R[r, i] + f * out[i]
    for i in range(n):
        out[i] = y[i] + theta * out[i]


@njit(error_model="numpy")
def _dense_eval_save(R, m, y, theta, save, out, j):
    """Evaluate the interpolant only at the stored components ``save``."""
    om = 1.0 - theta
    for k in range(save.size):
        i = save[k]
        acc = R[m - 1, i]
        for r in range(m - 2, -1, -1):
            acc = R[r, i] + (om if r % 2 == 0 else theta) * acc
        out[j, k] = y[i] + theta * acc


@njit(error_model="numpy")
def _hinit(rhs, t, y, p, f0, order, hmax, rtol, atol, y1, f1):
    """Hairer's initial step-size estimate (HINIT in dopri5.f / dop853.f)."""
    n = y.size
    dnf = 0.0
    dny = 0.0
    for i in range(n):
        sk = max(atol[i] + rtol * abs(y[i]), 1e-300)
        dnf += (f0[i] / sk) ** 2
        dny += (y[i] / sk) ** 2
    if dnf <= 1e-10 or dny <= 1e-10:
        h = 1e-6
    else:
        h = math.sqrt(dny / dnf) * 0.01
    h = min(h, hmax)
    for i in range(n):
        y1[i] = y[i] + h * f0[i]
    rhs(t + h, y1, p, f1)
    der2 = 0.0
    for i in range(n):
        sk = max(atol[i] + rtol * abs(y[i]), 1e-300)
        der2 += ((f1[i] - f0[i]) / sk) ** 2
    der2 = math.sqrt(der2) / h
    der12 = max(abs(der2), math.sqrt(dnf))
    if not math.isfinite(der12):
        # f blows up along the Euler step: start small and let the controller work it out.
        return h * 1e-3
    if der12 <= 1e-15:
        h1 = max(1e-6, h * 1e-3)
    else:
        h1 = (0.01 / der12) ** (1.0 / order)
    return min(100.0 * h, h1, hmax)


@njit(error_model="numpy")
def _crossing(sgn, g, n_switch):
    """True when some component of g lies strictly on the other side of its known sign."""
    for s in range(n_switch):
        sg = _sgn(g[s])
        if sgn[s] != 0 and sg != 0 and sg != sgn[s]:
            return True
    return False


@njit(error_model="numpy")
def _g_at(switch, R, m, y, t, h, p, tau, ym, g):
    """g(tau, u(tau)) on the interpolant of the step [t, t + h]; writes g, returns nothing."""
    _dense_eval(R, m, y, (tau - t) / h, ym)
    switch(tau, ym, p, g)


@njit(error_model="numpy")
def _root_bracket(switch, R, m, y, t, h, p, ym, gw, comp, old, ta, fa, tb, fb, xtol):
    """Brent's method (port of scipy's brentq.c) for switching component ``comp``.

    On entry g_comp(ta) lies on side ``old`` (or is zero) and g_comp(tb) strictly on the other
    side. An exact zero counts as "not yet crossed" (it is replaced by a tiny value of sign
    ``old``), so the bracket always keeps one end strictly on the new side. Returns
    ``(lo, hi)``: lo on the old side, hi on the new side, |hi - lo| <= xtol + 4 ulp(t).
    """
    tiny = old * 1e-300
    if fa == 0.0:
        fa = tiny
    xpre = ta
    xcur = tb
    fpre = fa
    fcur = fb
    xblk = 0.0
    fblk = 0.0
    spre = 0.0
    scur = 0.0
    for _ in range(200):
        if (fpre > 0.0) != (fcur > 0.0):
            xblk = xpre
            fblk = fpre
            spre = xcur - xpre
            scur = spre
        if abs(fblk) < abs(fcur):
            xpre = xcur
            xcur = xblk
            xblk = xpre
            fpre = fcur
            fcur = fblk
            fblk = fpre
        delta = 0.5 * (xtol + 4.0 * _EPS * abs(xcur))
        sbis = 0.5 * (xblk - xcur)
        if abs(sbis) < delta:
            break
        if abs(spre) > delta and abs(fcur) < abs(fpre):
            if xpre == xblk:
                stry = -fcur * (xcur - xpre) / (fcur - fpre)
            else:
                dpre = (fpre - fcur) / (xpre - xcur)
                dblk = (fblk - fcur) / (xblk - xcur)
                stry = -fcur * (fblk * dblk - fpre * dpre) / (dblk * dpre * (fblk - fpre))
            if 2.0 * abs(stry) < min(abs(spre), 3.0 * abs(sbis) - delta):
                spre = scur
                scur = stry
            else:
                spre = sbis
                scur = sbis
        else:
            spre = sbis
            scur = sbis
        xpre = xcur
        fpre = fcur
        if abs(scur) > delta:
            xcur += scur
        else:
            xcur += delta if sbis > 0.0 else -delta
        _g_at(switch, R, m, y, t, h, p, xcur, ym, gw)
        fcur = gw[comp]
        if fcur == 0.0 or not math.isfinite(fcur):
            fcur = tiny
    # xcur and xblk are on opposite sides; report which one is past the surface.
    if _sgn(fcur) == old:
        return xcur, xblk
    return xblk, xcur


@njit(error_model="numpy")
def _overshoot_tol(K, kf, y, atol, rtol, hs):
    """How far past a surface a step may end: the time in which y moves by one tolerance unit.

    1 / RMS(f_i / (atol_i + rtol |y_i|)) with f = K[kf] = f(t_new, y): ending that far past a
    jump of rhs of the size of f costs about one unit of the local error tolerance, and far
    less at a kink (O(overshoot^2)). Capped at 1e-3 * hs for a state at rest.
    """
    n = y.size
    s = 0.0
    for i in range(n):
        r = K[kf, i] / max(atol[i] + rtol * abs(y[i]), 1e-300)
        s += r * r
    cap = 1e-3 * hs
    if s * cap * cap <= n:
        return cap
    return math.sqrt(n / s)


@njit(error_model="numpy")
def _write_state(y, save, out, j):
    for k in range(save.size):
        out[j, k] = y[save[k]]


@njit(error_model="numpy")
def _find_crossing(switch, R, m, y, t, hs, p, t_base, g_base, t_new, g1, sgn, n_switch, ym, gs,
                   ga, gb, gw, detect_only, dt_ok):
    """First sign change of the switching functions in (t_base, t_new] of the current step.

    g is sampled on the interpolant at the quarter points of (t_base, t_new] and at the end
    (gs rows 0..4, row 0 = g_base). Where the parabola through three consecutive samples of a
    component that keeps its side has its extremum between them and comes within a quarter
    of the way to the surface, g is sampled once more at that extremum: that catches an
    excursion across the surface and back between two samples.

    Returns ``(comp, tb)``: comp = -1 when no crossing was found; otherwise the component
    whose root comes first and the end of its root bracket that lies past the surface. With
    ``detect_only`` the roots are not located (comp = 0 then just means "some crossing"). A
    root closer than ``dt_ok`` to the end of its bracket is accepted without a search.
    """
    span = t_new - t_base
    for s in range(n_switch):
        gs[0, s] = g_base[s]
        gs[4, s] = g1[s]
    for k in range(1, 4):
        _g_at(switch, R, m, y, t, hs, p, t_base + 0.25 * k * span, ym, gw)
        for s in range(n_switch):
            gs[k, s] = gw[s]
    # First quarter with a sign change.
    kc = 5
    for k in range(1, 5):
        for s in range(n_switch):
            sg = _sgn(gs[k, s])
            if sgn[s] != 0 and sg != 0 and sg != sgn[s]:
                kc = k
                break
        if kc < 5:
            break
    ta = t_base + 0.25 * (kc - 1) * span
    tb = t_new if kc >= 4 else t_base + 0.25 * kc * span
    found = kc < 5
    if found:
        for s in range(n_switch):
            ga[s] = gs[kc - 1, s]
            gb[s] = gs[kc, s]
    # Excursions between samples, before the first quarter with a sign change.
    for k in range(1, min(kc - 1, 4)):
        for s in range(n_switch):
            if sgn[s] == 0:
                continue
            # Distances to the surface (positive on the current side) at samples k-1, k, k+1.
            a0 = gs[k - 1, s] * sgn[s]
            a1 = gs[k, s] * sgn[s]
            a2 = gs[k + 1, s] * sgn[s]
            c1 = 0.5 * (a2 - a0)
            c2 = 0.5 * (a0 + a2) - a1
            if not (a0 > 0.0 and a1 > 0.0 and a2 > 0.0 and c2 > 0.0):
                continue
            uv = -c1 / (2.0 * c2)  # minimum of the parabola, in quarters from sample k
            if abs(uv) > 1.0 or a1 - c1 * c1 / (4.0 * c2) >= 0.25 * min(a0, a1, a2):
                continue
            tv = t_base + 0.25 * (k + uv) * span
            if found and tv >= tb:
                continue
            _g_at(switch, R, m, y, t, hs, p, tv, ym, gw)
            if _sgn(gw[s]) == -sgn[s]:
                found = True
                ta = t_base + 0.25 * (k - 1) * span
                tb = tv
                for q in range(n_switch):
                    ga[q] = gs[k - 1, q]
                    gb[q] = gw[q]
    if not found:
        return -1, t_new
    if detect_only:
        return 0, t_new
    xtol = _ROOT_XTOL_REL * hs
    first = -1
    for s in range(n_switch):
        sg = _sgn(gb[s])
        if sgn[s] == 0 or sg == 0 or sg == sgn[s]:
            continue
        if _sgn(ga[s]) == -sgn[s]:
            # Already past the surface at ta (possible only at t_base, e.g. two surfaces that
            # coincide): its root is at ta, within the tolerance of an earlier one.
            hi = ta
        else:
            # Probe just before tb first: after a step has been cut at a root, that root lies
            # within tolerance of the step end, and the probe confirms it without a search.
            tp = tb - max(0.5 * (xtol + 4.0 * _EPS * abs(tb)), dt_ok)
            if tp <= ta:
                hi = tb
            else:
                _g_at(switch, R, m, y, t, hs, p, tp, ym, gw)
                fp = gw[s]
                if _sgn(fp) != -sgn[s]:
                    hi = tb
                else:
                    _lo, hi = _root_bracket(switch, R, m, y, t, hs, p, ym, gw, s, sgn[s], ta,
                                            ga[s], tp, fp, xtol)
        if first < 0 or hi < tb:
            first = s
            if hi < tb:
                # Later components only need to be searched before this root.
                tb = hi
                _g_at(switch, R, m, y, t, hs, p, tb, ym, gb)
    return first, tb


@njit(error_model="numpy")
def _integrate_one(rhs, switch, method, y0, p, t0, te, save, out, rtol, atol, max_step,
                   first_step, max_steps, fixed_h, n_switch, freeze, cnt):
    """Integrate one sample from t0 over the output instants te; returns its status.

    out (n_t, n_save) is pre-filled with NaN by the caller: rows not reached stay NaN.
    cnt receives (accepted steps, rejected steps, rhs calls, switching events).
    """
    n = y0.size
    nt = te.size
    adaptive = fixed_h <= 0.0
    # Hairer's controller constants: safety, step-ratio limits [fac1, fac2], PI beta.
    safe = 0.9
    if method == _DOPRI5:
        nk, kf, m_full, order, fac1, fac2, beta = 7, 6, 4, 5, 0.2, 10.0, 0.04
    elif method == _DOP853:
        nk, kf, m_full, order, fac1, fac2, beta = 16, 12, 7, 8, 0.333, 6.0, 0.0
    else:
        nk, kf, m_full, order, fac1, fac2, beta = 5, 4, 3, 4, 0.2, 10.0, 0.0
    expo1 = 1.0 / order - 0.75 * beta
    facc1 = 1.0 / fac1
    facc2 = 1.0 / fac2

    # All float work arrays are reference-count-free views into one buffer (see the note at
    # _combine); p and atol are private copies, so no thread touches a shared count.
    ns = max(n_switch, 1)
    npar = p.size
    # With frozen sides, p is extended by the side (+1/-1, 0 unknown) of every switching
    # function at the step start, so that the rhs can pick its branch from them.
    n_side = n_switch if freeze else 0
    work = np.zeros(8 * n + (nk + 7) * n + 11 * ns + npar + n_side)
    y = _view1(work, 0, n)
    f = _view1(work, n, n)
    ynew = _view1(work, 2 * n, n)
    yt = _view1(work, 3 * n, n)
    ym = _view1(work, 4 * n, n)
    ev = _view1(work, 5 * n, n)
    atol = _copy_into(_view1(work, 6 * n, n), atol)
    K = _view2(work, 8 * n, nk, n)
    R = _view2(work, (8 + nk) * n, 7, n)
    o = (nk + 15) * n
    g0 = _view1(work, o, ns)  # g at the current accepted state
    g1 = _view1(work, o + ns, ns)  # g at the end of the step being taken
    g_base = _view1(work, o + 2 * ns, ns)
    ga = _view1(work, o + 3 * ns, ns)
    gb = _view1(work, o + 4 * ns, ns)
    gw = _view1(work, o + 5 * ns, ns)
    gs = _view2(work, o + 6 * ns, 5, ns)  # samples of g within a step (_find_crossing)
    p = _copy_into(_view1(work, o + 11 * ns, npar + n_side), p)
    for i in range(n):
        y[i] = y0[i]
    te = _view1(te, 0, nt)
    out = _view2(out, 0, nt, save.size)
    save = save.copy()
    sgn = np.zeros(ns, dtype=np.int64)  # last non-zero side of each switching function

    n_acc = 0
    n_rej = 0
    n_att = 0
    n_rhs = 0
    n_ev = 0
    status = STATUS_OK

    t = t0
    t_end = te[nt - 1]
    j = 0
    while j < nt and te[j] <= t:
        _write_state(y, save, out, j)
        j += 1

    if j < nt:
        _eval_into(rhs, t, y, p, f, K, 0)
        n_rhs += 1
        if not _row_finite(K, 0):
            status = STATUS_NONFINITE
    if status == STATUS_OK and j < nt:
        if n_switch > 0:
            switch(t, y, p, g0)
            for s in range(n_switch):
                sgn[s] = _sgn(g0[s])
                if freeze:
                    p[npar + s] = sgn[s]
        if adaptive:
            hmax = min(max_step, t_end - t)
            if first_step > 0.0:
                h = min(first_step, hmax)
            else:
                h = _hinit(rhs, t, y, p, f, order, hmax, rtol, atol, yt, ym)
                n_rhs += 1
        else:
            h = fixed_h
        facold = 1e-4
        last_rejected = False
        nonfinite_reject = False
        while True:
            if n_att >= max_steps:
                status = STATUS_STEP_LIMIT
                break
            if adaptive:
                h = min(h, max_step)
                if not h > _HMIN_REL * abs(t):
                    status = STATUS_NONFINITE if nonfinite_reject else STATUS_STEP_UNDERFLOW
                    break
                # Hairer: stretch the step by up to 1 % rather than leave a sliver at the end.
                last = t + 1.01 * h >= t_end
            else:
                last = t + (1.0 + 1e-9) * h >= t_end
            if last:
                h = t_end - t
                t_new = t_end
            else:
                t_new = t + h
            h_trial = h
            hs = h
            tb = t_new  # end of the step as cut at a switching surface

            # ---- trial step, then (with switching functions) cut it at the first crossing.
            # Without frozen sides the cut comes before the error test (a step across a kink
            # has a large error estimate, and testing it first would cost a cascade of
            # rejections per kink) and the step is re-taken up to the root. With frozen sides
            # the trial integrates one smooth field, so it is error-tested as it is and, if
            # accepted, truncated at the root on its own interpolant (no re-take).
            shortened = False
            hd = hs  # size of the step the interpolant R belongs to
            finite = True
            dense_rows = 0  # rows of the interpolant filled for the current step (0: none)
            for attempt in range(9):
                if attempt > 0:
                    # Redo the step: cut so that it ends just past the located root, or
                    # unchanged after a side flip at its start (frozen sides).
                    if tb < t_new:
                        shortened = True
                    t_new = tb
                    hs = t_new - t
                    hd = hs
                    dense_rows = 0
                err, nf = _step(rhs, method, t, t_new, y, p, hs, K, yt, f, ynew, ev, atol, rtol,
                                adaptive)
                n_rhs += nf
                n_att += 1
                finite = math.isfinite(err) and _all_finite(ynew)
                if finite and method != _DOPRI5:
                    _eval_into(rhs, t_new, ynew, p, f, K, kf)
                    n_rhs += 1
                finite = finite and _row_finite(K, kf)
                if not finite or n_switch == 0 or (freeze and adaptive and err > 1.0):
                    break
                switch(t_new, ynew, p, g1)
                t_base = t
                for s in range(n_switch):
                    g_base[s] = g0[s]
                first = -1
                redo = False
                dt_ok = 0.0
                for _sub in range(n_switch + 1):
                    if dense_rows == 0:
                        dense_rows, nf = _dense_prepare(rhs, method, t, y, p, hs, K, yt, f, ynew,
                                                        kf, R, False)
                        n_rhs += nf
                    if dense_rows < m_full:
                        # dop853: cheap Hermite test first, the 7th-order rows only on a hit.
                        first, tb = _find_crossing(switch, R, dense_rows, y, t, hs, p, t_base,
                                                   g_base, t_new, g1, sgn, n_switch, ym, gs,
                                                   ga, gb, gw, True, 0.0)
                        if first < 0:
                            break
                        dense_rows, nf = _dense_prepare(rhs, method, t, y, p, hs, K, yt, f, ynew,
                                                        kf, R, True)
                        n_rhs += nf
                    dt_ok = _overshoot_tol(K, kf, ynew, atol, rtol, hs)
                    first, tb = _find_crossing(switch, R, dense_rows, y, t, hs, p, t_base,
                                               g_base, t_new, g1, sgn, n_switch, ym, gs, ga,
                                               gb, gw, False, dt_ok)
                    if first < 0:
                        break
                    tol = 2.0 * (_ROOT_XTOL_REL * hs + 4.0 * _EPS * abs(tb))
                    if tb - t_base > tol:
                        break
                    # A crossing within root tolerance of the step start (the previous step
                    # ended a hair short of the surface): register it at the accepted state
                    # and look for further crossings in the rest of the step.
                    n_ev += 1
                    sgn[first] = -sgn[first]
                    g0[first] = 0.0
                    if freeze:
                        # The step was computed on the old side: redo it on the new one.
                        p[npar + first] = sgn[first]
                        redo = True
                        break
                    t_base = tb
                    _g_at(switch, R, dense_rows, y, t, hs, p, t_base, ym, g_base)
                    first = -1
                if redo:
                    tb = t_new
                    continue
                if freeze and first >= 0 and t_new - tb > max(
                        dt_ok, 2.0 * (_ROOT_XTOL_REL * hs + 4.0 * _EPS * abs(tb))):
                    # Truncate the accepted trial at the root: the end state is the (error
                    # controlled) interpolant there, and f is evaluated afresh at it.
                    _dense_eval(R, dense_rows, y, (tb - t) / hd, ynew)
                    t_new = tb
                    hs = t_new - t
                    _eval_into(rhs, t_new, ynew, p, f, K, kf)
                    n_rhs += 1
                    finite = _all_finite(ynew) and _row_finite(K, kf)
                    switch(t_new, ynew, p, g1)
                    break
                # No crossing, or the step already ends just past the first root (by at most
                # dt_ok, see _overshoot_tol).
                if first < 0 or t_new - tb <= max(
                        dt_ok, 2.0 * (_ROOT_XTOL_REL * hs + 4.0 * _EPS * abs(tb))):
                    break

            if not finite:
                if adaptive:
                    # Overflow or NaN inside the step: shrink hard and retry. If it never
                    # recovers, the step size underflows and the status says non-finite.
                    n_rej += 1
                    h = hs * fac1
                    last_rejected = True
                    nonfinite_reject = True
                    continue
                status = STATUS_NONFINITE
                break

            if adaptive:
                fac11 = err ** expo1
                fac = fac11 / facold ** beta
                fac = max(facc2, min(facc1, fac / safe))
                # hd: the size of the step err belongs to (a truncated step keeps its trial's).
                hnew = hd / fac
                if err > 1.0:
                    n_rej += 1
                    h = hd / min(facc1, fac11 / safe)
                    last_rejected = True
                    nonfinite_reject = False
                    continue

            # ---- the step [t, t_new] is accepted
            if n_switch > 0:
                # Register the sides reached at the step end. The stage f(t_new, y_new) that
                # starts the next step is already the new side's: a re-taken step evaluates
                # it at its end, past the surface, and a truncated one evaluates it afresh.
                for s in range(n_switch):
                    sg = _sgn(g1[s])
                    if sg != 0:
                        if sgn[s] != 0 and sg != sgn[s]:
                            n_ev += 1
                        sgn[s] = sg
                        if freeze:
                            p[npar + s] = sg

            # ---- output instants inside (t, t_new] by dense output
            while j < nt and te[j] <= t_new:
                if te[j] == t_new:
                    _write_state(ynew, save, out, j)
                else:
                    if dense_rows < m_full:
                        # (never for a truncated step: its rows were completed to find the root)
                        dense_rows, nf = _dense_prepare(rhs, method, t, y, p, hs, K, yt, f, ynew,
                                                        kf, R, True)
                        n_rhs += nf
                    _dense_eval_save(R, dense_rows, y, (te[j] - t) / hd, save, out, j)
                j += 1

            n_acc += 1
            t = t_new
            for i in range(n):
                y[i] = ynew[i]
                K[0, i] = K[kf, i]
            for s in range(n_switch):
                g0[s] = g1[s]
            if j >= nt:
                break
            if adaptive:
                facold = max(err, 1e-4)
                if last_rejected:
                    # Hairer: no step growth right after a rejection.
                    hnew = min(hnew, hd)
                if shortened:
                    # A step cut at a surface says nothing about the step size beyond it; the
                    # size proposed before the cut does.
                    hnew = max(hnew, h_trial)
                last_rejected = False
                nonfinite_reject = False
                h = hnew
            else:
                h = fixed_h

    cnt[0] = n_acc
    cnt[1] = n_rej
    cnt[2] = n_rhs
    cnt[3] = n_ev
    # The views above do not own their memory: keep the buffer alive up to here.
    work[0] = 0.0
    return status


# --------------------------------------------------------------------------------------------
# Entry points: compiled once (explicit signature, first-class function arguments) and cached.
# --------------------------------------------------------------------------------------------

_F1 = types.float64[::1]
#: numba signature every ``rhs`` and ``switch`` must compile to.
RHS_SIGNATURE = types.void(types.float64, _F1, _F1, _F1)
_FN = types.FunctionType(RHS_SIGNATURE)
_KERNEL_SIGNATURE = types.void(
    _FN, _FN, types.int64,
    types.float64[:, ::1], types.float64[:, ::1], _F1, types.float64[:, ::1],
    types.int64[::1], types.float64[:, :, ::1],
    types.float64, _F1, types.float64, types.float64, types.int64, types.float64,
    types.int64, types.boolean, types.int8[::1], types.int64[:, ::1],
)


def _solve_serial(rhs, switch, method, Y0, P, T0, TE, save, out, rtol, atol, max_step,
                  first_step, max_steps, fixed_h, n_switch, freeze, status, counts):
    """Serial loop over the samples (TE has one row shared by all, or one row per sample)."""
    for i in range(Y0.shape[0]):
        te = TE[0] if TE.shape[0] == 1 else TE[i]
        status[i] = _integrate_one(rhs, switch, method, Y0[i], P[i], T0[i], te, save, out[i],
                                   rtol, atol, max_step, first_step, max_steps, fixed_h,
                                   n_switch, freeze, counts[i])


_KERNEL: list[Any] = []


def _get_kernel(parallel: bool = False) -> Any:
    """Return the compiled entry point, compiling it (or loading it from the cache) once.

    Compilation is deferred to the first use so that ``import gearuq.ode`` stays cheap. There
    is one kernel, compiled with ``nogil=True``: ``parallel=True`` runs it in Python threads
    over blocks of samples (see :func:`_run_threads`) instead of a numba ``prange`` variant,
    whose parfor compilation alone cost ~16 s on a cold cache against ~12 s for this kernel.
    ``parallel`` is accepted for backward compatibility and ignored.
    """
    if not _KERNEL:
        _KERNEL.append(njit(_KERNEL_SIGNATURE, cache=True, nogil=True,
                            error_model="numpy")(_solve_serial))
    return _KERNEL[0]


def _run_threads(kernel: Any, args: tuple, n_samples: int, n_threads: int) -> None:
    """Run ``kernel`` over sample blocks in ``n_threads`` threads (the kernel drops the GIL).

    Samples share nothing and every block writes only its own rows of ``out``, ``status``
    and ``counts``, so results are bit-identical to one serial call. More blocks than
    threads balance samples of unequal cost (contact loss, stiff draws).
    """
    from concurrent.futures import ThreadPoolExecutor

    (rhs, switch, method, y0, p, t0, te, save, out, rtol, atol, max_step, first_step,
     max_steps, fixed_h, n_switch, freeze, status, counts) = args
    n_blocks = min(n_samples, 8 * n_threads)
    edges = np.linspace(0, n_samples, n_blocks + 1).astype(np.int64)

    def block(k: int) -> None:
        sl = slice(int(edges[k]), int(edges[k + 1]))
        kernel(rhs, switch, method, y0[sl], p[sl], t0[sl], te if te.shape[0] == 1 else te[sl],
               save, out[sl], rtol, atol, max_step, first_step, max_steps, fixed_h, n_switch,
               freeze, status[sl], counts[sl])

    with ThreadPoolExecutor(max_workers=n_threads) as pool:
        for future in [pool.submit(block, k) for k in range(n_blocks)]:
            future.result()


@njit(RHS_SIGNATURE, cache=True)
def _no_switch(t, y, p, g):  # pragma: no cover - never called (n_switch = 0)
    pass


# --------------------------------------------------------------------------------------------
# Python front end
# --------------------------------------------------------------------------------------------

@dataclass
class ODEResult:
    """Outputs of :func:`solve_batch`.

    Attributes
    ----------
    y : ndarray, shape (n_samples, n_t, n_save)
        States at the output instants, only the components listed in ``save``. NaN after
        the instant at which a sample failed.
    t : ndarray, shape (n_t,) or (n_samples, n_t)
        The output instants as given.
    status : ndarray of int8, shape (n_samples,)
        ``STATUS_OK`` (0), ``STATUS_STEP_LIMIT`` (1), ``STATUS_STEP_UNDERFLOW`` (2) or
        ``STATUS_NONFINITE`` (3), see :data:`STATUS_MEANINGS`.
    n_steps, n_rejected, n_rhs, n_events : ndarray of int64, shape (n_samples,)
        Accepted steps, rejected steps (error test or non-finite stage), calls of ``rhs``
        and registered sign changes of switching functions.
    method : str
    rtol : float
    atol : float or ndarray
    save : ndarray of int64
        State indices stored in ``y``.
    options : dict
        The remaining settings (see :meth:`settings`).
    """

    y: np.ndarray
    t: np.ndarray
    status: np.ndarray
    n_steps: np.ndarray
    n_rejected: np.ndarray
    n_rhs: np.ndarray
    n_events: np.ndarray
    method: str
    rtol: float
    atol: float | np.ndarray
    save: np.ndarray
    options: dict[str, Any] = field(default_factory=dict)

    @property
    def ok(self) -> np.ndarray:
        """Boolean mask of the samples that reached the last output instant."""
        return self.status == STATUS_OK

    def settings(self) -> dict[str, Any]:
        """Return the solver settings as a JSON-serialisable dict (for provenance)."""
        atol = self.atol.tolist() if isinstance(self.atol, np.ndarray) else float(self.atol)
        return {
            "solver": "gearuq.ode.solve_batch",
            "method": self.method,
            "rtol": float(self.rtol),
            "atol": atol,
            "save": self.save.tolist(),
            **self.options,
            "numba_version": numba.__version__,
        }


def _fail(name: str, value: Any, expected: str) -> ValueError:
    text = repr(value)
    if len(text) > 80:
        text = text[:77] + "..."
    return ValueError(f"solve_batch: {name}={text} is invalid: {expected}")


def _check_numba_function(fn: Any, name: str) -> None:
    from numba.core.ccallback import CFunc
    from numba.core.registry import CPUDispatcher

    if not isinstance(fn, CPUDispatcher | CFunc):
        raise TypeError(
            f"solve_batch: {name} must be a numba @njit function "
            f"{name}(t, y, p, out) -> None writing into out, got {type(fn).__name__}"
        )


def _probe(fn: Any, name: str, t: float, y: np.ndarray, p: np.ndarray, n_out: int) -> np.ndarray:
    """Call fn once from Python so that signature problems surface as a clear TypeError."""
    out = np.zeros(n_out)
    try:
        ret = fn(float(t), np.ascontiguousarray(y, dtype=np.float64),
                 np.ascontiguousarray(p, dtype=np.float64), out)
    except numba.core.errors.TypingError as exc:
        raise TypeError(
            f"solve_batch: {name} does not compile for "
            f"{name}(t: float64, y: float64[::1], p: float64[::1], out: float64[::1]) -> None:"
            f"\n{exc}"
        ) from exc
    if ret is not None:
        raise TypeError(
            f"solve_batch: {name} returned {type(ret).__name__}; it must return None and "
            "write its values into its last argument"
        )
    return out


def _as_float_array(x: Any, name: str) -> np.ndarray:
    try:
        a = np.asarray(x, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise _fail(name, x, "must be convertible to a float64 array") from exc
    # ascontiguousarray would turn a 0-d array into shape (1,): keep scalars as they are.
    return a if a.ndim == 0 else np.ascontiguousarray(a)


def _first_bad_row(a: np.ndarray) -> int:
    return int(np.nonzero(~np.isfinite(a).reshape(a.shape[0], -1).all(axis=1))[0][0])


def solve_batch(
    rhs: Any,
    y0: Any,
    params: Any,
    t_eval: Any,
    *,
    t0: float | Any = 0.0,
    method: str = "dopri5",
    rtol: float = 1e-6,
    atol: float | Any = 1e-9,
    max_step: float = np.inf,
    first_step: float = 0.0,
    max_steps: int = 1_000_000,
    fixed_step: float | None = None,
    switch: Any = None,
    n_switch: int = 0,
    save: Any = None,
    parallel: bool = True,
    freeze_sides: bool = False,
) -> ODEResult:
    """Integrate many independent ODE samples with an embedded Runge-Kutta method.

    Sample ``i`` solves ``y' = rhs(t, y, params[i])``, ``y(t0_i) = y0[i]`` and is stored at
    its output instants by dense output (the steps are chosen by the error control alone,
    not by the output grid).

    Parameters
    ----------
    rhs : numba dispatcher
        ``@njit`` function ``rhs(t, y, p, dydt) -> None`` writing dy/dt into ``dydt``. It
        must compile for ``(float64, float64[::1], float64[::1], float64[::1])``. Decorate
        it with ``cache=True`` to skip its compilation in later processes, and with
        ``error_model="numpy"`` so that a division by zero yields inf/nan (that sample then
        stops with ``STATUS_NONFINITE``) instead of raising and aborting the batch.
    y0 : array_like, shape (n_samples, n_state)
        Initial states; must be finite.
    params : array_like, shape (n_samples, n_par)
        Row ``i`` is passed to ``rhs`` as ``p`` for sample ``i`` (``n_par`` may be 0).
    t_eval : array_like, shape (n_t,) or (n_samples, n_t)
        Output instants, strictly increasing, shared or per sample. The integration of a
        sample ends at its last instant.
    t0 : float or array_like of shape (n_samples,), optional
        Start time(s), not after the first output instant.
    method : {"dopri5", "dop853", "rk4"}, optional
        ``"rk4"`` only with ``fixed_step``.
    rtol : float, optional
        Relative tolerance, in [100 eps, 1).
    atol : float or array_like of shape (n_state,), optional
        Absolute tolerance(s), >= 0. The local error of component k is kept below
        ``atol[k] + rtol * |y_k|`` in Hairer's RMS norm.
    max_step : float, optional
        Upper bound of the step size (> 0). Also the way to bound how far a pair of
        switching-surface crossings can hide inside one step (see Notes).
    first_step : float, optional
        Initial step; 0 selects Hairer's automatic estimate.
    max_steps : int, optional
        Bound on step attempts per sample (accepted, rejected and event re-takes); a sample
        that reaches it stops with ``STATUS_STEP_LIMIT``.
    fixed_step : float, optional
        Step size of fixed-step mode (no error control, dense output still used at
        ``t_eval``; the last step is shortened to end at ``t_eval[-1]``).
    switch : numba dispatcher, optional
        ``@njit`` function ``switch(t, y, p, g) -> None`` writing the ``n_switch`` values of
        the switching functions into ``g``. Steps are cut at their sign changes.
    n_switch : int, optional
        Number of switching functions; required > 0 with ``switch``.
    save : array_like of int, optional
        State indices to store (default: all). Only these are interpolated and returned.
    parallel : bool, optional
        Run blocks of samples in parallel threads (one per core; the compiled kernel
        releases the GIL). Results are bit-identical
        to ``parallel=False`` because samples do not interact.
    freeze_sides : bool, optional
        With ``switch``: pass ``rhs`` and ``switch`` a parameter vector extended by
        ``n_switch`` entries, ``p[n_par + k]`` = side of switching function k at the start
        of the current step (+1.0 or -1.0; 0.0 while unknown because g was exactly 0). They
        stay constant within a step and flip only at located crossings. An ``rhs`` that
        picks its branch from them (falling back to the state when the side is 0) sees one
        smooth vector field per step, so no Runge-Kutta stage straddles a surface; see
        docs/ode.md for why this matters most for dop853.

    Returns
    -------
    ODEResult

    Raises
    ------
    ValueError
        On invalid arguments; the message names the argument, its value and the valid range.
    TypeError
        When ``rhs`` or ``switch`` is not a numba function of the required signature.
    RuntimeError
        When ``rhs`` or ``switch`` raised inside the kernel (e.g. ZeroDivisionError under
        numba's default error model); use ``@njit(error_model="numpy")`` to avoid it.

    Notes
    -----
    A sample that fails keeps the outputs computed before the failure; later rows of ``y``
    are NaN and ``status`` tells why. Failures never raise and never affect other samples.

    Event location finds a crossing when a switching function has changed sign at the end
    of a step, at one of its interpolated quarter points, or at the extremum of the parabola
    through three samples where g comes close to the surface. A touch that does not cross
    (grazing) is not an event; an excursion across the surface and back that falls between
    two samples and is not revealed by the parabola is missed, which only a smaller
    ``max_step`` prevents. The number of events counts sign changes (two surfaces crossed at
    once count two).
    """
    # ---- functions and method
    _check_numba_function(rhs, "rhs")
    if not isinstance(method, str) or method not in METHODS:
        raise _fail("method", method, f"must be one of {', '.join(METHODS)}")
    if method == "rk4" and fixed_step is None:
        raise _fail("method", method, "'rk4' has no error estimate: use it with fixed_step=h")

    # ---- arrays
    y0a = _as_float_array(y0, "y0")
    if y0a.ndim != 2 or y0a.shape[0] < 1 or y0a.shape[1] < 1:
        raise _fail("y0", f"array of shape {y0a.shape}",
                    "must have shape (n_samples, n_state) with both >= 1 "
                    "(use y0[None, :] for a single sample)")
    n_samples, n_state = y0a.shape
    if not np.isfinite(y0a).all():
        i = _first_bad_row(y0a)
        raise _fail("y0", f"row {i}", f"must be finite, sample {i} has {y0a[i].tolist()}")

    pa = _as_float_array(params, "params")
    if pa.ndim == 1 and n_samples == 1:
        pa = pa[None, :]
    if pa.ndim != 2 or pa.shape[0] != n_samples:
        raise _fail("params", f"array of shape {pa.shape}",
                    f"must have shape (n_samples={n_samples}, n_par)")
    if not np.isfinite(pa).all():
        i = _first_bad_row(pa)
        raise _fail("params", f"row {i}", f"must be finite, sample {i} has {pa[i].tolist()}")

    te = _as_float_array(t_eval, "t_eval")
    if te.ndim == 1:
        te2 = te[None, :]
    elif te.ndim == 2 and te.shape[0] == n_samples:
        te2 = te
    else:
        raise _fail("t_eval", f"array of shape {te.shape}",
                    f"must have shape (n_t,) or (n_samples={n_samples}, n_t)")
    if te2.shape[1] < 1:
        raise _fail("t_eval", te, "must hold at least one output instant")
    if not np.isfinite(te2).all():
        raise _fail("t_eval", te, "must be finite")
    if te2.shape[1] > 1 and not (np.diff(te2, axis=1) > 0).all():
        row = int(np.nonzero(~(np.diff(te2, axis=1) > 0).all(axis=1))[0][0])
        where = "" if te.ndim == 1 else f" (sample {row})"
        raise _fail("t_eval", te, f"must be strictly increasing{where}")
    te2 = np.ascontiguousarray(te2)

    t0a = _as_float_array(t0, "t0")
    if t0a.ndim == 0:
        t0a = np.full(n_samples, float(t0a))
    if t0a.shape != (n_samples,):
        raise _fail("t0", f"array of shape {t0a.shape}", f"must be a float or shape ({n_samples},)")
    if not np.isfinite(t0a).all():
        raise _fail("t0", t0, "must be finite")
    first_out = te2[:, 0] if te2.shape[0] == n_samples else np.full(n_samples, te2[0, 0])
    if (first_out < t0a).any():
        i = int(np.nonzero(first_out < t0a)[0][0])
        raise _fail("t_eval", te, f"starts at {first_out[i]!r} before t0={t0a[i]!r} "
                    f"(sample {i}); output instants must be >= t0")

    # ---- tolerances and step settings
    if not (isinstance(rtol, int | float | np.floating) and RTOL_MIN <= rtol < 1.0):
        raise _fail("rtol", rtol, f"must be a float in [{RTOL_MIN:.3g}, 1)")
    atol_a = _as_float_array(atol, "atol")
    if atol_a.ndim == 0:
        atol_vec = np.full(n_state, float(atol_a))
    elif atol_a.shape == (n_state,):
        atol_vec = atol_a.copy()
    else:
        raise _fail("atol", atol, f"must be a float or shape (n_state={n_state},)")
    if not (np.isfinite(atol_vec).all() and (atol_vec >= 0).all()):
        raise _fail("atol", atol, "must be finite and >= 0")
    if not (isinstance(max_step, int | float | np.floating) and max_step > 0):
        raise _fail("max_step", max_step, "must be > 0 (np.inf for no bound)")
    if not (isinstance(first_step, int | float | np.floating) and math.isfinite(first_step)
            and first_step >= 0):
        raise _fail("first_step", first_step, "must be finite and >= 0 (0 = automatic)")
    if isinstance(max_steps, bool) or not isinstance(max_steps, int | np.integer) or max_steps < 1:
        raise _fail("max_steps", max_steps, "must be an integer >= 1")
    if fixed_step is None:
        fixed_h = 0.0
    else:
        if not (isinstance(fixed_step, int | float | np.floating) and math.isfinite(fixed_step)
                and fixed_step > 0):
            raise _fail("fixed_step", fixed_step, "must be a finite float > 0, or None")
        fixed_h = float(fixed_step)

    # ---- switching functions
    if isinstance(n_switch, bool) or not isinstance(n_switch, int | np.integer) or n_switch < 0:
        raise _fail("n_switch", n_switch, "must be an integer >= 0")
    if n_switch > 0 and switch is None:
        raise _fail("n_switch", n_switch, "> 0 needs switch=, the function filling g")
    if switch is not None and n_switch == 0:
        raise _fail("n_switch", n_switch, "must give the number of switching functions (>= 1) "
                    "when switch= is passed")
    if switch is not None:
        _check_numba_function(switch, "switch")
    if not isinstance(freeze_sides, bool | np.bool_):
        raise _fail("freeze_sides", freeze_sides, "must be True or False")
    if freeze_sides and switch is None:
        raise _fail("freeze_sides", freeze_sides, "needs switch= and n_switch > 0")

    # ---- stored components
    if save is None:
        save_a = np.arange(n_state, dtype=np.int64)
    else:
        save_a = np.asarray(save)
        if save_a.ndim == 0:
            save_a = save_a[None]
        if (save_a.ndim != 1 or save_a.size < 1 or not np.issubdtype(save_a.dtype, np.integer)
                or (save_a < 0).any() or (save_a >= n_state).any()):
            raise _fail("save", save, f"must be a 1-d array of state indices in [0, {n_state})")
        save_a = np.ascontiguousarray(save_a, dtype=np.int64)

    # ---- probe the user functions from Python (clear errors instead of numba tracebacks)
    p_probe = pa[0]
    if switch is not None:
        if freeze_sides:
            p_probe = np.concatenate([pa[0], np.zeros(int(n_switch))])
        g_probe = _probe(switch, "switch", t0a[0], y0a[0], p_probe, int(n_switch))
        if freeze_sides:
            p_probe[pa.shape[1]:] = np.sign(g_probe)
    _probe(rhs, "rhs", t0a[0], y0a[0], p_probe, n_state)

    # ---- run
    n_t = te2.shape[1]
    out = np.full((n_samples, n_t, save_a.size), np.nan)
    status = np.zeros(n_samples, dtype=np.int8)
    counts = np.zeros((n_samples, 4), dtype=np.int64)
    kernel = _get_kernel()
    args = (rhs, switch if switch is not None else _no_switch, _METHOD_CODE[method],
            y0a, np.ascontiguousarray(pa), t0a, te2, save_a, out, float(rtol), atol_vec,
            float(max_step), float(first_step), int(max_steps), fixed_h, int(n_switch),
            bool(freeze_sides), status, counts)
    n_threads = min(os.cpu_count() or 1, n_samples) if parallel else 1
    try:
        if n_threads > 1:
            _run_threads(kernel, args, n_samples, n_threads)
        else:
            kernel(*args)
    except Exception as exc:
        # Only user code can raise in the kernel (numba's default error model raises
        # ZeroDivisionError on float division by zero), and it aborts the whole batch.
        raise RuntimeError(
            f"solve_batch: rhs or switch raised {type(exc).__name__}: {exc}. An exception in "
            "the compiled kernel aborts the whole batch: compile rhs and switch with "
            "@njit(error_model='numpy') so that a division by zero gives inf/nan and only "
            "that sample stops, with STATUS_NONFINITE."
        ) from exc

    return ODEResult(
        y=out,
        t=te,
        status=status,
        n_steps=counts[:, 0].copy(),
        n_rejected=counts[:, 1].copy(),
        n_rhs=counts[:, 2].copy(),
        n_events=counts[:, 3].copy(),
        method=method,
        rtol=float(rtol),
        atol=float(atol_a) if atol_a.ndim == 0 else atol_vec,
        save=save_a,
        options={
            "max_step": float(max_step),
            "first_step": float(first_step),
            "max_steps": int(max_steps),
            "fixed_step": None if fixed_step is None else float(fixed_step),
            "n_switch": int(n_switch),
            "freeze_sides": bool(freeze_sides),
            "parallel": bool(parallel),
            "rhs": getattr(rhs, "__qualname__", repr(rhs)),
            "switch": None if switch is None else getattr(switch, "__qualname__", repr(switch)),
        },
    )
