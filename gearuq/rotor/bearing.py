"""Bearing element: constant stiffness and damping between a shaft node and the ground.

Yuan et al. (2020) (Sec. 2.2.1) argues for constant bearing stiffness (the variation with the
number of
loaded rolling elements is neglected); its values are not printed. The values used by the
built-in rotor and their sources are in docs/theory/geared_rotor.md.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from gearuq.rotor.element import Element, check_node, check_positive

__all__ = ["BearingElement"]


@dataclass(frozen=True)
class BearingElement(Element):
    """Linear bearing at one node, acting on x, y, z (and optionally on the tilts).

    Parameters
    ----------
    node : int
        Global node.
    kxx, kyy, kzz : float
        Direct stiffnesses [N/m], >= 0.
    cxx, cyy, czz : float
        Direct damping coefficients [N s/m], >= 0.
    kxy, kyx, cxy, cyx : float
        Cross-coupled coefficients [N/m], [N s/m] (fluid-film bearings; 0 for rolling
        bearings).
    k_tilt : float
        Tilting stiffness about x and y [N m/rad], >= 0 (0: the bearing is a pivot, as usual
        for a single-row rolling bearing).
    label : str
        Name used in results ("bearing 1").
    """

    node: int
    kxx: float
    kyy: float
    kzz: float = 0.0
    cxx: float = 0.0
    cyy: float = 0.0
    czz: float = 0.0
    kxy: float = 0.0
    kyx: float = 0.0
    cxy: float = 0.0
    cyx: float = 0.0
    k_tilt: float = 0.0
    label: str = "bearing"

    def __post_init__(self) -> None:
        check_node("node", self.node)
        for name in ("kxx", "kyy", "kzz", "cxx", "cyy", "czz", "k_tilt"):
            check_positive(name, getattr(self, name), "N/m, N s/m or N m/rad", allow_zero=True)

    def nodes(self) -> tuple[int]:
        """The bearing's node."""
        return (self.node,)

    def M(self) -> np.ndarray:
        """Zero (massless bearing)."""
        return np.zeros((6, 6))

    def K(self) -> np.ndarray:
        """6x6 stiffness matrix."""
        k = np.zeros((6, 6))
        k[0, 0], k[0, 1], k[1, 0], k[1, 1] = self.kxx, self.kxy, self.kyx, self.kyy
        k[2, 2] = self.kzz
        k[3, 3] = k[4, 4] = self.k_tilt
        return k

    def C(self) -> np.ndarray:
        """6x6 damping matrix."""
        c = np.zeros((6, 6))
        c[0, 0], c[0, 1], c[1, 0], c[1, 1] = self.cxx, self.cxy, self.cyx, self.cyy
        c[2, 2] = self.czz
        return c

    def force(self, displacement: np.ndarray, velocity: np.ndarray | None = None) -> np.ndarray:
        """Force of the bearing on the ground ``K u + C u'`` [N] (x, y, z components).

        Parameters
        ----------
        displacement, velocity : ndarray, (..., 6)
            Node displacements and velocities (velocity optional).
        """
        f = displacement @ self.K()[:3].T
        if velocity is not None:
            f = f + velocity @ self.C()[:3].T
        return f
