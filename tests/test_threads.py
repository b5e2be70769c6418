"""One BLAS thread inside gearuq's small dense solves, with the pools found once a process."""

from __future__ import annotations

import numpy as np
import scipy.linalg  # noqa: F401  (loads scipy's BLAS, as the solvers do)
from threadpoolctl import threadpool_info

from gearuq import _threads
from gearuq.rotor.geared import single_threaded_blas


def _blas_threads() -> list[int]:
    return [lib["num_threads"] for lib in threadpool_info() if lib["user_api"] == "blas"]


def test_one_blas_thread_limits_inside_and_restores_after():
    before = _blas_threads()
    assert before  # numpy's BLAS at least
    with _threads.one_blas_thread():
        assert _blas_threads() == [1] * len(before)
        a = np.random.default_rng(0).standard_normal((50, 50))
        np.testing.assert_allclose(np.linalg.solve(a, a @ np.ones(50)), np.ones(50),
                                   rtol=1e-8)
    assert _blas_threads() == before
    with _threads.one_blas_thread("blas"):
        assert _blas_threads() == [1] * len(before)
    assert _blas_threads() == before


def test_the_libraries_are_found_once_per_process():
    with single_threaded_blas():
        first = _threads._controller
    with single_threaded_blas(), _threads.one_blas_thread("blas"):
        assert _threads._controller is first
    assert first is not None and first is not False
