"""Li, Hu and Han Table 3 analog: Monte Carlo vibration reliability of the helical pair.

This is the study that ``gearuq demo`` runs; its code is packaged (registered as
``helical_pair_reliability`` under the ``gearuq.studies`` entry points) so the installed
command finds it. Run: ``python studies/helical_pair_reliability.py [--out DIR]``.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import gearuq

if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path,
                        default=Path("studies/output/helical_pair_reliability"))
    parser.add_argument("--n-samples", type=int, default=10_000)
    parser.add_argument("--seed", type=int, default=20240607)
    parser.add_argument("--executor", default=None)
    parser.add_argument("--keep-chunks", action=argparse.BooleanOptionalAction, default=False)
    args = parser.parse_args()
    run = gearuq.registry.get_study("helical_pair_reliability")
    raise SystemExit(run(args.out, args.n_samples, args.seed, args.executor,
                         keep_chunks=args.keep_chunks))
