"""A method's steps share one pool of worker processes, and its report counts their CPU.

Before, ``executor="processes"`` started fresh workers at every step of a method (each
subset-simulation level, each MFIS batch), seconds of imports and compiled kernels each.
"""

from __future__ import annotations

import functools
import os
import time
from pathlib import Path

import numpy as np
import pytest

import gearuq
from gearuq.failure.api import failure_probability


def _margin(x1, x2, *, folder: str, burn: float):
    # leave a mark of the process that ran this chunk; burn a known amount of CPU
    Path(folder, str(os.getpid())).touch()
    t0 = time.process_time()
    while time.process_time() - t0 < burn:
        pass
    return 3.0 - (np.asarray(x1) + np.asarray(x2)) / np.sqrt(2.0)


def _model(folder: Path, burn: float) -> gearuq.FunctionModel:
    fn = functools.partial(_margin, folder=str(folder), burn=burn)
    return gearuq.FunctionModel(fn, ["x1", "x2"], ["g"], name="plane")


@pytest.mark.e2e
def test_subset_levels_reuse_the_same_workers(tmp_path):
    space = gearuq.ParameterSpace.normal(x1=(0.0, 1.0), x2=(0.0, 1.0))
    burn = 0.02
    rep = failure_probability(_model(tmp_path, burn), space, "g", method="subset", rng=3,
                              executor="processes", chunk_size=250, n_per_level=1000)
    runs = int(rep["n_model_runs"])
    assert runs >= 3000  # at least three levels: fresh pools would show 2 pids per level
    pids = {p.name for p in tmp_path.iterdir()}
    assert str(os.getpid()) not in pids  # every chunk ran in a worker
    assert 1 <= len(pids) <= (os.cpu_count() or 1)
    # the report's CPU holds the workers' share: at least the CPU each chunk burned
    chunks = runs / 250
    assert float(rep["cpu_time"]) >= 0.9 * chunks * burn
    # and the estimate is the serial one, pool or not
    ref = failure_probability(_model(tmp_path, 0.0), space, "g", method="subset", rng=3,
                              executor="serial", chunk_size=250, n_per_level=1000)
    assert float(ref["pf"]) == float(rep["pf"])


def test_serial_cpu_time_is_the_callers(tmp_path):
    space = gearuq.ParameterSpace.normal(x1=(0.0, 1.0), x2=(0.0, 1.0))
    t0 = time.process_time()
    rep = failure_probability(_model(tmp_path, 0.005), space, "g", method="mc", rng=1,
                              n_samples=2000, chunk_size=500, executor="serial")
    spent = time.process_time() - t0
    assert 4 * 0.005 <= float(rep["cpu_time"]) <= spent + 1e-6
    assert rep["cpu_time"].attrs["units"] == "s"
