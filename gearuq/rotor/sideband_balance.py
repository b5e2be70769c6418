"""Steady state of a hunting-tooth geared rotor by harmonic balance on a sparse set of orders.

The harmonic balance of :mod:`gearuq.rotor.harmonic_balance` keeps every harmonic of the long
period up to ``H = n x lcm(z1, z2)``: for a 27/79 pair and four mesh orders, 8532 harmonics
and a dense system of 17065 unknowns. The excitation of such a pair holds much less: the
mesh orders ``h f_m`` and, around each, sidebands at the shaft orders of both gears (the
once-per-revolution pitch deviations), i.e. the long-period harmonics

    j = h L + i L / z1 + l L / z2,   0 <= h <= n_mesh,  |i|, |l| <= n_sidebands,  j >= 0

with ``L = lcm(z1, z2)`` (``L / z1`` long-period harmonics per pinion revolution). The
parametric coupling through the mesh stiffness, whose long-period harmonics sit on the same
kind of set, maps the set onto itself up to its edges. :func:`solve_periodic_orders` solves
the same equations as :func:`gearuq.rotor.harmonic_balance.solve_periodic` (Galerkin on the
mesh approach with the rotor's receptances; alternating frequency-time evaluation of the
contact law on a grid of the whole long period, so contact loss is exact on the grid) with the
unknowns restricted to a given set of orders: ``2 |J| - 1`` real unknowns instead of
``2 H + 1``. On the full set ``J = 0..H`` it is that solver (tested); without contact loss and
with an excitation held by the set it is exact; otherwise the orders left out are the
truncation, measured against the full harmonic balance in docs/theory/geared_rotor.md
(Sec. 13). :func:`spectral_orders` chooses the set from the excitation's spectrum instead.

:func:`solve_periodic_krylov` keeps every harmonic ``0..H`` but never forms the dense system:
FFT products and GMRES preconditioned by the mesh-order stiffness (one small block per
residue class ``j mod L``), semi-smooth Newton on the contact law when the flanks separate;
the long-period reference for pairs whose dense balance is out of reach.

:func:`solve_periodic_by_integration` integrates the reduced rotor in time, long period by
long period, until its state returns to itself: the periodic response where Newton's method
on the balance stagnates under heavy contact loss (docs/theory/geared_rotor.md, "Speed of
the long-period route").
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import scipy.fft as _fft
import scipy.linalg as sla

from gearuq.rotor.excitation import MeshExcitation
from gearuq.rotor.harmonic_balance import (
    STATUS_APERIODIC,
    STATUS_CONVERGED,
    STATUS_NOT_CONVERGED,
    STATUS_SINGULAR,
    PeriodicSolution,
    _backtrack,
    _contact_force,
    contact_branch,
)
from gearuq.rotor.reduction import ModalModel

__all__ = ["KrylovExcitation", "OrderExcitation", "excitation_from_long_period",
           "mesh_force_on_grid", "prepare_krylov", "prepare_orders", "sideband_orders",
           "solve_periodic_by_integration", "solve_periodic_krylov", "solve_periodic_orders",
           "spectral_orders", "synthesize_orders"]


def sideband_orders(z1: int, z2: int, n_mesh_harmonics: int, n_sidebands: int) -> np.ndarray:
    """Long-period harmonics of the mesh orders and their shaft-order sidebands.

    Parameters
    ----------
    z1, z2 : int
        Teeth of pinion and wheel (>= 1).
    n_mesh_harmonics : int
        Mesh orders ``h = 0..n_mesh_harmonics`` (>= 1).
    n_sidebands : int
        Sidebands ``|i|, |l| <= n_sidebands`` of each gear's shaft order (>= 0).

    Returns
    -------
    ndarray of int
        Sorted distinct ``j >= 0`` (``0`` included), in harmonics of the long period
        ``lcm(z1, z2)`` mesh cycles.
    """
    for name, v, low in (("z1", z1, 1), ("z2", z2, 1), ("n_mesh_harmonics", n_mesh_harmonics, 1),
                         ("n_sidebands", n_sidebands, 0)):
        if isinstance(v, bool) or int(v) != v or v < low:
            raise ValueError(f"{name}={v!r} is outside its valid range: integers >= {low}")
    L = math.lcm(int(z1), int(z2))
    s = np.arange(-int(n_sidebands), int(n_sidebands) + 1)
    side = (s[:, None] * (L // int(z1)) + s[None, :] * (L // int(z2))).ravel()
    j = (np.arange(int(n_mesh_harmonics) + 1)[:, None] * L + side[None, :]).ravel()
    return np.unique(j[j >= 0])


def spectral_orders(excitation: MeshExcitation, max_order: int, energy: float = 0.999,
                    always: np.ndarray | None = None) -> np.ndarray:
    """The long-period harmonics up to ``max_order`` that hold the excitation's energy.

    Ranks the harmonics ``1..max_order`` by ``|dk_j|^2 / sum |dk|^2 + |(k e)_j|^2 / sum
    |(k e)|^2`` (the stiffness fluctuation and the error forcing weighted alike) and keeps
    the fewest whose share reaches ``energy`` of the total (2), plus ``always`` and 0.
    Random tooth-to-tooth scatter spreads the excitation over every shaft order, where a
    fixed sideband count (:func:`sideband_orders`) cuts it; the spectrum says which orders
    carry it.

    Parameters
    ----------
    excitation : MeshExcitation
        Mesh stiffness and error over the long period.
    max_order : int
        Highest harmonic considered (e.g. ``n_mesh_harmonics x lcm(z1, z2)``), >= 1.
    energy : float
        Share to keep, in (0, 1].
    always : array_like of int, optional
        Harmonics kept whatever their share (e.g. the mesh orders).

    Returns
    -------
    ndarray of int
        Sorted harmonics, 0 included.
    """
    if not 0.0 < energy <= 1.0:
        raise ValueError(f"energy={energy!r} is outside its valid range (0, 1]")
    four = excitation.fourier()
    top = four["stiffness"].size - 1
    if isinstance(max_order, bool) or int(max_order) != max_order or not 1 <= max_order <= top:
        raise ValueError(f"max_order={max_order!r} is outside its valid range: integers "
                         f"1..{top}")
    share = np.zeros(int(max_order))
    for name in ("stiffness", "stiffness_error"):
        a2 = np.abs(four[name][1:int(max_order) + 1]) ** 2
        if a2.sum() > 0.0:
            share += a2 / a2.sum()
    rank = np.argsort(-share, kind="stable")
    total = share.sum()
    n = int(np.searchsorted(np.cumsum(share[rank]), energy * total * (1 - 1e-12))) + 1
    keep = rank[:min(n, rank.size)] + 1
    extra = np.zeros(0, np.int64) if always is None else np.asarray(always, np.int64)
    return np.unique(np.concatenate([[0], keep, extra[(extra >= 0) & (extra <= max_order)]]))


@dataclass(frozen=True)
class OrderExcitation:
    """Fourier data of an excitation for a set of orders (reusable over speeds).

    Attributes
    ----------
    orders : ndarray of int
        The kept long-period harmonics ``J`` (sorted, ``J[0] = 0``).
    n_time : int
        AFT instants per long period (> 4 max J: the products of ``k`` and the response
        alias nowhere into ``J``).
    k_grid, ke_grid : ndarray, (n_time,)
        Stiffness ``k`` and ``k e`` band-limited to ``2 max J`` on the AFT grid.
    stiffness_error : ndarray, complex (|J|,)
        ``(k e)_j``, ``j`` in ``J``.
    mean_stiffness : float
        ``k_bar`` [N/m].
    linear_blocks : ndarray, complex (|J|, 2 |J| - 1)
        Real-form coupling of ``J`` through ``k - k_bar`` (:func:`_order_blocks`).
    """

    orders: np.ndarray
    n_time: int
    k_grid: np.ndarray
    ke_grid: np.ndarray
    stiffness_error: np.ndarray
    mean_stiffness: float
    linear_blocks: np.ndarray

    @property
    def n_harmonics(self) -> int:
        """Largest kept harmonic ``max J``."""
        return int(self.orders[-1])


def _band_limited(one_sided: np.ndarray, limit: int, n_time: int) -> np.ndarray:
    c = np.zeros(n_time // 2 + 1, dtype=complex)
    m = min(limit, one_sided.size - 1, n_time // 2 - 1)
    c[:m + 1] = one_sided[:m + 1]
    return np.fft.irfft(c * n_time, n=n_time)


def _order_blocks(dk: np.ndarray, J: np.ndarray) -> np.ndarray:
    """``C`` with ``(T[dk] x)_j = C @ [Re x_0, Re x_l, Im x_l]`` for ``j``, ``l > 0`` in ``J``.

    ``dk``: one-sided harmonics of a real signal (index ``>= 2 max J``); ``x``: two-sided
    harmonics of a real signal on ``+-J``, so ``sum_l dk_{j-l} x_l = dk_j x_0 + sum_{l>0}
    (dk_{j-l} + dk_{j+l}) Re x_l + i (dk_{j-l} - dk_{j+l}) Im x_l``.
    """
    def at(k: np.ndarray) -> np.ndarray:
        v = dk[np.abs(k)]
        return np.where(k >= 0, v, np.conj(v))

    j = J[:, None]
    lp = J[None, 1:]
    P, Q = at(j - lp), at(j + lp)
    return np.concatenate([at(J)[:, None], P + Q, 1j * (P - Q)], axis=1)


def prepare_orders(excitation: MeshExcitation, orders: np.ndarray) -> OrderExcitation:
    """Fourier data of ``excitation`` on the long-period harmonics ``orders``.

    Parameters
    ----------
    excitation : MeshExcitation
        Mesh stiffness and error over the long period.
    orders : array_like of int
        Long-period harmonics to keep (0 is added; e.g. :func:`sideband_orders`).

    Returns
    -------
    OrderExcitation
    """
    J = np.unique(np.concatenate([[0], np.asarray(orders, dtype=np.int64).ravel()]))
    if J[0] < 0:
        raise ValueError(f"orders contain {int(J[0])}, outside the valid range: integers >= 0")
    four = excitation.fourier()
    top = four["stiffness"].size - 1
    if J[-1] > top:
        raise ValueError(f"orders up to {int(J[-1])} exceed the {top} harmonics the excitation "
                         f"samples resolve ({excitation.tau.size} positions per long period)")
    kbar = float(np.real(four["stiffness"][0]))
    limit = min(2 * int(J[-1]), top)
    dk = np.zeros(2 * int(J[-1]) + 1, dtype=complex)
    dk[1:limit + 1] = four["stiffness"][1:limit + 1]
    n_time = 1 << int(math.ceil(math.log2(4 * int(J[-1]) + 2)))
    return OrderExcitation(
        orders=J, n_time=n_time, k_grid=_band_limited(four["stiffness"], limit, n_time),
        ke_grid=_band_limited(four["stiffness_error"], limit, n_time),
        stiffness_error=four["stiffness_error"][J], mean_stiffness=kbar,
        linear_blocks=_order_blocks(dk, J))


def _solve_real(h: np.ndarray, blocks: np.ndarray, rhs: np.ndarray) -> np.ndarray:
    """Solve ``(I + diag(h) T) x = b`` on ``J`` in real form; returns one-sided ``x_J``."""
    n = h.size
    M = h[:, None] * blocks
    A = np.concatenate([M.real, M.imag[1:]])
    idx = np.arange(2 * n - 1)
    A[idx, idx] += 1.0
    y = sla.solve(A, np.concatenate([rhs.real, rhs.imag[1:]]), check_finite=True)
    x = y[:n].astype(complex)
    x[1:] += 1j * y[n:]
    return x


def _to_time(prep: OrderExcitation, x: np.ndarray) -> np.ndarray:
    N = prep.n_time
    c = np.zeros(N // 2 + 1, dtype=complex)
    c[prep.orders] = x
    return np.fft.irfft(c * N, n=N)


def _residual(x, prep, h, static, backlash):
    delta_t = _to_time(prep, x)
    force, slope, front, back = _contact_force(prep, delta_t, backlash)
    r = np.fft.rfft(force - prep.mean_stiffness * delta_t)[prep.orders] / prep.n_time
    R = x + h * r
    R[0] -= static
    return R, float(np.abs(R).max() / max(np.abs(x).max(), 1e-300)), slope, r


def solve_periodic_orders(
    model: ModalModel,
    prep: OrderExcitation,
    period: float,
    speed: float,
    *,
    backlash: float = math.inf,
    tol: float = 1e-9,
    max_iter: int = 40,
    initial: np.ndarray | None = None,
    receptance: dict[str, np.ndarray] | None = None,
    channels: list[str] | None = None,
) -> PeriodicSolution:
    """Periodic steady state over the long period on the orders of ``prep``.

    Parameters
    ----------
    model : ModalModel
        Reduced rotor (mean stiffness equal to ``prep.mean_stiffness``).
    prep : OrderExcitation
        From :func:`prepare_orders`.
    period : float
        Long period [s].
    speed : float
        Reference speed [rad/s] (gyroscopic terms).
    backlash : float
        Normal backlash [m] (``inf``: no back-flank contact).
    tol : float
        Newton tolerance on ``max |R_j| / max |delta_j|``.
    max_iter : int
        Newton iterations (semi-smooth Newton with backtracking, as the full balance).
    initial : ndarray, optional
        One-sided ``delta_j`` on ``prep.orders`` to start from (continuation).
    receptance : dict, optional
        :meth:`ModalModel.receptances` at ``j w0``, ``j`` in ``prep.orders``.
    channels : list of str, optional
        Outputs to compute (default all of the model's channels).

    Returns
    -------
    PeriodicSolution
        Its ``delta``, ``force``, ``remainder`` and channels are over ``prep.orders`` (not
        ``0..H``); ``status`` 0 converged, 1 Newton did not converge, 2 singular system.
    """
    if not (math.isfinite(period) and period > 0):
        raise ValueError(f"period={period!r} is outside its valid range (0, inf) s")
    if abs(prep.mean_stiffness - model.mean_stiffness) > 1e-9 * model.mean_stiffness:
        raise ValueError("the model's mean mesh stiffness differs from the excitation's")
    names = list(model.channels) if channels is None else channels
    J = prep.orders
    if receptance is None:
        receptance = model.receptances(speed, 2.0 * np.pi / period * J, names)
    h = receptance["mesh"]
    rhs = h * prep.stiffness_error
    rhs[0] += model.mesh_static
    status, start, iterations = STATUS_CONVERGED, "linear" if initial is None else "given", 0
    try:
        x = (_solve_real(h, prep.linear_blocks, rhs) if initial is None
             else np.asarray(initial, dtype=complex).copy())
    except (sla.LinAlgError, ValueError):
        x, status = np.zeros(J.size, dtype=complex), STATUS_SINGULAR
    x[0] = x[0].real
    R, res, slope, r = _residual(x, prep, h, model.mesh_static, backlash)
    while status == STATUS_CONVERGED and res > tol:
        if iterations >= max_iter:
            status = STATUS_NOT_CONVERGED
            break
        iterations += 1
        dk = np.fft.rfft(slope)[:2 * int(J[-1]) + 1] / prep.n_time
        dk[0] -= prep.mean_stiffness
        try:
            step = _solve_real(h, _order_blocks(dk, J), -R)
        except (sla.LinAlgError, ValueError):
            status = STATUS_SINGULAR
            break
        # x_0 and step_0 are real (_solve_real), so every trial's mean stays real
        trial, (R_t, res_t, slope_t, r_t), accepted = _backtrack(
            x, step, res, lambda z: _residual(z, prep, h, model.mesh_static, backlash))
        if not accepted:
            status = STATUS_NOT_CONVERGED
            break
        x, R, res, slope, r = trial, R_t, res_t, slope_t, r_t
    delta_t = _to_time(prep, x)
    force, _, front, back = _contact_force(prep, delta_t, backlash)
    n_sep = float(np.mean(~front & ~back))
    return PeriodicSolution(
        period=period, delta=x.copy(), force=np.fft.rfft(force)[J] / prep.n_time,
        remainder=r, status=status, iterations=iterations, residual=res,
        contact_loss_fraction=n_sep, back_contact_fraction=float(np.mean(back)),
        min_force=float(force.min()), branch=contact_branch(back.any(), n_sep > 0),
        start=start).with_channels(model, receptance, names)


def synthesize_orders(harmonics: np.ndarray, orders: np.ndarray, t: np.ndarray,
                      period: float) -> np.ndarray:
    """Real signal ``sum_j c_j exp(2 pi i j t / T)`` over ``+-orders`` (one-sided ``c``)."""
    orders = np.asarray(orders)
    ph = np.exp(2j * np.pi * np.outer(np.asarray(t, dtype=float), orders[1:]) / period)
    return np.real(harmonics[0]) + 2.0 * np.real(ph @ harmonics[1:])


def mesh_force_on_grid(prep: OrderExcitation, sol: PeriodicSolution,
                       backlash: float = math.inf) -> np.ndarray:
    """Mesh force [N] of a solution on the AFT grid of the long period (exact contact law).

    Its extremes are the mesh force's extremes to the grid spacing ``T / n_time``.
    """
    force, _, _, _ = _contact_force(prep, _to_time(prep, sol.delta), backlash)
    return force


def excitation_from_long_period(ds: object) -> MeshExcitation:
    """The rotor's mesh excitation from a long-period LTCA Dataset.

    ``ds``: a result of :func:`gearuq.gears.long_period.long_period_ltca` or of
    :func:`gearuq.gears.ltca.ltca` over the long period (``ste`` in um, ``lpms_tangent`` in
    N/um, ``normal_force_N`` in the attrs); the mesh is linearised with the tangent stiffness
    as in :meth:`MeshExcitation.from_setup`. Raises ValueError when a position's status is
    not 0 (a load the LTCA could not carry is never passed on).
    """
    status = np.asarray(ds["status"])
    if np.any(status != 0):
        bad = int(np.flatnonzero(status != 0)[0])
        raise ValueError(f"status={int(status[bad])} at position {bad} of the LTCA: a position "
                         "that did not converge is outside what the excitation accepts")
    tau = np.asarray(ds["tau"], dtype=float)
    ste = np.asarray(ds["ste"], dtype=float) * 1e-6
    k_t = np.asarray(ds["lpms_tangent"], dtype=float) * 1e6
    P = float(ds.attrs["normal_force_N"])
    ppc = int(round(1.0 / (tau[1] - tau[0])))
    return MeshExcitation(
        tau=tau, stiffness=k_t, error=ste - P / k_t, normal_force=P,
        n_cycles=int(round(tau.size / ppc)), ste=ste,
        secant_stiffness=np.asarray(ds["lpms"], dtype=float) * 1e6,
        secant_error=np.asarray(ds["cms"], dtype=float) * 1e-6,
        contact_loss_fraction=np.asarray(ds["contact_loss_fraction"], dtype=float),
        meta={"source": str(ds.attrs.get("model", "ltca")), "torque_Nm":
              float(ds.attrs.get("torque_Nm", math.nan)), "tangent": "ltca",
              "positions_per_cycle": ppc})


# ------------------------------------------------------------------ every harmonic, iteratively
STATUS_CONTACT_LOSS = 4


@dataclass(frozen=True)
class KrylovExcitation:
    """Fourier data for the balance on every harmonic ``0..H`` by GMRES (reusable).

    Attributes
    ----------
    n_harmonics : int
        ``H = n_mesh_harmonics x n_cycles`` (every harmonic of the long period up to the
        highest mesh order kept).
    n_cycles : int
        Mesh cycles per long period ``L``.
    n_time : int
        Instants per long period of the FFT products (> 4 H).
    k_grid, ke_grid : ndarray, (n_time,)
        ``k`` and ``k e`` band-limited to ``2 H``.
    stiffness_error : ndarray, complex (H + 1,)
        ``(k e)_j``.
    mesh_stiffness : ndarray, complex (2 n_mesh_harmonics + 1,)
        ``dk_{mL}``, ``m = 0..2 n_mesh`` (``dk_0 = 0``): the stiffness fluctuation repeated
        every mesh cycle, the preconditioner's part.
    mean_stiffness : float
        ``k_bar`` [N/m].
    class_index : ndarray of int, (L, 2 n_mesh_harmonics + 1)
        Two-sided index ``j + H`` of the members ``j = r + m L`` of each residue class
        ``r``, -1 where ``|j| > H`` (the preconditioner's layout, fixed over speeds).
    class_coupling : ndarray, complex (2 n_mesh_harmonics + 1,) * 2
        ``dk_{(a - b) L}``: the mesh-order stiffness coupling within a class.
    """

    n_harmonics: int
    n_cycles: int
    n_time: int
    k_grid: np.ndarray
    ke_grid: np.ndarray
    stiffness_error: np.ndarray
    mesh_stiffness: np.ndarray
    mean_stiffness: float
    class_index: np.ndarray
    class_coupling: np.ndarray


def prepare_krylov(excitation: MeshExcitation, n_mesh_harmonics: int,
                   n_time: int | None = None) -> KrylovExcitation:
    """Fourier data of ``excitation`` for :func:`solve_periodic_krylov`.

    Parameters
    ----------
    excitation : MeshExcitation
        Mesh stiffness and error over the long period.
    n_mesh_harmonics : int
        Mesh orders kept, >= 1 (``H = n_mesh_harmonics x lcm``).
    n_time : int, optional
        Instants per long period of the FFT products and of the contact law (> 4 H). Default
        the smallest ``2^a 3^b 5^c`` above ``4 H``. In full contact the solution does not
        depend on it; with contact loss the grid is the law's discretisation, and the dense
        balance's (the next power of two) gives the dense balance's solution.
    """
    n = n_mesh_harmonics
    if isinstance(n, bool) or int(n) != n or n < 1:
        raise ValueError(f"n_mesh_harmonics={n!r} is outside its valid range: integers >= 1")
    L = int(excitation.n_cycles)
    H = int(n) * L
    four = excitation.fourier()
    top = four["stiffness"].size - 1
    if H > top:
        raise ValueError(f"n_mesh_harmonics={n} needs {H} harmonics; the excitation resolves "
                         f"{top} ({excitation.tau.size} positions per long period)")
    limit = min(2 * H, top)
    # products alias nowhere into 0..H for n_time > 4 H; a 2^a 3^b 5^c length, not the next
    # power of two (27/79, H = 6399: 25 600 instants instead of 32 768)
    if n_time is None:
        n_time = _fft.next_fast_len(4 * H + 2, real=True)
    elif isinstance(n_time, bool) or int(n_time) != n_time or n_time < 4 * H + 2:
        raise ValueError(f"n_time={n_time!r} is outside its valid range: integers >= "
                         f"{4 * H + 2} (4 H + 2)")
    n_time = int(n_time)
    dk = np.zeros(2 * H + 1, dtype=complex)
    dk[1:limit + 1] = four["stiffness"][1:limit + 1]
    mesh_stiffness = dk[::L][:2 * int(n) + 1].copy()
    m = np.arange(-int(n), int(n) + 1)
    j = np.arange(L)[:, None] + m[None, :] * L  # class r: r + m L
    return KrylovExcitation(
        n_harmonics=H, n_cycles=L, n_time=n_time,
        k_grid=_band_limited(four["stiffness"], limit, n_time),
        ke_grid=_band_limited(four["stiffness_error"], limit, n_time),
        stiffness_error=four["stiffness_error"][:H + 1].copy(),
        mesh_stiffness=mesh_stiffness,
        mean_stiffness=float(np.real(four["stiffness"][0])),
        class_index=np.where((j >= -H) & (j <= H), j + H, -1),
        class_coupling=_class_toeplitz(mesh_stiffness))


def _class_toeplitz(c: np.ndarray) -> np.ndarray:
    """``T[a, b] = c_{a - b}`` (``c_{-k} = conj(c_k)``) from the one-sided ``c_0..c_{2n}``."""
    n = (c.size - 1) // 2
    d = np.arange(-n, n + 1)[:, None] - np.arange(-n, n + 1)[None, :]
    return np.where(d >= 0, c[np.abs(d)], np.conj(c[np.abs(d)]))


def _class_blocks(prep: KrylovExcitation, h_two: np.ndarray,
                  coupling: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """LU factors of ``I + diag(h) T[dk_mesh]`` per residue class ``j mod L`` (``r <= L/2``).

    ``coupling``: the Toeplitz ``T`` of another mesh-periodic weight (default
    ``prep.class_coupling``, the stiffness fluctuation's).

    Two-sided index ``j = -H..H``; class ``r`` holds ``r + m L``, ``m = -n..n``
    (``prep.class_index``, -1 padding, whose rows and columns are those of the identity).
    Only classes ``0..L // 2`` are factored: class ``L - r`` holds the negatives of class
    ``r``'s members ``m = -n..n-1`` (``m = n`` is padding for ``r > 0``), and ``h_{-j} =
    conj(h_j)``, ``dk_{-k} = conj(dk_k)`` for a real signal, so its solution is the
    conjugate of class ``r``'s on those members; classes ``r > 0`` are factored on their
    ``2 n`` members only. Returns ``(lu, piv)`` for
    :func:`gearuq.rotor._spectral_kernels.apply_class_factors`.
    """
    from gearuq.rotor._spectral_kernels import class_factors  # numba: imported for cost

    T = prep.class_coupling if coupling is None else coupling
    # compiled: numpy's batched inv of 7 x 7 blocks was mostly per-block overhead; LU
    # factors instead of inverses: a third of the arithmetic (0.73 -> 0.25 ms per speed
    # for 27/79, the solves 0.05 ms dearer per application)
    return class_factors(prep.class_index, np.ascontiguousarray(h_two, dtype=complex),
                         np.ascontiguousarray(T, dtype=complex))


#: Krylov vectors kept before GMRES restarts (at contact loss near a resonance GMRES(50)
#: stagnated: 10 000 iterations for four decades where GMRES(300) took 1100 for three).
GMRES_RESTART = 100

#: Largest relative tolerance of a Newton step's GMRES solve (inexact Newton): at 12 % contact
#: loss 520 GMRES iterations to the same steady state where exact steps took 6650.
NEWTON_FORCING_MAX = 0.3

#: GMRES iterations a steady state may spend over all its solves (``max_iter``): at about
#: 1.4 ms each for a 27/79 pair, a few seconds; reached, the steady state returns status 1.
GMRES_BUDGET = 3000


def _gmres(apply_a: Callable[[np.ndarray], np.ndarray],
           apply_m: Callable[[np.ndarray], np.ndarray], b: np.ndarray, x0: np.ndarray | None,
           rtol: float, restart: int, max_iterations: int, *,
           by_products: Callable[[], tuple[np.ndarray, ...]] | None = None,
           ) -> tuple[np.ndarray, bool, int, tuple[np.ndarray, ...] | None]:
    """Right-preconditioned restarted GMRES: ``||b - A x|| <= rtol ||b||``.

    With the preconditioner on the right the least-squares residual of the Arnoldi basis is
    the residual of ``A x = b`` itself, so convergence needs no extra product to confirm
    (scipy's left-preconditioned ``gmres`` checks the true residual after every cycle: one
    FFT product more per solve, a fifth of a continued solve's products). Classical
    Gram-Schmidt applied twice (BLAS products). At most ``max_iterations`` products with
    ``A`` in all (restarts included): on reaching it, the iterate so far is returned with
    converged False. Returns ``x``, converged, iterations and ``x``'s by-products.

    ``by_products``, when given, returns what the last call of ``apply_a`` computed on the
    way that is linear in its argument (e.g. the vector's FFT); they are combined as the
    vectors are, so that ``x``'s come without another product (None when ``x`` is zero).
    """
    n = b.size
    target = rtol * float(np.linalg.norm(b))
    x = np.zeros(n) if x0 is None else np.array(x0, dtype=float)
    parts = None  # by-products of x (None: x is zero)
    if x0 is not None and np.any(x):
        r = b - apply_a(x)
        parts = None if by_products is None else by_products()
    else:
        r = b.copy()
    total = 0
    while total < max_iterations:
        beta = float(np.linalg.norm(r))
        if beta <= target:
            return x, True, total, parts
        restart = min(restart, max_iterations - total)
        # rows added as needed: a continued solve takes 2-4 of the `restart` (fresh
        # multi-megabyte buffers per call were a fifth of the solve)
        V = np.empty((min(restart + 1, 8), n))
        Z = np.empty((min(restart, 8), n))
        Hm = np.zeros((restart + 1, restart))
        cs, sn = np.zeros(restart), np.zeros(restart)
        g = np.zeros(restart + 1)
        g[0] = beta
        V[0] = r / beta
        made: list[tuple[np.ndarray, ...]] = []
        k = 0
        for k in range(restart):
            if k + 1 >= V.shape[0]:
                V = np.concatenate([V, np.empty((min(V.shape[0], restart + 1 - V.shape[0]),
                                                 n))])
                Z = np.concatenate([Z, np.empty((V.shape[0] - 1 - Z.shape[0], n))])
            Z[k] = apply_m(V[k])
            w = apply_a(Z[k])
            if by_products is not None:
                made.append(by_products())
            for _twice in range(2):  # CGS2: orthogonal to rounding
                c = V[:k + 1] @ w
                w -= c @ V[:k + 1]
                Hm[:k + 1, k] += c
            Hm[k + 1, k] = float(np.linalg.norm(w))
            exact = Hm[k + 1, k] == 0.0  # the Krylov space holds the solution
            if not exact:
                V[k + 1] = w / Hm[k + 1, k]
            for i in range(k):  # previous rotations, then this column's
                Hm[i, k], Hm[i + 1, k] = (cs[i] * Hm[i, k] + sn[i] * Hm[i + 1, k],
                                          -sn[i] * Hm[i, k] + cs[i] * Hm[i + 1, k])
            d = math.hypot(Hm[k, k], Hm[k + 1, k])
            cs[k], sn[k] = (Hm[k, k] / d, Hm[k + 1, k] / d) if d > 0.0 else (1.0, 0.0)
            Hm[k, k], Hm[k + 1, k] = d, 0.0
            g[k], g[k + 1] = cs[k] * g[k], -sn[k] * g[k]
            total += 1
            if abs(g[k + 1]) <= target or exact:
                break
        y = sla.solve_triangular(Hm[:k + 1, :k + 1], g[:k + 1], check_finite=False)
        x = x + y @ Z[:k + 1]
        if by_products is not None:
            step = [sum(yi * p[m] for yi, p in zip(y, made, strict=True))
                    for m in range(len(made[0]))]
            parts = tuple(step) if parts is None else tuple(
                a + c for a, c in zip(parts, step, strict=True))
        if abs(g[k + 1]) <= target:
            return x, True, total, parts
        r = b - apply_a(x)
    return x, bool(np.linalg.norm(r) <= target), total, parts


def solve_periodic_krylov(
    model: ModalModel,
    prep: KrylovExcitation,
    period: float,
    speed: float,
    *,
    tol: float = 1e-10,
    max_iter: int = GMRES_BUDGET,
    contact_loss: bool = True,
    newton_tol: float = 1e-9,
    max_newton: int = 40,
    receptance: dict[str, np.ndarray] | None = None,
    channels: list[str] | None = None,
    initial: np.ndarray | None = None,
    newton_start: np.ndarray | None = None,
) -> PeriodicSolution:
    """Steady state on every harmonic ``0..H`` of the long period, by preconditioned GMRES.

    The balance of :func:`gearuq.rotor.harmonic_balance.solve_periodic` (no back flank),
    without forming the Toeplitz matrix: products with the stiffness by FFT on the long
    period (``O(H log H)``), and as preconditioner the exact solve with the mesh-order part
    of the stiffness alone, which couples harmonic ``j`` only with ``j +- m L`` (one small
    block per residue class). The rest of the fluctuation (its long-period part, from the
    pitch deviations) is small, so GMRES converges in a few iterations. Full contact is one
    linear solve; when the flanks separate, semi-smooth Newton on the exact contact law
    follows (each step a GMRES solve of ``I + diag(h) T[c k - k_bar]``, ``c`` the contact
    indicator, same preconditioner), with backtracking on the residual as the full balance.

    Parameters
    ----------
    model : ModalModel
        Reduced rotor (mean stiffness equal to ``prep.mean_stiffness``).
    prep : KrylovExcitation
        From :func:`prepare_krylov`.
    period, speed : float
        Long period [s] and reference speed [rad/s].
    tol : float
        GMRES relative residual tolerance (of the full-contact solve, and of Newton's last
        steps: earlier steps are solved to at most ``NEWTON_FORCING_MAX``, Eisenstat and
        Walker's inexact Newton).
    max_iter : int
        GMRES iterations of the whole steady state, over all its solves (the budget that
        bounds its cost: near a resonance with contact loss Newton's method can stagnate);
        reached, the steady state returns status 1.
    contact_loss : bool
        Solve the contact law when the full-contact solution separates; False: return it
        with status 4.
    newton_tol, max_newton : float, int
        Newton tolerance on ``max |R_j| / max |delta_j|`` and iteration limit.
    receptance : dict, optional
        :meth:`ModalModel.receptances` at ``j w0``, ``j = 0..H``.
    channels : list of str, optional
        Outputs to compute (default all of the model's channels).
    initial : ndarray, complex (H + 1,), optional
        Start of GMRES for the full-contact solve (e.g. the neighbouring speed's ``delta``);
        the tolerance stays relative to the right-hand side, so a close start saves
        iterations without changing what is converged to.
    newton_start : ndarray, complex (H + 1,), optional
        Start of Newton's method when the flanks separate (e.g. the neighbouring speed's
        contact-loss ``delta``), taken when its residual is below the linear solution's.

    Returns
    -------
    PeriodicSolution
        Over harmonics ``0..H``; ``status`` 0 converged, 1 GMRES or Newton did not
        converge (``max_iter``, ``max_newton`` or a failed line search), 4 contact loss
        not solved (``contact_loss=False``); ``iterations`` counts
        GMRES iterations over all solves.
    """
    from gearuq.rotor._spectral_kernels import apply_class_factors  # numba: for cost

    if not (math.isfinite(period) and period > 0):
        raise ValueError(f"period={period!r} is outside its valid range (0, inf) s")
    if abs(prep.mean_stiffness - model.mean_stiffness) > 1e-9 * model.mean_stiffness:
        raise ValueError("the model's mean mesh stiffness differs from the excitation's")
    H, N = prep.n_harmonics, prep.n_time
    names = list(model.channels) if channels is None else channels
    if receptance is None:
        receptance = model.receptances(speed, 2.0 * np.pi / period * np.arange(H + 1), names)
    h = receptance["mesh"]
    kbar = prep.mean_stiffness
    if initial is not None and np.shape(initial) != (H + 1,):
        raise ValueError(f"initial has shape {np.shape(initial)}, outside the valid shape "
                         f"({H + 1},): one-sided harmonics 0..H")

    def to_complex(v):  # real [Re x_0..x_H, Im x_1..x_H] -> one-sided complex
        x = v[:H + 1].astype(complex)
        x[1:] += 1j * v[H + 1:]
        return x

    def to_real(x):
        return np.concatenate([x.real, x.imag[1:]])

    last: list[tuple[np.ndarray, np.ndarray]] = []

    def operator(weight):  # v -> v + h (weight v)_j, weight(t) on the grid
        def apply(v):
            x = to_complex(v)
            t = _fft.irfft(x * N, n=N)
            p = _fft.rfft(t * weight)[:H + 1] / N
            last[:] = [(t, p)]  # linear in v: GMRES combines them into the solution's
            return to_real(x + h * p)
        return apply

    h_two = np.concatenate([np.conj(h[:0:-1]), h])
    blocks = [_class_blocks(prep, h_two)]  # replaced per Newton step (contact indicator)
    idx = prep.class_index

    def precondition(v):
        # one solve per class r <= L/2 gives classes r and L - r, in the real layout
        return apply_class_factors(*blocks[0], idx, np.ascontiguousarray(v, dtype=float))

    count = [0]

    def solve(weight, b, x0=None, rtol=tol, **kw):
        # one budget for the whole steady state: what is left of it bounds this solve
        v, ok, its, parts = _gmres(operator(weight), precondition, b, x0, rtol,
                                   GMRES_RESTART, max(max_iter - count[0], 0), **kw)
        count[0] += its
        return v, ok, parts

    def residual(x, product=None):
        # product: (delta(t), ((k - k_bar) delta)_j) of x when known (the full-contact
        # solve's, combined by GMRES): in full contact r = ((k - k_bar) delta)_j - (k e)_j
        # (k e is band-limited to 2 H), so the residual needs no FFT
        delta_t = _fft.irfft(x * N, n=N) if product is None else product[0]
        F = prep.k_grid * delta_t - prep.ke_grid
        if product is not None and F.min() > 0.0:
            r = product[1] - prep.stiffness_error
        else:
            r = _fft.rfft(np.maximum(F, 0.0) - kbar * delta_t)[:H + 1] / N
        R = x + h * r
        R[0] -= model.mesh_static
        return R, float(np.abs(R).max() / max(np.abs(x).max(), 1e-300)), F, r

    rhs = h * prep.stiffness_error
    rhs[0] += model.mesh_static
    v, ok, product = solve(prep.k_grid - kbar, to_real(rhs), None if initial is None else
                           to_real(np.asarray(initial, dtype=complex)),
                           by_products=lambda: last[0])
    x = to_complex(v)
    R, res, F, r = residual(x, product)
    status = STATUS_CONVERGED if ok else STATUS_NOT_CONVERGED
    n_newton, eta, res_before = 0, NEWTON_FORCING_MAX, res
    if ok and F.min() <= 0.0:
        if not contact_loss:
            status = STATUS_CONTACT_LOSS
        elif newton_start is not None:
            # a neighbouring speed's contact-loss solution: Newton starts there when it
            # meets the contact law better than the linear solution does
            guess = np.asarray(newton_start, dtype=complex)
            evaluated = residual(guess)
            if evaluated[1] < res:
                x, (R, res, F, r) = guess, evaluated
        while contact_loss and res > newton_tol:
            if n_newton >= max_newton:
                status = STATUS_NOT_CONVERGED
                break
            n_newton += 1
            weight = np.where(F > 0.0, prep.k_grid, 0.0) - kbar
            # preconditioner: the weight's mesh-periodic part (its harmonics at m L, mean
            # included), i.e. the contact indicator averaged over the mesh cycles; with the
            # full-contact blocks GMRES took thousands of iterations at 31 % contact loss
            M = prep.class_coupling.shape[0]
            blocks[0] = _class_blocks(prep, h_two, _class_toeplitz(
                _fft.rfft(weight)[::prep.n_cycles][:M] / N))
            # inexact Newton (Eisenstat and Walker's second forcing term): a loose linear
            # solve while the contact law is far from met, tight near the solution (first
            # step: res_before = res gives the cap); their safeguard: no sudden tightening
            floor = 0.9 * eta ** 2
            eta = min(NEWTON_FORCING_MAX, max(0.9 * (res / res_before) ** 2,
                                              floor if floor > 0.1 else 0.0))
            res_before = res
            step, ok, _ = solve(weight, -to_real(R), rtol=max(tol, eta))
            if not ok:
                status = STATUS_NOT_CONVERGED
                break
            step = to_complex(step)
            trial, (R_t, res_t, F_t, r_t), accepted = _backtrack(x, step, res, residual)
            if not accepted:
                status = STATUS_NOT_CONVERGED
                break
            x, R, res, F, r = trial, R_t, res_t, F_t, r_t
    if status != STATUS_CONTACT_LOSS:
        force = np.maximum(F, 0.0)
        # r holds force - k_bar delta on 0..H, delta is band-limited to H: no FFT needed
        force_hat = r + kbar * x
    else:
        force = F
        force_hat = _fft.rfft(force)[:H + 1] / N
    n_sep = float(np.mean(F <= 0.0))
    return PeriodicSolution(
        period=period, delta=x, force=force_hat, remainder=r,
        status=status, iterations=count[0], residual=res, contact_loss_fraction=n_sep,
        back_contact_fraction=0.0, min_force=float(force.min()),
        branch=contact_branch(False, n_sep > 0), start="linear",
        min_approach=float(np.min((F + prep.ke_grid) / prep.k_grid))
    ).with_channels(model, receptance, names)


# ------------------------------------------------------------- the periodic state in time
#: Long periods :func:`solve_periodic_by_integration` integrates at most (from a start near
#: the steady state the return map settled in 2-10 on the 27/79 stage, 0.1 s each; a 13/17
#: stage rattling on the back flank at damping ratio 0.01 took 37, 4 ms each).
INTEGRATION_PERIODS = 100
#: Long periods at the end of an integration whose largest mesh force is kept
#: (``PeriodicSolution.window_peak_force``): what K_v reads where no periodic response is
#: found and the option ``aperiodic_response="window_max"`` asks for a value (on the 27/79
#: stage 10 long periods are 21 330 mesh cycles, 2-3 s of running at 10 000 rpm).
WINDOW_PERIODS = 10
#: Mesh cycles over which the state's change over a long period must shrink for the
#: integration of a long-period problem to go on (``stall_periods`` of
#: :func:`solve_periodic_by_integration`, at least ``MIN_STALL_PERIODS`` periods; checked
#: from twice that on): the transients of the rotor's modes decay within a few hundred mesh
#: cycles at 1 % damping, so a change that has not shrunk over 20 000 mesh cycles belongs to
#: a response that is not periodic on the long period (quasi-periodic, chaotic, a
#: subharmonic of it) or to a departure from an unstable one still under way. On the 27/79
#: stage (2133 mesh cycles, about 0.1 s of CPU a long period) the integration then stops
#: after 20 periods at the earliest instead of 100. A one-cycle mesh can take a hundred
#: periods to leave an unstable response (the test's 3700 rpm: the change grows from 0.05 to
#: 0.67 toward a period-2 response): with fewer than 400 mesh cycles a long period the rule
#: cannot act within 100 periods.
STALL_MESH_CYCLES = 20_000
MIN_STALL_PERIODS = 10


def stall_periods_for(n_cycles: int) -> int:
    """``stall_periods`` of a long period of ``n_cycles`` mesh cycles: the periods that
    hold :data:`STALL_MESH_CYCLES`, at least :data:`MIN_STALL_PERIODS`."""
    return max(MIN_STALL_PERIODS, math.ceil(STALL_MESH_CYCLES / n_cycles))

#: Relative change of the state over one long period (energy norm) taken as periodic (below
#: the step's own error; 1e-8 took a period more per speed and moved K_v by 2.5e-8).
INTEGRATION_TOL = 1e-6


def _modal_state_at_zero(model: ModalModel, speed: float, remainder: np.ndarray,
                         period: float) -> np.ndarray:
    """Modal state ``[eta, eta']`` at ``t = 0`` of the response to ``r`` (one-sided harmonics).

    ``y_j = (i w_j - A)^-1 B f_j`` with ``f_j = load [j = 0] - psi r_j`` through the state
    matrix's eigen-solution: one pass over (pole, harmonic) where a solve per harmonic
    (:func:`gearuq.rotor.time_integration.initial_state`) took 0.2-0.7 s for 6400 of them.
    """
    n = model.n_modes
    lam, X = np.linalg.eig(model.state_matrix(speed))
    u = np.linalg.solve(X, np.concatenate([np.zeros(n), model.mesh]))
    w = 2.0 * np.pi / period * np.arange(1, remainder.size)
    # sum_j -r_j / (i w_j - lam_k), j >= 1, for every pole at once
    s = np.array([np.sum(-remainder[1:] / (1j * w - p)) for p in lam])
    y = 2.0 * np.real(X @ (u * s))
    y[:n] += (model.load - model.mesh * remainder[0].real) / model.omega ** 2  # j = 0
    return y


def solve_periodic_by_integration(
    model: ModalModel,
    prep: KrylovExcitation,
    period: float,
    speed: float,
    *,
    start: PeriodicSolution | None = None,
    backlash: float = math.inf,
    tol: float = INTEGRATION_TOL,
    max_periods: int = INTEGRATION_PERIODS,
    steps_per_instant: int = 2,
    receptance: dict[str, np.ndarray] | None = None,
    channels: list[str] | None = None,
    window_periods: int = WINDOW_PERIODS,
    stall_periods: int | None = None,
) -> PeriodicSolution:
    """Periodic steady state of the reduced rotor by integrating it in time, long period by
    long period, until its state returns to itself (front flank, apart, back flank).

    Where semi-smooth Newton on the balance stagnates under heavy contact loss (each of its
    GMRES solves then takes thousands of iterations), the reduced model integrated from
    Newton's best iterate settles on a periodic response within a few long periods, at
    about a tenth of a second each for a 27/79 stage (docs/theory/geared_rotor.md).
    Classical Runge-Kutta with ``steps_per_instant x n_time`` steps per long period, the
    stiffness and ``k e``
    of ``prep`` (band-limited to ``2 H``) resampled on the steps' ends and midpoints, the
    contact law exact at each stage (its switching inside a step is not located). The
    returned harmonics ``0..H`` are those of the last period's approach and force on the
    ``n_time`` instants, so that the outputs (K_v from the force series, the DTE) are read
    as the balance's are.

    Parameters
    ----------
    model : ModalModel
        Reduced rotor (mean stiffness equal to ``prep.mean_stiffness``).
    prep : KrylovExcitation
        From :func:`prepare_krylov`.
    period, speed : float
        Long period [s] and reference speed [rad/s].
    start : PeriodicSolution, optional
        Harmonics to start from (e.g. Newton's best iterate: its branch); default the
        static state under the load.
    backlash : float
        Normal backlash [m] (``inf``: no back-flank contact).
    tol : float
        Largest relative change of the state over one long period (energy norm
        ``sqrt(sum w^2 eta^2 + eta'^2)``) taken as periodic, in (0, 1).
    max_periods : int
        Long periods integrated at most (>= 2).
    steps_per_instant : int
        Runge-Kutta steps per instant of the ``n_time`` grid (>= 1; its error:
        docs/theory/geared_rotor.md).
    receptance, channels
        As :func:`solve_periodic_krylov`.
    window_periods : int
        Last long periods integrated whose largest mesh force (on the ``n_time`` instants)
        is returned as ``window_peak_force`` (>= 1; at most the second half of the periods
        integrated, so that the start's transient stays out of it).
    stall_periods : int, optional
        The integration stops without a periodic response once the state's change over a
        period is no smaller than ``stall_periods`` periods before (>= 1; default never:
        ``max_periods`` are integrated; :data:`STALL_MESH_CYCLES`).

    Returns
    -------
    PeriodicSolution
        Over harmonics ``0..H``, ``start`` "time_integration"; ``status`` 0 when the state
        returned to itself within ``tol``, 3 when it did not within ``max_periods`` (no
        periodic response on the long period was found: subharmonic, quasi-periodic or
        chaotic), 1 when the state left the finite numbers; ``iterations`` the long periods
        integrated (fewer than ``max_periods`` where the return map stalled),
        ``residual`` the last period's relative change; ``window_peak_force`` the largest
        force of the last ``window_periods`` periods (at most half of those integrated)
        and ``window_periods`` their number.
    """
    from gearuq.rotor._spectral_kernels import rk4_long_period  # numba: imported for cost

    if not (math.isfinite(period) and period > 0):
        raise ValueError(f"period={period!r} is outside its valid range (0, inf) s")
    if not 0.0 < tol < 1.0:
        raise ValueError(f"tol={tol!r} is outside its valid range (0, 1)")
    if not backlash > 0.0:
        raise ValueError(f"backlash={backlash!r} is outside its valid range (0, inf] m")
    if isinstance(max_periods, bool) or int(max_periods) != max_periods or max_periods < 2:
        raise ValueError(f"max_periods={max_periods!r} is outside its valid range: integers "
                         ">= 2")
    if (isinstance(steps_per_instant, bool) or int(steps_per_instant) != steps_per_instant
            or steps_per_instant < 1):
        raise ValueError(f"steps_per_instant={steps_per_instant!r} is outside its valid range: "
                         "integers >= 1")
    stall = int(max_periods) + 1 if stall_periods is None else stall_periods
    for name, value in (("window_periods", window_periods), ("stall_periods", stall)):
        if isinstance(value, bool) or int(value) != value or value < 1:
            raise ValueError(f"{name}={value!r} is outside its valid range: integers >= 1")
    if abs(prep.mean_stiffness - model.mean_stiffness) > 1e-9 * model.mean_stiffness:
        raise ValueError("the model's mean mesh stiffness differs from the excitation's")
    H, N = prep.n_harmonics, prep.n_time
    names = list(model.channels) if channels is None else channels
    if receptance is None:
        receptance = model.receptances(speed, 2.0 * np.pi / period * np.arange(H + 1), names)
    n_fine = 2 * int(steps_per_instant) * N  # step ends and midpoints

    def fine(grid):  # band-limited (2 H < N / 2): exact on the fine instants by zero padding
        c = np.zeros(n_fine // 2 + 1, dtype=complex)
        c[:N // 2] = _fft.rfft(grid)[:N // 2]
        return _fft.irfft(c, n=n_fine) * (n_fine / N)

    k_fine, ke_fine = fine(prep.k_grid), fine(prep.ke_grid)
    w2 = model.omega ** 2
    D = np.ascontiguousarray(model.damping + speed * model.gyroscopic)
    dres = model.mesh_static - model.mesh @ (model.load / w2)
    y = (np.concatenate([model.load / w2, np.zeros(model.n_modes)]) if start is None
         else _modal_state_at_zero(model, speed, np.asarray(start.remainder), period))
    weight = np.concatenate([np.sqrt(w2), np.ones(model.n_modes)])
    delta_t, force_t = np.empty(N), np.empty(N)
    status, change, done = STATUS_APERIODIC, math.inf, 0
    peaks: list[float] = []  # largest force of each period (the window is the last ones)
    changes: list[float] = []
    while done < int(max_periods):
        done += 1
        before = y.copy()
        rk4_long_period(y, k_fine, ke_fine, float(period), w2, D, model.mesh, model.load,
                        float(dres), float(model.mean_stiffness), float(model.mesh_residual),
                        float(backlash), delta_t, force_t)
        if not np.all(np.isfinite(y)):
            status = STATUS_NOT_CONVERGED
            break
        peaks.append(float(force_t.max()))
        change = float(np.linalg.norm(weight * (y - before))
                       / max(np.linalg.norm(weight * y), 1e-300))
        if change <= tol:
            status = STATUS_CONVERGED
            break
        changes.append(change)
        if done >= 2 * stall and change >= changes[-1 - int(stall)]:
            break  # the return map has stalled: no periodic response is on its way
    window = min(int(window_periods), max(done // 2, 1))
    x = _fft.rfft(delta_t)[:H + 1] / N
    force_hat = _fft.rfft(force_t)[:H + 1] / N
    r = force_hat - model.mean_stiffness * x
    n_sep, n_back = float(np.mean(force_t == 0.0)), float(np.mean(force_t < 0.0))
    return PeriodicSolution(
        period=period, delta=x, force=force_hat, remainder=r, status=status,
        iterations=done, residual=change, contact_loss_fraction=n_sep,
        back_contact_fraction=n_back, min_force=float(force_t.min()),
        branch=contact_branch(n_back > 0, n_sep > 0), start="time_integration",
        min_approach=float(delta_t.min()),
        window_peak_force=max(peaks[-window:], default=math.nan), window_periods=window,
    ).with_channels(model, receptance, names)
