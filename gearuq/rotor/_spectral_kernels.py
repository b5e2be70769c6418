"""Compiled inner loops of the long-period steady state (hunting-tooth stages).

Each replaces a numpy expression whose temporaries, not its arithmetic, cost the time at
``H`` of several thousand harmonics (docs/theory/geared_rotor.md, "Speed of the long-period
route"): the modal receptances (a complex division per frequency and pole, then one product
per output), the preconditioner's small blocks per residue class (batched ``inv`` of 7 x 7
matrices is mostly call overhead) and their application, and the Newton polish of a
trigonometric series' maximum. Each computes what the numpy expression computed, to
rounding.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit


@njit(cache=True)
def pole_sums(w: np.ndarray, poles: np.ndarray, weights: np.ndarray) -> np.ndarray:
    """``out[f, c] = sum_k weights[k, c] / (i w[f] - poles[k])`` in real arithmetic.

    ``1 / (i w - p) = (a - i b) / (a^2 + b^2)`` with ``a = -Re p``, ``b = w - Im p``: one
    real division per frequency and pole instead of numpy's complex division and its
    ``(n_w, n_poles)`` temporary.
    """
    nf, nk, nc = w.size, poles.size, weights.shape[1]
    acc_r = np.zeros((nc, nf))
    acc_i = np.zeros((nc, nf))
    rr = np.empty(nf)
    ri = np.empty(nf)
    for k in range(nk):  # frequencies innermost: contiguous, vectorised
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


@njit(cache=True)
def _invert(A: np.ndarray, n: int) -> np.ndarray:
    """Inverse of the leading ``n x n`` block of ``A`` (Gauss-Jordan, partial pivoting)."""
    a = A[:n, :n].copy()
    inv = np.eye(n, dtype=np.complex128)
    for col in range(n):
        piv = col  # pivot by |Re| + |Im| (no square root)
        best = abs(a[col, col].real) + abs(a[col, col].imag)
        for r in range(col + 1, n):
            m = abs(a[r, col].real) + abs(a[r, col].imag)
            if m > best:
                piv, best = r, m
        if piv != col:
            for c in range(n):
                a[col, c], a[piv, c] = a[piv, c], a[col, c]
                inv[col, c], inv[piv, c] = inv[piv, c], inv[col, c]
        s = 1.0 / a[col, col]
        for c in range(n):
            a[col, c] *= s
            inv[col, c] *= s
        for r in range(n):
            if r != col:
                f = a[r, col]
                if f != 0.0:
                    for c in range(n):
                        a[r, c] -= f * a[col, c]
                        inv[r, c] -= f * inv[col, c]
    return inv


@njit(cache=True)
def class_inverses(index: np.ndarray, h_two: np.ndarray, coupling: np.ndarray) -> np.ndarray:
    """Inverse blocks of ``I + diag(h) T`` per residue class (see ``_class_blocks``).

    Classes ``0..L // 2`` are inverted (class 0 on all ``M`` members, the others on their
    ``M - 1``; the last member is padding, an identity row and column); class ``L - r`` is
    the conjugate of class ``r`` reversed.
    """
    L, M = index.shape
    half = L // 2 + 1
    inv = np.zeros((L, M, M), dtype=np.complex128)
    B = np.empty((M, M), dtype=np.complex128)
    for r in range(half):
        for a in range(M):
            ia = index[r, a]
            for b in range(M):
                ib = index[r, b]
                if ia >= 0 and ib >= 0:
                    B[a, b] = (1.0 if a == b else 0.0) + h_two[ia] * coupling[a, b]
                else:
                    B[a, b] = 1.0 if a == b else 0.0
        n = M if r == 0 else M - 1
        inv[r, :n, :n] = _invert(B, n)
        if r > 0:
            inv[r, M - 1, M - 1] = 1.0
    m2 = M - 1
    for r in range(half, L):
        src = L - r
        for a in range(m2):
            for b in range(m2):
                inv[r, a, b] = np.conj(inv[src, m2 - 1 - a, m2 - 1 - b])
        inv[r, m2, m2] = 1.0
    return inv


@njit(cache=True)
def apply_class_inverses(inv: np.ndarray, index: np.ndarray, v: np.ndarray) -> np.ndarray:
    """The block preconditioner on a real vector ``[Re x_0..x_H, Im x_1..x_H]``.

    ``x`` is the one-sided spectrum of a real signal (``x_-j = conj(x_j)``); only the
    outputs ``j >= 0`` are formed (the rest is their conjugate), and the result is returned
    in the same real layout with ``Im`` of ``j = 0`` dropped.
    """
    L, M = index.shape
    H = (v.size - 1) // 2
    out = np.zeros(v.size)
    for r in range(L):
        for a in range(M):
            ia = index[r, a]
            if ia < H:  # padding (-1) or a negative harmonic
                continue
            sr = 0.0
            si = 0.0
            for b in range(M):
                ib = index[r, b]
                if ib < 0:
                    continue
                j = ib - H
                if j >= 0:
                    xr = v[j]
                    xi = v[H + j] if j > 0 else 0.0
                else:
                    xr = v[-j]
                    xi = -v[H - j]
                c = inv[r, a, b]
                sr += c.real * xr - c.imag * xi
                si += c.real * xi + c.imag * xr
            j = ia - H
            out[j] = sr
            if j > 0:
                out[H + j] = si
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
