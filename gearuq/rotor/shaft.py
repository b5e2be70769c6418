"""Timoshenko shaft element (2 nodes x 6 DOF) and shaft lines built from sections.

Bending uses the interdependent-interpolation Timoshenko element (Friedman & Kosmatka 1993;
the element of Przemieniecki, Nelson 1980 and Friswell et al. 2010, Sec. 5.4): cubic
displacement and quadratic rotation fields that solve the static Timoshenko equations exactly,
so the stiffness is exact for nodal loads. With ``xi = s / L`` and
``Phi = 12 E I / (kappa G A L^2)`` (Phi = 0 without shear)::

    N_w   = [1+Phi - Phi xi - 3 xi^2 + 2 xi^3,
             L (xi (1+Phi/2) - xi^2 (2+Phi/2) + xi^3),
             Phi xi + 3 xi^2 - 2 xi^3,
             L (-xi Phi/2 - xi^2 (1-Phi/2) + xi^3)] / (1+Phi)
    N_phi = [6 (xi^2 - xi) / L, 1+Phi - (4+Phi) xi + 3 xi^2,
             -6 (xi^2 - xi) / L, -(2-Phi) xi + 3 xi^2] / (1+Phi)

acting on ``(w1, phi1, w2, phi2)`` with ``phi`` the cross-section rotation. The matrices are
integrated exactly (5-point Gauss, polynomial degree <= 6)::

    K = int EI phi'^T phi' + kappa G A (w' - phi)^T (w' - phi) + EA u'^T u' + GJ t'^T t'
    M = int rho A (w^T w + u^T u) + rho I phi^T phi + rho J t^T t       (consistent mass)
    G = int rho J (theta_x^T theta_y - theta_y^T theta_x)              (per unit spin)

Axial (``u``) and torsional (``t``) fields are linear. Shear coefficient of Cowper (1966) for
a hollow circle, ``kappa = 6 (1+nu)(1+m^2)^2 / ((7+6nu)(1+m^2)^2 + (20+12nu) m^2)``,
``m = d_i / d_o``. Derivation and checks: docs/theory/geared_rotor.md.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from gearuq.rotor.element import Element, Material, check_node, check_positive, steel

__all__ = ["ShaftLine", "TimoshenkoShaftElement", "cowper_shear_coefficient"]

_GAUSS_X, _GAUSS_W = np.polynomial.legendre.leggauss(5)


def cowper_shear_coefficient(nu: float, diameter_ratio: float = 0.0) -> float:
    """Cowper's (1966) shear coefficient of a hollow circular section.

    Parameters
    ----------
    nu : float
        Poisson's ratio.
    diameter_ratio : float
        Inner over outer diameter, in [0, 1).
    """
    m2 = diameter_ratio**2
    a = (1.0 + m2) ** 2
    return 6.0 * (1.0 + nu) * a / ((7.0 + 6.0 * nu) * a + (20.0 + 12.0 * nu) * m2)


def _bending_shapes(xi: float, length: float, phi: float) -> tuple[np.ndarray, ...]:
    """Shape functions of w, phi and their s-derivatives at ``xi`` (planar DOFs w1 p1 w2 p2)."""
    L, P = length, phi
    d = 1.0 + P
    w = np.array([
        1.0 + P - P * xi - 3.0 * xi**2 + 2.0 * xi**3,
        L * (xi * (1.0 + P / 2) - xi**2 * (2.0 + P / 2) + xi**3),
        P * xi + 3.0 * xi**2 - 2.0 * xi**3,
        L * (-xi * P / 2 - xi**2 * (1.0 - P / 2) + xi**3),
    ]) / d
    dw = np.array([
        -P - 6.0 * xi + 6.0 * xi**2,
        L * ((1.0 + P / 2) - 2.0 * xi * (2.0 + P / 2) + 3.0 * xi**2),
        P + 6.0 * xi - 6.0 * xi**2,
        L * (-P / 2 - 2.0 * xi * (1.0 - P / 2) + 3.0 * xi**2),
    ]) / (d * L)
    r = np.array([
        6.0 * (xi**2 - xi) / L,
        1.0 + P - (4.0 + P) * xi + 3.0 * xi**2,
        -6.0 * (xi**2 - xi) / L,
        -(2.0 - P) * xi + 3.0 * xi**2,
    ]) / d
    dr = np.array([
        6.0 * (2.0 * xi - 1.0) / L,
        -(4.0 + P) + 6.0 * xi,
        -6.0 * (2.0 * xi - 1.0) / L,
        -(2.0 - P) + 6.0 * xi,
    ]) / (d * L)
    return w, dw, r, dr


# local DOF indices (x y z tx ty tz per node, two nodes)
_XZ = np.array([0, 4, 6, 10])      # x, theta_y (slope dx/dz = theta_y)
_YZ = np.array([1, 3, 7, 9])       # y, theta_x (slope dy/dz = -theta_x)
_YZ_SIGN = np.array([1.0, -1.0, 1.0, -1.0])


def _field_rows(xi: float, length: float, phi: float) -> dict[str, np.ndarray]:
    """12-vectors interpolating every field (and derivative) of the element at ``xi``."""
    w, dw, r, dr = _bending_shapes(xi, length, phi)
    rows = {k: np.zeros(12) for k in ("x", "dx", "y", "dy", "tx", "dtx", "ty", "dty",
                                      "z", "dz", "tz", "dtz")}
    rows["x"][_XZ], rows["dx"][_XZ] = w, dw
    rows["ty"][_XZ], rows["dty"][_XZ] = r, dr
    # y-z plane: planar DOFs (y, -theta_x); the section rotation there is -theta_x
    rows["y"][_YZ], rows["dy"][_YZ] = w * _YZ_SIGN, dw * _YZ_SIGN
    rows["tx"][_YZ], rows["dtx"][_YZ] = -r * _YZ_SIGN, -dr * _YZ_SIGN
    lin, dlin = np.array([1.0 - xi, xi]), np.array([-1.0, 1.0]) / length
    rows["z"][[2, 8]], rows["dz"][[2, 8]] = lin, dlin
    rows["tz"][[5, 11]], rows["dtz"][[5, 11]] = lin, dlin
    return rows


@dataclass(frozen=True)
class TimoshenkoShaftElement(Element):
    """Two-node, 12-DOF Timoshenko shaft element (bending, shear, axial, torsion, gyroscopic).

    Parameters
    ----------
    node : int
        Global number of the left node; the right node is ``node + 1``.
    length : float
        Element length [m], > 0.
    outer_diameter : float
        Outer diameter [m], > 0.
    inner_diameter : float
        Bore [m], in [0, outer_diameter).
    material : Material
        Material (default :data:`gearuq.rotor.element.steel`).
    shear : bool
        Include shear deformation (Timoshenko); ``False`` gives Euler-Bernoulli bending.
    rotary_inertia : bool
        Include the rotary inertia of the cross-sections.
    gyroscopic : bool
        Include the gyroscopic matrix.
    spin_ratio : float
        Speed of this shaft over the rotor's reference speed.
    """

    node: int
    length: float
    outer_diameter: float
    inner_diameter: float = 0.0
    material: Material = steel
    shear: bool = True
    rotary_inertia: bool = True
    gyroscopic: bool = True
    spin_ratio: float = 1.0

    def __post_init__(self) -> None:
        check_node("node", self.node)
        check_positive("length", self.length, "m")
        check_positive("outer_diameter", self.outer_diameter, "m")
        check_positive("inner_diameter", self.inner_diameter, "m", allow_zero=True)
        if self.inner_diameter >= self.outer_diameter:
            raise ValueError(
                f"inner_diameter={self.inner_diameter!r} is outside its valid range "
                f"[0, outer_diameter={self.outer_diameter!r}) m"
            )

    def nodes(self) -> tuple[int, int]:
        """The two nodes ``(node, node + 1)``."""
        return (self.node, self.node + 1)

    # section properties -------------------------------------------------------------
    @property
    def area(self) -> float:
        """Cross-section area [m^2]."""
        return math.pi / 4.0 * (self.outer_diameter**2 - self.inner_diameter**2)

    @property
    def second_moment(self) -> float:
        """Diametral second moment of area I [m^4]."""
        return math.pi / 64.0 * (self.outer_diameter**4 - self.inner_diameter**4)

    @property
    def polar_moment(self) -> float:
        """Polar second moment of area J = 2 I [m^4]."""
        return 2.0 * self.second_moment

    @property
    def shear_coefficient(self) -> float:
        """Cowper's shear coefficient kappa."""
        return cowper_shear_coefficient(self.material.poisson_ratio,
                                        self.inner_diameter / self.outer_diameter)

    @property
    def shear_parameter(self) -> float:
        """``Phi = 12 E I / (kappa G A L^2)`` (0 without shear)."""
        if not self.shear:
            return 0.0
        m = self.material
        return 12.0 * m.E * self.second_moment / (
            self.shear_coefficient * m.G * self.area * self.length**2)

    @property
    def mass(self) -> float:
        """Element mass [kg]."""
        return self.material.rho * self.area * self.length

    # matrices -----------------------------------------------------------------------
    @cached_property
    def _matrices(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        m, L = self.material, self.length
        A, I, J = self.area, self.second_moment, self.polar_moment
        kGA = self.shear_coefficient * m.G * A if self.shear else 0.0
        phi = self.shear_parameter
        K = np.zeros((12, 12))
        M = np.zeros((12, 12))
        G = np.zeros((12, 12))
        rho_i = m.rho * I if self.rotary_inertia else 0.0
        for x, wt in zip(_GAUSS_X, _GAUSS_W, strict=True):
            xi = 0.5 * (x + 1.0)
            f = _field_rows(xi, L, phi)
            dl = 0.5 * wt * L
            K += dl * m.E * I * (np.outer(f["dtx"], f["dtx"]) + np.outer(f["dty"], f["dty"]))
            if self.shear:
                gx = f["dx"] - f["ty"]
                gy = f["dy"] + f["tx"]
                K += dl * kGA * (np.outer(gx, gx) + np.outer(gy, gy))
            K += dl * (m.E * A * np.outer(f["dz"], f["dz"])
                       + m.G * J * np.outer(f["dtz"], f["dtz"]))
            M += dl * m.rho * A * (np.outer(f["x"], f["x"]) + np.outer(f["y"], f["y"])
                                   + np.outer(f["z"], f["z"]))
            M += dl * (rho_i * (np.outer(f["tx"], f["tx"]) + np.outer(f["ty"], f["ty"]))
                       + m.rho * J * np.outer(f["tz"], f["tz"]))
            if self.gyroscopic:
                G += dl * m.rho * J * (np.outer(f["tx"], f["ty"]) - np.outer(f["ty"], f["tx"]))
        # without shear the Phi = 0 shape functions satisfy phi = w' exactly (Euler-Bernoulli)
        return K, M, G

    def K(self) -> np.ndarray:
        """12x12 stiffness matrix."""
        return self._matrices[0].copy()

    def M(self) -> np.ndarray:
        """12x12 consistent mass matrix (translational, rotary, axial, torsional)."""
        return self._matrices[1].copy()

    def G(self) -> np.ndarray:
        """12x12 gyroscopic matrix per unit spin speed (skew-symmetric)."""
        return self._matrices[2].copy()


def _as_list(name: str, values: float | Sequence[float], n: int) -> list[float]:
    if np.ndim(values) == 0:
        return [float(values)] * n
    out = [float(v) for v in values]
    if len(out) != n:
        raise ValueError(f"{name} has {len(out)} values, expected {n} (one per section)")
    return out


@dataclass(frozen=True)
class ShaftLine:
    """A straight shaft: node positions along z and one cross-section per element.

    Parameters
    ----------
    node_z : sequence of float
        Axial positions of the nodes [m], strictly increasing (at least two).
    outer_diameters : sequence of float
        Outer diameter of each element [m] (``len(node_z) - 1`` values).
    inner_diameters : sequence of float or None
        Bore of each element [m] (default solid).
    material : Material
        Material of every element.
    first_node : int
        Global number of the first node (shafts are numbered one after the other).
    axis : (float, float)
        Position ``(x, y)`` of the shaft axis in the global frame [m].
    spin_ratio : float
        Speed of this shaft over the rotor's reference speed.
    name : str
        Label.
    """

    node_z: tuple[float, ...]
    outer_diameters: tuple[float, ...]
    inner_diameters: tuple[float, ...] | None = None
    material: Material = steel
    first_node: int = 0
    axis: tuple[float, float] = (0.0, 0.0)
    spin_ratio: float = 1.0
    name: str = "shaft"

    def __post_init__(self) -> None:
        z = np.asarray(self.node_z, dtype=float)
        if z.ndim != 1 or z.size < 2 or not np.all(np.isfinite(z)):
            raise ValueError(f"node_z={self.node_z!r} must hold at least two finite positions")
        dz = np.diff(z)
        if np.any(dz <= 0):
            i = int(np.flatnonzero(dz <= 0)[0])
            raise ValueError(
                f"element length {dz[i]!r} m (element {i} of shaft {self.name!r}) is outside "
                "its valid range (0, inf) m: node_z must increase strictly"
            )
        check_node("first_node", self.first_node)
        n_el = z.size - 1
        od = _as_list("outer_diameters", self.outer_diameters, n_el)
        idd = _as_list("inner_diameters", self.inner_diameters or 0.0, n_el)
        for i, (o, b) in enumerate(zip(od, idd, strict=True)):
            check_positive(f"outer_diameters[{i}]", o, "m")
            check_positive(f"inner_diameters[{i}]", b, "m", allow_zero=True)
            if b >= o:
                raise ValueError(f"inner_diameters[{i}]={b!r} is outside its valid range "
                                 f"[0, outer diameter {o!r}) m")
        object.__setattr__(self, "node_z", tuple(float(v) for v in z))
        object.__setattr__(self, "outer_diameters", tuple(od))
        object.__setattr__(self, "inner_diameters", tuple(idd))

    @classmethod
    def from_sections(
        cls,
        lengths: Sequence[float],
        outer_diameters: Sequence[float],
        elements_per_section: Sequence[int] | int = 1,
        *,
        inner_diameters: Sequence[float] | None = None,
        z0: float = 0.0,
        **kw: object,
    ) -> ShaftLine:
        """Build a shaft from cylindrical sections, each split into equal elements.

        Parameters
        ----------
        lengths, outer_diameters : sequence of float
            Length and outer diameter of each section [m], > 0.
        elements_per_section : int or sequence of int
            Number of equal elements per section (>= 1).
        inner_diameters : sequence of float or None
            Bore of each section [m].
        z0 : float
            Axial position of the first node [m].
        **kw
            Passed to the constructor (material, first_node, axis, spin_ratio, name).
        """
        n_sec = len(lengths)
        ls = _as_list("lengths", lengths, n_sec)
        od = _as_list("outer_diameters", outer_diameters, n_sec)
        idd = _as_list("inner_diameters", inner_diameters or 0.0, n_sec)
        nel = [int(v) for v in _as_list("elements_per_section", elements_per_section, n_sec)]
        for i, (length, n) in enumerate(zip(ls, nel, strict=True)):
            check_positive(f"lengths[{i}]", length, "m")
            if n < 1:
                raise ValueError(f"elements_per_section[{i}]={n} is outside its valid range: "
                                 "integers >= 1")
        z = [float(z0)]
        el_od: list[float] = []
        el_id: list[float] = []
        start = float(z0)
        for length, o, b, n in zip(ls, od, idd, nel, strict=True):
            # nodes from the section start, not by accumulation (no round-off drift)
            z.extend(start + length * k / n for k in range(1, n + 1))
            el_od.extend([o] * n)
            el_id.extend([b] * n)
            start += length
        return cls(node_z=tuple(z), outer_diameters=tuple(el_od),
                   inner_diameters=tuple(el_id), **kw)

    @property
    def n_nodes(self) -> int:
        """Number of nodes."""
        return len(self.node_z)

    @property
    def last_node(self) -> int:
        """Global number of the last node."""
        return self.first_node + self.n_nodes - 1

    @property
    def length(self) -> float:
        """Total length [m]."""
        return self.node_z[-1] - self.node_z[0]

    def node_at(self, z: float, *, tol: float = 1e-9) -> int:
        """Global number of the node at axial position ``z`` [m].

        Raises
        ------
        ValueError
            If no node lies within ``tol`` of ``z`` (a bearing or gear outside the shaft or
            between nodes).
        """
        zz = np.asarray(self.node_z)
        i = int(np.argmin(np.abs(zz - z)))
        if abs(zz[i] - z) > tol:
            raise ValueError(
                f"z={z!r} m is not a node of shaft {self.name!r}: valid positions are its "
                f"nodes in [{zz[0]:g}, {zz[-1]:g}] m ({', '.join(f'{v:g}' for v in zz)})"
            )
        return self.first_node + i

    def positions(self) -> np.ndarray:
        """Global coordinates ``(n_nodes, 3)`` of the nodes [m]."""
        z = np.asarray(self.node_z)
        return np.column_stack([np.full_like(z, self.axis[0]), np.full_like(z, self.axis[1]), z])

    def elements(self, **kw: object) -> list[TimoshenkoShaftElement]:
        """The shaft elements (options such as ``shear=False`` passed on)."""
        z = self.node_z
        return [
            TimoshenkoShaftElement(
                node=self.first_node + i, length=z[i + 1] - z[i],
                outer_diameter=self.outer_diameters[i],
                inner_diameter=self.inner_diameters[i], material=self.material,
                spin_ratio=self.spin_ratio, **kw)
            for i in range(len(z) - 1)
        ]
