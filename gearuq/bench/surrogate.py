"""``gearuq bench surrogate``: speed against error of Monte Carlo and PCE on analytic oracles.

Four problems with exact answers (:mod:`gearuq.testing.problems`), measured side by side in
one run:

==============  ==============================================  ===============================
benchmark       quantity and exact value                        compared
==============  ==============================================  ===============================
ishigami        S1, ST (a=7, b=0.1, U[-pi, pi]^3)               Sobol' MC (Saltelli) vs PCE
                                                                (least squares, quadrature,
                                                                sparse auto degree <= 14)
g_function      S1, ST (a = 0, 1, 4.5, 9, 99 x 4; U[0, 1]^8)    Sobol' MC (Jansen) vs sparse PCE
linear          Pf = Phi(-3) of g = 3 - (x1 + x2)/sqrt(2)       MC vs PCE surrogate
four_branch     Pf = 4.45733e-3 of the four-branch series       MC vs sparse PCE surrogate
                system (k = 6/sqrt(2))
==============  ==============================================  ===============================

Error is the largest absolute index error (sensitivity) or the relative Pf error
(reliability); PCE rows also give the LOO error and, for the sparse Ishigami row, the
relative error on an independent 10^4-point hold-out set. Wall times are for this machine, in
the same run; the analytic models cost microseconds, so for an expensive model the
model-evaluation column is the one to read.
"""

from __future__ import annotations

import math
import time
import warnings
from pathlib import Path
from typing import Any

import numpy as np

from gearuq.testing.problems import (
    FOUR_BRANCH_PF,
    LINEAR_PF,
    benchmark_problems,
    g_function_exact,
    ishigami_exact,
)

__all__ = ["run", "benchmarks", "FOUR_BRANCH_PF", "ISHIGAMI_SPARSE"]

#: The sparse-PCE target setting on Ishigami: auto degree up to 14, 512 Sobol' points.
ISHIGAMI_SPARSE = {"order": "auto", "max_order": 14, "method": "sparse", "n_samples": 512,
                   "rule": "sobol"}
_N_HOLDOUT = 10_000


def benchmarks() -> dict[str, tuple[Any, Any]]:
    """The four (model, space) pairs (:func:`gearuq.testing.problems.benchmark_problems`)."""
    return benchmark_problems()


def _timed(fn):
    t0 = time.perf_counter()
    r = fn()
    return r, time.perf_counter() - t0


def _sens_rows(name, model, space, exact, mc_ns, pce_cases, estimator):
    from gearuq.engines.pce import polynomial_chaos
    from gearuq.engines.sensitivity import sobol_indices

    rows = []
    for n in mc_ns:
        ds, w = _timed(lambda n=n: sobol_indices(model, space, n_base=n, estimator=estimator,
                                                 rng=1, n_bootstrap=50))
        err = max(np.abs(ds["S1"].values[0] - exact.S1).max(),
                  np.abs(ds["ST"].values[0] - exact.ST).max())
        rows.append({"benchmark": name, "method": f"Sobol MC ({estimator})",
                     "setting": f"N={n}", "n_eval": int(ds.attrs["n_model_evaluations"]),
                     "wall": w, "error": float(err)})
    for label, case in pce_cases:
        kw = {k: v for k, v in case.items() if k != "holdout"}
        pce, w = _timed(lambda kw=kw: polynomial_chaos(model, space, rng=1, **kw))
        s = pce.sobol()
        err = max(np.abs(s["S1"].values - exact.S1).max(),
                  np.abs(s["ST"].values - exact.ST).max())
        row = {"benchmark": name, "method": label,
               "setting": f"p={pce.order}, {pce.n_terms} terms"
               + (f", n={kw['n_samples']}" if "n_samples" in kw else ""),
               "n_eval": pce.n_evaluations, "wall": w, "error": float(err),
               "loo": pce.loo_error[pce.output_names[0]],
               "corrected_loo": pce.corrected_loo_error[pce.output_names[0]]}
        if case.get("holdout"):  # validation outside the timed fit, on independent draws
            x = space.sample(case["holdout"], "random", 12345)
            ref = model.response(x)
            row["holdout"] = pce.validate(ref, record=False)[pce.output_names[0]]
        rows.append(row)
    return rows


def _pf_rows(name, model, space, exact, mc_ns, pce_cases, n_surrogate):
    from gearuq.engines.montecarlo import monte_carlo
    from gearuq.engines.pce import polynomial_chaos
    from gearuq.failure.modes import Band
    from gearuq.failure.samples import reliability

    band = Band("g", lower=0.0)
    rows = []
    for n in mc_ns:
        def mc(n=n):
            ds = monte_carlo(model, space, n_samples=n, rng=5, executor="serial",
                             progress=False)
            return reliability(ds, band)
        rel, w = _timed(mc)
        pf = float(rel["pf"].sel(mode="g"))
        rows.append({"benchmark": name, "method": "MC", "setting": f"n={n}", "n_eval": n,
                     "wall": w, "error": abs(pf - exact) / exact, "pf": pf,
                     "pf_lower": float(rel["pf_lower"].sel(mode="g")),
                     "pf_upper": float(rel["pf_upper"].sel(mode="g"))})
    for label, kw in pce_cases:
        def fit(kw=kw):
            pce = polynomial_chaos(model, space, rng=2, **kw)
            return pce, pce.reliability(band, n_samples=n_surrogate, rng=6)
        (pce, rel), w = _timed(fit)
        pf = float(rel["pf"].sel(mode="g"))
        rows.append({"benchmark": name, "method": label,
                     "setting": f"p={pce.order}, n={pce.n_evaluations}",
                     "n_eval": pce.n_evaluations, "wall": w, "error": abs(pf - exact) / exact,
                     "pf": pf, "loo": pce.loo_error["g"],
                     "corrected_loo": pce.corrected_loo_error["g"]})
    return rows


def _settings(quick: bool) -> dict[str, Any]:
    """The cases of each benchmark (``quick``: fewer and smaller)."""
    ish_ls = [("PCE LS", {"order": p, "n_samples": 2 * math.comb(p + 3, 3), "rule": "lhs"})
              for p in ((6, 10) if quick else (6, 8, 10, 12))]
    ish_ls.append(("PCE quadrature", {"order": 12, "method": "quadrature"}))
    ish_ls.append(("PCE sparse auto", {**ISHIGAMI_SPARSE, "holdout": _N_HOLDOUT}))
    fb = [("PCE sparse", {"order": p, "method": "sparse", "n_samples": n, "rule": "lhs"})
          for p, n in ((6, 200), (10, 1000)) + (() if quick else ((14, 2000),))]
    fb.append(("PCE LS", {"order": 6, "n_samples": 1000, "rule": "lhs"}))
    return {
        "mc_sens": [2**8, 2**10, 2**12] if quick else [2**8, 2**10, 2**12, 2**14],
        "ishigami": ish_ls,
        "g_function": [("PCE sparse", {"order": 10, "method": "sparse", "truncation": 0.5,
                                       "n_samples": n})
                       for n in ((256, 1024) if quick else (256, 512, 1024, 2048))],
        "mc_pf": [10**3, 10**4, 10**5] if quick else [10**3, 10**4, 10**5, 10**6],
        "n_surrogate": 2 * 10**5 if quick else 10**6,
        "linear": [("PCE LS", {"order": 1, "n_samples": 8})],
        "four_branch": fb,
    }


def run(out: str | Path = "gearuq_bench_surrogate", quick: bool = False) -> dict[str, Any]:
    """Run the four benchmarks; write ``surrogate_bench.md`` and ``surrogate_bench.png``.

    Parameters
    ----------
    out : path
        Output folder (created).
    quick : bool
        Fewer and smaller settings (for CI, a few seconds).

    Returns
    -------
    dict
        ``rows`` (list of dicts: benchmark, method, setting, n_eval, wall, error, loo,
        corrected_loo, holdout, pf...), ``markdown`` (the table) and ``paths``.
    """
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    b = benchmarks()
    cfg = _settings(quick)
    rows: list[dict[str, Any]] = []
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        rows += _sens_rows("ishigami", *b["ishigami"], ishigami_exact(), cfg["mc_sens"],
                           cfg["ishigami"], "saltelli")
        rows += _sens_rows("g_function", *b["g_function"], g_function_exact(),
                           cfg["mc_sens"], cfg["g_function"], "jansen")
        rows += _pf_rows("linear", *b["linear"], LINEAR_PF, cfg["mc_pf"], cfg["linear"],
                         cfg["n_surrogate"])
        rows += _pf_rows("four_branch", *b["four_branch"], FOUR_BRANCH_PF, cfg["mc_pf"],
                         cfg["four_branch"], cfg["n_surrogate"])
    text = _markdown(rows)
    (out / "surrogate_bench.md").write_text(text)
    _figure(rows, out / "surrogate_bench.png")
    print(text)
    return {"rows": rows, "markdown": text,
            "paths": [out / "surrogate_bench.md", out / "surrogate_bench.png"]}


def _markdown(rows: list[dict[str, Any]]) -> str:
    md = [
        "# Surrogate benchmark: speed against error",
        "",
        "Error: sensitivity -- largest |S1 - exact|, |ST - exact|; reliability -- "
        "|Pf - exact| / exact. LOO / corrected LOO / hold-out: relative mean-square errors "
        "of the surrogate. Wall time on this machine, same run (analytic models: read the "
        "model-evaluation column for expensive models; hold-out runs not counted).",
        "",
        "| benchmark | method | setting | model evals | wall [s] | error | LOO | corr. LOO "
        "| hold-out |",
        "|---|---|---|---|---|---|---|---|---|",
    ]

    def e(v):
        return "" if v is None else f"{v:.1e}"

    for r in rows:
        md.append(f"| {r['benchmark']} | {r['method']} | {r['setting']} | {r['n_eval']} | "
                  f"{r['wall']:.3f} | {r['error']:.2e} | {e(r.get('loo'))} | "
                  f"{e(r.get('corrected_loo'))} | {e(r.get('holdout'))} |")
    fb_mc = [r for r in rows if r["benchmark"] == "four_branch" and r["method"] == "MC"]
    if fb_mc:
        big = fb_mc[-1]
        md += ["", f"four_branch: MC n={big['n_eval']} gives {big['pf']:.4e} "
               f"[{big['pf_lower']:.4e}, {big['pf_upper']:.4e}] (exact {FOUR_BRANCH_PF:.4e}); "
               "the global PCE surrogates smooth the kinks of the min() and are off by the "
               "error shown."]
    return "\n".join(md) + "\n"


def _figure(rows: list[dict[str, Any]], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    from matplotlib.figure import Figure

    fig = Figure(figsize=(12, 8.5), layout="constrained")
    axes = fig.subplots(2, 2).ravel()
    for ax, name in zip(axes, ("ishigami", "g_function", "linear", "four_branch"),
                        strict=True):
        sel = [r for r in rows if r["benchmark"] == name]
        for method in dict.fromkeys(r["method"] for r in sel):
            pts = sorted((r["n_eval"], max(r["error"], 1e-16)) for r in sel
                         if r["method"] == method)
            ax.plot(*zip(*pts, strict=True), "o-", ms=5, label=method)
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("model evaluations")
        ax.set_ylabel("relative Pf error (1)" if name in ("linear", "four_branch")
                      else "max |index error| (1)")
        ax.set_title(name)
        ax.grid(alpha=0.3, which="both")
        ax.legend(fontsize=7)
    fig.suptitle("Monte Carlo vs polynomial chaos: error against model evaluations "
                 "(errors below 1e-16 drawn at 1e-16)")
    fig.savefig(path, dpi=110)
