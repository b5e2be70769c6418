"""Rigid disk element (gear body, coupling hub, impeller) at one node."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from gearuq.rotor.element import Element, Material, check_node, check_positive, steel

__all__ = ["DiskElement"]


@dataclass(frozen=True)
class DiskElement(Element):
    """Rigid disk: mass in x, y, z, diametral inertia about x and y, polar inertia about z.

    The gyroscopic matrix per unit spin couples the tilts:
    ``G[theta_x, theta_y] = Ip``, ``G[theta_y, theta_x] = -Ip`` (from d(H)/dt of the spin
    momentum ``Ip Omega`` tilted by ``(theta_x, theta_y)``).

    Parameters
    ----------
    node : int
        Global node.
    mass : float
        Mass [kg], > 0.
    diametral_inertia : float
        Moment of inertia about a diameter, Id [kg m^2], >= 0.
    polar_inertia : float
        Moment of inertia about the axis, Ip [kg m^2], >= 0.
    spin_ratio : float
        Speed of the disk's shaft over the rotor's reference speed.
    """

    node: int
    mass: float
    diametral_inertia: float
    polar_inertia: float
    spin_ratio: float = 1.0

    def __post_init__(self) -> None:
        check_node("node", self.node)
        check_positive("mass", self.mass, "kg")
        check_positive("diametral_inertia", self.diametral_inertia, "kg m2", allow_zero=True)
        check_positive("polar_inertia", self.polar_inertia, "kg m2", allow_zero=True)

    @classmethod
    def from_geometry(
        cls,
        node: int,
        width: float,
        inner_diameter: float,
        outer_diameter: float,
        material: Material = steel,
        *,
        spin_ratio: float = 1.0,
    ) -> DiskElement:
        """Disk of a homogeneous annular cylinder.

        ``m = rho pi/4 (D^2 - d^2) w``, ``Ip = m (D^2 + d^2) / 8``,
        ``Id = Ip / 2 + m w^2 / 12``.

        Parameters
        ----------
        node : int
            Global node.
        width : float
            Axial width [m], > 0.
        inner_diameter : float
            Bore [m], in [0, outer_diameter).
        outer_diameter : float
            Outer diameter [m], > 0.
        material : Material
            Material (density used).
        spin_ratio : float
            Speed ratio of the disk's shaft.
        """
        w = check_positive("width", width, "m")
        D = check_positive("outer_diameter", outer_diameter, "m")
        d = check_positive("inner_diameter", inner_diameter, "m", allow_zero=True)
        if d >= D:
            raise ValueError(f"inner_diameter={inner_diameter!r} is outside its valid range "
                             f"[0, outer_diameter={outer_diameter!r}) m")
        m = material.rho * math.pi / 4.0 * (D**2 - d**2) * w
        ip = m * (D**2 + d**2) / 8.0
        return cls(node=node, mass=m, diametral_inertia=0.5 * ip + m * w**2 / 12.0,
                   polar_inertia=ip, spin_ratio=spin_ratio)

    def nodes(self) -> tuple[int]:
        """The disk's node."""
        return (self.node,)

    def M(self) -> np.ndarray:
        """6x6 diagonal mass matrix."""
        m, i_d, i_p = self.mass, self.diametral_inertia, self.polar_inertia
        return np.diag([m, m, m, i_d, i_d, i_p])

    def K(self) -> np.ndarray:
        """Zero (a rigid disk adds no stiffness)."""
        return np.zeros((6, 6))

    def G(self) -> np.ndarray:
        """6x6 gyroscopic matrix per unit spin."""
        g = np.zeros((6, 6))
        g[3, 4] = self.polar_inertia
        g[4, 3] = -self.polar_inertia
        return g
