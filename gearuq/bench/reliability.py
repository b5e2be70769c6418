"""``gearuq bench reliability``: speed against error of every reliability method, side by side.

Every method of :func:`gearuq.failure_probability` runs on the problems of
:mod:`gearuq.testing.reliability_problems` (exact or quadrature references), in one run:

* the **error** is the relative error of Pf against the reference (mean of the absolute
  errors over the seeds), beside the method's own coefficient of variation and whether its
  interval holds the reference (fraction of seeds);
* the **cost** is the number of model runs (the decisive number for an expensive model) and
  the wall time (measured on whatever else the machine does at the time);
* **runs for 10 %** extrapolates each sampling method to a 10 % coefficient of variation,
  ``n (cov / 0.1)^2``; crude Monte Carlo needs ``100 (1 - pf) / pf``. FORM/SORM are
  approximations: their cost is what they used and their error is a bias that more runs do
  not remove. AK-MCS reports what it used (its error is bounded by its population).

Where a method fails (FORM on the parabola with two design points, AK-MCS on the
discontinuous response, one-point importance sampling on the parabola), the row says so.
The table is printed, written to ``OUT/reliability_bench.md`` and, with ``docs``, into the
reliability section of docs/benchmarks.md (between its markers).
"""

from __future__ import annotations

import functools
import json
import math
import time
import warnings
from pathlib import Path
from typing import Any

import numpy as np

from gearuq.registry import (
    get_reliability_case,
    list_reliability_cases,
    reliability_case_attribute,
)

__all__ = ["run", "cases", "main", "coverage", "coverage_cases", "rejudge"]

_START = "<!-- reliability-bench:start -->"
_END = "<!-- reliability-bench:end -->"
_COV_START = "<!-- reliability-coverage:start -->"
_COV_END = "<!-- reliability-coverage:end -->"
_RUNS_START = "<!-- reliability-runs:start -->"
_RUNS_END = "<!-- reliability-runs:end -->"


def cases(quick: bool = False) -> list[tuple[str, str, str, dict[str, Any]]]:
    """``(problem, row label, method, settings)`` of every row."""
    heavy = not quick
    rows: list[tuple[str, str, str, dict[str, Any]]] = []
    mc_n = 10_000 if quick else 100_000
    for problem in ("offset", "linear_100d", "resistance_load", "oscillator", "four_branch",
                    "four_branch_system", "parabola", "jump"):
        rows.append((problem, f"crude MC ({mc_n:.0e})", "mc", {"n_samples": mc_n}))
        if problem != "four_branch_system":
            # one start: the classic FORM/SORM cost (status 8 says other design points were
            # not looked for); the default multi-start search is in the coverage benchmark
            rows.append((problem, "FORM", "form", {"n_starts": 1}))
            if problem != "linear_100d" or heavy:
                rows.append((problem, "SORM (Tvedt)", "sorm", {"n_starts": 1}))
        if problem == "parabola":
            rows.append((problem, "FORM, 6 starts", "form", {"n_starts": 6}))
        if problem != "four_branch_system":
            rows.append((problem, "IS, 1 start", "importance", {"n_starts": 1}))
            rows.append((problem, "IS", "importance", {}))
        rows.append((problem, "subset", "subset", {}))
        if problem == "linear_100d":
            continue  # Kriging in 100 dimensions: not attempted (see the note)
        ak = {"max_runs": 150}
        if problem == "offset":
            if quick:
                continue
            ak["max_mc"] = 1_000_000
        if problem == "jump":
            ak["max_mc"] = 200_000
        if quick:
            ak.update(n_mc=30_000, max_mc=min(ak.get("max_mc", 10**6), 60_000))
        rows.append((problem, "AK-MCS", "akmcs", ak))
    return rows


_NOTES = {
    ("parabola", "FORM"): "fails: one of two design points (Pf -39 %)",
    ("parabola", "SORM (Tvedt)"): "fails: one of two design points",
    ("parabola", "IS, 1 start"): "one design point of two: status 8 says so",
    ("parabola", "FORM, 6 starts"): "2 design points found; series FORM in pf_multi",
    ("jump", "FORM"): "discontinuous g: FD gradient meaningless at the jump",
    ("jump", "SORM (Tvedt)"): "discontinuous g",
    ("jump", "AK-MCS"): "discontinuous g: U stays < 2 along the jump, stops at max_runs",
    ("offset", "AK-MCS"): "population-limited: Pf 3e-6 needs ~1e8 points",
    ("four_branch", "FORM"): "fails: series system, FORM sees one branch",
    ("four_branch", "SORM (Tvedt)"): "fails: series system, one branch (and its kink)",
    ("four_branch", "IS, 1 start"): "one design point of four: status 8 says so",
    ("linear_100d", "AK-MCS"): "not run: Kriging in 100-D",
}


def _one(problem: dict[str, Any], method: str, settings: dict[str, Any], seed: int
         ) -> dict[str, Any]:
    from gearuq.failure.api import failure_probability

    t0 = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        rep = failure_probability(problem["model"], problem["space"], problem["limit_state"],
                                  problem.get("t"), method=method, rng=seed,
                                  executor="serial",
                                  model_options=problem.get("model_options"), **settings)
    wall = time.perf_counter() - t0
    ref = problem["pf"]
    pf = float(rep["pf"])
    lo, up = float(rep["pf_lower"]), float(rep["pf_upper"])
    extra = {}
    if "pf_multi_design_points" in rep:
        extra["pf_multi"] = float(rep["pf_multi_design_points"])
    if "n_low_fidelity_runs" in rep:
        extra["lf_runs"] = int(rep["n_low_fidelity_runs"])
    return {"pf": pf, "lower": lo, "upper": up,
            "error": abs(pf / ref - 1) if math.isfinite(pf) else math.nan,
            "cov": float(rep["cov_pf"]), "covered": bool(lo <= ref <= up) if math.isfinite(
                lo + up) else None, "runs": int(rep["n_model_runs"]), "wall": wall,
            "status": int(rep["status"]), "bound": int(rep["pf_is_upper_bound"]), **extra}


def _summarise(name: str, label: str, method: str, ref: float, runs: list[dict[str, Any]]
               ) -> dict[str, Any]:
    err = [r["error"] for r in runs if math.isfinite(r["error"])]
    cov = [r["cov"] for r in runs if math.isfinite(r["cov"])]
    covered = [r["covered"] for r in runs if r["covered"] is not None]
    n = float(np.mean([r["runs"] for r in runs]))
    row = {"problem": name, "row": label, "method": method, "reference": ref,
           "pf": float(np.mean([r["pf"] for r in runs])),
           "error": float(np.mean(err)) if err else math.nan,
           "cov": float(np.mean(cov)) if cov else math.nan,
           "covered": float(np.mean(covered)) if covered else math.nan,
           "runs": n, "wall": float(np.mean([r["wall"] for r in runs])),
           "seeds": len(runs), "status": max(r["status"] for r in runs),
           "bound": max(r["bound"] for r in runs),
           "note": _NOTES.get((name, label), "")}
    if "pf_multi" in runs[0]:
        row["pf_multi"] = float(np.mean([r["pf_multi"] for r in runs]))
    row["mc_runs_10pct"] = 100.0 * (1 - ref) / ref
    if method == "mc":
        row["runs_10pct"] = row["mc_runs_10pct"]
    elif method in ("importance", "subset") and row["cov"] > 0 and not row["bound"]:
        row["runs_10pct"] = n * (row["cov"] / 0.1) ** 2
    else:
        row["runs_10pct"] = n
    # a saving counts only where the answer is right: the interval holds the reference
    # (sampling methods) or the error is within 10 % (approximations and surrogates)
    ok = (row["covered"] >= 0.5) if method in ("mc", "importance", "subset") else (
        row["error"] <= 0.10)
    row["saving"] = row["mc_runs_10pct"] / row["runs_10pct"] if ok else math.nan
    return row


def run(out: str | Path = "gearuq_bench_reliability", quick: bool = False,
        docs: str | Path | None = None, seeds: int | None = None) -> dict[str, Any]:
    """Run every row; print, write ``reliability_bench.md`` / ``.json`` into ``out``.

    Parameters
    ----------
    out : path
        Output folder (created).
    quick : bool
        Smaller settings and one seed (about a minute).
    docs : path, optional
        docs/benchmarks.md to update (only the text between the reliability markers; the
        section is appended when the markers are missing).
    seeds : int, optional
        Seeds per sampling-method row (default 1 quick, 3 full).

    Returns
    -------
    dict
        ``rows`` (one dict per table row) and ``markdown``.
    """
    from gearuq.testing.reliability_problems import reliability_problems

    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    problems = reliability_problems()
    n_seeds = seeds if seeds is not None else (1 if quick else 3)
    rows = []
    for name, label, method, settings in cases(quick):
        p = problems[name]
        reps = 1 if method in ("form", "sorm") else n_seeds
        results = [_one(p, method, settings, 100 + s) for s in range(reps)]
        row = _summarise(name, label, method, p["pf"], results)
        rows.append(row)
        print(f"  {name:<18} {label:<16} pf={row['pf']:.4g} err={row['error']:.3g} "
              f"runs={row['runs']:.0f} wall={row['wall']:.2f}s", flush=True)
    text = markdown(rows, quick, n_seeds)
    (out / "reliability_bench.md").write_text(text)
    (out / "reliability_bench.json").write_text(json.dumps(rows, indent=1, default=float))
    if docs is not None:
        update_docs(Path(docs), text)
    print(text)
    return {"rows": rows, "markdown": text}


def _fmt(v: float, spec: str = ".3g") -> str:
    return "--" if v is None or not math.isfinite(v) else format(v, spec)


def markdown(rows: list[dict[str, Any]], quick: bool, n_seeds: int) -> str:
    """The table as markdown."""
    head = [
        f"Measured by `gearuq bench reliability{' --quick' if quick else ''}` "
        f"({n_seeds} seed(s) per sampling row; FORM/SORM are deterministic). Wall times are "
        "**provisional**: the 2-core machine ran other jobs; the model-run column is the one "
        "to read for an expensive model. *runs for 10 %*: sampling methods extrapolated to a "
        "10 % CoV as n (CoV/0.1)^2; crude MC needs 100 (1 - Pf)/Pf; FORM/SORM/AK-MCS: the "
        "runs used. *saving* = crude-MC runs for 10 % / this method's, shown only where the "
        "answer is right (interval holds the reference, or error <= 10 % for FORM/SORM/AK-MCS)."
        " *in CI*: fraction of seeds whose interval holds the reference.",
        "",
        "| problem | Pf ref | method | Pf | rel. error | CoV | in CI | model runs | "
        "runs for 10 % | saving vs MC | wall [s] | note |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    body = []
    for r in rows:
        pf = _fmt(r["pf"], ".4g") + (" (bound)" if r["bound"] else "")
        note = r["note"]
        if r["status"] not in (0, 4) and not note:
            note = {1: "not converged", 2: "model failure", 3: "weights degenerate",
                    5: "SORM invalid"}.get(r["status"], "")
        if "pf_multi" in r:
            note += f" (series FORM {r['pf_multi']:.4g})"
        body.append(
            f"| {r['problem']} | {r['reference']:.4g} | {r['row']} | {pf} | "
            f"{_fmt(r['error'], '.1%') if not r['bound'] else '--'} | {_fmt(r['cov'], '.2f')} "
            f"| {_fmt(r['covered'], '.0%')} | {r['runs']:.0f} | {r['runs_10pct']:.3g} | "
            f"{_fmt(r['saving'], '.3g') + 'x' if math.isfinite(r['saving']) else '--'} | "
            f"{r['wall']:.2f} | {note} |")
    return "\n".join(head + body) + "\n"


def update_docs(path: Path, table: str, markers: tuple[str, str] = (_START, _END),
                heading: str = "## `gearuq bench reliability`\n\nRare-event methods against "
                "crude Monte Carlo on exact references; method notes in "
                "[reliability.md](reliability.md).") -> None:
    """Replace the text between ``markers`` in ``path`` (append with ``heading`` if missing)."""
    start, end = markers
    text = path.read_text() if path.exists() else ""
    block = f"{start}\n{table}{end}"
    if start in text and end in text:
        before = text[: text.index(start)]
        after = text[text.index(end) + len(end):]
        text = before + block + after
    else:
        text = text.rstrip("\n") + "\n\n" + heading + "\n\n" + block + "\n"
    path.write_text(text)


def main(quick: bool = False, out: str = "gearuq_bench", docs: str | None = "auto",
         with_coverage: bool = False, seeds: int | None = None, workers: int = 1,
         problems: list[str] | None = None) -> int:
    """Entry for ``gearuq bench reliability [--coverage]``: run, print, write; return 0.

    ``docs="auto"`` updates ``docs/benchmarks.md`` when run from a source checkout (the file
    exists relative to the working directory); ``None`` leaves the docs alone.
    """
    if docs == "auto":
        docs = "docs/benchmarks.md" if Path("docs/benchmarks.md").is_file() else None
    if with_coverage:
        coverage(Path(out), quick=quick, docs=docs, seeds=seeds, workers=workers,
                 problems=problems)
    else:
        run(Path(out), quick=quick, docs=docs)
    if docs is not None:
        print(f"reliability table written into {docs}")
    return 0


# =========================================================================== coverage
def case_label(method: str, settings: dict[str, Any]) -> str:
    """The method as the tables name it: its settings that change what it does."""
    if settings.get("replicates", 1) > 1:
        return f"{method} (replicates {settings['replicates']})"
    if method == "mfis":
        opts = ", ".join(f"{k} {v:g}" if isinstance(v, float) else f"{k} {v}"
                         for k, v in (settings.get("low_fidelity_options") or {}).items())
        lf = settings["low_fidelity"]
        lf = getattr(lf, "name", lf)
        biasing = settings.get("biasing", "gaussian")
        tail = f"; {biasing}" if biasing != "gaussian" else ""
        if settings.get("low_fidelity_t") is not None:
            tail += f"; {np.size(settings['low_fidelity_t'])} instants"
        return f"mfis (LF: {lf}{', ' + opts if opts else ''}{tail})"
    return method


def coverage_cases(quick: bool = False) -> list[tuple[str, str, dict[str, Any]]]:
    """``(problem, method, settings)`` of the coverage benchmark: the generic problems' rows
    here, the gear models' rows from their cases (``gearuq.reliability_cases``, full size
    only)."""
    rows: list[tuple[str, str, dict[str, Any]]] = []
    for problem in ("offset", "resistance_load", "oscillator", "four_branch", "parabola",
                    "jump", "linear_100d", "exponential_sum", "nan_tail"):
        rows.append((problem, "mc", {"n_samples": 20_000 if quick else 100_000}))
        rows.append((problem, "importance", {}))
        rows.append((problem, "subset", {}))
        if problem not in ("linear_100d", "offset", "exponential_sum") and not quick:
            rows.append((problem, "akmcs", {"max_runs": 150, "n_mc": 50_000,
                                            "max_mc": 400_000}))
    # a partially informative cheap model: it sees one of two failure mechanisms (a third of
    # Pf); MFIS must hold or say so, whatever its defensive draws happen to hit
    rows.append(("two_mechanisms", "mfis", {"low_fidelity": _problems()["two_mechanisms"][
        "low_fidelity"], "max_samples": 5000 if quick else 10_000}))
    if not quick:  # the gear models' cases, each with the rows its plugin declares
        for name in sorted(list_reliability_cases(), key=_gear_first):
            rows.extend((name, method, settings)
                        for method, settings in _problems()[name].get("coverage", ()))
    # issue 30: modes in different units (as a series system and as one limit state), a
    # ridge whose chains do not mix, and the helical pair's deep level
    for problem in ("unit_modes_system", "unit_modes_single", "ridge"):
        if problem != "ridge":
            rows.append((problem, "importance", {}))
        rows.append((problem, "subset", {}))
    return rows


def _gear_first(name: str) -> tuple[int, str]:
    """Table order: the gear cases of :data:`GEAR_PROBLEMS` in their order, then the others."""
    return (GEAR_PROBLEMS.index(name), "") if name in GEAR_PROBLEMS else (len(GEAR_PROBLEMS),
                                                                           name)


@functools.lru_cache(maxsize=1)
def _problems() -> dict[str, dict[str, Any]]:
    """The problems, built once per process (every seed of every row reads them)."""
    from gearuq.space import ParameterSpace
    from gearuq.testing.reliability_problems import (
        reliability_problems,
        ridge_model,
        ridge_pf,
        unit_modes_limit_state,
        unit_modes_model,
        unit_modes_pf,
    )

    plane = ParameterSpace.normal(u1=(0.0, 1.0), u2=(0.0, 1.0))
    units = {f"unit_modes_{kind}": {
        "model": unit_modes_model((1e3, 1e-3)), "space": plane,
        "limit_state": unit_modes_limit_state(kind == "system"), "pf": unit_modes_pf(),
        "source": "1-D quadrature"} for kind in ("system", "single")}
    ridge = {"model": ridge_model(), "space": ParameterSpace.normal(
        **{f"x{i}": (0.0, 1.0) for i in range(1, 7)}), "limit_state": "g", "pf": ridge_pf(),
        "source": "1-D quadrature"}
    gear = {name: get_reliability_case(name) for name in list_reliability_cases()}
    return {**reliability_problems(), **gear, **units, "ridge": ridge}


def _coverage_task(args: tuple[str, str, dict[str, Any], int]) -> dict[str, Any]:
    name, method, settings, seed = args
    return _one(_problems()[name], method, settings, seed)


def coverage_row(name: str, method: str, ref: float, runs: list[dict[str, Any]]
                 ) -> dict[str, Any]:
    """Mean, bias, empirical and reported CoV, coverage and runs of one (problem, method)."""
    pf = np.array([r["pf"] for r in runs])
    ok = np.array([r["status"] == 0 for r in runs])
    held = np.array([bool(r["covered"]) for r in runs])
    # estimates only: a run that observed no failure reports a bound, not an estimate
    finite = np.isfinite(pf) & ~np.array([bool(r["bound"]) for r in runs])
    mean = float(pf[finite].mean()) if finite.any() else math.nan
    sd = float(pf[finite].std(ddof=1)) if finite.sum() > 1 else math.nan
    se = sd / math.sqrt(finite.sum()) if finite.sum() > 1 else math.nan
    rep_cov = [r["cov"] for r in runs if math.isfinite(r["cov"])]
    judged = [bool(r["covered"]) for r in runs if r["covered"] is not None]
    n_runs = float(np.mean([r["runs"] for r in runs]))
    cov_emp = sd / ref
    # expensive runs for a 10 % empirical CoV: the variance falls as 1/runs
    runs_10 = n_runs * (cov_emp / 0.1) ** 2 if math.isfinite(cov_emp) else math.nan
    mc_10 = 100.0 * (1.0 - ref) / ref
    return {"coverage_all": float(np.mean(judged)) if judged else math.nan,
            "lf_runs": float(np.mean([r.get("lf_runs", 0) for r in runs])),
            "runs_10pct": runs_10, "mc_runs_10pct": mc_10,
            "gain_vs_mc": mc_10 / runs_10 if runs_10 and math.isfinite(runs_10) else math.nan,
            "problem": name, "method": method, "reference": ref, "seeds": len(runs),
            "pf_mean": mean, "bias_se": (mean - ref) / se if se and se > 0 else math.nan,
            "cov_empirical": cov_emp, "cov_reported": float(np.mean(rep_cov)) if rep_cov
            else math.nan, "n_status0": int(ok.sum()),
            "coverage_status0": float(held[ok].mean()) if ok.any() else math.nan,
            "held_or_flagged": float(np.mean(held | ~ok)),
            "statuses": sorted({int(r["status"]) for r in runs}),
            "runs": n_runs, "wall": float(np.mean([r["wall"] for r in runs]))}


def coverage(out: str | Path = "gearuq_bench_reliability", quick: bool = False,
             docs: str | Path | None = None, seeds: int | None = None, workers: int = 1,
             cases_: list[tuple[str, str, dict[str, Any]]] | None = None,
             problems: list[str] | None = None) -> dict[str, Any]:
    """Interval coverage of every method over many seeds against exact references.

    For each (problem, method): the mean Pf, its bias in standard errors, the empirical CoV
    (spread of the estimates over the seeds) against the mean reported one, how many runs
    had status 0, the share of those whose interval holds the reference (the honesty
    target: >= 90 %), and the share of all runs whose interval holds or whose status is
    nonzero. ``workers`` > 1 runs seeds in parallel processes. ``problems`` keeps only the
    rows of those problems; the docs table then keeps its other rows and replaces these.
    The gear-model rows also go into a second table: expensive runs for a 10 % empirical
    CoV against crude Monte Carlo's.
    """
    import concurrent.futures as cf

    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    n_seeds = seeds if seeds is not None else (5 if quick else 20)
    todo = cases_ if cases_ is not None else coverage_cases(quick)
    if problems is not None:
        known = sorted({name for name, _, _ in todo})
        unknown = [p for p in problems if p not in known]
        if unknown:
            raise ValueError(f"problems: unknown {unknown}; valid: {', '.join(known)}")
        todo = [case for case in todo if case[0] in problems]
    problems_ = _problems()
    tasks = [(name, method, settings, 1000 + k) for name, method, settings in todo
             for k in range(n_seeds)]
    if workers > 1:
        with cf.ProcessPoolExecutor(workers) as pool:
            results = list(pool.map(_coverage_task, tasks, chunksize=1))
    else:
        results = [_coverage_task(t) for t in tasks]
    rows = []
    for i, (name, method, settings) in enumerate(todo):
        label = case_label(method, settings)
        row = coverage_row(name, label, problems_[name]["pf"],
                           results[i * n_seeds:(i + 1) * n_seeds])
        rows.append(row)
        print(f"  {name:<16} {method:<10} status0 {row['n_status0']:>2}/{n_seeds} coverage "
              f"{_fmt(row['coverage_status0'], '.0%')} held-or-flagged "
              f"{row['held_or_flagged']:.0%} runs {row['runs']:.0f}", flush=True)
    text = coverage_markdown(rows, quick, n_seeds)
    (out / "reliability_coverage.md").write_text(text)
    (out / "reliability_coverage.json").write_text(json.dumps(rows, indent=1, default=float))
    # every run as it came (pf, interval, runs, status): a later reference re-judges them
    (out / "reliability_coverage_runs.json").write_text(json.dumps(
        [{"problem": t[0], "method": case_label(t[1], t[2]), "seed": t[3], **r}
         for t, r in zip(tasks, results, strict=True)], indent=1, default=float))
    runs_text = runs_markdown([r for r in rows if r["problem"] in GEAR_PROBLEMS], n_seeds)
    if docs is not None:
        if problems is not None:
            text = merge_table_rows(Path(docs), text, (_COV_START, _COV_END))
        update_docs(Path(docs), text, (_COV_START, _COV_END),
                    "## Interval coverage: `gearuq bench reliability --coverage`")
        if runs_text:
            if problems is not None:
                runs_text = merge_table_rows(Path(docs), runs_text, (_RUNS_START, _RUNS_END))
            update_docs(Path(docs), runs_text, (_RUNS_START, _RUNS_END),
                        "## Runs to a 10 % CoV on the gear models")
    print(text + "\n" + runs_text)
    return {"rows": rows, "markdown": text, "runs_markdown": runs_text}


def rejudge(out: str | Path = "gearuq_bench_reliability", docs: str | Path | None = None
            ) -> dict[str, Any]:
    """Judge the stored runs of :func:`coverage` (``OUT/reliability_coverage_runs.json``)
    again against the problems' current references, and rewrite the tables.

    For a reference revised after the runs (the runs themselves do not depend on it): each
    run's interval is compared with the new value, and the rows of the problems in the file
    replace theirs in ``docs`` (the other rows are kept).
    """
    out = Path(out)
    runs = json.loads((out / "reliability_coverage_runs.json").read_text())
    problems_ = _problems()
    groups: dict[tuple[str, str], list[dict[str, Any]]] = {}
    for r in runs:
        ref = problems_[r["problem"]]["pf"]
        lo, up = r["lower"], r["upper"]
        r["covered"] = bool(lo <= ref <= up) if math.isfinite(lo + up) else None
        r["error"] = abs(r["pf"] / ref - 1) if math.isfinite(r["pf"]) else math.nan
        groups.setdefault((r["problem"], r["method"]), []).append(r)
    n_seeds = max(len(g) for g in groups.values())
    rows = [coverage_row(name, label, problems_[name]["pf"], g)
            for (name, label), g in groups.items()]
    text = coverage_markdown(rows, False, n_seeds)
    runs_text = runs_markdown([r for r in rows if r["problem"] in GEAR_PROBLEMS], n_seeds)
    (out / "reliability_coverage.json").write_text(json.dumps(rows, indent=1, default=float))
    if docs is not None:
        update_docs(Path(docs), merge_table_rows(Path(docs), text, (_COV_START, _COV_END)),
                    (_COV_START, _COV_END),
                    "## Interval coverage: `gearuq bench reliability --coverage`")
        if runs_text:
            update_docs(Path(docs), merge_table_rows(Path(docs), runs_text,
                                                     (_RUNS_START, _RUNS_END)),
                        (_RUNS_START, _RUNS_END), "## Runs to a 10 % CoV on the gear models")
    print(text + "\n" + runs_text)
    return {"rows": rows, "markdown": text, "runs_markdown": runs_text}


#: Problems that are gear models: their rows also go into the runs-to-10 % table.
GEAR_PROBLEMS = ("helical_pair", "helical_pair_grid", "geared_rotor")


def runs_markdown(rows: list[dict[str, Any]], n_seeds: int) -> str:
    """Expensive-model runs for a 10 % empirical CoV against crude Monte Carlo ("" if none)."""
    if not rows:
        return ""
    head = [
        f"Measured with the coverage table's runs ({n_seeds} seeds per row). *HF runs*: mean "
        "expensive-model runs per estimate; *LF runs*: cheap-model runs (not in HF runs); "
        "*HF runs for 10 %*: HF runs x (empirical CoV / 0.1)^2; *crude MC*: 100 (1 - Pf) / Pf "
        "runs for the same CoV; *coverage (all)*: share of every run's 95 % interval that "
        "holds the reference, whatever its status.",
        "",
        "| problem | Pf ref | method | mean Pf | CoV emp. | coverage (all) | statuses | "
        "HF runs | LF runs | HF runs for 10 % | crude MC | gain |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    body = [
        f"| {r['problem']} | {r['reference']:.3g} | {r['method']} | {_fmt(r['pf_mean'], '.3g')}"
        f" | {_fmt(r['cov_empirical'], '.2f')} | {_fmt(r['coverage_all'], '.0%')} | "
        f"{','.join(map(str, r['statuses']))} | {r['runs']:.0f} | {r['lf_runs']:.0f} | "
        f"{_fmt(r['runs_10pct'], '.3g')} | {r['mc_runs_10pct']:.3g} | "
        f"{_fmt(r['gain_vs_mc'], '.3g')}x |" for r in rows]
    return "\n".join(head + body) + "\n"


def merge_table_rows(path: Path, table: str, markers: tuple[str, str]) -> str:
    """``table`` with the rows of the table already between ``markers`` in ``path`` that it
    does not replace (a row is keyed by its problem and method cells), in their order."""
    text = path.read_text() if path.exists() else ""
    start, end = markers
    if start not in text or end not in text:
        return table
    old = text[text.index(start) + len(start): text.index(end)]

    def key(line: str) -> tuple[str, str]:
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        return cells[0], cells[2]

    def is_row(line: str) -> bool:
        return line.startswith("| ") and not line.startswith("| problem") and len(
            line.split("|")) > 4

    new_lines = table.rstrip("\n").split("\n")
    new_rows = {key(line): line for line in new_lines if is_row(line)}
    merged = [new_rows.pop(key(line), line) for line in old.split("\n") if is_row(line)]
    merged += list(new_rows.values())
    prose = [line for line in new_lines if not is_row(line)]
    return "\n".join(prose + merged) + "\n"


def coverage_markdown(rows: list[dict[str, Any]], quick: bool, n_seeds: int) -> str:
    """The coverage table as markdown."""
    head = [
        f"Measured by `gearuq bench reliability --coverage{' --quick' if quick else ''}`, "
        f"{n_seeds} seeds per row (seeds 1000-{999 + n_seeds}). *status 0*: runs where the "
        "method vouched for its interval; *coverage*: share of those whose 95 % interval "
        "holds the reference (target >= 90 %); *held or flagged*: share of all runs whose "
        "interval holds or whose status is nonzero; *bias*: (mean Pf - reference) in "
        "standard errors of the mean; *CoV emp.*: spread of the estimates over the seeds / "
        "reference, against the mean reported CoV (mean, bias and CoVs over the runs that gave "
        "an estimate, not a bound).",
        "",
        "| problem | Pf ref | method | mean Pf | bias [se] | CoV emp. | CoV rep. | status 0 "
        "| coverage | held or flagged | statuses | model runs |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    body = [
        f"| {r['problem']} | {r['reference']:.3g} | {r['method']} | {_fmt(r['pf_mean'], '.3g')}"
        f" | {_fmt(r['bias_se'], '+.1f')} | {_fmt(r['cov_empirical'], '.2f')} | "
        f"{_fmt(r['cov_reported'], '.2f')} | {r['n_status0']}/{r['seeds']} | "
        f"{_fmt(r['coverage_status0'], '.0%')} | {r['held_or_flagged']:.0%} | "
        f"{','.join(map(str, r['statuses']))} | {r['runs']:.0f} |" for r in rows]
    return "\n".join(head + body) + "\n"


def __getattr__(name: str) -> Any:
    """``HELICAL_PAIR_LOW_FIDELITY`` and ``HELICAL_PAIR_LOW_FIDELITY_T``, the helical pair's
    MFIS settings, live in its plugin now; found through ``gearuq.reliability_cases``."""
    return reliability_case_attribute(name, __name__)
