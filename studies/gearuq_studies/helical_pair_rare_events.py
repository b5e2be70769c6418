"""Rare events of the helical pair: P(peak dynamic mesh force over tau in [100, 200] >= F).

The question a designer asks at a design margin: with torque, speed, transmission-error
amplitude, mesh damping and backlash scattered as they are in service (a space far wider than
Li, Hu and Han's Table 2, whose standard deviations are 0.02 % of the means), how likely is the peak
dynamic mesh force in the steady window tau in [100, 200] to reach a limit ``F``? Answered at
three limits by subset simulation (first passage: the limit state is ``F - max_t force(t)``),
at the lowest by AK-MCS too, and checked against crude Monte Carlo where it is affordable.

Engineering space (independent; docs/reliability.md gives the reasons):

=========  ======================================  =======================================
parameter  distribution                            why
=========  ======================================  =======================================
T          lognormal, mean 2600 N m, CoV 10 %      load spectrum about Li, Hu and Han's torque
n          uniform 3000 .. 4400 rpm                operating range about their 3600-4000 rpm
e_a        lognormal, mean 10.8 um, CoV 20 %       manufacturing scatter of the error
zeta_m     uniform 0.03 .. 0.17                    their Table 1 range of mesh damping
b5         lognormal, mean 20 um, CoV 10 %         backlash tolerance
=========  ======================================  =======================================

Model: ``helical_pair`` with ``mesh_damping="in_contact"`` (no damping force across an open
gap), output ``mesh_force`` at 801 instants in tau = [100, 200] (the start-up transient is
left out). Whether that grid resolves first passage is checked exactly on ``p1`` with its
derivative ``dp1`` (Hermite reconstruction between instants, Rice rate).

Run: ``gearuq study helical_pair_rare_events [--quick] [--out DIR]``, or
``python -m gearuq_studies.helical_pair_rare_events [--full] [--seed S] [--replot]``. The
default takes a few minutes (1e4 Monte Carlo runs, subset simulation with 500 samples per
level, AK-MCS with at most 150 runs); ``--full`` runs 1e5 Monte Carlo runs, three subset seeds
with 1000 per level and AK-MCS up to 400 runs (about half an hour on 2 cores); ``--quick``
runs 2000 Monte Carlo runs, 200 per subset level, AK-MCS up to 80 runs on 10^4 candidates and
the grid check on 500 samples (the Monte Carlo check then sees few failures at the check
limit and none at the rare ones: its intervals say so). Writes netCDF reports, a JSON
summary and ``pf_vs_model_runs.png`` into the output folder (and the Monte Carlo chunk store
``mc_store_N``, which a rerun reuses).
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path
from typing import Any

import numpy as np

import gearuq
from gearuq import plot
from gearuq.failure.api import failure_probability
from gearuq.failure.intervals import wilson_interval
from gearuq.failure.modes import LimitState
from gearuq.failure.report import describe_status

#: Limits on the peak mesh force [N]: a Monte Carlo check, ~1e-4 and ~1e-6.
MARGINS = {"check": 200e3, "1e-4": 300e3, "1e-6": 390e3}
TAU = np.linspace(100.0, 200.0, 801)
OPTIONS = {"mesh_damping": "in_contact"}


def engineering_space() -> gearuq.ParameterSpace:
    """The five scattered design parameters (see the module docstring)."""
    return gearuq.ParameterSpace({
        "T": {"dist": "lognormal", "mean": 2600.0, "std": 260.0},
        "n": {"dist": "uniform", "lower": 3000.0, "upper": 4400.0},
        "e_a": {"dist": "lognormal", "mean": 1.08e-5, "std": 2.16e-6},
        "zeta_m": {"dist": "uniform", "lower": 0.03, "upper": 0.17},
        "b5": {"dist": "lognormal", "mean": 2.0e-5, "std": 2.0e-6},
    })


class LogMargin:
    """``g = ln(F / force)``: the same failure set as ``F - force``, on a scale a Kriging model
    fits better (the peak force is heavy-tailed). Module level so that it pickles."""

    def __init__(self, limit: float) -> None:
        self.limit = limit

    def __call__(self, mesh_force: Any) -> Any:
        return np.log(self.limit / np.maximum(mesh_force, 1.0))


def crude_monte_carlo(model: Any, space: Any, n: int, seed: int, store: Path
                      ) -> dict[str, Any]:
    """Peak force of ``n`` random samples; Pf and its running estimate at every margin.

    The samples stream to ``store`` (10^5 x 801 instants would be 640 MB in memory); the
    result is read back lazily and ``gearuq.reliability`` counts failures chunk by chunk. A
    rerun with the same seed reuses the stored chunks.
    """
    t0 = time.perf_counter()
    ds = gearuq.monte_carlo(model, space, TAU, n_samples=n, rng=seed, outputs=["mesh_force"],
                            executor="serial", store=store, model_options=OPTIONS)
    wall = time.perf_counter() - t0
    modes = [LimitState.upper("mesh_force", f, name=k) for k, f in MARGINS.items()]
    rel = gearuq.reliability(ds, modes, system=False)
    peak = ds["mesh_force"].max("time").values  # one chunk at a time (dask)
    ok = ds["status"].values == 0
    running = {}
    for key, limit in MARGINS.items():
        fails = np.cumsum((peak >= limit) & ok)
        count = np.cumsum(ok)
        running[key] = (count, fails)
    return {"ds": ds, "rel": rel.isel(time=-1), "peak": peak, "wall": wall,
            "running": running}


def subset_runs(model: Any, space: Any, seeds: list[int], n_level: int) -> dict[str, list]:
    """Subset simulation at every margin (first passage over the window)."""
    out: dict[str, list] = {k: [] for k in MARGINS}
    for key, limit in MARGINS.items():
        for seed in seeds:
            rep = failure_probability(model, space, LimitState.upper("mesh_force", limit),
                                      TAU, method="subset", rng=seed, n_per_level=n_level,
                                      model_options=OPTIONS)
            out[key].append(rep)
            print(f"  subset {key:>5} (F = {limit / 1e3:.0f} kN, seed {seed}): pf = "
                  f"{float(rep['pf']):.3g} [{float(rep['pf_lower']):.3g}, "
                  f"{float(rep['pf_upper']):.3g}], {int(rep['n_model_runs'])} runs, "
                  f"{float(rep['wall_time']):.0f} s; {describe_status(rep)}", flush=True)
    return out


def akmcs_run(model: Any, space: Any, seed: int, max_runs: int, n_mc: int) -> Any:
    """AK-MCS at the check margin (log-margin limit state, 50 initial points)."""
    limit = MARGINS["check"]
    rep = failure_probability(model, space, LimitState(LogMargin(limit), "mesh_force",
                                                       name="ln(F / force)"), TAU,
                              method="akmcs", rng=seed, n_initial=50, max_runs=max_runs,
                              n_mc=n_mc, max_mc=n_mc, model_options=OPTIONS)
    print(f"  AK-MCS check: pf = {float(rep['pf']):.3g} [{float(rep['pf_lower']):.3g}, "
          f"{float(rep['pf_upper']):.3g}], {int(rep['n_model_runs'])} runs, "
          f"{float(rep['wall_time']):.0f} s; {describe_status(rep)}", flush=True)
    return rep


def grid_check(model: Any, space: Any, seed: int, n: int = 2000) -> Any:
    """Does the 801-instant grid resolve first passage? Checked exactly on the pinion's
    radial displacement ``p1``, whose derivative ``dp1`` the model provides (``mesh_force``
    has none): per-sample Hermite reconstruction between instants and the Rice rate."""
    from gearuq.failure.outcrossing import first_passage

    ds = gearuq.monte_carlo(model, space, TAU, n_samples=n, rng=seed + 1,
                            outputs=["p1", "dp1"], executor="serial", model_options=OPTIONS)
    level = float(np.quantile(ds["p1"].max("time").values, 0.98))
    fp = first_passage(ds, "p1", level, derivative="dp1")
    print(f"  grid check on p1 >= {level:.4g} ({n} samples): grid {float(fp['pf_grid']):.4g}, "
          f"Hermite {float(fp['pf_hermite']):.4g}, Poisson-Rice {float(fp['pf_rice']):.4g}; "
          f"{float(fp['points_per_period']):.0f} instants per mean period; "
          f"{fp.attrs['verdict']}", flush=True)
    return fp


def figure(mc: dict[str, Any], subset: dict[str, list], ak: Any, path: Path) -> None:
    """Pf against model runs: crude MC running estimate, subset, AK-MCS, per margin."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    colours = {"check": "tab:blue", "1e-4": "tab:orange", "1e-6": "tab:green"}
    fig, ax = plt.subplots(figsize=(12.0, 5.8))
    no_failure_until = 0
    for key, limit in MARGINS.items():
        c = colours[key]
        count, fails = mc["running"][key]
        idx = np.unique(np.geomspace(50, count.size, 60).astype(int)) - 1
        n, k = count[idx], fails[idx]
        lo, up = wilson_interval(k, n)
        has = k > 0
        label = f"F = {limit / 1e3:.0f} kN"
        if has.any():
            ax.plot(n[has], (k / n)[has], color=c, lw=1.5, label=f"{label}: crude MC")
            ax.fill_between(n[has], lo[has], up[has], color=c, alpha=0.15)
        no_failure_until = max(no_failure_until, int(n[~has].max()) if (~has).any() else 0)
        for i, rep in enumerate(subset[key]):
            pf, pl, pu = (float(rep[v]) for v in ("pf", "pf_lower", "pf_upper"))
            ax.errorbar(int(rep["n_model_runs"]) * (1 + 0.04 * i), pf,
                        yerr=[[pf - pl], [pu - pf]], fmt="o", color=c, capsize=4,
                        label=f"{label}: subset simulation" if i == 0 else None)
    if no_failure_until:  # the bound depends on n only: one line for every limit
        n = np.geomspace(50, no_failure_until, 40)
        ax.plot(n, wilson_interval(0, n.astype(int))[1], color="0.35", lw=1.2, ls=":",
                label="crude MC upper bound while no failure is seen (any F)")
    runs = ak["iteration_model_runs"].values
    hist = ak["iteration_pf"].values
    good = hist > 0
    ax.plot(runs[good], hist[good], color="tab:purple", lw=1.2,
            label="F = 200 kN: AK-MCS history")
    pf, pl, pu = (float(ak[v]) for v in ("pf", "pf_lower", "pf_upper"))
    ax.errorbar(int(ak["n_model_runs"]), pf, yerr=[[pf - pl], [pu - pf]], fmt="s",
                color="tab:purple", capsize=4, label="F = 200 kN: AK-MCS final (with its "
                "surrogate error)")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("model runs (helical_pair samples) [-]")
    ax.set_ylabel("P_f = P(max mesh force over tau in [100, 200] >= F) [-]")
    ax.set_title("helical_pair rare events: failure probability against model runs")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.01, 1.0))
    fig.tight_layout()
    plot.save_figure(fig, path, dpi=130)
    plt.close(fig)


def summary(mc: dict[str, Any], subset: dict[str, list], ak: Any, n_mc: int) -> dict:
    """Numbers for the docs, one dict per margin and method."""
    out: dict[str, Any] = {"monte_carlo": {}, "subset": {}, "akmcs": {}}
    for key in MARGINS:
        m = mc["rel"].sel(mode=key)
        out["monte_carlo"][key] = {
            "pf": float(m["pf_first_passage"]), "lower": float(m["pf_first_passage_lower"]),
            "upper": float(m["pf_first_passage_upper"]),
            "failures": int(m["n_failures_first_passage"]), "runs": n_mc,
            "grid_gap": float(m["pf_first_passage_grid_gap"]),
            "grid_warning": int(m["first_passage_grid_warning"])}
        out["subset"][key] = [{v: float(r[v]) for v in ("pf", "pf_lower", "pf_upper",
                                                         "cov_pf", "n_model_runs",
                                                         "wall_time")} for r in subset[key]]
    out["akmcs"]["check"] = {v: float(ak[v]) for v in ("pf", "pf_lower", "pf_upper",
                                                       "n_model_runs", "wall_time",
                                                       "pf_surrogate_lower",
                                                       "pf_surrogate_upper")}
    out["akmcs"]["check"]["message"] = ak.attrs["message"]
    out["mc_wall_per_run"] = mc["wall"] / n_mc
    return out


@plot.quick_mode(
    "2000 Monte Carlo runs, 200 per subset level, AK-MCS up to 80 runs",
    left_out=(
        "10^4 Monte Carlo runs, 500 per subset level and AK-MCS up to 150 runs on 5 x 10^4 "
        "candidates: the rare levels are not checked by Monte Carlo"))
def run(out: str | Path = "gearuq_helical_pair_rare_events", quick: bool = False,
        full: bool = False, seed: int = 2024, replot: bool = False) -> int:
    """Rare peak mesh forces of Li, Hu and Han's helical pair: subset simulation, AK-MCS, MC.

    P(peak dynamic mesh force over tau in [100, 200] >= F) at three limits F, over an
    engineering space of torque, speed, error amplitude, mesh damping and backlash.

    Parameters
    ----------
    out : path
        Output folder (created): ``monte_carlo_reliability.nc``, ``subset_*.nc``,
        ``akmcs_check.nc``, ``grid_check_p1.nc``, ``summary.json``, ``pf_vs_model_runs.png``
        and the reusable Monte Carlo store ``mc_store_N``.
    quick : bool
        2000 Monte Carlo runs, 200 per subset level, AK-MCS up to 80 runs, grid check on 500.
    full : bool
        1e5 Monte Carlo runs, three subset seeds with 1000 per level, AK-MCS up to 400 runs.
    seed : int
        Seed of every random stage.
    replot : bool
        Only redraw the figure from the saved reports and the Monte Carlo store.

    Returns
    -------
    int
        0.
    """
    if quick and full:
        raise ValueError("quick=True and full=True: choose one")
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    n_mc = 100_000 if full else 2_000 if quick else 10_000
    seeds = [seed + i for i in range(3 if full else 1)]
    n_level = 1000 if full else 200 if quick else 500
    ak_runs, ak_mc = (400, 100_000) if full else (80, 10_000) if quick else (150, 50_000)
    model = gearuq.get_model("helical_pair")
    space = engineering_space()
    t0 = time.perf_counter()
    print(f"crude Monte Carlo, {n_mc} runs ...", flush=True)
    mc = crude_monte_carlo(model, space, n_mc, seed, out / f"mc_store_{n_mc}")
    if replot:
        ss = {k: [gearuq.load(p) for p in sorted(out.glob(f"subset_{k}_*.nc"))]
              for k in MARGINS}
        ak = gearuq.load(out / "akmcs_check.nc")
        figure(mc, ss, ak, out / "pf_vs_model_runs.png")
        print(f"redrawn: {out / 'pf_vs_model_runs.png'}")
        return 0
    print("subset simulation ...", flush=True)
    ss = subset_runs(model, space, seeds, n_level)
    print("AK-MCS ...", flush=True)
    ak = akmcs_run(model, space, seed, ak_runs, ak_mc)
    print("time-grid check ...", flush=True)
    grid = grid_check(model, space, seed, n=500 if quick else 2000)
    figure(mc, ss, ak, out / "pf_vs_model_runs.png")
    gearuq.save(mc["rel"], out / "monte_carlo_reliability.nc")
    gearuq.save(grid, out / "grid_check_p1.nc")
    for key in MARGINS:
        for i, rep in enumerate(ss[key]):
            gearuq.save(rep, out / f"subset_{key}_{i}.nc")
    gearuq.save(ak, out / "akmcs_check.nc")
    info = summary(mc, ss, ak, n_mc)
    info["grid_check_p1"] = {k: float(grid[k]) for k in ("pf_grid", "pf_hermite", "pf_rice",
                                                          "points_per_period", "peak_loss")}
    info["grid_check_p1"]["verdict"] = grid.attrs["verdict"]
    info["quick"] = quick
    info["total_wall"] = time.perf_counter() - t0
    (out / "summary.json").write_text(json.dumps(info, indent=1))
    print("\nhelical_pair rare events (peak mesh force over tau in [100, 200]):")
    print(f"{'limit':>8} {'method':<14} {'Pf':>10} {'interval':>24} {'runs':>8}")
    for key, limit in MARGINS.items():
        m = info["monte_carlo"][key]
        print(f"{limit / 1e3:>6.0f}kN {'crude MC':<14} {m['pf']:>10.3g} "
              f"[{m['lower']:.3g}, {m['upper']:.3g}]".ljust(60) + f"{m['runs']:>8}")
        for r in info["subset"][key]:
            print(f"{limit / 1e3:>6.0f}kN {'subset':<14} {r['pf']:>10.3g} "
                  f"[{r['pf_lower']:.3g}, {r['pf_upper']:.3g}]".ljust(60)
                  + f"{r['n_model_runs']:>8.0f}")
    a = info["akmcs"]["check"]
    print(f"{MARGINS['check'] / 1e3:>6.0f}kN {'AK-MCS':<14} {a['pf']:>10.3g} "
          f"[{a['pf_lower']:.3g}, {a['pf_upper']:.3g}]".ljust(60) + f"{a['n_model_runs']:>8.0f}")
    print(f"written: {out} (pf_vs_model_runs.png, *.nc, summary.json); "
          f"{info['total_wall']:.0f} s")
    return 0


def main(argv: list[str] | None = None) -> int:
    """Command line: ``python -m gearuq_studies.helical_pair_rare_events``."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("gearuq_helical_pair_rare_events"))
    parser.add_argument("--quick", action="store_true",
                        help="2000 MC runs, 200 per subset level, AK-MCS 80 runs")
    parser.add_argument("--full", action="store_true",
                        help="1e5 MC runs, 3 subset seeds x 1000 per level, AK-MCS 400 runs")
    parser.add_argument("--seed", type=int, default=2024)
    parser.add_argument("--replot", action="store_true",
                        help="redraw the figure from the saved reports and the Monte Carlo store")
    args = parser.parse_args(argv)
    return run(args.out, quick=args.quick, full=args.full, seed=args.seed, replot=args.replot)


if __name__ == "__main__":
    raise SystemExit(main())
