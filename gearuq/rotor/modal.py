"""Modal analysis of an assembled rotor: real modes, complex (gyroscopic) modes, Campbell data.

* :func:`undamped_modes` solves ``K phi = w^2 M phi`` (symmetric, non-rotating), the basis of
  the modal reduction.
* :func:`complex_modes` solves the first-order problem of
  ``M q'' + (C + Omega G) q' + K q = 0`` at one speed: eigenvalues ``lambda = -zeta w + i w_d``
  with whirl direction and the kind of motion (lateral / axial / torsional) of every mode.
* :func:`campbell` repeats it over speeds and returns an :class:`xarray.Dataset`.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla
import xarray as xr

from gearuq.rotor.assembly import Rotor
from gearuq.rotor.element import DOFS_PER_NODE

__all__ = ["ComplexModes", "RealModes", "campbell", "complex_modes", "undamped_modes"]


@dataclass(frozen=True)
class RealModes:
    """Undamped non-rotating modes.

    Attributes
    ----------
    omega : ndarray, (n_modes,)
        Natural frequencies [rad/s], increasing (rigid-body modes have 0).
    shapes : ndarray, (n_dof, n_modes)
        Mass-normalised mode shapes (``shapes.T M shapes = I``).
    rigid : ndarray of bool
        Which modes are rigid-body modes.
    """

    omega: np.ndarray
    shapes: np.ndarray
    rigid: np.ndarray

    @property
    def elastic(self) -> RealModes:
        """Only the elastic (non-rigid) modes."""
        keep = ~self.rigid
        return RealModes(self.omega[keep], self.shapes[:, keep], self.rigid[keep])


def undamped_modes(rotor: Rotor, *, stiffness: np.ndarray | None = None,
                   rigid_tol: float = 1e-9) -> RealModes:
    """Solve ``K phi = w^2 M phi`` for all modes of the rotor.

    Parameters
    ----------
    rotor : Rotor
        The assembled rotor.
    stiffness : ndarray, optional
        Stiffness matrix to use instead of ``rotor.K()``.
    rigid_tol : float
        Eigenvalues ``w^2`` below ``rigid_tol`` times the largest are rigid-body modes.
    """
    K = rotor.K() if stiffness is None else stiffness
    w2, vec = sla.eigh(K, rotor.M())
    rigid = np.abs(w2) < rigid_tol * max(abs(w2[-1]), 1.0)
    omega = np.sqrt(np.where(rigid, 0.0, np.clip(w2, 0.0, None)))
    return RealModes(omega, vec, rigid)


def _motion_kind(rotor: Rotor, shapes: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Kinetic-energy share of lateral, axial and torsional DOFs and the whirl measure.

    Returns ``kind`` (0 lateral, 1 axial, 2 torsional) and ``whirl`` in [-1, 1]: +1 circular
    forward (the orbit turns with the shaft's own spin), -1 backward, 0 planar.
    """
    M = rotor.M()
    n_dof = rotor.n_dof
    node = np.arange(n_dof) // DOFS_PER_NODE
    local = np.arange(n_dof) % DOFS_PER_NODE
    groups = [np.isin(local, (0, 1, 3, 4)), local == 2, local == 5]
    energy = np.empty((3, shapes.shape[1]))
    for g, mask in enumerate(groups):
        Mg = M[np.ix_(mask, mask)]
        sg = shapes[mask]
        energy[g] = np.real(np.einsum("im,ij,jm->m", sg.conj(), Mg, sg))
    kind = np.argmax(energy, axis=0)
    spin = np.ones(rotor.n_nodes)
    for s in rotor.shafts:
        spin[s.first_node:s.last_node + 1] = np.sign(s.spin_ratio) or 1.0
    X = shapes[local == 0]
    Y = shapes[local == 1]
    sense = -2.0 * np.imag(np.conj(X) * Y) * spin[node[local == 0]][:, None]
    amp = np.abs(X) ** 2 + np.abs(Y) ** 2
    whirl = sense.sum(axis=0) / np.maximum(amp.sum(axis=0), 1e-300)
    return kind, whirl


_KIND_NAMES = ("lateral", "axial", "torsional")


@dataclass(frozen=True)
class ComplexModes:
    """Modes of the damped, rotating rotor at one speed.

    Attributes
    ----------
    eigenvalues : ndarray, complex (n_modes,)
        ``lambda = -zeta w + i w_d`` with ``w_d > 0``, sorted by ``w_d``.
    frequency : ndarray
        Damped natural frequencies ``w_d`` [rad/s].
    damping_ratio : ndarray
        ``-Re(lambda) / |lambda|``.
    shapes : ndarray, complex (n_dof, n_modes)
        Displacement part of the eigenvectors.
    whirl : ndarray
        Whirl measure in [-1, 1] (+1 forward circular, -1 backward circular).
    kind : list of str
        "lateral", "axial" or "torsional" (largest kinetic-energy share).
    speed : float
        Reference speed [rad/s].
    """

    eigenvalues: np.ndarray
    frequency: np.ndarray
    damping_ratio: np.ndarray
    shapes: np.ndarray
    whirl: np.ndarray
    kind: list[str]
    speed: float

    def whirl_label(self, tol: float = 0.1) -> list[str]:
        """"forward", "backward", or the motion kind for planar / non-lateral modes."""
        out = []
        for w, k in zip(self.whirl, self.kind, strict=True):
            if k != "lateral" or abs(w) < tol:
                out.append(k if k != "lateral" else "planar")
            else:
                out.append("forward" if w > 0 else "backward")
        return out


def complex_modes(rotor: Rotor, speed: float = 0.0, *, n_modes: int | None = None,
                  stiffness: np.ndarray | None = None, damping: np.ndarray | None = None,
                  zero_tol: float = 1e-6) -> ComplexModes:
    """Eigen-solution of ``M q'' + (C + speed G) q' + K q = 0``.

    Parameters
    ----------
    rotor : Rotor
        The assembled rotor.
    speed : float
        Reference (driving-shaft) speed [rad/s].
    n_modes : int, optional
        Keep the lowest ``n_modes`` (default all).
    stiffness, damping : ndarray, optional
        Replace ``rotor.K()`` / ``rotor.C()``.
    zero_tol : float
        Eigenvalues with ``|lambda|`` below ``zero_tol`` times the largest natural frequency
        (rigid-body modes) and non-oscillating (overdamped) roots are dropped.
    """
    M = rotor.M()
    K = rotor.K() if stiffness is None else stiffness
    C = (rotor.C() if damping is None else damping) + float(speed) * rotor.G()
    n = M.shape[0]
    # generalized first-order form  [[C, M], [M, 0]] z' = -[[K, 0], [0, -M]] z  (z = [q, q'])
    A = np.zeros((2 * n, 2 * n))
    B = np.zeros((2 * n, 2 * n))
    A[:n, :n], A[n:, n:] = -K, M
    B[:n, :n], B[:n, n:], B[n:, :n] = C, M, M
    lam, vec = sla.eig(A, B)
    finite = np.isfinite(lam)
    lam, vec = lam[finite], vec[:, finite]
    scale = np.sqrt(np.abs(np.diag(K) / np.maximum(np.diag(M), 1e-300))).max()
    keep = (lam.imag > zero_tol * scale) & (np.abs(lam) > zero_tol * scale)
    lam, vec = lam[keep], vec[:n, keep]
    order = np.argsort(lam.imag)
    lam, vec = lam[order], vec[:, order]
    if n_modes is not None:
        lam, vec = lam[:n_modes], vec[:, :n_modes]
    # normalise each shape to unit largest component (phase removed)
    big = vec[np.argmax(np.abs(vec), axis=0), np.arange(vec.shape[1])]
    vec = vec / big
    kind, whirl = _motion_kind(rotor, vec)
    return ComplexModes(
        eigenvalues=lam, frequency=lam.imag, damping_ratio=-lam.real / np.abs(lam),
        shapes=vec, whirl=whirl, kind=[_KIND_NAMES[k] for k in kind], speed=float(speed))


def campbell(rotor: Rotor, speeds: Sequence[float], *, n_modes: int = 12,
             excitation_orders: Sequence[float] = (1.0,), **kw: object) -> xr.Dataset:
    """Damped natural frequencies over speed (Campbell diagram data).

    Parameters
    ----------
    rotor : Rotor
        The assembled rotor.
    speeds : sequence of float
        Reference speeds [rad/s].
    n_modes : int
        Modes kept at each speed (the lowest by frequency).
    excitation_orders : sequence of float
        Orders of the reference speed drawn as excitation lines (1 = shaft frequency, ``z1``
        = mesh frequency); stored as ``excitation`` over ``(speed, order)``.
    **kw
        Passed to :func:`complex_modes`.

    Returns
    -------
    xarray.Dataset
        ``frequency`` [rad/s] and ``damping_ratio``, ``whirl``, ``kind`` over
        ``(speed, mode)``; ``excitation`` [rad/s] over ``(speed, order)``. Modes are sorted by
        frequency at every speed (no mode tracking across crossings).
    """
    speeds = np.asarray(speeds, dtype=float)
    freq = np.full((speeds.size, n_modes), np.nan)
    zeta = np.full_like(freq, np.nan)
    whirl = np.full_like(freq, np.nan)
    kind = np.full(freq.shape, "", dtype=object)
    for i, s in enumerate(speeds):
        cm = complex_modes(rotor, s, n_modes=n_modes, **kw)
        m = cm.frequency.size
        freq[i, :m], zeta[i, :m], whirl[i, :m] = cm.frequency, cm.damping_ratio, cm.whirl
        kind[i, :m] = cm.whirl_label()
    orders = np.asarray(excitation_orders, dtype=float)
    return xr.Dataset(
        {
            "frequency": (("speed", "mode"), freq, {"units": "rad s-1",
                                                    "long_name": "damped natural frequency"}),
            "damping_ratio": (("speed", "mode"), zeta, {"units": "1"}),
            "whirl": (("speed", "mode"), whirl, {"units": "1", "long_name":
                      "whirl measure (+1 forward circular, -1 backward circular)"}),
            "kind": (("speed", "mode"), kind.astype(str), {"long_name":
                     "forward / backward / planar / axial / torsional"}),
            "excitation": (("speed", "order"), speeds[:, None] * orders[None, :],
                           {"units": "rad s-1", "long_name": "excitation lines"}),
        },
        coords={"speed": ("speed", speeds, {"units": "rad s-1"}),
                "mode": ("mode", np.arange(n_modes)),
                "order": ("order", orders, {"units": "1"})},
        attrs={"rotor": rotor.name},
    )
