"""The geared rotor of a hunting-tooth stage: line-load table excitation, long-period solvers.

A stage whose long period exceeds ``MAX_DENSE_LONG_PERIOD`` mesh cycles (27/79: 2133) is out
of reach of the dense harmonic balance (three mesh harmonics: 6399 harmonics, a dense system of
12 799 unknowns per speed) and of the full LTCA (2.7 s per sample). On this route a sample's
excitation comes from :func:`gearuq.gears.long_period.long_period_ltca` (one line-load table
per sample, built for its torque) and every steady state of the speed range is solved on every
harmonic ``0..H`` by preconditioned GMRES (:func:`gearuq.rotor.sideband_balance.
solve_periodic_krylov`, the default: the balance itself, no truncation beyond ``H``), or on the
long-period harmonics that hold ``spectral_energy`` of the excitation (:func:`~gearuq.rotor.
sideband_balance.solve_periodic_orders`). What each costs and loses: docs/theory/
geared_rotor.md, "Hunting-tooth stages in the plugin".
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np

from gearuq.rotor.excitation import MeshExcitation
from gearuq.rotor.geared import GearedRotorProblem, single_threaded_blas
from gearuq.rotor.harmonic_balance import PeriodicSolution

#: Longest period [mesh cycles] solved by the dense balance; above it, this module.
MAX_DENSE_LONG_PERIOD = 120


#: Most harmonics the back-flank fallback solves densely (a real system of 2 x this size);
#: beyond, it keeps the spectral orders and flags the speed with STATUS_BACK_FLANK_TRUNCATED.
MAX_DENSE_FALLBACK_ORDERS = 2048

#: Status of a steady state (beyond the balance's 0-3): back-flank contact solved on the
#: spectral orders only, with their truncation error (docs/theory/geared_rotor.md).
STATUS_BACK_FLANK_TRUNCATED = 4

#: Steady-state solvers of the long-period route.
LONG_PERIOD_SOLVERS = ("gmres", "spectral_orders")


class LongPeriodProblem(GearedRotorProblem):
    """A :class:`GearedRotorProblem` whose steady states suit a long period.

    Only the speed-range analysis (:meth:`dynamics_at`, and through it the inherited
    :meth:`dynamics_over_speeds` with its peak refinement) is offered; the dense methods
    (:meth:`steady_state`, :meth:`rms_over_speeds`, :meth:`sweep`, :meth:`verify`) refuse.

    Parameters
    ----------
    rotor_factory, excitation, pinion_teeth, damping_ratio, cutoff_factor, backlash
        As :class:`GearedRotorProblem`.
    mesh_harmonics : int
        Mesh orders ``M`` of the steady state: harmonics up to ``H = M lcm(z1, z2)``.
    solver : {"gmres", "spectral_orders"}
        Every harmonic ``0..H`` by GMRES, or the spectral orders. GMRES has no back-flank
        contact: a steady state that would reach it is solved again by the order balance,
        which has: on every harmonic up to ``MAX_DENSE_FALLBACK_ORDERS`` of them, beyond on
        the spectral orders with status ``STATUS_BACK_FLANK_TRUNCATED``.
    spectral_energy : float
        With ``solver="spectral_orders"``: share of the excitation's energy the kept orders
        hold, in (0, 1].
    """

    def __init__(self, rotor_factory: Callable[[float], Any], excitation: MeshExcitation,
                 pinion_teeth: int, *, mesh_harmonics: int, solver: str = "gmres",
                 spectral_energy: float = 0.99, damping_ratio: float = 0.05,
                 cutoff_factor: float = 1.0, backlash: float = math.inf) -> None:
        from gearuq.rotor.sideband_balance import prepare_krylov, prepare_orders, spectral_orders

        if solver not in LONG_PERIOD_SOLVERS:
            raise ValueError(f"solver={solver!r} is outside its valid set {LONG_PERIOD_SOLVERS}")

        # the dense preparation is built for one harmonic only (unused: no dense solve here)
        super().__init__(rotor_factory, excitation, pinion_teeth, damping_ratio=damping_ratio,
                         n_harmonics=1, cutoff_factor=cutoff_factor, backlash=backlash)
        L = excitation.n_cycles
        self.mesh_harmonics = int(mesh_harmonics)
        self.spectral_energy = float(spectral_energy)
        self._H = self.mesh_harmonics * L
        self.mesh_order_index = np.arange(1, self.mesh_harmonics + 1) * L
        self.solver = solver
        if solver == "gmres":
            self.krylov = prepare_krylov(excitation, self.mesh_harmonics)
            self.kept = np.arange(self._H + 1)
            self.orders = None  # built on demand for a back-flank fallback
        else:
            self.krylov = None
            self.orders = prepare_orders(excitation, spectral_orders(
                excitation, self._H, self.spectral_energy, always=self.mesh_order_index))
            self.kept = self.orders.orders

    @property
    def n_harmonics(self) -> int:
        """Highest harmonic ``H`` of the long period (the kept orders are a subset)."""
        return self._H

    def _dense_only(self, *args: Any, **kw: Any) -> Any:
        raise NotImplementedError("the long-period problem of a hunting-tooth stage offers "
                                  "dynamics_at / dynamics_over_speeds only")

    steady_state = rms_over_speeds = sweep = verify = _dense_only

    def dynamics_at(self, speed_rpm: float, *, mesh_orders: int | None = None,
                    acceleration_channel: str = "bearing 1 acceleration y", tol: float = 1e-9,
                    initial: np.ndarray | None = None) -> tuple[dict, PeriodicSolution]:
        """K_v, DTE measures and mesh-order amplitudes at one speed, on the kept orders.

        As :meth:`GearedRotorProblem.dynamics_at`; ``initial`` is a two-sided
        ``delta`` over the kept orders (a previous solution's :meth:`two_sided_delta`; the
        spectral-orders solver starts from it, GMRES from the linear solution).
        """
        M = self.mesh_harmonics if mesh_orders is None else int(mesh_orders)
        if not 1 <= M <= self.mesh_harmonics:
            raise ValueError(f"mesh_orders={mesh_orders!r} is outside its valid range: "
                             f"integers 1..{self.mesh_harmonics}")
        J = self.kept
        T, omega = self.period(float(speed_rpm)), 2.0 * math.pi * float(speed_rpm) / 60.0
        names = ["dte", acceleration_channel]
        with single_threaded_blas():
            model = self.reduced(float(speed_rpm))
            rec = model.receptances(omega, 2.0 * np.pi / T * J, names)
            sol = self._solve(model, T, omega, rec, names, tol, initial)
        dte, acc = sol.channels["dte"], sol.channels[acceleration_channel]
        at = np.searchsorted(J, self.mesh_order_index[:M])
        band = J >= self.excitation.n_cycles // 2
        values = {
            "kv": self.peak_mesh_force(sol) / self.excitation.normal_force,
            "dte_rms": math.sqrt(2.0 * float(np.sum(np.abs(dte[1:]) ** 2))),
            "dte_mesh_band_rms": math.sqrt(2.0 * float(np.sum(np.abs(dte[band]) ** 2))),
            "dte_mesh_orders": 2.0 * np.abs(dte[at]),
            "acceleration_mesh_orders": 2.0 * np.abs(acc[at]),
            "status": sol.status, "iterations": sol.iterations,
            "contact_loss_fraction": sol.contact_loss_fraction,
        }
        return values, sol

    def peak_mesh_force(self, sol: PeriodicSolution) -> float:
        """Largest mesh force [N] from its harmonics on the kept orders.

        As :meth:`GearedRotorProblem.peak_mesh_force`: synthesised from the harmonics the
        balance holds (here the kept orders) with >= 64 instants per period of the highest
        (the sampled maximum within 0.12 % of that harmonic's amplitude of the true one), so
        that ``K_v = 1`` quasi-statically up to the orders left out.
        """
        n = 1 << math.ceil(math.log2(64 * int(self.kept[-1])))
        c = np.zeros(n // 2 + 1, dtype=complex)
        c[self.kept] = sol.force
        return float(np.max(np.fft.irfft(c * n, n=n)))

    def _solve(self, model: Any, T: float, omega: float, rec: dict, names: list[str],
               tol: float, initial: np.ndarray | None) -> PeriodicSolution:
        """One steady state on the kept orders by the chosen solver."""
        from gearuq.rotor.sideband_balance import (
            solve_periodic_krylov,
            solve_periodic_orders,
        )

        if self.solver == "gmres":
            sol = solve_periodic_krylov(model, self.krylov, T, omega, newton_tol=tol,
                                        receptance=rec, channels=names)
            N = self.krylov.n_time
            if math.isinf(self.backlash) or np.min(np.fft.irfft(
                    sol.delta * N, n=N)) > -self.backlash:
                return sol
            # the flanks would meet on the back: the order balance, which has the back flank
            return self._back_flank(model, T, omega, rec, names, tol)
        start = None if initial is None or np.asarray(initial).size != 2 * self.kept.size - 1 \
            else np.asarray(initial)[self.kept.size - 1:]
        kw = {"backlash": self.backlash, "tol": tol, "receptance": rec, "channels": names}
        sol = solve_periodic_orders(model, self.orders, T, omega, initial=start, **kw)
        if start is not None and sol.status != 0:  # fall back to the linear start
            sol = solve_periodic_orders(model, self.orders, T, omega, **kw)
        return sol

    def _back_flank(self, model: Any, T: float, omega: float, rec: dict, names: list[str],
                    tol: float) -> PeriodicSolution:
        """Back-flank contact after GMRES: every harmonic, or the spectral orders, flagged."""
        from gearuq.rotor.sideband_balance import (
            prepare_orders,
            solve_periodic_orders,
            spectral_orders,
        )

        truncated = self.kept.size > MAX_DENSE_FALLBACK_ORDERS
        if self.orders is None:
            J = (spectral_orders(self.excitation, self._H, self.spectral_energy,
                                 always=self.mesh_order_index) if truncated else self.kept)
            self.orders = prepare_orders(self.excitation, J)
        J = self.orders.orders
        sol = solve_periodic_orders(model, self.orders, T, omega, backlash=self.backlash,
                                    tol=tol, channels=names,
                                    receptance={k: v[J] for k, v in rec.items()})
        if not truncated:
            return sol
        # back onto 0..H, the orders left out zero, so the caller reads one layout
        for name in ("delta", "force", "remainder"):
            full = np.zeros(self.kept.size, dtype=complex)
            full[J] = getattr(sol, name)
            setattr(sol, name, full)
        for name in list(sol.channels):
            full = np.zeros(self.kept.size, dtype=complex)
            full[J] = sol.channels[name]
            sol.channels[name] = full
        if sol.status == 0:
            sol.status = STATUS_BACK_FLANK_TRUNCATED
        return sol

