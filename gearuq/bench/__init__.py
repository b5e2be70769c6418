"""Benchmarks behind ``gearuq bench``: one package, one module per question.

- :mod:`gearuq.bench.core`: the batched integrator's work-precision and the cold start
  (``gearuq bench integrator``, ``gearuq bench startup``), plus the shared helpers
  :func:`machine_description` and :func:`best_time`;
- :mod:`gearuq.bench.memory`: peak memory of Monte Carlo against sample count;
- :mod:`gearuq.bench.reliability`: speed against error and interval coverage of every
  reliability method (``gearuq bench reliability [--coverage]``);
- :mod:`gearuq.bench.surrogate`: Monte Carlo against PCE on analytic oracles.

Benchmarks compare side by side in one run and report the machine; tests assert their ratios
and errors, never seconds.
"""

from gearuq.bench.core import best_time, machine_description, run_bench

__all__ = ["best_time", "machine_description", "run_bench"]
