"""Errors that name their cause, leftovers that are cleaned, loads that are not silent
(issue "The remaining holes", items 4 and 5)."""

from __future__ import annotations

import errno
import os
import signal
import subprocess
import sys
import textwrap
import time
import warnings
from pathlib import Path

import netCDF4
import numpy as np
import pytest
import xarray as xr

import gearuq
from gearuq.engines.montecarlo import monte_carlo
from gearuq.execution.store import write_chunk
from gearuq.io import clean_stale_temporaries, load, save, temporary_path

REPO = Path(__file__).resolve().parents[1]
SPACE = gearuq.ParameterSpace.normal(x1=(0.0, 1.0), x2=(0.0, 1.0))


def _env() -> dict[str, str]:
    return {**os.environ, "PYTHONPATH": os.pathsep.join([str(REPO),
                                                         os.environ.get("PYTHONPATH", "")])}


def _add(x1, x2):
    return x1 + x2


MODEL = gearuq.FunctionModel(_add, ["x1", "x2"], ["y"], name="add")


@pytest.fixture
def tmpfs(tmp_path):
    """Mount a small tmpfs (root only); yields ``mount(size) -> Path`` and unmounts after."""
    mnt = tmp_path / "mnt"
    mnt.mkdir()
    mounted = []

    def mount(size: str) -> Path:
        if sys.platform != "linux":
            pytest.skip("a small real file system is mounted with Linux's tmpfs")
        res = subprocess.run(["mount", "-t", "tmpfs", "-o", f"size={size},mode=0777", "tmpfs",
                              str(mnt)], capture_output=True, text=True)
        if res.returncode != 0:
            pytest.skip(f"cannot mount a small tmpfs here (needs root and mount permission): "
                        f"{res.stderr.strip()}")
        mounted.append(mnt)
        return mnt

    yield mount
    for m in mounted:
        subprocess.run(["umount", "-l", str(m)], capture_output=True)


def _remount_read_only(mnt: Path) -> None:
    res = subprocess.run(["mount", "-o", "remount,ro", str(mnt)], capture_output=True,
                         text=True)
    if res.returncode != 0:
        pytest.skip(f"cannot remount the tmpfs read-only: {res.stderr.strip()}")


def _big(n: int = 300_000) -> xr.Dataset:
    return xr.Dataset({"y": ("sample", np.arange(n, dtype=float))},
                      coords={"sample": np.arange(n)}, attrs={"gearuq_version": "test"})


# ------------------------------------------------------------------------------ item 4a
def test_full_disk_names_the_file_and_the_free_space(tmpfs):
    mnt = tmpfs("1m")
    target = mnt / "result.nc"
    with pytest.raises(OSError) as info:
        save(_big(), target)  # 4.8 MB of values on a 1 MB file system
    msg = str(info.value)
    assert info.value.errno == errno.ENOSPC
    assert str(target) in msg and "no space left" in msg
    assert "free of 1.0 MB" in msg and "needs about" in msg
    assert not target.exists() and list(mnt.iterdir()) == []  # no partial file left


def test_full_disk_in_a_store_names_the_chunk(tmpfs):
    mnt = tmpfs("1m")
    with pytest.raises(OSError, match=r"cannot write \S*chunk_000007\.nc: no space left"):
        write_chunk(mnt, 7, _big())
    assert list(mnt.iterdir()) == []


# ------------------------------------------------------------------------------ item 4b, c
def test_non_numeric_parameters_are_named_with_value_and_valid_range():
    with pytest.raises(ValueError, match=r"parameter 'x2': value 'abc' is text, not a real "
                                         r"number; valid: real numbers in"):
        MODEL.response({"x2": "abc"})
    with pytest.raises(ValueError, match=r"parameter 'x1': value \(1\+2j\) at sample 1 is a "
                                         r"complex number.*valid: real numbers in"):
        MODEL.response({"x1": [0.5, 1 + 2j]})
    ds = MODEL.response({"x1": [0.5, 2], "x2": np.array([1, 0.25], dtype=object)})
    np.testing.assert_array_equal(ds["y"].values, [1.5, 2.25])


@pytest.mark.parametrize("limit", [-1, 0, float("nan"), "1GB"])
def test_bad_memory_limit_is_rejected_as_an_argument(limit):
    with pytest.raises(ValueError, match=r"memory_limit: .* not valid.*> 0"):
        monte_carlo(MODEL, SPACE, n_samples=10, rng=1, memory_limit=limit, progress=False)


# ------------------------------------------------------------------------------ item 4e
def test_corrupt_chunk_warning_says_what_happens(tmp_path):
    store = tmp_path / "s"
    first = monte_carlo(MODEL, SPACE, n_samples=40, rng=3, chunk_size=10, store=store,
                        executor="serial", progress=False)
    ref = first["y"].values.copy()
    chunk = store / "chunk_000002.nc"
    raw = bytearray(chunk.read_bytes())
    raw[len(raw) // 2] ^= 0xFF
    chunk.write_bytes(bytes(raw))
    with pytest.warns(RuntimeWarning, match="chunk_000002.nc is corrupt") as rec:
        again = monte_carlo(MODEL, SPACE, n_samples=40, rng=3, chunk_size=10, store=store,
                            executor="serial", progress=False)
    text = " ".join(str(w.message) for w in rec if "corrupt" in str(w.message))
    assert "it was deleted and this run computes it again" in text
    assert "delete it" not in text
    assert again.attrs["reused_chunks"] == 3
    np.testing.assert_array_equal(again["y"].values, ref)


# ------------------------------------------------------------------------------ item 5a
KILLED_SAVE = """
import sys, time
import dask.array as da
import xarray as xr
from gearuq.io import save

def stall(block):
    if block.size:  # not on dask's zero-size probe
        time.sleep(600)
    return block

values = da.zeros(100, chunks=50).map_blocks(stall, dtype=float)
save(xr.Dataset({"y": ("sample", values)}), sys.argv[1], checksum=False)
"""


@pytest.mark.e2e
def test_temporary_of_a_killed_save_is_removed_by_the_next_save(tmp_path):
    target = tmp_path / "result.nc"
    script = tmp_path / "killed_save.py"
    script.write_text(textwrap.dedent(KILLED_SAVE))
    proc = subprocess.Popen([sys.executable, str(script), str(target)], env=_env(),
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        deadline = time.monotonic() + 60  # guards against a hang; not a timing assertion
        while time.monotonic() < deadline and not list(tmp_path.glob("*.tmp")):
            assert proc.poll() is None, "the save ended before it could be killed"
            time.sleep(0.05)
    finally:
        proc.send_signal(signal.SIGKILL)
        proc.wait()
    left = list(tmp_path.glob("*.tmp"))
    assert len(left) == 1  # SIGKILL during the write leaves the temporary file
    # a live writer's temporary (this process) must survive the cleaning
    live = temporary_path(target)
    live.write_bytes(b"in progress")
    save(_big(10), target)
    assert not left[0].exists()
    assert live.exists()
    np.testing.assert_array_equal(load(target)["y"].values, np.arange(10.0))
    live.unlink()
    assert clean_stale_temporaries(target) == []


# ------------------------------------------------------------------------------ item 5b
def test_deleted_checksum_attributes_warn_that_the_file_is_unverified(tmp_path):
    path = save(_big(10), tmp_path / "r.nc")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        load(path)  # intact: silent
    with netCDF4.Dataset(path, "a") as nc:
        nc["y"].delncattr("checksum")
    with pytest.warns(RuntimeWarning, match=r"r\.nc: variable\(s\) 'y' lost their 'checksum'"):
        load(path)
    with netCDF4.Dataset(path, "a") as nc:
        nc.delncattr("checksum")
    with pytest.warns(RuntimeWarning, match=r"r\.nc has no 'checksum' attribute: its contents "
                                            r"cannot be verified"):
        ds = load(path)
    np.testing.assert_array_equal(ds["y"].values, np.arange(10.0))


# ------------------------------------------------------------------------------ item 5c
def test_complete_store_on_read_only_media_is_reused(tmpfs):
    mnt = tmpfs("16m")
    store = mnt / "store"
    kwargs = dict(n_samples=60, rng=11, chunk_size=20, store=store, executor="serial",
                  progress=False)
    ref = monte_carlo(MODEL, SPACE, **kwargs)["y"].values.copy()
    _remount_read_only(mnt)
    ds = monte_carlo(MODEL, SPACE, **kwargs)
    assert ds.attrs["reused_chunks"] == 3
    np.testing.assert_array_equal(ds["y"].values, ref)
    ds.close()


def test_incomplete_store_on_read_only_media_says_what_to_do(tmpfs):
    mnt = tmpfs("16m")
    store = mnt / "store"
    kwargs = dict(n_samples=60, rng=11, chunk_size=20, store=store, executor="serial",
                  progress=False)
    monte_carlo(MODEL, SPACE, **kwargs).close()
    for p in store.glob("chunk_000001.nc*"):
        p.unlink()
    _remount_read_only(mnt)
    with pytest.raises(OSError, match=r"cannot be written .* 1 of its 3 chunks are missing "
                                      r"or corrupt; copy it to writable storage"):
        monte_carlo(MODEL, SPACE, **kwargs)
