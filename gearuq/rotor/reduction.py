"""Modal reduction of a geared rotor around its mesh, with static correction.

The linear time-invariant part of the rotor (mean mesh stiffness ``k_bar`` included in ``K``)
is reduced to the elastic modes below a cut-off chosen from the excitation band::

    eta'' + (C_r + Omega G_r) eta' + diag(w_r^2) eta = Phi^T (f_load - v r),
    r = F_mesh - k_bar delta       (the part of the mesh force not in K)

and every displacement-type output ``y = a . q + b . q'`` is recovered with the residual
(static) flexibility of the dropped modes, the mode-acceleration correction::

    q = Phi eta + R (f_load - v r),     R = K^+ - Phi diag(1/w_r^2) Phi^T

so the reduced model is exact at zero frequency (``K^+`` is the inverse in the complement of
the rigid-body modes) and its error grows only as ``(w / w_cut)^2`` below the cut-off. The
rigid-body mode of the drivetrain is dropped: balanced loads and the mesh force do no work on
it. Damping: the element dampers (bearings, mesh) projected on the modes plus modal damping
``2 zeta w_r`` on every elastic mode (or Rayleigh ``alpha + beta w_r^2``). The same damping
in the full model is ``C + M Phi_all diag(2 zeta w) Phi_all^T M`` (:func:`full_damping`).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import scipy.linalg as sla

from gearuq.rotor.assembly import Rotor
from gearuq.rotor.modal import RealModes, undamped_modes

__all__ = ["Channel", "ModalModel", "full_damping", "full_receptance", "reduce_rotor"]


@dataclass(frozen=True)
class Channel:
    """A linear output ``y = a . q + b . q'`` (differentiated ``derivative`` times).

    Parameters
    ----------
    name : str
        Output name.
    displacement : ndarray, (n_dof,)
        ``a``.
    velocity : ndarray or None
        ``b`` (bearing damping forces), or None.
    derivative : int
        0 for the output itself, 2 for its second time derivative (accelerations).
    units : str
        Units of ``y`` (after differentiation).
    """

    name: str
    displacement: np.ndarray
    velocity: np.ndarray | None = None
    derivative: int = 0
    units: str = "m"


@dataclass
class ModalModel:
    """The reduced rotor: modal matrices, mesh and output projections, static corrections.

    Attributes
    ----------
    omega : ndarray, (n_r,)
        Retained natural frequencies [rad/s] (mean mesh stiffness included).
    shapes : ndarray, (n_dof, n_r)
        Mass-normalised mode shapes.
    damping : ndarray, (n_r, n_r)
        Modal damping matrix ``Phi^T C Phi + diag(2 zeta w)`` [1/s].
    gyroscopic : ndarray, (n_r, n_r)
        ``Phi^T G Phi`` per unit reference speed (skew).
    mesh : ndarray, (n_r,)
        ``psi = Phi^T v``.
    mesh_residual : float
        Residual mesh compliance ``v^T R v`` [m/N].
    mesh_static : float
        Static mesh approach under the load, ``v^T K^+ f_load`` [m].
    load : ndarray, (n_r,)
        Modal load ``Phi^T f_load``.
    mean_stiffness : float
        ``k_bar`` [N/m] contained in K.
    channels : dict
        Output name -> dict with ``a``, ``b`` (modal projections), ``a_res``, ``b_res``
        (residual responses to a unit mesh force pair), ``static`` (static value under the
        load), ``derivative``, ``units``.
    all_omega : ndarray
        Every elastic natural frequency of the full model (for reports).
    cutoff : float
        The cut-off [rad/s].
    """

    omega: np.ndarray
    shapes: np.ndarray
    damping: np.ndarray
    gyroscopic: np.ndarray
    mesh: np.ndarray
    mesh_residual: float
    mesh_static: float
    load: np.ndarray
    mean_stiffness: float
    channels: dict[str, dict] = field(default_factory=dict)
    all_omega: np.ndarray = field(default_factory=lambda: np.zeros(0))
    cutoff: float = np.inf

    @property
    def n_modes(self) -> int:
        """Number of retained modes."""
        return self.omega.size

    def state_matrix(self, speed: float) -> np.ndarray:
        """First-order matrix of ``[eta, eta']`` at reference speed ``speed`` [rad/s]."""
        n = self.n_modes
        A = np.zeros((2 * n, 2 * n))
        A[:n, n:] = np.eye(n)
        A[n:, :n] = -np.diag(self.omega**2)
        A[n:, n:] = -(self.damping + speed * self.gyroscopic)
        return A

    def receptances(self, speed: float, frequencies: np.ndarray,
                    names: list[str] | None = None) -> dict[str, np.ndarray]:
        """Receptances to a unit mesh force pair ``v`` at angular frequencies ``w >= 0``.

        Returns ``mesh``: ``h(w) = v^T H(w) v`` [m/N] and, per channel, ``g(w) = y`` for the
        load ``v`` (already differentiated, times ``(i w)^d``), with the static correction;
        ``H(w) = (K - w^2 M + i w (C + speed G))^-1`` of the reduced model. The mesh force
        enters the equations as ``-v r``, so an output is ``static - g r``.
        """
        w = np.asarray(frequencies, dtype=float)
        n = self.n_modes
        names = list(self.channels) if names is None else names
        out: dict[str, np.ndarray] = {}
        s = 1j * w
        if n:
            # numba: imported for cost
            from gearuq.rotor._spectral_kernels import pole_sums_auto

            lam, X = np.linalg.eig(self.state_matrix(speed))
            B = np.concatenate([np.zeros(n), self.mesh])
            u = np.linalg.solve(X, B)
            disp = X[:n]                                     # eta part
            vel = X[n:]                                      # eta' part
            # residues of every output at once: one pass over (frequency, pole), no
            # (n_w, 2n) temporary (a third of the long-period route's cost before)
            rows = [self.mesh @ disp]
            for name in names:
                ch = self.channels[name]
                rows.append(ch["a"] @ disp)
                if ch["b"] is not None:
                    rows.append(ch["b"] @ vel)
            weights = (u * np.array(rows)).T
            # a real system's poles pair with their conjugates (LAPACK returns exact
            # conjugate eigenvectors, so the residues pair too): one term per pair
            upper, lower = lam.imag > 0.0, lam.imag < 0.0
            n_pairs = int(upper.sum()) if upper.sum() == lower.sum() else 0
            order = (np.concatenate([np.flatnonzero(upper), np.flatnonzero(~upper & ~lower)])
                     if n_pairs else np.arange(lam.size))
            sums = pole_sums_auto(np.ascontiguousarray(w.ravel()),
                                  np.ascontiguousarray(lam[order]),
                                  np.ascontiguousarray(weights[order]), n_pairs
                                  ).reshape(w.shape + (len(rows),))
            out["mesh"] = sums[..., 0] + self.mesh_residual
            col = 1
            for name in names:
                ch = self.channels[name]
                g = sums[..., col] + ch["a_res"]
                col += 1
                if ch["b"] is not None:
                    g = g + sums[..., col] + s * ch["b_res"]
                    col += 1
                out[name] = g * s ** ch["derivative"]
        else:
            out["mesh"] = np.full(w.shape, self.mesh_residual, dtype=complex)
            for name in names:
                ch = self.channels[name]
                g = np.full(w.shape, ch["a_res"], dtype=complex)
                if ch["b"] is not None:
                    g = g + s * ch["b_res"]
                out[name] = g * s ** ch["derivative"]
        return out

    def static_value(self, name: str) -> float:
        """Static value of a channel under the load alone (no mesh fluctuation)."""
        ch = self.channels[name]
        return ch["static"] if ch["derivative"] == 0 else 0.0


def full_damping(rotor: Rotor, modes: RealModes, *, damping_ratio: float = 0.0,
                 rayleigh: tuple[float, float] | None = None) -> np.ndarray:
    """Full-model damping matrix: element dampers plus modal (or Rayleigh) damping.

    ``C + M Phi diag(2 zeta w) Phi^T M`` over the elastic modes (the rigid-body mode stays
    undamped), or ``C + alpha M + beta K`` for ``rayleigh=(alpha, beta)``.
    """
    C = rotor.C()
    if rayleigh is not None:
        alpha, beta = rayleigh
        return C + alpha * rotor.M() + beta * rotor.K()
    if damping_ratio:
        el = modes.elastic
        MPhi = rotor.M() @ el.shapes
        C = C + MPhi @ np.diag(2.0 * damping_ratio * el.omega) @ MPhi.T
    return C


def reduce_rotor(
    rotor: Rotor,
    load: np.ndarray,
    channels: list[Channel],
    *,
    cutoff: float,
    damping_ratio: float = 0.0,
    rayleigh: tuple[float, float] | None = None,
    min_modes: int = 0,
    modes: RealModes | None = None,
    mesh_index: int = 0,
) -> ModalModel:
    """Reduce ``rotor`` to its elastic modes below ``cutoff`` with static correction.

    Parameters
    ----------
    rotor : Rotor
        Assembled rotor, the mesh element at its mean stiffness.
    load : ndarray, (n_dof,)
        Constant balanced load (input and output torques) [N, N m].
    channels : list of Channel
        Outputs to recover.
    cutoff : float
        Keep the elastic modes with ``w <= cutoff`` [rad/s].
    damping_ratio : float
        Modal damping ratio of every elastic mode (ignored with ``rayleigh``).
    rayleigh : (alpha, beta), optional
        Rayleigh damping ``alpha M + beta K`` instead.
    min_modes : int
        Keep at least this many elastic modes.
    modes : RealModes, optional
        Precomputed :func:`undamped_modes` of the rotor (saves the eigen-solution).
    mesh_index : int
        Which mesh element.
    """
    modes = undamped_modes(rotor) if modes is None else modes
    el = modes.elastic
    keep = el.omega <= cutoff
    keep[: min(min_modes, keep.size)] = True
    Phi, w = el.shapes[:, keep], el.omega[keep]
    v = rotor.mesh_vector(mesh_index)
    Cr = Phi.T @ rotor.C() @ Phi
    if rayleigh is not None:
        Cr = Cr + np.diag(rayleigh[0] + rayleigh[1] * w**2)
    else:
        Cr = Cr + np.diag(2.0 * damping_ratio * w)
    # static solutions: unit mesh pair and the load (rigid-body modes constrained)
    statics = rotor.static(np.column_stack([v, load]))
    q_mesh, q_load = statics[:, 0], statics[:, 1]
    psi = Phi.T @ v
    inv_w2 = 1.0 / w**2
    model = ModalModel(
        omega=w, shapes=Phi, damping=Cr, gyroscopic=Phi.T @ rotor.G() @ Phi, mesh=psi,
        mesh_residual=float(v @ q_mesh - psi @ (inv_w2 * psi)),
        mesh_static=float(v @ q_load), load=Phi.T @ load,
        mean_stiffness=float(rotor.meshes[mesh_index].stiffness), all_omega=el.omega,
        cutoff=float(cutoff))
    for ch in channels:
        a = Phi.T @ ch.displacement
        entry = {
            "a": a, "a_res": float(ch.displacement @ q_mesh - a @ (inv_w2 * psi)),
            "b": None, "b_res": 0.0, "static": float(ch.displacement @ q_load),
            "derivative": int(ch.derivative), "units": ch.units,
        }
        if ch.velocity is not None:
            b = Phi.T @ ch.velocity
            entry["b"] = b
            entry["b_res"] = float(ch.velocity @ q_mesh - b @ (inv_w2 * psi))
        model.channels[ch.name] = entry
    return model


def full_receptance(rotor: Rotor, damping: np.ndarray, speed: float,
                    frequencies: np.ndarray, output: np.ndarray | None = None,
                    mesh_index: int = 0) -> np.ndarray:
    """Receptance ``a^T (K - w^2 M + i w (C + speed G))^-1 v`` of the full model.

    The reference for the truncation error of the reduction (``a = v`` by default); at
    ``w = 0`` the rigid-body modes are constrained as in :meth:`Rotor.static`.
    """
    v = rotor.mesh_vector(mesh_index)
    a = v if output is None else output
    K, M, G = rotor.K(), rotor.M(), rotor.G()
    out = np.empty(np.size(frequencies), dtype=complex)
    for i, w in enumerate(np.atleast_1d(frequencies)):
        if w == 0.0:
            out[i] = a @ rotor.static(v)
        else:
            Z = K - w**2 * M + 1j * w * (damping + speed * G)
            out[i] = a @ sla.solve(Z, v.astype(complex))
    return out
