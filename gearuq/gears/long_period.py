"""Long-period LTCA whose cost does not grow with ``lcm(z1, z2)``: the line-load table.

The long period of a hunting-tooth pair is ``lcm(z1, z2) = z1 z2`` mesh cycles (2133 for a
27/79 pair), and the full LTCA (:func:`gearuq.gears.ltca.ltca`) solves the contact problem at
every one of its positions. Two facts make that unnecessary:

1. the influence matrix ``D`` is block diagonal over the lines of contact (different tooth
   pairs do not interact through the compliance), and Weber's approach is local, so a line
   of contact interacts with the others only through the common rigid-body approach
   ``STE``. Each line carries the load ``L_q(STE - e)`` of its own force-deflection curve,
   where ``q`` is the line's geometry (its phase ``tau - k``, with the designed flank
   modifications at its points) and ``e`` the separation of its tooth pair (the normal
   projection of the pinion's plus the wheel's cumulative pitch deviation);
2. a long period holds only ``positions_per_cycle x ceil(eps_gamma)`` distinct line
   geometries, the same in every mesh cycle.

So :func:`line_load_table` solves each line geometry alone, once per stage, at a ladder of
line loads from ``min_load_fraction x P_max`` to ``P_max`` (the exact same Newton /
active-set solver as the full LTCA, :func:`gearuq.gears.ltca_kernel.solve_line_loads`), and
:func:`long_period_ltca` evaluates the long period from it: at each position the equilibrium
``sum_lines L_q(STE - e_line) = P`` is one monotone scalar equation, solved by safeguarded
Newton on a cubic Hermite interpolant of the tabulated curves (exact values and exact
tangent stiffnesses at the nodes, so the interpolant is C1). The table serves every load up
to ``P_max`` and every pitch-deviation realisation; a sample costs a few microseconds per
position. The only approximations are the interpolation between load nodes
(``n_load_nodes``), measured against the full LTCA in ``docs/theory/ltca.md`` (Sec. 10), and
the solver's load floor for Weber's approach, which is relative to the line's load instead of
the whole mesh's.

Main entry points: :func:`line_load_table`, :func:`long_period_ltca`, :class:`LongPeriodSettings`.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, replace

import numba as nb
import numpy as np
import xarray as xr

from gearuq._version import __version__
from gearuq.gears.compliance import ComplianceModel
from gearuq.gears.contact import long_period_cycles
from gearuq.gears.deviations import FlankDeviations
from gearuq.gears.geometry import HelicalGearPair
from gearuq.gears.ltca import PARTIAL_LOSS_THRESHOLD, ltca_setup, normal_force_from_torque

__all__ = [
    "LineLoadTable",
    "LongPeriodSettings",
    "line_load_table",
    "long_period_ltca",
    "pitch_separations",
]


@dataclass(frozen=True)
class LongPeriodSettings:
    """Settings of the line-load table (the ones that trade cost for accuracy).

    Parameters
    ----------
    positions_per_cycle : int
        Mesh positions per mesh cycle (>= 1), as in :func:`gearuq.gears.ltca.ltca`.
    n_pts : int
        Points per line of contact (>= 1).
    n_load_nodes : int
        Line loads tabulated per line geometry (>= 4). The interpolation error of the STE
        falls as ``n_load_nodes^-4`` between active-set changes (docs/theory/ltca.md, Sec. 10).
    min_load_fraction : float
        Smallest tabulated line load over ``P_max``, in (0, 0.1); below it a line's load is
        linear in its approach from the first touching point.
    tol : float
        Newton tolerance of the line solves on ``max |dF| / L`` (as the full LTCA's ``tol``).
    max_newton : int
        Newton iteration limit of the line solves.
    """

    positions_per_cycle: int = 24
    n_pts: int = 20
    n_load_nodes: int = 48
    min_load_fraction: float = 1e-4
    tol: float = 1e-13
    max_newton: int = 40

    def __post_init__(self) -> None:
        for name, low in (("positions_per_cycle", 1), ("n_pts", 1), ("n_load_nodes", 4),
                          ("max_newton", 1)):
            v = getattr(self, name)
            if isinstance(v, bool) or int(v) != v or v < low:
                raise ValueError(f"{name}={v!r} is outside its valid range: integers >= {low}")
        if not 0.0 < self.min_load_fraction < 0.1:
            raise ValueError(f"min_load_fraction={self.min_load_fraction!r} is outside its "
                             "valid range (0, 0.1)")
        if not 0.0 < self.tol < 1e-3:
            raise ValueError(f"tol={self.tol!r} is outside its valid range (0, 1e-3)")

    def load_fractions(self) -> np.ndarray:
        """Tabulated line loads over ``P_max``: a geometric ladder up to 5 %, then uniform.

        A quarter of the nodes (at least 2) climb geometrically from ``min_load_fraction``
        to 0.05, where a line's force-deflection curve bends most (Weber's approach, points
        entering contact); the rest are uniform up to 1.
        """
        n_low = max(2, self.n_load_nodes // 4)
        low = np.geomspace(self.min_load_fraction, 0.05, n_low, endpoint=False)
        return np.concatenate([low, np.linspace(0.05, 1.0, self.n_load_nodes - n_low)])


@dataclass(frozen=True)
class LineLoadTable:
    """Force-deflection curve of every line geometry of one mesh cycle (SI units).

    Built by :func:`line_load_table`; valid for every pitch-deviation realisation and every
    normal force up to ``max_normal_force`` of its pair, compliance and designed flank
    modifications. Arrays over ``phase`` hold one entry per distinct line geometry.

    Attributes
    ----------
    pair : HelicalGearPair
    compliance : ComplianceModel
    modifications : FlankDeviations
        The designed modifications (reliefs, crowning) the table holds.
    settings : LongPeriodSettings
    max_normal_force : float
        Largest normal force ``P_max`` [N] the table serves.
    phase : ndarray of int, (positions_per_cycle, n_lines)
        Line geometry of each line slot at each position of a mesh cycle (-1: no line).
        Slot ``a`` at position ``m positions_per_cycle + j`` of the long period is tooth
        pair ``m - a`` (:func:`gearuq.gears.contact.contact_grid`).
    loads : ndarray, (n_load,)
        Tabulated line loads [N].
    approach : ndarray, (n_phase, n_load)
        Approach of the line at each load (the STE it would have alone) [m].
    stiffness : ndarray, (n_phase, n_load)
        Tangent stiffness ``dL / d approach`` [N/m].
    touch : ndarray, (n_phase,)
        Approach at which the line first touches, ``min xi`` [m].
    n_valid : ndarray of int, (n_phase,)
        Nodes of each geometry where its curve is valid: up to the first node whose
        approach no longer increases or whose solve failed (a short line under a load far
        above any it meets leaves the range of Weber's formula). Status 2 flags a position
        where a line's load exceeds its valid range.
    forces : ndarray, (n_phase, n_load, n_pts)
        Point forces [N].
    onset : ndarray, (n_phase, n_pts)
        Approach at which each point enters contact [m] (``inf``: never up to ``P_max``;
        NaN: the point leaves contact again at a higher load, its state is interpolated).
    secant : ndarray, (n_phase, n_load)
        ``sum F_i / (approach - xi_i)`` over loaded points [N/m] (the line's share of
        Yuan et al.'s Eq. 4).
    weighted_clearance : ndarray, (n_phase, n_load)
        ``sum k_i xi_i`` over loaded points [N] (the line's share of Eq. 5's numerator).
    xi : ndarray, (n_phase, n_pts)
        Designed clearances of each geometry [m].
    segment : ndarray, (n_phase,)
        Segment length along the line [m].
    contact_length : ndarray, (positions_per_cycle,)
        Geometric contact length at each position of the cycle [m].
    status : ndarray of int, (n_phase, n_load)
        0 ok, 1 the line solve did not converge.
    """

    pair: HelicalGearPair
    compliance: ComplianceModel
    modifications: FlankDeviations
    settings: LongPeriodSettings
    max_normal_force: float
    phase: np.ndarray
    loads: np.ndarray
    approach: np.ndarray
    stiffness: np.ndarray
    touch: np.ndarray
    n_valid: np.ndarray
    forces: np.ndarray
    onset: np.ndarray
    secant: np.ndarray

    @property
    def nested(self) -> np.ndarray:
        """Whether each geometry's loaded set only grows with its approach, ``(n_phase,)``."""
        return ~np.isnan(self.onset).any(axis=1)

    @property
    def onset_sorted(self) -> np.ndarray:
        """Onset approaches sorted per geometry (NaN as inf), ``(n_phase, n_pts)`` [m]."""
        return np.sort(np.where(np.isnan(self.onset), np.inf, self.onset), axis=1)
    weighted_clearance: np.ndarray
    xi: np.ndarray
    segment: np.ndarray
    contact_length: np.ndarray
    status: np.ndarray


def _design_modifications(deviations: FlankDeviations | None) -> FlankDeviations:
    dev = deviations or FlankDeviations()
    # a clearance map that declares itself the same on every tooth (a stage's reliefs of any
    # shape) is a designed modification: it depends on the line geometry alone
    if dev.user is not None and not getattr(dev.user, "same_on_every_tooth", False):
        raise ValueError("deviations.user (a per-tooth clearance map) is outside what the "
                         "line-load table represents (designed modifications, the same on every "
                         "tooth, plus pitch deviations); use gearuq.gears.ltca.ltca")
    design = dev.design_only()
    return design if dev.user is None else replace(design, user=dev.user)


def line_load_table(
    pair: HelicalGearPair,
    *,
    max_torque: float | None = None,
    max_normal_force: float | None = None,
    modifications: FlankDeviations | None = None,
    settings: LongPeriodSettings | None = None,
    compliance: ComplianceModel | None = None,
) -> LineLoadTable:
    """Tabulate the force-deflection curve of every line geometry of one mesh cycle.

    Parameters
    ----------
    pair : HelicalGearPair
        The gear pair (pinion drives).
    max_torque, max_normal_force : float
        Largest pinion torque [N m] or normal mesh force [N] to serve; exactly one, > 0.
        A single line can carry at most the whole mesh force, so the table covers every
        line load that occurs at or below it.
    modifications : FlankDeviations or None
        Designed modifications (tip and root reliefs, crowning); pitch deviations in it are
        ignored (they enter :func:`long_period_ltca` per sample). ``None``: none.
    settings : LongPeriodSettings or None
        ``None``: the defaults.
    compliance : ComplianceModel or None
        ``None``: the potential-energy model with Weber contact, default parameters.

    Returns
    -------
    LineLoadTable
    """
    from gearuq.gears.ltca_kernel import solve_line_loads

    if (max_torque is None) == (max_normal_force is None):
        raise ValueError("give exactly one of max_torque [N m] or max_normal_force [N]")
    p_max = (normal_force_from_torque(pair, max_torque) if max_torque is not None
             else float(max_normal_force))
    if not (math.isfinite(p_max) and p_max > 0):
        raise ValueError(f"max_normal_force={max_normal_force!r} is outside its valid range "
                         "(0, inf) N")
    settings = settings or LongPeriodSettings()
    design = _design_modifications(modifications)
    setup = ltca_setup(pair, compliance=compliance, n_cycles=1, n_pts=settings.n_pts,
                       positions_per_cycle=settings.positions_per_cycle)
    xi_grid = setup.clearance(design)
    n_phase = setup.D.shape[0]
    rows, cols = np.nonzero(setup.phase >= 0)
    q = setup.phase[rows, cols]
    xi = np.empty((n_phase, setup.n_pts))
    xi[q] = xi_grid[rows, cols]  # designed clearances depend on the line geometry alone
    loads = p_max * settings.load_fractions()
    shape = (n_phase, loads.size)
    forces = np.zeros((*shape, setup.n_pts))
    approach, stiffness = np.zeros(shape), np.zeros(shape)
    n_iter, status = np.zeros(shape, np.int64), np.zeros(shape, np.int64)
    comp = setup.compliance
    solve_line_loads(setup.D, np.ascontiguousarray(xi), setup.dL, setup.R, setup.h1, setup.h2,
                     loads, comp.E, comp.nu, bool(comp.hertz), float(settings.tol),
                     int(settings.max_newton), forces, approach, stiffness, n_iter, status)
    loaded = forces > 0.0
    defl = approach[..., None] - xi[:, None, :]
    k_point = np.where(loaded, forces / np.where(loaded, defl, 1.0), 0.0)
    n_valid = _valid_nodes(approach, status)
    return LineLoadTable(
        pair=pair, compliance=comp, modifications=design, settings=settings,
        max_normal_force=p_max, phase=setup.phase, loads=loads, approach=approach,
        stiffness=stiffness, touch=xi.min(axis=1), n_valid=n_valid,
        forces=forces,
        onset=_onset_approach(approach, forces, xi, n_valid), secant=k_point.sum(axis=2),
        weighted_clearance=(k_point * xi[:, None, :]).sum(axis=2), xi=xi,
        segment=setup.dL.copy(), contact_length=setup.grid.length, status=status)


def _valid_nodes(approach: np.ndarray, status: np.ndarray) -> np.ndarray:
    """Nodes before the first one whose approach does not increase or whose solve failed."""
    bad = np.zeros(approach.shape, bool)
    bad[:, 1:] = np.diff(approach, axis=1) <= 0.0
    bad |= status != 0
    n = np.where(bad.any(axis=1), np.argmax(bad, axis=1), approach.shape[1])
    return np.maximum(n, 1).astype(np.int64)


def _onset_approach(approach: np.ndarray, forces: np.ndarray, xi: np.ndarray,
                    n_valid: np.ndarray) -> np.ndarray:
    """Approach at which each point enters contact, from the first two loaded nodes [m].

    Between the last unloaded node and the first loaded one, a point's force grows about
    linearly from zero; the line through its first two loaded nodes gives the onset, kept
    inside that interval (the point's own clearance ``xi`` bounds it from below). Points
    loaded at the first node start at their clearance's touch (linear from the first
    touch); points that are unloaded again at a higher load get NaN. Nodes beyond a
    geometry's ``n_valid`` repeat its last valid node.
    """
    n_phase, n_load, n_pts = forces.shape
    last = np.minimum(np.arange(n_load)[None, :], n_valid[:, None] - 1)
    forces = np.take_along_axis(forces, last[..., None], axis=1)
    approach = np.take_along_axis(approach, last, axis=1)
    loaded = forces > 0.0
    onset = np.full((n_phase, n_pts), np.inf)
    first = np.argmax(loaded, axis=1)  # first loaded node (0 if never: masked below)
    ever = loaded.any(axis=1)
    q, i = np.nonzero(ever)
    j1 = first[q, i]
    a1 = approach[q, j1]
    f1 = forces[q, j1, i]
    j2 = np.minimum(j1 + 1, n_load - 1)
    run = approach[q, j2] - a1  # 0 at the last (valid) node: no slope, onset = a0
    slope = np.where(run > 0.0, forces[q, j2, i] - f1, 0.0) / np.where(run > 0.0, run, 1.0)
    a0 = np.where(j1 > 0, approach[q, np.maximum(j1 - 1, 0)], xi[q, i])
    est = np.where(slope > 0.0, a1 - f1 / np.where(slope > 0.0, slope, 1.0), a0)
    onset[q, i] = np.clip(est, a0, a1)
    # loaded at the first node: the point's clearance is below the first node's approach
    lead = j1 == 0
    onset[q[lead], i[lead]] = np.minimum(np.maximum(est[lead], xi[q[lead], i[lead]]),
                                         a1[lead])
    # a point unloaded again at a higher load: no single onset
    relapse = ever & (np.cumsum(loaded, axis=1)[:, -1, :] < n_load - first)
    onset[relapse] = np.nan
    return onset


def pitch_separations(pair: HelicalGearPair, deviations: FlankDeviations | None,
                      n_cycles: int, n_lines: int) -> np.ndarray:
    """Normal separation of the tooth pair in each line slot of each mesh cycle [m].

    Slot ``a`` of cycle ``m`` is tooth pair ``k = m - a``: pinion tooth ``k mod z1``
    against wheel tooth ``k mod z2``; its separation is ``(F_p1 + F_p2) cos(alpha_t)
    cos(beta_b)`` (Yuan et al. Eq. 2, as :meth:`FlankDeviations.clearance`).

    Returns
    -------
    ndarray, (n_cycles, n_lines)
    """
    k = np.arange(int(n_cycles))[:, None] - np.arange(int(n_lines))[None, :]
    sep = np.zeros(k.shape)
    if deviations is None:
        return sep
    deviations.validate(pair)
    conv = math.cos(pair.alpha_t) * math.cos(pair.beta_b)
    if deviations.Fp1 is not None:
        sep = sep + np.asarray(deviations.Fp1, dtype=float)[np.mod(k, pair.z1)] * conv
    if deviations.Fp2 is not None:
        sep = sep + np.asarray(deviations.Fp2, dtype=float)[np.mod(k, pair.z2)] * conv
    return sep


# ------------------------------------------------------------------------------ kernels
@nb.njit(cache=True, nogil=True, inline="always")
def _line_load(q, a, approach, loads, stiffness, touch, n_valid, hint):
    """Load, slope, interval and weight of line geometry ``q`` at approach ``a``.

    Interval -2: not touching; -1: between the first touch and the first node (linear);
    ``i``: cubic Hermite between nodes ``i`` and ``i + 1``; ``n - 1``: beyond the last valid
    node ``n = n_valid[q]`` (linear extrapolation, only met inside the root bracket or when
    the status flags it). ``hint``: an interval to try before the binary search (the
    previous Newton iterate's).
    """
    n = n_valid[q]
    a_first = approach[q, 0]
    if a <= touch[q]:
        return 0.0, 0.0, -2, 0.0
    if a <= a_first:
        k = loads[0] / (a_first - touch[q])
        return k * (a - touch[q]), k, -1, (a - touch[q]) / (a_first - touch[q])
    if a >= approach[q, n - 1]:
        k = stiffness[q, n - 1]
        return loads[n - 1] + k * (a - approach[q, n - 1]), k, n - 1, 1.0
    lo, hi = 0, n - 1
    if 0 <= hint < n - 1 and approach[q, hint] < a <= approach[q, hint + 1]:
        lo, hi = hint, hint + 1
    while hi - lo > 1:
        mid = (lo + hi) // 2
        if approach[q, mid] < a:
            lo = mid
        else:
            hi = mid
    h = approach[q, hi] - approach[q, lo]
    u = (a - approach[q, lo]) / h
    u2 = u * u
    u3 = u2 * u
    f = ((2 * u3 - 3 * u2 + 1) * loads[lo] + (u3 - 2 * u2 + u) * h * stiffness[q, lo]
         + (-2 * u3 + 3 * u2) * loads[hi] + (u3 - u2) * h * stiffness[q, hi])
    df = ((6 * u2 - 6 * u) * (loads[lo] - loads[hi]) / h
          + (3 * u2 - 4 * u + 1) * stiffness[q, lo] + (3 * u2 - 2 * u) * stiffness[q, hi])
    return f, df, lo, u


@nb.njit(cache=True, nogil=True, inline="always")
def _count_below(sorted_rows, q, a):
    """Number of entries of row ``q`` (sorted) below ``a``."""
    lo, hi = 0, sorted_rows.shape[1]
    while lo < hi:
        mid = (lo + hi) // 2
        if sorted_rows[q, mid] < a:
            lo = mid + 1
        else:
            hi = mid
    return lo


@nb.njit(cache=True, nogil=True, inline="always")
def _node_value(values, q, idx, w, n_valid):
    """Linear interpolation of a tabulated line quantity (the first node's below it)."""
    n = n_valid[q]
    if idx == -2:
        return 0.0
    if idx == -1:  # a secant stiffness jumps from 0 when the first point touches
        return values[q, 0]
    if idx >= n - 1:
        return values[q, n - 1]
    return (1.0 - w) * values[q, idx] + w * values[q, idx + 1]


@nb.njit(cache=True, nogil=True, inline="always")
def _point_loaded(forces, onset, q, idx, w, a, i, n_valid):
    """Whether point ``i`` of a line at approach ``a`` (interval ``idx``, weight ``w``) is loaded.

    From the point's onset approach when its loaded set only grows with the load, else from
    the interpolated node forces.
    """
    n = n_valid[q]
    if idx == -2:
        return False
    if not math.isnan(onset[q, i]):
        return a > onset[q, i]
    if idx == -1:
        return forces[q, 0, i] > 0.0
    if idx >= n - 1:
        return forces[q, n - 1, i] > 0.0
    return (1.0 - w) * forces[q, idx, i] + w * forces[q, idx + 1, i] > 0.0


@nb.njit(cache=True, nogil=True)
def _solve_long_period(phase, sep, P, approach, loads, stiffness, touch, n_valid, forces,
                       onset, onset_sorted, nested, secant, wclear, segment, guess_ste,
                       guess_k, ref_idx, ref_w, has_ref,
                       ste, k_tan, k_sec, cms_num, loaded_len, lost_len, ref_len, n_teeth,
                       kin_te, line_load, line_idx, line_w, n_iter, status):
    """Equilibrium ``sum L_q(STE - e) = P`` at every position, then its summaries.

    ``phase`` (ppc, n_lines); ``sep`` (n_cycles, n_lines) [m]; position ``p`` is cycle
    ``p // ppc``, cycle position ``p % ppc``. ``guess_ste``, ``guess_k`` (ppc,), (ppc,
    n_lines): the error-free solution and line stiffnesses, for the first Newton guess;
    ``ref_idx``, ``ref_w`` (ppc, n_lines): the error-free pattern (when ``has_ref``).
    """
    ppc, n_lines = phase.shape
    n_pos = sep.shape[0] * ppc
    n_pts = forces.shape[2]
    tol_f = 1e-13 * P
    hints = np.empty(n_lines, np.int64)
    for p in range(n_pos):
        m = p // ppc
        j = p - m * ppc
        for a in range(n_lines):  # the error-free interval is the likeliest
            hints[a] = ref_idx[j, a]
        # bracket: below, no line touches; above, every line carries at least P (on the
        # tabulated curve or its linear extension with the last slope)
        lo = np.inf
        hi = -np.inf
        k_min = np.inf
        num = 0.0
        den = 0.0
        for a in range(n_lines):
            q = phase[j, a]
            if q < 0:
                continue
            last = n_valid[q] - 1
            lo = min(lo, touch[q] + sep[m, a])
            hi = max(hi, approach[q, last] + sep[m, a])
            k_min = min(k_min, stiffness[q, last])
            num += guess_k[j, a] * sep[m, a]
            den += guess_k[j, a]
        hi += P / k_min
        kin_te[p] = lo  # the no-load kinematic TE: the first point to touch
        d = guess_ste[j] + (num / den if den > 0.0 else 0.0)
        if not (lo < d < hi):
            d = 0.5 * (lo + hi)
        ok = False
        it = 0
        while it < 200:
            it += 1
            f = -P
            df = 0.0
            for a in range(n_lines):
                q = phase[j, a]
                if q >= 0:
                    fa, dfa, hints[a], _ = _line_load(q, d - sep[m, a], approach, loads,
                                                      stiffness, touch, n_valid, hints[a])
                    f += fa
                    df += dfa
            if abs(f) <= tol_f:
                ok = True
                break
            if f < 0.0:
                lo = d
            else:
                hi = d
            step = d - f / df if df > 0.0 else lo - 1.0
            newton = lo < step < hi
            change = abs(step - d) if newton else np.inf
            d = step if newton else 0.5 * (lo + hi)
            # Newton converges quadratically: after a correction below 1e-11 m the error is
            # ~ 1e-22 m^2 / (deflection ~ 1e-5 m) ~ 1e-17 m; stopping there saves one
            # evaluation of every line per position
            if change <= 1e-11 or hi - lo <= 1e-16 * max(abs(hi), 1e-6):
                ok = True
                break
        ste[p] = d
        n_iter[p] = it
        status[p] = 0 if ok else 1
        kt = 0.0
        ks = 0.0
        cn = 0.0
        ll = 0.0
        lost = 0.0
        rl = 0.0
        nt = 0
        for a in range(n_lines):
            q = phase[j, a]
            line_idx[p, a] = -2
            line_w[p, a] = 0.0
            line_load[p, a] = 0.0
            if q < 0:
                continue
            fa, dfa, idx, w = _line_load(q, d - sep[m, a], approach, loads, stiffness, touch,
                                         n_valid, hints[a])
            if fa > loads[n_valid[q] - 1] * (1.0 + 1e-9):  # beyond the line's valid table
                status[p] = 2
            line_idx[p, a] = idx
            line_w[p, a] = w
            line_load[p, a] = fa
            kt += dfa
            s_a = _node_value(secant, q, idx, w, n_valid)
            ks += s_a
            cn += _node_value(wclear, q, idx, w, n_valid) + sep[m, a] * s_a
            if fa > 0.0:
                nt += 1
            if nested[q]:  # the loaded sets grow with the approach: count the onsets passed
                n_now = _count_below(onset_sorted, q, d - sep[m, a])
                ll += n_now * segment[q]
                if has_ref:
                    n_ref = _count_below(onset_sorted, q, guess_ste[j])
                    rl += n_ref * segment[q]
                    lost += max(n_ref - n_now, 0) * segment[q]
                continue
            for i in range(n_pts):
                now = _point_loaded(forces, onset, q, idx, w, d - sep[m, a], i, n_valid)
                if now:
                    ll += segment[q]
                if has_ref and _point_loaded(forces, onset, q, ref_idx[j, a], ref_w[j, a],
                                             guess_ste[j], i, n_valid):
                    rl += segment[q]
                    if not now:
                        lost += segment[q]
        k_tan[p] = kt
        k_sec[p] = ks
        cms_num[p] = cn
        loaded_len[p] = ll
        lost_len[p] = lost
        ref_len[p] = rl
        n_teeth[p] = nt


def _solve(table: LineLoadTable, P: float, sep: np.ndarray, guess: dict | None) -> dict:
    ppc, n_lines = table.phase.shape
    n_pos = sep.shape[0] * ppc
    out = {name: np.zeros(n_pos) for name in ("ste", "k_tan", "k_sec", "cms_num",
                                              "loaded_len", "lost_len", "ref_len", "kin_te")}
    out.update(n_teeth=np.zeros(n_pos, np.int64), n_iter=np.zeros(n_pos, np.int64),
               status=np.zeros(n_pos, np.int64), line_load=np.zeros((n_pos, n_lines)),
               line_idx=np.zeros((n_pos, n_lines), np.int64), line_w=np.zeros((n_pos, n_lines)))
    if guess is None:
        g_ste, g_k = np.zeros(ppc), np.zeros((ppc, n_lines))
        r_idx, r_w, has_ref = np.full((ppc, n_lines), -2, np.int64), np.zeros((ppc, n_lines)), False
    else:
        g_ste, g_k = guess["ste"], guess["line_k"]
        r_idx, r_w, has_ref = guess["line_idx"], guess["line_w"], True
    _solve_long_period(table.phase, np.ascontiguousarray(sep), float(P), table.approach,
                       table.loads, table.stiffness, table.touch, table.n_valid, table.forces,
                       table.onset, table.onset_sorted, table.nested,
                       table.secant,
                       table.weighted_clearance, table.segment, g_ste, g_k, r_idx, r_w, has_ref,
                       out["ste"], out["k_tan"], out["k_sec"], out["cms_num"], out["loaded_len"],
                       out["lost_len"], out["ref_len"], out["n_teeth"], out["kin_te"],
                       out["line_load"],
                       out["line_idx"], out["line_w"], out["n_iter"], out["status"])
    return out


def _design_guess(table: LineLoadTable, P: float) -> dict:
    """The error-free solution over one mesh cycle: first guess and design contact pattern."""
    ppc, n_lines = table.phase.shape
    design = _solve(table, P, np.zeros((1, n_lines)), None)
    line_k = np.zeros((ppc, n_lines))
    for a in range(n_lines):  # line tangent stiffness from the line loads: finite, positive
        q = table.phase[:, a]
        ok = q >= 0
        idx = np.clip(design["line_idx"][ok, a], 0, table.loads.size - 1)
        line_k[ok, a] = np.where(design["line_load"][ok, a] > 0.0,
                                 table.stiffness[q[ok], idx], 0.0)
    return {"ste": design["ste"], "line_k": line_k, "line_idx": design["line_idx"],
            "line_w": design["line_w"], "status": design["status"]}


# ------------------------------------------------------------------------------ front end
def long_period_ltca(
    pair: HelicalGearPair,
    deviations: FlankDeviations | None = None,
    *,
    torque: float | None = None,
    normal_force: float | None = None,
    settings: LongPeriodSettings | None = None,
    table: LineLoadTable | None = None,
    compliance: ComplianceModel | None = None,
    n_cycles: int | None = None,
    keep_lines: bool = True,
) -> xr.Dataset:
    """LTCA over the long period from the line-load table (cost independent of the period).

    Parameters
    ----------
    pair : HelicalGearPair
        The gear pair (pinion drives).
    deviations : FlankDeviations or None
        Pitch deviations and designed modifications of this sample; the modifications must
        be those of ``table``. ``None``: perfect gears.
    torque, normal_force : float
        Pinion torque [N m] or normal mesh force [N]; exactly one, > 0, at most the
        table's ``max_normal_force``.
    settings : LongPeriodSettings or None
        Used to build the table when ``table`` is None.
    table : LineLoadTable or None
        A table of this pair (:func:`line_load_table`), reused across samples and loads;
        ``None`` builds one for this load (``max_normal_force = P``).
    compliance : ComplianceModel or None
        Used to build the table when ``table`` is None.
    n_cycles : int or None
        Mesh cycles to cover; ``None``: the long period ``lcm(z1, z2)``.
    keep_lines : bool
        Keep the per-line variables (``line_load``, ``valid``, ``pinion_tooth``,
        ``wheel_tooth``); False keeps only the per-position ones (a fifth of the cost).

    Returns
    -------
    xarray.Dataset
        Over ``position`` (coordinates ``tau`` [mesh cycles] and ``mesh_cycle``), the
        per-position variables of :func:`gearuq.gears.ltca.ltca` (``ste``,
        ``ste_transverse``, ``kinematic_te``, ``cms`` in um; ``lpms`` secant and
        ``lpms_tangent`` in N/um; ``n_teeth_in_contact``; ``contact_length``,
        ``loaded_length`` in mm; ``contact_loss_fraction``, ``geometric_loss_fraction``,
        ``partial_contact_loss``; ``status``, ``n_iterations``) and over
        ``(position, line)`` the ``line_load`` (N) each tooth pair carries, with
        ``pinion_tooth``, ``wheel_tooth`` and ``valid``.
    """
    if (torque is None) == (normal_force is None):
        raise ValueError("give exactly one of torque [N m] or normal_force [N]")
    P = (normal_force_from_torque(pair, torque) if torque is not None else float(normal_force))
    if not (math.isfinite(P) and P > 0):
        raise ValueError(f"normal_force={normal_force!r} is outside its valid range (0, inf) N")
    design = _design_modifications(deviations)
    if table is None:
        table = line_load_table(pair, max_normal_force=P, modifications=design,
                                settings=settings, compliance=compliance)
    elif table.pair != pair:
        raise ValueError("table was built for a different pair")
    elif design != table.modifications:
        raise ValueError(f"deviations' designed modifications {design!r} differ from the "
                         f"table's {table.modifications!r}; build a table for them")
    if P > table.max_normal_force * (1.0 + 1e-12):
        raise ValueError(f"normal_force={P!r} N is outside the table's valid range "
                         f"(0, {table.max_normal_force!r}] N")
    nc = long_period_cycles(pair) if n_cycles is None else n_cycles
    if isinstance(nc, bool) or int(nc) != nc or nc < 1:
        raise ValueError(f"n_cycles={n_cycles!r} is outside its valid range: integers >= 1")
    ppc, n_lines = table.phase.shape
    guess = _design_guess(table, P)
    errors = deviations is not None and deviations.has_errors
    sep = pitch_separations(pair, deviations, int(nc), n_lines) if errors \
        else np.zeros((int(nc), n_lines))
    sol = _solve(table, P, sep, guess)
    return _dataset(table, sol, sep, P, int(nc), guess["status"], bool(keep_lines))


def _dataset(table: LineLoadTable, sol: dict, sep: np.ndarray, P: float, nc: int,
             design_status: np.ndarray, keep_lines: bool) -> xr.Dataset:
    """Label the long-period solution like :func:`gearuq.gears.ltca.ltca` (um, N/um, mm)."""
    pair = table.pair
    ppc, n_lines = table.phase.shape
    n_pos = nc * ppc
    j = np.arange(n_pos) % ppc
    cycle = np.arange(n_pos) // ppc
    cos_bb = math.cos(pair.beta_b)
    kin_te = sol["kin_te"]
    geo_len = table.contact_length[j]
    geo_loss = np.clip(1.0 - sol["loaded_len"] / geo_len, 0.0, 1.0)
    ref_len = sol["ref_len"]
    loss = sol["lost_len"] / np.where(ref_len > 0.0, ref_len, 1.0)
    loss = np.where(loss < 1e-12, 0.0, loss)
    status = np.where(sol["status"] != 0, sol["status"], np.where(design_status[j] != 0, 1, 0))
    um = 1e6
    pos = "position"
    data = {
        "ste": (pos, sol["ste"] * um, {"units": "um", "long_name": "static transmission error "
                                       "(normal approach of the flanks)"}),
        "ste_transverse": (pos, sol["ste"] / cos_bb * um, {
            "units": "um", "long_name": "STE along the transverse line of action"}),
        "lpms": (pos, sol["k_sec"] * 1e-6, {"units": "N/um", "long_name": "long-period mesh "
                                            "stiffness sum F_i/(STE - xi_i) (Yuan et al. Eq. 4, "
                                            "secant)"}),
        "lpms_tangent": (pos, sol["k_tan"] * 1e-6, {"units": "N/um",
                                                    "long_name": "tangent mesh stiffness dP/dSTE"}),
        "cms": (pos, sol["cms_num"] / sol["k_sec"] * um, {
            "units": "um", "long_name": "composite mesh error sum k_i xi_i / k_m (Yuan et al. "
            "Eq. 5)"}),
        "kinematic_te": (pos, kin_te * um, {"units": "um",
                                            "long_name": "no-load kinematic TE min(xi)"}),
        "n_teeth_in_contact": (pos, sol["n_teeth"], {"units": "1"}),
        "contact_length": (pos, geo_len * 1e3, {"units": "mm",
                                                "long_name": "geometric contact length"}),
        "loaded_length": (pos, sol["loaded_len"] * 1e3, {"units": "mm"}),
        "contact_loss_fraction": (pos, loss, {
            "units": "1", "long_name": "unloaded share of the design contact pattern (same "
            "modified flank without pitch deviations, same load)"}),
        "geometric_loss_fraction": (pos, geo_loss, {
            "units": "1", "long_name": "unloaded share of the geometric contact length"}),
        "partial_contact_loss": (pos, loss > PARTIAL_LOSS_THRESHOLD, {
            "long_name": "more than 5 % of the design contact length unloaded"}),
        "n_iterations": (pos, sol["n_iter"], {"units": "1",
                                              "long_name": "Newton iterations on the STE"}),
        "status": (pos, status, {"long_name": "0 ok, 1 the STE equation did not converge, "
                                 "2 a line's load is beyond its valid table range"}),
    }
    if keep_lines:
        k = cycle[:, None] - np.arange(n_lines)[None, :]
        data.update({
            "line_load": ((pos, "line"), sol["line_load"], {
                "units": "N", "long_name": "normal load carried by the tooth pair of the line"}),
            "valid": ((pos, "line"), table.phase[j] >= 0, {}),
            "pinion_tooth": ((pos, "line"), np.mod(k, pair.z1), {}),
            "wheel_tooth": ((pos, "line"), np.mod(k, pair.z2), {}),
        })
    ds = xr.Dataset(data, coords={
        "tau": (pos, cycle + j / ppc, {"units": "mesh cycles"}),
        "mesh_cycle": (pos, cycle, {}),
    })
    comp = table.compliance
    ds.attrs.update({
        "model": "gearuq.gears.long_period", "route": "line-load table",
        "gearuq_version": __version__, "normal_force_N": P,
        "torque_Nm": P * 0.5 * pair.db1 * cos_bb, "table_max_normal_force_N":
        table.max_normal_force, "compliance": comp.kind, "hertz": int(comp.hertz),
        "coupling_length_m": float(comp.coupling_length), "z1": int(pair.z1),
        "z2": int(pair.z2), "n_cycles": nc,
        **{f"setting_{k}": v for k, v in asdict(table.settings).items()},
    })
    return ds
