"""``gearuq bench integrator``: work-precision of the batched integrator, side by side.

For the ``helical_pair`` model (any model exposing ``ode_problem`` works) on samples of its
built-in parameter space, tau in [0, 200]: for rtol from 1e-3 to 1e-10, time per sample on
one core and the error against a tight reference (gearuq DOP853 with located switchings,
rtol 1e-12, itself cross-checked against scipy DOP853 at rtol 1e-12), for

- gearuq Dormand-Prince 5(4) with located switching instants, stages on the branch frozen
  at the step start and the step cut at the crossing (the default), and with the step
  re-taken up to the crossing instead,
- the same stepping across the kinks (no event location),
- gearuq DOP853 with located switchings and frozen sides,
- scipy ``solve_ivp`` RK45, a per-sample Python loop with the model's plain-NumPy
  right-hand side (the usual baseline), and the same loop calling the compiled rhs,
- numbalsoda LSODA and DOP853 where the package is installed (it needs a Fortran compiler).

All timings are taken in this one run; nothing is compared with numbers from elsewhere.

``gearuq bench startup`` measures the first ``helical_pair`` call in fresh interpreters with
an empty numba cache (what a fresh clone pays: the kernel is compiled), with the filled
cache, and after the install-time ``precompile`` step.
"""

from __future__ import annotations

import json
import platform
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

RTOLS = (1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10)
TAU_END = 200.0
N_OUT = 201


def machine_description() -> str:
    """CPU model, logical core count and Python version, for benchmark reports."""
    import os

    cpu = platform.processor() or platform.machine()
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    return f"{cpu}, {os.cpu_count()} logical cores, Python {platform.python_version()}"


def best_time(fn: Callable[[], Any], repeat: int = 1) -> tuple[float, Any]:
    """Best wall time of ``repeat`` calls of ``fn`` and the last call's result."""
    best, out = np.inf, None
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t0)
    return best, out


def _error(y: np.ndarray, ref: np.ndarray) -> float:
    """Max absolute error over samples, instants and displacement states (nondimensional)."""
    return float(np.nanmax(np.abs(y - ref)))


def _scipy_loop(prob: dict, idx: list[int], t_eval: np.ndarray, method: str, rtol: float,
                atol: float, numpy_rhs: bool = False) -> np.ndarray:
    from scipy.integrate import solve_ivp

    rhs = prob["rhs"]
    out = np.empty((len(idx), t_eval.size, 10))
    for k, i in enumerate(idx):
        p = prob["coef"][i]

        def f(t, y, p=p):
            if numpy_rhs:
                return prob["rhs_numpy"](t, y, p)
            d = np.empty_like(y)
            rhs(t, y, p, d)
            return d

        sol = solve_ivp(f, (0.0, t_eval[-1]), prob["y0"][i], method=method, t_eval=t_eval,
                        rtol=rtol, atol=atol)
        out[k] = sol.y[:10].T if sol.success else np.nan
    return out


def _numbalsoda_solvers(prob: dict) -> dict[str, Any]:
    """numbalsoda solvers wrapping the same compiled rhs, or {} when not installed."""
    try:
        import numbalsoda
        from numba import carray, cfunc
    except ImportError:
        return {}
    rhs = prob["rhs"]
    n_state = prob["y0"].shape[1]
    n_coef = prob["coef"].shape[1]

    @cfunc(numbalsoda.lsoda_sig)
    def f(t, u, du, p):  # pragma: no cover - compiled
        rhs(t, carray(u, (n_state,)), carray(p, (n_coef,)), carray(du, (n_state,)))

    address = f.address

    def run(solver):
        def go(idx, t_eval, rtol, atol):
            out = np.empty((len(idx), t_eval.size, 10))
            for k, i in enumerate(idx):
                usol, ok = solver(address, prob["y0"][i].copy(), t_eval,
                                  data=prob["coef"][i].copy(), rtol=rtol, atol=atol)
                out[k] = usol[:, :10] if ok else np.nan
            return out
        return go

    return {"numbalsoda LSODA": run(numbalsoda.lsoda), "numbalsoda DOP853": run(numbalsoda.dop853)}


def integrator_table(model_name: str = "helical_pair", *, n_samples: int = 32,
                     n_scipy: int = 4, rtols=RTOLS, seed: int = 7) -> dict[str, Any]:
    """Measure the work-precision table; returns rows and metadata (no files written)."""
    import gearuq
    from gearuq.ode import solve_batch

    model = gearuq.get_model(model_name)
    space = model.default_space()
    params = space.sample(n_samples, rule="random", rng=seed)
    prob = model.ode_problem(params)
    t_eval = np.linspace(0.0, TAU_END, N_OUT)
    rhs, switch, n_switch = prob["rhs"], prob["switch"], prob["n_switch"]
    save = np.arange(10)

    def gearuq_run(method, rtol, events, parallel=False, idx=None, frozen=False):
        sel = slice(None) if idx is None else idx
        res = solve_batch(prob["rhs_sides"] if frozen else rhs, prob["y0"][sel],
                          prob["coef"][sel], t_eval, method=method,
                          rtol=rtol, atol=rtol * 1e-2, switch=switch if events else None,
                          n_switch=n_switch if events else 0, save=save, parallel=parallel,
                          max_steps=5_000_000, freeze_sides=frozen)
        return res

    # warm up every kernel variant used below (each is compiled, or loaded from the cache, on
    # its first use) before any timing
    gearuq_run("dopri5", 1e-3, True, idx=[0])
    gearuq_run("dop853", 1e-3, True, idx=[0])
    gearuq_run("dopri5", 1e-3, False, idx=[0])
    gearuq_run("dopri5", 1e-3, True, idx=[0], frozen=True)
    gearuq_run("dop853", 1e-3, True, idx=[0], frozen=True)
    t_ref, ref_res = best_time(lambda: gearuq_run("dop853", 1e-12, True))
    ref = ref_res.y
    scipy_idx = list(range(min(n_scipy, n_samples)))
    scipy_ref = _scipy_loop(prob, scipy_idx, t_eval, "DOP853", 1e-12, 1e-14)
    ref_check = _error(scipy_ref, ref[scipy_idx])

    rows: list[dict[str, Any]] = []

    def add(method, rtol, seconds, n, y, ref_rows, **extra):
        rows.append({"method": method, "rtol": rtol, "time_per_sample": seconds / n,
                     "error": _error(y, ref_rows), "n_samples": n, **extra})

    for rtol in rtols:
        for label, meth, events, frozen in (
                ("gearuq DOPRI5 + events (frozen sides)", "dopri5", True, True),
                ("gearuq DOPRI5 + events (re-take)", "dopri5", True, False),
                ("gearuq DOPRI5 no events", "dopri5", False, False),
                ("gearuq DOP853 + events (frozen sides)", "dop853", True, True)):
            sec, res = best_time(lambda m=meth, e=events, r=rtol, f=frozen: gearuq_run(m, r, e,
                                                                                   frozen=f),
                              repeat=2)
            add(label, rtol, sec, n_samples, res.y, ref,
                steps=float(res.n_steps.mean()), events=float(res.n_events.mean()),
                failed=int((res.status != 0).sum()))
    for rtol in rtols:
        if rtol < 1e-8:  # RK45 in Python needs minutes per sample there
            continue
        if "rhs_numpy" in prob:
            sec, y = best_time(lambda r=rtol: _scipy_loop(prob, scipy_idx, t_eval, "RK45", r,
                                                       r * 1e-2, numpy_rhs=True))
            add("scipy RK45 loop", rtol, sec, len(scipy_idx), y, ref[scipy_idx])
        sec, y = best_time(lambda r=rtol: _scipy_loop(prob, scipy_idx, t_eval, "RK45", r, r * 1e-2))
        add("scipy RK45 loop, numba rhs", rtol, sec, len(scipy_idx), y, ref[scipy_idx])
    for label, go in _numbalsoda_solvers(prob).items():
        go(scipy_idx[:1], t_eval, 1e-3, 1e-5)  # compile the cfunc path
        for rtol in rtols:
            sec, y = best_time(lambda r=rtol, g=go: g(list(range(n_samples)), t_eval, r, r * 1e-2))
            add(label, rtol, sec, n_samples, y, ref)
    # the parallel throughput actually used by studies
    sec, res = best_time(lambda: gearuq_run("dopri5", 1e-6, True, parallel=True, frozen=True),
                      repeat=2)
    parallel_row = {"method": "gearuq DOPRI5 + events (frozen sides), all cores", "rtol": 1e-6,
                    "time_per_sample": sec / n_samples, "error": _error(res.y, ref)}
    return {"rows": rows, "parallel": parallel_row, "reference_time_per_sample": t_ref / n_samples,
            "reference_vs_scipy_dop853": ref_check, "n_samples": n_samples,
            "machine": machine_description(), "model": model_name, "tau_end": TAU_END,
            "n_out": N_OUT}


def matched_error_ratios(rows: list[dict[str, Any]], baseline: str = "scipy RK45 loop",
                         baseline_rtol: float = 1e-6) -> dict[str, float]:
    """Speed ratio baseline/method at the baseline's error (log-log interpolation)."""
    base = [r for r in rows if r["method"] == baseline and r["rtol"] == baseline_rtol]
    if not base:
        return {}
    target = np.log10(base[0]["error"])
    out = {}
    for method in sorted({r["method"] for r in rows} - {baseline}):
        pts = sorted((np.log10(r["error"]), np.log10(r["time_per_sample"]))
                     for r in rows if r["method"] == method and r["error"] > 0)
        if len(pts) < 2:
            continue
        e, t = np.array(pts).T
        if not e.min() <= target <= e.max():
            continue
        order = np.argsort(e)
        t_at = 10 ** np.interp(target, e[order], t[order])
        out[method] = base[0]["time_per_sample"] / t_at
    return out


def render_markdown(result: dict[str, Any]) -> str:
    """Markdown table of a :func:`integrator_table` result."""
    lines = [
        f"Machine: {result['machine']}. Model `{result['model']}`, tau in [0, "
        f"{result['tau_end']:g}], {result['n_out']} output instants, {result['n_samples']} "
        "samples of the built-in space; times on ONE core (serial), error = max |p - p_ref| "
        "over samples, instants and the 10 nondimensional displacements (1 = 10 um).",
        f"Reference: gearuq DOP853 + events, rtol 1e-12 "
        f"({result['reference_time_per_sample'] * 1e3:.2f} ms/sample); its difference to "
        f"scipy DOP853 rtol 1e-12: {result['reference_vs_scipy_dop853']:.1e}.",
        "",
        "| method | rtol | ms per sample | error | mean steps | located switchings |",
        "|---|---|---|---|---|---|",
    ]
    for r in result["rows"]:
        lines.append(f"| {r['method']} | {r['rtol']:.0e} | {r['time_per_sample'] * 1e3:.3f} | "
                     f"{r['error']:.2e} | {r.get('steps', float('nan')):.0f} | "
                     f"{r.get('events', float('nan')):.0f} |")
    p = result["parallel"]
    lines += ["", f"All cores: {p['method']} at rtol 1e-6: {p['time_per_sample'] * 1e3:.3f} ms "
              f"per sample (error {p['error']:.2e})."]
    ratios = matched_error_ratios(result["rows"])
    if ratios:
        lines += ["", "Speed-up over the scipy RK45 loop at the error scipy reaches with rtol "
                  "1e-6 (log-log interpolation of each method's curve, one core):", ""]
        lines += [f"- {m}: {v:.0f}x" for m, v in ratios.items()]
    return "\n".join(lines)


# --------------------------------------------------------------------------------------------
# gearuq bench startup: the first helical_pair call from an empty compilation cache
# --------------------------------------------------------------------------------------------

_FIRST_CALL_SCRIPT = """
import json, sys, time
wall, cpu = time.perf_counter(), time.process_time()
import numpy as np
import gearuq
n, precompile_only = int(sys.argv[1]), sys.argv[2] == "precompile"
model = gearuq.get_model("helical_pair")
if precompile_only:
    model.precompile()
    print(json.dumps({"precompile_wall": time.perf_counter() - wall,
                      "precompile_cpu": time.process_time() - cpu}))
    sys.exit(0)
params = model.default_space().sample(n, rule="random", rng=1)
tau = np.linspace(0.0, 200.0, 101)
outputs = [f"p{i}" for i in range(1, 11)]
setup = (time.perf_counter() - wall, time.process_time() - cpu)
w, c = time.perf_counter(), time.process_time()
ds = model.response(params, tau, outputs=outputs)
first = (time.perf_counter() - w, time.process_time() - c)
w, c = time.perf_counter(), time.process_time()
model.response(params, tau, outputs=outputs)
second = (time.perf_counter() - w, time.process_time() - c)
print(json.dumps({"setup_wall": setup[0], "setup_cpu": setup[1], "first_wall": first[0],
                  "first_cpu": first[1], "second_wall": second[0], "second_cpu": second[1],
                  "failed": int((ds["status"] != 0).sum())}))
"""


def _first_call(cache_dir: Path, n_samples: int, mode: str = "call") -> dict[str, float]:
    """Run the first-call probe in a fresh interpreter with the given numba cache folder."""
    import os
    import subprocess
    import sys

    env = dict(os.environ, NUMBA_CACHE_DIR=str(cache_dir))
    wall = time.perf_counter()
    done = subprocess.run([sys.executable, "-c", _FIRST_CALL_SCRIPT, str(n_samples), mode],
                          capture_output=True, text=True, env=env, check=True)
    result = json.loads(done.stdout.strip().splitlines()[-1])
    result["process_wall"] = time.perf_counter() - wall
    return result


def startup_table(n_samples: int = 10_000) -> dict[str, Any]:
    """First-call times of helical_pair (tau in [0, 200], 101 instants, p1..p10) in fresh
    processes: from an empty numba cache (as after a fresh clone), from the filled cache, and
    after :meth:`HelicalPair.precompile` (the install-time step), for 1 and ``n_samples``
    samples. Each row also holds the second call in the same process."""
    import tempfile

    rows = []
    for n in (1, n_samples):
        with tempfile.TemporaryDirectory() as tmp:
            cache = Path(tmp)
            rows.append({"case": "empty cache (fresh clone)", "n_samples": n,
                         **_first_call(cache, n)})
            rows.append({"case": "filled cache (later runs)", "n_samples": n,
                         **_first_call(cache, n)})
    with tempfile.TemporaryDirectory() as tmp:
        cache = Path(tmp)
        pre = _first_call(cache, 1, "precompile")
        rows.append({"case": "after precompile", "n_samples": 1, **_first_call(cache, 1)})
    return {"rows": rows, "precompile": pre, "machine": machine_description()}


def render_startup(result: dict[str, Any]) -> str:
    """Markdown table of a :func:`startup_table` result."""
    pre = result["precompile"]
    lines = [
        f"Machine: {result['machine']}. helical_pair, tau in [0, 200], 101 instants, outputs "
        "p1..p10, Li, Hu and Han Table 2 samples; each row a fresh interpreter; "
        "wall (CPU) seconds.",
        f"`HelicalPair.precompile()` into an empty cache: {pre['precompile_wall']:.2f} "
        f"({pre['precompile_cpu']:.2f}) s.",
        "",
        "| numba cache | samples | import + set-up | first call | second call | process |",
        "|---|---|---|---|---|---|",
    ]
    for r in result["rows"]:
        lines.append(
            f"| {r['case']} | {r['n_samples']} | {r['setup_wall']:.2f} ({r['setup_cpu']:.2f}) | "
            f"{r['first_wall']:.2f} ({r['first_cpu']:.2f}) | {r['second_wall']:.2f} "
            f"({r['second_cpu']:.2f}) | {r['process_wall']:.2f} |")
    return "\n".join(lines)


#: The first call of each model the per-model table times: outputs and instants of a small
#: but real call (one nominal sample, default options), what a new user's first call needs.
MODEL_FIRST_CALLS: dict[str, dict[str, Any]] = {
    "linear_oscillator": {"outputs": ["displacement"], "t": [0.0, 10.0, 101]},
    "helical_pair": {"outputs": [f"p{i}" for i in range(1, 11)], "t": [0.0, 200.0, 101]},
    "mesh_excitation": {"outputs": ["ste_ptp"], "t": None},
    "geared_rotor": {"outputs": ["dte_rms"], "t": None},
    "mesh_oscillator": {"outputs": ["amplitude_up"], "t": None},
}

_MODEL_CALL_SCRIPT = """
import json, sys, time
cpu0, wall0 = time.process_time(), time.perf_counter()
import numpy as np
import gearuq
from numba.core import event
compiled = []
class _Count(event.Listener):
    def on_start(self, ev):
        compiled.append(1)
    def on_end(self, ev):
        pass
event.register("numba:compile", _Count())
name, spec = sys.argv[1], json.loads(sys.argv[2])
t = None if spec["t"] is None else np.linspace(*spec["t"][:2], int(spec["t"][2]))
model = gearuq.get_model(name)
ds = model.response({}, t, outputs=spec["outputs"])
first = (time.process_time() - cpu0, time.perf_counter() - wall0)
n_compiled = len(compiled)
c, w = time.process_time(), time.perf_counter()
model.response({}, t, outputs=spec["outputs"])
print(json.dumps({"first_cpu": first[0], "first_wall": first[1],
                  "again_cpu": time.process_time() - c, "again_wall": time.perf_counter() - w,
                  "status": int(np.max(ds["status"].values)), "compiled": n_compiled}))
"""


def model_first_calls(models: list[str] | None = None, route: str = "auto") -> dict[str, Any]:
    """First call of each model in a fresh interpreter, imports included: from an empty numba
    cache (a fresh install: everything compiles) and from the cache that run filled (every
    later process), side by side; plus the same call again in the warm process.

    Parameters
    ----------
    models : list of str, optional
        Names from :data:`MODEL_FIRST_CALLS` (default: all of them).
    route : {"auto", "compiled", "interpreted"}
        ``GEARUQ_KERNELS`` of the measured processes: ``"auto"`` (the default rule of
        :mod:`gearuq._firstcall`), ``"compiled"`` (compile from the first call, the behaviour
        before it) or ``"interpreted"``.

    Returns
    -------
    dict
        ``rows`` (one per model: ``cold_cpu``, ``cold_wall``, ``warm_cpu``, ``warm_wall``,
        ``again_cpu``, ``cold_compiled``: the number of numba compilations in the cold call,
        0 when it ran its kernels interpreted or needs none; the call's outputs and
        instants) and ``machine``.
    """
    import os
    import subprocess
    import sys
    import tempfile

    if route not in ("auto", "compiled", "interpreted"):
        raise ValueError(f"route={route!r}; valid: 'auto', 'compiled', 'interpreted'")
    names = list(MODEL_FIRST_CALLS) if models is None else list(models)
    unknown = [n for n in names if n not in MODEL_FIRST_CALLS]
    if unknown:
        raise ValueError(f"models: {unknown} have no first-call probe; valid: "
                         f"{', '.join(MODEL_FIRST_CALLS)}")
    rows = []
    for name in names:
        spec = MODEL_FIRST_CALLS[name]
        with tempfile.TemporaryDirectory() as cache:
            env = dict(os.environ, NUMBA_CACHE_DIR=cache, GEARUQ_QUIET_COMPILE="1",
                       GEARUQ_KERNELS=route,
                       GEARUQ_FIRSTCALL_LEDGER=os.path.join(cache, "gearuq_firstcall.json"))
            runs = [json.loads(subprocess.run(
                [sys.executable, "-c", _MODEL_CALL_SCRIPT, name, json.dumps(spec)],
                capture_output=True, text=True, env=env, check=True).stdout.splitlines()[-1])
                for _ in ("cold", "warm")]
        cold, warm = runs
        rows.append({"model": name, "outputs": spec["outputs"], "t": spec["t"],
                     "cold_cpu": cold["first_cpu"], "cold_wall": cold["first_wall"],
                     "warm_cpu": warm["first_cpu"], "warm_wall": warm["first_wall"],
                     "again_cpu": warm["again_cpu"], "status": max(cold["status"],
                                                                  warm["status"]),
                     "cold_compiled": cold["compiled"]})
    return {"rows": rows, "machine": machine_description()}


def render_model_first_calls(result: dict[str, Any]) -> str:
    """Markdown table of a :func:`model_first_calls` result."""
    lines = [
        f"Machine: {result['machine']}. One nominal sample per model, default options; each "
        "cell a fresh interpreter, imports included; CPU (wall) seconds. Cold: an empty numba "
        "cache (a fresh install); warm: the cache the cold run filled. Compiled: numba "
        "compilations in the cold call (0: its kernels ran as plain Python, gearuq._firstcall, "
        "or it has none).",
        "",
        "| model | call | cold first call | warm first call | cold / warm CPU | "
        "same call again | compiled |",
        "|---|---|---|---|---|---|---|",
    ]
    for r in result["rows"]:
        t = "no instants" if r["t"] is None else f"{r['t'][2]} instants"
        outs = ", ".join(r["outputs"]) if len(r["outputs"]) < 4 else \
            f"{r['outputs'][0]}..{r['outputs'][-1]}"
        lines.append(
            f"| {r['model']} | {outs}, {t} | {r['cold_cpu']:.2f} ({r['cold_wall']:.2f}) | "
            f"{r['warm_cpu']:.2f} ({r['warm_wall']:.2f}) | "
            f"{r['cold_cpu'] / r['warm_cpu']:.1f} | {r['again_cpu']:.3f} | "
            f"{r.get('cold_compiled', '-')} |")
    return "\n".join(lines)


def run_bench(what: str, out: str | Path = "gearuq_bench", quick: bool = False) -> int:
    """Run a benchmark and write its tables (markdown, JSON) and figure into ``out``.

    ``what``: ``"integrator"`` (work-precision of the batched integrator) or ``"startup"``
    (first-call times from an empty and a filled compilation cache).
    """
    from gearuq import plot

    if what not in ("integrator", "startup"):
        raise ValueError(f"bench: unknown benchmark {what!r}; valid: 'integrator', 'startup'")
    out = Path(out)
    if what == "startup":
        out.mkdir(parents=True, exist_ok=True)
        per_model = model_first_calls()
        result = startup_table(n_samples=1000 if quick else 10_000)
        text = render_model_first_calls(per_model) + "\n\n" + render_startup(result)
        (out / "startup.md").write_text(text + "\n")
        (out / "startup.json").write_text(json.dumps({**result, "per_model": per_model},
                                                     indent=1, default=float))
        print(text)
        return 0
    out.mkdir(parents=True, exist_ok=True)
    kwargs = {"n_samples": 4, "n_scipy": 1, "rtols": (1e-4, 1e-6, 1e-8)} if quick else {}
    result = integrator_table(**kwargs)
    text = render_markdown(result)
    (out / "integrator.md").write_text(text + "\n")
    (out / "integrator.json").write_text(json.dumps(result, indent=1, default=float))
    fig, ax = plot.plot_work_precision(result["rows"])
    ax.set_title("helical_pair, tau in [0, 200]: work-precision (one core)")
    plot.save_figure(fig, out / "integrator_work_precision.png")
    print(text)
    print(f"\nwritten: {out}/integrator.md, integrator.json, integrator_work_precision.png")
    return 0


if __name__ == "__main__":  # python -m gearuq.bench.core {integrator,startup} [--quick]
    import sys

    raise SystemExit(run_bench(sys.argv[1] if len(sys.argv) > 1 else "integrator",
                               quick="--quick" in sys.argv))
