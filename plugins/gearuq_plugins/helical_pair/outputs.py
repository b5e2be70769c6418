"""The helical pair's outputs: their declarations, which states they need, and their values.

Declarations (:data:`OUTPUTS`) are plain metadata (no numba), read by the package's
``__init__`` at import. :func:`needed_states` tells the integration which states to store,
and :func:`assemble` turns the stored states into the requested outputs; it receives the
set-up and the trajectory and returns new arrays (nothing flows back).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from gearuq.model import Output, bounded_below
from gearuq_plugins.helical_pair.layout import I_B5, I_V, INTERNAL_LENGTH, N_DOF, N_STATE
from gearuq_plugins.helical_pair.physics import (
    ROTATIONS,
    PairSystem,
    error_excitation,
    mesh_force,
    static_state,
    stiffness_factor,
)

#: DOF names in state order: (symbol, SI unit, meaning)
DOFS = (
    ("x_p", "m", "pinion radial displacement (along the line of centres)"),
    ("y_p", "m", "pinion tangential displacement"),
    ("z_p", "m", "pinion axial displacement"),
    ("theta_py", "rad", "pinion swing (rocking about the tangential axis)"),
    ("theta_pz", "rad", "pinion torsional vibration angle"),
    ("x_g", "m", "gear radial displacement"),
    ("y_g", "m", "gear tangential displacement"),
    ("z_g", "m", "gear axial displacement"),
    ("theta_gy", "rad", "gear swing (rocking about the tangential axis)"),
    ("theta_gz", "rad", "gear torsional vibration angle (positive in the driven sense)"),
)

#: Status codes of this model beyond gearuq.model's 0..4 (always declared, so that every
#: chunk of a run carries the same flag attributes).
STATUS_STATIC_NOT_FINITE = 16
STATUS_LENGTH_SCALE_ZERO = 17
STATUS_KV_NO_LOAD = 18
STATUS_MEANINGS = {
    STATUS_STATIC_NOT_FINITE: "static_equilibrium_not_finite",
    STATUS_LENGTH_SCALE_ZERO: "length_scale_b5_is_zero",
    STATUS_KV_NO_LOAD: "kv_undefined_without_torque",
}


def _declare() -> tuple[Output, ...]:
    outs = []
    for i, (_, _, meaning) in enumerate(DOFS):
        outs.append(Output(f"p{i + 1}", "1", ("sample", "time"),
                           f"nondimensional {meaning} p{i + 1} = u / L "
                           f"(Li, Hu and Han's p{i + 1})"))
    for i in range(N_DOF):
        outs.append(Output(f"dp{i + 1}", "1", ("sample", "time"),
                           f"nondimensional velocity d p{i + 1} / d tau"))
    for i, (_, _, meaning) in enumerate(DOFS):
        outs.append(Output(f"v{i + 1}", "1", ("sample", "time"),
                           f"vibration of p{i + 1} about the sample's own static equilibrium "
                           f"(p{i + 1} - p{i + 1},static; {meaning})"))
    for name, unit, meaning in DOFS:
        outs.append(Output(name, unit, ("sample", "time"), meaning))
    for name, unit, meaning in DOFS:
        outs.append(Output(f"{name}_dot", f"{unit} s-1", ("sample", "time"), f"rate of {meaning}"))
    for name, unit, meaning in DOFS:
        outs.append(Output(f"vib_{name}", unit, ("sample", "time"),
                           f"vibration about the static equilibrium: {meaning}"))
    outs += [
        Output("mesh_force", "N", ("sample", "time"),
               "dynamic mesh force along the normal line of action (k f(delta) + c delta'; "
               "gated and clipped with mesh_damping='in_contact')"),
        Output("dte", "m", ("sample", "time"),
               "dynamic transmission error: relative normal displacement of the contact points"),
        Output("mesh_deflection", "m", ("sample", "time"),
               "mesh deflection delta = dte - e(t) (contact when |delta| > b5)"),
        Output("kv", "1", ("sample",),
               "dynamic factor: largest mesh_force over the output instants / the static "
               "normal mesh force T / (r_p cos a_n cos b) (ISO 6336-1 K_v; 1 quasi-static)"),
        Output("omega_n", "rad s-1", ("sample",), "time scale sqrt(k_m / m_e)"),
        Output("mesh_frequency", "Hz", ("sample",), "mesh frequency z1 n / 60"),
        Output("k_mesh", "N m-1", ("sample",), "mean mesh stiffness (ISO 6336-1 method B)"),
        Output("contact_ratio", "1", ("sample",), "transverse contact ratio epsilon_alpha"),
        Output("m_p", "kg", ("sample",), "pinion mass (solid cylinder blank)"),
        Output("m_g", "kg", ("sample",), "gear mass (solid cylinder blank)"),
        Output("length_unit", "m", ("sample",),
               "length L of the nondimensional outputs p, dp, v (option length_scale)"),
    ]
    # properties of the pair that cannot be negative (kv can: a mesh force that is a damping
    # force alone, with mesh_damping="always" and the teeth apart)
    return bounded_below(outs, ["omega_n", "mesh_frequency", "k_mesh", "contact_ratio", "m_p",
                                "m_g", "length_unit"])


OUTPUTS = _declare()

# output name -> (state index, kind); kind: "nondim" (p, dp), "si" (u, u_dot),
# "vib" (v_i), "vib_si" (vib_<dof>)
_STATE_OUTPUTS: dict[str, tuple[int, str]] = {}
for _i, (_name, _, _) in enumerate(DOFS):
    _STATE_OUTPUTS[f"p{_i + 1}"] = (_i, "nondim")
    _STATE_OUTPUTS[f"dp{_i + 1}"] = (N_DOF + _i, "nondim")
    _STATE_OUTPUTS[f"v{_i + 1}"] = (_i, "vib")
    _STATE_OUTPUTS[_name] = (_i, "si")
    _STATE_OUTPUTS[f"{_name}_dot"] = (N_DOF + _i, "si")
    _STATE_OUTPUTS[f"vib_{_name}"] = (_i, "vib_si")
MESH_OUTPUTS = ("mesh_force", "dte", "mesh_deflection", "kv")
_NONDIMENSIONAL = ("nondim", "vib")


def needed_states(outputs: list[str]) -> np.ndarray:
    """Indices of the states the integration must store for ``outputs`` (empty: none)."""
    if any(o in MESH_OUTPUTS for o in outputs):
        return np.arange(N_STATE)
    return np.array(sorted({_STATE_OUTPUTS[o][0] for o in outputs if o in _STATE_OUTPUTS}),
                    dtype=np.int64)


def output_length_unit(system: PairSystem, length_scale: float | str) -> np.ndarray:
    """Length unit L (n,) [m] of the nondimensional outputs: a fixed length or each b5."""
    if length_scale == "b5":
        return system.coef[:, I_B5] * INTERNAL_LENGTH
    return np.full(system.n_samples, float(length_scale))


def _si_scale(system: PairSystem, state: int) -> np.ndarray:
    """Factor from an internal state (units of INTERNAL_LENGTH, tau) to SI, per sample."""
    dof = state % N_DOF
    scale = np.full(system.n_samples, INTERNAL_LENGTH)
    if dof in ROTATIONS:  # arc length on the pitch radius -> angle
        scale = scale / (system.gear["r_p"] if dof < 5 else system.gear["r_g"])
    if state >= N_DOF:  # velocity: d/dt = omega_n d/dtau
        scale = scale * system.gear["omega_n"]
    return scale


def assemble(
    system: PairSystem,
    outputs: list[str],
    *,
    states: np.ndarray | None,
    save: np.ndarray,
    tau: np.ndarray | None,
    length_scale: float | str,
    status: np.ndarray,
) -> tuple[dict[str, np.ndarray], np.ndarray]:
    """Values of the requested outputs, and the status updated for output-level failures.

    Parameters
    ----------
    system : PairSystem
    outputs : list of str
    states : ndarray (n, n_t, n_save) or None
        Stored states in internal units (NaN after a failure), None when no state is needed.
    save : ndarray of int
        State index of each column of ``states``.
    tau : ndarray, (n_t,) or (n, n_t), or None
        Nondimensional output instants.
    length_scale : float or "b5"
        Unit of the nondimensional outputs (option ``length_scale``).
    status : ndarray of int8
        Per-sample status of the integration (not modified; a new array is returned).
    """
    status = status.copy()
    data: dict[str, np.ndarray] = {}
    col = {int(s): j for j, s in enumerate(save)}
    nondim = any(_STATE_OUTPUTS.get(o, (0, ""))[1] in _NONDIMENSIONAL for o in outputs)
    unit = output_length_unit(system, length_scale)
    to_output = INTERNAL_LENGTH / np.where(unit > 0, unit, np.nan)
    if nondim:
        _flag(status, ~(unit > 0), STATUS_LENGTH_SCALE_ZERO)
    static = None
    if any(_STATE_OUTPUTS.get(o, (0, ""))[1] in ("vib", "vib_si") for o in outputs):
        static = static_state(system.coef)
        _flag(status, ~np.isfinite(static).all(axis=1), STATUS_STATIC_NOT_FINITE)
    for o in outputs:
        if o not in _STATE_OUTPUTS:
            continue
        state, kind = _STATE_OUTPUTS[o]
        q = states[:, :, col[state]]
        if kind in ("vib", "vib_si"):
            q = q - static[:, state][:, None]
        scale = to_output if kind in _NONDIMENSIONAL else _si_scale(system, state)
        data[o] = q * scale[:, None]
    if any(o in MESH_OUTPUTS for o in outputs):
        data.update(_mesh_outputs(system, states, tau, outputs))
    if "kv" in outputs:  # a dynamic factor needs a static load to be a factor of
        _flag(status, ~(system.gear["static_mesh_force"] > 0), STATUS_KV_NO_LOAD)
    per_sample = {
        "omega_n": system.gear["omega_n"], "mesh_frequency": system.gear["mesh_frequency"],
        "k_mesh": system.gear["k_mesh"], "contact_ratio": system.gear["eps_alpha"],
        "m_p": system.gear["m_p"], "m_g": system.gear["m_g"], "length_unit": unit,
    }
    data.update({o: per_sample[o] for o in outputs if o in per_sample})
    return data, status


def _flag(status: np.ndarray, bad: np.ndarray, code: int) -> None:
    """Give ``code`` to the samples in ``bad`` that have no earlier failure."""
    status[bad & (status == 0)] = code


def _mesh_outputs(system: PairSystem, states: np.ndarray, tau: np.ndarray,
                  outputs: list[str]) -> dict[str, np.ndarray]:
    """Mesh force, DTE and mesh deflection (SI) from all 20 stored states."""
    coef = system.coef
    n, nt = states.shape[:2]
    tau2 = np.broadcast_to(tau, (n, nt))
    v = coef[:, I_V:I_V + N_DOF]
    rel = np.einsum("nti,ni->nt", states[:, :, :N_DOF], v)
    drel = np.einsum("nti,ni->nt", states[:, :, N_DOF:], v)
    eps, deps = error_excitation(tau2, coef)
    d = rel - eps
    out = {"dte": rel * INTERNAL_LENGTH, "mesh_deflection": d * INTERNAL_LENGTH}
    if "mesh_force" in outputs or "kv" in outputs:
        fm = mesh_force(stiffness_factor(tau2, coef), d, drel - deps, coef)
        out["mesh_force"] = fm * (system.gear["k_mesh"] * INTERNAL_LENGTH)[:, None]
        static = system.gear["static_mesh_force"]
        out["kv"] = out["mesh_force"].max(axis=1) / np.where(static > 0, static, np.nan)
    return {k: val for k, val in out.items() if k in outputs}


def describe_scale(length_scale: float | str) -> dict[str, Any]:
    """Dataset attributes that say what the nondimensional outputs are measured in."""
    return {"length_scale": "b5 (each sample's half backlash, as the seed)"
            if length_scale == "b5" else f"{float(length_scale):g} m",
            "internal_length_m": INTERNAL_LENGTH}
