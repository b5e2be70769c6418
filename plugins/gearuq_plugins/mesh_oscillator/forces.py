"""Force-deflection functions ``f(x, phase)`` of a gear mesh (Eritenel and Parker (2013) Eq. 1).

``x`` is the mesh deflection (dynamic transmission error along the line of action) [m],
``phase`` the mesh phase in mesh cycles (``f`` has period 1 in it), ``f`` the mesh force [N].
Contact exists for ``x >= g(phase)``, the unloaded transmission error, where ``f(g) = 0``
(EP Eq. 2). Every function evaluates on batches: ``x`` of shape ``(n, n_phase, m)`` for
``n`` samples on a phase grid of ``n_phase`` points; the optional per-sample ``values``
(a dict of arrays of length ``n``) select a member of a family (e.g. a relief amount).

Kinds:

- :class:`PolynomialForce` ``f = sum_i k_i (x - g)^i`` (linear, cubic hardening/softening);
- :class:`SegmentForce` ``f = sum_j k_j(phase) max(x - c_j(phase), 0)^p_j`` (linear with
  periodic stiffness, Hertzian line contact, piecewise linear with partial contact loss);
- :class:`LoadDeflectionTable` deflections at given loads over a mesh cycle (the LTCA's
  ``force_deflection`` output, with its tangent stiffness) or converted from a user force
  table (:meth:`LoadDeflectionTable.from_force_table`);
- :class:`TableFamily` tables on one grid, interpolated in a parameter (relief, crowning).

Each also gives its nondimensional block for the exact time-domain kernels
(:mod:`.kernels`).

EP: Eritenel and Parker (2013), the paper this model follows (docs/models.md).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from gearuq.model import Parameter

TWO_PI = 2.0 * math.pi


# --------------------------------------------------------------------------- periodic data
@dataclass(frozen=True)
class Periodic:
    """A periodic function of the mesh phase: ``mean + sum_r cos_r cos(2 pi r phase) +
    sin_r sin(2 pi r phase)``.

    Parameters
    ----------
    mean : float
        Mean value.
    cos, sin : sequence of float
        Harmonics ``r = 1, 2, ...``.
    """

    mean: float
    cos: tuple[float, ...] = ()
    sin: tuple[float, ...] = ()

    def __post_init__(self) -> None:
        object.__setattr__(self, "cos", tuple(float(v) for v in self.cos))
        object.__setattr__(self, "sin", tuple(float(v) for v in self.sin))
        values = (self.mean, *self.cos, *self.sin)
        if not all(math.isfinite(v) for v in values):
            raise ValueError(f"Periodic: non-finite coefficient in {values}")

    @property
    def n_harmonics(self) -> int:
        """Highest harmonic order."""
        return max(len(self.cos), len(self.sin))

    def __call__(self, phase: np.ndarray) -> np.ndarray:
        """Values at ``phase`` [cycles]."""
        phase = np.asarray(phase, dtype=float)
        out = np.full(phase.shape, self.mean)
        for r, a in enumerate(self.cos, 1):
            out = out + a * np.cos(TWO_PI * r * phase)
        for r, b in enumerate(self.sin, 1):
            out = out + b * np.sin(TWO_PI * r * phase)
        return out

    def coefficients(self, n_harmonics: int) -> np.ndarray:
        """``[mean, cos_1, sin_1, ..., cos_H, sin_H]`` padded with zeros to ``H``."""
        out = np.zeros(1 + 2 * n_harmonics)
        out[0] = self.mean
        for r, a in enumerate(self.cos[:n_harmonics], 1):
            out[2 * r - 1] = a
        for r, b in enumerate(self.sin[:n_harmonics], 1):
            out[2 * r] = b
        return out


def as_periodic(value: Periodic | float) -> Periodic:
    """A constant as a :class:`Periodic` (periodic data passes through)."""
    if isinstance(value, Periodic):
        return value
    return Periodic(float(value))


def fourier_coefficients(samples: np.ndarray) -> np.ndarray:
    """Real Fourier coefficients of samples on a uniform grid over one period (last axis).

    Returns ``[..., 1 + 2 H]`` = ``mean, a_1, b_1, ..., a_H, b_H`` with ``H = N // 2``; the
    series interpolates the samples exactly (for even ``N`` the Nyquist term is a cosine with
    its proper weight).
    """
    samples = np.asarray(samples, dtype=float)
    n = samples.shape[-1]
    spec = np.fft.rfft(samples, axis=-1) / n
    h = n // 2
    out = np.zeros(samples.shape[:-1] + (1 + 2 * h,))
    out[..., 0] = spec[..., 0].real
    for r in range(1, h + 1):
        factor = 1.0 if (n % 2 == 0 and r == h) else 2.0
        out[..., 2 * r - 1] = factor * spec[..., r].real
        out[..., 2 * r] = -factor * spec[..., r].imag
    return out


def shift_fourier(coef: np.ndarray, shift: np.ndarray) -> np.ndarray:
    """Coefficients of ``f(theta + shift)`` from those of ``f(theta)`` (angle in radians).

    ``coef[..., 1 + 2 H]``, ``shift`` broadcastable to ``coef[..., 0]``.
    """
    coef = np.asarray(coef, dtype=float)
    out = coef.copy()
    shift = np.asarray(shift, dtype=float)
    for r in range(1, (coef.shape[-1] - 1) // 2 + 1):
        a, b = coef[..., 2 * r - 1], coef[..., 2 * r]
        cs, sn = np.cos(r * shift), np.sin(r * shift)
        # a cos(r(t+s)) + b sin(r(t+s)) = (a cs + b sn) cos(rt) + (b cs - a sn) sin(rt)
        out[..., 2 * r - 1] = a * cs + b * sn
        out[..., 2 * r] = b * cs - a * sn
    return out


# --------------------------------------------------------------------------- base class
class ForceDeflection:
    """Base class of the force-deflection functions (see the module docstring).

    Subclasses implement :meth:`derivatives`, :meth:`unloaded` and :meth:`kernel_block`.
    """

    #: Short name shown in provenance.
    kind: str = "force"
    #: Whether Taylor derivatives at the mean deflection describe the nonlinearity (False for
    #: kinked functions, whose default expansion is a least-squares fit over the vibration).
    smooth: bool = True
    #: Extra per-sample parameters (families).
    parameters: tuple[Parameter, ...] = ()

    def derivatives(self, x: np.ndarray, phase: np.ndarray, order: int,
                    values: Mapping[str, np.ndarray] | None = None) -> np.ndarray:
        """``d^i f / dx^i`` for ``i = 0..order``, shape ``(order + 1,) + x.shape``.

        ``x`` has shape ``(n, n_phase, m)`` and ``phase`` shape ``(n_phase,)``; zero out of
        contact.
        """
        raise NotImplementedError

    def force(self, x: np.ndarray, phase: np.ndarray,
              values: Mapping[str, np.ndarray] | None = None) -> np.ndarray:
        """Mesh force [N] (see :meth:`derivatives` for shapes)."""
        return self.derivatives(x, phase, 0, values)[0]

    def unloaded(self, phase: np.ndarray, n: int,
                 values: Mapping[str, np.ndarray] | None = None) -> np.ndarray:
        """Unloaded transmission error ``g(phase)`` [m], shape ``(n, n_phase)``."""
        raise NotImplementedError

    def natural_phases(self) -> np.ndarray | None:
        """Phase grid on which the data are given (tables), or ``None`` (analytic)."""
        return None

    def kernel_block(self, x_m: np.ndarray, d: np.ndarray, k_mean: np.ndarray,
                     shift: np.ndarray, values: Mapping[str, np.ndarray] | None,
                     harmonics: int | None) -> tuple[int, np.ndarray, int]:
        """Nondimensional block of the exact time-domain kernel (:mod:`.kernels`).

        Parameters
        ----------
        x_m, d, k_mean : ndarray, shape (n,)
            Mean deflection, deflection scale ``x_m - g_0`` [m], mean tangent stiffness
            ``beta_{1,0}`` [N/m] (``u = (x - x_m) / d``, forces over ``k_mean d``).
        shift : ndarray, shape (n,)
            Phase of the first excitation harmonic ``Phi_{0,1}`` [rad]: the kernel phase is
            ``theta = 2 pi phase - Phi_{0,1}``.
        values : dict or None
            Per-sample family values.
        harmonics : int or None
            Fourier harmonics kept (``None``: all the data carry).

        Returns
        -------
        kind, block, n_switch
        """
        raise NotImplementedError

    def describe(self) -> dict[str, Any]:
        """JSON-serialisable description (provenance)."""
        return {"kind": self.kind}

    def member(self, values: Mapping[str, float] | None = None) -> ForceDeflection:
        """The force of one family member (``self`` for plain forces)."""
        return self


def _contact_power(gap: np.ndarray, power: float, i: int) -> np.ndarray:
    """``d^i/dgap^i max(gap, 0)^power`` (zero out of contact)."""
    coef = 1.0
    for k in range(i):
        coef *= power - k
    if coef == 0.0:
        return np.zeros_like(gap)
    pos = np.maximum(gap, 0.0)
    with np.errstate(divide="ignore", invalid="ignore"):
        val = coef * np.where(gap > 0.0, pos ** (power - i), 0.0)
    return val


# --------------------------------------------------------------------------- polynomial
@dataclass(frozen=True)
class PolynomialForce(ForceDeflection):
    """``f = sum_{i>=1} k_i (x - g)^i`` in contact (``x >= g``), 0 otherwise; time-invariant.

    Parameters
    ----------
    stiffness : sequence of float
        ``k_1`` [N/m], ``k_2`` [N/m^2], ``k_3`` [N/m^3], ...; ``k_1 > 0``.
    unloaded_deflection : float
        ``g`` [m].
    """

    stiffness: tuple[float, ...]
    unloaded_deflection: float = 0.0
    kind: str = field(default="polynomial", init=False)

    def __post_init__(self) -> None:
        k = tuple(float(v) for v in self.stiffness)
        object.__setattr__(self, "stiffness", k)
        if not k or not all(math.isfinite(v) for v in k):
            raise ValueError(f"stiffness={self.stiffness!r}: give finite k_1, k_2, ... [N/m^i]")
        if k[0] <= 0.0:
            raise ValueError(f"stiffness k_1={k[0]!r} is outside its valid range (0, inf) N/m")
        if not math.isfinite(self.unloaded_deflection):
            raise ValueError(f"unloaded_deflection={self.unloaded_deflection!r} must be finite")

    @classmethod
    def linear(cls, stiffness: float, unloaded_deflection: float = 0.0) -> PolynomialForce:
        """``f = k (x - g)``."""
        return cls((stiffness,), unloaded_deflection)

    @classmethod
    def cubic(cls, stiffness: float, cubic_stiffness: float,
              unloaded_deflection: float = 0.0) -> PolynomialForce:
        """``f = k (x - g) + k_3 (x - g)^3`` (hardening for ``k_3 > 0``, softening < 0)."""
        return cls((stiffness, 0.0, cubic_stiffness), unloaded_deflection)

    def derivatives(self, x, phase, order, values=None):
        gap = np.asarray(x, dtype=float) - self.unloaded_deflection
        out = np.zeros((order + 1,) + gap.shape)
        for i in range(order + 1):
            for p, k in enumerate(self.stiffness, 1):
                if k != 0.0 and p >= i:
                    out[i] += k * _contact_power(gap, float(p), i)
        return out

    def unloaded(self, phase, n, values=None):
        return np.full((n, np.size(phase)), self.unloaded_deflection)

    def kernel_block(self, x_m, d, k_mean, shift, values, harmonics):
        from gearuq_plugins.mesh_oscillator import kernels

        # f = sum_p k_p d^p (1 + u)^p: binomial expansion in u, forces over k_mean d
        n = x_m.size
        n_ord = len(self.stiffness)
        alpha = np.zeros((n, n_ord + 1, 1))
        for p, k in enumerate(self.stiffness, 1):
            for j in range(p + 1):
                alpha[:, j, 0] += k * d ** p * math.comb(p, j) / (k_mean * d)
        block = np.zeros((n, 2 + 2 * (n_ord + 1)))
        block[:, 0] = n_ord
        block[:, 1] = 0
        block[:, 2:2 + n_ord + 1] = alpha[:, :, 0]
        return kernels.KIND_EXPANDED, block, 1

    def describe(self):
        return {"kind": self.kind, "stiffness": list(self.stiffness),
                "unloaded_deflection": self.unloaded_deflection}


# --------------------------------------------------------------------------- segments
@dataclass(frozen=True)
class ContactSegment:
    """One contact term ``k(phase) max(x - c(phase), 0)^p``.

    Parameters
    ----------
    stiffness : Periodic or float
        ``k`` [N/m^p], positive over the whole cycle.
    clearance : Periodic or float
        ``c`` [m], the deflection at which this part of the contact engages.
    exponent : float
        ``p >= 1`` (1 linear, 1.5 Hertzian point contact).
    """

    stiffness: Periodic | float
    clearance: Periodic | float = 0.0
    exponent: float = 1.0

    def __post_init__(self) -> None:
        object.__setattr__(self, "stiffness", as_periodic(self.stiffness))
        object.__setattr__(self, "clearance", as_periodic(self.clearance))
        if not (math.isfinite(self.exponent) and self.exponent >= 1.0):
            raise ValueError(f"exponent={self.exponent!r} is outside its valid range [1, inf)")
        grid = np.linspace(0.0, 1.0, 257)
        kmin = float(self.stiffness(grid).min())
        if kmin <= 0.0:
            raise ValueError(f"stiffness: must stay > 0 over the mesh cycle (min {kmin:g})")


@dataclass(frozen=True)
class SegmentForce(ForceDeflection):
    """``f = sum_j k_j(phase) max(x - c_j(phase), 0)^p_j``: contact that engages part by part.

    A single linear segment is a mesh spring with periodic stiffness and unloaded
    transmission error; several linear segments with different clearances model partial
    contact loss (the part of the contact lines behind a relief engages only after an extra
    deflection); ``p = 1.5`` is Hertzian point contact.
    """

    segments: tuple[ContactSegment, ...]
    kind: str = field(default="segments", init=False)

    def __post_init__(self) -> None:
        segs = tuple(self.segments)
        if not segs or not all(isinstance(s, ContactSegment) for s in segs):
            raise ValueError("segments: give one or more ContactSegment")
        object.__setattr__(self, "segments", segs)
        object.__setattr__(self, "smooth", len(segs) == 1)

    @classmethod
    def linear(cls, stiffness: Periodic | float,
               unloaded_deflection: Periodic | float = 0.0) -> SegmentForce:
        """``f = k(phase) (x - g(phase))`` in contact."""
        return cls((ContactSegment(stiffness, unloaded_deflection, 1.0),))

    @classmethod
    def hertz(cls, stiffness: Periodic | float,
              unloaded_deflection: Periodic | float = 0.0,
              exponent: float = 1.5) -> SegmentForce:
        """``f = K(phase) (x - g(phase))^{3/2}`` in contact."""
        return cls((ContactSegment(stiffness, unloaded_deflection, exponent),))

    def derivatives(self, x, phase, order, values=None):
        x = np.asarray(x, dtype=float)
        out = np.zeros((order + 1,) + x.shape)
        for seg in self.segments:
            k = seg.stiffness(phase)[None, :, None]
            c = seg.clearance(phase)[None, :, None]
            for i in range(order + 1):
                out[i] += k * _contact_power(x - c, seg.exponent, i)
        return out

    def unloaded(self, phase, n, values=None):
        g = np.min([seg.clearance(phase) for seg in self.segments], axis=0)
        return np.broadcast_to(g, (n, np.size(phase))).copy()

    def kernel_block(self, x_m, d, k_mean, shift, values, harmonics):
        from gearuq_plugins.mesh_oscillator import kernels

        nh = max(max(s.stiffness.n_harmonics, s.clearance.n_harmonics) for s in self.segments)
        nh = nh if harmonics is None else min(nh, harmonics)
        n = x_m.size
        width = 1 + 2 * (2 * nh + 1)
        block = np.zeros((n, 2 + len(self.segments) * width))
        block[:, 0] = len(self.segments)
        block[:, 1] = nh
        for j, seg in enumerate(self.segments):
            off = 2 + j * width
            kc = np.broadcast_to(seg.stiffness.coefficients(nh), (n, 2 * nh + 1))
            cc = np.broadcast_to(seg.clearance.coefficients(nh), (n, 2 * nh + 1)).copy()
            # k (x - c)^p = k d^p (u - (c - x_m)/d)^p, forces over k_mean d
            scale = d ** (seg.exponent - 1.0) / k_mean
            cc[:, 0] -= x_m
            block[:, off] = seg.exponent
            block[:, off + 1:off + 2 + 2 * nh] = shift_fourier(kc * scale[:, None], shift)
            block[:, off + 2 + 2 * nh:off + width] = shift_fourier(cc / d[:, None], shift)
        return kernels.KIND_SEGMENTS, block, len(self.segments)

    def describe(self):
        return {"kind": self.kind, "segments": [
            {"stiffness": [s.stiffness.mean, list(s.stiffness.cos), list(s.stiffness.sin)],
             "clearance": [s.clearance.mean, list(s.clearance.cos), list(s.clearance.sin)],
             "exponent": s.exponent} for s in self.segments]}


# --------------------------------------------------------------------------- tables
def _hermite_derivatives(x: np.ndarray, nodes_x: np.ndarray, nodes_p: np.ndarray,
                         slopes: np.ndarray, order: int) -> np.ndarray:
    """Piecewise force of a load-deflection table and its derivatives in ``x``.

    ``nodes_x`` (..., L) deflections at the loads ``nodes_p`` (L,) with node 0 the unloaded
    deflection (load 0); ``slopes`` (..., L) tangent stiffnesses at the nodes. Linear from
    node 0 to node 1 (the contact stiffness of line contact vanishes at zero load, which a
    cubic would overshoot), cubic Hermite between load nodes, tangent extrapolation above the
    last node, zero below node 0. ``x`` (..., m); returns ``(order + 1, ..., m)``.
    """
    n_nodes = nodes_x.shape[-1]
    xb = x
    out = np.zeros((order + 1,) + x.shape)
    # interval index: number of nodes <= x, minus 1, clipped to the pieces
    idx = (xb[..., None] >= nodes_x[..., None, :]).sum(axis=-1) - 1
    below = idx < 0
    idx = np.clip(idx, 0, n_nodes - 1)

    def take(a: np.ndarray, i: np.ndarray) -> np.ndarray:
        return np.take_along_axis(a, i, axis=-1)

    x0 = take(nodes_x, idx)
    p0 = nodes_p[idx]
    s0 = take(slopes, idx)
    nxt = np.minimum(idx + 1, n_nodes - 1)
    x1 = take(nodes_x, nxt)
    p1 = nodes_p[nxt]
    s1 = take(slopes, nxt)
    first = idx == 0
    last = idx == n_nodes - 1
    h = np.where(last, 1.0, x1 - x0)
    t = (xb - x0) / h
    # cubic Hermite basis and derivatives in t
    h00 = (1 + 2 * t) * (1 - t) ** 2
    h10 = t * (1 - t) ** 2
    h01 = t * t * (3 - 2 * t)
    h11 = t * t * (t - 1)
    cubic = [h00 * p0 + h10 * h * s0 + h01 * p1 + h11 * h * s1]
    d1 = ((6 * t * t - 6 * t) * p0 + (3 * t * t - 4 * t + 1) * h * s0
          + (6 * t - 6 * t * t) * p1 + (3 * t * t - 2 * t) * h * s1) / h
    d2 = ((12 * t - 6) * p0 + (6 * t - 4) * h * s0 + (6 - 12 * t) * p1
          + (6 * t - 2) * h * s1) / h**2
    d3 = (12 * p0 + 6 * h * s0 - 12 * p1 + 6 * h * s1) / h**3
    cubic += [d1, d2, d3]
    lin_slope = (p1 - p0) / np.where(first, h, 1.0)
    for i in range(order + 1):
        if i == 0:
            val = np.where(first, p0 + lin_slope * (xb - x0), cubic[0])
            val = np.where(last, p0 + s0 * (xb - x0), val)
        elif i == 1:
            val = np.where(first, lin_slope, cubic[1])
            val = np.where(last, s0, val)
        elif i <= 3:
            val = np.where(first | last, 0.0, cubic[i])
        else:
            val = np.zeros_like(xb)
        out[i] = np.where(below, 0.0, val)
    return out


@dataclass(frozen=True, eq=False)
class LoadDeflectionTable(ForceDeflection):
    """Mesh deflections at given loads over one mesh cycle (the LTCA form).

    Parameters
    ----------
    loads : array_like, shape (L,)
        Mesh forces [N], > 0, strictly increasing.
    phase : array_like, shape (N,)
        Mesh phases [cycles], uniform over one cycle starting at 0 (endpoint excluded).
    deflection : array_like, shape (L, N)
        Deflection (static transmission error along the line of action) [m] at each load.
    unloaded_deflection : array_like, shape (N,)
        Deflection at zero load ``g(phase)`` [m] (no-load kinematic transmission error).
    tangent_stiffness : array_like, shape (L, N), optional
        ``dP/dx`` at the nodes [N/m]; default: monotone slopes (Fritsch-Carlson) from the
        table itself.

    Notes
    -----
    Between the nodes the force is the cubic Hermite interpolant on the node values and
    tangent stiffnesses, linear from the unloaded deflection to the first load, and the
    tangent extrapolation above the last load (the same interpolation as
    ``gearuq.gears.ltca.force_at_deflection``).
    """

    loads: np.ndarray
    phase: np.ndarray
    deflection: np.ndarray
    unloaded_deflection: np.ndarray
    tangent_stiffness: np.ndarray | None = None
    source: str = "table"
    kind: str = field(default="table", init=False)

    def __post_init__(self) -> None:
        loads = np.asarray(self.loads, dtype=float)
        phase = np.asarray(self.phase, dtype=float)
        defl = np.asarray(self.deflection, dtype=float)
        g = np.asarray(self.unloaded_deflection, dtype=float)
        _check_table_shapes(loads, phase, defl, g)
        nodes = np.concatenate([g[None, :], defl], axis=0)
        steps = np.diff(nodes, axis=0)
        if np.any(steps <= 0.0):
            j, k = np.unravel_index(int(np.argmin(steps)), steps.shape)
            raise ValueError(
                f"deflection: not monotone in load at phase {phase[k]:g} (load index {j}: "
                f"{nodes[j, k]:.6g} m -> {nodes[j + 1, k]:.6g} m); valid: deflection strictly "
                "increasing with load (and above the unloaded deflection) at every phase")
        if self.tangent_stiffness is None:
            slopes = _monotone_slopes(nodes, np.concatenate([[0.0], loads]))[1:]
        else:
            slopes = np.asarray(self.tangent_stiffness, dtype=float)
            if slopes.shape != defl.shape or not np.all(np.isfinite(slopes)) or np.any(
                    slopes <= 0.0):
                raise ValueError(f"tangent_stiffness: shape {slopes.shape} and values must "
                                 f"match deflection {defl.shape}, finite and > 0 N/m")
        object.__setattr__(self, "loads", loads)
        object.__setattr__(self, "phase", phase)
        object.__setattr__(self, "deflection", defl)
        object.__setattr__(self, "unloaded_deflection", g)
        object.__setattr__(self, "tangent_stiffness", slopes)
        object.__setattr__(self, "smooth", False)

    # ---- constructors
    @classmethod
    def from_ltca(cls, pair: Any, loads: Sequence[float], *, positions_per_cycle: int = 32,
                  **ltca_options: Any) -> LoadDeflectionTable:
        """Run ``gearuq.gears.ltca.force_deflection`` over one mesh cycle.

        Parameters
        ----------
        pair : gearuq.gears.HelicalGearPair
            The gear pair.
        loads : sequence of float
            Normal mesh forces [N], > 0, increasing.
        positions_per_cycle : int
            Mesh positions of the cycle.
        **ltca_options
            Passed on (``deviations``, ``compliance``, ``n_pts``...). The deviations must be
            the same on every tooth (one mesh cycle is the period of the SDOF model).
        """
        from gearuq.gears.ltca import force_deflection

        fd = force_deflection(pair, np.asarray(loads, dtype=float), n_cycles=1,
                              positions_per_cycle=positions_per_cycle, **ltca_options)
        tangent = fd["lpms_tangent"].values * 1e6 if "lpms_tangent" in fd else None
        return cls(loads=fd["load"].values, phase=fd["tau"].values % 1.0,
                   deflection=fd["ste"].values * 1e-6,
                   unloaded_deflection=fd["ste_at_zero_load"].values * 1e-6,
                   tangent_stiffness=tangent, source="gearuq.gears.ltca.force_deflection")

    @classmethod
    def from_force_table(cls, deflection: Sequence[float], phase: Sequence[float],
                         force: np.ndarray, n_loads: int | None = None) -> LoadDeflectionTable:
        """Convert a user force table ``force[i, j] = f(deflection[i], phase[j])``.

        Parameters
        ----------
        deflection : array_like, shape (M,)
            Strictly increasing deflections [m]; the first must be out of contact (force 0)
            at every phase.
        phase : array_like, shape (N + 1,)
            Uniform phases [cycles] from 0 to 1 inclusive: the last column repeats the first,
            which is how periodicity is checked.
        force : array_like, shape (M, N + 1)
            Mesh force [N], >= 0, non-decreasing in deflection and strictly increasing where
            positive (monotone: one deflection per load).
        n_loads : int, optional
            Load levels of the converted table (default ``M - 1``), uniform from 0 to the
            largest force reached at every phase.
        """
        x = np.asarray(deflection, dtype=float)
        ph = np.asarray(phase, dtype=float)
        f = np.asarray(force, dtype=float)
        _check_force_table(x, ph, f)
        f = f[:, :-1]
        ph = ph[:-1]
        n_phase = ph.size
        g = np.empty(n_phase)
        for j in range(n_phase):
            zero = np.flatnonzero(f[:, j] <= 0.0)
            g[j] = x[zero[-1]]
        top = float(f[-1].min())
        n_loads = x.size - 1 if n_loads is None else int(n_loads)
        if n_loads < 2:
            raise ValueError(f"n_loads={n_loads!r} is outside its valid range: integers >= 2")
        levels = np.linspace(0.0, top, n_loads + 1)[1:]
        defl = np.empty((n_loads, n_phase))
        for j in range(n_phase):
            pos = f[:, j] > 0.0
            xs = np.concatenate([[g[j]], x[pos]])
            fs = np.concatenate([[0.0], f[pos, j]])
            defl[:, j] = np.interp(levels, fs, xs)
        return cls(loads=levels, phase=ph, deflection=defl, unloaded_deflection=g,
                   source="force table")

    # ---- evaluation
    def natural_phases(self):
        return self.phase

    def _nodes(self, phase: np.ndarray, n: int, values=None):
        """Node deflections and slopes ``(n, n_phase, L + 1)`` at ``phase`` (exact at the
        table phases, trigonometric interpolation elsewhere)."""
        nodes = np.concatenate([self.unloaded_deflection[None, :], self.deflection], axis=0)
        first_slope = self.loads[0] / (self.deflection[0] - self.unloaded_deflection)
        slopes = np.concatenate([first_slope[None, :], self.tangent_stiffness], axis=0)
        return _at_phase(nodes, slopes, self.phase, phase, n)

    def derivatives(self, x, phase, order, values=None):
        x = np.asarray(x, dtype=float)
        nx, sl = self._nodes(np.asarray(phase, dtype=float), x.shape[0], values)
        p = np.concatenate([[0.0], self.loads])
        return _hermite_derivatives(x, nx, p, sl, order)

    def unloaded(self, phase, n, values=None):
        nx, _ = self._nodes(np.asarray(phase, dtype=float), n, values)
        return nx[..., 0]

    def kernel_block(self, x_m, d, k_mean, shift, values, harmonics):
        nodes, slopes = self._node_arrays(x_m.size, values)
        return _table_block(nodes, slopes, np.concatenate([[0.0], self.loads]), x_m, d,
                            k_mean, shift, harmonics)

    def _node_arrays(self, n: int, values=None):
        nodes = np.concatenate([self.unloaded_deflection[None, :], self.deflection], axis=0)
        first_slope = self.loads[0] / (self.deflection[0] - self.unloaded_deflection)
        slopes = np.concatenate([first_slope[None, :], self.tangent_stiffness], axis=0)
        return (np.broadcast_to(nodes, (n,) + nodes.shape),
                np.broadcast_to(slopes, (n,) + slopes.shape))

    def describe(self):
        return {"kind": self.kind, "source": self.source, "loads_N": self.loads.tolist(),
                "n_phase": int(self.phase.size),
                "deflection_range_m": [float(self.unloaded_deflection.min()),
                                       float(self.deflection.max())]}


def _check_table_shapes(loads, phase, defl, g) -> None:
    if loads.ndim != 1 or loads.size < 2 or np.any(np.diff(loads) <= 0) or loads[0] <= 0:
        raise ValueError(f"loads={loads!r}: valid: strictly increasing, > 0 N, at least 2")
    n = phase.size
    if phase.ndim != 1 or n < 4:
        raise ValueError(f"phase: a 1-D grid of at least 4 points, got shape {phase.shape}")
    uniform = np.arange(n) / n
    if not np.allclose(phase, uniform, atol=1e-9):
        raise ValueError("phase: valid: the uniform grid k/N, k = 0..N-1, over one mesh cycle "
                         f"(got {phase[:3]}...{phase[-1:]})")
    if defl.shape != (loads.size, n) or g.shape != (n,):
        raise ValueError(f"deflection {defl.shape} / unloaded_deflection {g.shape}: valid "
                         f"shapes ({loads.size}, {n}) and ({n},)")
    for name, values in (("deflection", defl), ("unloaded_deflection", g)):
        if not np.all(np.isfinite(values)):
            where = tuple(int(k) for k in np.argwhere(~np.isfinite(values))[0])
            raise ValueError(f"{name}: non-finite value {float(values[where])!r} at index {where}; "
                             "valid: finite deflections [m]")


def _check_force_table(x, ph, f) -> None:
    if x.ndim != 1 or x.size < 3 or not np.all(np.isfinite(x)) or np.any(np.diff(x) <= 0):
        raise ValueError(f"deflection: valid: finite, strictly increasing, at least 3 values, "
                         f"got {x}")
    if ph.ndim != 1 or ph.size < 5 or not np.all(np.isfinite(ph)):
        raise ValueError(f"phase: valid: at least 5 finite values from 0 to 1, got {ph}")
    if abs(ph[0]) > 1e-12 or abs(ph[-1] - 1.0) > 1e-12 or not np.allclose(
            np.diff(ph), 1.0 / (ph.size - 1), atol=1e-9):
        raise ValueError("phase: valid: a uniform grid from 0 to 1 inclusive (one mesh cycle, "
                         f"last column = first), got {ph[0]:g} ... {ph[-1]:g}")
    if f.shape != (x.size, ph.size):
        raise ValueError(f"force: valid: shape {(x.size, ph.size)} (deflections, phases), "
                         f"got {f.shape}")
    if not np.all(np.isfinite(f)):
        i, j = np.argwhere(~np.isfinite(f))[0]
        n_bad = int(np.count_nonzero(~np.isfinite(f)))
        raise ValueError(f"force: {n_bad} non-finite value(s), the first {float(f[i, j])!r} at "
                         f"deflection {x[i]:.6g} m, phase {ph[j]:g}; valid: finite forces >= 0 N")
    scale = float(np.abs(f).max()) or 1.0
    gap = np.abs(f[:, 0] - f[:, -1]).max()
    if gap > 1e-6 * scale:
        raise ValueError(f"force: the table is not periodic: the columns at phase 0 and 1 "
                         f"differ by {gap:.4g} N (valid: <= 1e-6 of the largest force)")
    if np.any(f < 0.0):
        raise ValueError("force: negative values; valid: >= 0 (compression only)")
    df = np.diff(f, axis=0)
    bad = (df < 0.0) | ((df == 0.0) & (f[1:] > 0.0))
    if bad.any():
        i, j = np.unravel_index(int(np.argmax(bad)), bad.shape)
        raise ValueError(f"force: not monotone in deflection at phase {ph[j]:g} between "
                         f"deflections {x[i]:.6g} and {x[i + 1]:.6g} m ({f[i, j]:.6g} -> "
                         f"{f[i + 1, j]:.6g} N); valid: strictly increasing where in contact")
    if np.any(f[0] > 0.0):
        raise ValueError("force: the first deflection must be out of contact (force 0) at "
                         "every phase, so that the unloaded deflection lies in the table")


def _monotone_slopes(x: np.ndarray, p: np.ndarray) -> np.ndarray:
    """Fritsch-Carlson slopes ``dP/dx`` at the nodes ``x`` (L, N) of loads ``p`` (L,)."""
    dx = np.diff(x, axis=0)
    sec = np.diff(p)[:, None] / dx
    slopes = np.empty_like(x)
    slopes[0] = sec[0]
    slopes[-1] = sec[-1]
    # weighted harmonic mean of the neighbouring secants (scipy's PCHIP rule)
    w1 = 2 * dx[1:] + dx[:-1]
    w2 = dx[1:] + 2 * dx[:-1]
    slopes[1:-1] = (w1 + w2) / (w1 / sec[:-1] + w2 / sec[1:])
    return slopes


def _at_phase(nodes, slopes, table_phase, phase, n):
    """Node arrays ``(n, n_phase, L)`` at ``phase``; ``nodes``/``slopes`` (L, N) or
    (n, L, N)."""
    if nodes.ndim == 2:
        nodes = nodes[None]
        slopes = slopes[None]
    same = phase.shape == table_phase.shape and np.allclose(phase, table_phase, atol=1e-12)
    if same:
        nx = np.moveaxis(nodes, 1, 2)
        sl = np.moveaxis(slopes, 1, 2)
    else:
        cn = fourier_coefficients(nodes)
        cs = fourier_coefficients(slopes)
        nx = np.moveaxis(_evaluate_fourier(cn, TWO_PI * phase), 1, 2)
        sl = np.moveaxis(_evaluate_fourier(cs, TWO_PI * phase), 1, 2)
    return (np.broadcast_to(nx, (n,) + nx.shape[1:]).copy(),
            np.broadcast_to(sl, (n,) + sl.shape[1:]).copy())


def _evaluate_fourier(coef: np.ndarray, theta: np.ndarray) -> np.ndarray:
    """``coef[..., 1 + 2H]`` at angles ``theta`` (T,) -> (..., T)."""
    h = (coef.shape[-1] - 1) // 2
    out = np.repeat(coef[..., :1], theta.size, axis=-1)
    for r in range(1, h + 1):
        out = out + coef[..., 2 * r - 1:2 * r] * np.cos(r * theta) + coef[..., 2 * r:2 * r + 1] \
            * np.sin(r * theta)
    return out


def _table_block(nodes, slopes, loads, x_m, d, k_mean, shift, harmonics):
    """Nondimensional table-kernel block from node arrays (n, L + 1, N)."""
    from gearuq_plugins.mesh_oscillator import kernels

    n, n_nodes, n_phase = nodes.shape
    cn = fourier_coefficients((nodes - x_m[:, None, None]) / d[:, None, None])
    cs = fourier_coefficients(slopes / k_mean[:, None, None])
    nh = (cn.shape[-1] - 1) // 2
    if harmonics is not None:
        nh = min(nh, int(harmonics))
    cn = shift_fourier(cn[..., :1 + 2 * nh], shift[:, None])
    cs = shift_fourier(cs[..., :1 + 2 * nh], shift[:, None])
    width = 2 * (2 * nh + 1)
    block = np.zeros((n, 2 + n_nodes + n_nodes * width))
    block[:, 0] = n_nodes
    block[:, 1] = nh
    block[:, 2:2 + n_nodes] = loads[None, :] / (k_mean * d)[:, None]
    for node in range(n_nodes):
        off = 2 + n_nodes + node * width
        block[:, off:off + 2 * nh + 1] = cn[:, node]
        block[:, off + 2 * nh + 1:off + width] = cs[:, node]
    return kernels.KIND_TABLE, block, 1


# --------------------------------------------------------------------------- families
@dataclass(frozen=True, eq=False)
class TableFamily(ForceDeflection):
    """Load-deflection tables on one grid, interpolated linearly in a parameter.

    The deflections (and tangent stiffnesses) at each load and phase are interpolated
    between the members, so a random modification (relief amount, crowning) costs one LTCA
    run per member, not per sample.

    Parameters
    ----------
    members : sequence of LoadDeflectionTable
        Tables with the same loads and phases.
    values : sequence of float
        Parameter value of each member, strictly increasing.
    name, units, description : str
        The parameter it adds to the model (its nominal value is the middle member's).
    """

    members: tuple[LoadDeflectionTable, ...]
    values: tuple[float, ...]
    name: str = "modification"
    units: str = "m"
    description: str = "modification amount of the force-deflection family"
    kind: str = field(default="table_family", init=False)

    def __post_init__(self) -> None:
        members = tuple(self.members)
        values = tuple(float(v) for v in self.values)
        if len(members) < 2 or len(values) != len(members):
            raise ValueError("TableFamily: give at least two members and one value per member")
        if any(b <= a for a, b in zip(values, values[1:], strict=False)):
            raise ValueError(f"values={values!r}: valid: strictly increasing")
        ref = members[0]
        for m in members[1:]:
            if not (np.array_equal(m.loads, ref.loads) and np.array_equal(m.phase, ref.phase)):
                raise ValueError("TableFamily: members must share loads and phases")
        object.__setattr__(self, "members", members)
        object.__setattr__(self, "values", values)
        object.__setattr__(self, "smooth", False)
        nominal = values[len(values) // 2]
        object.__setattr__(self, "parameters", (
            Parameter(self.name, self.units, nominal, values[0], values[-1], self.description),))

    def _stack(self, n: int, values: Mapping[str, np.ndarray] | None):
        v = np.broadcast_to(np.asarray((values or {}).get(self.name, self.parameters[0].nominal),
                                       dtype=float), (n,))
        grid = np.asarray(self.values)
        i = np.clip(np.searchsorted(grid, v, side="right") - 1, 0, len(grid) - 2)
        w = ((v - grid[i]) / (grid[i + 1] - grid[i]))[:, None, None]
        arrays = [m._node_arrays(1) for m in self.members]
        nodes = np.stack([a[0][0] for a in arrays])
        slopes = np.stack([a[1][0] for a in arrays])
        return ((1 - w) * nodes[i] + w * nodes[i + 1], (1 - w) * slopes[i] + w * slopes[i + 1])

    def natural_phases(self):
        return self.members[0].phase

    def derivatives(self, x, phase, order, values=None):
        x = np.asarray(x, dtype=float)
        nodes, slopes = self._stack(x.shape[0], values)
        nx, sl = _at_phase(nodes, slopes, self.members[0].phase, np.asarray(phase, float),
                           x.shape[0])
        p = np.concatenate([[0.0], self.members[0].loads])
        return _hermite_derivatives(x, nx, p, sl, order)

    def unloaded(self, phase, n, values=None):
        nodes, slopes = self._stack(n, values)
        nx, _ = _at_phase(nodes, slopes, self.members[0].phase, np.asarray(phase, float), n)
        return nx[..., 0]

    def kernel_block(self, x_m, d, k_mean, shift, values, harmonics):
        nodes, slopes = self._stack(x_m.size, values)
        return _table_block(nodes, slopes, np.concatenate([[0.0], self.members[0].loads]),
                            x_m, d, k_mean, shift, harmonics)

    def member(self, values=None):
        v = float((values or {}).get(self.name, self.parameters[0].nominal))
        nodes, slopes = self._stack(1, {self.name: np.array([v])})
        ref = self.members[0]
        return LoadDeflectionTable(ref.loads, ref.phase, nodes[0, 1:], nodes[0, 0],
                                   slopes[0, 1:], source=f"{self.name}={v:g}")

    def describe(self):
        return {"kind": self.kind, "parameter": self.name, "units": self.units,
                "values": list(self.values), "members": [m.describe() for m in self.members]}
