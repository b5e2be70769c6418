"""Compiled building blocks of a Runge-Kutta step: stages, error norms, dense output.

Each method has its own step and dense-output functions, so that a kernel compiled for one
method types and optimises only that method's code (see ``kernel.py``). They are plain
``@njit`` (no cache of their own): they are compiled into, and cached with, the kernel
entry points that call them.

Performance note: the hot loops index 2-d arrays as ``K[j, i]`` and never take row views
such as ``K[j]``. Every view increments and decrements the array's reference count with an
atomic instruction. For the same reason the work arrays of a sample are views made with
``numba.carray`` into one buffer (:func:`view1`, :func:`view2`): such arrays carry no
reference count (meminfo NULL), so passing them to rhs/switch (first-class function calls
incref and decref every array argument) costs no atomic operation. Before this,
NRT_incref/NRT_decref took ~45 % of the run time, and the counts of arrays shared between
threads made the parallel loop no faster than the serial one.
"""

from __future__ import annotations

import math

import numpy as np
from numba import carray, njit, types
from numba.core.extending import intrinsic

from .tableaux import (
    D5_A_IDX,
    D5_A_PTR,
    D5_A_VAL,
    D5_B_IDX,
    D5_B_PTR,
    D5_B_VAL,
    D5_D_IDX,
    D5_D_PTR,
    D5_D_VAL,
    D5_E_IDX,
    D5_E_PTR,
    D5_E_VAL,
    D8_A_IDX,
    D8_A_PTR,
    D8_A_VAL,
    D8_B_IDX,
    D8_B_PTR,
    D8_B_VAL,
    D8_D_IDX,
    D8_D_PTR,
    D8_D_VAL,
    D8_E3_IDX,
    D8_E3_PTR,
    D8_E3_VAL,
    D8_E5_IDX,
    D8_E5_PTR,
    D8_E5_VAL,
    DOP853_C,
    DOPRI5_C,
    R4_A_IDX,
    R4_A_PTR,
    R4_A_VAL,
    R4_B_IDX,
    R4_B_PTR,
    R4_B_VAL,
    RK4_C,
)


@intrinsic
def _f64_ptr(typingctx, address):
    """Reinterpret an integer address as a float64 pointer (for numba.carray)."""
    sig = types.CPointer(types.float64)(types.uintp)

    def codegen(context, builder, signature, args):
        return builder.inttoptr(args[0], context.get_value_type(types.CPointer(types.float64)))

    return sig, codegen


@njit(error_model="numpy")
def view1(buf, offset, n):
    """1-d view of buf[offset:offset + n] without a reference count (see the module note)."""
    return carray(_f64_ptr(buf.ctypes.data + 8 * offset), n)


@njit(error_model="numpy")
def view2(buf, offset, n0, n1):
    """2-d C-contiguous view of n0 * n1 elements of buf from offset, without a reference count."""
    return carray(_f64_ptr(buf.ctypes.data + 8 * offset), (n0, n1))


@njit(error_model="numpy")
def combine(out, base, h, K, ptr, idx, val, row):
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
def lincomb_row(R, r, h, K, ptr, idx, val, row):
    """R[r] = h * sum_q val[q] * K[idx[q]] over the sparse row ``row``."""
    n = K.shape[1]
    for i in range(n):
        R[r, i] = 0.0
    for q in range(ptr[row], ptr[row + 1]):
        a = h * val[q]
        j = idx[q]
        for i in range(n):
            R[r, i] += a * K[j, i]


@njit(error_model="numpy", inline="always")
def eval_into(rhs, t, y, p, f, K, s):
    """K[s] = rhs(t, y); rhs writes into the scratch vector f, which is copied (no view)."""
    rhs(t, y, p, f)
    for i in range(f.size):
        K[s, i] = f[i]


@njit(error_model="numpy", inline="always")
def row_finite(K, s):
    """Whether every entry of K[s] is finite."""
    for i in range(K.shape[1]):
        if not math.isfinite(K[s, i]):
            return False
    return True


@njit(error_model="numpy", inline="always")
def all_finite(x):
    """Whether every entry of x is finite."""
    for i in range(x.size):
        if not math.isfinite(x[i]):
            return False
    return True


@njit(error_model="numpy")
def stages(rhs, t, y, p, h, K, yt, f, s_lo, s_hi, c, ptr, idx, val):
    """Evaluate stages s_lo..s_hi-1 into the rows of K (stage 0 must already hold f(t, y))."""
    for s in range(s_lo, s_hi):
        combine(yt, y, h, K, ptr, idx, val, s)
        eval_into(rhs, t + c[s] * h, yt, p, f, K, s)


@njit(error_model="numpy")
def _rms_error(ev, y, ynew, atol, rtol):
    """Hairer's scaled RMS norm of the error vector ev."""
    n = y.size
    s = 0.0
    for i in range(n):
        sk = atol[i] + rtol * max(abs(y[i]), abs(ynew[i]))
        # atol = 0 and y = 0: a zero error counts as 0, any other as huge.
        r = ev[i] / max(sk, 1e-300)
        s += r * r
    return math.sqrt(s / n)


@njit(error_model="numpy")
def step_dopri5(rhs, t, t_new, y, p, h, K, yt, f, ynew, ev, atol, rtol, want_err):
    """One Dormand-Prince 5(4) step of size h from (t, y), K[0] = f(t, y) on entry.

    Writes y_new and K[6] = f(t_new, y_new) (FSAL). Returns (err, n_rhs) with err the scaled
    error norm, or 0 when ``want_err`` is false.
    """
    stages(rhs, t, y, p, h, K, yt, f, np.int64(1), np.int64(6), DOPRI5_C, D5_A_PTR, D5_A_IDX,
           D5_A_VAL)
    combine(ynew, y, h, K, D5_B_PTR, D5_B_IDX, D5_B_VAL, np.int64(0))
    # t_new rather than t + h so that the last step ends exactly on t_eval[-1].
    eval_into(rhs, t_new, ynew, p, f, K, np.int64(6))
    err = 0.0
    if want_err:
        # the error vector combines stages 0..6 (6 = FSAL stage)
        for i in range(ev.size):
            ev[i] = 0.0
        for q in range(D5_E_PTR[0], D5_E_PTR[1]):
            a = h * D5_E_VAL[q]
            j = D5_E_IDX[q]
            for i in range(ev.size):
                ev[i] += a * K[j, i]
        err = _rms_error(ev, y, ynew, atol, rtol)
    return err, 6


@njit(error_model="numpy")
def step_dop853(rhs, t, t_new, y, p, h, K, yt, f, ynew, ev, atol, rtol, want_err):
    """One DOP853 step of size h from (t, y), K[0] = f(t, y) on entry.

    Writes y_new (f(t_new, y_new) is left to the caller). Returns (err, n_rhs), err with
    Hairer's combined estimator |h| e5^2 / sqrt(e5^2 + 0.01 e3^2) (dop853.f).
    """
    stages(rhs, t, y, p, h, K, yt, f, np.int64(1), np.int64(12), DOP853_C, D8_A_PTR, D8_A_IDX,
           D8_A_VAL)
    combine(ynew, y, h, K, D8_B_PTR, D8_B_IDX, D8_B_VAL, np.int64(0))
    err = 0.0
    if want_err:
        n = y.size
        for i in range(n):
            ev[i] = 0.0
            yt[i] = 0.0
        for q in range(D8_E5_PTR[0], D8_E5_PTR[1]):
            j = D8_E5_IDX[q]
            for i in range(n):
                ev[i] += D8_E5_VAL[q] * K[j, i]
        for q in range(D8_E3_PTR[0], D8_E3_PTR[1]):
            j = D8_E3_IDX[q]
            for i in range(n):
                yt[i] += D8_E3_VAL[q] * K[j, i]
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
    return err, 11


@njit(error_model="numpy")
def step_rk4(rhs, t, t_new, y, p, h, K, yt, f, ynew, ev, atol, rtol, want_err):
    """One classical RK4 step (no error estimate: err = 0). Returns (0, n_rhs)."""
    stages(rhs, t, y, p, h, K, yt, f, np.int64(1), np.int64(4), RK4_C, R4_A_PTR, R4_A_IDX, R4_A_VAL)
    combine(ynew, y, h, K, R4_B_PTR, R4_B_IDX, R4_B_VAL, np.int64(0))
    return 0.0, 3


@njit(error_model="numpy")
def dense_dopri5(R, y, h, K, ynew):
    """Rows of Hairer's 4th-order continuous extension of a DOPRI5 step (no rhs call).

    All methods share the form
    ``u(t + theta h) = y + theta*(R0 + (1-theta)*(R1 + theta*(R2 + (1-theta)*(R3 + ...))))``.
    """
    for i in range(y.size):
        d = ynew[i] - y[i]
        b = h * K[0, i] - d
        R[0, i] = d
        R[1, i] = b
        R[2, i] = d - h * K[6, i] - b
    lincomb_row(R, np.int64(3), h, K, D5_D_PTR, D5_D_IDX, D5_D_VAL, np.int64(0))
    return 4


@njit(error_model="numpy")
def dense_hermite(R, y, h, K, ynew, kf):
    """Rows R0..R2 of the cubic Hermite interpolant (K[kf] = f(t + h, y_new)); returns 3."""
    for i in range(y.size):
        d = ynew[i] - y[i]
        R[0, i] = d
        R[1, i] = h * K[0, i] - d
        R[2, i] = 2.0 * d - h * (K[kf, i] + K[0, i])
    return 3


@njit(error_model="numpy")
def dense_dop853_extra(rhs, t, y, p, h, K, yt, f, R):
    """The four 7th-order rows R3..R6 of DOP853 (three extra rhs calls); after the Hermite
    rows. Returns the number of rows (7)."""
    stages(rhs, t, y, p, h, K, yt, f, np.int64(13), np.int64(16), DOP853_C, D8_A_PTR, D8_A_IDX,
           D8_A_VAL)
    for r in range(4):
        lincomb_row(R, 3 + r, h, K, D8_D_PTR, D8_D_IDX, D8_D_VAL, r)
    return 7


@njit(error_model="numpy")
def dense_eval(R, m, y, theta, out):
    """Evaluate the interpolant with m rows at theta in [0, 1] (all components).

    Horner over the rows with the component loop innermost, so that it vectorises.
    """
    n = y.size
    om = 1.0 - theta
    for i in range(n):
        out[i] = R[m - 1, i]
    for r in range(m - 2, -1, -1):
        # After an even row the factor is (1 - theta), after an odd row theta.
        fac = om if r % 2 == 0 else theta
        for i in range(n):
            out[i] = R[r, i] + fac * out[i]
    for i in range(n):
        out[i] = y[i] + theta * out[i]


@njit(error_model="numpy")
def dense_eval_save(R, m, y, theta, save, out, j):
    """Evaluate the interpolant only at the stored components ``save`` into out[j]."""
    om = 1.0 - theta
    for k in range(save.size):
        i = save[k]
        acc = R[m - 1, i]
        for r in range(m - 2, -1, -1):
            acc = R[r, i] + (om if r % 2 == 0 else theta) * acc
        out[j, k] = y[i] + theta * acc


@njit(error_model="numpy", inline="always")
def write_state(y, save, out, j):
    """out[j] = y[save]."""
    for k in range(save.size):
        out[j, k] = y[save[k]]


@njit(error_model="numpy")
def hinit(rhs, t, y, p, f0, order, hmax, rtol, atol, y1, f1):
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
