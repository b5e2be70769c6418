"""Face-width coupling length of the LTCA from cantilever-plate theory.

A point load on a helical tooth deflects it over a band of the face width, not only under the
load. The LTCA (:mod:`gearuq.gears.compliance`) spreads the slice compliance with the
normalised exponential kernel ``exp(-|u|/lam) / (2 lam)``, whose *effective width*
``W_eff = (integral of the deflection over the face) / (peak deflection)`` is ``2 lam``.

The coupling length ``lam`` is taken from the classical model of a gear tooth under a
concentrated load, the **cantilever plate** (Jaramillo 1950; applied to gear teeth by
Wellauer & Seireg 1960): a Kirchhoff plate of height ``H`` (root circle to tip circle) and
infinite width, clamped at the root (``x = 0``) and free at the tip (``x = H``), loaded by a
point force at height ``h``. Fourier-transforming along the face (``w = W(x) exp(i k y)``)
gives, per wavenumber, ``W'''' - 2 k^2 W'' + k^4 W = delta(x - h) / D`` with

* clamped root: ``W(0) = W'(0) = 0``;
* free tip: ``W'' - nu k^2 W = 0`` (no bending moment) and ``W''' - (2 - nu) k^2 W' = 0``
  (no Kirchhoff shear);
* at the load: ``W, W', W''`` continuous, ``W'''`` jumps by ``1/D``.

The deflection under the load is ``w(h, y) = (1/pi) int_0^inf W_k(h) cos(k y) dk`` and its
integral over ``y`` is the beam value ``W_0(h) = h^3 / (3 D)``, so
``W_eff = W_0(h) / w(h, 0)``; it depends on ``h / H`` and ``nu`` only (``D`` cancels). For a
tip load ``W_eff = 2.00 H``, for a load at mid height ``1.65 H``. The LTCA uses one kernel per
pair: ``lam = mean(W_eff) / 2`` over the load heights of the active flanks of both gears
(:func:`plate_coupling_length`), 1.85 ``m_n`` for Yuan et al.'s pair. Why a thin plate, and what
it leaves out, is discussed in ``docs/theory/ltca.md``.
"""

from __future__ import annotations

import functools
import math

import numpy as np
from scipy.integrate import quad

from gearuq.gears.geometry import HelicalGearPair

__all__ = [
    "cantilever_plate_effective_width",
    "cantilever_plate_transform",
    "plate_coupling_length",
]


def _basis(k: float, x: float, ref_up: float, ref_down: float) -> np.ndarray:
    """Values and first three x-derivatives of the four homogeneous solutions at ``x``.

    Basis ``e^{k(x - ref_up)}``, ``x e^{k(x - ref_up)}``, ``e^{-k(x - ref_down)}``,
    ``x e^{-k(x - ref_down)}``; the reference points keep every exponential <= 1 on its
    interval (no overflow for large ``k H``). Returns ``B[j, d]``, j basis, d derivative.
    """
    ep = math.exp(k * (x - ref_up))
    em = math.exp(-k * (x - ref_down))
    return np.array([
        [ep, k * ep, k * k * ep, k**3 * ep],
        [x * ep, ep + k * x * ep, 2 * k * ep + k * k * x * ep, 3 * k * k * ep + k**3 * x * ep],
        [em, -k * em, k * k * em, -(k**3) * em],
        [x * em, em - k * x * em, -2 * k * em + k * k * x * em, 3 * k * k * em - k**3 * x * em],
    ])


def cantilever_plate_transform(
    k: float, load_height: float, *, height: float = 1.0, nu: float = 0.3
) -> float:
    """Fourier transform along the face of the deflection under the load, ``W_k(h)``.

    Kirchhoff cantilever plate (clamped root, free tip) of height ``height`` with unit
    flexural rigidity, unit point load at ``x = load_height``; ``W_0(h) = h^3 / 3`` (beam).

    Parameters
    ----------
    k : float
        Wavenumber along the face [1/length], >= 0.
    load_height : float
        Height of the load above the clamped root, in ``(0, height]``.
    height : float, optional
        Plate height (root to free tip).
    nu : float, optional
        Poisson's ratio.

    Returns
    -------
    float
        ``W_k(h)`` [length^3 / rigidity].
    """
    h, H = float(load_height), float(height)
    if not 0.0 < h <= H:
        raise ValueError(f"load_height={load_height!r} is outside its valid range (0, {H!r}]")
    if k * H < 1e-4:  # the exponential basis degenerates; the beam limit is exact to O(k^2)
        return h**3 / 3.0
    # unknowns: 4 coefficients below the load (0 < x < h), 4 above (h < x < H)
    below_0 = _basis(k, 0.0, h, 0.0)
    below_h = _basis(k, h, h, 0.0)
    above_h = _basis(k, h, H, h)
    above_H = _basis(k, H, H, h)
    A = np.zeros((8, 8))
    rhs = np.zeros(8)
    A[0, :4] = below_0[:, 0]  # W(0) = 0
    A[1, :4] = below_0[:, 1]  # W'(0) = 0
    A[2, 4:] = above_H[:, 2] - nu * k * k * above_H[:, 0]  # no moment at the tip
    A[3, 4:] = above_H[:, 3] - (2.0 - nu) * k * k * above_H[:, 1]  # no shear at the tip
    for d in range(3):  # W, W', W'' continuous at the load
        A[4 + d, :4] = below_h[:, d]
        A[4 + d, 4:] = -above_h[:, d]
    A[7, :4] = -below_h[:, 3]  # W''' jumps by the unit load
    A[7, 4:] = above_h[:, 3]
    rhs[7] = 1.0
    coef = np.linalg.solve(A, rhs)
    return float(below_h[:, 0] @ coef[:4])


def cantilever_plate_effective_width(load_height_ratio: float, nu: float = 0.3) -> float:
    """Effective width of the load-line deflection of a cantilever plate, ``W_eff / H``.

    ``W_eff = int w(h, y) dy / w(h, 0)`` for a point load at ``h = load_height_ratio * H``.

    Parameters
    ----------
    load_height_ratio : float
        ``h / H`` in ``(0, 1]``.
    nu : float, optional
        Poisson's ratio in ``[0, 0.5)``.

    Returns
    -------
    float
        ``W_eff / H`` (2.00 for a tip load, 1.65 at mid height for ``nu = 0.3``).
    """
    r = float(load_height_ratio)
    if not 0.0 < r <= 1.0:
        raise ValueError(f"load_height_ratio={load_height_ratio!r} is outside its valid range "
                         "(0, 1]")
    if not 0.0 <= nu < 0.5:
        raise ValueError(f"nu={nu!r} is outside its valid range [0, 0.5)")
    # the transform decays on the scale 1/h; beyond 100/h the tail is below 1e-6 relative
    peak, _ = quad(lambda k: cantilever_plate_transform(k, r, nu=nu), 0.0, 100.0 / r,
                   limit=400, epsabs=0.0, epsrel=1e-9)
    return (r**3 / 3.0) / (peak / math.pi)


@functools.lru_cache(maxsize=8)
def _effective_width_table(nu: float) -> tuple[np.ndarray, np.ndarray]:
    """``W_eff / H`` on 20 load heights (computed once per ``nu``, ~0.3 s)."""
    ratios = np.linspace(0.05, 1.0, 20)
    return ratios, np.array([cantilever_plate_effective_width(r, nu) for r in ratios])


def plate_coupling_length(pair: HelicalGearPair, *, nu: float = 0.3, n_heights: int = 9) -> float:
    """Return the face-width coupling length ``lam`` [m] of the LTCA kernel for ``pair``.

    ``lam = mean(W_eff) / 2``, the mean over ``n_heights`` contact points evenly spaced along
    the path of contact, on both gears, of the cantilever-plate effective width at the
    point's height above the root circle (plate height: root circle to tip circle).

    Parameters
    ----------
    pair : HelicalGearPair
        The gear pair.
    nu : float, optional
        Poisson's ratio.
    n_heights : int, optional
        Contact points along the path of contact (>= 2).

    Returns
    -------
    float
        ``lam`` in metres (Yuan, Liu and Liu's pair: 11.1 mm = 1.85 ``m_n``).
    """
    ratios, table = _effective_width_table(float(nu))
    t1t2 = pair.centre_distance * math.sin(pair.alpha_wt)
    s = np.linspace(pair.g_f1, pair.g_f1 + pair.g_alpha, int(n_heights))
    widths = []
    for rho, db, da, df in ((s, pair.db1, pair.da1, pair.df1),
                            (t1t2 - s, pair.db2, pair.da2, pair.df2)):
        radius = np.sqrt((0.5 * db) ** 2 + rho**2)
        height = 0.5 * (da - df)
        ratio = np.clip((radius - 0.5 * df) / height, ratios[0], 1.0)
        widths.append(np.interp(ratio, ratios, table) * height)
    return 0.5 * float(np.mean(np.concatenate(widths)))
