"""Tests of gearuq.engines.montecarlo and gearuq.execution: estimates, reproducibility across
chunk sizes and executors, durable resumable runs, failing chunks and input errors."""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import numpy as np
import pytest
import xarray as xr
from scipy import stats

import gearuq
from gearuq.engines.montecarlo import estimate_mean, monte_carlo, resolve_seed
from gearuq.execution import (
    ChunkStore,
    ProcessRunner,
    StoreMismatchError,
    chunk_bounds,
    default_chunk_size,
    resolve_executor,
)
from gearuq.model import Output, Parameter
from gearuq.space import ParameterSpace

REPO = Path(gearuq.__file__).resolve().parents[1]
# what a run cost (a resumed run evaluates only the missing chunks) differs from run to run;
# the results themselves may not
VOLATILE = ("created", "executor", "executor_reason", "chunk_size", "n_chunks", "store",
            "reused_chunks", "n_evaluations", "n_reused_samples", "cpu_seconds",
            "worker_cpu_seconds")


# ------------------------------------------------------------------------------- models
def _sum_fn(x1, x2):
    return x1 + x2


def _oscillating(a, b, c, t):
    y = a[:, None] * np.sin(b[:, None] * t[None, :]) + c[:, None] * t[None, :] ** 2
    return {"y": y, "peak": a * b + np.exp(-c) / 3.0}


def sum_model():
    return gearuq.FunctionModel(_sum_fn, ["x1", "x2"], ["y"], name="sum", version="1")


def osc_model():
    return gearuq.FunctionModel(
        _oscillating,
        [Parameter("a", "m", 1.0, 0.0, 10.0), Parameter("b", "rad s-1", 2.0, 0.0, 10.0),
         Parameter("c", "1", 0.1, -5.0, 5.0)],
        [Output("y", "m", ("sample", "time")), Output("peak", "m", ("sample",))],
        name="osc",
        version="2",
    )


def osc_space():
    return ParameterSpace.from_spec(
        [{"name": "a", "dist": "lognormal", "mean": 1.0, "std": 0.2},
         {"name": "b", "dist": "uniform", "lower": 1.0, "upper": 3.0}],
        correlation={("a", "b"): 0.3},
    )


T = np.linspace(0.0, 2.0, 9)


def _data(ds):
    """Copy of ``ds`` without the attributes that legitimately differ between runs."""
    out = ds.copy()
    out.attrs = {k: v for k, v in ds.attrs.items() if k not in VOLATILE}
    return out


# ------------------------------------------------------------------------------- estimates
def test_sum_of_normals_matches_exact_answer_within_99_percent_intervals():
    space = ParameterSpace.normal(x1=(1.0, 0.3), x2=(2.0, 0.4))
    n = 20_000
    ds = monte_carlo(sum_model(), space, n_samples=n, rng=2024, executor="serial",
                     progress=False)
    y = ds["y"].values
    mu, sd = 3.0, 0.5
    z99 = stats.norm.ppf(0.995)
    assert abs(y.mean() - mu) < z99 * sd / math.sqrt(n)
    chi = (n - 1) * y.var(ddof=1) / sd**2
    assert stats.chi2.ppf(0.005, n - 1) < chi < stats.chi2.ppf(0.995, n - 1)
    c = 3.8
    p_exact = stats.norm.sf((c - mu) / sd)
    k = int((y > c).sum())
    lo, hi = stats.beta.ppf(0.005, k, n - k + 1), stats.beta.ppf(0.995, k + 1, n - k)
    assert lo < p_exact < hi
    est = estimate_mean(ds, "y", confidence=0.99)
    assert float(est["ci_lower"]) < mu < float(est["ci_upper"])
    assert float(est["sem"]) == pytest.approx(y.std(ddof=1) / math.sqrt(n))
    assert float(est["cov"]) == pytest.approx(sd / mu, rel=0.03)
    assert float(est["rel_se"]) == pytest.approx(float(est["sem"]) / abs(y.mean()))
    assert int(est["n"]) == n


def test_estimate_mean_per_time_and_excludes_failed_samples():
    ds = monte_carlo(osc_model(), osc_space(), T, n_samples=200, rng=1, executor="serial",
                     progress=False)
    ds["status"][:10] = 4
    est = estimate_mean(ds, "y")
    assert est["mean"].dims == ("time",)
    np.testing.assert_allclose(est["mean"], ds["y"][10:].mean("sample"))
    assert int(est["n"][0]) == 190
    with pytest.raises(ValueError, match="no variable 'zz'"):
        estimate_mean(ds, "zz")


@pytest.mark.e2e
def test_lhs_reduces_variance_for_a_monotone_output():
    model = gearuq.FunctionModel(lambda x1, x2: np.exp(x1) * (1.0 + x2) + x2**3,
                                 ["x1", "x2"], ["y"], name="mono")
    space = ParameterSpace.uniform(x1=(0.0, 1.0), x2=(0.0, 1.0))
    means = {}
    for rule in ("random", "lhs"):
        means[rule] = np.array([
            float(monte_carlo(model, space, n_samples=100, rule=rule, rng=seed,
                              executor="serial", progress=False)["y"].mean())
            for seed in range(50)
        ])
    exact = (math.e - 1) * 1.5 + 0.25
    ratio = means["lhs"].var(ddof=1) / means["random"].var(ddof=1)
    print(f"LHS/MC variance ratio of the mean estimator (n=100, 50 seeds): {ratio:.4f}")
    assert ratio < 0.1
    assert abs(means["lhs"].mean() - exact) < 5 * means["lhs"].std(ddof=1) / math.sqrt(50)


@pytest.mark.parametrize("rule", ["sobol", "halton"])
def test_qmc_rules_run_and_record(rule):
    space = ParameterSpace.normal(x1=(1.0, 0.3), x2=(2.0, 0.4))
    ds = monte_carlo(sum_model(), space, n_samples=256, rule=rule, rng=3, executor="serial",
                     progress=False)
    assert ds.attrs["rule"] == rule
    assert abs(float(ds["y"].mean()) - 3.0) < 0.01


# ------------------------------------------------------------------------------- provenance
def test_result_layout_and_provenance(tmp_path):
    space = osc_space()
    ds = monte_carlo(osc_model(), space, T, n_samples=50, rng=7, executor="serial",
                     chunk_size=16, progress=False, outputs=["y", "peak"])
    assert list(ds["sample"].values) == list(range(50))
    np.testing.assert_array_equal(ds["time"], T)
    assert ds["y"].dims == ("sample", "time") and ds["peak"].dims == ("sample",)
    np.testing.assert_array_equal(ds["c"], 0.1)  # not in the space: nominal value
    a = ds.attrs
    assert a["gearuq_version"] == gearuq.__version__
    assert (a["model"], a["model_version"], a["engine"]) == ("osc", "2", "monte_carlo")
    assert ParameterSpace.from_json(a["space"]) == space
    assert (a["rule"], a["seed"], a["n_samples"], a["chunk_size"]) == ("random", 7, 50, 16)
    assert a["executor"] == "serial" and a["n_failed"] == 0
    assert json.loads(a["options"]) == {}
    assert "T" in a["created"]
    # the recorded seed reproduces the design
    x = space.sample(50, rule="random", rng=a["seed"])
    np.testing.assert_array_equal(ds["a"], x["a"])
    # netCDF-safe attributes
    ds.to_netcdf(tmp_path / "mc.nc", engine="netcdf4")


def test_seed_drawn_and_recorded_when_rng_is_none_or_generator(tmp_path):
    space = ParameterSpace.normal(x1=(1.0, 0.3), x2=(2.0, 0.4))
    ds = monte_carlo(sum_model(), space, n_samples=20, executor="serial", progress=False)
    seed = ds.attrs["seed"]
    assert isinstance(seed, int) and 0 <= seed < 2**63
    again = monte_carlo(sum_model(), space, n_samples=20, rng=seed, executor="serial",
                        progress=False)
    xr.testing.assert_equal(_data(ds).drop_attrs(), _data(again).drop_attrs())
    g1 = monte_carlo(sum_model(), space, n_samples=20, rng=np.random.default_rng(5),
                     executor="serial", progress=False)
    assert g1.attrs["seed"] == resolve_seed(np.random.default_rng(5))
    ds.to_netcdf(tmp_path / "seed.nc", engine="netcdf4")


def test_model_by_registered_name():
    from gearuq.registry import register_model

    register_model("test_mc_sum", sum_model, overwrite=True)
    space = ParameterSpace.normal(x1=(1.0, 0.3))
    ds = monte_carlo("test_mc_sum", space, n_samples=10, rng=1, executor="serial",
                     progress=False)
    assert ds.attrs["model"] == "sum"
    np.testing.assert_array_equal(ds["x2"], 0.0)


# ------------------------------------------------------------------------------- reproducibility
# 2-6 s of CPU: CI runs it with the end-to-end runs (-m e2e)
@pytest.mark.e2e
def test_bit_identical_for_chunk_sizes_and_executors():
    n = 60
    kw = {"n_samples": n, "rng": 99, "rule": "lhs", "progress": False}
    ref = monte_carlo(osc_model(), osc_space(), T, executor="serial", chunk_size=n, **kw)
    for cs in (1, 7):
        other = monte_carlo(osc_model(), osc_space(), T, executor="serial", chunk_size=cs, **kw)
        xr.testing.assert_identical(_data(ref), _data(other))
        assert other.attrs["n_chunks"] == math.ceil(n / cs)
    with ProcessRunner(2) as runner:
        proc = monte_carlo(osc_model(), osc_space(), T, executor=runner, chunk_size=7, **kw)
    assert proc.attrs["executor"] == "processes"
    xr.testing.assert_identical(_data(ref), _data(proc))


def test_user_executor_and_progress_bar(capsys):
    from concurrent.futures import ThreadPoolExecutor

    kw = {"n_samples": 30, "rng": 4, "rule": "random"}
    ref = monte_carlo(osc_model(), osc_space(), T, executor="serial", progress=False, **kw)
    with ThreadPoolExecutor(2) as pool:
        other = monte_carlo(osc_model(), osc_space(), T, executor=pool, chunk_size=4,
                            progress=True, **kw)
    assert other.attrs["executor"] == "futures"
    xr.testing.assert_identical(_data(ref), _data(other))
    assert "30/30" in capsys.readouterr().err


@pytest.mark.e2e
def test_bit_identical_on_dask_local_cluster(tmp_path):
    distributed = pytest.importorskip("distributed")
    n = 60
    kw = {"n_samples": n, "rng": 99, "rule": "lhs", "progress": False}
    ref = monte_carlo(osc_model(), osc_space(), T, executor="serial", chunk_size=n, **kw)
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=False,
                                  dashboard_address=None) as cluster:
        with distributed.Client(cluster) as client:
            via_client = monte_carlo(osc_model(), osc_space(), T, executor=client,
                                     chunk_size=7, **kw)
        via_address = monte_carlo(osc_model(), osc_space(), T,
                                  executor=cluster.scheduler_address, chunk_size=16, **kw)
        # with a store the workers write their own chunks; the result streams from them
        stored = monte_carlo(osc_model(), osc_space(), T, executor=cluster.scheduler_address,
                             chunk_size=16, store=tmp_path / "s", **kw)
    assert via_client.attrs["executor"] == via_address.attrs["executor"] == "dask"
    xr.testing.assert_identical(_data(ref), _data(via_client))
    xr.testing.assert_identical(_data(ref), _data(via_address))
    assert len(list((tmp_path / "s").glob("chunk_*.nc.sha256"))) == 4
    xr.testing.assert_identical(_data(ref), _data(stored.load()))


def test_default_chunking_and_executor_resolution():
    assert default_chunk_size(10) == 10
    assert default_chunk_size(1000) == 64
    assert default_chunk_size(10**7) == 10_000
    assert chunk_bounds(10, 4) == [(0, 4), (4, 8), (8, 10)]
    assert resolve_executor("serial").name == "serial"
    assert resolve_executor("processes", n_workers=3).n_workers == 3
    with pytest.raises(ValueError, match="executor: unknown 'gpu'; valid: 'serial'"):
        resolve_executor("gpu")
    with pytest.raises(ValueError, match="unsupported object"):
        resolve_executor(3.5)


# ------------------------------------------------------------------------------- durable runs
class CountingModel(gearuq.FunctionModel):
    """The 'slow' model of the resume tests without the sleep, counting its calls."""

    def __init__(self):
        self.calls = 0
        super().__init__(self._fn, ["x1", "x2"], ["y"], name="slowsum", version="1")

    def _fn(self, x1, x2):
        self.calls += 1
        return x1 * x2 + x1


RESUME_SCRIPT = """
import sys, time
import numpy as np
import gearuq
from gearuq.engines.montecarlo import monte_carlo

COUNT_FILE = sys.argv[2]

def fn(x1, x2):
    with open(COUNT_FILE, "a") as fh:
        fh.write("call\\n")
    time.sleep(float(sys.argv[3]))
    return x1 * x2 + x1

model = gearuq.FunctionModel(fn, ["x1", "x2"], ["y"], name="slowsum", version="1")
space = gearuq.ParameterSpace.normal(x1=(1.0, 0.3), x2=(2.0, 0.4))
if __name__ == "__main__":
    ds = monte_carlo(model, space, n_samples=60, rng=31, chunk_size=5, executor="serial",
                     store=sys.argv[1], progress=False)
    gearuq.save(ds.load(), sys.argv[4])
"""


def _resume_space():
    return ParameterSpace.normal(x1=(1.0, 0.3), x2=(2.0, 0.4))


def _script_env():
    return {**os.environ, "PYTHONPATH": os.pathsep.join([str(REPO),
                                                         os.environ.get("PYTHONPATH", "")])}


@pytest.mark.e2e  # two runs in subprocesses, one killed (5 s of CPU): CI runs it with -m e2e
def test_resume_after_killed_subprocess(tmp_path):
    """Kill a run after >= 3 of 12 chunks; the identical rerun computes only the rest."""
    store = tmp_path / "store"
    script = tmp_path / "run.py"
    script.write_text(textwrap.dedent(RESUME_SCRIPT))
    calls = tmp_path / "calls.txt"
    cmd = [sys.executable, str(script), str(store), str(calls)]
    proc = subprocess.Popen([*cmd, "0.25", str(tmp_path / "unused.nc")], env=_script_env(),
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    deadline = time.monotonic() + 120  # guard against a hang, not a timing assertion
    try:
        while time.monotonic() < deadline and proc.poll() is None:
            if len(list(store.glob("chunk_*.nc.sha256"))) >= 3:
                break
            time.sleep(0.02)
    finally:
        proc.kill()  # SIGKILL: no clean-up runs, the OS releases the store lock
        _, err = proc.communicate()
    on_disk = len(list(store.glob("chunk_*.nc.sha256")))
    assert 3 <= on_disk < 12, err.decode()[-2000:]

    calls.unlink()
    out = subprocess.run([*cmd, "0", str(tmp_path / "resumed.nc")], env=_script_env(),
                         capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr[-3000:]
    assert len(calls.read_text().splitlines()) == 12 - on_disk
    assert len(list(store.glob("chunk_*.nc.sha256"))) == 12
    assert not list(store.glob("*.tmp"))
    resumed = gearuq.load(tmp_path / "resumed.nc")
    fresh = monte_carlo(CountingModel(), _resume_space(), n_samples=60, rng=31, chunk_size=5,
                        executor="serial", progress=False)
    xr.testing.assert_identical(_data(fresh), _data(resumed))


@pytest.mark.e2e
def test_resume_recomputes_only_missing_chunks(tmp_path):
    kw = {"n_samples": 40, "rng": 5, "chunk_size": 4, "executor": "serial", "progress": False,
          "store": tmp_path / "s"}
    first_model = CountingModel()
    first = monte_carlo(first_model, _resume_space(), **kw).load()  # files change below
    assert first_model.calls == 10
    for i in (0, 3, 9):
        (tmp_path / "s" / f"chunk_{i:06d}.nc").unlink()
    (tmp_path / "s" / "chunk_000005.nc").write_bytes(b"garbage")  # a corrupt chunk
    again = CountingModel()
    with pytest.warns(RuntimeWarning, match="chunk_000005.nc is corrupt"):
        second = monte_carlo(again, _resume_space(), **kw)
    assert again.calls == 4
    # the resumed run counts what it evaluated and what it read back, and nothing twice
    assert second.attrs["n_evaluations"] + second.attrs["n_reused_samples"] == \
        first.attrs["n_evaluations"] and second.attrs["n_reused_samples"] > 0
    xr.testing.assert_identical(_data(first), _data(second))
    third = CountingModel()
    monte_carlo(third, _resume_space(), **kw)
    assert third.calls == 0


def test_store_fingerprint_mismatch_raises(tmp_path):
    kw = {"n_samples": 20, "chunk_size": 5, "executor": "serial", "progress": False,
          "store": tmp_path / "s"}
    monte_carlo(CountingModel(), _resume_space(), rng=1, **kw)
    with pytest.raises(StoreMismatchError, match="seed: store has 1, this call has 2"):
        monte_carlo(CountingModel(), _resume_space(), rng=2, **kw)
    with pytest.raises(StoreMismatchError, match="chunk_size"):
        monte_carlo(CountingModel(), _resume_space(), rng=1, **{**kw, "chunk_size": 4})
    other_space = ParameterSpace.normal(x1=(1.0, 0.31), x2=(2.0, 0.4))
    with pytest.raises(StoreMismatchError, match="space"):
        monte_carlo(CountingModel(), other_space, rng=1, **kw)
    (tmp_path / "other").mkdir()
    (tmp_path / "other" / "notes.txt").write_text("hello")
    with pytest.raises(ValueError, match="not empty.*no manifest.json"):
        ChunkStore(tmp_path / "other", {"a": 1})


# ------------------------------------------------------------------------------- failures
def _fails_above(x1, x2):
    if np.any(x1 > 1.4):
        raise FloatingPointError(f"diverged at x1={x1.max():.3f}")
    return x1 + x2


@pytest.mark.e2e
def test_only_the_failing_samples_get_status_4(tmp_path):
    """A chunk that raises is bisected: exactly the samples that fail are flagged."""
    model = gearuq.FunctionModel(_fails_above, ["x1", "x2"], ["y"], name="flaky")
    space = ParameterSpace.normal(x1=(1.0, 0.3), x2=(2.0, 0.4))
    kw = {"n_samples": 200, "rng": 8, "chunk_size": 10, "progress": False}
    with pytest.warns(RuntimeWarning, match=r"sample\(s\) raised.*FloatingPointError"):
        ds = monte_carlo(model, space, executor="serial", store=tmp_path / "s", **kw)
    x1, x2 = ds["x1"].values, ds["x2"].values
    bad = x1 > 1.4
    assert 0 < bad.sum() < 200
    np.testing.assert_array_equal(ds["status"].values, np.where(bad, 4, 0))
    assert np.all(np.isnan(ds["y"].values[bad]))
    np.testing.assert_array_equal(ds["y"].values[~bad], (x1 + x2)[~bad])
    assert ds.sizes["sample"] == 200 and not np.isnan(ds["x1"]).any()
    assert ds.attrs["n_failed"] == ds.attrs["n_model_errors"] == bad.sum()
    failures = json.loads(ds.attrs["failures"])
    flagged = sorted(s for g in failures for s in g["samples"])
    assert flagged == list(np.flatnonzero(bad))
    for g in failures:  # each sample keeps its own exception message
        for s in g["samples"]:
            assert g["error"] == f"FloatingPointError: diverged at x1={x1[s]:.3f}"
    # every chunk is stored, failed samples included (a model error is a result)
    assert len(list((tmp_path / "s").glob("chunk_*.nc.sha256"))) == 20
    ds.load().to_netcdf(tmp_path / "flaky.nc", engine="netcdf4")


def test_every_chunk_failing_raises():
    def always(x1, x2):
        raise RuntimeError("solver exploded")

    model = gearuq.FunctionModel(always, ["x1", "x2"], ["y"], name="broken")
    with pytest.raises(RuntimeError, match="every sample failed.*solver exploded"):
        monte_carlo(model, ParameterSpace.normal(x1=(1.0, 0.3)), n_samples=20, chunk_size=5,
                    rng=1, executor="serial", progress=False)


# ------------------------------------------------------------------------------- input errors
def test_input_errors_are_clear():
    space = ParameterSpace.normal(x1=(1.0, 0.3), zeta=(0.1, 0.01))
    with pytest.raises(ValueError, match=r"space parameter\(s\) 'zeta' not in model 'sum'; "
                                         r"model parameters: x1, x2"):
        monte_carlo(sum_model(), space, n_samples=10)
    ok = ParameterSpace.normal(x1=(1.0, 0.3))
    for n in (0, -5, 2.5, True, None):
        with pytest.raises(ValueError, match="n_samples"):
            monte_carlo(sum_model(), ok, n_samples=n)
    with pytest.raises(ValueError, match="rule: unknown sampling rule 'qmc'; valid: random"):
        monte_carlo(sum_model(), ok, n_samples=10, rule="qmc")
    with pytest.raises(ValueError, match="no output.*'z'"):
        monte_carlo(sum_model(), ok, n_samples=10, outputs="z")
    with pytest.raises(ValueError, match="t: this model has time-dependent outputs"):
        monte_carlo(osc_model(), osc_space(), n_samples=10)
    with pytest.raises(ValueError, match="rng: seed must lie"):
        monte_carlo(sum_model(), ok, n_samples=10, rng=-1)
    with pytest.raises(ValueError, match="chunk_size"):
        monte_carlo(sum_model(), ok, n_samples=10, chunk_size=0, executor="serial")
    with pytest.raises(TypeError, match="model: expected a gearuq Model"):
        monte_carlo(object(), ok, n_samples=10)


def test_out_of_range_draws_are_reported_with_probability():
    wide = ParameterSpace.normal(a=(1.0, 0.6), b=(2.0, 0.1))
    with pytest.raises(ValueError, match=r"'a'.*outside valid range.*a: 0\.04\d"):
        monte_carlo(osc_model(), wide, T, n_samples=500, rng=1, executor="serial")
