"""A killed run's worker processes stop and never write into the store after it is gone
(issue "The remaining holes", item 1)."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

from gearuq.execution import lifeline
from gearuq.execution.store import write_chunk

REPO = Path(__file__).resolve().parents[1]

RUN = """
import sys, time
import gearuq
from gearuq.engines.montecarlo import monte_carlo
from gearuq.execution import ProcessRunner

def slow(x1, x2):
    time.sleep(0.1 * len(x1))
    return x1 + x2

model = gearuq.FunctionModel(slow, ["x1", "x2"], ["y"], name="slow")
space = gearuq.ParameterSpace.normal(x1=(0.0, 1.0), x2=(0.0, 1.0))
if __name__ == "__main__":
    monte_carlo(model, space, n_samples=600, rng=1, chunk_size=2,
                executor=ProcessRunner(2), store=sys.argv[1], progress=False)
"""


def _children(pid: int) -> list[int]:
    """Pids whose parent is ``pid`` (from /proc)."""
    out = []
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit():
            continue
        try:
            stat = (entry / "stat").read_text()
        except OSError:
            continue
        if int(stat[stat.rindex(")") + 2:].split()[1]) == pid:
            out.append(int(entry.name))
    return out


def _running(pid: int) -> bool:
    """Alive and not a zombie waiting to be reaped."""
    try:
        stat = (Path("/proc") / str(pid) / "stat").read_text()
    except OSError:
        return False
    return stat[stat.rindex(")") + 2] != "Z"


def _chunks(store: Path) -> set[str]:
    return {p.name for p in store.glob("chunk_*.nc*") if not p.name.endswith(".tmp")}


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc (Linux)")
@pytest.mark.e2e
def test_sigkill_of_a_run_stops_its_workers_and_their_writes(tmp_path):
    store = tmp_path / "store"
    script = tmp_path / "run.py"
    script.write_text(textwrap.dedent(RUN))
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(REPO),
                                                         os.environ.get("PYTHONPATH", "")])}
    proc = subprocess.Popen([sys.executable, str(script), str(store)], env=env,
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        deadline = time.monotonic() + 120  # guards against a hang; not a timing assertion
        workers: list[int] = []
        while time.monotonic() < deadline:
            workers = _children(proc.pid)
            if len(list(store.glob("*.sha256"))) >= 4 and len(workers) >= 2:
                break
            assert proc.poll() is None, "the run ended before it could be killed"
            time.sleep(0.05)
        else:
            pytest.fail("the run wrote no chunks")
        workers = _children(proc.pid)  # the two workers and multiprocessing's resource tracker
        assert len(workers) >= 2
        proc.send_signal(signal.SIGKILL)
        proc.wait()
        at_kill = _chunks(store)
        # liveness bound: before the fix the workers were still alive after minutes
        deadline = time.monotonic() + 10
        while time.monotonic() < deadline and any(map(_running, workers)):
            time.sleep(0.05)
        alive = [p for p in workers if _running(p)]
        time.sleep(1.0)  # five chunk durations: an orphan still writing would show up
        after = _chunks(store)
    finally:
        proc.kill()
        for pid in _children(proc.pid) + workers:
            if _running(pid):
                os.kill(pid, signal.SIGKILL)
    assert alive == [], f"processes of the killed run still alive: {alive}"
    assert after - at_kill == set(), f"chunks written after the kill: {sorted(after - at_kill)}"
    assert len(at_kill) < 600  # the run really was interrupted


def _tiny() -> xr.Dataset:
    return xr.Dataset({"y": ("sample", np.arange(3.0))}, coords={"sample": np.arange(3)})


def test_chunk_write_refuses_once_the_parent_is_gone(tmp_path, monkeypatch):
    # a worker whose recorded parent is not its parent any more: an orphan
    monkeypatch.setattr(lifeline, "_PARENT", os.getppid() + 1_000_000)
    with pytest.raises(lifeline.ParentGoneError, match="chunk_000003.nc"):
        write_chunk(tmp_path, 3, _tiny())
    assert list(tmp_path.iterdir()) == []
    monkeypatch.setattr(lifeline, "_PARENT", os.getppid())  # parent alive: written
    write_chunk(tmp_path, 3, _tiny())
    assert sorted(p.name for p in tmp_path.iterdir()) == ["chunk_000003.nc",
                                                          "chunk_000003.nc.sha256"]


def _product(x1, x2):
    return x1 * x2


@pytest.mark.e2e
@pytest.mark.skipif(sys.platform == "win32", reason="no forkserver on Windows")
def test_forkserver_workers_watch_their_real_parent():
    # a forkserver worker's parent is the fork server, not the run: the guard must not
    # mistake that for an orphan (every chunk would then fail in the executor)
    import gearuq
    from gearuq.engines.montecarlo import monte_carlo
    from gearuq.execution import ProcessRunner

    model = gearuq.FunctionModel(_product, ["x1", "x2"], ["y"], name="product")
    space = gearuq.ParameterSpace.normal(x1=(0.0, 1.0), x2=(0.0, 1.0))
    kwargs = dict(n_samples=120, rng=4, chunk_size=30, progress=False)
    ref = monte_carlo(model, space, executor="serial", **kwargs)
    with ProcessRunner(2, mp_context="forkserver") as runner:
        ds = monte_carlo(model, space, executor=runner, **kwargs)
    assert "failures" not in ds.attrs
    np.testing.assert_array_equal(ds["y"].values, ref["y"].values)
