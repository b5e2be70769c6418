"""How the helical-pair references of :mod:`gearuq.testing.reliability_problems` were made.

Two independent estimates of the same probabilities, from one kind of model run: the
dynamic mesh force on ``tau = linspace(100, 200, 2001)`` (default space and options), reduced
per sample to

* ``peak``: the continuous-time peak (a parabola through every local maximum and its
  neighbours, :func:`gearuq.failure.modes.first_passage_min`), the ``"peak"`` case;
* ``peak_half``: the same on every other instant (the grid check);
* ``grid``: the largest value on the instants ``tau = 100, 101, ..., 200`` (every 20th
  instant), the earlier ``"grid"`` case: on the same instants as ``linspace(0, 200, 201)``
  the integrator's dense output gives bit-identical values (checked on 600 draws).

:func:`crude_mc` is plain Monte Carlo in chunks of 2000 draws (chunk ``k`` of seed ``s``
draws from ``SeedSequence([s, k])``), each chunk written to ``OUT/s{seed}_c{k}.npz``, so a run
resumes and several seeds pool; :func:`bounded_is` (``n`` draws per seed from
``default_rng(seed)``) is importance sampling from half the
standard normal and half a broad normal about the failure region: every weight is at most 2,
so the estimator is unbiased and its normal interval honest whatever the broad component
misses (that part is sampled at half the crude rate). Neither uses any gearuq
failure-probability method. ``python -m gearuq.testing.helical_pair_reference crude OUT
SEEDS N_CHUNKS`` / ``... is OUT SEEDS N`` / ``... summary OUT`` run them (two processes).
"""

from __future__ import annotations

import math
import os
import sys
from pathlib import Path
from typing import Any

import numpy as np
from scipy import stats

__all__ = ["peaks", "crude_mc", "bounded_is", "summary", "IS_MEAN", "IS_STD", "CHUNK"]

CHUNK = 2000
#: Centre and standard deviations (standard normal space: B1, B2, b5, rho, s, n) of the broad
#: component of :func:`bounded_is`, about where subset simulation's failing samples sit.
IS_MEAN = np.array([2.2, 2.3, 0.0, -0.2, -0.4, -0.8])
IS_STD = np.array([0.9, 0.9, 1.0, 1.0, 1.1, 1.0])
_T = np.linspace(100.0, 200.0, 2001)


def peaks(u: np.ndarray) -> dict[str, np.ndarray]:
    """``peak``, ``peak_half``, ``grid`` [N] and ``status`` of standard normal points ``u``."""
    from gearuq.failure.evaluator import LimitStateEvaluator
    from gearuq.failure.modes import first_passage_min
    from gearuq.testing.reliability_problems import helical_pair_problem

    p = helical_pair_problem("peak")
    ev = LimitStateEvaluator(p["model"], p["space"], p["limit_state"], p["t"])
    ds = p["model"].response(ev.to_physical(u), _T, outputs=["mesh_force"], parallel=False)
    f = ds["mesh_force"].values
    return {"peak": -first_passage_min(-f, _T, "parabola"),
            "peak_half": -first_passage_min(-f[:, ::2], _T[::2], "parabola"),
            "grid": f[:, ::20].max(axis=1), "status": ds["status"].values}


def _crude_chunk(args: tuple[str, int, int]) -> str:
    out, seed, k = args
    path = Path(out) / f"s{seed}_c{k:04d}.npz"
    if not path.exists():
        u = np.random.default_rng(np.random.SeedSequence([seed, k])).standard_normal((CHUNK, 6))
        tmp = path.with_suffix(".tmp.npz")
        np.savez(tmp, u=u, **peaks(u))
        os.replace(tmp, path)
    return str(path)


def crude_mc(out: str | os.PathLike, seeds: list[int], n_chunks: int, workers: int = 2
             ) -> None:
    """Crude Monte Carlo, ``n_chunks`` x 2000 draws per seed, resumable chunk by chunk."""
    from concurrent.futures import ProcessPoolExecutor

    Path(out).mkdir(parents=True, exist_ok=True)
    tasks = [(str(out), s, k) for s in seeds for k in range(n_chunks)]
    with ProcessPoolExecutor(workers) as pool:
        for i, _ in enumerate(pool.map(_crude_chunk, tasks, chunksize=1)):
            if i % 50 == 0:
                print(f"{i}/{len(tasks)} chunks", flush=True)


def is_log_weights(u: np.ndarray) -> np.ndarray:
    """``log(phi(u) / h(u))`` of :func:`bounded_is`'s density (at most log 2)."""
    lphi = -0.5 * np.sum(u * u, axis=1)
    lq = -0.5 * np.sum(((u - IS_MEAN) / IS_STD) ** 2, axis=1) - np.sum(np.log(IS_STD))
    return lphi - np.logaddexp(math.log(0.5) + lphi, math.log(0.5) + lq)


def _is_chunk(args: tuple[str, int, int]) -> str:
    out, seed, n = args
    path = Path(out) / f"is{seed}_n{n}.npz"
    if not path.exists():
        rng = np.random.default_rng(seed)
        standard = rng.random(n) < 0.5
        u = rng.standard_normal((n, 6))
        u[~standard] = IS_MEAN + u[~standard] * IS_STD
        parts = [peaks(u[k:k + 1000]) for k in range(0, n, 1000)]  # bounded memory
        tmp = path.with_suffix(".tmp.npz")
        np.savez(tmp, u=u, log_w=is_log_weights(u),
                 **{key: np.concatenate([p[key] for p in parts]) for key in parts[0]})
        os.replace(tmp, path)
    return str(path)


def bounded_is(out: str | os.PathLike, seeds: list[int], n: int = 20_000, workers: int = 2
               ) -> None:
    """Bounded-weight importance sampling, ``n`` draws per seed (one file each)."""
    from concurrent.futures import ProcessPoolExecutor

    Path(out).mkdir(parents=True, exist_ok=True)
    with ProcessPoolExecutor(workers) as pool:
        list(pool.map(_is_chunk, [(str(out), s, n) for s in seeds], chunksize=1))


def summary(out: str | os.PathLike, levels: dict[str, float], confidence: float = 0.95
            ) -> dict[str, Any]:
    """Estimates at ``levels`` (``{"peak": 76220.0, ...}``) from every chunk under ``out``:
    crude MC (count, Clopper-Pearson interval) and bounded IS (mean, normal interval)."""
    from gearuq.failure.intervals import binomial_interval

    z = stats.norm.isf((1 - confidence) / 2)
    res: dict[str, Any] = {}
    for kind, pattern in (("crude", "s*_c*.npz"), ("is", "is*_n*.npz")):
        files = sorted(Path(out).glob(pattern))
        files = [f for f in files if ".tmp" not in f.name]
        if not files:
            continue
        data = [np.load(f) for f in files]
        status = np.concatenate([d["status"] for d in data])
        w = (np.exp(np.concatenate([d["log_w"] for d in data])) if kind == "is"
             else np.ones(status.size))
        for name, level in levels.items():
            if not all(name in d.files for d in data):
                continue
            v = np.concatenate([d[name] for d in data])
            fail = (v >= level) & (status == 0)
            n = v.size
            if kind == "crude":
                k = int(fail.sum())
                lo, up = binomial_interval(k, n, confidence, "clopper-pearson")
                res[f"{kind}/{name}"] = {"n": n, "failures": k, "pf": k / n, "lower": float(lo),
                                         "upper": float(up),
                                         "invalid": int((status != 0).sum())}
            else:
                c = np.where(fail, w, 0.0)
                pf, se = float(c.mean()), float(c.std(ddof=1) / math.sqrt(n))
                res[f"{kind}/{name}"] = {"n": n, "failures": int(fail.sum()), "pf": pf,
                                         "lower": pf - z * se, "upper": pf + z * se,
                                         "cov": se / pf if pf > 0 else math.inf,
                                         "invalid": int((status != 0).sum())}
    return res


def main(argv: list[str]) -> int:
    """Command line (see the module docstring)."""
    if len(argv) >= 4 and argv[0] == "crude":
        crude_mc(argv[1], [int(s) for s in argv[2].split(",")], int(argv[3]))
    elif len(argv) >= 4 and argv[0] == "is":
        bounded_is(argv[1], [int(s) for s in argv[2].split(",")], int(argv[3]))
    elif len(argv) >= 2 and argv[0] == "summary":
        from gearuq.testing.reliability_problems import (
            HELICAL_PAIR_GRID_LEVEL,
            HELICAL_PAIR_LEVEL,
        )

        levels = {"peak": HELICAL_PAIR_LEVEL, "peak_half": HELICAL_PAIR_LEVEL,
                  "grid": HELICAL_PAIR_GRID_LEVEL}
        for key, val in summary(argv[1], levels).items():
            print(key, val)
    else:
        print(__doc__)
        return 2
    return 0


if __name__ == "__main__":  # pragma: no cover
    raise SystemExit(main(sys.argv[1:]))
