"""The deterministic analysis of a gear stage (``gearuq run STAGE.toml``) and its report.

Steps, each a function that receives what it needs and returns what it made:

1. :func:`geometry_table` and :func:`iso6336_table`: ISO 21771 geometry and ISO 6336-1
   method B stiffness;
2. :func:`mesh_cycle`: LTCA static transmission error and mesh stiffness (secant, tangent)
   over one mesh cycle at the design torque, with the stage's designed modifications (the
   same on every tooth, so one mesh cycle is exact; pitch deviations and the long period of a
   hunting-tooth pair are not part of it);
3. :func:`run_up`: the stage's FE geared rotor (:func:`gearuq.rotor.stage.stage_rotor`) with
   the stage's mesh stiffness, driven by the STE's mesh harmonics over the speed range (linear
   modal superposition, modal damping), the dynamic mesh force per harmonic and speed, and
   the resonances marked (speeds where ``h z1 n / 60`` meets a natural frequency that loads
   the mesh);
4. :func:`rotor_run_up`: the ``geared_rotor`` model built from the stage (per-bearing
   stiffness, per-gear classes and reliefs, the long period of a hunting-tooth pair) at its
   nominal values, its harmonic-balance steady states over the speed range: K_v and the DTE
   at the mesh harmonics per speed, each peak located between the grid speeds;
5. :func:`analyse_stage` gathers them in one Dataset (units, provenance);
   :func:`write_stage_results` writes it as netCDF, CSV tables and one self-contained HTML
   report (figures embedded as base64 PNG).

Choices and their reasons: docs/stage.md.
"""

from __future__ import annotations

import base64
import datetime as _dt
import hashlib
import html
import io
import math
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from gearuq._version import __version__
from gearuq.model import status_meanings

__all__ = ["analyse_stage", "geometry_table", "iso6336_table", "mesh_cycle", "reliability",
           "rotor_run_up", "run_up", "write_stage_results"]

_GEOMETRY = (  # (name, units, description)
    ("d1", "mm", "pinion reference diameter z1 m_n / cos(beta)"),
    ("d2", "mm", "wheel reference diameter"),
    ("db1", "mm", "pinion base diameter"),
    ("db2", "mm", "wheel base diameter"),
    ("da1", "mm", "pinion tip diameter"),
    ("da2", "mm", "wheel tip diameter"),
    ("df1", "mm", "pinion root diameter"),
    ("df2", "mm", "wheel root diameter"),
    ("centre_distance", "mm", "working centre distance"),
    ("alpha_wt_deg", "degree", "working transverse pressure angle"),
    ("beta_b_deg", "degree", "base helix angle"),
    ("pbt", "mm", "transverse base pitch"),
    ("pbn", "mm", "normal base pitch"),
    ("g_alpha", "mm", "length of path of contact"),
    ("eps_alpha", "1", "transverse contact ratio"),
    ("eps_beta", "1", "overlap ratio"),
    ("eps_gamma", "1", "total contact ratio"),
)
_ISO = (
    ("q_prime", "mm um/N", "minimum flexibility of a tooth pair q'"),
    ("c_th", "N/(mm um)", "theoretical single stiffness c'_th"),
    ("C_M", "1", "correction factor"),
    ("C_R", "1", "gear blank factor"),
    ("C_B", "1", "basic rack factor"),
    ("c_prime", "N/(mm um)", "single stiffness c'"),
    ("c_gamma_alpha", "N/(mm um)", "mesh stiffness c_gamma_alpha"),
    ("c_gamma_beta", "N/(mm um)", "mesh stiffness c_gamma_beta"),
    ("k_mesh", "N/um", "c_gamma_alpha b"),
)


def geometry_table(stage: Any) -> xr.Dataset:
    """ISO 21771 geometry of the stage as a table over ``geometry_quantity``."""
    s = stage.summary()
    return xr.Dataset(
        {"geometry": ("geometry_quantity", [s[n] for n, _, _ in _GEOMETRY],
                      {"long_name": "ISO 21771 geometry", "source": "gearuq.gears.geometry "
                       "(ISO 21771 closed forms)"})},
        coords={"geometry_quantity": [n for n, _, _ in _GEOMETRY],
                "geometry_units": ("geometry_quantity", [u for _, u, _ in _GEOMETRY]),
                "geometry_meaning": ("geometry_quantity", [d for _, _, d in _GEOMETRY])})


def iso6336_table(stage: Any) -> xr.Dataset:
    """ISO 6336-1 method B stiffness of the stage as a table over ``iso_quantity``."""
    from gearuq.gears.iso6336 import mesh_stiffness

    ms = mesh_stiffness(stage.pair).as_dict()
    ms["k_mesh"] = ms["k_mesh_N_per_m"] * 1e-6
    return xr.Dataset(
        {"iso6336": ("iso_quantity", [float(ms[n]) for n, _, _ in _ISO],
                     {"long_name": "ISO 6336-1 method B tooth stiffness (solid blanks)",
                      "source": "gearuq.gears.iso6336.mesh_stiffness"})},
        coords={"iso_quantity": [n for n, _, _ in _ISO],
                "iso_units": ("iso_quantity", [u for _, u, _ in _ISO]),
                "iso_meaning": ("iso_quantity", [d for _, _, d in _ISO])})


def mesh_cycle(stage: Any, *, positions_per_cycle: int = 24, n_pts: int = 20) -> xr.Dataset:
    """LTCA over one mesh cycle at the design torque (designed modifications, no errors)."""
    from gearuq.gears.stage import design_mesh_cycle

    torque = stage.operation.torque_design
    ds = design_mesh_cycle(stage, positions_per_cycle=positions_per_cycle, n_pts=n_pts)
    src = (f"gearuq.gears.ltca.ltca at {torque:g} N m, {positions_per_cycle} positions x "
           f"{n_pts} points, the stage's reliefs and crowning, no pitch deviations")
    tau = ds["tau"].values
    out = xr.Dataset(coords={"tau": ("tau", tau, {"units": "mesh cycles",
                                                   "long_name": "mesh position"})})
    for name, units, text in (("ste", "um", "static transmission error (normal)"),
                              ("lpms", "N/um", "mesh stiffness, secant P / STE"),
                              ("lpms_tangent", "N/um", "mesh stiffness, tangent dP/dSTE"),
                              ("n_teeth_in_contact", "1", "tooth pairs in contact")):
        out[f"ltca_{name}"] = ("tau", np.asarray(ds[name].values, dtype=float),
                               {"units": units, "long_name": text, "source": src})
    out["ltca_status"] = ("tau", np.asarray(ds["status"].values, dtype=np.int8),
                          {"long_name": "LTCA status per position (0: converged)"})
    return out


def _modes(rotor: Any, mesh_stiffness: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Elastic modes: natural frequencies [Hz], mass-normalised shapes, mesh energy share."""
    from gearuq.rotor.modal import undamped_modes

    modes = undamped_modes(rotor)
    keep = ~modes.rigid
    omega, shapes = modes.omega[keep], modes.shapes[:, keep]
    v = rotor.mesh_vector()
    mesh_energy = mesh_stiffness * (v @ shapes) ** 2 / np.maximum(omega**2, 1e-300)
    return omega / (2 * math.pi), shapes, mesh_energy


def run_up(stage: Any, ste_um: np.ndarray, mesh_stiffness: float, *, n_speeds: int = 1000,
           n_harmonics: int = 3, damping_ratio: float = 0.03,
           max_element_length: float = 0.02) -> xr.Dataset:
    """Dynamic mesh force over the speed range from the STE's mesh harmonics.

    Linear modal superposition on the stage's FE rotor (undamped modes at rest, modal
    damping ``damping_ratio``, gyroscopic terms left out): the mesh harmonic ``h`` of the STE,
    ``e_h``, enters as the force ``k e_h v`` along the mesh direction ``v``; the mesh approach
    is ``v . q`` and the dynamic mesh force ``k (v . q - e_h)`` (0 at low speed, ``k e_h`` far
    above every mode). A resonance is a local maximum of the first harmonic's force above
    1.5 x its high-speed value, or of a higher harmonic's.
    """
    from gearuq.rotor.stage import stage_rotor

    if not 1 <= n_harmonics < len(ste_um) // 2:
        raise ValueError(f"n_harmonics={n_harmonics!r} is outside its valid range "
                         f"[1, {len(ste_um) // 2 - 1}] (positions per cycle / 2)")
    rotor = stage_rotor(stage, mesh_stiffness, max_element_length=max_element_length)
    f_n, shapes, mesh_energy = _modes(rotor, mesh_stiffness)
    v = rotor.mesh_vector()
    modal_v = v @ shapes  # v . phi_r
    coef = np.fft.rfft(np.asarray(ste_um, dtype=float)) / len(ste_um)
    e_h = 2.0 * coef[1:n_harmonics + 1] * 1e-6  # complex amplitude [m] of harmonic h
    speeds = np.linspace(*stage.operation.speed, n_speeds)
    z1 = stage.teeth[0]
    harmonics = np.arange(1, n_harmonics + 1)
    f_exc = harmonics[None, :] * z1 * speeds[:, None] / 60.0  # (speed, h) [Hz]
    w, wr = 2 * math.pi * f_exc[..., None], 2 * math.pi * f_n[None, None, :]
    receptance = (modal_v**2 / (wr**2 - w**2 + 2j * damping_ratio * wr * w)).sum(axis=-1)
    approach = mesh_stiffness * e_h[None, :] * receptance  # v . q  [m]
    force = mesh_stiffness * (approach - e_h[None, :])
    out = xr.Dataset(coords={
        "speed": ("speed", speeds, {"units": "rpm", "long_name": "pinion speed"}),
        "harmonic": ("harmonic", harmonics, {"long_name": "mesh harmonic h"}),
        "mode": ("mode", np.arange(1, f_n.size + 1), {"long_name": "elastic mode"})})
    src = (f"gearuq.stage_analysis.run_up: FE rotor (gearuq.rotor.stage), modal "
           f"superposition, modal damping {damping_ratio:g}, STE harmonics of the LTCA")
    out["mesh_frequency"] = ("speed", z1 * speeds / 60.0,
                             {"units": "Hz", "long_name": "mesh frequency z1 n / 60"})
    out["dynamic_mesh_force"] = (("speed", "harmonic"), np.abs(force),
                                 {"units": "N", "long_name": "amplitude of the dynamic mesh "
                                  "force at mesh harmonic h", "source": src})
    out["mesh_approach_amplitude"] = (("speed", "harmonic"), np.abs(approach) * 1e6,
                                      {"units": "um", "long_name": "amplitude of the dynamic "
                                       "mesh approach (DTE, normal) at harmonic h",
                                       "source": src})
    out["ste_harmonic"] = ("harmonic", np.abs(e_h) * 1e6,
                           {"units": "um", "long_name": "STE amplitude at mesh harmonic h"})
    out["natural_frequency"] = ("mode", f_n, {"units": "Hz", "long_name": "undamped natural "
                                              "frequency at rest", "source": src})
    out["mesh_energy_share"] = ("mode", np.clip(mesh_energy, 0.0, 1.0),
                                {"units": "1", "long_name": "share of the mode's strain energy "
                                 "in the mesh spring"})
    rows = _resonances(out, mesh_stiffness)
    for name, units, text in (("resonance_speed", "rpm", "speed of the peak"),
                              ("resonance_harmonic", "1", "mesh harmonic h of the peak"),
                              ("resonance_frequency", "Hz", "h z1 n / 60 at the peak"),
                              ("resonance_mode_frequency", "Hz", "nearest natural frequency "
                               "of a mode with >= 1 % of its strain energy in the mesh"),
                              ("resonance_force", "N", "dynamic mesh force at the peak")):
        out[name] = ("resonance", np.array([r[name] for r in rows], dtype=float),
                     {"units": units, "long_name": text})
    out.attrs["rotor_dofs"] = int(rotor.n_dof)
    return out


#: a mode "strains the mesh" when at least this share of its strain energy is in the mesh
MESH_MODE_SHARE = 0.01


def _resonances(ds: xr.Dataset, mesh_stiffness: float) -> list[dict[str, float]]:
    """Local maxima of each harmonic's dynamic force that stand above its high-speed value,
    each with the nearest natural frequency of a mode that strains the mesh."""
    rows = []
    f_n = ds["natural_frequency"].values
    share = ds["mesh_energy_share"].values
    loaded = f_n[share >= MESH_MODE_SHARE] if np.any(share >= MESH_MODE_SHARE) else f_n
    for j, h in enumerate(ds["harmonic"].values):
        force = ds["dynamic_mesh_force"].values[:, j]
        far = ds["ste_harmonic"].values[j] * 1e-6  # e_h: force far above the modes / k
        peaks = np.flatnonzero((force[1:-1] > force[:-2]) & (force[1:-1] >= force[2:])) + 1
        for i in peaks:
            if force[i] < 1.5 * far * mesh_stiffness:
                continue
            f = float(ds["mesh_frequency"].values[i] * h)
            rows.append({"resonance_speed": float(ds["speed"].values[i]),
                         "resonance_harmonic": float(h), "resonance_frequency": f,
                         "resonance_mode_frequency": float(loaded[np.argmin(abs(loaded - f))]),
                         "resonance_force": float(force[i])})
    return rows


#: outputs of the geared rotor's run-up -> (name in the stage's Dataset, meaning)
_ROTOR_OUTPUTS = {
    "kv_over_speed": ("rotor_kv", "dynamic factor K_v (largest mesh force over the long "
                      "period / static mesh force) at each speed"),
    "kv_max": ("rotor_kv_max", "largest K_v over the range, peak located"),
    "speed_at_kv_max": ("rotor_speed_at_kv_max", "speed of rotor_kv_max"),
    "dte_mesh_order_over_speed": ("rotor_dte_mesh_order", "DTE amplitude at mesh harmonic "
                                  "m f_m at each speed"),
    "dte_mesh_order_max": ("rotor_dte_mesh_order_max", "largest DTE amplitude at m f_m, peak "
                           "located"),
    "speed_at_dte_mesh_order_max": ("rotor_speed_at_dte_mesh_order_max",
                                    "speed of rotor_dte_mesh_order_max"),
}


def rotor_run_up(stage: Any, *, n_speeds: int = 32, positions_per_cycle: int = 24,
                 n_pts: int = 20, mesh_harmonics: int = 2) -> xr.Dataset:
    """The ``geared_rotor`` model of the stage over its speed range, at its nominal values.

    Harmonic-balance steady states of the FE rotor with the LTCA's mesh stiffness and error
    over the long period (``n_speeds`` grid speeds, each peak located by golden-section
    search), so the run-up carries the parametric excitation, the per-bearing stiffness and
    the per-gear classes and reliefs that :func:`run_up`'s modal superposition leaves out.
    Variables ``rotor_*`` on the coordinates ``rotor_speed`` and ``rotor_mesh_harmonic``;
    the sample's status (0: every steady state converged) in ``rotor_status``, its meaning
    in the attrs. A stage the model refuses raises its ValueError, naming the reason.
    """
    from gearuq.registry import get_model

    model = get_model("geared_rotor", stage=stage)
    lo, hi = stage.operation.speed
    options = dict(positions_per_cycle=positions_per_cycle, n_pts=n_pts, n_speeds=n_speeds,
                   speed_min=lo, speed_max=hi, range_mesh_harmonics=mesh_harmonics)
    res = model.response({}, None, outputs=list(_ROTOR_OUTPUTS), **options)
    out = xr.Dataset(coords={
        "rotor_speed": ("rotor_speed", res["range_speed"].values,
                        {"units": "rpm", "long_name": "pinion speed of the rotor's run-up"}),
        "rotor_mesh_harmonic": ("rotor_mesh_harmonic", res["mesh_harmonic"].values,
                                {"units": "1", "long_name": "mesh harmonic m of m f_m"})})
    src = (f"gearuq model geared_rotor (stage {stage.name}) at its nominal values, "
           + ", ".join(f"{k}={v:g}" for k, v in options.items()))
    dims = {"range_speed": "rotor_speed", "mesh_harmonic": "rotor_mesh_harmonic"}
    for name, (target, meaning) in _ROTOR_OUTPUTS.items():
        var = res[name].isel(sample=0, drop=True)
        out[target] = (tuple(dims[d] for d in var.dims), var.values,
                       {"units": var.attrs.get("units", "1"), "long_name": meaning,
                        "source": src})
    status = int(res["status"].values[0])
    meanings = status_meanings(res["status"])
    out["rotor_status"] = ((), status, {"units": "1", "long_name": "status of the rotor's "
                                        "run-up: " + meanings.get(status, str(status))})
    return out


def analyse_stage(stage: Any, *, positions_per_cycle: int = 24, n_pts: int = 20,
                  n_speeds: int = 1000, n_harmonics: int = 3, damping_ratio: float = 0.03,
                  progress: bool = True, stage_file: str | None = None,
                  rotor_speeds: int = 0) -> xr.Dataset:
    """The whole deterministic analysis of a stage in one Dataset (see the module text).

    ``rotor_speeds`` > 0 adds :func:`rotor_run_up` on that many speeds (with the same LTCA
    settings); a stage the geared rotor refuses is noted in the attr ``rotor_run_up``.
    """
    from tqdm.auto import tqdm

    def whole(value: Any) -> bool:
        return isinstance(value, (int, np.integer)) and not isinstance(value, bool)

    if not (whole(n_speeds) and n_speeds >= 2):
        raise ValueError(f"n_speeds={n_speeds!r} is outside its valid range: integers >= 2 "
                         "(a range has two ends)")
    if not (whole(rotor_speeds) and (rotor_speeds == 0 or rotor_speeds >= 2)):
        raise ValueError(f"rotor_speeds={rotor_speeds!r} is outside its valid range: 0 (skip "
                         "the geared rotor's run-up) or integers >= 2")
    steps = ["geometry", "ISO 6336-1", "LTCA over a mesh cycle", "mesh stiffness",
             "FE rotor run-up", "geared rotor run-up"]
    bar = tqdm(total=len(steps), desc="stage", disable=not progress, unit="step")
    parts = []
    bar.set_postfix_str(steps[0])
    parts.append(geometry_table(stage))
    bar.update()
    bar.set_postfix_str(steps[1])
    parts.append(iso6336_table(stage))
    bar.update()
    bar.set_postfix_str(steps[2])
    cycle = mesh_cycle(stage, positions_per_cycle=positions_per_cycle, n_pts=n_pts)
    parts.append(cycle)
    bar.update()
    bar.set_postfix_str(steps[3])
    stiffness = stage.mesh_stiffness(positions_per_cycle=positions_per_cycle, n_pts=n_pts)
    bar.update()
    if stage.pinion_shaft is not None and stage.wheel_shaft is not None:
        bar.set_postfix_str(steps[4])
        up = run_up(stage, cycle["ltca_ste"].values, stiffness.value_N_per_m,
                    n_speeds=n_speeds, n_harmonics=n_harmonics, damping_ratio=damping_ratio)
        parts.append(up)
    bar.update()
    rotor_note = "not run (rotor_speeds=0)"
    if rotor_speeds > 0:
        bar.set_postfix_str(steps[5])
        try:
            parts.append(rotor_run_up(stage, n_speeds=rotor_speeds,
                                      positions_per_cycle=positions_per_cycle, n_pts=n_pts))
            rotor_note = f"geared_rotor on {rotor_speeds} speeds"
        except ValueError as exc:  # a stage the model refuses: said in the report
            rotor_note = f"not run: {exc}"
    bar.update()
    bar.close()
    ds = xr.merge(parts, combine_attrs="drop_conflicts")
    ds.attrs = {}
    ds.attrs.update({
        "title": f"gearuq stage analysis: {stage.name}",
        "stage_name": stage.name, "stage_description": stage.description,
        "stage_source": stage.source, "stage_toml": stage.to_toml(),
        "stage_sha256": hashlib.sha256(stage.to_toml().encode()).hexdigest(),
        "stage_file": stage_file or "none",
        "mesh_stiffness_N_per_um": stiffness.value,
        "mesh_stiffness_definition": (
            f"{stiffness.source}: " + ("LTCA mean tangent stiffness dP/dSTE over one mesh "
                                       "cycle at the design torque, normal direction"
                                       if stiffness.source == "ltca" else
                                       "ISO 6336-1 method B c_gamma_alpha b")),
        "ltca_secant_mean_N_per_um": stiffness.secant_mean,
        "ltca_tangent_mean_N_per_um": stiffness.tangent_mean,
        "ltca_over_iso_secant_transverse": stiffness.ratio,
        "ltca_iso_band": list(stiffness.band),
        "ltca_iso_within_band": int(stiffness.within_band),
        "design_torque_N_m": stage.operation.torque_design,
        "speed_range_rpm": list(stage.operation.speed),
        "long_period_mesh_cycles": stage.long_period_mesh_cycles,
        "hunting_tooth": int(stage.is_hunting_tooth),
        "run_up_settings": f"n_speeds={n_speeds}, n_harmonics={n_harmonics}, "
                           f"damping_ratio={damping_ratio}",
        "ltca_settings": f"positions_per_cycle={positions_per_cycle}, n_pts={n_pts}",
        "rotor_run_up": rotor_note,
        "gearuq_version": __version__,
        "created": _dt.datetime.now(_dt.UTC).isoformat(timespec="seconds"),
    })
    return ds


# ---------------------------------------------------------------------- reliability
def reliability_problem(stage: Any) -> dict[str, Any]:
    """The stage's ``[reliability]`` and ``[random]`` tables made into a model, a space, a
    band and settings, checked before anything runs.

    A wrong name (the model, its output, a random parameter, an option, the method) or a
    law that cannot be built fails here, named by its table, instead of after the geometry,
    the LTCA and the run-up. :func:`reliability` runs what this returns.
    """
    from gearuq.failure.api import METHODS
    from gearuq.failure.modes import Band
    from gearuq.registry import get_model
    from gearuq.space import ParameterSpace

    cfg = stage.reliability_settings
    if not cfg:  # a stage that has the table has its model and output (GearStage checks)
        raise ValueError(f"stage {stage.name!r} has no [reliability] table")
    try:
        model = get_model(cfg["model"], stage=stage)
    except ValueError as exc:
        raise ValueError(f"[reliability] model={cfg['model']!r}: {exc}") from None
    if cfg["output"] not in model.output_names:
        raise ValueError(f"[reliability] output={cfg['output']!r} is not an output of model "
                         f"{model.name!r}; valid: {', '.join(model.output_names)}")
    try:
        space = ParameterSpace(stage.random_inputs)
    except (ValueError, TypeError) as exc:
        raise type(exc)(f"[random] {exc}") from None
    unknown = [n for n in space.names if n not in model.parameter_names]
    if unknown:
        raise ValueError(f"[random] {unknown}: not parameters of model {model.name!r}; valid: "
                         f"{', '.join(model.parameter_names)}")
    method = cfg.get("method", "subset")
    if method not in METHODS:
        raise ValueError(f"[reliability] method={method!r} is not a method; valid: "
                         f"{', '.join(METHODS)}")
    try:
        band = Band(cfg["output"], lower=cfg.get("lower"), upper=cfg.get("upper"))
        meta = model.output(cfg["output"])
        band.check_reach(meta.valid_min, meta.units)
        opts = dict(cfg.get("model_options", {}))
        model.validate_options(opts)
    except (ValueError, TypeError) as exc:
        raise type(exc)(f"[reliability] {exc}") from None
    return {"model": model, "space": space, "band": band, "options": opts,
            "seed": cfg.get("seed", 0), "method": method, "n_base": cfg.get("n_base", 128),
            "method_settings": cfg.get("method_settings", {})}


def reliability(stage: Any, *, progress: bool = False,
                problem: dict[str, Any] | None = None) -> tuple[xr.Dataset, xr.Dataset]:
    """The failure probability and the Sobol' ranking of the stage's ``[reliability]``.

    The model named there is built from the stage; the random inputs are the stage's
    ``[random]`` tables; failure is the output leaving ``[lower, upper]``. The probability
    comes from :func:`gearuq.failure_probability` (``method``, default ``"subset"``, with its
    interval and status), the ranking from :func:`gearuq.sobol_indices` (Saltelli, bootstrap
    intervals, ``n_base`` (D + 2) runs) on the same output. ``problem``: what
    :func:`reliability_problem` returned for this stage (built here when not given).
    """
    from gearuq.engines.sensitivity import sobol_indices
    from gearuq.failure.api import failure_probability

    pr = reliability_problem(stage) if problem is None else problem
    report = failure_probability(pr["model"], pr["space"], pr["band"], method=pr["method"],
                                 rng=pr["seed"], model_options=pr["options"],
                                 **pr["method_settings"])
    sobol = sobol_indices(pr["model"], pr["space"], n_base=int(pr["n_base"]),
                          outputs=[pr["band"].output], rng=pr["seed"],
                          model_options=pr["options"], progress=progress)
    return report, sobol


def _reliability_html(report: xr.Dataset, sobol: xr.Dataset, cfg: dict[str, Any]) -> str:
    band = f"[{cfg.get('lower', '-inf')}, {cfg.get('upper', 'inf')}]"
    rows = [("model", cfg["model"], "built from the stage"),
            ("output and allowed band", f"{cfg['output']} in {band}", "[reliability]"),
            ("method", report.attrs.get("method", cfg.get("method", "subset")),
             "gearuq.failure_probability")]
    for name in ("pf", "pf_lower", "pf_upper", "cov_pf", "beta", "n_model_runs", "status"):
        if name in report:
            rows.append((name, report[name].values.item() if report[name].size == 1 else
                         report[name].values, report[name].attrs.get("long_name", "")))
    meaning = report.attrs.get("status_reason") or report.attrs.get("status_meaning", "")
    if meaning:
        rows.append(("status in words", meaning, ""))
    out = "<h2>Reliability</h2>" + _html_table(rows, ("quantity", "value", "provenance"))
    names = [str(n) for n in sobol["parameter"].values] if "parameter" in sobol.coords else []
    if names:
        keys = [k for k in ("S1", "S1_conf", "ST", "ST_conf") if k in sobol]
        table = [(n, *(float(np.ravel(sobol[k].sel(parameter=n).values)[0]) for k in keys))
                 for n in names]
        table.sort(key=lambda r: -r[keys.index("ST") + 1] if "ST" in keys else 0.0)
        out += ("<h3>Sobol' ranking (gearuq.sobol_indices, Saltelli, bootstrap intervals)"
                "</h3>" + _html_table(table, ("parameter", *keys)))
    return out


# ---------------------------------------------------------------------- writing
def _write_csv(table: xr.Dataset, path: Path) -> Path:
    """One CSV table with ``name [units]`` headers, as :func:`gearuq.export_csv` writes them
    (the one place the stage tables are written; not ``export_csv`` itself, whose layout
    differs: a folder per group of dimensions, see docs/stage.md)."""
    from gearuq.io import _csv_header

    frame = table.to_dataframe()
    frame = frame.rename(columns={c: _csv_header(str(c), table[c].attrs) for c in frame.columns})
    frame.index = frame.index.set_names(
        [_csv_header(str(n), table[n].attrs if n in table.coords else {})
         for n in frame.index.names])
    frame.to_csv(path)
    return path


def _figure_png(fig: Any) -> str:
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=110, bbox_inches="tight")
    return base64.b64encode(buf.getvalue()).decode("ascii")


def _figures(ds: xr.Dataset) -> list[tuple[str, str]]:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    out = []
    fig, ax = plt.subplots(1, 2, figsize=(10, 3.4))
    ax[0].plot(ds["tau"], ds["ltca_ste"], marker=".")
    ax[0].set(xlabel="mesh position [mesh cycles]", ylabel="STE [um]",
              title="static transmission error")
    ax[1].plot(ds["tau"], ds["ltca_lpms"], label="secant")
    ax[1].plot(ds["tau"], ds["ltca_lpms_tangent"], label="tangent")
    ax[1].set(xlabel="mesh position [mesh cycles]", ylabel="mesh stiffness [N/um]",
              title="mesh stiffness")
    ax[1].legend()
    out.append(("LTCA over one mesh cycle at the design torque", _figure_png(fig)))
    plt.close(fig)
    if "dynamic_mesh_force" in ds:
        fig, ax = plt.subplots(figsize=(10, 3.8))
        for h in ds["harmonic"].values:
            ax.semilogy(ds["speed"], ds["dynamic_mesh_force"].sel(harmonic=h),
                        label=f"mesh harmonic {h}")
        for s, f in zip(ds["resonance_speed"].values, ds["resonance_force"].values,
                        strict=True):
            ax.plot(s, f, "kv")
        ax.set(xlabel="pinion speed [rpm]", ylabel="dynamic mesh force [N]",
               title="run-up (triangles: resonances)")
        ax.legend()
        out.append(("Run-up: dynamic mesh force per mesh harmonic", _figure_png(fig)))
        plt.close(fig)
    if "rotor_kv" in ds:
        fig, ax = plt.subplots(1, 2, figsize=(10, 3.4))
        ax[0].plot(ds["rotor_speed"], ds["rotor_kv"], marker=".")
        ax[0].plot(ds["rotor_speed_at_kv_max"], ds["rotor_kv_max"], "kv")
        ax[0].set(xlabel="pinion speed [rpm]", ylabel="K_v [1]", title="dynamic factor")
        for m in ds["rotor_mesh_harmonic"].values:
            ax[1].semilogy(ds["rotor_speed"], ds["rotor_dte_mesh_order"].sel(
                rotor_mesh_harmonic=m) * 1e6, marker=".", label=f"{m} f_m")
        ax[1].set(xlabel="pinion speed [rpm]", ylabel="DTE amplitude [um]",
                  title="DTE at the mesh harmonics")
        ax[1].legend()
        out.append(("Geared rotor run-up (harmonic balance; triangle: located peak)",
                    _figure_png(fig)))
        plt.close(fig)
    return out


def _html_table(rows: list[tuple], header: tuple[str, ...]) -> str:
    head = "".join(f"<th>{html.escape(h)}</th>" for h in header)
    body = "".join("<tr>" + "".join(f"<td>{html.escape(_fmt(c))}</td>" for c in r) + "</tr>"
                   for r in rows)
    return f"<table><tr>{head}</tr>{body}</table>"


def _fmt(value: Any) -> str:
    if isinstance(value, float | np.floating):
        return f"{value:.6g}"
    return str(value)


def _report_html(ds: xr.Dataset, extra: str = "") -> str:
    a = ds.attrs
    parts = [f"<h1>{html.escape(a['title'])}</h1>",
             f"<p>{html.escape(a['stage_description'])}<br>Source: "
             f"{html.escape(a['stage_source'])}<br>gearuq {a['gearuq_version']}, "
             f"{a['created']}, stage SHA-256 {a['stage_sha256'][:16]}...</p>"]
    parts.append("<h2>Geometry (ISO 21771)</h2>")
    parts.append(_html_table([(q, v, u, m, "ISO 21771 closed form (gearuq.gears.geometry)")
                              for q, v, u, m in zip(
        ds["geometry_quantity"].values, ds["geometry"].values, ds["geometry_units"].values,
        ds["geometry_meaning"].values, strict=True)],
        ("quantity", "value", "units", "meaning", "provenance")))
    parts.append("<h2>ISO 6336-1 method B stiffness</h2>")
    parts.append(_html_table([(q, v, u, m, "ISO 6336-1:2019 method B (gearuq.gears.iso6336)")
                              for q, v, u, m in zip(
        ds["iso_quantity"].values, ds["iso6336"].values, ds["iso_units"].values,
        ds["iso_meaning"].values, strict=True)],
        ("quantity", "value", "units", "meaning", "provenance")))
    parts.append("<h2>The stage's mesh stiffness</h2>")
    parts.append(_html_table([
        ("mesh stiffness used by the models", a["mesh_stiffness_N_per_um"], "N/um",
         a["mesh_stiffness_definition"]),
        ("LTCA mean secant", a["ltca_secant_mean_N_per_um"], "N/um",
         "LTCA, " + a["ltca_settings"]),
        ("LTCA mean tangent", a["ltca_tangent_mean_N_per_um"], "N/um",
         "LTCA, " + a["ltca_settings"]),
        ("LTCA / ISO (secant, transverse)", a["ltca_over_iso_secant_transverse"], "1",
         f"measured band {list(a['ltca_iso_band'])}: "
         f"{'within' if a['ltca_iso_within_band'] else 'OUTSIDE'}"),
    ], ("quantity", "value", "units", "provenance")))
    if "resonance" in ds.dims or "resonance_speed" in ds:
        parts.append("<h2>Run-up resonances</h2>")
        parts.append(_html_table([tuple(ds[k].values[i] for k in (
            "resonance_speed", "resonance_harmonic", "resonance_frequency",
            "resonance_mode_frequency", "resonance_force"))
            for i in range(ds["resonance_speed"].size)],
            ("speed [rpm]", "harmonic", "h z1 n/60 [Hz]", "natural frequency [Hz]",
             "dynamic mesh force [N]")))
        parts.append("<p>Provenance: " + html.escape(ds["dynamic_mesh_force"].attrs["source"])
                     + "; " + html.escape(a["run_up_settings"]) + ".</p>")
    if "rotor_kv" in ds:
        parts.append("<h2>Geared rotor run-up</h2>")
        rows = [("largest K_v", float(ds["rotor_kv_max"]), "1",
                 float(ds["rotor_speed_at_kv_max"]))]
        rows += [(f"largest DTE amplitude at {m} f_m", float(v) * 1e6, "um", float(n))
                 for m, v, n in zip(ds["rotor_mesh_harmonic"].values,
                                    ds["rotor_dte_mesh_order_max"].values,
                                    ds["rotor_speed_at_dte_mesh_order_max"].values,
                                    strict=True)]
        parts.append(_html_table(rows, ("quantity", "value", "units", "at speed [rpm]")))
        parts.append("<p>Provenance: " + html.escape(ds["rotor_kv"].attrs["source"]) + "; "
                     + html.escape(ds["rotor_status"].attrs["long_name"]) + ".</p>")
    elif a.get("rotor_run_up", "").startswith("not run: "):
        parts.append("<h2>Geared rotor run-up</h2><p>" + html.escape(a["rotor_run_up"])
                     + "</p>")
    parts.append(extra)
    for title, png in _figures(ds):
        parts.append(f"<h2>{html.escape(title)}</h2><img alt='{html.escape(title)}' "
                     f"src='data:image/png;base64,{png}'>")
    parts.append("<h2>Stage file</h2><pre>" + html.escape(a["stage_toml"]) + "</pre>")
    style = ("body{font-family:sans-serif;max-width:70em;margin:auto}table{border-collapse:"
             "collapse}td,th{border:1px solid #bbb;padding:2px 6px;text-align:left}")
    return (f"<!DOCTYPE html><html><head><meta charset='utf-8'><title>"
            f"{html.escape(a['title'])}</title><style>{style}</style></head><body>"
            + "\n".join(parts) + "</body></html>\n")


def write_stage_results(ds: xr.Dataset, out: str | Path, *,
                        reliability: tuple[xr.Dataset, xr.Dataset] | None = None,
                        reliability_settings: dict[str, Any] | None = None) -> dict[str, Path]:
    """Write the analysis as ``stage.nc``, CSV tables and ``report.html`` in ``out``.

    With ``reliability`` (the report and the Sobol' indices of :func:`reliability`) also
    ``reliability.nc``, ``sobol.nc``, their CSV tables and a section of the report.
    """
    from gearuq.io import save

    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    paths = {"netcdf": save(ds, out / "stage.nc")}
    extra_html = ""
    if reliability is not None:
        report, sobol = reliability
        paths["reliability"] = save(report, out / "reliability.nc")
        paths["sobol"] = save(sobol, out / "sobol.nc")
        scalars = [k for k in report.data_vars if report[k].ndim == 0]
        paths["reliability_csv"] = _write_csv(report[scalars].expand_dims("run"),
                                              out / "reliability.csv")
        paths["sobol_csv"] = _write_csv(sobol[[k for k in sobol.data_vars
                                               if "parameter" in sobol[k].dims]],
                                        out / "sobol.csv")
        extra_html = _reliability_html(report, sobol, reliability_settings or {})
    tables = {"geometry": ["geometry", "geometry_units"], "iso6336": ["iso6336", "iso_units"],
              "mesh_cycle": ["ltca_ste", "ltca_lpms", "ltca_lpms_tangent",
                             "n_teeth_in_contact" if "n_teeth_in_contact" in ds else
                             "ltca_n_teeth_in_contact"]}
    if "dynamic_mesh_force" in ds:
        tables |= {"run_up": ["dynamic_mesh_force", "mesh_approach_amplitude"],
                   "modes": ["natural_frequency", "mesh_energy_share"],
                   "resonances": ["resonance_speed", "resonance_harmonic",
                                  "resonance_frequency", "resonance_mode_frequency",
                                  "resonance_force"]}
    if "rotor_kv" in ds:
        tables["rotor_run_up"] = ["rotor_kv", "rotor_dte_mesh_order"]
    for name, variables in tables.items():
        paths[name] = _write_csv(ds[variables], out / f"{name}.csv")
    paths["report"] = out / "report.html"
    paths["report"].write_text(_report_html(ds, extra_html), encoding="utf-8")
    return paths
