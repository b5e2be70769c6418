"""Assembly of rotor elements into global matrices, static solution, rigid-body modes.

A :class:`Rotor` is a list of elements over numbered nodes (6 DOF each, see
:mod:`gearuq.rotor.element`). The global equations are::

    M q'' + (C + Omega G) q' + K q = f

with ``G = sum_e spin_ratio_e G_e`` so that ``Omega`` is the reference speed (the driving
shaft's) in rad/s. A geared rotor has a rigid-body mode (the drivetrain turning freely);
:meth:`Rotor.static` solves in the complement of the rigid-body modes, which requires the
applied loads to be balanced (no work on a rigid-body mode).

Building a different rotor takes a few lines::

    from gearuq.rotor import ShaftLine, DiskElement, BearingElement, Rotor
    shaft = ShaftLine.from_sections([0.5, 0.5, 0.5], [0.05] * 3, 2)
    rotor = Rotor(shaft.elements()
                  + [DiskElement.from_geometry(shaft.node_at(0.5), 0.07, 0.05, 0.28),
                     BearingElement(shaft.node_at(0.0), 1e6, 1e6),
                     BearingElement(shaft.node_at(1.5), 1e6, 1e6)],
                  shafts=[shaft])
"""

from __future__ import annotations

from collections.abc import Sequence
from functools import cached_property

import numpy as np
import scipy.linalg as sla

from gearuq.rotor.bearing import BearingElement
from gearuq.rotor.disk import DiskElement
from gearuq.rotor.element import DOF_NAMES, DOFS_PER_NODE, Element
from gearuq.rotor.mesh import HelicalMeshElement
from gearuq.rotor.shaft import ShaftLine, TimoshenkoShaftElement

__all__ = ["Rotor"]


class Rotor:
    """Assembled rotor: global M, K, C, G over all nodes.

    Parameters
    ----------
    elements : sequence of Element
        Shaft, disk, bearing and mesh elements (any :class:`Element`).
    shafts : sequence of ShaftLine, optional
        The shaft lines the elements came from (node positions, labels, spin ratios).
    n_nodes : int, optional
        Number of nodes (default: one more than the largest node used).
    name : str
        Label.
    tags : dict, optional
        Names of important nodes (``{"pinion": 7, "bearing 1": 2, ...}``).
    """

    def __init__(
        self,
        elements: Sequence[Element],
        *,
        shafts: Sequence[ShaftLine] = (),
        n_nodes: int | None = None,
        name: str = "rotor",
        tags: dict[str, int] | None = None,
    ) -> None:
        self.elements = list(elements)
        if not self.elements:
            raise ValueError("elements: a rotor needs at least one element")
        self.shafts = list(shafts)
        used = max(max(e.nodes()) for e in self.elements) + 1
        self.n_nodes = used if n_nodes is None else int(n_nodes)
        if self.n_nodes < used:
            raise ValueError(f"n_nodes={n_nodes} is smaller than the nodes used ({used})")
        self.name = name
        self.tags = dict(tags or {})
        for tag, node in self.tags.items():
            if not 0 <= node < self.n_nodes:
                raise ValueError(f"tag {tag!r}: node {node} is outside 0..{self.n_nodes - 1}")
        self._check_nodes_on_shafts()

    def _check_nodes_on_shafts(self) -> None:
        """Every disk, bearing and mesh node must belong to a shaft (when shafts are given)."""
        if not self.shafts:
            return
        owned = set()
        for s in self.shafts:
            owned.update(range(s.first_node, s.last_node + 1))
        for e in self.elements:
            if isinstance(e, TimoshenkoShaftElement):
                continue
            for n in e.nodes():
                if n not in owned:
                    raise ValueError(
                        f"{type(e).__name__} at node {n} is outside the shafts: valid nodes "
                        + ", ".join(f"{s.name} {s.first_node}..{s.last_node}"
                                    for s in self.shafts))

    # ------------------------------------------------------------------ bookkeeping
    @property
    def n_dof(self) -> int:
        """Number of DOFs (6 per node)."""
        return DOFS_PER_NODE * self.n_nodes

    def dof(self, node: int, name: str) -> int:
        """Global index of DOF ``name`` (x, y, z, theta_x, theta_y, theta_z) of ``node``."""
        if name not in DOF_NAMES:
            raise ValueError(f"dof name {name!r} is outside its valid set {DOF_NAMES}")
        if not 0 <= node < self.n_nodes:
            raise ValueError(f"node={node} is outside its valid range 0..{self.n_nodes - 1}")
        return DOFS_PER_NODE * node + DOF_NAMES.index(name)

    def dof_labels(self) -> list[str]:
        """Labels ``"n<node>_<dof>"`` of all DOFs."""
        return [f"n{n}_{d}" for n in range(self.n_nodes) for d in DOF_NAMES]

    def node_positions(self) -> np.ndarray:
        """Global node coordinates ``(n_nodes, 3)`` [m] (NaN for nodes on no shaft)."""
        pos = np.full((self.n_nodes, 3), np.nan)
        for s in self.shafts:
            pos[s.first_node:s.last_node + 1] = s.positions()
        return pos

    def elements_of(self, kind: type) -> list:
        """The elements of one type, in order."""
        return [e for e in self.elements if isinstance(e, kind)]

    @property
    def bearings(self) -> list[BearingElement]:
        """Bearing elements."""
        return self.elements_of(BearingElement)

    @property
    def disks(self) -> list[DiskElement]:
        """Disk elements."""
        return self.elements_of(DiskElement)

    @property
    def meshes(self) -> list[HelicalMeshElement]:
        """Mesh elements."""
        return self.elements_of(HelicalMeshElement)

    # ------------------------------------------------------------------ assembly
    def _assemble(self, which: str) -> np.ndarray:
        out = np.zeros((self.n_dof, self.n_dof))
        for e in self.elements:
            local = getattr(e, which)()
            if which == "G":
                local = e.spin_ratio * local
            idx = e.dof_mapping()
            out[np.ix_(idx, idx)] += local
        return out

    @cached_property
    def _matrices(self) -> dict[str, np.ndarray]:
        return {k: self._assemble(k) for k in ("M", "K", "C", "G")}

    def M(self) -> np.ndarray:
        """Global mass matrix."""
        return self._matrices["M"].copy()

    def K(self) -> np.ndarray:
        """Global stiffness matrix (meshes at their mean stiffness)."""
        return self._matrices["K"].copy()

    def C(self) -> np.ndarray:
        """Global viscous damping matrix of the elements (bearings, mesh dampers)."""
        return self._matrices["C"].copy()

    def G(self) -> np.ndarray:
        """Global gyroscopic matrix per unit reference speed."""
        return self._matrices["G"].copy()

    def global_vector(self, element: Element, local: np.ndarray) -> np.ndarray:
        """Scatter a local vector of ``element`` into a global one."""
        out = np.zeros(self.n_dof)
        out[element.dof_mapping()] += local
        return out

    def mesh_vector(self, index: int = 0) -> np.ndarray:
        """Global direction vector ``v`` of mesh ``index`` (``delta = v . q``)."""
        mesh = self.meshes[index]
        return self.global_vector(mesh, mesh.direction_vector())

    def transmission_error_vector(self, index: int = 0) -> np.ndarray:
        """Global vector of the torsional transmission error of mesh ``index``."""
        mesh = self.meshes[index]
        return self.global_vector(mesh, mesh.transmission_error_vector())

    # ------------------------------------------------------------------ statics
    @cached_property
    def rigid_body_modes(self) -> np.ndarray:
        """Mass-normalised rigid-body modes ``(n_dof, n_rigid)`` (zero strain energy).

        A zero-energy motion moves every shaft rigidly, so the modes are sought among the
        rigid motions of the shafts (6 per shaft): the null space of the small matrix
        ``R^T K R`` holds only bearing and mesh energies and is found reliably even when the
        shafts are orders of magnitude stiffer than the bearings (an eigenvalue threshold on
        the full ``(K, M)`` problem is not: its round-off scales with the stiffest element).
        Without shaft lines the full problem is used (eigenvalues below 1e-9 of the largest).
        A geared drivetrain free to turn has one: the kinematic rotation.
        """
        K, M = self._matrices["K"], self._matrices["M"]
        if not self.shafts:
            w2, vec = sla.eigh(K, M)
            scale = max(abs(w2[-1]), 1.0)
            return vec[:, np.abs(w2) < 1e-9 * scale]
        R = self._shaft_rigid_motions()
        Mr = R.T @ M @ R
        Kr = R.T @ K @ R
        w2, vec = sla.eigh(0.5 * (Kr + Kr.T), 0.5 * (Mr + Mr.T))
        scale = max(abs(w2[-1]), 1.0)
        return R @ vec[:, np.abs(w2) < 1e-9 * scale]

    def _shaft_rigid_motions(self) -> np.ndarray:
        """Rigid translations and rotations of each shaft line (columns)."""
        cols = []
        pos = self.node_positions()
        for s in self.shafts:
            nodes = range(s.first_node, s.last_node + 1)
            for k in range(6):
                c = np.zeros(self.n_dof)
                for n in nodes:
                    d = DOFS_PER_NODE * n
                    if k < 3:
                        c[d + k] = 1.0
                    else:
                        axis = np.zeros(3)
                        axis[k - 3] = 1.0
                        c[d:d + 3] = np.cross(axis, pos[n] - np.array([*s.axis, 0.0]))
                        c[d + k] = 1.0
                cols.append(c)
        return np.column_stack(cols)

    def static(self, force: np.ndarray, *, stiffness: np.ndarray | None = None,
               balance_tol: float = 1e-8) -> np.ndarray:
        """Static displacement ``K q = f`` orthogonal (in M) to the rigid-body modes.

        Parameters
        ----------
        force : ndarray, (n_dof,) or (n_dof, k)
            Load vector(s) [N, N m].
        stiffness : ndarray, optional
            Stiffness matrix to use (default :meth:`K`); its rigid-body modes must be those
            of :meth:`K`.
        balance_tol : float
            Relative tolerance of the check that the loads do no work on a rigid-body mode.

        Raises
        ------
        ValueError
            If the loads are not balanced (a free drivetrain would accelerate).
        """
        K = self._matrices["K"] if stiffness is None else stiffness
        R = self.rigid_body_modes
        f = np.asarray(force, dtype=float)
        if R.shape[1]:
            work = R.T @ f
            ref = np.linalg.norm(f, axis=0) * np.linalg.norm(R, axis=0).max() + 1e-300
            if np.any(np.abs(work) > balance_tol * ref):
                raise ValueError(
                    "force: the loads do work on a rigid-body mode (unbalanced torques "
                    f"{np.abs(work).max():.3g}); apply balanced input and output loads")
            MR = self._matrices["M"] @ R
            n, r = K.shape[0], R.shape[1]
            A = np.zeros((n + r, n + r))
            A[:n, :n], A[:n, n:], A[n:, :n] = K, MR, MR.T
            rhs = np.concatenate([f, np.zeros((r,) + f.shape[1:])])
            return np.linalg.solve(A, rhs)[:n]
        return np.linalg.solve(K, f)
