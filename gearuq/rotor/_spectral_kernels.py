"""Compiled inner loops of the long-period steady state (hunting-tooth stages).

Each replaces a numpy expression whose temporaries, not its arithmetic, cost the time at
``H`` of several thousand harmonics (docs/theory/geared_rotor.md, "Speed of the long-period
route"): the modal receptances (a complex division per frequency and pole, then one product
per output), the preconditioner's small blocks per residue class (batched ``inv`` of 7 x 7
matrices is mostly call overhead; here LU factors) and their solves, and the Newton polish
of a trigonometric series' maximum. Each computes what the numpy expression computed, to
rounding.
"""

from __future__ import annotations

import functools
import math
from typing import Any

import numpy as np
from numba import njit


@njit(cache=True)
def pole_sums(w: np.ndarray, poles: np.ndarray, weights: np.ndarray,
              n_pairs: int) -> np.ndarray:
    """``out[f, c] = sum_k weights[k, c] / (i w[f] - poles[k])`` in real arithmetic.

    The first ``n_pairs`` poles stand each for itself and its conjugate with the conjugate
    weight (a real system's poles and residues): ``w / (i W - p) + conj(w) / (i W -
    conj(p)) = (-2 Re(w conj(p)) + 2 i W Re w) / (|p|^2 - W^2 + 2 i a W)``, ``a = -Re p``,
    one real division per pair and frequency and half the products. The other poles
    singly: ``1 / (i W - p) = (a - i b) / (a^2 + b^2)`` with ``b = W - Im p``. No
    ``(n_w, n_poles)`` temporary.
    """
    nf, nk, nc = w.size, poles.size, weights.shape[1]
    acc_r = np.zeros((nc, nf))
    acc_i = np.zeros((nc, nf))
    rr = np.empty(nf)
    ri = np.empty(nf)
    for k in range(n_pairs):  # frequencies innermost: contiguous, vectorised
        a = -poles[k].real
        b = poles[k].imag
        for f in range(nf):
            dr = a * a + (b - w[f]) * (b + w[f])  # |p|^2 - W^2 without cancelling at W ~ b
            di = 2.0 * a * w[f]
            d = 1.0 / (dr * dr + di * di)
            rr[f] = dr * d
            ri[f] = di * d
        for c in range(nc):
            n0 = 2.0 * (a * weights[k, c].real - b * weights[k, c].imag)
            n1 = 2.0 * weights[k, c].real
            for f in range(nf):
                acc_r[c, f] += n0 * rr[f] + n1 * w[f] * ri[f]
                acc_i[c, f] += n1 * w[f] * rr[f] - n0 * ri[f]
    for k in range(n_pairs, nk):
        a = -poles[k].real
        pi = poles[k].imag
        for f in range(nf):
            b = w[f] - pi
            d = 1.0 / (a * a + b * b)
            rr[f] = a * d
            ri[f] = -b * d
        for c in range(nc):
            wr = weights[k, c].real
            wi = weights[k, c].imag
            for f in range(nf):
                acc_r[c, f] += rr[f] * wr - ri[f] * wi
                acc_i[c, f] += rr[f] * wi + ri[f] * wr
    out = np.empty((nf, nc), dtype=np.complex128)
    for c in range(nc):
        for f in range(nf):
            out[f, c] = acc_r[c, f] + 1j * acc_i[c, f]
    return out


def pole_sums_numpy(w: np.ndarray, poles: np.ndarray, weights: np.ndarray,
                    n_pairs: int) -> np.ndarray:
    """:func:`pole_sums` without compiling: the same operations in the same order, each loop
    over frequencies one numpy expression (its plain-Python route, :mod:`gearuq._firstcall`:
    a few numpy calls per pole instead of the ~1 s compile a small first call would pay)."""
    nk, nc = poles.size, weights.shape[1]
    acc_r = np.zeros((nc, w.size))
    acc_i = np.zeros((nc, w.size))
    for k in range(n_pairs):
        a = -poles[k].real
        b = poles[k].imag
        dr = a * a + (b - w) * (b + w)
        di = 2.0 * a * w
        d = 1.0 / (dr * dr + di * di)
        rr = dr * d
        ri = di * d
        for c in range(nc):
            n0 = 2.0 * (a * weights[k, c].real - b * weights[k, c].imag)
            n1 = 2.0 * weights[k, c].real
            acc_r[c] += n0 * rr + n1 * w * ri
            acc_i[c] += n1 * w * rr - n0 * ri
    for k in range(n_pairs, nk):
        a = -poles[k].real
        b = w - poles[k].imag
        d = 1.0 / (a * a + b * b)
        rr = a * d
        ri = -b * d
        for c in range(nc):
            wr = weights[k, c].real
            wi = weights[k, c].imag
            acc_r[c] += rr * wr - ri * wi
            acc_i[c] += rr * wi + ri * wr
    return (acc_r + 1j * acc_i).T.copy()


#: CPU seconds of :func:`pole_sums_numpy` per pole, output and frequency, plus per pole and
#: output (numpy's call overhead); measured 0.9 ms for 300 frequencies, 40 poles and 3
#: outputs, 5.7 ms for 5000, 60 and 5 (these constants predict 1.3 and 1.6 times that: the
#: allowance is spent on the safe side).
POLE_SUMS_NUMPY_CPU = (4e-9, 6e-6)


@functools.cache
def pole_sums_route() -> Any:
    """Compiled or numpy :func:`pole_sums` (:class:`gearuq._firstcall.FirstCallRoute`): a
    small first call (the geared rotor's few hundred frequencies) runs the numpy twin in a few
    milliseconds instead of compiling (about 1 s of CPU, numba's start-up included)."""
    from gearuq._firstcall import FirstCallRoute

    return FirstCallRoute(pole_sums, "the rotor's receptance kernel (pole sums)", unit_cpu=1.0,
                          compile_cpu=1.5, twin=lambda: pole_sums_numpy)


def pole_sums_auto(w: np.ndarray, poles: np.ndarray, weights: np.ndarray,
                   n_pairs: int) -> np.ndarray:
    """:func:`pole_sums` by the route :func:`pole_sums_route` chooses (same arguments)."""
    per_point, per_column = POLE_SUMS_NUMPY_CPU
    columns = poles.size * (weights.shape[1] + 1)
    predicted = columns * (per_column + per_point * w.size)
    kernel, _ = pole_sums_route().choose(predicted, (w, poles, weights, n_pairs))
    return kernel(w, poles, weights, n_pairs)


@njit(cache=True)
def _factor(a: np.ndarray, n: int, piv: np.ndarray) -> None:
    """LU of the leading ``n x n`` block of ``a`` in place, ``P a = L U`` (rows swapped
    whole, as LAPACK's ``getrf``; ``piv[k]``: the row swapped with ``k`` at step ``k``)."""
    for col in range(n):
        p = col  # pivot by |Re| + |Im| (no square root)
        best = abs(a[col, col].real) + abs(a[col, col].imag)
        for r in range(col + 1, n):
            m = abs(a[r, col].real) + abs(a[r, col].imag)
            if m > best:
                p, best = r, m
        piv[col] = p
        if p != col:
            for c in range(n):
                a[col, c], a[p, c] = a[p, c], a[col, c]
        d = 1.0 / a[col, col]
        for r in range(col + 1, n):
            f = a[r, col] * d
            a[r, col] = f
            for c in range(col + 1, n):
                a[r, c] -= f * a[col, c]


@njit(cache=True)
def class_factors(index: np.ndarray, h_two: np.ndarray,
                  coupling: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """LU factors of ``I + diag(h) T`` for the residue classes ``0..L // 2`` only.

    Class 0 on all ``M`` members, the others on their ``M - 1`` (the last member is
    padding); a third of the arithmetic of the blocks' inverses. Class ``L - r`` needs no
    factors: its members are the negatives of class ``r``'s, and
    :func:`apply_class_factors` reads their outputs as conjugates of class ``r``'s.
    """
    L, M = index.shape
    half = L // 2 + 1
    lu = np.zeros((half, M, M), dtype=np.complex128)
    piv = np.zeros((half, M), dtype=np.int64)
    for r in range(half):
        for a in range(M):
            ia = index[r, a]
            for b in range(M):
                ib = index[r, b]
                lu[r, a, b] = 1.0 if a == b else 0.0
                if ia >= 0 and ib >= 0:
                    lu[r, a, b] += h_two[ia] * coupling[a, b]
        _factor(lu[r], M if r == 0 else M - 1, piv[r])
    return lu, piv


@njit(cache=True)
def apply_class_factors(lu: np.ndarray, piv: np.ndarray, index: np.ndarray,
                        v: np.ndarray) -> np.ndarray:
    """The block preconditioner by its LU factors on ``[Re x_0..x_H, Im x_1..x_H]``.

    One solve per class ``r = 0..L // 2`` on all its members: those ``j >= 0`` are outputs
    of class ``r``, those ``j < 0`` give class ``L - r``'s outputs at ``-j`` as their
    conjugates (``x`` is the spectrum of a real signal, and so is its image).
    """
    M = index.shape[1]
    half = lu.shape[0]
    H = (v.size - 1) // 2
    out = np.zeros(v.size)
    z = np.empty(M, dtype=np.complex128)
    for r in range(half):
        n = M if r == 0 else M - 1
        for a in range(n):
            j = index[r, a] - H
            if j > 0:
                z[a] = v[j] + 1j * v[H + j]
            elif j == 0:
                z[a] = v[0]
            else:
                z[a] = v[-j] - 1j * v[H - j]
        for k in range(n):  # the row swaps, then L (unit diagonal), then U
            p = piv[r, k]
            if p != k:
                z[k], z[p] = z[p], z[k]
        for a in range(1, n):
            s = z[a]
            for b in range(a):
                s -= lu[r, a, b] * z[b]
            z[a] = s
        for a in range(n - 1, -1, -1):
            s = z[a]
            for b in range(a + 1, n):
                s -= lu[r, a, b] * z[b]
            z[a] = s / lu[r, a, a]
        for a in range(n):
            j = index[r, a] - H
            if j >= 0:
                out[j] = z[a].real
                if j > 0:
                    out[H + j] = z[a].imag
            else:
                out[-j] = z[a].real
                out[H - j] = -z[a].imag
    return out


@njit(cache=True)
def polish_maxima(harmonics: np.ndarray, orders: np.ndarray, t: np.ndarray, period: float,
                  steps: int, max_step: float) -> np.ndarray:
    """Newton on the derivative of ``f(t) = Re c_0 + 2 Re sum_j c_j exp(i w j t)`` from ``t``.

    ``orders`` ascending with ``orders[0] = 0``; ``w = 2 pi / period``. Each step moves by
    at most ``max_step`` and only where ``f'' < 0``. The powers ``exp(i w t)^j`` come from
    products (rounding grows as ``j eps``). Returns ``f`` at the polished instants.
    """
    w = 2.0 * math.pi / period
    top = orders[-1]
    values = np.empty(t.size)
    for i in range(t.size):
        ti = t[i]
        for step in range(steps + 1):
            zr = math.cos(w * ti)
            zi = math.sin(w * ti)
            er, ei = 1.0, 0.0
            f0 = 0.0
            f1 = 0.0
            f2 = 0.0
            p = 1
            for j in range(1, top + 1):
                er, ei = er * zr - ei * zi, er * zi + ei * zr
                if orders[p] == j:
                    cr = harmonics[p].real
                    ci = harmonics[p].imag
                    re = cr * er - ci * ei  # Re(c e)
                    im = cr * ei + ci * er  # Im(c e)
                    wj = w * j
                    f0 += re
                    f1 -= wj * im          # Re(i w j c e) = -w j Im(c e)
                    f2 -= wj * wj * re
                    p += 1
            if step == steps:
                values[i] = harmonics[0].real + 2.0 * f0
                break
            d1 = 2.0 * f1
            d2 = 2.0 * f2
            if d2 < 0.0:
                s = -d1 / d2
                ti += min(max(s, -max_step), max_step)
    return values


@njit(cache=True)
def _modal_rates(y: np.ndarray, k: float, ke: float, w2: np.ndarray, DT: np.ndarray,
                 psi: np.ndarray, load: np.ndarray, dres: float, kbar: float, hres: float,
                 backlash: float, out: np.ndarray) -> tuple[float, float]:
    """Rates of the reduced rotor and its mesh force and approach.

    ``eta'' = f - w^2 eta - D eta' - psi r`` (``DT`` is ``D`` transposed), the approach
    algebraic (the dropped modes' static flexibility ``hres``), front flank, apart or back
    flank (``backlash`` [m], inf: none): as :mod:`gearuq.rotor._kernels`, the branch by the
    state.
    """
    n = w2.size
    dm = dres
    for i in range(n):
        dm += psi[i] * y[i]
    one = 1.0 - hres * kbar
    if k * dm - ke * one > 0.0:  # front flank
        d = (dm + hres * ke) / (1.0 + hres * (k - kbar))
        force = k * d - ke
    elif k * dm - (ke - k * backlash) * one < 0.0:  # back flank (never for inf)
        d = (dm + hres * (ke - k * backlash)) / (1.0 + hres * (k - kbar))
        force = k * d - ke + k * backlash
    else:
        d = dm / one
        force = 0.0
    r = force - kbar * d
    for i in range(n):
        out[i] = y[n + i]
        out[n + i] = load[i] - w2[i] * y[i] - psi[i] * r
    # column by column, ``DT`` the transpose (its rows contiguous): each rate still subtracts
    # its terms in the order j = 0, 1, ..., so the sums are the row-wise loop's bit for bit,
    # while the loop over i carries no dependency and vectorises (1.5 times faster a period)
    for j in range(n):
        v = y[n + j]
        for i in range(n):
            out[n + i] -= DT[j, i] * v
    return force, d


@njit(cache=True)
def rk4_long_period(y: np.ndarray, k_fine: np.ndarray, ke_fine: np.ndarray, period: float,
                    w2: np.ndarray, D: np.ndarray, psi: np.ndarray, load: np.ndarray,
                    dres: float, kbar: float, hres: float, backlash: float,
                    delta_out: np.ndarray, force_out: np.ndarray) -> None:
    """One long period of the reduced rotor by the classical Runge-Kutta rule, ``y`` in place
    (the contact law of :func:`_modal_rates` at each stage).

    ``K = k_fine.size // 2`` steps; ``k`` and ``k e`` on ``2 K`` instants (step ends and
    midpoints: no interpolation). The approach and force at the start of every
    ``K // delta_out.size``-th step go to ``delta_out`` and ``force_out``.
    """
    n2 = y.size
    K = k_fine.size // 2
    every = K // delta_out.size
    h = period / K
    k1 = np.empty(n2)
    k2 = np.empty(n2)
    k3 = np.empty(n2)
    k4 = np.empty(n2)
    tmp = np.empty(n2)
    DT = np.ascontiguousarray(D.T)
    for s in range(K):
        i0 = 2 * s
        i2 = (i0 + 2) % k_fine.size
        force, d = _modal_rates(y, k_fine[i0], ke_fine[i0], w2, DT, psi, load, dres, kbar,
                                hres, backlash, k1)
        if s % every == 0 and s // every < delta_out.size:
            delta_out[s // every] = d
            force_out[s // every] = force
        for i in range(n2):
            tmp[i] = y[i] + 0.5 * h * k1[i]
        _modal_rates(tmp, k_fine[i0 + 1], ke_fine[i0 + 1], w2, DT, psi, load, dres, kbar, hres,
                     backlash, k2)
        for i in range(n2):
            tmp[i] = y[i] + 0.5 * h * k2[i]
        _modal_rates(tmp, k_fine[i0 + 1], ke_fine[i0 + 1], w2, DT, psi, load, dres, kbar, hres,
                     backlash, k3)
        for i in range(n2):
            tmp[i] = y[i] + h * k3[i]
        _modal_rates(tmp, k_fine[i2], ke_fine[i2], w2, DT, psi, load, dres, kbar, hres,
                     backlash, k4)
        for i in range(n2):
            y[i] += h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i])
