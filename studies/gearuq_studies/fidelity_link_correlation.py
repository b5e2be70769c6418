"""How well does each fidelity link follow its high-fidelity model, and what does it cost?

For each registered link (``gearuq.registry.get_link``) the high-fidelity (HF) model and the
link run on the same draws of the HF default space (or of a wider engineering space, see
below), and the quantity a reliability study would threshold is compared: Pearson and
Spearman correlation with 95 % intervals (Fisher z; for Spearman with the Fieller-Hartley-
Pearson variance 1.06 / (n - 3)), means, the process CPU seconds per sample of both models
(warm: a first small call compiles and fills caches) and their ratio.

- ``helical_pair -> mesh_oscillator``: the peak mesh force over tau in [100, 200] on
  ``t = linspace(0, 200, 201)`` (the helical-pair rare-event limit state), over the pair's
  default space and over a wider engineering space (``--space wide``: torque 1500-3500 N m,
  speed 2500-5500 rpm, stiffness variation s 0.05-0.2, error amplitude 0-15 um, damping
  0.03-0.12 uniform, on top of the default space), where the force itself varies by tens of
  percent.
- ``geared_rotor -> mesh_oscillator``: ``dte_rms_max`` over 25-8000 rpm (160 speeds) and
  the speed where it sits, over the rotor's default space.

Run: ``gearuq study fidelity_link_correlation [--quick] [--out DIR]`` (the pair link over its
default space, 400 samples; ``--quick``: 60), or
``python -m gearuq_studies.fidelity_link_correlation [--link pair|rotor] [--n N]
[--space default|wide] [--seed S]`` (minutes for the rotor at N = 80; ``--quick``: 6). Prints
a table and writes ``correlation.nc`` (both models' values per sample), ``correlation.md``
and ``scatter.png`` into the output folder.
"""

from __future__ import annotations

import argparse
import math
import time
from pathlib import Path

import numpy as np
import xarray as xr
from scipy import stats

import gearuq
from gearuq import plot
from gearuq.failure.modes import LimitState
from gearuq.registry import get_link
from gearuq.space import ParameterSpace


def correlation_intervals(a: np.ndarray, b: np.ndarray) -> dict[str, tuple[float, float, float]]:
    """Pearson and Spearman correlation with 95 % Fisher-z intervals."""
    n = a.size
    out = {}
    for name, r, var in (("pearson", stats.pearsonr(a, b)[0], 1.0 / (n - 3)),
                         ("spearman", stats.spearmanr(a, b)[0], 1.06 / (n - 3))):
        z, h = math.atanh(r), 1.959964 * math.sqrt(var)
        out[name] = (float(r), math.tanh(z - h), math.tanh(z + h))
    return out


def _timed(fn):
    t0 = time.process_time()
    value = fn()
    return value, time.process_time() - t0


def wide_pair_space(pair) -> ParameterSpace:
    """The pair's default space with the operating point and mesh data spread wider."""
    wide = {"T": (1500.0, 3500.0), "n": (2500.0, 5500.0), "s": (0.05, 0.2),
            "e_a": (0.0, 15e-6), "zeta_m": (0.03, 0.12)}
    spec = {p.pop("name"): p for p in pair.default_space().to_dict()["parameters"]
            if p["name"] not in wide}
    spec |= {k: {"dist": "uniform", "lower": lo, "upper": hi} for k, (lo, hi) in wide.items()}
    return ParameterSpace(spec)


def run_pair(n: int, space_kind: str, seed: int) -> dict:
    link = get_link("helical_pair", "mesh_oscillator")
    pair = link.high
    space = pair.default_space() if space_kind == "default" else wide_pair_space(pair)
    t = np.linspace(0.0, 200.0, 201)
    limit = LimitState.upper("mesh_force", 0.0, window=(100.0, 200.0))
    warm = space.sample(4, rng=seed + 1)
    with gearuq.kernels_route("compiled"):  # a warm-up compiles: the timings below must not
        pair.response(warm, t, outputs=["mesh_force"])
        link.response(warm, t, outputs=["mesh_force"])
    x = space.sample(n, rng=seed)
    hf, t_hf = _timed(lambda: pair.response(x, t, outputs=["mesh_force"]))
    lf, t_lf = _timed(lambda: link.response(x, t, outputs=["mesh_force"]))
    a, b = -limit.sample_values(hf), -limit.sample_values(lf)
    return {"quantity": "peak mesh force [N]", "hf": a, "lf": b, "t_hf": t_hf, "t_lf": t_lf,
            "ok": (hf["status"].values == 0) & (lf["status"].values == 0)}


def run_rotor(n: int, seed: int) -> dict:
    link = get_link("geared_rotor", "mesh_oscillator")
    rotor = link.high
    space = rotor.default_space()
    outs = ["dte_rms_max", "speed_at_dte_rms_max"]
    warm = space.sample(2, rng=seed + 1)
    with gearuq.kernels_route("compiled"):
        rotor.response(warm, None, outputs=outs)
        link.response(warm, None, outputs=outs)
    x = space.sample(n, rng=seed)
    hf, t_hf = _timed(lambda: rotor.response(x, None, outputs=outs))
    lf, t_lf = _timed(lambda: link.response(x, None, outputs=outs))
    return {"quantity": "dte_rms_max [um]", "hf": hf["dte_rms_max"].values * 1e6,
            "lf": lf["dte_rms_max"].values * 1e6, "t_hf": t_hf, "t_lf": t_lf,
            "speed_hf": hf["speed_at_dte_rms_max"].values,
            "speed_lf": lf["speed_at_dte_rms_max"].values,
            "ok": (hf["status"].values == 0) & (lf["status"].values == 0)}


def report(res: dict, n: int) -> list[str]:
    """The summary lines (printed and written to ``correlation.md``)."""
    ok = res["ok"]
    a, b = res["hf"][ok], res["lf"][ok]
    lines = [f"samples: {n}, both ok: {int(ok.sum())}; quantity: {res['quantity']}"]
    for name, (r, lo, hi) in correlation_intervals(a, b).items():
        lines.append(f"  {name:9s} {r:.3f}  (95 % CI {lo:.3f} - {hi:.3f})")
    lines.append(f"  HF mean {a.mean():.4g} sd {a.std(ddof=1):.3g}; link mean {b.mean():.4g} "
                 f"sd {b.std(ddof=1):.3g}; ratio of means {b.mean() / a.mean():.3f}")
    lines.append(f"  CPU s per sample: HF {res['t_hf'] / n:.4g}, link {res['t_lf'] / n:.4g}, "
                 f"ratio {res['t_hf'] / max(res['t_lf'], 1e-9):.1f}")
    if "speed_hf" in res:
        lines.append(
            f"  speed of the maximum, HF: median {np.median(res['speed_hf'][ok]):.0f} rpm "
            f"(range {res['speed_hf'][ok].min():.0f}-{res['speed_hf'][ok].max():.0f}); "
            f"link: median {np.median(res['speed_lf'][ok]):.0f} rpm "
            f"(range {res['speed_lf'][ok].min():.0f}-{res['speed_lf'][ok].max():.0f})")
    return lines


def to_dataset(res: dict, link: str, space_kind: str, seed: int) -> xr.Dataset:
    """Both models' values per sample, the correlations as attributes."""
    unit = res["quantity"].split("[")[-1].rstrip("]")
    ok = res["ok"]
    data = {"high_fidelity": ("sample", res["hf"], {"units": unit, "long_name": res["quantity"]
                                                   + " of the high-fidelity model"}),
            "link": ("sample", res["lf"], {"units": unit, "long_name": res["quantity"]
                                           + " of the fidelity link"}),
            "status": ("sample", np.where(ok, 0, 1).astype(np.int8),
                       {"long_name": "0 when both models succeeded"})}
    for key in ("speed_hf", "speed_lf"):
        if key in res:
            data[key] = ("sample", res[key], {"units": "rpm"})
    corr = correlation_intervals(res["hf"][ok], res["lf"][ok])
    attrs = {"link": link, "space": space_kind, "seed": seed,
             "cpu_s_per_sample_high": res["t_hf"] / ok.size,
             "cpu_s_per_sample_link": res["t_lf"] / ok.size}
    for name, (r, lo, hi) in corr.items():
        attrs |= {f"{name}": r, f"{name}_lower": lo, f"{name}_upper": hi}
    return xr.Dataset(data, coords={"sample": np.arange(ok.size)}, attrs=attrs)


def scatter_figure(ds: xr.Dataset, title: str):
    """Link against high fidelity, one point per sample, with the identity line."""
    from matplotlib.figure import Figure

    ok = ds["status"].values == 0
    a, b = ds["high_fidelity"].values[ok], ds["link"].values[ok]
    unit = ds["high_fidelity"].attrs["units"]
    fig = Figure(figsize=(6.0, 5.2), layout="constrained")
    ax = fig.subplots()
    ax.plot(a, b, "o", ms=4, mfc="none", color="tab:blue",
            label=f"samples (Pearson {ds.attrs['pearson']:.3f}, Spearman "
                  f"{ds.attrs['spearman']:.3f})")
    lo, hi = float(min(a.min(), b.min())), float(max(a.max(), b.max()))
    ax.plot([lo, hi], [lo, hi], "--", color="0.3", lw=1, label="link = high fidelity")
    ax.set(xlabel=f"high-fidelity model [{unit}]", ylabel=f"fidelity link [{unit}]",
           title=title)
    ax.title.set_fontsize(9)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    return fig


@plot.quick_mode(
    lambda a: f"{a['n'] or (60 if a['link'] == 'pair' else 6)} samples",
    left_out=(
        "400 pair samples (80 for the rotor's link): the correlations' intervals are wide"))
def run(out: str | Path = "gearuq_fidelity_link_correlation", quick: bool = False,
        link: str = "pair", n: int | None = None, space: str = "default",
        seed: int = 2024) -> int:
    """How closely each cheap fidelity link follows its expensive model, and what it saves.

    Parameters
    ----------
    out : path
        Output folder (created): ``correlation.nc``, ``correlation.md``, ``scatter.png``.
    quick : bool
        60 samples for the pair link (400 otherwise), 6 for the rotor link (80 otherwise).
    link : {"pair", "rotor"}
        ``helical_pair -> mesh_oscillator`` or ``geared_rotor -> mesh_oscillator``.
    n : int, optional
        Number of samples (overrides ``quick``).
    space : {"default", "wide"}
        The pair's default space or the wider engineering space (pair link only).
    seed : int
        Seed of the draws.

    Returns
    -------
    int
        0, or 1 when fewer than 4 samples succeeded on both models (no correlation).
    """
    if link not in ("pair", "rotor"):
        raise ValueError(f"link={link!r}: valid 'pair', 'rotor'")
    if space not in ("default", "wide"):
        raise ValueError(f"space={space!r}: valid 'default', 'wide'")
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    if link == "pair":
        n = n or (60 if quick else 400)
        res = run_pair(n, space, seed)
        title = f"helical_pair -> mesh_oscillator, {space} space, {n} samples"
    else:
        n = n or (6 if quick else 80)
        res = run_rotor(n, seed)
        title = f"geared_rotor -> mesh_oscillator, default space, {n} samples"
    if int(res["ok"].sum()) < 4:
        print(f"only {int(res['ok'].sum())} of {n} samples succeeded on both models: no "
              "correlation can be estimated")
        return 1
    lines = report(res, n)
    print("\n".join(lines))
    ds = to_dataset(res, link, space, seed)
    gearuq.save(ds, out / "correlation.nc")
    (out / "correlation.md").write_text(f"# {title}\n\n```\n" + "\n".join(lines)
                                        + "\n```\n")
    from gearuq.plot import save_figure

    save_figure(scatter_figure(ds, title), out / "scatter.png")
    print(f"written: {out} (correlation.nc, correlation.md, scatter.png)")
    return 0


def main(argv: list[str] | None = None) -> int:
    """Command line: ``python -m gearuq_studies.fidelity_link_correlation``."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, default=Path("gearuq_fidelity_link_correlation"))
    ap.add_argument("--quick", action="store_true", help="60 pair / 6 rotor samples")
    ap.add_argument("--link", choices=("pair", "rotor"), default="pair")
    ap.add_argument("--n", type=int, default=None)
    ap.add_argument("--space", choices=("default", "wide"), default="default")
    ap.add_argument("--seed", type=int, default=2024)
    args = ap.parse_args(argv)
    return run(args.out, quick=args.quick, link=args.link, n=args.n, space=args.space,
               seed=args.seed)


if __name__ == "__main__":
    raise SystemExit(main())
