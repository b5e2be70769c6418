"""helical_pair accepts repeated output instants like every other model (issue "The
remaining holes", item 4d)."""

from __future__ import annotations

import numpy as np

import gearuq


def test_repeated_instants_are_exact_copies_of_the_distinct_ones():
    model = gearuq.get_model("helical_pair")
    params = {"n": [3600.0, 4000.0], "T": [2600.0, 1500.0]}
    outputs = ["p1", "v5", "mesh_force", "omega_n"]
    distinct = [0.0, 0.5, 1.0, 2.0]
    repeated = [0.0, 0.0, 0.5, 1.0, 1.0, 1.0, 2.0]
    ref = model.response(params, distinct, outputs=outputs)
    ds = model.response(params, repeated, outputs=outputs)
    np.testing.assert_array_equal(ds["time"].values, repeated)
    np.testing.assert_array_equal(ds["status"].values, ref["status"].values)
    assert not ds["status"].values.any()
    where = np.searchsorted(distinct, repeated)
    for name in ("p1", "v5", "mesh_force"):
        np.testing.assert_array_equal(ds[name].values, ref[name].values[:, where])
    np.testing.assert_array_equal(ds["omega_n"].values, ref["omega_n"].values)
    # the state moves between the distinct instants: the copies are not trivially equal
    assert np.ptp(ref["p1"].values, axis=1).min() > 0
