"""A benchmark's or study's warm-up call compiles its kernels, wherever it is started from.

Small first calls run uncompiled kernels as plain Python (gearuq._firstcall). A warm-up made
from Python without forcing the compiled route would compile nothing, and the compile would fall
into the timed call (or into every worker). Each check here makes the environment ask for the
interpreted route (``GEARUQ_KERNELS=interpreted``), which only a forced warm-up overrides, and
stops the function at its first kernel call: no integration or compile runs, so the checks take
a fraction of a second and do not depend on what this process has compiled already.
"""

from __future__ import annotations

import numpy as np
import pytest

import gearuq
from gearuq import _firstcall


class _Stop(Exception):
    """Raised at the first kernel call: what came before it is the warm-up."""


@pytest.fixture
def first_route(monkeypatch: pytest.MonkeyPatch) -> list[str]:
    """Routes chosen by the kernel calls of the test (the first one stops it)."""
    monkeypatch.setenv("GEARUQ_KERNELS", "interpreted")
    routes: list[str] = []
    choose = _firstcall.FirstCallRoute.choose

    def spy(self: _firstcall.FirstCallRoute, units: float, args: tuple):
        kernel, route = choose(self, units, args)
        routes.append(route)
        raise _Stop(self.label)

    monkeypatch.setattr(_firstcall.FirstCallRoute, "choose", spy)
    return routes


def test_kernels_route_overrides_the_environment_and_is_public(first_route):
    """The spy tells the routes apart: unforced, the environment's interpreted route holds."""
    pair = gearuq.get_model("helical_pair")
    t = np.linspace(0.0, 2.0, 3)
    with pytest.raises(_Stop):
        pair.response({}, t, outputs=["dte"])
    with gearuq.kernels_route("compiled"), pytest.raises(_Stop):
        pair.response({}, t, outputs=["dte"])
    assert first_route == ["interpreted", "compiled"]
    with pytest.raises(ValueError, match="route='fast'"):
        with gearuq.kernels_route("fast"):
            pass


def test_model_fidelity_warms_the_helical_pair_compiled(first_route):
    from gearuq_studies import model_fidelity

    with pytest.raises(_Stop, match="integrator"):
        model_fidelity.helical_curve(1e-6, np.array([500.0, 600.0]), 25.0, quick=True)
    assert first_route == ["compiled"]


def test_speed_range_bench_warms_the_ltca_compiled(first_route):
    from gearuq_studies import geared_rotor_speed_range_bench

    model = gearuq.get_model("geared_rotor")
    with pytest.raises(_Stop, match="LTCA"):
        geared_rotor_speed_range_bench.bench(model, 1)
    assert first_route == ["compiled"]


@pytest.mark.parametrize("which", ["pair", "rotor"])
def test_fidelity_link_correlation_warms_both_models_compiled(first_route, which):
    from gearuq_studies import fidelity_link_correlation as study

    with pytest.raises(_Stop):
        study.run_pair(2, "default", 1) if which == "pair" else study.run_rotor(2, 1)
    assert first_route == ["compiled"]


def test_rare_events_study_compiles_before_its_workers_start(first_route, tmp_path):
    from gearuq_studies import geared_rotor_rare_events

    with pytest.raises(_Stop, match="LTCA"):
        geared_rotor_rare_events.run(tmp_path, quick=True)
    assert first_route == ["compiled"]


def test_mesh_oscillator_bench_warms_the_continuation_compiled(first_route):
    from gearuq_plugins.mesh_oscillator import bench

    with pytest.raises(_Stop, match="continuation"):
        bench.damping_dependence(5, (0.05,))
    assert first_route == ["compiled"]


def test_a_forced_warm_up_leaves_the_kernel_compiled(monkeypatch):
    """The real thing on a fresh kernel: unforced, a small call compiles nothing; forced, the
    dispatcher holds the call's signature afterwards (nothing is timed)."""
    from numba import njit

    @njit
    def cube_sum(x):
        s = 0.0
        for v in x:
            s += v * v * v
        return s

    monkeypatch.delenv("GEARUQ_KERNELS", raising=False)
    route = _firstcall.FirstCallRoute(cube_sum, "a test kernel", unit_cpu=1e-6,
                                      compile_cpu=1.0)
    x = np.arange(4.0)
    kernel, chosen = route.choose(1.0, (x,))
    assert chosen == "interpreted" and kernel(x) == 36.0
    assert cube_sum.signatures == []
    with gearuq.kernels_route("compiled"):
        kernel, chosen = route.choose(1.0, (x,))
        assert kernel(x) == 36.0
    assert chosen == "compiled" and len(cube_sum.signatures) == 1
