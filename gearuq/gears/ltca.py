"""Loaded tooth contact analysis (LTCA) of a helical pair over the long period (seed 002).

For each mesh position the contact problem of seed 002, Eq. 3, is solved exactly::

    g = xi + D F + chi(F) - STE >= 0,   F >= 0,   F_i g_i = 0,   sum F = P

``F`` are the normal forces at the contact points (segment midpoints of the lines of contact,
:mod:`gearuq.gears.contact`), ``D`` the linear influence matrix and ``chi`` Weber's nonlinear
contact approach (:mod:`gearuq.gears.compliance`), ``xi`` the initial normal clearances
(:mod:`gearuq.gears.deviations`), ``STE`` the static transmission error as the rigid-body
approach of the flanks along the normal line of action, and ``P`` the normal mesh force.
The linear complementarity problem with the Hertz compliance frozen at its secant value is
solved by an active-set method (equality-constrained solves, drop the most negative force,
add the most penetrating gap; warm-started from the previous position); the secant is then
updated from the new forces until the forces stop changing (fixed point; the two loops of
seed 002, ref. [26]). Everything is in SI units (N, m); the Dataset reports micrometres
where the attrs say so.

Main entry points: :func:`ltca`, :func:`force_deflection`, :func:`tip_relief_map`.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np
import xarray as xr

from gearuq.gears.compliance import ComplianceModel
from gearuq.gears.contact import contact_grid, long_period_cycles
from gearuq.gears.deviations import FlankDeviations
from gearuq.gears.geometry import HelicalGearPair

__all__ = [
    "force_at_deflection",
    "stiffness_at_deflection",
    "force_deflection",
    "ltca",
    "normal_force_from_torque",
    "tip_relief_map",
]


def normal_force_from_torque(pair: HelicalGearPair, torque: float) -> float:
    """Return the normal mesh force ``P = T1 / (r_b1 cos(beta_b))`` [N] for pinion torque [N m]."""
    _check_positive("torque", torque, "N m")
    return float(torque) / (0.5 * pair.db1 * math.cos(pair.beta_b))


def _check_positive(name: str, value: float, unit: str) -> None:
    if not (np.isfinite(value) and value > 0):
        raise ValueError(f"{name}={value!r} is outside its valid range (0, inf) {unit}")


# ------------------------------------------------------------------------------ numba core
@nb.njit(cache=True)
def _solve_lcp(A, xi, P, active, max_iter):
    """Active-set solution of ``g = xi + A F - d >= 0, F >= 0, F g = 0, sum F = P``.

    ``active`` (bool, in/out) is the initial guess of the loaded set. Returns (F, d, ok).
    """
    m = xi.shape[0]
    F = np.zeros(m)
    d = 0.0
    # scale compliances to O(1) so the bordered system is well conditioned
    sc = 0.0
    for i in range(m):
        sc += A[i, i]
    sc = sc / m
    A = A / sc
    xi = xi / sc
    if not active.any():
        active[np.argmin(xi)] = True
    for _ in range(max_iter):
        idx = np.nonzero(active)[0]
        na = idx.shape[0]
        K = np.zeros((na + 1, na + 1))
        r = np.zeros(na + 1)
        for a in range(na):
            for c in range(na):
                K[a, c] = A[idx[a], idx[c]]
            K[a, na] = -1.0
            K[na, a] = 1.0
            r[a] = -xi[idx[a]]
        r[na] = P
        sol = np.linalg.solve(K, r)
        fa = sol[:na]
        d = sol[na]
        # drop the most negative force
        jmin = np.argmin(fa)
        if fa[jmin] < -1e-14 * P:
            active[idx[jmin]] = False
            continue
        F[:] = 0.0
        for a in range(na):
            F[idx[a]] = max(fa[a], 0.0)
        # add the most penetrating inactive point
        g = xi + A @ F - d
        worst = -1
        gmin = -1e-13 * (abs(d) + 1e-12)
        for i in range(m):
            if not active[i] and g[i] < gmin:
                gmin = g[i]
                worst = i
        if worst < 0:
            return F, d * sc, True
        active[worst] = True
    return F, d * sc, False


@nb.njit(cache=True)
def _hertz(F, dL, R, h1, h2, E, nu, p_floor):
    """Weber's approach chi(F), secant chi/F and tangent dchi/dF compliances per point.

    ``w = k0 p [ln(4 h1 h2 / a^2) - c]`` with ``a^2`` proportional to ``p`` gives
    ``dw/dp = w/p - k0``: the tangent compliance is the secant one minus ``k0 / dL``.
    """
    m = F.shape[0]
    chi = np.zeros(m)
    sec = np.zeros(m)
    tan = np.zeros(m)
    k0 = 2.0 * (1.0 - nu * nu) / (math.pi * E)
    c = nu / (1.0 - nu)
    for i in range(m):
        p = max(F[i] / dL[i], p_floor)
        a2 = 8.0 * p * R[i] * (1.0 - nu * nu) / (math.pi * E)
        w_over_p = k0 * (math.log(4.0 * h1[i] * h2[i] / a2) - c)
        sec[i] = w_over_p / dL[i]
        tan[i] = (w_over_p - k0) / dL[i]
        chi[i] = w_over_p * F[i] / dL[i] if F[i] > 0 else 0.0
    return chi, sec, tan


@nb.njit(cache=True)
def _solve_all(Dblk, valid, pair_index, dL, xi, R, h1, h2, P, E, nu, hertz, tol, max_outer):
    """Solve every position; arrays (n_pos, n_lines[, n_pts[, n_pts]])."""
    n_pos, n_lines, n = xi.shape
    Fout = np.zeros((n_pos, n_lines, n))
    gout = np.zeros((n_pos, n_lines, n))
    ste = np.zeros(n_pos)
    n_iter = np.zeros(n_pos, np.int64)
    status = np.zeros(n_pos, np.int64)
    ktan = np.zeros(n_pos)
    prev_active = np.zeros((n_lines, n), np.bool_)
    prev_pairs = np.full(n_lines, -(10**12), np.int64)
    for p in range(n_pos):
        lines = np.nonzero(valid[p])[0]
        nl = lines.shape[0]
        m = nl * n
        A0 = np.zeros((m, m))
        xv = np.zeros(m)
        dv = np.zeros(m)
        Rv = np.zeros(m)
        h1v = np.zeros(m)
        h2v = np.zeros(m)
        active = np.zeros(m, np.bool_)
        for a in range(nl):
            ln = lines[a]
            warm = -1
            for q in range(n_lines):
                if prev_pairs[q] == pair_index[p, ln]:
                    warm = q
            for i in range(n):
                r0 = a * n + i
                xv[r0] = xi[p, ln, i]
                dv[r0] = dL[p, ln]
                Rv[r0] = R[p, ln, i]
                h1v[r0] = h1[p, ln, i]
                h2v[r0] = h2[p, ln, i]
                if warm >= 0:
                    active[r0] = prev_active[warm, i]
                for j in range(n):
                    A0[r0, a * n + j] = Dblk[p, ln, i, j]
        if not active.any():
            xmin = xv.min()
            for i in range(m):
                active[i] = xv[i] <= xmin + 1e-12
        total_len = 0.0
        for a in range(nl):
            total_len += dv[a * n] * n
        p_floor = 1e-3 * P / total_len
        F = np.zeros(m)
        A = A0.copy()
        ok = False
        it = 0
        if hertz:
            # start the secant at the uniform line load
            for i in range(m):
                F[i] = P / total_len * dv[i]
        while it < max_outer:
            it += 1
            if hertz:
                chi, sec, tan = _hertz(F, dv, Rv, h1v, h2v, E, nu, p_floor)
                for i in range(m):
                    A[i, i] = A0[i, i] + sec[i]
            Fn, d, ok = _solve_lcp(A, xv, P, active, 20 * m + 50)
            change = np.abs(Fn - F).max()
            F = Fn
            if not hertz or (ok and change <= tol * P):
                break
        # residual gaps with the true nonlinear law
        g = xv + A0 @ F - d
        tan = np.zeros(m)
        if hertz:
            chi, sec, tan = _hertz(F, dv, Rv, h1v, h2v, E, nu, p_floor)
            g = g + chi
        # tangent mesh stiffness dP/dSTE on the loaded set: 1^T (D + dchi/dF)_AA^-1 1
        idx = np.nonzero(F > 0.0)[0]
        Mt = np.empty((idx.shape[0], idx.shape[0]))
        for a in range(idx.shape[0]):
            for c in range(idx.shape[0]):
                Mt[a, c] = A0[idx[a], idx[c]]
            Mt[a, a] += tan[idx[a]]
        ktan[p] = np.linalg.solve(Mt, np.ones(idx.shape[0])).sum()
        ste[p] = d
        n_iter[p] = it
        status[p] = 0 if ok else 1
        prev_active[:, :] = False
        prev_pairs[:] = -(10**12)
        for a in range(nl):
            ln = lines[a]
            prev_pairs[a] = pair_index[p, ln]
            for i in range(n):
                Fout[p, ln, i] = F[a * n + i]
                gout[p, ln, i] = g[a * n + i]
                prev_active[a, i] = F[a * n + i] > 0.0
    return Fout, gout, ste, ktan, n_iter, status


# ------------------------------------------------------------------------------ public API
def _positions(pair: HelicalGearPair, positions_per_cycle: int, n_cycles: int | None):
    if int(positions_per_cycle) != positions_per_cycle or positions_per_cycle < 1:
        raise ValueError(
            f"positions_per_cycle={positions_per_cycle!r} is outside its valid range: "
            "integers >= 1"
        )
    nc = long_period_cycles(pair) if n_cycles is None else n_cycles
    if int(nc) != nc or nc < 1:
        raise ValueError(f"n_cycles={n_cycles!r} is outside its valid range: integers >= 1")
    return np.arange(int(nc) * int(positions_per_cycle)) / positions_per_cycle


def ltca(
    pair: HelicalGearPair,
    *,
    torque: float | None = None,
    normal_force: float | None = None,
    deviations: FlankDeviations | None = None,
    compliance: ComplianceModel | None = None,
    positions_per_cycle: int = 24,
    n_cycles: int | None = None,
    tau: np.ndarray | None = None,
    n_pts: int = 20,
    tol: float = 1e-13,
    max_outer: int = 60,
    keep_points: bool = True,
) -> xr.Dataset:
    """Run the LTCA at one load over the long period (or at the given positions).

    Parameters
    ----------
    pair : HelicalGearPair
        The gear pair (pinion drives).
    torque, normal_force : float
        Pinion torque [N m] or normal mesh force ``P`` [N]; exactly one, > 0.
    deviations : FlankDeviations or None
        Pitch deviations, reliefs, crowning, user map; ``None``: perfect gears.
    compliance : ComplianceModel or None
        ``None``: the potential-energy model with Weber contact, default parameters.
    positions_per_cycle : int
        Positions per mesh cycle (used unless ``tau`` is given).
    n_cycles : int or None
        Mesh cycles to cover; ``None``: the long period ``lcm(z1, z2)``.
    tau : array_like or None
        Explicit mesh positions in mesh cycles.
    n_pts : int
        Points per line of contact.
    tol : float
        Fixed-point tolerance of the Hertz loop on ``max |dF| / P``.
    max_outer : int
        Maximum Hertz iterations.
    keep_points : bool
        Keep the per-point variables (dims ``position, line, point``).

    Returns
    -------
    xarray.Dataset
        Over ``position`` (coordinate ``tau`` in mesh cycles, ``mesh_cycle``): ``ste``,
        ``ste_transverse`` (um), ``lpms`` (N/um), ``cms`` (um), ``n_teeth_in_contact``,
        ``contact_length``, ``loaded_length`` (mm), ``contact_loss_fraction``,
        ``partial_contact_loss``, ``kinematic_te`` (um), ``status``,
        ``complementarity_residual``; over ``(position, line, point)``: ``force`` (N),
        ``line_load`` (N/mm), ``in_contact`` (contact pattern), ``gap`` and ``xi`` (um),
        ``s``, ``y`` (mm); over ``(position, line)``: ``valid``, ``pinion_tooth``,
        ``wheel_tooth``.
    """
    if (torque is None) == (normal_force is None):
        raise ValueError("give exactly one of torque [N m] or normal_force [N]")
    if torque is not None:
        P = normal_force_from_torque(pair, torque)
    else:
        _check_positive("normal_force", normal_force, "N")
        P = float(normal_force)
    if int(n_pts) != n_pts or n_pts < 1:
        raise ValueError(f"n_pts={n_pts!r} is outside its valid range: integers >= 1")
    taus = _positions(pair, positions_per_cycle, n_cycles) if tau is None else np.atleast_1d(
        np.asarray(tau, dtype=float)
    )
    dev = deviations or FlankDeviations()
    dev.validate(pair)
    comp = compliance or ComplianceModel(pair)
    if comp.pair != pair:
        raise ValueError("compliance was built for a different pair")
    grid = contact_grid(pair, taus, n_pts)
    kin = grid.kin
    k1 = np.mod(grid.pair_index, pair.z1)
    k2 = np.mod(grid.pair_index, pair.z2)
    xi = dev.clearance(pair, kin, grid.s, grid.y, k1[..., None], k2[..., None])
    xi = np.where(grid.valid[..., None], xi, 0.0)
    D = comp.matrices(grid.s, grid.y, grid.y_lo, grid.dy, kin)
    R, h1, h2 = comp.hertz_params(grid.s, kin)
    dL = np.where(grid.valid, grid.dL, 1.0)
    F, g, ste, ktan, n_iter, status = _solve_all(
        np.ascontiguousarray(D), grid.valid, grid.pair_index, dL, np.ascontiguousarray(xi),
        R, h1, h2, P, comp.E, comp.nu, bool(comp.hertz), tol, max_outer,
    )
    return _dataset(pair, grid, F, g, xi, ste, ktan, n_iter, status, P, comp, n_pts, keep_points)


def _dataset(pair, grid, F, g, xi, ste, ktan, n_iter, status, P, comp, n_pts, keep_points):
    kin = grid.kin
    valid = grid.valid[..., None] & np.ones(n_pts, bool)
    loaded = F > 0.0
    defl = ste[:, None, None] - xi  # total deformation at loaded points, = D F + chi
    with np.errstate(divide="ignore", invalid="ignore"):
        k_i = np.where(loaded, F / np.where(loaded, defl, 1.0), 0.0)
    km = k_i.sum(axis=(1, 2))
    em = (k_i * xi).sum(axis=(1, 2)) / km
    geo_len = grid.length
    seg = np.broadcast_to(grid.dL[..., None], F.shape)
    loaded_len = np.where(loaded & valid, seg, 0.0).sum(axis=(1, 2))
    loss = np.clip(1.0 - loaded_len / geo_len, 0.0, 1.0)
    loss[loss < 1e-12] = 0.0
    xi_min = np.where(valid, xi, np.inf).min(axis=(1, 2))
    n_teeth = ((F.sum(axis=2) > 0.0) & grid.valid).sum(axis=1)
    # complementarity residual relative to the elastic deflection scale P / k_m
    dscale = P / km
    resid = np.maximum.reduce([
        np.abs(np.where(valid, F * g, 0.0)).sum(axis=(1, 2)) / (P * dscale),
        np.maximum(-np.where(valid, g, 0.0).min(axis=(1, 2)), 0.0) / dscale,
        np.abs(F.sum(axis=(1, 2)) - P) / P,
    ])
    tau = grid.tau
    um = 1e6
    data = {
        "ste": ("position", ste * um, {"units": "um", "long_name": "static transmission error "
                                       "(normal approach of the flanks)"}),
        "ste_transverse": ("position", ste / kin.cos_bb * um,
                           {"units": "um", "long_name": "STE along the transverse line of "
                            "action (base-circle arc of the pinion)"}),
        "lpms": ("position", km * 1e-6, {"units": "N/um", "long_name": "long-period mesh "
                                         "stiffness sum F_i/(STE - xi_i) (seed Eq. 4)"}),
        "lpms_tangent": ("position", ktan * 1e-6, {
            "units": "N/um", "long_name": "tangent mesh stiffness dP/dSTE (linearised "
            "dynamics); seed Eq. 4 gives the secant lpms"}),
        "cms": ("position", em * um, {"units": "um", "long_name": "composite mesh error "
                                      "sum k_i xi_i / k_m (seed Eq. 5)"}),
        "kinematic_te": ("position", xi_min * um,
                         {"units": "um", "long_name": "no-load kinematic TE min(xi)"}),
        "n_teeth_in_contact": ("position", n_teeth, {"units": "1"}),
        "contact_length": ("position", geo_len * 1e3, {"units": "mm",
                                                        "long_name": "geometric contact length"}),
        "loaded_length": ("position", loaded_len * 1e3, {"units": "mm"}),
        "contact_loss_fraction": ("position", loss, {"units": "1",
                                                     "long_name": "unloaded share of the "
                                                     "geometric contact length"}),
        "partial_contact_loss": ("position", loss > 0.05,
                                 {"long_name": "more than 5 % of the contact length unloaded"}),
        "complementarity_residual": ("position", resid, {"units": "1"}),
        "n_iterations": ("position", n_iter, {"units": "1"}),
        "status": ("position", status, {"long_name": "0 ok, 1 active set did not converge"}),
    }
    if keep_points:
        pdims = ("position", "line", "point")
        data.update({
            "force": (pdims, F, {"units": "N", "long_name": "normal force at the contact point"}),
            "in_contact": (pdims, loaded & valid, {"long_name": "contact pattern (F > 0)"}),
            "line_load": (pdims, F / np.where(valid, seg, 1.0) * 1e-3, {"units": "N/mm"}),
            "gap": (pdims, np.where(valid, g, np.nan) * um, {"units": "um"}),
            "xi": (pdims, np.where(valid, xi, np.nan) * um, {"units": "um"}),
            "s": (pdims, np.where(valid, grid.s, np.nan) * 1e3, {"units": "mm",
                  "long_name": "POA coordinate from T1"}),
            "y": (pdims, np.where(valid, grid.y, np.nan) * 1e3, {"units": "mm"}),
            "valid": (("position", "line"), grid.valid, {}),
            "pinion_tooth": (("position", "line"), np.mod(grid.pair_index, pair.z1), {}),
            "wheel_tooth": (("position", "line"), np.mod(grid.pair_index, pair.z2), {}),
        })
    ds = xr.Dataset(
        data,
        coords={"tau": ("position", tau, {"units": "mesh cycles"}),
                "mesh_cycle": ("position", np.floor(tau).astype(int), {})},
    )
    ds.attrs.update({
        "model": "gearuq.gears.ltca", "normal_force_N": P,
        "torque_Nm": P * 0.5 * pair.db1 * kin.cos_bb, "compliance": comp.kind,
        "coupling_length_m": float(comp.coupling_length), "hertz": int(comp.hertz),
        "n_pts": n_pts, "s_A_m": kin.s_A, "s_E_m": kin.s_E, "face_width_m": kin.b,
    })
    return ds


def force_deflection(
    pair: HelicalGearPair, loads: np.ndarray, **kw: object
) -> xr.Dataset:
    """Return ``STE(P, position)`` on a load grid; ``F(delta)`` follows by inversion.

    Parameters
    ----------
    pair : HelicalGearPair
        The gear pair.
    loads : array_like
        Normal forces ``P`` [N], > 0, increasing.
    **kw
        Passed to :func:`ltca` (deviations, compliance, positions...).

    Returns
    -------
    xarray.Dataset
        ``ste`` (um) and ``lpms`` over ``(load, position)``; use :func:`force_at_deflection`.
    """
    loads = np.asarray(loads, dtype=float)
    if loads.ndim != 1 or loads.size < 2 or np.any(np.diff(loads) <= 0) or loads[0] <= 0:
        raise ValueError(f"loads={loads!r} must be a strictly increasing 1-D array of > 0 N")
    kw = {**kw, "keep_points": False}
    runs = [ltca(pair, normal_force=float(p), **kw) for p in loads]
    ds = xr.concat([r[["ste", "lpms", "lpms_tangent", "cms"]] for r in runs], dim="load")
    ds = ds.assign_coords(load=("load", loads, {"units": "N"}))
    ds["ste_at_zero_load"] = runs[0]["kinematic_te"]
    return ds


def _hermite_force(fd: xr.Dataset, delta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Piecewise force ``F(delta)`` and slope ``dF/ddelta`` per position (SI: N, N/m).

    Between load nodes: cubic Hermite on the exact node values ``(STE_j, P_j)`` and the exact
    tangent stiffnesses ``dP/dSTE``; between the no-load TE and the first load: linear (the
    Weber contact makes the true slope vanish at zero load, which a cubic would overshoot);
    below the no-load TE: 0 (contact lost); above the last load: NaN (not computed).
    """
    loads = fd["load"].values
    n_pos = fd.sizes["position"]
    force = np.full((n_pos, delta.size), np.nan)
    slope = np.full((n_pos, delta.size), np.nan)
    d = delta * 1e-6
    for p in range(n_pos):
        ste = fd["ste"].values[:, p] * 1e-6
        kt = fd["lpms_tangent"].values[:, p] * 1e6
        d0 = float(fd["ste_at_zero_load"][p]) * 1e-6
        below = d < d0
        force[p, below] = 0.0
        slope[p, below] = 0.0
        first = (d >= d0) & (d <= ste[0])
        k_first = loads[0] / (ste[0] - d0)
        force[p, first] = k_first * (d[first] - d0)
        slope[p, first] = k_first
        for j in range(loads.size - 1):
            inside = (d > ste[j]) & (d <= ste[j + 1])
            if not inside.any():
                continue
            h = ste[j + 1] - ste[j]
            u = (d[inside] - ste[j]) / h
            h00, h10 = 2 * u**3 - 3 * u**2 + 1, u**3 - 2 * u**2 + u
            h01, h11 = -2 * u**3 + 3 * u**2, u**3 - u**2
            force[p, inside] = (h00 * loads[j] + h10 * h * kt[j] + h01 * loads[j + 1]
                                + h11 * h * kt[j + 1])
            dh00, dh10 = 6 * u**2 - 6 * u, 3 * u**2 - 4 * u + 1
            dh01, dh11 = -6 * u**2 + 6 * u, 3 * u**2 - 2 * u
            slope[p, inside] = (dh00 * loads[j] + dh01 * loads[j + 1]) / h + (
                dh10 * kt[j] + dh11 * kt[j + 1])
    return force, slope


def force_at_deflection(fd: xr.Dataset, delta_um: float | np.ndarray) -> xr.DataArray:
    """Interpolate the mesh force ``F(delta)`` [N] at approaches ``delta_um`` [um].

    Parameters
    ----------
    fd : xarray.Dataset
        Result of :func:`force_deflection` (needs ``ste``, ``lpms_tangent``,
        ``ste_at_zero_load`` over ``(load, position)``).
    delta_um : float or array_like
        Normal approaches of the flanks (the STE coordinate) [um].

    Returns
    -------
    xarray.DataArray
        ``F`` over ``(position, delta)`` [N]: 0 below the no-load TE (contact loss), linear up
        to the first load, cubic Hermite on the exact values and tangent stiffnesses between
        loads (error O(h^4)), NaN above the last load.
    """
    delta = np.atleast_1d(np.asarray(delta_um, dtype=float))
    force, _ = _hermite_force(fd, delta)
    return xr.DataArray(force, dims=("position", "delta"),
                        coords={"delta": ("delta", delta, {"units": "um"})},
                        attrs={"units": "N", "long_name": "mesh force F(delta)"})


def stiffness_at_deflection(fd: xr.Dataset, delta_um: float | np.ndarray) -> xr.DataArray:
    """Return the tangent mesh stiffness ``dF/ddelta`` [N/um] of :func:`force_at_deflection`.

    Parameters
    ----------
    fd : xarray.Dataset
        Result of :func:`force_deflection`.
    delta_um : float or array_like
        Normal approaches [um].

    Returns
    -------
    xarray.DataArray
        Slope over ``(position, delta)`` [N/um]; equals ``lpms_tangent`` at the load nodes,
        0 below the no-load TE, NaN above the last load.
    """
    delta = np.atleast_1d(np.asarray(delta_um, dtype=float))
    _, slope = _hermite_force(fd, delta)
    return xr.DataArray(slope * 1e-6, dims=("position", "delta"),
                        coords={"delta": ("delta", delta, {"units": "um"})},
                        attrs={"units": "N/um", "long_name": "tangent stiffness dF/ddelta"})


def tip_relief_map(
    pair: HelicalGearPair,
    amounts: np.ndarray,
    lengths: np.ndarray,
    *,
    torque: float | None = None,
    normal_force: float | None = None,
    base: FlankDeviations | None = None,
    positions_per_cycle: int = 24,
    n_cycles: int = 1,
    **kw: object,
) -> xr.Dataset:
    """Brute-force STE peak-to-peak over symmetric tip-relief amount x length (seed Fig. 14).

    Parameters
    ----------
    pair : HelicalGearPair
        The gear pair.
    amounts, lengths : array_like
        Relief amounts [m] and lengths along the path of contact [m] (seed Eq. 12, same on
        both gears).
    torque, normal_force : float
        The load (one of them).
    base : FlankDeviations or None
        Other deviations kept while the relief varies (e.g. pitch deviations).
    positions_per_cycle, n_cycles : int
        Positions; one mesh cycle suffices without pitch deviations.
    **kw
        Passed to :func:`ltca`.

    Returns
    -------
    xarray.Dataset
        ``ste_ptp`` (um) over ``(amount, length)``, the optimum in attrs.
    """
    amounts = np.asarray(amounts, dtype=float)
    lengths = np.asarray(lengths, dtype=float)
    comp = kw.pop("compliance", None) or ComplianceModel(pair)
    ptp = np.empty((amounts.size, lengths.size))
    base_kw = {} if base is None else {
        k: getattr(base, k) for k in ("Fp1", "Fp2", "root_relief1", "root_relief2",
                                       "crowning", "user")}
    for i, ca in enumerate(amounts):
        for j, la in enumerate(lengths):
            dev = FlankDeviations.symmetric_tip_relief(float(ca), float(la), **base_kw)
            r = ltca(pair, torque=torque, normal_force=normal_force, deviations=dev,
                     compliance=comp, positions_per_cycle=positions_per_cycle,
                     n_cycles=n_cycles, keep_points=False, **kw)
            ste = r["ste"].values
            ptp[i, j] = ste.max() - ste.min()
    i, j = np.unravel_index(np.argmin(ptp), ptp.shape)
    ds = xr.Dataset(
        {"ste_ptp": (("amount", "length"), ptp, {"units": "um",
                                                  "long_name": "STE peak-to-peak"})},
        coords={"amount": ("amount", amounts * 1e6, {"units": "um"}),
                "length": ("length", lengths * 1e3, {"units": "mm"})},
    )
    ds.attrs.update({"optimum_amount_um": float(amounts[i] * 1e6),
                     "optimum_length_mm": float(lengths[j] * 1e3),
                     "optimum_ste_ptp_um": float(ptp[i, j])})
    return ds
