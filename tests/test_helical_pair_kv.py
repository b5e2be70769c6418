"""The helical pair's dynamic factor K_v: largest mesh force over the static one.

Oracles: the static normal force from a hand formula (the torque over the base-circle arm in
the normal direction), the torque balance of a periodic steady state (the mean mesh force
carries the torque exactly, whatever the dynamics), and the excitation-free pair (K_v = 1).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import gearuq

Z1, M_N, BETA, ALPHA_N, TORQUE = 34, 0.006, 17.0, 25.0, 2600.0  # the model's nominal pair


def static_normal_force() -> float:
    """T / (r_p cos a_n cos b): the normal force whose torsional part carries T."""
    r_p = M_N * Z1 / math.cos(math.radians(BETA)) / 2.0
    return TORQUE / r_p / (math.cos(math.radians(ALPHA_N)) * math.cos(math.radians(BETA)))


@pytest.fixture(scope="module")
def model():
    return gearuq.get_model("helical_pair")


def _window(n_rpm: float, settle: int, periods: int, points: int) -> np.ndarray:
    period = 60.0 / (n_rpm * Z1)
    return np.linspace(settle * period, (settle + periods) * period, points)


def test_mean_mesh_force_carries_the_torque_and_kv_is_its_peak(model):
    t = _window(3000.0, 200, 10, 2001)
    ds = model.response({"n": 3000.0}, t, outputs=["kv", "mesh_force"], time="s")
    assert int(ds["status"][0]) == 0
    force = ds["mesh_force"].values[0]
    f_static = static_normal_force()
    # torque balance over whole mesh periods of the steady state (torsion has no support)
    assert force[:-1].mean() / f_static == pytest.approx(1.0, abs=1e-4)
    kv = float(ds["kv"][0])
    assert kv == pytest.approx(force.max() / f_static, rel=1e-9)
    assert kv > 1.2  # near the pair's mesh resonance the dynamics do lift the force


def test_kv_is_one_without_excitation(model):
    # no stiffness variation, no static error: the force stays the static one at any speed
    t = _window(1000.0, 200, 10, 2001)
    ds = model.response({"n": 1000.0, "s": 0.0, "e_a": 0.0}, t, outputs="kv", time="s")
    assert float(ds["kv"][0]) == pytest.approx(1.0, abs=1e-4)


def test_kv_tends_to_one_in_the_quasi_static_limit(model):
    values = []
    for n in (4000.0, 400.0, 20.0):
        ds = model.response({"n": n}, _window(n, 20, 3, 601), outputs="kv", time="s")
        values.append(float(ds["kv"][0]))
    assert values[0] > values[1] > values[2] >= 1.0 - 1e-6
    assert values[2] - 1.0 < 2e-3


def test_kv_without_torque_is_flagged(model):
    ds = model.response({"n": 1000.0, "T": 0.0}, _window(1000.0, 2, 2, 101),
                        outputs="kv", time="s")
    assert int(ds["status"][0]) != 0
    assert "kv_undefined_without_torque" in ds["status"].attrs["flag_meanings"]
    assert np.isnan(float(ds["kv"][0]))
