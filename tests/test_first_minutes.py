"""What a new user meets in the first minutes: edge cases refused with the argument's name,
the CSV export read back, chaospy's logging undone, and the command line's own checks."""

from __future__ import annotations

import csv
import json
import math
import subprocess
import sys

import numpy as np
import pytest
import xarray as xr

import gearuq
from gearuq import cli
from gearuq.failure.modes import Band, LimitState
from gearuq.failure.report import STATUS_TEXT
from gearuq.failure.samples import reliability


def _passage_dataset(n: int = 400, seed: int = 3) -> xr.Dataset:
    """y(t) = a t on t = 0..200 with a ~ U(0, 1): sample i first exceeds 1 at t = 1 / a_i."""
    rng = np.random.default_rng(seed)
    a = rng.uniform(0.0, 1.0, n)
    t = np.linspace(0.0, 200.0, 201)
    ds = xr.Dataset(coords={"sample": np.arange(n), "time": ("time", t, {"units": "s"})})
    ds["y"] = (("sample", "time"), a[:, None] * t[None, :], {"units": "m", "role": "output"})
    ds["a"] = ("sample", a, {"units": "1/s", "role": "input"})
    ds["status"] = ("sample", np.zeros(n, np.int8))
    return ds


# =========================================================================== time windows
def test_a_window_inside_the_instants_counts_first_passages_in_it():
    ds = _passage_dataset()
    a = ds["a"].values
    rel = reliability(ds, Band("y", upper=1.0), system=False, time=(150.0, 200.0))
    # independent count: over [150, 200] a sample fails iff a * 200 > 1 (the last instant)
    expected = np.mean(a * 200.0 > 1.0)
    got = float(rel["pf_first_passage"].sel(mode="y").isel(time=-1))
    assert got == pytest.approx(expected, abs=1e-12)
    assert float(rel["time"][0]) == 150.0


@pytest.mark.parametrize("window", [(150.0, 300.0), (-10.0, 50.0), slice(150.0, 300.0)])
def test_a_window_reaching_outside_the_instants_is_refused_like_a_limit_state_window(window):
    ds = _passage_dataset(50)
    with pytest.raises(ValueError, match=r"time: window \[.*\] reaches outside .*\[0, 200\]"):
        reliability(ds, Band("y", upper=1.0), time=window)
    with pytest.raises(ValueError, match="reaches outside the instants"):
        LimitState.upper("y", 1.0, window=(150.0, 300.0)).values(ds)


def test_instants_outside_the_grid_are_refused_not_replaced_by_the_nearest():
    ds = _passage_dataset(50)
    with pytest.raises(ValueError, match=r"time: instant\(s\) \[250.0\] outside"):
        reliability(ds, Band("y", upper=1.0), time=[100.0, 250.0])
    # inside, the nearest instant stands for it, as documented
    rel = reliability(ds, Band("y", upper=1.0), time=[100.2])
    assert float(rel["time"][0]) == 100.0


@pytest.mark.parametrize(("bad", "error", "words"), [
    ((200.0, 150.0), ValueError, r"time: \(200, 150\) is reversed"),
    (("a", "b"), ValueError, r"time: t0 = 'a' is not a real number"),
    ((0.0, math.nan), ValueError, "time: t1 = nan is not finite"),
    ("0:10", ValueError, "time: '0:10' is not an instant"),
    ((1.0, 2.0, 3.0), TypeError, "time: expected a pair"),
])
def test_bad_time_selections_name_the_argument(bad, error, words):
    with pytest.raises(error, match=words):
        reliability(_passage_dataset(20), Band("y", upper=1.0), time=bad)


@pytest.mark.parametrize(("bad", "error", "words"), [
    (100.0, TypeError, r"window: expected a pair \(t0, t1\) of instants, got 100.0 \(float\)"),
    (("a", "b"), ValueError, "window: t0 = 'a' is not a real number"),
    ((5.0, 1.0), ValueError, r"window: \(5, 1\) is reversed"),
    ("0:10", TypeError, "window: expected a pair"),
])
def test_bad_limit_state_windows_name_the_argument(bad, error, words):
    with pytest.raises(error, match=words):
        LimitState.upper("y", 1.0, window=bad)


@pytest.mark.parametrize("bad", ["0:10", ["a", "b"], {"t": 1.0}])
def test_bad_instants_of_a_model_call_name_t(bad):
    model = gearuq.get_model("linear_oscillator")
    with pytest.raises(TypeError, match=r"^t: expected an array of output instants"):
        model.response({}, bad)


# =========================================================================== force table
def _force_table():
    x = np.linspace(0.0, 3e-5, 7)
    phase = np.linspace(0.0, 1.0, 9)
    k = 2e8 * (1.0 + 0.1 * np.cos(2 * np.pi * phase))
    force = np.maximum(x[:, None] - 5e-6, 0.0) * k[None, :]
    return x, phase, force


def test_a_nan_in_a_force_table_is_named_as_such_not_as_a_shape_error():
    from gearuq_plugins.mesh_oscillator import LoadDeflectionTable

    x, phase, force = _force_table()
    LoadDeflectionTable.from_force_table(x, phase, force)  # the clean table converts
    force[3, 2] = np.nan
    with pytest.raises(ValueError, match=r"force: 1 non-finite value\(s\), the first nan at "
                                         r"deflection 1\.5e-05 m, phase 0\.25"):
        LoadDeflectionTable.from_force_table(x, phase, force)
    with pytest.raises(ValueError, match=r"force: valid: shape \(7, 9\)"):
        LoadDeflectionTable.from_force_table(x, phase, force[:, :-1])
    x[2] = np.nan
    with pytest.raises(ValueError, match="deflection: valid: finite"):
        LoadDeflectionTable.from_force_table(x, phase, np.nan_to_num(force))


# =========================================================================== CSV export
def _read_csv(path):
    with open(path, newline="") as fh:
        rows = list(csv.reader(fh))
    return rows[0], rows[1:]


def test_export_csv_reads_back_values_and_units(tmp_path):
    model = gearuq.get_model("linear_oscillator")
    t = np.linspace(0.0, 2.0, 11)
    params = {p.name: np.full(3, p.nominal) for p in model.parameters}
    params[model.parameters[0].name] = model.parameters[0].nominal * np.array([0.9, 1.0, 1.1])
    ds = model.response(params, t)
    gearuq.save(ds, tmp_path / "run.nc")
    ds = gearuq.load(tmp_path / "run.nc")
    written = gearuq.export_csv(ds, tmp_path / "csv")
    names = sorted(p.name for p in written)
    assert "provenance.json" in names and "sample.csv" in names and "sample-time.csv" in names
    n_values = 0
    for file in written:
        if file.suffix != ".csv":
            continue
        header, rows = _read_csv(file)
        dims = file.stem.split("-") if file.stem != "scalars" else []
        for col, head in enumerate(header):
            name, _, units = head.partition(" [")
            source = ds[name]
            assert units.rstrip("]") == str(source.attrs.get("units", "")), head
            if col < len(dims):
                continue
            want = np.asarray(source.transpose(*dims).values).ravel()
            got = np.array([r[col] for r in rows], dtype=want.dtype)
            np.testing.assert_array_equal(got, want)  # exact: repr digits round-trip
            n_values += want.size
        if dims:  # the dimension columns enumerate the grid, first dim slowest
            assert len(rows) == int(np.prod([ds.sizes[d] for d in dims]))
            if dims == ["sample", "time"]:
                assert [float(r[1]) for r in rows[:11]] == pytest.approx(t.tolist())
    assert n_values >= 3 * 11
    meta = json.loads((tmp_path / "csv" / "provenance.json").read_text())
    assert meta["attrs"]["model"] == "linear_oscillator"
    assert meta["attrs"]["gearuq_version"] == gearuq.__version__


def test_export_csv_scalars_and_text_coordinates(tmp_path):
    ds = xr.Dataset({"pf": ((), 0.125, {"units": "1"}), "n": ((), np.int64(80))},
                    attrs={"method": "subset"})
    ds["g"] = ("mode", [1.5, -2.0], {"units": "N"})
    ds = ds.assign_coords(mode=["v1", "system"], output=("mode", ["v1", ""]))
    written = gearuq.export_csv(ds, tmp_path)
    header, rows = _read_csv(tmp_path / "scalars.csv")
    assert header == ["pf [1]", "n"] and rows == [["0.125", "80"]]
    header, rows = _read_csv(tmp_path / "mode.csv")
    assert header == ["mode", "g [N]", "output"]
    assert rows == [["v1", "1.5", "v1"], ["system", "-2.0", ""]]
    assert json.loads(written[-1].read_text())["attrs"] == {"method": "subset"}


def test_export_csv_bad_input(tmp_path):
    with pytest.raises(TypeError, match="dataset: expected an xarray.Dataset, got dict"):
        gearuq.export_csv({"a": 1}, tmp_path)
    with pytest.raises(ValueError, match="path: an empty folder name"):
        gearuq.export_csv(xr.Dataset({"a": 1.0}), "")
    (tmp_path / "f.txt").write_text("x")
    with pytest.raises(ValueError, match="is a file"):
        gearuq.export_csv(xr.Dataset({"a": 1.0}), tmp_path / "f.txt")


def test_cli_export_writes_csv_and_refuses_without_a_format(tmp_path, capsys):
    ds = xr.Dataset({"y": ("sample", [1.0, 2.0], {"units": "m"})})
    gearuq.save(ds, tmp_path / "r.nc")
    assert cli.main(["export", str(tmp_path / "r.nc")]) == 2
    assert "choose a format: --csv" in capsys.readouterr().err
    assert cli.main(["export", str(tmp_path / "r.nc"), "--csv"]) == 0
    header, rows = _read_csv(tmp_path / "r_csv" / "sample.csv")
    assert header == ["sample", "y [m]"] and rows == [["0", "1.0"], ["1", "2.0"]]


# =========================================================================== command line
def test_info_on_a_folder_says_it_is_a_folder(tmp_path, capsys):
    gearuq.save(xr.Dataset({"y": ("sample", [1.0])}), tmp_path / "a.nc")
    assert cli.main(["info", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert "is a folder, not a result file" in err and "a.nc" in err


@pytest.mark.parametrize("argv", [
    ["bench", "reliability", "--coverage", "--workers", "0"],
    ["bench", "reliability", "--seeds", "-3"],
    ["demo", "--out", ""],
    ["study", "mc_vs_surrogate", "--out", " "],
])
def test_cli_refuses_zero_workers_and_empty_folders(argv, capsys):
    with pytest.raises(SystemExit) as exc:
        cli.main(argv)
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert ("outside its valid range: integers >= 1" in err) or ("empty folder name" in err)


def test_a_rejected_sample_count_leaves_no_folder(tmp_path, capsys):
    out = tmp_path / "demo"
    with pytest.raises(SystemExit):
        cli.main(["demo", "--out", str(out), "--n-samples", "0"])
    assert not out.exists()
    study = gearuq.get_study("helical_pair_reliability")
    with pytest.raises(ValueError, match="n_samples: -5 is outside its valid range"):
        study(out=out, n_samples=-5)
    assert not out.exists()


# =========================================================================== logging
@pytest.mark.e2e  # two fresh interpreters importing chaospy and gearuq (2.4 s of CPU)
def test_chaospy_imported_first_leaves_numba_quiet():
    code = ("import logging, chaospy\n"
            "assert logging.getLogger().level == logging.DEBUG  # chaospy's own basicConfig\n"
            "import gearuq\n"
            "root = logging.getLogger()\n"
            "print(root.level, len(root.handlers), logging.getLogger('numba').getEffectiveLevel())")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True).stdout.split()
    assert out == [str(30), "0", str(30)]
    # a configuration of the user's own survives
    code = ("import logging; logging.basicConfig(level=logging.INFO)\n"
            "import chaospy, gearuq\n"
            "print(logging.getLogger().level, len(logging.getLogger().handlers))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True).stdout.split()
    assert out == [str(20), "1"]


# =========================================================================== study options
def test_every_study_help_lists_its_own_options(capsys):
    import inspect

    from gearuq import registry

    for name in registry.list_studies():
        study = registry.get_study(name)
        with pytest.raises(SystemExit) as exc:
            cli.main(["study", name, "--help"])
        assert exc.value.code == 0
        text = capsys.readouterr().out
        for pname in inspect.signature(study).parameters:
            assert "--" + pname.replace("_", "-") in text, (name, pname)


def test_study_options_reach_the_run_function_typed(monkeypatch, tmp_path, capsys):
    from gearuq import registry

    seen = {}

    def fake(out: str = "x", quick: bool = False, n: int | None = None, limit: float = 1.0,
             executor=None, progress: bool = True) -> int:
        """A study.

        Parameters
        ----------
        out : path
            Folder.
        n : int, optional
            Samples per grade
            (a second line).
        limit : float
            The limit [um].
        """
        seen.update(out=out, quick=quick, n=n, limit=limit, executor=executor,
                    progress=progress)
        return 0

    monkeypatch.setattr(registry, "get_study", lambda name: fake)
    with pytest.raises(SystemExit):
        cli.main(["study", "fake", "-h"])
    text = capsys.readouterr().out
    assert "Samples per grade (a second line)" in text and "The limit [um]" in text
    assert cli.main(["study", "--quick", "fake", "--n", "7", "--limit", "2.5",
                     "--executor", "serial", "--no-progress", "--out", str(tmp_path)]) == 0
    assert seen == {"out": str(tmp_path), "quick": True, "n": 7, "limit": 2.5,
                    "executor": "serial", "progress": False}
    seen.clear()
    assert cli.main(["study", "fake"]) == 0  # nothing given: the study's own defaults
    assert seen == {"out": "gearuq_fake", "quick": False, "n": None, "limit": 1.0,
                    "executor": None, "progress": True}
    with pytest.raises(SystemExit) as exc:
        cli.main(["study", "fake", "--n", "seven"])
    assert exc.value.code == 2 and "argument --n: invalid int value: 'seven'" in \
        capsys.readouterr().err


# =========================================================================== status, quick
def test_describe_status_of_a_report_and_of_samples():
    from gearuq.failure.report import STATUS_TEXT, describe_status
    from gearuq.model import status_attrs

    reasons = [{"status": 3, "meaning": "weights_degenerate", "message": "two draws carry 60 %"},
               {"status": 6, "meaning": "invalid_samples", "message": "2 of 90 runs invalid"}]
    rep = xr.Dataset({"status": ((), np.int8(3))},
                     attrs={"status_reasons": json.dumps(reasons), "message": "x"})
    assert describe_status(rep) == (f"status 3: {STATUS_TEXT[3]} (two draws carry 60 %; "
                                    "2 of 90 runs invalid [status 6])")
    rep = xr.Dataset({"status": ((), np.int8(4))})  # no reasons recorded: the table's words
    assert describe_status(rep) == f"status 4: {STATUS_TEXT[4]}"
    ok = xr.Dataset({"status": ((), np.int8(0))})
    assert describe_status(ok) == f"status 0: {STATUS_TEXT[0]}"
    codes = np.array([0, 1, 0, 3, 1, 0], np.int8)
    ds = xr.Dataset({"status": ("sample", codes, status_attrs({16: "contact lost"}))})
    assert describe_status(ds) == ("status: 3 of 6 samples failed: 2 x 1 (step limit "
                                   "reached), 1 x 3 (non finite state)")
    assert describe_status(ds["status"] * 0) == "status: all 6 samples ok"
    with pytest.raises(ValueError, match="holds no 'status' variable"):
        describe_status(xr.Dataset({"a": 1.0}))
    with pytest.raises(TypeError, match="result: expected an xarray"):
        describe_status({"status": 0})


def test_status_meanings_inverts_the_flag_attributes(tmp_path):
    """Code -> name from a result's status variable, also after a netCDF round trip, and
    from a plugin's own codes; a variable without flags gives an empty mapping."""
    import gearuq
    from gearuq.model import STATUS_MEANINGS, status_attrs, status_meanings

    attrs = status_attrs({16: "contact lost", 21: "peak not located"})
    got = status_meanings(attrs)
    assert got[16] == "contact_lost" and got[21] == "peak_not_located"
    assert got == {c: n.replace(" ", "_") for c, n in (
        STATUS_MEANINGS | {16: "contact lost", 21: "peak not located"}).items()}
    ds = xr.Dataset({"status": ("sample", np.array([0, 21], np.int8), attrs)})
    gearuq.save(ds, tmp_path / "r.nc")
    assert status_meanings(gearuq.load(tmp_path / "r.nc")["status"]) == got
    assert status_meanings(xr.DataArray(0)) == {}


def test_quick_run_prints_and_stamps_every_figure_saved_inside(tmp_path, capsys):
    from matplotlib.figure import Figure

    from gearuq.plot import quick_run, save_figure

    def text_of(fig):
        return [t.get_text() for t in fig.texts]

    with quick_run(True, 8, "the Sobol' indices") as mark:
        fig = Figure()
        fig.add_subplot().plot([0, 1])
        save_figure(fig, tmp_path / "a.png")
    assert mark == "quick: 8 runs, not a result"
    assert capsys.readouterr().out == "quick: 8 runs, not a result; left out: the Sobol' indices\n"
    assert text_of(fig) == [mark] and (tmp_path / "a.png").stat().st_size > 0
    after = Figure()
    save_figure(after, tmp_path / "b.png")  # outside the block: no mark
    with quick_run(False, 8, "x") as mark:
        save_figure(fig2 := Figure(), tmp_path / "c.png")
    assert text_of(after) == [] and text_of(fig2) == [] and mark == ""
    # the PNG itself says it: the mark in its text chunks, read back by Pillow (not our code)
    from PIL import Image

    from gearuq.plot import QUICK_MARK_KEY

    assert Image.open(tmp_path / "a.png").text[QUICK_MARK_KEY] == "quick: 8 runs, not a result"
    assert QUICK_MARK_KEY not in Image.open(tmp_path / "b.png").text
    assert QUICK_MARK_KEY not in Image.open(tmp_path / "c.png").text
    with pytest.raises(ValueError, match="runs: expected a positive number"):
        with quick_run(True, 0, "x"):
            pass
    with pytest.raises(ValueError, match="left_out: say in words"):
        with quick_run(True, "a few", " "):
            pass


def test_every_study_has_a_marked_quick_mode_that_keeps_its_signature():
    import inspect

    from gearuq import registry

    for name in registry.list_studies():
        study = registry.get_study(name)
        assert "quick" in inspect.signature(study).parameters, name
        assert study.quick_left_out.strip(), name  # what quick_mode records
        assert inspect.signature(study) == inspect.signature(study.__wrapped__), name


# =========================================================================== compile notice
@pytest.mark.e2e  # two fresh interpreters, a compile and a cache load (1.9 s of CPU)
def test_the_first_compile_of_a_gearuq_kernel_says_so_once_and_a_cache_load_does_not(tmp_path):
    from importlib.metadata import entry_points

    eps = [ep.value for ep in entry_points(group="numba_extensions", name="init")]
    assert "gearuq._compile_notice:init" in eps
    # a tiny kernel that numba takes for the linear oscillator's (its __module__ says so),
    # compiled twice in one process (announced once) and then loaded from the disk cache by a
    # second process (not announced)
    code = ("import sys, types, numba\n"
            "mod = types.ModuleType('gearuq_plugins.linear_oscillator.probe')\n"
            "sys.modules[mod.__name__] = mod\n"
            f"mod.__file__ = {str(tmp_path / 'probe.py')!r}\n"
            "src = 'def f(x):\\n    return 2.0 * x\\ndef g(x):\\n    return x + 1\\n'\n"
            "open(mod.__file__, 'w').write(src)\n"
            "exec(compile(src, mod.__file__, 'exec'), mod.__dict__)\n"
            "f = numba.njit(cache=True)(mod.f); g = numba.njit(cache=True)(mod.g)\n"
            "print(f(1.5), g(2))\n")
    env = {**__import__("os").environ, "NUMBA_CACHE_DIR": str(tmp_path / "cache")}
    env.pop("GEARUQ_QUIET_COMPILE", None)
    first = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                           env=env, check=True)
    assert first.stdout.split() == ["3.0", "3"]
    notes = [line for line in first.stderr.splitlines() if line.startswith("gearuq: compiling")]
    assert notes == ["gearuq: compiling the linear oscillator's numba kernels (once per "
                     "install: later runs load them from the cache; `gearuq compile` does it "
                     "ahead) ..."]
    again = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                           env=env, check=True)
    assert again.stdout.split() == ["3.0", "3"] and "gearuq: compiling" not in again.stderr


def test_compile_notice_families():
    from gearuq import _compile_notice as notice

    assert notice.family_of("gearuq.ode.kernel") == "gearuq.ode"
    assert notice.family_of("gearuq.odex") is None and notice.family_of("numpy.linalg") is None
    assert notice.family_of("gearuq_plugins.helical_pair.kernel") == \
        "gearuq_plugins.helical_pair"


def test_per_model_first_call_probes_cover_every_model_and_refuse_others():
    from gearuq.bench import core

    with pytest.raises(ValueError, match=r"models: \['nope'\] have no first-call probe"):
        core.model_first_calls(["nope"])
    assert set(core.MODEL_FIRST_CALLS) == set(gearuq.list_models())


@pytest.mark.e2e  # two fresh interpreters, cold and warm (2.5 s of CPU)
def test_per_model_first_call_table(monkeypatch):
    from gearuq.bench import core

    res = core.model_first_calls(["linear_oscillator"])
    (row,) = res["rows"]
    assert row["model"] == "linear_oscillator" and row["status"] == 0
    # imports are inside the timed first call: a fresh interpreter's first call costs more CPU
    # than the same call again in the warm process
    assert row["cold_cpu"] > row["again_cpu"] and row["warm_cpu"] > row["again_cpu"]
    table = core.render_model_first_calls(res)
    assert (f"| linear_oscillator | displacement, 101 instants | {row['cold_cpu']:.2f} "
            f"({row['cold_wall']:.2f}) | {row['warm_cpu']:.2f}") in table
    assert set(core.MODEL_FIRST_CALLS) == set(gearuq.list_models())


def test_info_prints_a_reports_status_in_words(tmp_path, capsys):
    reasons = [{"status": 4, "meaning": "upper_bound_only",
                "message": "no failure in 300 runs: pf is an upper bound"}]
    rep = xr.Dataset({"pf": ((), 0.0, {"units": "1"}), "status": ((), np.int8(4))},
                     attrs={"status_reasons": json.dumps(reasons), "method": "mc"})
    gearuq.save(rep, tmp_path / "rep.nc")
    assert cli.main(["info", str(tmp_path / "rep.nc")]) == 0
    out = capsys.readouterr().out
    assert (f"status 4: {STATUS_TEXT[4]} (no failure in 300 runs: pf is an upper bound)"
            in out)


# ------------------------------------------------------ the suite on two processes (conftest)
def test_warm_up_split_gives_every_model_to_one_worker_and_balances_the_compile():
    """Greedy longest-first over the cold compile costs: every model warmed up by exactly one
    worker, and with two workers the heavier share is at most the lighter one plus the
    largest single model (the greedy bound); with two workers, on these costs, it is the best
    split there is (every partition tried)."""
    import conftest

    costs = conftest.WARM_UP_CPU
    for n_workers in (2, 3, 5):
        shares = [conftest.warm_up_share(k, n_workers) for k in range(n_workers)]
        flat = sorted(name for share in shares for name in share)
        assert flat == sorted(costs), shares
        loads = [sum(costs[m] for m in share) for share in shares]
        assert max(loads) - min(loads) <= max(costs.values()) + 1e-12, loads
    two = [sum(costs[m] for m in conftest.warm_up_share(k, 2)) for k in range(2)]
    import itertools

    total = sum(costs.values())
    best = min(max(sum(costs[m] for m in part), total - sum(costs[m] for m in part))
               for r in range(len(costs) + 1) for part in itertools.combinations(costs, r))
    assert max(two) == pytest.approx(best)


def test_numba_cache_saves_wait_for_each_other(tmp_path):
    """A save into numba's cache blocks while another holder has the index's lock (two
    workers adding signatures of one function), and completes once it is released."""
    import fcntl
    import threading

    from numba.core import caching

    assert getattr(caching.IndexDataCacheFile.save, "serialised", False)
    cache = caching.IndexDataCacheFile(str(tmp_path), "kernel-demo", "0")
    with open(cache._index_path + ".lock", "a") as holder:
        fcntl.flock(holder, fcntl.LOCK_EX)
        saver = threading.Thread(target=cache.save, args=(("sig", "magic"), b"code"))
        saver.start()
        saver.join(0.3)
        assert saver.is_alive() and not (tmp_path / "kernel-demo.nbi").exists()
        fcntl.flock(holder, fcntl.LOCK_UN)
    saver.join(10.0)
    assert not saver.is_alive()
    assert cache.load(("sig", "magic")) == b"code"


# =========================================================================== docs gallery
def test_gallery_outputs_are_kept_until_the_library_changes(tmp_path, monkeypatch):
    """sphinx-gallery skips an example whose ``.md5`` matches it; conf.py removes those marks
    when the library's digest differs from the one the outputs were made with."""
    import importlib.util
    from pathlib import Path

    docs = Path(__file__).resolve().parents[1] / "docs"
    spec = importlib.util.spec_from_file_location("docs_conf_gallery", docs / "conf.py")
    conf = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(conf)
    gallery = tmp_path / "auto_examples"
    conf._expire_gallery_outputs(gallery)  # a first build: nothing to expire, digest written
    stamp = (gallery / "library.sha256").read_text().strip()
    assert len(stamp) == 64 and stamp == conf.library_fingerprint()
    for name in ("plot_a.py.md5", "plot_b.py.md5"):
        (gallery / name).write_text("0" * 32)
    (gallery / "plot_a.png").write_bytes(b"png")
    conf._expire_gallery_outputs(gallery)  # unchanged library: every mark kept
    assert sorted(p.name for p in gallery.glob("*.md5")) == ["plot_a.py.md5", "plot_b.py.md5"]
    monkeypatch.setattr(conf, "library_fingerprint", lambda: "f" * 64)
    conf._expire_gallery_outputs(gallery)  # changed: marks gone (examples rerun), outputs kept
    assert list(gallery.glob("*.md5")) == [] and (gallery / "plot_a.png").exists()
    assert (gallery / "library.sha256").read_text().strip() == "f" * 64


def test_the_library_digest_follows_its_sources(tmp_path, monkeypatch):
    """A changed byte in any module of gearuq changes the digest; the same tree gives the same."""
    import importlib.util
    import shutil
    from pathlib import Path

    docs = Path(__file__).resolve().parents[1] / "docs"
    spec = importlib.util.spec_from_file_location("docs_conf_digest", docs / "conf.py")
    conf = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(conf)
    copy = tmp_path / "gearuq"
    shutil.copytree(Path(gearuq.__file__).parent, copy,
                    ignore=shutil.ignore_patterns("__pycache__"))
    fake = type("Module", (), {"__file__": str(copy / "__init__.py")})
    real_import = importlib.import_module
    monkeypatch.setattr(importlib, "import_module",
                        lambda name: fake if name == "gearuq" else real_import(name))
    before = conf.library_fingerprint()
    assert conf.library_fingerprint() == before
    (copy / "signal.py").write_text((copy / "signal.py").read_text() + "\n# changed\n")
    assert conf.library_fingerprint() != before


def test_a_study_setting_that_takes_names_reads_a_comma_separated_list():
    def study(out: str = "x", quick: bool = False,
              methods: tuple[str, ...] = ("subspace",)) -> int:
        """A study.

        Parameters
        ----------
        methods : tuple of str
            Which methods.
        """
        return 0

    parser = cli.study_parser("demo_study", study)
    assert vars(parser.parse_args(["--methods", "mfis, subset"])) == {
        "methods": ("mfis", "subset")}
    assert vars(parser.parse_args([])) == {}  # the study's own default applies
    with pytest.raises(SystemExit):
        parser.parse_args(["--methods", " , "])
    assert "NAME[,NAME...]" in parser.format_help() and "default: subspace" in parser.format_help()
