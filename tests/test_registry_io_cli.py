"""Registry, netCDF round trip and the command line."""

import subprocess
import sys
from importlib.metadata import EntryPoint

import numpy as np
import pytest
import xarray as xr

import gearuq
from gearuq import cli, registry
from gearuq.model import FunctionModel, Output, Parameter


def test_builtin_plugins_listed_without_import():
    code = ("import sys, gearuq; names = gearuq.list_models(); "
            "assert 'linear_oscillator' in names and 'helical_pair' in names, names; "
            "heavy = [m for m in ('numba', 'chaospy', 'dask', 'gearuq_plugins.helical_pair.kernel')"
            " if m in sys.modules]; assert not heavy, heavy")
    subprocess.run([sys.executable, "-c", code], check=True)


def test_unknown_model_lists_available():
    with pytest.raises(ValueError, match="unknown model 'nope'.*linear_oscillator"):
        gearuq.get_model("nope")


def test_broken_plugin_reported_without_breaking_others(monkeypatch):
    broken = EntryPoint("broken_plugin", "gearuq_no_such_module:Thing", registry.ENTRY_POINT_GROUP)
    real = registry._entry_points

    def fake():
        eps = real()
        eps["broken_plugin"] = broken
        return eps

    monkeypatch.setattr(registry, "_entry_points", fake)
    rows = {r.name: r for r in registry.describe_models()}
    assert "broken_plugin" in rows["broken_plugin"].error
    assert "gearuq_no_such_module" in rows["broken_plugin"].error
    assert rows["linear_oscillator"].error == ""
    with pytest.raises(registry.ModelLoadError, match="broken_plugin.*failed to import"):
        gearuq.get_model("broken_plugin")
    assert gearuq.get_model("linear_oscillator").name == "linear_oscillator"


def test_register_function_model(monkeypatch):
    # a registration lives for the process: keep it out of later tests (test_docs checks
    # that every registered model has a theory page)
    monkeypatch.setattr(registry, "_RUNTIME", dict(registry._RUNTIME))
    fm = FunctionModel(lambda a: 2 * a, [Parameter("a", "m", 1.0, 0.0, 10.0)],
                       [Output("y", "m", ("sample",))], name="double")
    registry.register_model("double_test", lambda: fm, overwrite=True)
    assert "double_test" in gearuq.list_models()
    ds = gearuq.get_model("double_test").response({"a": [1.0, 2.5]})
    np.testing.assert_array_equal(ds["y"], [2.0, 5.0])


def test_function_model_flags_nonfinite_samples():
    fm = FunctionModel(lambda a: np.log(np.where(a > 0, a, np.nan)), ["a"], ["y"])
    ds = fm.response({"a": [1.0, -1.0, 2.0]})
    np.testing.assert_array_equal(ds["status"], [0, 3, 0])
    assert ds.sizes["sample"] == 3  # flagged, not dropped


def test_function_model_time_dependent():
    fm = FunctionModel(lambda a, t: a[:, None] * t[None, :], ["a"], ["y"], time_dependent=True)
    ds = fm.response({"a": [1.0, 2.0]}, [0.0, 1.0, 2.0])
    assert ds["y"].dims == ("sample", "time")
    np.testing.assert_array_equal(ds["y"][1], [0.0, 2.0, 4.0])
    gearuq.testing.check_model(fm, [0.0, 1.0])


def test_netcdf_roundtrip(tmp_path):
    m = gearuq.get_model("linear_oscillator")
    ds = m.response({"k": [1e4, 2e4]}, np.linspace(0, 0.1, 7))
    ds.attrs["flag"] = True
    ds.attrs["settings"] = {"a": 1}
    path = gearuq.save(ds, tmp_path / "sub" / "r.nc")
    back = gearuq.load(path)
    xr.testing.assert_allclose(back, ds.drop_attrs(deep=False), rtol=0, atol=0)
    assert back["displacement"].attrs["units"] == "m"
    assert back["time"].attrs["units"] == "s"
    assert back.attrs["flag"] == 1 and back.attrs["settings"] == '{"a": 1}'
    assert back["status"].attrs["flag_meanings"].split()[0] == "ok"


def test_load_rejects_foreign_files(tmp_path):
    xr.Dataset({"a": ("x", [1.0])}).to_netcdf(tmp_path / "plain.nc")
    with pytest.raises(ValueError, match="not a gearuq result"):
        gearuq.load(tmp_path / "plain.nc")
    (tmp_path / "text.nc").write_text("hello")
    with pytest.raises(ValueError, match="not a readable netCDF"):
        gearuq.load(tmp_path / "text.nc")
    with pytest.raises(FileNotFoundError):
        gearuq.load(tmp_path / "missing.nc")


def test_cli_models_and_info(tmp_path, capsys):
    assert cli.main(["models"]) == 0
    out = capsys.readouterr().out
    assert "linear_oscillator" in out and "helical_pair" in out
    assert cli.main(["models", "linear_oscillator"]) == 0
    out = capsys.readouterr().out
    assert "stiffness" in out and "N m-1" in out and "displacement" in out
    ds = gearuq.get_model("linear_oscillator").response({}, [0.0, 0.1])
    gearuq.save(ds, tmp_path / "r.nc")
    assert cli.main(["info", str(tmp_path / "r.nc")]) == 0
    out = capsys.readouterr().out
    assert "linear_oscillator" in out and "displacement" in out
    assert cli.main(["models", "nope"]) == 2
    assert "unknown model" in capsys.readouterr().err


def test_cli_version_and_help():
    out = subprocess.run([sys.executable, "-m", "gearuq.cli", "--version"],
                         capture_output=True, text=True, check=True).stdout
    assert gearuq.__version__ in out
    out = subprocess.run([sys.executable, "-m", "gearuq.cli", "--help"],
                         capture_output=True, text=True, check=True).stdout
    for cmd in ("models", "info", "demo", "bench"):
        assert cmd in out


def test_cli_bench_surrogate_quick(tmp_path, monkeypatch):
    """The CLI passes --quick/--out to the benchmark (run and asserted once in the suite:
    tests/test_pce.py::test_bench_surrogate_quick)."""
    from gearuq.bench import surrogate as bench_surrogate

    seen = {}
    monkeypatch.setattr(bench_surrogate, "run",
                        lambda out, quick=False: seen.update(out=str(out), quick=quick) or {})
    assert cli.main(["bench", "surrogate", "--quick", "--out", str(tmp_path)]) == 0
    assert seen == {"out": str(tmp_path), "quick": True}


def test_with_nominal_changes_what_engines_use_outside_the_space():
    """A copy with another nominal value: samples outside the space take it, the original is
    untouched, the fingerprint and provenance tell them apart, bad values are refused."""
    from gearuq.execution import model_fingerprint

    base = gearuq.FunctionModel(lambda a, b: a + 10.0 * b, ["a", "b"], ["y"], name="sum")
    fixed = base.with_nominal(b=2.0)
    x = {"a": np.array([0.0, 1.0])}
    np.testing.assert_allclose(fixed.response(x)["y"].values, [20.0, 21.0])
    np.testing.assert_allclose(base.response(x)["y"].values, [base.nominal()["b"] * 10.0,
                                                             1.0 + base.nominal()["b"] * 10.0])
    assert model_fingerprint(fixed) != model_fingerprint(base)
    ds = gearuq.monte_carlo(fixed, gearuq.ParameterSpace.normal(a=(0.0, 1.0)), n_samples=4,
                            rng=1)
    assert '"b": 2.0' in ds.attrs["model_nominal_overrides"]
    with pytest.raises(ValueError, match="unknown parameter"):
        base.with_nominal(c=1.0)
