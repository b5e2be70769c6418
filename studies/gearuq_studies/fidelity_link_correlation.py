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

Run: ``python studies/fidelity_link_correlation.py [--link pair|rotor] [--n N]
[--space default|wide] [--seed S]``; prints a table (minutes for the rotor at N = 80).
"""

from __future__ import annotations

import argparse
import math
import time

import numpy as np
from scipy import stats

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


def report(res: dict, n: int) -> None:
    ok = res["ok"]
    a, b = res["hf"][ok], res["lf"][ok]
    print(f"samples: {n}, both ok: {int(ok.sum())}; quantity: {res['quantity']}")
    for name, (r, lo, hi) in correlation_intervals(a, b).items():
        print(f"  {name:9s} {r:.3f}  (95 % CI {lo:.3f} - {hi:.3f})")
    print(f"  HF mean {a.mean():.4g} sd {a.std(ddof=1):.3g}; link mean {b.mean():.4g} "
          f"sd {b.std(ddof=1):.3g}; ratio of means {b.mean() / a.mean():.3f}")
    print(f"  CPU s per sample: HF {res['t_hf'] / n:.4g}, link {res['t_lf'] / n:.4g}, "
          f"ratio {res['t_hf'] / res['t_lf']:.1f}")
    if "speed_hf" in res:
        print(f"  speed of the maximum, HF: median {np.median(res['speed_hf'][ok]):.0f} rpm "
              f"(range {res['speed_hf'][ok].min():.0f}-{res['speed_hf'][ok].max():.0f}); "
              f"link: median {np.median(res['speed_lf'][ok]):.0f} rpm "
              f"(range {res['speed_lf'][ok].min():.0f}-{res['speed_lf'][ok].max():.0f})")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--link", choices=("pair", "rotor"), default="pair")
    ap.add_argument("--n", type=int, default=None)
    ap.add_argument("--space", choices=("default", "wide"), default="default")
    ap.add_argument("--seed", type=int, default=2024)
    args = ap.parse_args()
    if args.link == "pair":
        n = args.n or 400
        report(run_pair(n, args.space, args.seed), n)
    else:
        n = args.n or 80
        report(run_rotor(n, args.seed), n)


if __name__ == "__main__":
    main()
