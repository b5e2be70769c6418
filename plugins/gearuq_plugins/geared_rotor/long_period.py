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
geared_rotor.md, "Hunting-tooth stages in the plugin" and "Speed of the long-period route"
(GMRES to ``gmres_tol``, started from the previous speed of a sweep; K_v from the force
series' maximum polished by Newton's method; the GMRES iterations of a steady state and of a
speed-range call bounded; where Newton's method stagnates under contact loss, the reduced
rotor integrated in time to its periodic response, which exists there: fifth round).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from contextlib import nullcontext
from typing import Any

import numpy as np

from gearuq.rotor.excitation import MeshExcitation
from gearuq.rotor.geared import GearedRotorProblem, read_aperiodic, single_threaded_blas
from gearuq.rotor.harmonic_balance import STATUS_NOT_CONVERGED, PeriodicSolution

#: Longest period [mesh cycles] solved by the dense balance; above it, this module.
MAX_DENSE_LONG_PERIOD = 120


#: Most harmonics the back-flank fallback solves densely (a real system of 2 x this size);
#: beyond, it keeps the spectral orders and flags the speed with STATUS_BACK_FLANK_TRUNCATED.
MAX_DENSE_FALLBACK_ORDERS = 2048

#: Most spectral orders the back-flank fallback of a long period solves (a dense real system
#: of twice as many unknowns per Newton step, 0.1 s at 512 orders): a 27/79 sample (germ
#: seed 3, 150 N m) met the back flank with a set that took minutes per steady state.
MAX_SPECTRAL_FALLBACK_ORDERS = 512

#: Status of a steady state (beyond the balance's 0-3): back-flank contact solved on the
#: spectral orders only, with their truncation error (docs/theory/geared_rotor.md).
STATUS_BACK_FLANK_TRUNCATED = 4

#: GMRES relative tolerance of the long-period route (its error: docs/theory/geared_rotor.md).
GMRES_TOL = 1e-6

#: GMRES iterations one speed-range call (a sample's sweep and peak refinement) may spend
#: in all (about 30 s of CPU for a 27/79 stage): past it, each steady state gets
#: ``SPENT_SWEEP_GMRES``, enough for full contact, so a sample whose contact-loss steady
#: states stagnate ends in bounded time with status 1 at those speeds.
SWEEP_GMRES_BUDGET = 20_000

#: GMRES iterations a steady state gets once the sweep's budget is spent.
SPENT_SWEEP_GMRES = 200

#: GMRES iterations Newton's method may spend on a contact-loss steady state before the
#: reduced rotor is integrated in time from its best iterate instead (about 1.3 s for a
#: 27/79 stage; converging contact-loss steady states took 77-550, stagnating ones ran to
#: 3000 and beyond while the integration settles in 0.3-0.6 s).
NEWTON_GMRES_BEFORE_INTEGRATION = 300

#: What one long period of that time integration costs, in GMRES iterations of the sweep's
#: account (27/79: 0.1 s against about 1.2 ms per iteration): the account bounds both, and
#: once it is spent a steady state is no longer integrated, it is flagged.
INTEGRATION_PERIOD_GMRES = 100

#: GMRES iterations Newton's method gets at a speed next to one that needed the time
#: integration, before the integration continues from there (where the separation fades,
#: Newton takes it back in 5-60).
NEWTON_GMRES_AFTER_INTEGRATION = 60

#: Local maxima of the sampled mesh force polished by Newton's method for K_v.
PEAK_CANDIDATES = 4

#: Newton steps of that polish (quadratic convergence from within one sample spacing).
NEWTON_STEPS = 4

#: Steady-state solvers of the long-period route.
LONG_PERIOD_SOLVERS = ("gmres", "spectral_orders")


def _series_maximum(harmonics: np.ndarray, orders: np.ndarray, period: float) -> float:
    """Maximum of ``c_0 + 2 Re sum_j c_j exp(2 pi i j t / period)`` over ``orders`` (``J[0] = 0``).

    Sampled at ``next_fast_len(4 max J)`` instants (>= 4 per period of the highest order),
    then the ``PEAK_CANDIDATES`` largest local maxima of the samples refined by Newton's
    method on the derivative (steps within one sample spacing). Never below the sampled
    maximum.
    """
    import scipy.fft

    from gearuq.rotor._spectral_kernels import polish_maxima  # numba: imported for cost

    n = scipy.fft.next_fast_len(max(4 * int(orders[-1]), 8), real=True)
    c = np.zeros(n // 2 + 1, dtype=complex)
    c[orders] = harmonics
    f = scipy.fft.irfft(c * n, n=n)
    top = float(f.max())
    peaks = np.flatnonzero((f >= np.roll(f, 1)) & (f >= np.roll(f, -1)))
    if peaks.size > PEAK_CANDIDATES:  # the largest few, unordered (no full sort)
        peaks = peaks[np.argpartition(f[peaks], -PEAK_CANDIDATES)[-PEAK_CANDIDATES:]]
    dt = period / n
    # compiled: one pass over the orders per candidate and step, where numpy's phases by
    # cumprod over every order were a seventh of a steady state's cost
    values = polish_maxima(np.ascontiguousarray(harmonics, dtype=complex),
                           np.ascontiguousarray(orders, dtype=np.int64), peaks * dt,
                           float(period), NEWTON_STEPS, dt)
    return max(top, float(values.max(initial=-np.inf)))


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
    gmres_tol : float
        With ``solver="gmres"``: GMRES relative residual tolerance of each linear solve, in
        (0, 0.1] (its error on the outputs: docs/theory/geared_rotor.md).
    """

    def __init__(self, rotor_factory: Callable[[float], Any], excitation: MeshExcitation,
                 pinion_teeth: int, *, mesh_harmonics: int, solver: str = "gmres",
                 spectral_energy: float = 0.99, damping_ratio: float = 0.05,
                 cutoff_factor: float = 1.0, backlash: float = math.inf,
                 gmres_tol: float = GMRES_TOL) -> None:
        from gearuq.rotor.sideband_balance import prepare_krylov, prepare_orders, spectral_orders

        if solver not in LONG_PERIOD_SOLVERS:
            raise ValueError(f"solver={solver!r} is outside its valid set {LONG_PERIOD_SOLVERS}")
        if not 0.0 < gmres_tol <= 0.1:
            raise ValueError(f"gmres_tol={gmres_tol!r} is outside its valid range (0, 0.1]")

        # the dense preparation is built for one harmonic only (unused: no dense solve here)
        super().__init__(rotor_factory, excitation, pinion_teeth, damping_ratio=damping_ratio,
                         n_harmonics=1, cutoff_factor=cutoff_factor, backlash=backlash)
        L = excitation.n_cycles
        self.mesh_harmonics = int(mesh_harmonics)
        self.spectral_energy = float(spectral_energy)
        self._H = self.mesh_harmonics * L
        self.mesh_order_index = np.arange(1, self.mesh_harmonics + 1) * L
        self.solver = solver
        self.gmres_tol = float(gmres_tol)
        self._blas_limited = False  # inside dynamics_over_speeds, BLAS is limited once
        self._previous: np.ndarray | None = None  # last GMRES delta: the next solve's start
        self._previous_remainder: np.ndarray | None = None  # its r_j (full contact)
        self._previous_timed: PeriodicSolution | None = None  # a time-integrated previous
        self._continued = False  # GMRES starts from _previous (inside dynamics_over_speeds)
        self._spent = 0  # GMRES iterations of the current dynamics_over_speeds call
        self._budget = SWEEP_GMRES_BUDGET  # what that call may spend (twice with a run-down)
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
                    initial: np.ndarray | None = None, aperiodic_response: str = "invalid"
                    ) -> tuple[dict, PeriodicSolution]:
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
        at = np.searchsorted(J, self.mesh_order_index[:M])
        with nullcontext() if self._blas_limited else single_threaded_blas():
            model = self.reduced(float(speed_rpm))
            names = ["dte", acceleration_channel]
            rec = model.receptances(omega, 2.0 * np.pi / T * J, names)
            sol = self._solve(model, T, omega, rec, names, tol, initial)
        dte, acc = sol.channels["dte"], sol.channels[acceleration_channel]
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
        return read_aperiodic(values, sol, self.excitation.normal_force,
                              aperiodic_response), sol

    def dynamics_over_speeds(self, speeds_rpm: Any, **kw: Any) -> Any:
        """As :meth:`GearedRotorProblem.dynamics_over_speeds`, BLAS limited once for all.

        With ``continuation`` (default True), each GMRES solve starts from the steady state
        before it on its sweep (the grid in order; a run-down from the speed above; a peak's
        refinement from the peak's own grid speed on the sweep it came from), so a call's
        results depend on its arguments alone, to the GMRES tolerance.
        """
        with single_threaded_blas():
            self._blas_limited = True
            self._continued = bool(kw.get("continuation", True))
            self._spent = 0
            # the run-down's steady states get an account as large as the run-up's
            self._budget = SWEEP_GMRES_BUDGET * (
                2 if kw.get("sweep_direction", "up") == "up_and_down" else 1)
            try:
                return super().dynamics_over_speeds(speeds_rpm, **kw)
            finally:
                self._blas_limited = self._continued = False
                self._previous = self._previous_remainder = self._previous_timed = None

    def _solve_from(self, speed_rpm: float, state: object, kw: dict) -> tuple[dict, object]:
        """As :meth:`GearedRotorProblem._solve_from`; GMRES's state is its start.

        With GMRES the state is ``(delta, remainder, timed)``, what :meth:`_solve` keeps for
        the next speed (the last converged ``delta``; after full contact its remainder;
        a time-integrated solution), restored before the solve and read after it.
        """
        if self.solver != "gmres":
            return super()._solve_from(speed_rpm, state, kw)
        self._previous, self._previous_remainder, self._previous_timed = (
            state if state is not None else (None, None, None))
        values, _ = self.dynamics_at(speed_rpm, **kw)
        return values, (self._previous, self._previous_remainder, self._previous_timed)

    def peak_mesh_force(self, sol: PeriodicSolution) -> float:
        """Largest mesh force [N] from its harmonics on the kept orders.

        As :meth:`GearedRotorProblem.peak_mesh_force`, the maximum of the force synthesised
        from the harmonics the balance holds (here the kept orders), so that ``K_v = 1``
        quasi-statically up to the orders left out: sampled at >= 4 instants per period of
        the highest harmonic, then the ``PEAK_CANDIDATES`` largest local maxima of the
        samples polished by Newton's method on the series' derivative (the maximum of the
        series to rounding, where 64 instants per period of the highest harmonic were 36x
        the cost and 0.12 % of that harmonic's amplitude short).
        """
        return _series_maximum(sol.force, self.kept, 2.0 * math.pi)

    def _solve(self, model: Any, T: float, omega: float, rec: dict, names: list[str],
               tol: float, initial: np.ndarray | None) -> PeriodicSolution:
        """One steady state on the kept orders by the chosen solver."""
        from gearuq.rotor.sideband_balance import (
            GMRES_BUDGET,
            solve_periodic_by_integration,
            solve_periodic_krylov,
            solve_periodic_orders,
            stall_periods_for,
        )

        if self.solver == "gmres":
            start = self._previous if self._continued else None
            budget = min(GMRES_BUDGET, NEWTON_GMRES_BEFORE_INTEGRATION,
                         max(self._budget - self._spent, SPENT_SWEEP_GMRES))
            account = not self._blas_limited or self._spent < self._budget
            # next to a speed that needed the time integration Newton gets a short try, then
            # the integration continues from that speed's state
            timed_before = self._previous_timed if start is not None and account else None
            if timed_before is not None:
                budget = min(budget, NEWTON_GMRES_AFTER_INTEGRATION)
            guess = start
            if start is not None and self._previous_remainder is not None:
                # after full contact, GMRES starts from the previous remainder through this
                # speed's receptance: near a resonance h moves with the speed and r hardly
                # (27/79 sample: 495 -> 370 GMRES iterations over 160 speeds)
                guess = -rec["mesh"] * self._previous_remainder
                guess[0] += model.mesh_static
            sol = solve_periodic_krylov(
                model, self.krylov, T, omega, newton_tol=tol, tol=self.gmres_tol,
                receptance=rec, channels=names, initial=guess, newton_start=start,
                max_iter=budget)
            if self._blas_limited:  # inside dynamics_over_speeds: the sweep's account
                self._spent += sol.iterations
            if account and sol.status == STATUS_NOT_CONVERGED and sol.contact_loss_fraction > 0:
                # Newton stagnated under contact loss (near a resonance, where a periodic
                # response exists but each GMRES solve takes thousands of iterations)
                if sol.min_approach <= -self.backlash:
                    # toward the back flank: the order balance where it is affordable
                    # (refused beyond MAX_SPECTRAL_FALLBACK_ORDERS, then the integration)
                    ordered = self._back_flank(model, T, omega, rec, names, tol, sol)
                    if ordered.status in (0, STATUS_BACK_FLANK_TRUNCATED):
                        self._previous = self._previous_timed = None
                        self._previous_remainder = None
                        return ordered
                # the reduced rotor integrated in time from Newton's best iterate
                timed = solve_periodic_by_integration(
                    model, self.krylov, T, omega, start=timed_before or sol,
                    backlash=self.backlash, receptance=rec, channels=names,
                    stall_periods=stall_periods_for(self.excitation.n_cycles))
                if self._blas_limited:
                    self._spent += INTEGRATION_PERIOD_GMRES * timed.iterations
                if timed.status != STATUS_NOT_CONVERGED:  # periodic (0) or not (3): said so
                    timed.iterations = sol.iterations  # the GMRES count, as the account's
                    sol = timed
            self._previous_timed = sol if sol.start == "time_integration" and \
                sol.status == 0 else None
            # the next speed starts GMRES here (a nearby speed: fewer iterations)
            self._previous = sol.delta if sol.status == 0 else None
            self._previous_remainder = (sol.remainder if sol.status == 0
                                        and sol.branch == "full_contact" else None)
            if (math.isinf(self.backlash) or sol.min_approach > -self.backlash
                    or sol.start == "time_integration"):  # the integration has the back flank
                return sol
            # the flanks would meet on the back: the order balance, which has the back flank
            return self._back_flank(model, T, omega, rec, names, tol, sol)
        start = None if initial is None or np.asarray(initial).size != 2 * self.kept.size - 1 \
            else np.asarray(initial)[self.kept.size - 1:]
        kw = {"backlash": self.backlash, "tol": tol, "receptance": rec, "channels": names}
        sol = solve_periodic_orders(model, self.orders, T, omega, initial=start, **kw)
        if start is not None and sol.status != 0:  # fall back to the linear start
            sol = solve_periodic_orders(model, self.orders, T, omega, **kw)
        return sol

    def _back_flank(self, model: Any, T: float, omega: float, rec: dict, names: list[str],
                    tol: float, front_only: PeriodicSolution) -> PeriodicSolution:
        """Back-flank contact after GMRES: every harmonic, or the spectral orders, flagged.

        Spectral orders beyond ``MAX_SPECTRAL_FALLBACK_ORDERS`` are not solved (a dense
        system of twice their number per Newton step): ``front_only``, GMRES's solution
        without the back flank, is returned with status 1.
        """
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
        if truncated and J.size > MAX_SPECTRAL_FALLBACK_ORDERS:
            front_only.status = STATUS_NOT_CONVERGED
            return front_only
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

