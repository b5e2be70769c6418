"""Lines of contact of an involute helical gear pair in the plane of action.

Coordinates (SI, metres) in the plane of action (POA) of the driving flanks:

- ``s``: transverse coordinate along the line of action measured from ``T1``, the point
  where the line of action touches the pinion base circle; the path of contact runs from
  ``s_A = g_f1`` (start of action, wheel tip) to ``s_E = s_A + g_alpha`` (pinion tip).
  ``s`` is also the pinion's radius of curvature in the transverse plane; the wheel's is
  ``T1T2 - s`` with ``T1T2 = a sin(alpha_wt)``.
- ``y``: axial coordinate across the face, ``0 <= y <= b``.

A line of contact is the straight line ``s + y tan(beta_b) = c`` (inclined at ``beta_b`` to the
axial direction in the POA). Tooth pair ``k`` (pinion tooth ``k mod z1`` against wheel tooth
``k mod z2``, both numbered in the order they enter the mesh) has
``c_k(tau) = s_A + (tau - k) pbt`` at the mesh position ``tau`` (in mesh cycles; the pinion
has turned ``tau`` base pitches, ``phi1 = tau pbt / r_b1``). It is in contact while
``0 <= tau - k < eps_gamma``.

Each line is cut to the contact zone ``[s_A, s_E] x [0, b]`` and discretised into ``n``
equal segments represented by their midpoints (midpoint rule: the total discretised length
is exact). Details in ``docs/theory/ltca.md``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from gearuq.gears.geometry import HelicalGearPair

__all__ = ["ContactGrid", "MeshKinematics", "contact_grid", "long_period_cycles"]


def long_period_cycles(pair: HelicalGearPair) -> int:
    """Return the number of mesh cycles after which the tooth pairing repeats.

    ``lcm(z1, z2)``: 30 for the 30/30 pair of Yuan, Liu and Liu (2020).
    """
    return math.lcm(int(pair.z1), int(pair.z2))


@dataclass(frozen=True)
class MeshKinematics:
    """Scalar geometry of the plane of action used by the LTCA (SI units).

    Attributes
    ----------
    s_A, s_E : float
        Start and end of the path of contact from ``T1`` [m].
    T1T2 : float
        Length of the line of action between the base-circle tangency points [m].
    b : float
        Effective face width [m].
    tan_bb, cos_bb : float
        ``tan(beta_b)`` and ``cos(beta_b)``.
    pbt : float
        Transverse base pitch [m].
    eps_gamma : float
        Total contact ratio.
    """

    s_A: float
    s_E: float
    T1T2: float
    b: float
    tan_bb: float
    cos_bb: float
    pbt: float
    eps_gamma: float

    @classmethod
    def of(cls, pair: HelicalGearPair) -> MeshKinematics:
        """Build from a :class:`HelicalGearPair`."""
        s_a = pair.g_f1
        return cls(
            s_A=s_a,
            s_E=s_a + pair.g_alpha,
            T1T2=pair.centre_distance * math.sin(pair.alpha_wt),
            b=pair.face_width,
            tan_bb=math.tan(pair.beta_b),
            cos_bb=math.cos(pair.beta_b),
            pbt=pair.pbt,
            eps_gamma=pair.g_alpha / pair.pbt + pair.face_width * math.tan(pair.beta_b) / pair.pbt,
        )


@dataclass(frozen=True)
class ContactGrid:
    """Discretised lines of contact at a set of mesh positions.

    Arrays have shape ``(n_pos, n_lines, n_pts)``; lines not in contact have ``valid=False``
    and zero length. ``n_lines = ceil(eps_gamma) + 1`` slots are kept per position.

    Attributes
    ----------
    tau : ndarray, (n_pos,)
        Mesh positions in mesh cycles.
    pair_index : ndarray of int, (n_pos, n_lines)
        Tooth-pair counter ``k``; pinion tooth ``k mod z1``, wheel tooth ``k mod z2``.
    s, y : ndarray, (n_pos, n_lines, n_pts)
        POA coordinates of the segment midpoints [m].
    dL : ndarray, (n_pos, n_lines)
        Length of each segment along the line of contact [m] (``dy / cos(beta_b)``).
    dy : ndarray, (n_pos, n_lines)
        Axial width of each segment [m].
    y_lo, y_hi : ndarray, (n_pos, n_lines)
        Axial extent of each line in the contact zone [m].
    valid : ndarray of bool, (n_pos, n_lines)
        Whether the line is in the contact zone.
    kin : MeshKinematics
        The POA geometry.
    """

    tau: np.ndarray
    pair_index: np.ndarray
    s: np.ndarray
    y: np.ndarray
    dL: np.ndarray
    dy: np.ndarray
    y_lo: np.ndarray
    y_hi: np.ndarray
    valid: np.ndarray
    kin: MeshKinematics

    @property
    def length(self) -> np.ndarray:
        """Total length of the lines of contact at each position [m], ``(n_pos,)``."""
        return (self.dL * self.s.shape[2]).sum(axis=1)

    def roll_angles(self, pair: HelicalGearPair) -> tuple[np.ndarray, np.ndarray]:
        """Return the transverse roll angles ``(s / r_b1, (T1T2 - s) / r_b2)`` [rad]."""
        return self.s / (0.5 * pair.db1), (self.kin.T1T2 - self.s) / (0.5 * pair.db2)


def contact_grid(
    pair: HelicalGearPair, tau: np.ndarray | float, n_pts: int = 20
) -> ContactGrid:
    """Discretise the lines of contact of every tooth pair at the mesh positions ``tau``.

    Parameters
    ----------
    pair : HelicalGearPair
        The gear pair.
    tau : array_like
        Mesh positions in mesh cycles (any real numbers; ``tau = 0`` is the instant tooth
        pair 0 enters contact at ``(s_A, y=0)``).
    n_pts : int, optional
        Points per line of contact (>= 1).

    Returns
    -------
    ContactGrid
    """
    if int(n_pts) != n_pts or n_pts < 1:
        raise ValueError(f"n_pts={n_pts!r} is outside its valid range: integers >= 1")
    n_pts = int(n_pts)
    kin = MeshKinematics.of(pair)
    tau = np.atleast_1d(np.asarray(tau, dtype=float))
    n_lines = int(math.ceil(kin.eps_gamma)) + 1
    # pair k is in contact for tau - k in [0, eps_gamma): the newest pair is floor(tau)
    k_new = np.floor(tau).astype(np.int64)
    k = k_new[:, None] - np.arange(n_lines)[None, :]
    c = kin.s_A + (tau[:, None] - k) * kin.pbt
    b, t = kin.b, kin.tan_bb
    if t > 0.0:
        y_lo = np.clip((c - kin.s_E) / t, 0.0, b)
        y_hi = np.clip((c - kin.s_A) / t, 0.0, b)
    else:  # spur: the line spans the face while c is on the path of contact
        inside = (c >= kin.s_A) & (c <= kin.s_E)
        y_lo = np.zeros_like(c)
        y_hi = np.where(inside, b, 0.0)
    valid = (y_hi - y_lo) > 1e-9 * b
    y_lo = np.where(valid, y_lo, 0.0)
    y_hi = np.where(valid, y_hi, 0.0)
    dy = (y_hi - y_lo) / n_pts
    frac = (np.arange(n_pts) + 0.5) / n_pts
    y = y_lo[..., None] + (y_hi - y_lo)[..., None] * frac
    s = c[..., None] - y * t
    s = np.where(valid[..., None], s, kin.s_A)
    return ContactGrid(
        tau=tau,
        pair_index=k,
        s=s,
        y=y,
        dL=dy / kin.cos_bb,
        dy=dy,
        y_lo=y_lo,
        y_hi=y_hi,
        valid=valid,
        kin=kin,
    )
