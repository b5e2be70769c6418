"""Which of Li, Hu and Han's six Table 2 parameters drives the helical pair's vibration?

Ranks B1, B2, b5, rho, s, n by first-order (S1) and total (ST) Sobol' indices for each DOF's
vibration ``v_i = p_i - p_i,static`` (the response of the reliability study, ``gearuq demo``)
at tau = 200 and over tau in [0, 200] (S1(t), ST(t)), three ways: Sobol' Monte Carlo (SALib
Saltelli design and estimator), the analytic indices of a polynomial chaos surrogate, and
Morris screening; the three rankings in one table.

Response choice: the signed vibration ``v_i(tau)`` about the sample's own static position (the
plugin's outputs ``v1..v10``, computed inside each chunk) -- the quantity the tolerance bands
of the reliability study act on -- rather than an amplitude
over the last mesh periods, so the ranking answers "which parameter moves the quantity the
bands judge". Its variance across the Table 2 scatter is what the indices split.

Run: ``gearuq study sensitivity_ranking [--quick] [--out DIR]``, or
``python -m gearuq_studies.sensitivity_ranking [--n-base N]``. Writes ``indices_tau200.nc``,
``indices_time_mc.nc``, ``indices_time_pce.nc``, ``morris.nc``, ``ranking.md`` and PNG
figures into the output folder. ``--quick``: Sobol' base 64 (1024 otherwise), a PCE of degree
at most 3 on 128 points, 10 Morris trajectories, 11 instants; the small indices are then not
distinguishable from zero (their intervals say so).
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

import gearuq
from gearuq import plot
from gearuq.engines.pce import polynomial_chaos
from gearuq.engines.sensitivity import morris_screening, sobol_indices

DOFS = ["x_p", "y_p", "z_p", "theta_py", "theta_pz", "x_g", "y_g", "z_g", "theta_gy",
        "theta_gz"]
#: The plugin's vibration outputs v_i = p_i - p_i,static (each sample's own static
#: equilibrium, computed inside each chunk by the model; status-flagged when not finite).
OUTPUTS = [f"v{i + 1}" for i in range(len(DOFS))]
TAU_END = 200.0


def _rank(v: np.ndarray) -> np.ndarray:
    return np.argsort(np.argsort(-np.nan_to_num(v, nan=-np.inf))) + 1


@plot.quick_mode(
    lambda a: f"Sobol' base {a['n_base'] or 64}",
    left_out=(
        "Sobol' base 1024, the full PCE degree and design, the full Morris trajectories and "
        "instants (11 here): small indices cannot be told from zero, total indices may "
        "exceed 1"))
def run(out: str | Path = "gearuq_sensitivity_ranking", quick: bool = False,
        n_base: int | None = None, seed: int = 2024) -> int:
    """Which of Li, Hu and Han's Table 2 parameters drives the vibration: Sobol', PCE, Morris.

    Parameters
    ----------
    out : path
        Output folder (created): ``indices_tau200.nc``, ``indices_time_mc.nc``,
        ``indices_time_pce.nc``, ``morris.nc``, ``ranking.md``, ``sobol_over_time.png``,
        ``ranking_tau200.png``.
    quick : bool
        Sobol' base 64, PCE degree <= 3 on 128 points, 10 Morris trajectories, 11 instants.
    n_base : int, optional
        Sobol' base sample size (1024; 64 with ``quick``), >= 8.
    seed : int
        Seed of every random stage.

    Returns
    -------
    int
        0.
    """
    import matplotlib
    import matplotlib.pyplot as plt

    n_base = n_base or (64 if quick else 1024)
    if n_base < 8:
        raise ValueError(f"n_base={n_base}: the Sobol' base sample size must be >= 8")
    matplotlib.use("Agg")
    wall0 = time.perf_counter()
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    model = gearuq.get_model("helical_pair")
    space = model.default_space()
    names = space.names
    outs = OUTPUTS
    n_time = 11 if quick else 41
    tau = np.linspace(0.0, TAU_END, n_time)
    end = [TAU_END]

    # ---------------------------------------------------------------- Sobol' Monte Carlo
    t0 = time.perf_counter()
    mc = sobol_indices(model, space, end, n_base=n_base, outputs=outs, rng=seed,
                       estimator="saltelli", n_bootstrap=200)
    t_mc = time.perf_counter() - t0
    # ---------------------------------------------------------------- PCE (degree by LOO)
    t0 = time.perf_counter()
    # sparse (hybrid LARS) so that terms the data do not support are dropped rather than
    # soaking up the misfit of the min(B1, B2) kink
    pce = polynomial_chaos(model, space, tau, order="auto", max_order=3 if quick else 4,
                           method="sparse", outputs=outs, n_samples=128 if quick else 512,
                           rng=seed + 1,
                           n_holdout=0 if quick else 200)
    t_pce = time.perf_counter() - t0
    pce_end = [pce.sobol(o).isel(time=-1) for o in outs]
    # ---------------------------------------------------------------- Morris
    t0 = time.perf_counter()
    mor = morris_screening(model, space, end, n_trajectories=10 if quick else 40,
                           outputs=outs, rng=seed + 2)
    t_mor = time.perf_counter() - t0
    mc.attrs["response"] = "v_i = p_i - static p_i at tau = 200"
    gearuq.save(mc, out / "indices_tau200.nc")
    gearuq.save(mor, out / "morris.nc")

    # ---------------------------------------------------------------- over time (MC + PCE)
    t0 = time.perf_counter()
    mc_t = sobol_indices(model, space, tau, n_base=max(32 if quick else 64, n_base // 4),
                         outputs=outs,
                         rng=seed + 3, estimator="jansen", n_bootstrap=100)
    t_mct = time.perf_counter() - t0
    pce_t = [pce.sobol(o) for o in outs]
    import xarray as xr

    pce_time = xr.concat([p[["S1", "ST"]] for p in pce_t],
                         dim=xr.DataArray(outs, dims="output", name="output"))
    pce_time.attrs.update({"method": "pce", "order": pce.order,
                           "n_model_evaluations": pce.n_evaluations})
    gearuq.save(mc_t, out / "indices_time_mc.nc")
    gearuq.save(pce_time, out / "indices_time_pce.nc")

    # ---------------------------------------------------------------- table
    lines = [
        "# Sensitivity ranking of Li, Hu and Han Table 2 parameters",
        "",
        "Response: v_i(tau = 200) = p_i - static p_i (the reliability study's quantity).",
        f"Sobol' MC: SALib Saltelli, N = {n_base}, {mc.attrs['n_model_evaluations']} runs, "
        f"{t_mc:.1f} s. PCE: order {pce.order} (sparse LARS, degree chosen by corrected LOO "
        f"of 1..{3 if quick else 4}), "
        f"{pce.n_evaluations} runs incl. hold-out ({pce.n_failed} failed, excluded from the "
        f"fit; a failed Sobol' or Morris run stops the study), {t_pce:.1f} s, LOO error "
        f"{np.mean(list(pce.loo_error.values())):.2e} (mean over DOFs). Morris: "
        f"{mor.attrs['n_model_evaluations']} runs, {t_mor:.1f} s.",
        "",
        "| DOF | method | " + " | ".join(names) + " | top |",
        "|---|---|" + "---|" * (len(names) + 1),
    ]
    top_counts: dict[str, int] = {}
    for i, o in enumerate(outs):
        s1 = mc["S1"].sel(output=o).isel(time=0).values
        st = mc["ST"].sel(output=o).isel(time=0).values
        c1 = mc["ST_conf"].sel(output=o).isel(time=0).values
        p1 = pce_end[i]["S1"].values
        pt = pce_end[i]["ST"].values
        ms = mor["mu_star"].sel(output=o).isel(time=0).values
        rows = [
            ("MC S1", s1, None), ("MC ST", st, c1), ("PCE S1", p1, None), ("PCE ST", pt, None),
            ("Morris mu*", ms / np.nanmax(ms), None),
        ]
        for label, v, conf in rows:
            r = _rank(v)
            cells = [f"{v[j]:.3f}" + (f"±{conf[j]:.3f}" if conf is not None else "")
                     + f" ({r[j]})" for j in range(len(names))]
            top = names[int(np.argmin(r))]
            top_counts[f"{label}:{top}"] = top_counts.get(f"{label}:{top}", 0) + 1
            lines.append(f"| {DOFS[i]} | {label} | " + " | ".join(cells) + f" | {top} |")
    def top2(v):
        return frozenset(names[j] for j in np.argsort(-np.nan_to_num(v, nan=-np.inf))[:2])

    agree = sum(
        top2(mc["ST"].sel(output=o).isel(time=0).values) == top2(pce_end[i]["ST"].values)
        == top2(mor["mu_star"].sel(output=o).isel(time=0).values)
        for i, o in enumerate(outs))
    cv = {k: space.std()[k] / abs(space.mean()[k]) for k in names}
    sum_s1 = float(mc["S1"].isel(time=0).sum("parameter").mean())
    sum_st = float(mc["ST"].isel(time=0).sum("parameter").mean())
    lines += [
        "",
        "(value (rank); Morris mu* normalised by the largest; MC ST with its 95 % bootstrap "
        "half-width)",
        "",
        f"The top two parameters (by MC ST, PCE ST, Morris mu*) are the same set for {agree} "
        f"of {len(outs)} DOFs; B1 and B2 enter symmetrically (min(B1, B2)), so their order "
        "within the pair is within sampling error.",
        "",
        "Coefficients of variation of the Table 2 inputs: " + ", ".join(
            f"{k} {v:.1e}" for k, v in cv.items()) + ".",
        "",
        f"Sum of MC S1 over the parameters (DOF-averaged): {sum_s1:.2f}; sum of ST: "
        f"{sum_st:.2f}. PCE LOO error (mean over DOFs) "
        f"{np.mean(list(pce.loo_error.values())):.2e}"
        + (f", hold-out {np.mean(list(pce.holdout_error.values())):.2e}."
           if pce.holdout_error else "."),
        "",
        "Why: the Table 2 standard deviations are tiny (CoV 4e-5 to 5e-3) so only the "
        "parameters whose scatter moves the response most relative to the others matter. The "
        "face widths B1, B2 dominate because the mesh stiffness uses the effective contact "
        "width b = min(B1, B2) (equal means, so half the samples take each one): the response "
        "has a kink along B1 = B2, which is why S1 << ST for both (an interaction, not a "
        "nonlinearity in either alone) and why a global polynomial fits it poorly (LOO "
        "above). n, rho, b5, s have CoVs of 1e-4 or less of a mesh-frequency effect (n) or "
        "enter weakly (s: 3.3e-3 of a 0.1 stiffness ripple) and are not distinguishable "
        "from zero at this N (flagged in the netCDF). The ranking is that of the Table 2 "
        "scatter, not of the physical importance of a parameter over a design range.",
    ]
    text = "\n".join(lines)
    (out / "ranking.md").write_text(text + "\n")

    # ---------------------------------------------------------------- figures
    fig, axes = plt.subplots(2, 5, figsize=(18, 6.5), sharex=True, sharey=True,
                             layout="constrained")
    for ax, o, dof in zip(axes.ravel(), outs, DOFS, strict=True):
        for j, k in enumerate(names):
            line, = ax.plot(tau, pce_time["ST"].sel(output=o, parameter=k), lw=1.4, label=k)
            ax.plot(mc_t["time"], mc_t["ST"].sel(output=o, parameter=k), "o", ms=2.5,
                    color=line.get_color())
            ax.plot(tau, pce_time["S1"].sel(output=o, parameter=k), ":", lw=1.0,
                    color=line.get_color())
            del j
        ax.set_title(f"{dof} ({o})")
        ax.set_ylim(-0.05, 1.05)
        ax.grid(alpha=0.3)
    for ax in axes[-1]:
        ax.set_xlabel("tau (nondimensional time, 1)")
    for ax in axes[:, 0]:
        ax.set_ylabel("Sobol index (1)")
    axes[0, 0].legend(fontsize=7, ncol=2)
    fig.suptitle("ST(tau): PCE (line), Sobol' MC Jansen (dots); S1(tau) PCE dotted")
    plot.save_figure(fig, out / "sobol_over_time.png", dpi=110)
    plt.close(fig)

    fig, axes = plt.subplots(1, 3, figsize=(16, 4.6), layout="constrained")
    x = np.arange(len(outs))
    width = 0.8 / len(names)
    for j, k in enumerate(names):
        axes[0].bar(x + j * width, mc["ST"].sel(parameter=k).isel(time=0), width,
                    yerr=mc["ST_conf"].sel(parameter=k).isel(time=0), label=k)
        axes[1].bar(x + j * width, [pce_end[i]["ST"].sel(parameter=k) for i in range(10)],
                    width, label=k)
        ms = mor["mu_star"].isel(time=0)
        axes[2].bar(x + j * width, (ms / ms.max("parameter")).sel(parameter=k), width, label=k)
    for ax, title, ylabel in zip(
            axes, ["Sobol' MC ST (95 % bootstrap)", f"PCE ST (order {pce.order})",
                   "Morris mu* / max"],
            ["total Sobol index ST (1)", "total Sobol index ST (1)",
             "mu* over its largest value (1)"], strict=True):
        ax.set_ylabel(ylabel)
        ax.set_xticks(x + 0.4, DOFS, rotation=45, fontsize=8)
        ax.set_title(title)
        ax.grid(alpha=0.3, axis="y")
    axes[0].legend(fontsize=7)
    fig.suptitle("Total-effect ranking at tau = 200 of v_i = p_i - static p_i")
    plot.save_figure(fig, out / "ranking_tau200.png", dpi=110)
    plt.close(fig)

    print(text)
    print(f"\nover time: MC Jansen N={mc_t.attrs['n_base']} "
          f"({mc_t.attrs['n_model_evaluations']} runs, {t_mct:.1f} s), PCE from the same fit")
    print(f"wall time {time.perf_counter() - wall0:.1f} s; written to {out}")
    return 0


def main(argv: list[str] | None = None) -> int:
    """Command line: ``python -m gearuq_studies.sensitivity_ranking``."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("gearuq_sensitivity_ranking"))
    parser.add_argument("--n-base", type=int, default=None, help="Sobol' base (1024)")
    parser.add_argument("--quick", action="store_true", help="Sobol' base 64, coarser PCE")
    args = parser.parse_args(argv)
    return run(args.out, quick=args.quick, n_base=args.n_base)


if __name__ == "__main__":
    raise SystemExit(main())
