"""Loaded tooth contact analysis (LTCA) of a helical pair over the long period (Yuan et al. (2020)).

For each mesh position the contact problem of Yuan, Liu and Liu (2020), Eq. 3, is solved exactly::

    g = xi + D F + chi(F) - STE >= 0,   F >= 0,   F_i g_i = 0,   sum F = P

``F`` are the normal forces at the contact points (segment midpoints of the lines of contact,
:mod:`gearuq.gears.contact`), ``D`` the linear influence matrix and ``chi`` Weber's nonlinear
contact approach (:mod:`gearuq.gears.compliance`), ``xi`` the initial normal clearances
(:mod:`gearuq.gears.deviations`), ``STE`` the static transmission error as the rigid-body
approach of the flanks along the normal line of action, and ``P`` the normal mesh force.
The solver (:mod:`gearuq.gears.ltca_kernel`) is an exact block active-set method inside a
Newton loop on the contact law. Everything is in SI units (N, m) inside; the Dataset reports
micrometres where the attrs say so.

The geometry of a line of contact depends only on its phase ``tau - k`` (position minus tooth
pair counter), so the influence blocks are computed once per distinct phase
(:func:`ltca_setup`, about ``positions_per_cycle x ceil(eps_gamma)`` of them) and reused for
every position of the long period, every load and every deviation.

Main entry points: :func:`ltca`, :func:`ltca_setup` + :func:`ltca_solve`,
:func:`force_deflection`, :func:`force_at_deflection`, :func:`stiffness_at_deflection`,
:func:`tip_relief_map`.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from typing import Any, NamedTuple

import numpy as np
import xarray as xr

from gearuq.gears.compliance import ComplianceModel
from gearuq.gears.contact import ContactGrid, contact_grid, long_period_cycles
from gearuq.gears.deviations import FlankDeviations
from gearuq.gears.geometry import HelicalGearPair

__all__ = [
    "LtcaSetup",
    "LtcaSolution",
    "PARTIAL_LOSS_THRESHOLD",
    "force_at_deflection",
    "force_deflection",
    "ltca",
    "ltca_setup",
    "ltca_solve",
    "mesh_summaries",
    "normal_force_from_torque",
    "stiffness_at_deflection",
    "tip_relief_map",
]

#: Share of the design contact length that must be unloaded to flag partial contact loss.
PARTIAL_LOSS_THRESHOLD = 0.05


def normal_force_from_torque(pair: HelicalGearPair, torque: float) -> float:
    """Return the normal mesh force ``P = T1 / (r_b1 cos(beta_b))`` [N] for pinion torque [N m]."""
    _check_positive("torque", torque, "N m")
    return float(torque) / (0.5 * pair.db1 * math.cos(pair.beta_b))


def _check_positive(name: str, value: float, unit: str) -> None:
    if not (np.isfinite(value) and value > 0):
        raise ValueError(f"{name}={value!r} is outside its valid range (0, inf) {unit}")


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


# ------------------------------------------------------------------------------ setup
@dataclass(frozen=True)
class LtcaSetup:
    """Load- and deviation-independent part of an LTCA: contact grid and influence blocks.

    Build it with :func:`ltca_setup`; reuse it for any load and deviations
    (:func:`ltca_solve`). Arrays over ``phase`` hold one entry per distinct line geometry.

    Attributes
    ----------
    pair : HelicalGearPair
    compliance : ComplianceModel
    grid : ContactGrid
        Points of every line at every position (``(n_pos, n_lines, n_pts)``).
    phase : ndarray of int, (n_pos, n_lines)
        Index of the line geometry, -1 where no line is in contact.
    D : ndarray, (n_phase, n_pts, n_pts)
        Influence blocks [m/N].
    dL : ndarray, (n_phase,)
        Segment length along the line of contact [m].
    R, h1, h2 : ndarray, (n_phase, n_pts)
        Equivalent normal radius and half tooth thicknesses for Weber's approach [m].
    """

    pair: HelicalGearPair
    compliance: ComplianceModel
    grid: ContactGrid
    phase: np.ndarray
    D: np.ndarray
    dL: np.ndarray
    R: np.ndarray
    h1: np.ndarray
    h2: np.ndarray

    @property
    def n_pts(self) -> int:
        """Points per line of contact."""
        return int(self.grid.s.shape[2])

    def clearance(self, deviations: FlankDeviations | None) -> np.ndarray:
        """Initial normal clearances ``xi`` [m] of ``deviations`` at every grid point."""
        dev = deviations or FlankDeviations()
        dev.validate(self.pair)
        g = self.grid
        k1 = np.mod(g.pair_index, self.pair.z1)
        k2 = np.mod(g.pair_index, self.pair.z2)
        xi = dev.clearance(self.pair, g.kin, g.s, g.y, k1[..., None], k2[..., None])
        return np.ascontiguousarray(np.where(g.valid[..., None], xi, 0.0))


def ltca_setup(
    pair: HelicalGearPair,
    *,
    compliance: ComplianceModel | None = None,
    positions_per_cycle: int = 24,
    n_cycles: int | None = None,
    tau: np.ndarray | None = None,
    n_pts: int = 20,
) -> LtcaSetup:
    """Discretise the lines of contact and compute the influence blocks once.

    Parameters
    ----------
    pair : HelicalGearPair
        The gear pair (pinion drives).
    compliance : ComplianceModel or None
        ``None``: the potential-energy model with Weber contact, default parameters.
    positions_per_cycle, n_cycles : int
        Uniform positions over ``n_cycles`` mesh cycles (``None``: the long period
        ``lcm(z1, z2)``); used unless ``tau`` is given.
    tau : array_like or None
        Explicit mesh positions in mesh cycles.
    n_pts : int
        Points per line of contact (>= 1).

    Returns
    -------
    LtcaSetup
    """
    if int(n_pts) != n_pts or n_pts < 1:
        raise ValueError(f"n_pts={n_pts!r} is outside its valid range: integers >= 1")
    taus = _positions(pair, positions_per_cycle, n_cycles) if tau is None else np.atleast_1d(
        np.asarray(tau, dtype=float))
    if taus.ndim != 1 or not np.all(np.isfinite(taus)):
        raise ValueError("tau must be a 1-D array of finite mesh positions [mesh cycles]")
    comp = compliance or ComplianceModel(pair)
    if comp.pair != pair:
        raise ValueError("compliance was built for a different pair")
    grid = contact_grid(pair, taus, int(n_pts))
    # distinct line geometries: phase tau - k rounded far below any physical scale
    key = np.round((grid.tau[:, None] - grid.pair_index) * 2.0**32)
    _, first, inverse = np.unique(np.where(grid.valid, key, -np.inf), return_index=True,
                                  return_inverse=True)
    inverse = inverse.reshape(grid.valid.shape)
    rows, cols = np.unravel_index(first, grid.valid.shape)
    keep = grid.valid[rows, cols]  # drop the entry of the invalid lines
    rows, cols = rows[keep], cols[keep]
    remap = np.cumsum(keep) - 1
    phase = np.where(grid.valid, remap[inverse], -1).astype(np.int64)
    s, y = grid.s[rows, cols], grid.y[rows, cols]
    D = comp.matrices(s, y, grid.y_lo[rows, cols], grid.dy[rows, cols], grid.kin)
    R, h1, h2 = comp.hertz_params(s, grid.kin)
    return LtcaSetup(pair=pair, compliance=comp, grid=grid, phase=phase,
                     D=np.ascontiguousarray(D), dL=np.ascontiguousarray(grid.dL[rows, cols]),
                     R=np.ascontiguousarray(R), h1=np.ascontiguousarray(h1),
                     h2=np.ascontiguousarray(h2))


# ------------------------------------------------------------------------------ solve
class LtcaSolution(NamedTuple):
    """Raw solution of :func:`ltca_solve` (SI units).

    ``force``, ``gap`` (n_pos, n_lines, n_pts) [N], [m]; ``ste`` (n_pos,) [m]; ``lpms_tangent``
    (n_pos,) [N/m]; ``n_iterations``, ``status`` (n_pos,) (0 ok, 1 not converged);
    ``xi`` the clearances used [m]; ``normal_force`` [N].
    """

    force: np.ndarray
    gap: np.ndarray
    ste: np.ndarray
    lpms_tangent: np.ndarray
    n_iterations: np.ndarray
    status: np.ndarray
    xi: np.ndarray
    normal_force: float


def ltca_solve(
    setup: LtcaSetup,
    normal_force: float,
    xi: np.ndarray,
    *,
    tol: float = 1e-13,
    max_newton: int = 40,
) -> LtcaSolution:
    """Solve the contact problem at every position of ``setup`` for one load and clearance.

    Parameters
    ----------
    setup : LtcaSetup
        Grid and influence blocks (:func:`ltca_setup`).
    normal_force : float
        Normal mesh force ``P`` [N], > 0.
    xi : ndarray, (n_pos, n_lines, n_pts)
        Initial normal clearances [m] (:meth:`LtcaSetup.clearance`).
    tol : float
        Newton tolerance on ``max |dF| / P``.
    max_newton : int
        Newton iteration limit per position.

    Returns
    -------
    LtcaSolution
    """
    _check_positive("normal_force", normal_force, "N")
    xi = np.ascontiguousarray(xi, dtype=float)
    if xi.shape != setup.grid.s.shape:
        raise ValueError(f"xi has shape {xi.shape}, valid: {setup.grid.s.shape}")
    shape = xi.shape
    F, gap = np.zeros(shape), np.zeros(shape)
    n_pos = shape[0]
    ste, k_t = np.zeros(n_pos), np.zeros(n_pos)
    n_iter, status = np.zeros(n_pos, np.int64), np.zeros(n_pos, np.int64)
    comp = setup.compliance
    args = (setup.D, setup.phase, setup.grid.pair_index, xi, setup.dL, setup.R, setup.h1,
            setup.h2, float(normal_force), comp.E, comp.nu, bool(comp.hertz), float(tol),
            int(max_newton), F, gap, ste, k_t, n_iter, status)
    kernel, _ = _positions_route().choose(n_pos * shape[1], args)
    kernel(*args)
    return LtcaSolution(F, gap, ste, k_t, n_iter, status, xi, float(normal_force))


@functools.cache
def _positions_route() -> Any:
    """Compiled or plain-Python LTCA (:mod:`gearuq._firstcall`): about 0.4 ms of CPU per
    position and line slot interpreted (1.2 s for the mesh excitation's nominal call, 960
    positions), against about 8 s for the compile."""
    from gearuq._firstcall import FirstCallRoute
    from gearuq.gears.ltca_kernel import line_solve_numpy, solve_positions

    return FirstCallRoute(solve_positions, "the tooth-contact (LTCA) solver", unit_cpu=5e-4,
                          compile_cpu=8.0, overrides={"_line_solve": line_solve_numpy})


def _design_reference(setup: LtcaSetup, deviations: FlankDeviations, P: float,
                      **solve_kw: object) -> np.ndarray:
    """Contact pattern of the same modified flank without errors, mapped onto ``setup``.

    Without pitch deviations (and user maps) every tooth pair meets the same flank, so the
    pattern depends only on ``frac(tau)``; it is solved at the distinct ``frac(tau)`` (one
    mesh cycle) and line slot ``j`` at ``tau`` maps to slot ``j`` at ``frac(tau)`` (same
    phase ``tau - k``). Returns the boolean pattern ``(n_pos, n_lines, n_pts)``.
    """
    frac = np.mod(setup.grid.tau, 1.0)
    key = np.round(frac * 2.0**32)
    uniq, first, inverse = np.unique(key, return_index=True, return_inverse=True)
    ref = ltca_setup(setup.pair, compliance=setup.compliance, tau=frac[first],
                     n_pts=setup.n_pts)
    design = deviations.design_only()
    sol = ltca_solve(ref, P, ref.clearance(design), **solve_kw)
    return (sol.force > 0.0)[inverse.ravel()]


# ------------------------------------------------------------------------------ summaries
def mesh_summaries(
    setup: LtcaSetup, sol: LtcaSolution, reference_pattern: np.ndarray | None = None
) -> dict[str, np.ndarray]:
    """Per-position mesh quantities of a solution (SI units).

    Returns a dict of arrays over positions: ``lpms`` (secant, Yuan et al. Eq. 4) and
    ``lpms_tangent`` [N/m], ``cms`` (Yuan et al. Eq. 5) [m], ``ste`` [m], ``kinematic_te`` [m],
    ``contact_length``, ``loaded_length`` [m], ``contact_loss_fraction`` (unloaded share of
    the design pattern ``reference_pattern``; of the geometric length when it is None),
    ``geometric_loss_fraction``, ``n_teeth_in_contact`` and ``complementarity_residual``.
    """
    grid = setup.grid
    F, g, xi, P = sol.force, sol.gap, sol.xi, sol.normal_force
    valid = np.broadcast_to(grid.valid[..., None], F.shape)
    loaded = F > 0.0
    defl = sol.ste[:, None, None] - xi  # total deformation at loaded points, = D F + chi
    with np.errstate(divide="ignore", invalid="ignore"):
        k_i = np.where(loaded, F / np.where(loaded, defl, 1.0), 0.0)
    km = k_i.sum(axis=(1, 2))
    em = (k_i * xi).sum(axis=(1, 2)) / km
    seg = np.broadcast_to(grid.dL[..., None], F.shape)
    geo_len = grid.length
    loaded_len = np.where(loaded & valid, seg, 0.0).sum(axis=(1, 2))
    geo_loss = np.clip(1.0 - loaded_len / geo_len, 0.0, 1.0)
    if reference_pattern is None:
        loss = geo_loss
    else:
        ref_len = np.where(reference_pattern & valid, seg, 0.0).sum(axis=(1, 2))
        lost = np.where(reference_pattern & valid & ~loaded, seg, 0.0).sum(axis=(1, 2))
        loss = lost / np.where(ref_len > 0.0, ref_len, 1.0)
    loss = np.where(loss < 1e-12, 0.0, loss)
    dscale = P / km  # residuals relative to the elastic deflection scale
    resid = np.maximum.reduce([
        np.abs(np.where(valid, F * g, 0.0)).sum(axis=(1, 2)) / (P * dscale),
        np.maximum(-np.where(valid, g, 0.0).min(axis=(1, 2)), 0.0) / dscale,
        np.abs(F.sum(axis=(1, 2)) - P) / P,
    ])
    return {
        "ste": sol.ste, "lpms": km, "lpms_tangent": sol.lpms_tangent, "cms": em,
        "kinematic_te": np.where(valid, xi, np.inf).min(axis=(1, 2)),
        "contact_length": geo_len, "loaded_length": loaded_len,
        "contact_loss_fraction": loss, "geometric_loss_fraction": geo_loss,
        "n_teeth_in_contact": ((F.sum(axis=2) > 0.0) & grid.valid).sum(axis=1),
        "complementarity_residual": resid,
    }


# ------------------------------------------------------------------------------ front end
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
    max_newton: int = 40,
    keep_points: bool = True,
    setup: LtcaSetup | None = None,
    max_outer: int | None = None,
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
        Newton tolerance of the contact-law loop on ``max |dF| / P``.
    max_newton : int
        Newton iteration limit per position.
    keep_points : bool
        Keep the per-point variables (dims ``position, line, point``).
    setup : LtcaSetup or None
        A prepared grid (:func:`ltca_setup`); then ``compliance``, ``positions_per_cycle``,
        ``n_cycles``, ``tau`` and ``n_pts`` are taken from it.
    max_outer : int or None
        Version-1 name of ``max_newton`` (kept as an alias; it wins when given).

    Returns
    -------
    xarray.Dataset
        Over ``position`` (coordinate ``tau`` in mesh cycles, ``mesh_cycle``): ``ste``,
        ``ste_transverse`` (um), ``lpms`` and ``lpms_tangent`` (N/um), ``cms`` (um),
        ``n_teeth_in_contact``, ``contact_length``, ``loaded_length`` (mm),
        ``contact_loss_fraction`` (unloaded share of the design pattern: the same modified
        flank without pitch deviations at the same load), ``geometric_loss_fraction``,
        ``partial_contact_loss`` (loss > :data:`PARTIAL_LOSS_THRESHOLD`), ``kinematic_te``
        (um), ``status``, ``n_iterations``, ``complementarity_residual``; over
        ``(position, line, point)``: ``force`` (N), ``line_load`` (N/mm), ``in_contact``
        (contact pattern), ``design_contact`` (pattern of the error-free modified flank),
        ``gap`` and ``xi`` (um), ``s``, ``y`` (mm); over ``(position, line)``: ``valid``,
        ``pinion_tooth``, ``wheel_tooth``.
    """
    if (torque is None) == (normal_force is None):
        raise ValueError("give exactly one of torque [N m] or normal_force [N]")
    if torque is not None:
        P = normal_force_from_torque(pair, torque)
    else:
        _check_positive("normal_force", normal_force, "N")
        P = float(normal_force)
    if max_outer is not None:
        max_newton = int(max_outer)
    if setup is None:
        setup = ltca_setup(pair, compliance=compliance, positions_per_cycle=positions_per_cycle,
                           n_cycles=n_cycles, tau=tau, n_pts=n_pts)
    elif setup.pair != pair:
        raise ValueError("setup was built for a different pair")
    dev = deviations or FlankDeviations()
    xi = setup.clearance(dev)
    sol = ltca_solve(setup, P, xi, tol=tol, max_newton=max_newton)
    ref = _design_reference(setup, dev, P, tol=tol, max_newton=max_newton) \
        if dev.has_errors else sol.force > 0.0
    return _dataset(setup, sol, ref, keep_points)


def _dataset(setup: LtcaSetup, sol: LtcaSolution, ref: np.ndarray, keep_points: bool):
    """Label a solution as a Dataset (um, N/um, mm)."""
    pair, grid, comp = setup.pair, setup.grid, setup.compliance
    kin = grid.kin
    summ = mesh_summaries(setup, sol, ref)
    um = 1e6
    pos = "position"
    data = {
        "ste": (pos, summ["ste"] * um, {"units": "um", "long_name": "static transmission error "
                                        "(normal approach of the flanks)"}),
        "ste_transverse": (pos, summ["ste"] / kin.cos_bb * um,
                           {"units": "um", "long_name": "STE along the transverse line of "
                            "action (base-circle arc of the pinion)"}),
        "lpms": (pos, summ["lpms"] * 1e-6, {"units": "N/um", "long_name": "long-period mesh "
                                            "stiffness sum F_i/(STE - xi_i) (Yuan et al. Eq. 4, "
                                            "secant)"}),
        "lpms_tangent": (pos, summ["lpms_tangent"] * 1e-6, {
            "units": "N/um", "long_name": "tangent mesh stiffness dP/dSTE (linearised "
            "dynamics); Yuan et al. Eq. 4 gives the secant lpms"}),
        "cms": (pos, summ["cms"] * um, {"units": "um", "long_name": "composite mesh error "
                                        "sum k_i xi_i / k_m (Yuan et al. Eq. 5)"}),
        "kinematic_te": (pos, summ["kinematic_te"] * um,
                         {"units": "um", "long_name": "no-load kinematic TE min(xi)"}),
        "n_teeth_in_contact": (pos, summ["n_teeth_in_contact"], {"units": "1"}),
        "contact_length": (pos, summ["contact_length"] * 1e3,
                           {"units": "mm", "long_name": "geometric contact length"}),
        "loaded_length": (pos, summ["loaded_length"] * 1e3, {"units": "mm"}),
        "contact_loss_fraction": (pos, summ["contact_loss_fraction"], {
            "units": "1", "long_name": "unloaded share of the design contact pattern (same "
            "modified flank without pitch deviations, same load)"}),
        "geometric_loss_fraction": (pos, summ["geometric_loss_fraction"], {
            "units": "1", "long_name": "unloaded share of the geometric contact length "
            "(counts zones a relief unloads by design)"}),
        "partial_contact_loss": (pos, summ["contact_loss_fraction"] > PARTIAL_LOSS_THRESHOLD,
                                 {"long_name": "more than 5 % of the design contact length "
                                  "unloaded"}),
        "complementarity_residual": (pos, summ["complementarity_residual"], {"units": "1"}),
        "n_iterations": (pos, sol.n_iterations, {"units": "1",
                                                 "long_name": "Newton iterations"}),
        "status": (pos, sol.status, {"long_name": "0 ok, 1 solver did not converge"}),
    }
    if keep_points:
        data.update(_point_variables(setup, sol, ref))
    ds = xr.Dataset(
        data,
        coords={"tau": (pos, grid.tau, {"units": "mesh cycles"}),
                "mesh_cycle": (pos, np.floor(grid.tau).astype(int), {})},
    )
    ds.attrs.update({
        "model": "gearuq.gears.ltca", "normal_force_N": sol.normal_force,
        "torque_Nm": sol.normal_force * 0.5 * pair.db1 * kin.cos_bb, "compliance": comp.kind,
        "coupling_length_m": float(comp.coupling_length), "hertz": int(comp.hertz),
        "n_pts": setup.n_pts, "s_A_m": kin.s_A, "s_E_m": kin.s_E, "face_width_m": kin.b,
    })
    return ds


def _point_variables(setup: LtcaSetup, sol: LtcaSolution, ref: np.ndarray) -> dict:
    grid, pair = setup.grid, setup.pair
    F = sol.force
    valid = np.broadcast_to(grid.valid[..., None], F.shape)
    seg = np.broadcast_to(grid.dL[..., None], F.shape)
    pdims = ("position", "line", "point")
    um = 1e6
    return {
        "force": (pdims, F, {"units": "N", "long_name": "normal force at the contact point"}),
        "in_contact": (pdims, (F > 0.0) & valid, {"long_name": "contact pattern (F > 0)"}),
        "design_contact": (pdims, ref & valid, {"long_name": "contact pattern of the same "
                                                "modified flank without pitch deviations"}),
        "line_load": (pdims, F / np.where(valid, seg, 1.0) * 1e-3, {"units": "N/mm"}),
        "gap": (pdims, np.where(valid, sol.gap, np.nan) * um, {"units": "um"}),
        "xi": (pdims, np.where(valid, sol.xi, np.nan) * um, {"units": "um"}),
        "s": (pdims, np.where(valid, grid.s, np.nan) * 1e3, {"units": "mm",
              "long_name": "POA coordinate from T1"}),
        "y": (pdims, np.where(valid, grid.y, np.nan) * 1e3, {"units": "mm"}),
        "valid": (("position", "line"), grid.valid, {}),
        "pinion_tooth": (("position", "line"), np.mod(grid.pair_index, pair.z1), {}),
        "wheel_tooth": (("position", "line"), np.mod(grid.pair_index, pair.z2), {}),
    }


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
        ``ste`` (um), ``lpms`` (secant) and ``lpms_tangent`` (N/um), ``cms`` (um) over
        ``(load, position)`` and ``ste_at_zero_load`` (the no-load TE); use
        :func:`force_at_deflection` and :func:`stiffness_at_deflection`.
    """
    loads = np.asarray(loads, dtype=float)
    if loads.ndim != 1 or loads.size < 2 or np.any(np.diff(loads) <= 0) or loads[0] <= 0:
        raise ValueError(f"loads={loads!r} must be a strictly increasing 1-D array of > 0 N")
    setup = kw.pop("setup", None)
    if setup is None:
        grid_kw = {k: kw.pop(k) for k in ("compliance", "positions_per_cycle", "n_cycles",
                                          "tau", "n_pts") if k in kw}
        setup = ltca_setup(pair, **grid_kw)
    kw = {**kw, "keep_points": False, "setup": setup}
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
    """Brute-force STE peak-to-peak over symmetric tip-relief amount x length (Yuan et al. Fig. 14).

    Parameters
    ----------
    pair : HelicalGearPair
        The gear pair.
    amounts, lengths : array_like
        Relief amounts [m] and lengths along the path of contact [m] (Yuan et al. Eq. 12, same on
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
    setup = kw.pop("setup", None) or ltca_setup(
        pair, compliance=kw.pop("compliance", None), positions_per_cycle=positions_per_cycle,
        n_cycles=n_cycles, n_pts=kw.pop("n_pts", 20))
    ptp = np.empty((amounts.size, lengths.size))
    base_kw = {} if base is None else {
        k: getattr(base, k) for k in ("Fp1", "Fp2", "root_relief1", "root_relief2",
                                       "crowning", "user")}
    for i, ca in enumerate(amounts):
        for j, la in enumerate(lengths):
            dev = FlankDeviations.symmetric_tip_relief(float(ca), float(la), **base_kw)
            r = ltca(pair, torque=torque, normal_force=normal_force, deviations=dev,
                     setup=setup, keep_points=False, **kw)
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
