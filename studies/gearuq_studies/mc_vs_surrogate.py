"""Monte Carlo against polynomial chaos for the helical pair's reliability question.

Question (the ``gearuq demo`` Table 3 analog): each DOF's vibration ``v_i = p_i - static p_i``
at tau = 200 must stay within its tolerance band (mean +- 2.5 std of an independent
1000-sample pilot run, the demo's rule); what are the failure probabilities per DOF and for
the series system, and how cheaply can they be had?

Compared, in one run:

- crude Monte Carlo of the model at n = 10^2, 10^3, 10^4 (independent seeds), each with its
  Wilson 95 % interval, model evaluations and wall time;
- PCE surrogates (least squares of degree 1..4, 1..6 with ``--full``, and sparse hybrid LARS)
  fitted on ``2 x basis`` Sobol' points, then sampled 10^6 times through the same
  ``gearuq.reliability`` (wall time = model runs + fit + surrogate sampling);
- against a reference Monte Carlo run of ``--n-ref`` samples (default 2 x 10^4 so the default
  run stays near 3 minutes on 2 cores; ``--full`` uses 10^5).

Error = |Pf - Pf_ref| of the series system and the mean relative error over the 10 DOFs.
Writes ``comparison.nc``, ``table.md`` and ``speed_vs_error.png`` into the output folder.

Run: ``gearuq study mc_vs_surrogate [--quick] [--out DIR]``, or
``python -m gearuq_studies.mc_vs_surrogate [--full] [--n-ref N] [--replicates R]``.
``--quick``: a 300-sample pilot, a reference of 2000 samples, Monte Carlo at 10^2 and 10^3,
PCE least squares of degree 1..3 and one sparse fit, 10^5 surrogate samples, no extra
designs (well under a minute; the reference interval is then wide).
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np
import xarray as xr
from matplotlib.ticker import NullFormatter

import gearuq
from gearuq import plot
from gearuq.engines.pce import polynomial_chaos
from gearuq.failure.modes import Band
from gearuq.failure.report import describe_status
from gearuq.failure.samples import reliability

DOFS = ["x_p", "y_p", "z_p", "theta_py", "theta_pz", "x_g", "y_g", "z_g", "theta_gy",
        "theta_gz"]
#: The plugin's vibration outputs v_i = p_i - p_i,static (computed inside each chunk).
OUTPUTS = [f"v{i + 1}" for i in range(len(DOFS))]
TAU = [200.0]
TOL_K = 2.5
N_PILOT = 1000


def _pf(rel: xr.Dataset) -> dict[str, np.ndarray]:
    r = rel.isel(time=-1) if "time" in rel.dims else rel
    return {k: r[k].values for k in ("pf", "pf_lower", "pf_upper")}


@plot.quick_mode(
    "a 300-sample pilot and a 2000-sample reference",
    left_out=(
        "the 2 x 10^4-sample reference, Monte Carlo at 10^4, PCE degree 4 and the extra "
        "sparse designs: the reference interval is wide"))
def run(out: str | Path = "gearuq_mc_vs_surrogate", quick: bool = False, full: bool = False,
        n_ref: int | None = None, seed: int = 20240607, replicates: int | None = None) -> int:
    """Monte Carlo against polynomial chaos for Li, Hu and Han's tolerance-band reliability.

    Parameters
    ----------
    out : path
        Output folder (created): ``comparison.nc``, ``table.md``, ``speed_vs_error.png``.
    quick : bool
        Pilot 300, reference 2000, MC at 10^2 and 10^3, PCE degrees 1..3 and one sparse fit,
        10^5 surrogate samples, no extra designs.
    full : bool
        Reference 10^5 and PCE degrees up to 6.
    n_ref : int, optional
        Reference Monte Carlo size (default 2 x 10^4; 10^5 with ``full``; 2000 ``quick``).
    seed : int
        Seed of every random stage.
    replicates : int, optional
        Extra designs of the sparse degree-5 fit (3; 0 with ``quick``).

    Returns
    -------
    int
        0.
    """
    import matplotlib
    import matplotlib.pyplot as plt

    if quick and full:
        raise ValueError("quick=True and full=True: choose one")
    n_ref = n_ref or (100_000 if full else 2_000 if quick else 20_000)
    if n_ref < 100:
        raise ValueError(f"n_ref={n_ref}: the reference needs at least 100 samples")
    replicates = (0 if quick else 3) if replicates is None else replicates
    n_pilot = 300 if quick else N_PILOT
    n_surrogate = 10**5 if quick else 10**6
    matplotlib.use("Agg")
    wall0 = time.perf_counter()
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    model = gearuq.get_model("helical_pair")
    space = model.default_space()
    outs = OUTPUTS

    pilot = gearuq.monte_carlo(model, space, TAU, n_samples=n_pilot, rng=seed + 1,
                               outputs=outs, executor="serial", progress=False)
    ok = pilot["status"].values == 0
    print(f"pilot of {n_pilot} runs (the tolerance bands): {describe_status(pilot)}")
    bands = []
    for o, dof in zip(outs, DOFS, strict=True):
        v = pilot[o].values[ok, -1]
        bands.append(Band(o, v.mean() - TOL_K * v.std(ddof=1), v.mean() + TOL_K * v.std(ddof=1),
                          name=dof))

    def run_mc(n: int, s: int) -> tuple[xr.Dataset, float]:
        t0 = time.perf_counter()
        ds = gearuq.monte_carlo(model, space, TAU, n_samples=n, rng=s, outputs=outs,
                                executor="serial", progress=False)
        rel = reliability(ds, bands)
        return rel, time.perf_counter() - t0

    ref, t_ref = run_mc(n_ref, seed)
    pf_ref = _pf(ref)
    modes = list(ref["mode"].values)
    rows = [{"method": "MC reference", "n_eval": n_ref, "wall": t_ref, **_row(pf_ref, pf_ref),
             "loo": np.nan, "degree": np.nan}]
    for k, n in enumerate([100, 1000] if quick else [100, 1000, 10_000]):
        rel, w = run_mc(n, seed + 10 + k)
        rows.append({"method": "MC", "n_eval": n, "wall": w, **_row(_pf(rel), pf_ref),
                     "loo": np.nan, "degree": np.nan})

    degrees = range(1, 7 if full else 4 if quick else 5)
    fits = [("PCE LS", p, "regression", None) for p in degrees]
    fits += [("PCE sparse", 3, "sparse", 128)]
    if not quick:
        fits += [("PCE sparse", 5, "sparse", 256), ("PCE sparse", 7, "sparse", 512)]
    for label, p, method, n in fits:
        t0 = time.perf_counter()
        pce = polynomial_chaos(model, space, TAU, order=p, method=method, outputs=outs,
                               n_samples=n, rng=seed + 100 + p)
        rel = pce.reliability(bands, n_samples=n_surrogate, rng=seed + 200 + p)
        w = time.perf_counter() - t0
        rows.append({"method": label, "n_eval": pce.n_evaluations, "wall": w,
                     **_row(_pf(rel), pf_ref), "loo": float(np.mean(list(
                         pce.loo_error.values()))), "degree": p})

    # robustness: the same sparse degree-5 fit on other designs (is one good design luck?)
    for r in range(replicates):
        t0 = time.perf_counter()
        pce = polynomial_chaos(model, space, TAU, order=5, method="sparse", outputs=outs,
                               n_samples=256, rng=seed + 300 + r)
        rel = pce.reliability(bands, n_samples=n_surrogate, rng=seed + 400 + r)
        rows.append({"method": "PCE sparse (other design)", "n_eval": pce.n_evaluations,
                     "wall": time.perf_counter() - t0, **_row(_pf(rel), pf_ref),
                     "loo": float(np.mean(list(pce.loo_error.values()))), "degree": 5})

    # ---------------------------------------------------------------- table + dataset
    sys_i = modes.index("system")
    lo, hi = pf_ref["pf_lower"][sys_i], pf_ref["pf_upper"][sys_i]
    lines = [
        "# Monte Carlo vs polynomial chaos: helical_pair tolerance-band reliability at tau=200",
        "",
        f"Bands: v_i(200) within pilot mean +- {TOL_K} std ({n_pilot}-sample pilot). "
        f"Reference: MC n = {n_ref}, system Pf = {pf_ref['pf'][sys_i]:.4f} "
        f"[{lo:.4f}, {hi:.4f}] (95 % Wilson), {t_ref:.1f} s.",
        "",
        "| method | degree | model evals | wall [s] | Pf system | |err| system | in ref CI "
        "| mean rel. err DOFs | LOO |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        deg = "" if np.isnan(r["degree"]) else f"{int(r['degree'])}"
        inside = "yes" if lo <= r["pf_sys"] <= hi else "no"
        lines.append(
            f"| {r['method']} | {deg} | {r['n_eval']} | {r['wall']:.2f} | {r['pf_sys']:.4f} | "
            f"{r['err_sys']:.4f} | {inside} | {r['err_dof']:.3f} | "
            + ("" if np.isnan(r["loo"]) else f"{r['loo']:.2e}") + " |")
    budget = n_ref / 20
    ok_rows = [r for r in rows if r["method"].startswith("PCE") and r["n_eval"] <= budget
               and lo <= r["pf_sys"] <= hi]
    pce_rows = [r for r in rows if r["method"].startswith("PCE") and r["n_eval"] <= budget]
    lines += [
        "",
        f"PCE within the reference 95 % interval with at most 1/20 of its model evaluations "
        f"(<= {budget:.0f}): " + (", ".join(f"{r['method']} degree {int(r['degree'])} "
                                            f"({r['n_eval']} evals)" for r in ok_rows)
                                  if ok_rows else "none")
        + f" ({len(ok_rows)} of {len(pce_rows)} PCE fits within the budget).",
        "",
        "Per-DOF Pf (reference MC):",
        "",
        "| mode | " + " | ".join(modes) + " |",
        "|---|" + "---|" * len(modes),
        "| Pf | " + " | ".join(f"{v:.4f}" for v in pf_ref["pf"]) + " |",
    ]
    text = "\n".join(lines)
    (out / "table.md").write_text(text + "\n")
    ds = xr.Dataset(
        {k: ("row", [r[k] for r in rows]) for k in
         ("n_eval", "wall", "pf_sys", "err_sys", "err_dof", "loo", "degree")},
        coords={"row": np.arange(len(rows)), "method": ("row", [r["method"] for r in rows])})
    ds["pf_ref"] = ("mode", pf_ref["pf"])
    ds = ds.assign_coords(mode=modes)
    ds.attrs.update({"n_ref": n_ref, "band_rule": f"pilot mean +- {TOL_K} std at tau=200",
                     "seed": seed})
    gearuq.save(ds, out / "comparison.nc")

    fig, axes = plt.subplots(1, 2, figsize=(12, 4.6), layout="constrained")
    for ax, xkey, xlabel in ((axes[0], "n_eval", "model evaluations"),
                             (axes[1], "wall", "wall time [s] (this machine)")):
        for method, marker in (("MC", "o-"), ("PCE LS", "s-"), ("PCE sparse", "^-"),
                               ("PCE sparse (other design)", "v")):
            sel = [r for r in rows if r["method"] == method]
            if not sel:  # e.g. no extra designs in the quick run: no legend entry without a point
                continue
            ax.plot([r[xkey] for r in sel], [max(r["err_sys"], 1e-5) for r in sel], marker,
                    label=method)
            for r in sel:
                if not np.isnan(r["degree"]):
                    ax.annotate(f"p{int(r['degree'])}", (r[xkey], max(r["err_sys"], 1e-5)),
                                fontsize=7, xytext=(3, 3), textcoords="offset points")
        ax.axhline(hi - pf_ref["pf"][sys_i], color="k", ls=":", lw=1,
                   label="reference 95 % half-width")
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.xaxis.set_minor_formatter(NullFormatter())  # minor labels overlap on short ranges
        ax.set_xlabel(xlabel)
        ax.set_ylabel("|Pf - Pf_ref| of the series system (1)")
        ax.grid(alpha=0.3, which="both")
    # what a Monte Carlo run of n samples is expected to miss by (one MC point can be lucky)
    ns = np.logspace(2, 4.3, 30)
    pr = pf_ref["pf"][sys_i]
    axes[0].plot(ns, 1.96 * np.sqrt(pr * (1 - pr) / ns), "--", color="C0", lw=1,
                 label="MC expected 95 % half-width")
    axes[0].legend(fontsize=8)
    fig.suptitle(f"helical_pair tolerance-band Pf at tau = 200: MC vs PCE (reference MC "
                 f"n = {n_ref})")
    plot.save_figure(fig, out / "speed_vs_error.png", dpi=110)
    plt.close(fig)
    print(text)
    print(f"\nwall time {time.perf_counter() - wall0:.1f} s; written to {out}")
    return 0


def _row(pf: dict[str, np.ndarray], ref: dict[str, np.ndarray]) -> dict[str, float]:
    err = np.abs(pf["pf"] - ref["pf"])
    with np.errstate(divide="ignore", invalid="ignore"):
        rel = err[:-1] / ref["pf"][:-1]
    return {"pf_sys": float(pf["pf"][-1]), "err_sys": float(err[-1]),
            "err_dof": float(np.nanmean(rel))}


def main(argv: list[str] | None = None) -> int:
    """Command line: ``python -m gearuq_studies.mc_vs_surrogate``."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("gearuq_mc_vs_surrogate"))
    parser.add_argument("--quick", action="store_true",
                        help="reference 2000, PCE degrees 1-3 (well under a minute)")
    parser.add_argument("--n-ref", type=int, default=None)
    parser.add_argument("--full", action="store_true",
                        help="reference MC 1e5 and PCE degrees up to 6 (about 5 minutes)")
    parser.add_argument("--replicates", type=int, default=None,
                        help="extra designs of the sparse degree-5 fit (robustness; 3)")
    args = parser.parse_args(argv)
    return run(args.out, quick=args.quick, full=args.full, n_ref=args.n_ref,
               replicates=args.replicates)


if __name__ == "__main__":
    raise SystemExit(main())
