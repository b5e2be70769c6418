"""Seed 000 Table 3 analog: Monte Carlo vibration reliability of the helical pair.

This is the study that ``gearuq demo`` runs (the code lives in :mod:`gearuq.demo` so the
installed command finds it). Run: ``python studies/helical_pair_reliability.py [--out DIR]``.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from gearuq.demo import run_demo

if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path,
                        default=Path("studies/output/helical_pair_reliability"))
    parser.add_argument("--n-samples", type=int, default=10_000)
    parser.add_argument("--seed", type=int, default=20240607)
    parser.add_argument("--executor", default=None)
    args = parser.parse_args()
    raise SystemExit(run_demo(args.out, args.n_samples, args.seed, args.executor))
