"""12-DOF helical gear mesh element along the normal line of action (Yuan et al. (2020), Eqs. 6-10).

The mesh couples the pinion node ``p`` and the gear node ``g`` through one scalar, the
approach of the flanks along the normal line of action (the mesh deflection)::

    delta = v . u,   u = (x_p, y_p, z_p, theta_xp, theta_yp, theta_zp, x_g, ..., theta_zg)
    v = [n, r_p x n, -n, -(r_g x n)]

``n`` is the unit normal of the flanks (the direction of the normal line of action):
``n = cos(beta_b) t - h sin(beta_b) e_z`` with ``t`` the transverse line of action and ``h``
the helix sign (``h = +1`` gives the signs printed in Yuan et al. Eq. 8); ``r_p`` and ``r_g`` go
from the two nodes to the same contact point (the pitch point on the mid-face plane). The mesh
force ``F = k_m (delta - e_m)`` acts as ``-v F`` on the generalised coordinates.

Re-derivation (docs/theory/geared_rotor.md): Yuan et al. Eq. 8 takes the moment arms to the
base-circle tangency points ``T1`` and ``T2``; these are two different points, so a rigid
rotation of the whole gearbox about the axis normal to the plane of action would change
``delta`` by ``T1T2 sin(beta_b)`` per radian. With one contact point for both gears every
rigid motion gives ``delta = 0`` exactly; the tilt arms gain the term
``-s sin(beta_b) e_r`` (``s`` = distance from ``T1`` to the pitch point), the moment of the
axial force component about the radial direction. ``moment_arm="base_circle"`` keeps the
seed's form for comparison.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from gearuq.rotor.element import Element, check_node, check_positive

__all__ = ["HelicalMeshElement"]


def _rotate(v: np.ndarray, angle: float) -> np.ndarray:
    c, s = math.cos(angle), math.sin(angle)
    return np.array([c * v[0] - s * v[1], s * v[0] + c * v[1], 0.0])


@dataclass(frozen=True)
class HelicalMeshElement(Element):
    """Helical (or spur) mesh between two parallel shafts as a spring along the normal LOA.

    Parameters
    ----------
    pinion_node, gear_node : int
        Global nodes of the driving and the driven gear bodies (on their shaft axes, at the
        mid-face plane).
    base_radius_pinion, base_radius_gear : float
        Base-circle radii r_b1, r_b2 [m], > 0.
    pressure_angle : float
        Working transverse pressure angle alpha_wt [rad], in [0, pi/2).
    base_helix_angle : float
        beta_b [rad], in [0, pi/2) (0: spur).
    centre_line_angle : float
        Direction psi of the line of centres from pinion to gear, measured from +x towards +y
        [rad] (seed: the phase angle, ``phi = alpha - psi``).
    helix_sign : {1, -1}
        Sign of the axial component of ``n`` (+1: as printed in Yuan et al. Eq. 8).
    drive_sign : {1, -1}
        +1 when a positive pinion rotation about +z drives the gear (loads the flank).
    stiffness : float
        Mean mesh stiffness k_m [N/m] used by :meth:`K` (the linearised mesh).
    damping : float
        Viscous mesh damping c_m [N s/m] used by :meth:`C`.
    moment_arm : {"pitch_point", "base_circle"}
        Contact point of the rotational terms (see the module docstring).
    contact_offset : float
        Axial position of the contact point relative to the nodes [m].
    """

    pinion_node: int
    gear_node: int
    base_radius_pinion: float
    base_radius_gear: float
    pressure_angle: float
    base_helix_angle: float
    centre_line_angle: float = 0.0
    helix_sign: int = 1
    drive_sign: int = 1
    stiffness: float = 0.0
    damping: float = 0.0
    moment_arm: str = "pitch_point"
    contact_offset: float = 0.0

    def __post_init__(self) -> None:
        check_node("pinion_node", self.pinion_node)
        check_node("gear_node", self.gear_node)
        if self.pinion_node == self.gear_node:
            raise ValueError(f"pinion_node and gear_node are both {self.pinion_node}; a mesh "
                             "joins two different nodes")
        check_positive("base_radius_pinion", self.base_radius_pinion, "m")
        check_positive("base_radius_gear", self.base_radius_gear, "m")
        if not 0.0 <= self.pressure_angle < math.pi / 2:
            raise ValueError(f"pressure_angle={self.pressure_angle!r} is outside its valid "
                             "range [0, pi/2) rad")
        if not 0.0 <= self.base_helix_angle < math.pi / 2:
            raise ValueError(f"base_helix_angle={self.base_helix_angle!r} is outside its valid "
                             "range [0, pi/2) rad")
        for name in ("helix_sign", "drive_sign"):
            if getattr(self, name) not in (1, -1):
                raise ValueError(f"{name}={getattr(self, name)!r} is outside its valid set "
                                 "{1, -1}")
        check_positive("stiffness", self.stiffness, "N/m", allow_zero=True)
        check_positive("damping", self.damping, "N s/m", allow_zero=True)
        if self.moment_arm not in ("pitch_point", "base_circle"):
            raise ValueError(f"moment_arm={self.moment_arm!r} is outside its valid set "
                             "{'pitch_point', 'base_circle'}")

    @classmethod
    def from_pair(cls, pair: object, pinion_node: int, gear_node: int, **kw: object
                  ) -> HelicalMeshElement:
        """Build from a :class:`gearuq.gears.HelicalGearPair` (base radii, angles)."""
        return cls(pinion_node=pinion_node, gear_node=gear_node,
                   base_radius_pinion=0.5 * pair.db1, base_radius_gear=0.5 * pair.db2,
                   pressure_angle=pair.alpha_wt, base_helix_angle=pair.beta_b, **kw)

    def nodes(self) -> tuple[int, int]:
        """``(pinion_node, gear_node)``."""
        return (self.pinion_node, self.gear_node)

    # geometry -----------------------------------------------------------------------
    def frame(self) -> dict[str, np.ndarray]:
        """Unit vectors of the mesh: line of centres ``e_c``, transverse LOA ``t``, the
        radial direction ``e_r`` to the pinion's base tangency point, and the normal ``n``."""
        a, sd = self.pressure_angle, self.drive_sign
        e_c = np.array([math.cos(self.centre_line_angle), math.sin(self.centre_line_angle), 0.0])
        t = _rotate(e_c, sd * (0.5 * math.pi - a))
        e_r = _rotate(e_c, -sd * a)
        bb = self.base_helix_angle
        n = math.cos(bb) * t - self.helix_sign * math.sin(bb) * np.array([0.0, 0.0, 1.0])
        return {"e_c": e_c, "t": t, "e_r": e_r, "n": n}

    def contact_arms(self) -> tuple[np.ndarray, np.ndarray]:
        """Vectors from the pinion node and from the gear node to the contact point [m]."""
        f = self.frame()
        rb1, rb2, a = self.base_radius_pinion, self.base_radius_gear, self.pressure_angle
        dz = np.array([0.0, 0.0, self.contact_offset])
        if self.moment_arm == "pitch_point":
            rw1, rw2 = rb1 / math.cos(a), rb2 / math.cos(a)
            return rw1 * f["e_c"] + dz, -rw2 * f["e_c"] + dz
        return rb1 * f["e_r"] + dz, -rb2 * f["e_r"] + dz

    def direction_vector(self) -> np.ndarray:
        """The 12-vector ``v`` with ``delta = v . u`` (local DOF order)."""
        n = self.frame()["n"]
        r_p, r_g = self.contact_arms()
        return np.concatenate([n, np.cross(r_p, n), -n, -np.cross(r_g, n)])

    def transmission_error_vector(self) -> np.ndarray:
        """12-vector of the torsional transmission error along the normal LOA.

        ``TE = drive_sign cos(beta_b) (r_b1 theta_zp + r_b2 theta_zg)``: the part of ``v``
        that comes from the rotations about the shaft axes, i.e. what angle encoders on the
        two gear bodies measure, expressed as a normal approach [m].
        """
        v = self.direction_vector()
        te = np.zeros(12)
        te[5], te[11] = v[5], v[11]
        return te

    # matrices -----------------------------------------------------------------------
    def M(self) -> np.ndarray:
        """Zero (the gear bodies are disks on the two nodes)."""
        return np.zeros((12, 12))

    def K(self) -> np.ndarray:
        """``k_m v v^T`` with the mean stiffness."""
        v = self.direction_vector()
        return self.stiffness * np.outer(v, v)

    def C(self) -> np.ndarray:
        """``c_m v v^T``."""
        v = self.direction_vector()
        return self.damping * np.outer(v, v)
