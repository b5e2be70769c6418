"""Analog of Table 3 of Li, Hu and Han: Monte Carlo vibration reliability of their helical
gear pair (Chang Li, Mingyong Hu, Xing Han, "A non-linear random vibration reliability analysis
method for multi degree of freedom helical gear driven system").

The study that ``gearuq demo`` runs (registered as ``helical_pair_reliability`` in the
``gearuq.studies`` entry-point group; ``gearuq study helical_pair_reliability [--quick]`` and
``python -m gearuq_studies.helical_pair_reliability`` run it too). It uses only the public
API (the model comes from the registry), so it is
also the worked example of a reliability study:

1. the paper's Table 2 parameter space (six independent normals), 10^4 samples;
2. the ten nondimensional vibrations ``v1..v10`` (``p_i`` about the sample's own static
   equilibrium, computed by the model inside each chunk) over the response window tau in
   [0, 200] (the paper's "t = 200 s" is nondimensional time);
3. allowable bands: each DOF's vibration about its own static equilibrium may reach at most
   ``MARGIN`` times the nominal design's largest vibration (max |p - p_static| over the
   window) -- a design-margin criterion fixed from one deterministic nominal run before any
   random sample is drawn; and, for the Table 3 analog, two-sided tolerance bands at
   tau = 200 (mean +- 2.5 std of an independent pilot run, since the paper gives no limits);
4. instantaneous and first-passage reliability per DOF and for the series system, the
   generalised index beta = Phi^-1(R) with Wilson intervals, the mean-value (Cornell) index
   beside it, and the best-fit distribution of each DOF's deviation magnitude at tau = 200
   (a Table 3 analog), with R(t) curves and fitted-pdf-over-histogram figures.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import math
import shutil
import time
from pathlib import Path
from typing import Any

import numpy as np

from gearuq import plot
from gearuq.failure.report import describe_status

#: Design margin of the allowable bands over the nominal steady vibration amplitude.
MARGIN = 1.0
#: Margins of the first-passage sweep in the report.
MARGIN_SWEEP = (1.0, 1.0025, 1.005, 1.01)
MARGIN_RULE = (f"|v| <= {MARGIN} x the nominal design's largest vibration "
               "(max |p - p_static| over tau in [0, 200]), at every instant of the window")
#: Tolerance bands of the Table 3 analog: pilot mean +- TOL_K pilot std of the signed v(200).
TOL_K = 2.5
#: Samples of the quick run (``--quick``): about 3 times wider intervals than 10^4.
QUICK_SAMPLES = 1000
N_PILOT = 1000
TOLERANCE_RULE = (f"v(200) within mean +- {TOL_K} std of v(200) in an independent "
                  f"{N_PILOT}-sample pilot run (Eq. 2 of Li, Hu and Han: a two-sided band; the "
                  "paper does not give its limits)")
#: Table 3 of Li, Hu and Han (P_f and beta as printed) for the comparison in the report.
SEED_TABLE3 = {
    "x_p": (0.0148, 8.8057), "y_p": (0.0115, 9.7127), "z_p": (0.0197, 2.8025),
    "theta_py": (0.0168, 2.8588), "theta_pz": (0.0128, 9.3206),
    "x_g": (0.0146, 8.8532), "y_g": (0.0104, 10.0905), "z_g": (0.0184, 2.8268),
    "theta_gy": (0.0163, 8.4738), "theta_gz": (0.0138, 9.0515),
}
DOF_NAMES = list(SEED_TABLE3)
TAU_END = 200.0
N_TIME = 101


def seed_beta_explanation() -> str:
    """Why Li, Hu and Han's Table 3 beta values cannot follow from its failure probabilities."""
    from scipy.stats import norm

    lines = ["Li, Hu and Han, Table 3: printed beta vs the generalised index Phi^-1(1 - P_f) of "
             "its own P_f:"]
    for dof, (pf, beta) in SEED_TABLE3.items():
        lines.append(f"  {dof:<9} P_f = {pf:.4f}  printed beta = {beta:7.4f}  "
                     f"Phi^-1(1-P_f) = {norm.isf(pf):.4f}  P_f implied by printed beta = "
                     f"{norm.sf(beta):.1e}")
    lines.append(
        "  P_f of 1-2 % means beta of about 2.06-2.31; betas of 8.5-10.1 would mean P_f below "
        "1e-17. The printed values are not Phi^-1(R); they look like mean-value (Cornell) "
        "indices mu/sigma, which equal Phi^-1(R) only for a normal response. Both are "
        "reported below, labelled.")
    return "\n".join(lines)


def _quick_left_out(a: dict[str, Any]) -> str:
    """What 1000 samples leave out of ``n_samples``: the intervals' width grows as 1/sqrt(n)."""
    n = int(a["n_samples"])
    if n <= QUICK_SAMPLES:
        return f"nothing: n_samples={n} is within the quick run's {QUICK_SAMPLES} samples"
    return (f"{n} samples: the intervals are about {math.sqrt(n / QUICK_SAMPLES):.1f} times "
            "wider")


@plot.quick_mode(lambda a: f"{min(a['n_samples'], QUICK_SAMPLES)} samples",
                 left_out=_quick_left_out)
def run(
    out: str | Path = "gearuq_demo",
    n_samples: int = 10_000,
    seed: int = 20240607,
    executor: Any = None,
    progress: bool = True,
    store: str | Path | None = None,
    keep_chunks: bool = False,
    quick: bool = False,
) -> int:
    """Monte Carlo reliability of Li, Hu and Han's helical pair (analog of their Table 3).

    Parameters
    ----------
    out : path
        Output folder (created).
    n_samples : int
        Monte Carlo samples (10^4, as Li, Hu and Han; at least 3).
    seed : int
        Seed of the design.
    executor : str or None
        ``None``/``"serial"``: one process, the compiled integrator uses both cores;
        ``"processes"`` or a dask scheduler address to scale out.
    progress : bool
        Show a progress bar.
    store : path, optional
        Chunk store (default ``out/chunks-<hash of the settings>``): an interrupted run
        resumes from it; the report says how many chunks were reused.
    keep_chunks : bool
        Keep the store after the result file is written (default: remove it).
    quick : bool
        A small version: 1000 samples instead of ``n_samples`` (the intervals widen by about
        sqrt(10)).

    Returns
    -------
    int
        0 on success (the CLI exit code).
    """
    import gearuq

    # refused before anything is written: a rejected run leaves no folder behind
    if isinstance(n_samples, bool) or not isinstance(n_samples, (int, np.integer)) \
            or n_samples < 3:
        raise ValueError(f"n_samples: {n_samples!r} is outside its valid range: integers >= 3 "
                         "(the distribution fits need 3)")
    if not str(out).strip():
        raise ValueError("out: an empty folder name; give a folder to write into")
    if quick:
        n_samples = min(n_samples, QUICK_SAMPLES)
    wall0 = time.perf_counter()
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    model = gearuq.get_model("helical_pair")
    space = model.default_space()
    tau = np.linspace(0.0, TAU_END, N_TIME)
    margin_bands, band_rows = _margin_bands(model, tau)
    tol_bands = _tolerance_bands(model, space, tau, seed, executor, band_rows)
    settings = {"n_samples": n_samples, "seed": seed, "tau": [0.0, TAU_END, N_TIME],
                "outputs": VIB_OUTPUTS, "space": space.to_json()}
    store = Path(store) if store is not None else out / (
        "chunks-" + hashlib.sha256(json.dumps(settings, sort_keys=True).encode()).hexdigest()[:12])
    t_mc = time.perf_counter()
    ds = gearuq.monte_carlo(
        model, space, tau, n_samples=n_samples, rule="random", rng=seed, outputs=VIB_OUTPUTS,
        executor=executor, chunk_size=max(1, min(2500, n_samples)), store=store,
        progress=progress)
    t_mc = time.perf_counter() - t_mc
    ds.attrs.update({"allowable_bands": json.dumps(band_rows), "band_rule_margin": MARGIN_RULE,
                     "band_rule_tolerance": TOLERANCE_RULE})
    t_save = time.perf_counter()
    written = [gearuq.save(ds, out / "helical_pair_mc.nc")]
    t_save = time.perf_counter() - t_save
    reused, n_chunks = int(ds.attrs.get("reused_chunks", 0)), int(ds.attrs["n_chunks"])
    ds = ds.load()
    rel = gearuq.reliability(ds, margin_bands, confidence=0.95)
    rel.attrs["band_rule"] = MARGIN_RULE
    rel_tol = gearuq.reliability(ds, tol_bands, confidence=0.95, time=[TAU_END])
    rel_tol.attrs["band_rule"] = TOLERANCE_RULE
    written += [gearuq.save(rel, out / "reliability_margin.nc"),
                gearuq.save(rel_tol, out / "reliability_tolerance.nc")]
    rows, fits = _table3_rows(ds, band_rows, rel_tol.isel(time=-1), rel.isel(time=-1))
    sweep = _margin_sweep(ds, band_rows)
    t_post = time.perf_counter()
    # unit of the nondimensional outputs, e.g. "1e-05 m" ("b5 (...)" with the paper's scaling)
    unit = str(ds.attrs.get("length_scale", "1")).split(" (")[0]
    written += _figures(rel, fits, out, unit)
    t_fig = time.perf_counter() - t_post
    store_note = _store_note(store, keep_chunks, reused, n_chunks)
    timing = (f"Monte Carlo wall time {t_mc:.1f} s ({t_mc / n_samples * 1e3:.2f} ms/sample "
              f"incl. chunk store); netCDF save {t_save:.1f} s; figures {t_fig:.1f} s; "
              f"total {time.perf_counter() - wall0:.1f} s")
    (out / "table3.json").write_text(json.dumps(rows, indent=1))
    written.append(out / "table3.json")
    text = _report(n_samples, seed, space, ds, rows, band_rows, rel_tol.isel(time=-1),
                   rel.isel(time=-1), sweep, timing, store_note)
    (out / "summary.txt").write_text(text + "\n")
    written.append(out / "summary.txt")
    text += "\nwritten:\n" + "\n".join(
        f"  {p} ({p.stat().st_size / 2**20:.1f} MB)" for p in written)
    print(text)
    return 0


VIB_OUTPUTS = [f"v{i + 1}" for i in range(10)]


def _margin_bands(model: Any, tau: np.ndarray) -> tuple[list, list[dict[str, Any]]]:
    """Bands |v_i| <= MARGIN x the nominal design's largest vibration (one nominal run)."""
    from gearuq.failure.modes import Band

    nominal = model.response({}, tau, outputs=VIB_OUTPUTS + [f"p{i + 1}" for i in range(10)]
                             + ["length_unit"])
    length = float(nominal["length_unit"].values[0])  # [m] per unit of p and v
    bands, rows = [], []
    for i, (v, dof) in enumerate(zip(VIB_OUTPUTS, DOF_NAMES, strict=True)):
        amp = float(np.abs(nominal[v].values[0]).max())
        bands.append(Band(v, -MARGIN * amp, MARGIN * amp, name=dof))
        static = nominal[f"p{i + 1}"].values[0] - nominal[v].values[0]
        rows.append({"dof": dof, "output": v, "nominal_amplitude": amp,
                     "margin_half_width": MARGIN * amp,
                     "nominal_static_m": float(np.median(static)) * length,
                     "nominal_amplitude_m": amp * length})
    return bands, rows


def _tolerance_bands(model: Any, space: Any, tau: np.ndarray, seed: int, executor: Any,
                     rows: list[dict[str, Any]]) -> list:
    """Seed-style two-sided bands at tau = 200 from an independent pilot run."""
    import gearuq
    from gearuq.failure.modes import Band

    pilot = gearuq.monte_carlo(model, space, tau, n_samples=N_PILOT, rule="random",
                               rng=seed + 1, outputs=VIB_OUTPUTS, executor=executor,
                               progress=False)
    ok = pilot["status"].values == 0
    bands = []
    for row in rows:
        v200 = pilot[row["output"]].values[ok, -1]
        lo = float(v200.mean() - TOL_K * v200.std(ddof=1))
        hi = float(v200.mean() + TOL_K * v200.std(ddof=1))
        bands.append(Band(row["output"], lo, hi, name=row["dof"]))
        row["tolerance_band"] = (lo, hi)
        # The families are fitted to |v|. The band on v maps to one on |v| only when it
        # excludes 0; otherwise the fitted tail is not reported.
        row["tolerance_abs"] = ((min(abs(lo), abs(hi)), max(abs(lo), abs(hi))) if lo * hi > 0
                                else None)
        row["band_sign"] = float(np.sign(lo + hi))
    return bands


def _table3_rows(ds: Any, band_rows: list[dict[str, Any]], at_end: Any, margin_end: Any
                 ) -> tuple[list[dict[str, Any]], dict[str, tuple]]:
    """Per DOF: tolerance-band Pf, beta, mean-value beta, best-fit family of |v(200)|."""
    import gearuq
    from gearuq.failure.intervals import mean_value_beta

    valid = ds["status"].values == 0
    families = ("lognormal", "rayleigh", "normal", "weibull", "gamma")
    rows, fits = [], {}
    for row in band_rows:
        v_end = ds[row["output"]].values[valid, -1]
        dev = np.abs(v_end)
        fit = (gearuq.fit_distributions(dev, candidates=families, threshold=row["tolerance_abs"],
                                        tail="two-sided") if row["tolerance_abs"]
               else gearuq.fit_distributions(dev, candidates=families))
        fits[row["dof"]] = (dev, fit)
        best = fit.dataset.sel(candidate=fit.best)
        r, m_end = at_end.sel(mode=row["dof"]), margin_end.sel(mode=row["dof"])
        rows.append({
            "dof": row["dof"], "pf": float(r["pf"]), "pf_lower": float(r["pf_lower"]),
            "pf_upper": float(r["pf_upper"]), "R": float(r["r"]), "beta": float(r["beta"]),
            "beta_lower_bound": int(r["beta_is_lower_bound"]),
            "beta_lo": float(r["beta_lower"]), "beta_hi": float(r["beta_upper"]),
            "beta_mean_value": float(mean_value_beta(v_end, *row["tolerance_band"])),
            "best_fit": fit.best, "aic": float(best["aic"]), "ks": float(best["ks_statistic"]),
            "pf_fit": float(best["pf_fit"]) if "pf_fit" in best else float("nan"),
            "ranking": " > ".join(fit.ranking[:3]),
            "n_opposite_sign": int((np.sign(v_end) == -row["band_sign"]).sum()),
            "ks_pvalue_naive": float(best["ks_pvalue_naive"]),
            "margin_pf_instant": float(m_end["pf"]),
            "margin_pf_first_passage": float(m_end["pf_first_passage"]),
        })
    return rows, fits


def _margin_sweep(ds: Any, band_rows: list[dict[str, Any]]) -> list[tuple[float, float, float]]:
    """System first-passage Pf against margins: worst max_t |v_i| / nominal amplitude."""
    from gearuq.failure.intervals import wilson_interval

    valid = ds["status"].values == 0
    worst = np.max([np.abs(ds[r["output"]].values[valid]).max(axis=1) / r["nominal_amplitude"]
                    for r in band_rows], axis=0)
    sweep = []
    for m in MARGIN_SWEEP:
        k = int((worst > m).sum())
        sweep.append((m, k / worst.size, float(wilson_interval(k, worst.size, 0.95)[1])))
    return sweep


def _figures(rel: Any, fits: dict[str, tuple], out: Path, length_unit: str) -> list[Path]:
    from gearuq import plot

    paths = [out / "reliability_R_t.png", out / "failure_probability_t.png",
             out / "fitted_distributions.png"]
    plot.save_figure(_reliability_figure(rel), paths[0])
    plot.save_figure(_first_passage_figure(rel), paths[1])
    plot.save_figure(_fits_figure(fits, length_unit), paths[2])
    return paths


def _reliability_figure(rel: Any) -> Any:
    """R(t) per DOF (a), and 1 - R(t) on a log axis (b) where the band can be read.

    With 10^4 samples the 95 % Wilson band is [1 - 3.8e-4, 1] at an instant without
    failures: 0.1 % of panel (a)'s height, thinner than the line (its legend entry says
    so). Panel (b) shows that bound as a hatched strip; failures happen at a few instants
    only, whose intervals are drawn as bars in both panels. The system's first-passage
    reliability is a flat curve with a band of visible width.
    """
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    from gearuq import plot

    fig = Figure(figsize=(11, 8.4), layout="constrained")
    FigureCanvasAgg(fig)
    ax_r, ax_pf = fig.subplots(2, 1, sharex=True)
    tau = rel["time"].values
    system = rel.sel(mode="system")
    fp = {"r": ("r_first_passage", "r_first_passage_lower", "r_first_passage_upper"),
          "pf": ("pf_first_passage", "pf_first_passage_lower", "pf_first_passage_upper")}
    for ax, q in ((ax_r, "r"), (ax_pf, "pf")):
        plot.plot_reliability_curves(rel, quantity=q, ax=ax)
        y, lo, hi = (system[name].values for name in fp[q])
        if q == "pf":  # nothing failed yet: no point on the log axis (the strip shows it)
            y, lo, hi = (np.where(system["pf_first_passage_lower"].values > 0, a, np.nan)
                         for a in (y, lo, hi))
        ax.plot(tau, y, "k--", lw=1.5, label="system, first passage")
        ax.fill_between(tau, lo, hi, color="k", alpha=0.15, lw=0)
    ax_r.set_title(f"(a) reliability R(t) at each instant, |v| <= {MARGIN:g} x nominal largest "
                   "vibration, 95 % Wilson band", fontsize=10)
    ax_pf.set_title("(b) 1 - R(t) on a log axis: the band where no sample failed (hatched) "
                    "is readable here", fontsize=10)
    ax_r.set_ylabel("reliability R [1]")
    ax_pf.set_ylabel("1 - R = failure probability [1]")
    ax_r.set_xlabel("")
    ax_r.legend(loc="center left", bbox_to_anchor=(1.01, 0.5), fontsize=8, title="mode")
    handles, labels = ax_pf.get_legend_handles_labels()
    shown = set(ax_r.get_legend_handles_labels()[1]) - {"system, first passage"}
    keep = [(h, lab) for h, lab in zip(handles, labels, strict=True) if lab not in shown]
    ax_pf.legend(*zip(*keep, strict=True), loc="center left", bbox_to_anchor=(1.01, 0.5),
                 fontsize=8, title="colours as in (a)")
    return fig


def _first_passage_figure(rel: Any) -> Any:
    """First-passage Pf(t) per DOF and for the system on a log axis.

    The instantaneous Pf is zero at most instants (nothing to show on a log axis); the
    first-passage Pf only grows. Values with no failure observed yet are drawn at the
    detection limit 1/n (dotted line), so no curve vanishes.
    """
    import matplotlib
    from matplotlib.figure import Figure

    n = int(rel.attrs.get("n_valid", rel.attrs.get("n_samples", 1)))
    floor = 1.0 / max(n, 1)
    fig = Figure(figsize=(10, 4.8))
    ax = fig.subplots()
    cmap = matplotlib.colormaps["tab10"]
    tau = rel["time"].values
    curves = {str(m): rel["pf_first_passage"].sel(mode=m).values for m in rel["mode"].values
              if m != "system"}
    # exactly equal curves would hide each other: one curve, labelled with all its DOFs
    for i, group in enumerate(_groups({m: y.tobytes() for m, y in curves.items()})):
        ax.step(tau, np.maximum(curves[group[0]], floor), where="post", color=cmap(i % 10),
                lw=1.2, label=" = ".join(group))
    y = rel["pf_first_passage"].sel(mode="system").values
    # under the components, wider: the DOF that dominates the system stays visible on it
    ax.step(tau, np.maximum(y, floor), where="post", color="k", lw=3.0, label="system",
            zorder=1.5)
    ax.axhline(floor, color="0.4", ls=":", lw=1.0)
    ax.text(tau[0], floor * 1.15, f"detection limit 1/n = {floor:.0e} (no failure yet)",
            fontsize=8, color="0.3")
    ax.set_yscale("log")
    ax.set_ylim(floor / 2, 1.0)
    ax.set_xlabel("nondimensional time tau = omega_n t [1]")
    ax.set_ylabel("first-passage failure probability [1]")
    ax.set_title(f"P(|v| exceeds {MARGIN:g} x nominal largest vibration before tau)")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(loc="center left", bbox_to_anchor=(1.01, 0.5), fontsize=8)
    fig.subplots_adjust(left=0.08, right=0.82, bottom=0.11, top=0.92)
    return fig


def _store_note(store: Path, keep: bool, reused: int, n_chunks: int) -> str:
    size = sum(p.stat().st_size for p in store.glob("*") if p.is_file()) if store.exists() else 0
    note = (f"chunk store {store}: reused {reused} of {n_chunks} chunks from an earlier run"
            if reused else f"chunk store {store}: {n_chunks} chunks computed")
    if keep:
        return note + f"; kept ({size / 2**20:.1f} MB; --no-keep-chunks removes it)"
    shutil.rmtree(store, ignore_errors=True)
    return note + f"; removed ({size / 2**20:.1f} MB; --keep-chunks keeps it)"


def _report(n_samples: int, seed: int, space: Any, ds: Any, rows: list[dict[str, Any]],
            band_rows: list[dict[str, Any]], at_end: Any, margin_end: Any, sweep: list,
            timing: str, store_note: str) -> str:
    """The printed summary (also written to summary.txt)."""
    system, msys = at_end.sel(mode="system"), margin_end.sel(mode="system")
    lines = [
        f"gearuq demo: helical_pair Monte Carlo reliability ({n_samples} samples, seed {seed})",
        f"space: Table 2 of Li, Hu and Han ({', '.join(space.names)}), tau in [0, {TAU_END:g}], "
        f"{N_TIME} instants; responses v_i = p_i - static p_i (vibration)",
        describe_status(ds), "",
        f"Table 3 analog at tau = 200. Tolerance bands: {TOLERANCE_RULE}.",
        "beta = Phi^-1(R) (generalised), beta_MV = mean-value (Cornell) index of v; "
        "95 % Wilson intervals; fit = best of 5 families by AIC on |v(200)|",
        f"{'DOF':<9} {'P_f':>7} {'[lower, upper]':>17} {'R':>7} {'beta':>7} {'beta_MV':>7} "
        f"{'best fit':>9} {'KS':>6} {'Pf_fit':>8}  AIC ranking",
    ]
    table = {}
    for r in rows:
        beta = f"{r['beta']:.3f}" + (">" if r["beta_lower_bound"] else " ")
        table[r["dof"]] = (
            f"{r['pf']:7.4f} [{r['pf_lower']:.4f}, {r['pf_upper']:.4f}] "
            f"{r['R']:7.4f} {beta:>7} {r['beta_mean_value']:7.3f} {r['best_fit']:>9} "
            f"{r['ks']:6.3f} {r['pf_fit']:8.4f}  {r['ranking']}")
    margin = {r["dof"]: f"{r['margin_pf_instant']:12.4f} {r['margin_pf_first_passage']:25.4f}"
              for r in rows}
    same = [g for g in _groups(table) if len(g) > 1]
    same_margin = [g for g in _groups(margin) if len(g) > 1]
    lines += _marked(table, same)
    lines += [
        f"{'system':<9} {float(system['pf']):7.4f} [{float(system['pf_lower']):.4f}, "
        f"{float(system['pf_upper']):.4f}] {float(system['r']):7.4f} "
        f"{float(system['beta']):7.3f}  (series system of the 10 DOFs, same samples)",
        "('>' marks a beta that is a lower bound: no failure observed)", _fit_note(rows),
        *_identical_rows_note(same + [g for g in same_margin if g not in same], ds,
                              band_rows), "",
        f"Design-margin bands ({MARGIN_RULE}):",
        f"{'DOF':<9} {'Pf(tau=200)':>12} {'Pf first passage [0,200]':>25}",
    ]
    lines += _marked(margin, same_margin)
    lines += [
        f"{'system':<9} {float(msys['pf']):12.4f} {float(msys['pf_first_passage']):25.4f}",
        *(["('= name' marks a row identical to that DOF's: see the note on identical rows "
           "above)"] if same_margin else []),
        "(first passage is checked at the output instants only: a lower bound)",
        "system first-passage P_f over [0, 200] against the margin: " + ", ".join(
            f"{m:g}x: {p:.4f} (upper {u:.4f})" for m, p, u in sweep),
        "", seed_beta_explanation(), "", timing, store_note,
    ]
    return "\n".join(lines)


def _marked(table: dict[str, str], same: list[list[str]]) -> list[str]:
    """Table lines; a row identical to an earlier one ends with ``= <that DOF>``."""
    first = {dof: g[0] for g in same for dof in g[1:]}
    return [f"{dof:<9} {body}" + (f"  = {first[dof]}" if dof in first else "")
            for dof, body in table.items()]


#: Largest relative deviation from a fitted ratio that counts as "exactly proportional"
#: (round-off: the proportional rows of the demo deviate by 1e-12 at most, rows equal only in
#: their printed digits by 1e-2 or more).
PROPORTIONAL_TO = 1e-9


def _identical_rows_note(groups: list[list[str]], ds: Any,
                         band_rows: list[dict[str, Any]]) -> list[str]:
    """Say which rows are identical, show that their responses are proportional, and why.

    The ratio of each response to the group's first one is fitted over every sample and
    instant (least squares) and its largest deviation reported; the mechanism is stated
    only when the ratios are the mesh force's direction cosines and k_r = k_a, which is
    what makes the translations of one gear the same oscillator.
    """
    if not groups:
        return []
    rows = {r["dof"]: r for r in band_rows}
    valid = ds["status"].values == 0
    a_n, b = np.radians(float(ds["alpha_n"][0])), np.radians(float(ds["beta"][0]))
    n = {"x": np.sin(a_n), "y": np.cos(a_n) * np.cos(b), "z": np.cos(a_n) * np.sin(b)}
    ratios, coincident, cosines, seen = [], [], True, set()
    for g in groups:
        ref = rows[g[0]]["output"]
        x = ds[ref].values[valid]
        for dof in g[1:]:
            if (g[0], dof) in seen:  # a pair both tables group is described once
                continue
            seen.add((g[0], dof))
            out = rows[dof]["output"]
            y = ds[out].values[valid]
            c = float(np.sum(x * y) / np.sum(x * x))
            dev = float(np.max(np.abs(y - c * x)) / np.max(np.abs(y)))
            if dev <= PROPORTIONAL_TO:
                ratios.append(f"{out} = {c:.5g} {ref} (deviation {dev:.0e})")
                translation = g[0][0] in n and dof[0] in n and dof[1:] == g[0][1:]
                cosines &= translation and abs(c - n[dof[0]] / n[g[0][0]]) < 1e-8 * abs(c)
            else:
                coincident.append(f"{dof} and {g[0]} (deviation {dev:.0e})")
    lines = ["Identical rows (marked '= name'): " + "; ".join(" = ".join(g) for g in groups)
             + "."]
    if ratios:
        lines.append(
            "Not a copying error: in every sample at every instant these responses are "
            "exactly proportional, " + ", ".join(ratios) + " (largest deviation from the "
            "fitted ratio over all samples and instants, relative to the largest value).")
    if coincident:
        lines.append(
            "Equal in the printed digits only, not proportional responses: "
            + ", ".join(coincident) + f"; with {int(valid.sum())} valid samples their "
            "failure counts and the rounded statistics coincide, and more samples would "
            "tell them apart.")
    k_equal = bool(np.all(ds["k_r"].values == ds["k_a"].values))
    if ratios and cosines and k_equal:
        trans = [r for r in band_rows if r["dof"][0] in n]
        static = [abs(r["nominal_static_m"]) for r in trans]
        vib = max(r["nominal_amplitude_m"] for r in trans)
        clear = max(float(np.max(ds[c].values)) for c in ("b1", "b2", "b3", "b4"))
        lines.append(
            "Why: each gear's x, y and z translations carry the same mass, sit on supports "
            f"of equal stiffness (k_r = k_a = {float(ds['k_r'][0]):.4g} N/m in every sample) "
            "and damping, and stay outside their bearing clearances (nominal static "
            f"deflections {min(static) * 1e3:.2f}-{max(static) * 1e3:.2f} mm, vibrations up "
            f"to {vib * 1e6:.1f} um, half clearances up to {clear * 1e6:.0f} um), so each is "
            "the same linear oscillator driven by the mesh force's fluctuation times its "
            "direction cosine on the line of action: v_x : v_y : v_z = n_x : n_y : n_z = "
            "sin a_n : cos a_n cos b : cos a_n sin b = 1 : "
            f"{n['y'] / n['x']:.5g} : {n['z'] / n['x']:.5g} (a_n = {np.degrees(a_n):g} deg, "
            f"b = {np.degrees(b):g} deg), the ratios above. Both band rules scale with the "
            "response (margin: the nominal amplitude; tolerance: the pilot's mean and std), "
            "so a sample fails the x, y and z bands together, and P_f, beta, beta_MV and the "
            "fitted families (scale-invariant) repeat. It is one failure mode counted three "
            "times per gear; the series system counts it once.")
    return lines


def _fit_note(rows: list[dict[str, Any]]) -> str:
    """Say plainly when even the best family is rejected by the KS test."""
    bad = [r["dof"] for r in rows if r["ks_pvalue_naive"] < 0.01]
    if not bad:
        return "Best fits are not rejected by KS at the 1 % level (naive p-values)."
    return (f"KS rejects even the best family at the 1 % level for {', '.join(bad)} (naive "
            "p-value, optimistic for fitted parameters). The vibration at tau = 200 is "
            "A cos(Omega tau + phase) with a phase spread by the random mesh frequency ratio, "
            "so its magnitude piles up just below the amplitude (arcsine-like) with a long tail "
            "towards 0 -- none of the candidate families has that shape; trust the empirical "
            "P_f, not Pf_fit, here.")


def _fits_figure(fits: dict[str, tuple[np.ndarray, Any]], length_unit: str) -> Any:
    """2 x 5 grid: histogram of |p - p_static| at tau = 200 with the top fitted pdfs.

    ``length_unit`` is the unit of the nondimensional outputs (the dataset's attribute
    ``length_scale``, e.g. "1e-05 m"); rotations are pitch-circle arcs in that unit.
    """
    import xarray as xr
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    from gearuq import plot

    fig = Figure(figsize=(17, 7))
    FigureCanvasAgg(fig)
    axes = fig.subplots(2, 5)
    # fixed margins: constrained layout costs ~1 s on this 10-panel figure
    fig.subplots_adjust(left=0.04, right=0.99, bottom=0.08, top=0.9, wspace=0.3, hspace=0.35)
    seen: dict[str, np.ndarray] = {}
    for ax, (dof, (dev, fit)) in zip(axes.ravel(), fits.items(), strict=True):
        i = DOF_NAMES.index(dof) + 1
        # a panel that is an earlier one rescaled (proportional responses) says so
        same = next((f" = {c:.5g} {d}" for d, ref in seen.items()
                     if (c := float(np.sum(dev * ref) / np.sum(ref * ref))) > 0
                     and np.max(np.abs(dev - c * ref)) <= 1e-9 * np.max(dev)), "")
        seen.setdefault(dof, dev)
        unit = length_unit + (" arc" if dof.startswith("theta") else "")
        data = xr.DataArray(dev, attrs={"units": unit, "long_name": f"|v{i}| at tau = 200"})
        plot.plot_fit(data, fit, top=3, ax=ax)
        ax.set_xlim(np.quantile(dev, 0.002), dev.max() * 1.01)  # the tail to 0 is sparse
        ax.set_title(f"{dof}{same}: best {fit.best}")
    fig.suptitle("Deviation magnitude |v| = |p - p_static| at tau = 200: histogram and "
                 f"fitted pdfs (by AIC); translations in units of {length_unit}, rotations as "
                 f"pitch-circle arcs (r theta) in units of {length_unit}")
    return fig


def _groups(keys: dict[str, Any]) -> list[list[str]]:
    """Names with equal keys, grouped in order of first appearance."""
    out: dict[Any, list[str]] = {}
    for name, key in keys.items():
        out.setdefault(key, []).append(name)
    return list(out.values())


def main(argv: list[str] | None = None) -> int:
    """Command line: ``python -m gearuq_studies.helical_pair_reliability`` (as ``gearuq demo``)."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("gearuq_demo"))
    parser.add_argument("--quick", action="store_true", help="1000 samples instead of 10^4")
    parser.add_argument("--n-samples", type=int, default=10_000)
    parser.add_argument("--seed", type=int, default=20240607)
    parser.add_argument("--executor", default=None)
    parser.add_argument("--keep-chunks", action=argparse.BooleanOptionalAction, default=False)
    args = parser.parse_args(argv)
    return run(args.out, args.n_samples, args.seed, args.executor,
               keep_chunks=args.keep_chunks, quick=args.quick)


if __name__ == "__main__":
    raise SystemExit(main())
