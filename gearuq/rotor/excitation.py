"""Mesh excitation of a geared rotor over the long period: stiffness k(tau) and error e(tau).

The LTCA (:func:`gearuq.gears.ltca.ltca`) gives, at each mesh position ``tau`` (in mesh cycles)
over the long period of ``lcm(z1, z2)`` cycles, the static transmission error ``STE`` at the
normal load ``P``, the secant stiffness (Yuan et al. Eq. 4) and the tangent stiffness ``dP/dSTE``.
The dynamics is a small perturbation about this quasi-static state, so the mesh force is
linearised with the **tangent** stiffness::

    F = k_t(tau) (delta - e_t(tau)),    e_t = STE - P / k_t

which passes through the static state (``F = P`` at ``delta = STE``) with the right slope.
(The secant pair ``k_s, e_s`` of Yuan et al. Eqs. 4-5 passes through the same point with the slope
of the chord to the origin; see docs/theory/geared_rotor.md.) The positions map to time by
``tau = f_mesh t``, ``f_mesh = z1 n / 60``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

__all__ = ["MeshExcitation"]


@dataclass(frozen=True)
class MeshExcitation:
    """Periodic mesh stiffness and error over one long period.

    Attributes
    ----------
    tau : ndarray
        Equally spaced positions ``[0, n_cycles)`` [mesh cycles].
    stiffness : ndarray
        Mesh stiffness ``k(tau)`` used by the dynamics [N/m] (tangent).
    error : ndarray
        Mesh error ``e(tau)`` [m] with ``F = k (delta - e)``.
    normal_force : float
        Static normal mesh force ``P`` [N].
    n_cycles : int
        Mesh cycles per long period.
    ste : ndarray
        Static transmission error (normal) ``STE(tau)`` [m].
    secant_stiffness, secant_error : ndarray
        Yuan et al. Eqs. 4-5 ``k_s``, ``e_s`` [N/m, m] (for comparison).
    contact_loss_fraction : ndarray
        LTCA share of the geometric contact length left unloaded (partial contact loss).
    meta : dict
        Provenance (torque, LTCA settings, tangent method).
    """

    tau: np.ndarray
    stiffness: np.ndarray
    error: np.ndarray
    normal_force: float
    n_cycles: int
    ste: np.ndarray
    secant_stiffness: np.ndarray | None = None
    secant_error: np.ndarray | None = None
    contact_loss_fraction: np.ndarray | None = None
    meta: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        n = np.asarray(self.tau).size
        for name in ("stiffness", "error", "ste"):
            a = np.asarray(getattr(self, name), dtype=float)
            if a.shape != (n,):
                raise ValueError(f"{name} has shape {a.shape}, expected ({n},) like tau")
            if not np.all(np.isfinite(a)):
                raise ValueError(f"{name} contains non-finite values")
        if np.any(np.asarray(self.stiffness) <= 0):
            i = int(np.argmin(self.stiffness))
            raise ValueError(f"stiffness={self.stiffness[i]!r} N/m at position tau="
                             f"{self.tau[i]:g} is outside its valid range (0, inf) N/m")
        if not (math.isfinite(self.normal_force) and self.normal_force > 0):
            raise ValueError(f"normal_force={self.normal_force!r} is outside (0, inf) N")
        if int(self.n_cycles) != self.n_cycles or self.n_cycles < 1:
            raise ValueError(f"n_cycles={self.n_cycles!r} is outside its valid range: "
                             "integers >= 1")

    # ------------------------------------------------------------------ constructors
    @classmethod
    def from_ltca(
        cls,
        pair: Any,
        torque: float,
        *,
        deviations: Any = None,
        compliance: Any = None,
        positions_per_cycle: int = 24,
        n_pts: int = 20,
        tangent: str = "ltca",
        relative_step: float = 1e-3,
    ) -> MeshExcitation:
        """Run the LTCA over the long period at ``torque`` and linearise the mesh there.

        Parameters
        ----------
        pair : HelicalGearPair
            The gear pair (pinion drives).
        torque : float
            Pinion torque [N m], > 0.
        deviations : FlankDeviations or None
            Pitch deviations and modifications.
        compliance : ComplianceModel or None
            Tooth compliance (default: the LTCA's default model).
        positions_per_cycle, n_pts : int
            LTCA discretisation.
        tangent : {"ltca", "finite_difference"}
            ``"ltca"``: the LTCA's ``lpms_tangent``; ``"finite_difference"``: the central
            difference ``2 dP / (STE(P + dP) - STE(P - dP))`` of two more LTCA runs (an
            independent estimate of the same slope).
        relative_step : float
            ``dP / P`` of the finite difference.

        Raises
        ------
        ValueError
            For a torque <= 0, or when the LTCA does not converge at some position (the
            message names them): a load the LTCA cannot carry is never passed on.
        """
        from gearuq.gears.ltca import ltca_setup

        if not (math.isfinite(torque) and torque > 0):
            raise ValueError(f"torque={torque!r} is outside its valid range (0, inf) N m")
        setup = ltca_setup(pair, compliance=compliance, positions_per_cycle=positions_per_cycle,
                           n_pts=n_pts)
        return cls.from_setup(setup, torque, deviations=deviations, tangent=tangent,
                              relative_step=relative_step)

    @classmethod
    def from_setup(
        cls,
        setup: Any,
        torque: float,
        *,
        deviations: Any = None,
        tangent: str = "ltca",
        relative_step: float = 1e-3,
    ) -> MeshExcitation:
        """Like :meth:`from_ltca` on a prepared :func:`gearuq.gears.ltca.ltca_setup`.

        The setup (contact grid and influence blocks) depends only on the pair, the
        compliance and the discretisation, so many samples (loads, deviations) share it.
        """
        from gearuq.gears.ltca import ltca_solve, mesh_summaries, normal_force_from_torque

        if not (math.isfinite(torque) and torque > 0):
            raise ValueError(f"torque={torque!r} is outside its valid range (0, inf) N m")
        if tangent not in ("ltca", "finite_difference"):
            raise ValueError(f"tangent={tangent!r} is outside its valid set "
                             "{'ltca', 'finite_difference'}")
        pair = setup.pair
        P = normal_force_from_torque(pair, torque)
        xi = setup.clearance(deviations)
        sol = ltca_solve(setup, P, xi)
        _check_ltca(sol.status, setup.grid.tau, torque)
        summary = mesh_summaries(setup, sol)
        ste = np.asarray(summary["ste"], dtype=float)
        if tangent == "ltca":
            k_t = np.asarray(summary["lpms_tangent"], dtype=float)
        else:
            dP = relative_step * P
            hi, lo = ltca_solve(setup, P + dP, xi), ltca_solve(setup, P - dP, xi)
            _check_ltca(hi.status, setup.grid.tau, torque)
            _check_ltca(lo.status, setup.grid.tau, torque)
            k_t = 2.0 * dP / (hi.ste - lo.ste)
        tau = np.asarray(setup.grid.tau, dtype=float)
        ppc = int(round(1.0 / (tau[1] - tau[0])))
        return cls(
            tau=tau.copy(), stiffness=k_t, error=ste - P / k_t, normal_force=P,
            n_cycles=int(round(tau.size / ppc)), ste=ste,
            secant_stiffness=np.asarray(summary["lpms"], dtype=float),
            secant_error=np.asarray(summary["cms"], dtype=float),
            contact_loss_fraction=np.asarray(summary["contact_loss_fraction"], dtype=float),
            meta={"source": "ltca", "torque_Nm": float(torque), "tangent": tangent,
                  "positions_per_cycle": ppc, "n_pts": int(setup.n_pts)},
        )

    @classmethod
    def synthetic(
        cls,
        mean_stiffness: float,
        normal_force: float,
        *,
        n_cycles: int = 30,
        positions_per_cycle: int = 24,
        stiffness_harmonics: dict[int, complex] | None = None,
        error_harmonics: dict[int, complex] | None = None,
        mean_error: float = 0.0,
    ) -> MeshExcitation:
        """Excitation from a few Fourier harmonics of the long period (tests, studies).

        ``k(tau) = k_mean (1 + sum_j Re(a_j exp(2 pi i j tau / n_cycles)))`` and
        ``e(tau) = e_mean + sum_j Re(b_j exp(2 pi i j tau / n_cycles))`` with ``j`` in long-
        period orders (``j = n_cycles`` is the mesh frequency), ``a_j`` relative, ``b_j`` [m].
        """
        n = int(n_cycles) * int(positions_per_cycle)
        tau = np.arange(n) / positions_per_cycle
        ph = 2j * np.pi * tau / n_cycles
        rel = np.ones(n)
        for j, a in (stiffness_harmonics or {}).items():
            rel += np.real(a * np.exp(j * ph))
        err = np.full(n, float(mean_error))
        for j, b in (error_harmonics or {}).items():
            err += np.real(b * np.exp(j * ph))
        k = mean_stiffness * rel
        return cls(tau=tau, stiffness=k, error=err, normal_force=float(normal_force),
                   n_cycles=int(n_cycles), ste=err + normal_force / k,
                   meta={"source": "synthetic"})

    # ------------------------------------------------------------------ derived data
    @property
    def mean_stiffness(self) -> float:
        """Mean of ``k(tau)`` over the long period [N/m]."""
        return float(np.mean(self.stiffness))

    @property
    def positions_per_cycle(self) -> int:
        """Samples per mesh cycle."""
        return int(round(self.tau.size / self.n_cycles))

    def fourier(self) -> dict[str, np.ndarray]:
        """One-sided complex Fourier coefficients over the long period.

        Returns ``stiffness``, ``error`` and ``stiffness_error`` (of the product ``k e``),
        each ``c_j``, ``j = 0 .. n/2``, with ``x(tau) = sum_j c_j exp(2 pi i j tau / n_cycles)``
        over all ``j`` (``c_-j = conj(c_j)``): the trigonometric interpolant of the samples.
        """
        n = self.tau.size
        out = {}
        for name, x in (("stiffness", self.stiffness), ("error", self.error),
                        ("stiffness_error", self.stiffness * self.error)):
            c = np.fft.rfft(x) / n
            if n % 2 == 0:
                c[-1] *= 0.5  # split the Nyquist term evenly between +-n/2
            out[name] = c
        return out


def _check_ltca(status: np.ndarray, tau: np.ndarray, torque: float) -> None:
    bad = np.flatnonzero(np.asarray(status) != 0)
    if bad.size:
        taus = ", ".join(f"{t:g}" for t in np.asarray(tau)[bad[:5]])
        raise ValueError(
            f"torque={torque!r} N m: the LTCA did not converge at {bad.size} position(s) "
            f"(tau = {taus} ...); this load cannot be carried by the contact model")
