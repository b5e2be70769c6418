"""Integration of the helical-pair equations for a batch of samples.

Receives the set-up (:class:`~gearuq_plugins.helical_pair.physics.PairSystem`), the
nondimensional output instants and the solver options; returns a :class:`Trajectory`. The
compiled kernel and the integrator are imported here, on first use, so that importing the
plugin stays light.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from gearuq_plugins.helical_pair.layout import I_GATE, I_OMEGA, N_SWITCH, N_SWITCH_GATED
from gearuq_plugins.helical_pair.outputs import STATUS_STATIC_NOT_FINITE
from gearuq_plugins.helical_pair.physics import PairSystem, initial_state

#: Steps per mesh period at least, with the gated mesh (see :func:`integrate`).
GATED_STEPS_PER_PERIOD = 8
#: CPU seconds of the integrator run as plain Python (gearuq._firstcall), per unit of tau and
#: per step, measured on the nominal pair (tau in [0, 200]: 351 steps, 1.5 s).
INTERPRETED_CPU_PER_TAU = 8e-3
INTERPRETED_CPU_PER_STEP = 4.5e-3


@dataclass
class Trajectory:
    """Stored states of every sample at the output instants (internal units).

    Attributes
    ----------
    states : ndarray, shape (n, n_t, n_save)
        NaN after the instant at which a sample failed (and for samples never integrated).
    save : ndarray of int
        State index of each column of ``states``.
    status : ndarray of int8
        Per-sample status (0 ok; 1-3 from the integrator; 5 static initial state not finite).
    attrs : dict
        Solver settings for the provenance.
    extra : dict
        Per-sample diagnostics ``n_steps`` and ``n_events`` as (dims, values, attrs).
    """

    states: np.ndarray
    save: np.ndarray
    status: np.ndarray
    attrs: dict[str, Any] = field(default_factory=dict)
    extra: dict[str, tuple] = field(default_factory=dict)


def interpreted_cpu(span: float, max_step: float, n_samples: int) -> float:
    """Estimated CPU seconds of ``n_samples`` samples over ``tau`` in ``[0, span]`` with the
    integrator run as plain Python: the nominal pair's rate, or the step bound's count of
    steps when ``max_step`` forces more (the gated mesh)."""
    steps = span / max_step if max_step > 0.0 else 0.0
    return n_samples * max(INTERPRETED_CPU_PER_TAU * span, INTERPRETED_CPU_PER_STEP * steps)


def check_fixed_step(method: str, step: float, coef: np.ndarray, span: float) -> None:
    """Refuse a fixed step at which the method is unstable on the pair in contact.

    Without error control nothing else would notice: a step past the explicit method's
    stability region amplifies the fastest modes at every step, and the run ends with a
    finite, wrong response and status 0 (``fixed_step=100`` on tau in [0, 20]: ``v1`` of
    1088 where the adaptive solution is 0.26). Checked on the eigenvalues of the pair
    linearised in contact at its stiffest and softest mesh
    (:func:`~gearuq_plugins.helical_pair.physics.contact_eigenvalues`): ``|R(h lambda)|``
    of one step may exceed 1 by at most what keeps the spurious growth below a factor 2 over
    the run's ``span / h`` steps. Stability is necessary, not sufficient: a stable step can
    still be inaccurate (docs/theory/helical_pair.md).
    """
    from gearuq.ode.tableaux import largest_stable_step, step_amplification
    from gearuq_plugins.helical_pair.physics import contact_eigenvalues

    def growth(h: float) -> float:  # per step: at most a factor 2 over the run's steps
        return 2.0 ** (h / max(span, h)) - 1.0

    lam = contact_eigenvalues(coef)
    amp = np.where(lam.real <= 0.0, step_amplification(method, step, lam), 0.0)
    worst = amp.max(axis=1)
    refused = np.flatnonzero(worst > 1.0 + growth(step))
    if refused.size == 0:
        return
    # the step the refused samples allow, from their fastest eigenvalues
    fast = lam[refused[:100]]
    fast = np.take_along_axis(fast, np.argsort(-np.abs(fast), axis=1)[:, :6], axis=1)
    allowed = largest_stable_step(method, fast, growth(step))
    allowed = largest_stable_step(method, fast, growth(allowed))
    i = int(refused[np.argmax(worst[refused])])
    raise ValueError(
        f"fixed_step={step:g} is outside its valid range (0, {allowed:.3g}] for these samples: "
        f"{method}'s step is unstable on the pair in contact there (one step multiplies its "
        f"fastest mode by {worst[i]:.3g} at sample {i}; {refused.size} of {coef.shape[0]} "
        "samples refused). Take a smaller step, or the adaptive default (fixed_step=None)")


def integrate(
    system: PairSystem,
    tau: np.ndarray,
    save: np.ndarray,
    *,
    method: str,
    rtol: float,
    atol: float,
    max_step: float,
    max_steps: int,
    fixed_step: float | None,
    events: bool,
    freeze_sides: bool,
    initial: str,
    parallel: bool,
) -> Trajectory:
    """Integrate every sample from tau = 0 and store the states ``save`` at ``tau``.

    ``tau`` is (n_t,) shared or (n, n_t) per sample. A sample whose initial state is not
    finite is not integrated: its rows stay NaN and its status is
    ``STATUS_STATIC_NOT_FINITE``. See :func:`gearuq.ode.solve_batch` for the solver options;
    with ``events`` the dead-zone (and, gated, force-clipping) switchings are located, with
    ``freeze_sides`` every stage of a step stays on the branch that holds at its start.

    With the gated mesh the step is bounded by 1/8 of the shortest mesh period of the batch
    (or ``max_step`` if smaller): the flank forces that switch the clipping depend on the
    velocities and can change sign and back within one long DOP853 step, and a sign change
    that falls between the samples of a step is not seen (docs/theory/helical_pair.md §8).
    """
    from gearuq.ode import solve_batch
    from gearuq_plugins.helical_pair import kernel

    n = system.n_samples
    y0 = initial_state(system.coef, initial)
    ok = np.isfinite(y0).all(axis=1)
    status = np.where(ok, 0, STATUS_STATIC_NOT_FINITE).astype(np.int8)
    n_t = tau.shape[-1]
    states = np.full((n, n_t, save.size), np.nan)
    n_steps = np.zeros(n, dtype=np.int64)
    n_events = np.zeros(n, dtype=np.int64)
    attrs: dict[str, Any] = {"solver_events": int(events)}
    if ok.any():
        rows = slice(None) if ok.all() else np.flatnonzero(ok)
        if fixed_step is not None:
            check_fixed_step(method, float(fixed_step), system.coef[rows], float(np.max(tau)))
        gated = bool(system.coef[0, I_GATE])
        if gated:
            mesh_period = 2.0 * np.pi / system.coef[rows, I_OMEGA]
            max_step = min(max_step, float(mesh_period.min()) / GATED_STEPS_PER_PERIOD)
        n_switch = (N_SWITCH_GATED if gated else N_SWITCH) if events else 0
        frozen = bool(events and freeze_sides)
        res = solve_batch(
            kernel.rhs_sides if frozen else kernel.rhs, y0[rows], system.coef[rows],
            tau if tau.ndim == 1 else tau[rows], t0=0.0, method=method, rtol=rtol, atol=atol,
            max_step=max_step, max_steps=max_steps, fixed_step=fixed_step,
            switch=kernel.switch if events else None, n_switch=n_switch, save=save,
            parallel=parallel, freeze_sides=frozen,
            interpreted_cpu=interpreted_cpu(float(np.max(tau)), max_step, len(y0[rows])),
        )
        states[rows] = res.y
        status[rows] = res.status
        n_steps[rows] = res.n_steps
        n_events[rows] = res.n_events
        attrs.update({f"solver_{k}": v for k, v in res.settings().items()})
        attrs["solver_events"] = int(events)
    extra = {
        "n_steps": ("sample", n_steps, {"units": "1", "long_name": "accepted steps"}),
        "n_events": ("sample", n_events,
                     {"units": "1", "long_name": "located switchings (dead zones, clipping)"}),
    }
    return Trajectory(states=states, save=save, status=status, attrs=attrs, extra=extra)
