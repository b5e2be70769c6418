"""The rotor ``Element`` interface, node DOF conventions and materials.

Every node carries six degrees of freedom in the global frame, in this order::

    x, y, z, theta_x, theta_y, theta_z

``z`` is the axial direction of every shaft (all shafts are parallel), ``x``/``y`` the lateral
directions; ``theta_*`` are small rotations about the global axes (right-hand rule). A shaft
element bends in the x-z plane with slope ``dx/dz = theta_y`` and in the y-z plane with slope
``dy/dz = -theta_x``. Units are SI throughout (m, rad, kg, N, s).

An element answers ``M()``, ``K()``, ``C()``, ``G()`` (local matrices over its own DOFs) and
``dof_mapping()`` (the global DOF index of every local DOF). The gyroscopic matrix ``G`` is
per unit spin speed of the element's shaft: the assembly multiplies it by the reference speed
and the shaft's speed ratio, so that the equations read
``M q'' + (C + Omega G) q' + K q = f``.
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from dataclasses import dataclass

import numpy as np

__all__ = [
    "DOF_NAMES",
    "DOFS_PER_NODE",
    "Element",
    "Material",
    "check_positive",
    "node_dofs",
    "steel",
]

DOFS_PER_NODE = 6
DOF_NAMES = ("x", "y", "z", "theta_x", "theta_y", "theta_z")


def node_dofs(node: int) -> np.ndarray:
    """Return the six global DOF indices of ``node``."""
    return DOFS_PER_NODE * int(node) + np.arange(DOFS_PER_NODE)


def check_positive(name: str, value: float, units: str, *, allow_zero: bool = False) -> float:
    """Return ``value`` as float or raise a ValueError naming it and its valid range."""
    v = float(value)
    ok = math.isfinite(v) and (v >= 0.0 if allow_zero else v > 0.0)
    if not ok:
        bound = "[0, inf)" if allow_zero else "(0, inf)"
        raise ValueError(f"{name}={value!r} is outside its valid range {bound} {units}")
    return v


def check_node(name: str, node: int) -> int:
    """Return ``node`` as int or raise a ValueError (nodes are integers >= 0)."""
    if int(node) != node or node < 0:
        raise ValueError(f"{name}={node!r} is outside its valid range: integers >= 0")
    return int(node)


@dataclass(frozen=True)
class Material:
    """Isotropic linear-elastic material.

    Parameters
    ----------
    name : str
        Label.
    E : float
        Young's modulus [Pa].
    G : float
        Shear modulus [Pa].
    rho : float
        Density [kg m-3].
    """

    name: str
    E: float
    G: float
    rho: float

    def __post_init__(self) -> None:
        check_positive("E", self.E, "Pa")
        check_positive("G", self.G, "Pa")
        check_positive("rho", self.rho, "kg m-3")
        nu = self.poisson_ratio
        if not -1.0 < nu < 0.5:
            raise ValueError(
                f"E={self.E!r}, G={self.G!r} give Poisson's ratio {nu:.4g}, outside (-1, 0.5)"
            )

    @property
    def poisson_ratio(self) -> float:
        """Poisson's ratio ``E / (2 G) - 1``."""
        return self.E / (2.0 * self.G) - 1.0


#: Steel of Friswell et al., Dynamics of Rotating Machines (2010), Sec. 5.9 examples.
steel = Material("steel", E=211e9, G=81.2e9, rho=7810.0)


class Element(ABC):
    """A finite element of a rotor: local matrices and where they go in the global system.

    Subclasses implement :meth:`M`, :meth:`K` and :meth:`nodes`; :meth:`C` and :meth:`G`
    default to zero. ``spin_ratio`` is the speed of the element's shaft relative to the
    reference speed of the rotor (1 for the driving shaft, ``-z1/z2`` for the driven shaft of
    an external pair); the assembly scales ``G`` by it.
    """

    spin_ratio: float = 1.0

    @abstractmethod
    def nodes(self) -> tuple[int, ...]:
        """Global node numbers of the element, in local order."""

    @abstractmethod
    def M(self) -> np.ndarray:
        """Mass matrix over the local DOFs [kg, kg m^2]."""

    @abstractmethod
    def K(self) -> np.ndarray:
        """Stiffness matrix over the local DOFs [N/m, N m/rad]."""

    def C(self) -> np.ndarray:
        """Viscous damping matrix over the local DOFs [N s/m] (default none)."""
        n = DOFS_PER_NODE * len(self.nodes())
        return np.zeros((n, n))

    def G(self) -> np.ndarray:
        """Gyroscopic matrix per unit spin speed [kg m^2] (default none)."""
        n = DOFS_PER_NODE * len(self.nodes())
        return np.zeros((n, n))

    def dof_mapping(self) -> np.ndarray:
        """Global DOF index of every local DOF (node-major, :data:`DOF_NAMES` order)."""
        return np.concatenate([node_dofs(n) for n in self.nodes()])
