"""``gearuq bench memory``: peak memory and wall time of Monte Carlo against sample count.

Each configuration runs in a fresh subprocess (so peak RSS is its own) on the helical pair
over the Li, Hu and Han Table 2 space: all outputs or one output, with or without a chunk
store. A run whose in-memory result would not fit is refused before it starts (that is the designed
behaviour and is reported as such). The model is compiled once before timing (numba cache).
"""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path
from typing import Any

from gearuq.bench import machine_description

__all__ = ["run"]

_SCRIPT = r"""
import json, sys, time
import numpy as np
import gearuq

def hwm():
    # peak resident size of this process's own memory map (ru_maxrss would include the
    # parent's size at fork time)
    with open("/proc/self/status") as fh:
        return next(int(x.split()[1]) * 1024 for x in fh if x.startswith("VmHWM:"))

n, outputs, store, n_t = int(sys.argv[1]), sys.argv[2], sys.argv[3], int(sys.argv[4])
model = gearuq.get_model("helical_pair")
space = model.default_space()
tau = np.linspace(0.0, 200.0, n_t)
outs = None if outputs == "all" else outputs.split(",")
# compile (or load from the cache) outside the timing: forced, since a small first call
# would otherwise run the kernel as plain Python and compile nothing
with gearuq.kernels_route("compiled"):
    model.response({}, tau[:2], outputs=["p1"])
base = hwm()
t0 = time.perf_counter()
row = {"n": n, "outputs": outputs, "store": store != "-"}
try:
    ds = gearuq.monte_carlo(model, space, tau, n_samples=n, rng=1, outputs=outs,
                            store=None if store == "-" else store, progress=False)
    row["n_failed"] = int(ds.attrs["n_failed"])
    row["result_bytes"] = int(ds.nbytes)
    row["status"] = "ok"
except MemoryError as exc:
    row["status"] = "refused: " + str(exc).split(";")[0]
row["wall_s"] = time.perf_counter() - t0
row["peak_rss"] = hwm()
row["baseline_rss"] = base
print("ROW " + json.dumps(row))
"""


def run(out: str | Path = "gearuq_bench", quick: bool = False,
        sizes: tuple[int, ...] | None = None, n_time: int = 21) -> list[dict[str, Any]]:
    """Measure and print the table; write it as JSON and Markdown into ``out``.

    Parameters
    ----------
    out : path
        Output folder.
    quick : bool
        Sizes 10^3 and 10^4 only.
    sizes : tuple of int, optional
        Sample counts (default 10^4, 10^5, 10^6).
    n_time : int
        Output instants over tau in [0, 200] (all outputs: 43 time series per sample).
    """
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    sizes = sizes or ((1_000, 10_000) if quick else (10_000, 100_000, 1_000_000))
    rows = []
    for n in sizes:
        for outputs in ("all", "p1"):
            for use_store in (False, True):
                tmp = tempfile.mkdtemp(prefix="gearuq-bench-", dir=out)
                store = str(Path(tmp) / "store") if use_store else "-"
                proc = subprocess.run(
                    [sys.executable, "-c", _SCRIPT, str(n), outputs, store, str(n_time)],
                    capture_output=True, text=True)
                shutil.rmtree(tmp, ignore_errors=True)
                line = [x for x in proc.stdout.splitlines() if x.startswith("ROW ")]
                row = json.loads(line[-1][4:]) if line else {
                    "n": n, "outputs": outputs, "store": use_store,
                    "status": "crashed: " + proc.stderr.strip().splitlines()[-1][:120]}
                rows.append(row)
                print(_fmt(row), flush=True)
    text = render_markdown(rows, n_time)
    (out / "bench_memory.md").write_text(text)
    (out / "bench_memory.json").write_text(json.dumps(rows, indent=1))
    print(text)
    return rows


def _fmt(row: dict[str, Any]) -> str:
    gb = 2**30
    return (f"n={row['n']:>8} outputs={row['outputs']:<4} store={int(row['store'])} "
            f"{row.get('status', '')[:60]:<60} wall={row.get('wall_s', float('nan')):8.1f} s "
            f"peak={row.get('peak_rss', 0) / gb:6.2f} GB")


def render_markdown(rows: list[dict[str, Any]], n_time: int) -> str:
    """The measured table as Markdown."""
    gb = 2**30
    lines = [f"Machine: {machine_description()}. helical_pair, Li, Hu and Han Table 2 space, "
             "tau in [0, 200] at "
             f"{n_time} instants; 'all' = every output (43 time series + 6 scalars).", "",
             "| samples | outputs | store | result | wall time | per sample | peak RSS |",
             "|---:|---|---|---:|---:|---:|---:|"]
    for r in rows:
        size = f"{r['result_bytes'] / gb:.2f} GB" if "result_bytes" in r else r["status"]
        wall = r.get("wall_s", float("nan"))
        lines.append(
            f"| {r['n']:,} | {r['outputs']} | {'yes' if r['store'] else 'no'} | {size} | "
            f"{wall:.1f} s | {wall / r['n'] * 1e3:.3f} ms | "
            f"{r.get('peak_rss', 0) / gb:.2f} GB |")
    return "\n".join(lines) + "\n"
