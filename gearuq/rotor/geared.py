"""A geared rotor under a torque with a time-varying mesh: the problem the solvers share.

:class:`GearedRotorProblem` ties together a rotor with one mesh element (its stiffness set to
the mean of the excitation), the balanced input/output torques, the output channels (DTE,
mesh approach, bearing forces and accelerations), the modal reduction chosen from the
excitation band at each speed, and the periodic steady-state solver.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass, field

import numpy as np

from gearuq.rotor.assembly import Rotor
from gearuq.rotor.excitation import MeshExcitation
from gearuq.rotor.harmonic_balance import (
    STATUS_APERIODIC,
    STATUS_NOT_CONVERGED,
    PeriodicSolution,
    PreparedExcitation,
    _two_sided,
    prepare_excitation,
    solve_periodic,
    synthesize,
)
from gearuq.rotor.modal import RealModes, undamped_modes
from gearuq.rotor.reduction import Channel, ModalModel, full_damping, reduce_rotor
from gearuq.rotor.sideband_balance import (
    KrylovExcitation,
    prepare_krylov,
    solve_periodic_by_integration,
)

__all__ = ["DynamicRange", "GearedRotorProblem", "SpeedRange", "single_threaded_blas",
           "torque_load"]


@contextmanager
def single_threaded_blas() -> Iterator[None]:
    """Run small dense linear algebra on one BLAS thread.

    The matrices here are a few hundred wide: a multi-threaded BLAS spends more time
    synchronising than computing (measured 5-50x slower on a loaded 2-core machine).
    """
    from gearuq._threads import one_blas_thread

    with one_blas_thread():
        yield


def torque_load(rotor: Rotor, torque: float, *, mesh_index: int = 0) -> np.ndarray:
    """Balanced load: ``torque`` on the input node, the reaction ``T r_b2/r_b1`` on the output.

    Both act about +z in the global frame for ``drive_sign = +1`` (the driven gear turns the
    other way; its load torque opposes that motion).
    """
    mesh = rotor.meshes[mesh_index]
    f = np.zeros(rotor.n_dof)
    s = mesh.drive_sign
    f[rotor.dof(rotor.tags["input"], "theta_z")] = s * torque
    f[rotor.dof(rotor.tags["output"], "theta_z")] = (
        s * torque * mesh.base_radius_gear / mesh.base_radius_pinion)
    return f


def default_channels(rotor: Rotor, *, mesh_index: int = 0) -> list[Channel]:
    """DTE, mesh approach, and per bearing the forces and accelerations in x, y, z."""
    chans = [
        Channel("dte", rotor.transmission_error_vector(mesh_index), units="m"),
        Channel("delta", rotor.mesh_vector(mesh_index), units="m"),
    ]
    for b in rotor.bearings:
        K, C = b.K(), b.C()
        for i, ax in enumerate("xyz"):
            chans.append(Channel(f"{b.label} force {ax}", rotor.global_vector(b, K[i]),
                                 rotor.global_vector(b, C[i]) if C[i].any() else None,
                                 units="N"))
            unit = np.zeros(rotor.n_dof)
            unit[rotor.dof(b.node, ax)] = 1.0
            chans.append(Channel(f"{b.label} acceleration {ax}", unit, derivative=2,
                                 units="m s-2"))
    return chans


@dataclass
class SpeedRange:
    """RMS of one channel over a speed range (:meth:`GearedRotorProblem.rms_over_speeds`).

    Attributes
    ----------
    speeds : ndarray
        Speeds [rpm].
    rms : ndarray
        RMS about the mean at each speed (NaN where the solver failed).
    status : ndarray of int8
        Harmonic-balance status per speed (0 converged).
    iterations : ndarray
        Newton iterations per speed (0: full contact, the linear solution).
    contact_loss_fraction : ndarray
        Share of the period with the teeth apart, per speed.
    """

    speeds: np.ndarray
    rms: np.ndarray
    status: np.ndarray
    iterations: np.ndarray
    contact_loss_fraction: np.ndarray

    def maximum(self) -> tuple[float, float, int]:
        """``(largest rms, its speed, status)``; a failed speed makes the status non-zero."""
        bad = np.flatnonzero(self.status != 0)
        i = int(np.nanargmax(self.rms)) if np.any(np.isfinite(self.rms)) else 0
        return float(self.rms[i]), float(self.speeds[i]), int(self.status[bad[0]]
                                                               if bad.size else 0)


@dataclass
class DynamicRange:
    """What the mesh dynamics decide over a speed range.

    Made by :meth:`GearedRotorProblem.dynamics_over_speeds`.

    Attributes
    ----------
    speeds : ndarray, (n,)
        Speeds of the grid [rpm].
    kv : ndarray, (n,)
        Dynamic factor ``K_v = max_t F(t) / P``: largest mesh force over the long period
        over the static normal mesh force ``P`` (ISO 6336-1's definition; 1 quasi-statically).
    dte_rms, dte_mesh_band_rms : ndarray, (n,)
        RMS of the DTE about its mean, and of its orders ``>= f_m / 2`` [m].
    dte_mesh_orders : ndarray, (n, M)
        DTE amplitude at the mesh harmonics ``m f_m``, ``m = 1..M`` [m].
    acceleration_mesh_orders : ndarray, (n, M)
        Amplitude of ``acceleration_channel`` at the same harmonics [m s-2].
    status, iterations, contact_loss_fraction : ndarray, (n,)
        Harmonic-balance status (0 converged), Newton iterations, share of the period with
        the teeth apart.
    peaks : dict
        Quantity -> ``(value, speed, error_bound)`` of the largest value over the range
        after the refinement (:meth:`GearedRotorProblem.dynamics_over_speeds`);
        ``error_bound`` [rpm] is the width of the final bracket of the speed.
    refinement_runs : int
        Steady states solved by the peak refinement (beyond the grid).
    refinement_status : int
        First non-zero status among the refinement's steady states (0: none failed). A failed
        one ends its peak's search early: that peak is then the largest value found before
        it (never below the grid's), with a bracket wider than asked.
    kv_run_up : ndarray, (n,)
        K_v of the run-up alone (the increasing sweep); equal to ``kv`` with
        ``sweep_direction="up"``.
    run_down_speeds : int
        Grid speeds the run-down solved (``sweep_direction="up_and_down"``; 0 otherwise).
    aperiodic_speeds : int
        Grid speeds whose K_v was read from a time integration's window (on the sweep that
        supplied it) plus the distinct speeds of the peak refinement read so
        (``aperiodic_response="window_max"``; with ``"invalid"`` such a speed keeps its
        non-zero status and counts 0 here).
    """

    speeds: np.ndarray
    kv: np.ndarray
    dte_rms: np.ndarray
    dte_mesh_band_rms: np.ndarray
    dte_mesh_orders: np.ndarray
    acceleration_mesh_orders: np.ndarray
    status: np.ndarray
    iterations: np.ndarray
    contact_loss_fraction: np.ndarray
    peaks: dict = field(default_factory=dict)
    refinement_runs: int = 0
    refinement_status: int = 0
    kv_run_up: np.ndarray | None = None
    run_down_speeds: int = 0
    aperiodic_speeds: int = 0

    def worst_status(self) -> int:
        """First non-zero harmonic-balance status of the grid (0: every speed converged)."""
        bad = np.flatnonzero(self.status != 0)
        return int(self.status[bad[0]]) if bad.size else 0


#: Quantities of :class:`DynamicRange` whose peaks are located (name -> mesh-order column).
PEAK_QUANTITIES = ("kv", "dte_mesh_band_rms", "dte_mesh_orders", "acceleration_mesh_orders")

#: Sweeps of :meth:`GearedRotorProblem.dynamics_over_speeds`: the run-up alone, or the
#: run-up and a run-down over its contact-loss ranges (both branches where the response is
#: not unique; docs/theory/geared_rotor.md, "Two periodic responses at one speed").
SWEEP_DIRECTIONS = ("up", "up_and_down")

#: What a speed whose response is not periodic reports (the time integration did not return
#: to its state within its long periods: subharmonic, quasi-periodic or chaotic rattle):
#: ``"invalid"``, its non-zero status (the sample is flagged), or ``"window_max"``, K_v as
#: the largest mesh force over the integration's last ``WINDOW_PERIODS`` long periods (what
#: a test rig recording over that window would read: on a settled response a lower bound of
#: its supremum, on a transient still under way that transient's largest force) and
#: the other quantities from the last long period's harmonics, counted in
#: ``DynamicRange.aperiodic_speeds`` (docs/theory/geared_rotor.md, "Responses that are not
#: periodic").
APERIODIC_RESPONSES = ("invalid", "window_max")

#: Per-speed quantities of a sweep's rows, as :class:`DynamicRange` names them.
_ROW_QUANTITIES = ("kv", "dte_rms", "dte_mesh_band_rms", "dte_mesh_orders",
                   "acceleration_mesh_orders")


def _local_maxima(y: np.ndarray, count: int) -> list[int]:
    """Indices of the ``count`` largest local maxima of a sampled curve (ends included)."""
    finite = np.where(np.isfinite(y), y, -np.inf)
    n = finite.size
    idx = [i for i in range(n)
           if (i == 0 or finite[i] >= finite[i - 1]) and (i == n - 1 or finite[i] >= finite[i + 1])
           and np.isfinite(finite[i])]
    idx.sort(key=lambda i: -finite[i])
    return idx[:max(count, 0)]


class GearedRotorProblem:
    """One geared rotor, one excitation, one torque: steady states at any speed.

    Parameters
    ----------
    rotor_factory : callable
        ``rotor_factory(mean_mesh_stiffness) -> Rotor`` (tags ``input``, ``output``).
    excitation : MeshExcitation
        Mesh stiffness and error over the long period.
    pinion_teeth : int
        ``z1`` (mesh frequency ``z1 n / 60``).
    damping_ratio : float
        Modal damping ratio of every elastic mode.
    n_harmonics : int
        Harmonics ``H`` of the long period in the steady state.
    cutoff_factor : float
        Keep the modes below ``cutoff_factor * H * w0`` (``w0 = 2 pi / T``).
    backlash : float
        Normal backlash [m] (``inf``: no back-flank contact).
    min_modes : int
        Keep at least this many elastic modes.
    """

    def __init__(
        self,
        rotor_factory: Callable[[float], Rotor],
        excitation: MeshExcitation,
        pinion_teeth: int,
        *,
        damping_ratio: float = 0.05,
        n_harmonics: int = 120,
        cutoff_factor: float = 1.5,
        backlash: float = math.inf,
        min_modes: int = 4,
    ) -> None:
        self.excitation = excitation
        self.rotor = rotor_factory(excitation.mean_stiffness)
        self.pinion_teeth = int(pinion_teeth)
        self.damping_ratio = float(damping_ratio)
        self.cutoff_factor = float(cutoff_factor)
        self.backlash = float(backlash)
        self.min_modes = int(min_modes)
        mesh = self.rotor.meshes[0]
        self.torque = excitation.normal_force * mesh.base_radius_pinion * math.cos(
            mesh.base_helix_angle)
        self.load = torque_load(self.rotor, self.torque)
        self.channels = default_channels(self.rotor)
        self.modes: RealModes = undamped_modes(self.rotor)
        self.prep: PreparedExcitation = prepare_excitation(excitation, n_harmonics)
        self._models: dict[int, ModalModel] = {}
        self._full: ModalModel | None = None
        self._integration_prep: KrylovExcitation | None = None  # when first integrated

    @property
    def n_harmonics(self) -> int:
        """Harmonics H of the long period."""
        return self.prep.n_harmonics

    def period(self, speed_rpm: float) -> float:
        """Long period [s] at pinion speed ``speed_rpm``."""
        if not (math.isfinite(speed_rpm) and speed_rpm > 0):
            raise ValueError(f"speed={speed_rpm!r} rpm is outside its valid range (0, inf)")
        return 60.0 * self.excitation.n_cycles / (self.pinion_teeth * speed_rpm)

    def cutoff(self, speed_rpm: float) -> float:
        """Modal cut-off [rad/s] at this speed."""
        return self.cutoff_factor * self.n_harmonics * 2.0 * math.pi / self.period(speed_rpm)

    def reduced(self, speed_rpm: float | None = None, *, cutoff: float | None = None
                ) -> ModalModel:
        """The reduced model for a speed (its cut-off) or an explicit cut-off [rad/s]."""
        wc = self.cutoff(speed_rpm) if cutoff is None else cutoff
        el = self.modes.elastic.omega
        n = max(int(np.sum(el <= wc)), min(self.min_modes, el.size))
        if n not in self._models:
            self._models[n] = reduce_rotor(
                self.rotor, self.load, self.channels, cutoff=float(el[n - 1]),
                damping_ratio=self.damping_ratio, modes=self.modes)
        return self._models[n]

    def full_damping(self) -> np.ndarray:
        """Damping matrix of the full model consistent with the reduced one."""
        return full_damping(self.rotor, self.modes, damping_ratio=self.damping_ratio)

    def steady_state(self, speed_rpm: float, *, initial: np.ndarray | None = None,
                     cutoff: float | None = None, channels: Sequence[str] | None = None,
                     **kw: object) -> PeriodicSolution:
        """Periodic steady state at ``speed_rpm`` (see :func:`solve_periodic`)."""
        with single_threaded_blas():
            model = self.reduced(speed_rpm, cutoff=cutoff)
            return solve_periodic(model, self.prep, self.period(speed_rpm),
                                  2.0 * math.pi * speed_rpm / 60.0, backlash=self.backlash,
                                  initial=initial, channels=None if channels is None
                                  else list(channels), **kw)

    def verify(self, sol: PeriodicSolution, speed_rpm: float, *, n_periods: int = 8,
               tol: float = 0.1, _restarts: int = 1) -> PeriodicSolution:
        """Check a contact-loss solution by integrating the reduced model from it.

        Integrates ``n_periods`` long periods from the harmonic-balance state and compares
        the last period, projected on the ``H`` harmonics, with the solution. The solution is
        stable when the trajectory is periodic (last two periods agree to 1e-3 of the
        peak-to-peak approach) and stays within ``tol`` of it (``tol`` allows for the
        truncation of the harmonic balance; an unstable solution drifts to another response
        at order one). If the trajectory has settled on another periodic response, Newton's
        method restarts from it (``start = "time_integration"``); if it is not periodic, the
        solution is returned with status 3.
        """
        from gearuq.rotor.time_integration import initial_state, integrate_reduced

        model = self.reduced(speed_rpm)
        T, omega = self.period(speed_rpm), 2.0 * math.pi * speed_rpm / 60.0
        N, H = self.prep.n_time, self.n_harmonics
        t_eval = (n_periods - 2) * T + np.arange(2 * N) * T / N
        y0 = initial_state(model, sol, omega)[None]
        tr = integrate_reduced(model, self.prep, [omega], [T], t_eval, y0=y0,
                               backlash=self.backlash)
        d = tr.delta[0]
        last, before = d[N:], d[:N]
        scale = max(float(np.ptp(last)), 1e-300)
        projected = np.fft.rfft(last)[:H + 1] / N
        sol.drift = float(np.abs(synthesize(projected - sol.delta, t_eval[N:], T)).max()
                          / scale)
        periodic = bool(np.abs(last - before).max() / scale < 1e-3 and tr.status[0] == 0)
        sol.stable = bool(periodic and sol.drift < tol)
        if sol.stable:
            return sol
        if periodic and _restarts > 0:
            new = self.steady_state(speed_rpm, initial=_two_sided(projected, H))
            if new.status == 0:
                new.start = "time_integration"
                return self.verify(new, speed_rpm, n_periods=n_periods, tol=tol,
                                   _restarts=_restarts - 1)
        if not periodic:
            sol.status = STATUS_APERIODIC
        return sol

    def rms_over_speeds(self, speeds_rpm: Sequence[float], *, channel: str = "dte",
                        tol: float = 1e-9, continuation: bool = True) -> SpeedRange:
        """RMS of one channel about its mean at every speed of a range: the fast path.

        What does not change along the range is done once: the excitation's Fourier data
        and its real-form blocks (:func:`prepare_excitation`), the undamped modes and the
        reduced models (one per distinct mode count), one BLAS thread limit. Per speed only
        the receptances of the mesh and of ``channel`` and one real ``(2H+1)`` solve remain;
        with contact loss Newton's method starts from the previous speed's solution.

        Parameters
        ----------
        speeds_rpm : sequence of float
            Speeds in sweep order [rpm].
        channel : str
            Output channel (default the DTE).
        tol : float
            Harmonic-balance tolerance.
        continuation : bool
            Start a contact-loss solution from the previous speed's (when that one lost
            contact too).

        Returns
        -------
        SpeedRange
        """
        speeds = np.asarray(speeds_rpm, dtype=float)
        n = speeds.size
        out = SpeedRange(speeds=speeds, rms=np.full(n, np.nan), status=np.zeros(n, np.int8),
                         iterations=np.zeros(n, np.int64),
                         contact_loss_fraction=np.full(n, np.nan))
        prev: PeriodicSolution | None = None
        with single_threaded_blas():
            for i, s in enumerate(speeds):
                T, omega = self.period(float(s)), 2.0 * math.pi * float(s) / 60.0
                model = self.reduced(float(s))
                w = 2.0 * np.pi / T * np.arange(self.n_harmonics + 1)
                rec = model.receptances(omega, w, [channel])
                init = (prev.two_sided_delta() if continuation and prev is not None
                        and prev.status == 0 and prev.branch != "full_contact" else None)
                sol = solve_periodic(model, self.prep, T, omega, backlash=self.backlash,
                                     tol=tol, initial=init, receptance=rec,
                                     channels=[channel])
                if init is not None and sol.status != 0:  # fall back to the linear start
                    sol = solve_periodic(model, self.prep, T, omega, backlash=self.backlash,
                                         tol=tol, receptance=rec, channels=[channel])
                out.status[i] = sol.status
                out.iterations[i] = sol.iterations
                out.contact_loss_fraction[i] = sol.contact_loss_fraction
                c = sol.channels[channel]
                out.rms[i] = math.sqrt(2.0 * float(np.sum(np.abs(c[1:]) ** 2)))
                prev = sol
        return out

    # ------------------------------------------------------------------ dynamics over speed
    def peak_mesh_force(self, sol: PeriodicSolution) -> float:
        """Largest mesh force over the long period [N], as the harmonic balance resolves it.

        The force is synthesised from its harmonics ``F_0..F_H`` (those the balance
        equations hold) on 16 times the AFT grid: its highest harmonic then has >= 64
        instants per period, so the sampled maximum is within 0.12 % of that harmonic's
        amplitude of the true one. The products ``k delta`` of band-limited series also
        carry orders above ``H`` that the balance does not hold (quasi-statically they
        would put a spurious ripple of 0.7 % on K_v at the paper's load with three mesh
        harmonics); they are truncation error and are left out, so that ``K_v = 1 +
        O(n^2)`` at low speed as ISO 6336-1's definition requires.
        """
        n = 16 * self.prep.n_time
        return float(np.max(_band_limited(sol.force, n)))

    def dynamics_at(self, speed_rpm: float, *, mesh_orders: int | None = None,
                    acceleration_channel: str = "bearing 1 acceleration y", tol: float = 1e-9,
                    initial: np.ndarray | None = None, aperiodic_response: str = "invalid"
                    ) -> tuple[dict, PeriodicSolution]:
        """K_v, DTE measures and mesh-order amplitudes of the steady state at one speed.

        Returns ``(values, solution)``; ``values`` has the per-speed fields of
        :class:`DynamicRange` (``dte_mesh_orders`` and ``acceleration_mesh_orders`` of
        length ``mesh_orders``, default every mesh harmonic of the steady state) and
        ``aperiodic`` (:func:`read_aperiodic`, by ``aperiodic_response``).
        """
        nc = self.excitation.n_cycles
        M = self.n_harmonics // nc if mesh_orders is None else int(mesh_orders)
        if not 1 <= M <= self.n_harmonics // nc:
            raise ValueError(f"mesh_orders={mesh_orders!r} is outside its valid range: "
                             f"integers 1..{self.n_harmonics // nc} (the mesh harmonics of "
                             "the steady state)")
        T, omega = self.period(float(speed_rpm)), 2.0 * math.pi * float(speed_rpm) / 60.0
        names = ["dte", acceleration_channel]
        with single_threaded_blas():
            model = self.reduced(float(speed_rpm))
            rec = model.receptances(omega, 2.0 * np.pi / T * np.arange(self.n_harmonics + 1),
                                    names)
            sol = solve_periodic(model, self.prep, T, omega, backlash=self.backlash, tol=tol,
                                 initial=initial, receptance=rec, channels=names)
            if initial is not None and sol.status != 0:  # fall back to the linear start
                sol = solve_periodic(model, self.prep, T, omega, backlash=self.backlash,
                                     tol=tol, receptance=rec, channels=names)
            if (sol.status == STATUS_NOT_CONVERGED and sol.branch != "full_contact"
                    and self.n_harmonics % nc == 0):
                sol = self._through_integration(model, T, omega, sol, rec, names, tol)
        dte, acc = sol.channels["dte"], sol.channels[acceleration_channel]
        at = nc * np.arange(1, M + 1)
        values = {
            "kv": self.peak_mesh_force(sol) / self.excitation.normal_force,
            "dte_rms": math.sqrt(2.0 * float(np.sum(np.abs(dte[1:]) ** 2))),
            "dte_mesh_band_rms": math.sqrt(2.0 * float(np.sum(np.abs(dte[nc // 2:]) ** 2))),
            "dte_mesh_orders": 2.0 * np.abs(dte[at]),
            "acceleration_mesh_orders": 2.0 * np.abs(acc[at]),
            "status": sol.status, "iterations": sol.iterations,
            "contact_loss_fraction": sol.contact_loss_fraction,
        }
        return read_aperiodic(values, sol, self.excitation.normal_force,
                              aperiodic_response), sol

    def _through_integration(self, model: ModalModel, T: float, omega: float,
                             failed: PeriodicSolution, rec: dict, names: list[str],
                             tol: float) -> PeriodicSolution:
        """Newton's method failed under contact loss: the reduced rotor integrated in time
        from its iterate (:func:`gearuq.rotor.sideband_balance.solve_periodic_by_integration`)
        to the periodic response, then Newton from there.

        Newton's start, not the response, was at fault where this was examined (30/30
        sample at 7950 rpm, 22 % apart: converged in 2 iterations from the integrated state,
        docs/theory/geared_rotor.md). Returns Newton's solution from the integrated state
        when it converges, else the integrated one (status 0 when periodic, 3 when the state
        did not return to itself: no periodic response on the long period was found).
        """
        if self._integration_prep is None:  # the dense balance's grid and excitation
            self._integration_prep = prepare_krylov(
                self.excitation, self.n_harmonics // self.excitation.n_cycles,
                n_time=self.prep.n_time)
        timed = solve_periodic_by_integration(model, self._integration_prep, T, omega,
                                              start=failed, backlash=self.backlash,
                                              receptance=rec, channels=names)
        if timed.status == STATUS_NOT_CONVERGED:
            return failed
        if timed.status == 0:
            again = solve_periodic(model, self.prep, T, omega, backlash=self.backlash,
                                   tol=tol, initial=timed.two_sided_delta(), receptance=rec,
                                   channels=names)
            if again.status == 0:
                again.start = "time_integration"
                return again
        return timed

    def _solve_from(self, speed_rpm: float, state: object, kw: dict) -> tuple[dict, object]:
        """One steady state of a sweep started from ``state``: ``(values, next state)``.

        ``state`` is what an earlier call returned (``None``: the linear start). Here it is
        the two-sided ``delta`` of a converged contact-loss solution; subclasses whose
        solvers keep more (GMRES's start) return and restore their own.
        """
        values, sol = self.dynamics_at(speed_rpm, initial=state, **kw)
        return values, (sol.two_sided_delta() if sol.status == 0
                        and sol.branch != "full_contact" else None)

    def _run_down(self, speeds: np.ndarray, up: list[dict], up_states: list,
                  kw: dict) -> tuple[list[dict | None], list]:
        """The run-down over the run-up's contact-loss ranges: the other branch's rows.

        Starts at the top speed of each range of consecutive run-up speeds with the teeth
        apart, from the run-up's state there, and goes down speed by speed, each started
        from the last, until both sweeps are in full contact at one speed (where the linear
        response, unique, joins them). Where the mesh's softening bends a resonance toward
        lower speeds, the run-up jumps onto the large response only at the top of its range
        of existence and the run-down follows it to its peak. Returns rows and states
        (``None`` where the run-down did not solve).
        """
        n = speeds.size
        rows: list[dict | None] = [None] * n
        states: list = [None] * n
        active, state = False, None
        for i in range(n - 1, -1, -1):
            # a speed read from a time window has no periodic state to start from
            apart = (_quality(up[i]) == 2 and up[i]["contact_loss_fraction"] > 0)
            if not active:
                if apart:  # the top of a contact-loss range: the run-up's state there
                    active, state = True, up_states[i]
                continue
            rows[i], state = self._solve_from(float(speeds[i]), state, kw)
            states[i] = state
            if not apart and rows[i]["contact_loss_fraction"] == 0:
                active = False
        return rows, states

    def dynamics_over_speeds(
        self,
        speeds_rpm: Sequence[float],
        *,
        mesh_orders: int | None = None,
        acceleration_channel: str = "bearing 1 acceleration y",
        refine: Sequence[str] = PEAK_QUANTITIES,
        peaks_refined: int = 2,
        speed_tol: float = 1.0,
        tol: float = 1e-9,
        continuation: bool = True,
        sweep_direction: str = "up",
        aperiodic_response: str = "invalid",
    ) -> DynamicRange:
        """K_v, the mesh-band DTE and the mesh-order responses over a speed grid, peaks resolved.

        The grid is swept in order (with contact loss Newton's method starts from the
        previous speed's solution). With ``sweep_direction="up_and_down"`` the contact-loss
        ranges of that run-up are swept down as well (:meth:`_run_down`) and each quantity
        at each speed is the larger of the two sweeps: where two periodic responses exist
        (the teeth separate on one of them) the larger counts, as a gearbox that slows down
        through the range, or is kicked onto it, sees it. For every quantity in ``refine``
        (each mesh order separately) the ``peaks_refined`` largest local maxima of the grid
        are then located by golden-section search between the grid neighbours, to
        ``speed_tol`` rpm, each steady state started from the maximum's own grid speed on the
        sweep it came from (from the nearest grid speed's if that fails); the reported
        maximum is the largest value evaluated (grid or refinement), so it never falls below
        the grid's. A resonance narrower than the grid step can still be missed if no grid
        speed sees its flank; the grid step should stay below the half-power width
        ``2 zeta f_n`` of the lowest mode expressed in speed (docs/theory/geared_rotor.md).

        Parameters
        ----------
        speeds_rpm : sequence of float
            Increasing speeds of the grid [rpm].
        mesh_orders : int, optional
            Mesh harmonics reported (default all of the steady state's).
        acceleration_channel : str
            Channel whose mesh-order amplitudes are reported (default bearing 1, y: the
            direction of Yuan, Liu and Liu's Figs. 12 and 16).
        refine : sequence of str
            Quantities whose peaks are located (subset of ``PEAK_QUANTITIES``).
        peaks_refined : int
            Local maxima of the grid refined per quantity (0: the grid's maximum only).
        speed_tol : float
            Width [rpm] of the final bracket of each refined peak.
        tol : float
            Harmonic-balance tolerance.
        continuation : bool
            Start contact-loss solutions from the neighbouring speed's.
        sweep_direction : {"up", "up_and_down"}
            The run-up alone, or with the run-down over its contact-loss ranges
            (``SWEEP_DIRECTIONS``).
        aperiodic_response : {"invalid", "window_max"}
            What a speed without a periodic response reports (``APERIODIC_RESPONSES``).

        Returns
        -------
        DynamicRange
        """
        speeds = np.asarray(speeds_rpm, dtype=float)
        if speeds.ndim != 1 or speeds.size < 2 or np.any(np.diff(speeds) <= 0):
            raise ValueError("speeds_rpm must be an increasing 1-D grid of >= 2 speeds "
                             f"(got {speeds_rpm!r})")
        unknown = sorted(set(refine) - set(PEAK_QUANTITIES))
        if unknown:
            raise ValueError(f"refine={unknown!r} is outside its valid set {PEAK_QUANTITIES}")
        if not (math.isfinite(speed_tol) and speed_tol > 0):
            raise ValueError(f"speed_tol={speed_tol!r} rpm is outside its valid range (0, inf)")
        if sweep_direction not in SWEEP_DIRECTIONS:
            raise ValueError(f"sweep_direction={sweep_direction!r} is outside its valid set "
                             f"{SWEEP_DIRECTIONS}")
        if aperiodic_response not in APERIODIC_RESPONSES:
            raise ValueError(f"aperiodic_response={aperiodic_response!r} is outside its valid "
                             f"set {APERIODIC_RESPONSES}")
        kw = {"mesh_orders": mesh_orders, "acceleration_channel": acceleration_channel,
              "tol": tol, "aperiodic_response": aperiodic_response}
        up, up_states = [], []
        state: object = None
        with single_threaded_blas():
            for s in speeds:
                values, state = self._solve_from(float(s), state if continuation else None,
                                                 kw)
                up.append(values)
                up_states.append(state)
            sweeps, states = [up], [up_states]
            if sweep_direction == "up_and_down":
                down, down_states = self._run_down(speeds, up, up_states, kw)
                sweeps.append(down)
                states.append(down_states)
            out, origin = _envelope(speeds, sweeps)
            cache: dict[tuple[float, int], dict] = {}

            def evaluate(s: float, sweep: int, peak: int) -> dict:
                """The steady state at ``s`` on the branch of the peak at grid index ``peak``."""
                if (s, sweep) not in cache:
                    # from the peak's own state: between two grid speeds a nearer one can
                    # sit on the other branch (a jump); then from the nearest grid speed's
                    values = self._solve_from(s, states[sweep][peak] if continuation
                                              else None, kw)[0]
                    near = int(np.argmin(np.abs(speeds - s)))
                    if ((values["status"] != 0 or values["aperiodic"]) and continuation
                            and near != peak):
                        # a periodic response from the other start is preferred to a
                        # window, a window to a failure
                        other = self._solve_from(s, states[0][near], kw)[0]
                        values = other if _quality(other) > _quality(values) else values
                    cache[s, sweep] = values
                return cache[s, sweep]

            for name in PEAK_QUANTITIES:
                curves = getattr(out, name)
                columns = [None] if curves.ndim == 1 else range(curves.shape[1])
                for c in columns:
                    curve = curves if c is None else curves[:, c]
                    key = name if c is None else f"{name}_{c + 1}"
                    came_from = origin[name] if c is None else origin[name][:, c]
                    out.peaks[key] = _refined_peak(
                        speeds, curve,
                        (lambda s, i, n=name, c=c, w=came_from:
                         _pick(evaluate(s, int(w[i]), i), n, c)),
                        peaks_refined if name in refine else 0, speed_tol)
            out.refinement_runs = len(cache)
            failed = [int(v["status"]) for v in cache.values() if int(v["status"]) != 0]
            out.refinement_status = failed[0] if failed else 0
            out.aperiodic_speeds += len({s for (s, _), v in cache.items()
                                         if v["status"] == 0 and v["aperiodic"]})
        return out

    def sweep(self, speeds_rpm: Sequence[float], *, continuation: bool = True,
              verify: bool = False, **kw: object) -> list[PeriodicSolution]:
        """Steady states along ``speeds_rpm`` in the given order.

        Parameters
        ----------
        speeds_rpm : sequence of float
            Speeds in sweep order (increasing for an up sweep, decreasing for a down sweep).
        continuation : bool
            Start each speed from the previous solution (how a sweep lands on one branch
            and jumps where it ends).
        verify : bool
            Check contact-loss solutions by time integration (:meth:`verify`); unstable
            ones are replaced by the periodic response the integration settles on.
        **kw
            Passed to :meth:`steady_state`.
        """
        out: list[PeriodicSolution] = []
        for s in speeds_rpm:
            init = out[-1].two_sided_delta() if (continuation and out) else None
            sol = self.steady_state(float(s), initial=init, **kw)
            if init is not None and sol.status != 0:  # fall back to the linear start
                sol = self.steady_state(float(s), **kw)
            if verify and sol.branch != "full_contact" and sol.status in (0, 1):
                sol = self.verify(sol, float(s))
            out.append(sol)
        return out


def _envelope(speeds: np.ndarray, sweeps: list[list[dict | None]]
              ) -> tuple[DynamicRange, dict[str, np.ndarray]]:
    """The :class:`DynamicRange` of one or more sweeps' rows: each quantity the largest.

    ``sweeps[0]`` (the run-up) has a row at every speed, later sweeps where they solved
    (``None`` elsewhere). A converged row of a later sweep replaces the run-up's value where
    it is larger (or the run-up's failed); a failed row of a later sweep makes the speed's
    status its own (that response is not known). Returns the range and, per quantity, the
    sweep each value came from.
    """
    up = sweeps[0]
    values = {q: np.array([r[q] for r in up], dtype=float) for q in _ROW_QUANTITIES}
    origin = {q: np.zeros(v.shape, dtype=np.int8) for q, v in values.items()}
    status = np.array([r["status"] for r in up], dtype=np.int8)
    iterations = np.array([r["iterations"] for r in up], dtype=np.int64)
    apart = np.array([r["contact_loss_fraction"] for r in up], dtype=float)
    kv_up = values["kv"].copy()
    solved = 0
    for k, rows in enumerate(sweeps[1:], start=1):
        for i, row in enumerate(rows):
            if row is None:
                continue
            solved += 1
            iterations[i] += int(row["iterations"])
            if int(row["status"]) != 0:
                if status[i] == 0:
                    status[i] = int(row["status"])
                continue
            base_ok = status[i] == 0
            for q in _ROW_QUANTITIES:
                new = np.asarray(row[q], dtype=float)
                take = (new > values[q][i]) | (not base_ok) | ~np.isfinite(values[q][i])
                values[q][i] = np.where(take, new, values[q][i])
                origin[q][i] = np.where(take, k, origin[q][i])
            apart[i] = max(apart[i], float(row["contact_loss_fraction"]))
    # grid speeds whose K_v came from a window (of the sweep that supplied it)
    aperiodic = sum(int(sweeps[k][i]["aperiodic"]) for i, k in enumerate(origin["kv"]))
    out = DynamicRange(speeds=speeds, kv=values["kv"], dte_rms=values["dte_rms"],
                       dte_mesh_band_rms=values["dte_mesh_band_rms"],
                       dte_mesh_orders=values["dte_mesh_orders"],
                       acceleration_mesh_orders=values["acceleration_mesh_orders"],
                       status=status, iterations=iterations, contact_loss_fraction=apart,
                       kv_run_up=kv_up, run_down_speeds=solved, aperiodic_speeds=aperiodic)
    return out, origin


def read_aperiodic(values: dict, sol: PeriodicSolution, static_force: float,
                   aperiodic_response: str) -> dict:
    """Apply ``aperiodic_response`` (``APERIODIC_RESPONSES``) to one speed's ``values``.

    Sets ``values["aperiodic"]`` (1 where the values were read from the window of a
    response that is not periodic) and, with ``"window_max"``, K_v from the window's largest
    force and the speed's status 0. Returns ``values``.
    """
    values["aperiodic"] = 0
    if (aperiodic_response == "window_max" and sol.status == STATUS_APERIODIC
            and math.isfinite(sol.window_peak_force)):
        values.update(kv=sol.window_peak_force / static_force, status=0, aperiodic=1)
    return values


def _quality(values: dict) -> int:
    """0 a failed speed, 1 one read from a time window, 2 a periodic steady state."""
    return 0 if values["status"] != 0 else 1 if values["aperiodic"] else 2


def _band_limited(one_sided: np.ndarray, n: int) -> np.ndarray:
    """Real signal of one-sided harmonics ``c_0..c_m`` on ``n`` equally spaced instants."""
    c = np.zeros(n // 2 + 1, dtype=complex)
    m = min(np.asarray(one_sided).size, n // 2)
    c[:m] = np.asarray(one_sided)[:m]
    return np.fft.irfft(c * n, n=n)


def _pick(values: dict, name: str, column: int | None) -> float:
    v = values[name] if values["status"] == 0 else math.nan
    return float(v if column is None or not np.ndim(v) else v[column])


_GOLDEN = (math.sqrt(5.0) - 1.0) / 2.0


def _refined_peak(speeds: np.ndarray, curve: np.ndarray,
                  f: Callable[[float, int], float],
                  count: int, speed_tol: float) -> tuple[float, float, float]:
    """``(largest value, its speed, bracket width [rpm])`` after refining ``count`` maxima.

    Golden-section search between the grid neighbours of each local maximum ``i``, each
    value ``f(speed, i)``; a failed evaluation (NaN) ends that search with the best value
    found so far.
    """
    finite = np.isfinite(curve)
    if not finite.any():
        return math.nan, math.nan, math.nan
    i0 = int(np.nanargmax(curve))
    best = (float(curve[i0]), float(speeds[i0]),
            float(speeds[min(i0 + 1, speeds.size - 1)] - speeds[max(i0 - 1, 0)]))
    for i in _local_maxima(curve, count):
        a, b = float(speeds[max(i - 1, 0)]), float(speeds[min(i + 1, speeds.size - 1)])
        found = (float(curve[i]), float(speeds[i]))
        x1, x2 = b - _GOLDEN * (b - a), a + _GOLDEN * (b - a)
        f1, f2 = f(x1, i), f(x2, i)
        while b - a > speed_tol and math.isfinite(f1) and math.isfinite(f2):
            if f1 >= f2:
                b, x2, f2 = x2, x1, f1
                x1 = b - _GOLDEN * (b - a)
                f1 = f(x1, i)
            else:
                a, x1, f1 = x1, x2, f2
                x2 = a + _GOLDEN * (b - a)
                f2 = f(x2, i)
        for x, v in ((x1, f1), (x2, f2)):
            if math.isfinite(v) and v > found[0]:
                found = (v, x)
        if found[0] > best[0] or (found[0] == best[0] and i == i0):
            best = (found[0], found[1], b - a)
    return best
