"""The failure-analysis package: no import cycle, one method table, one status table, and
the defects that once gave a confident wrong answer (each on a problem it shows on)."""

from __future__ import annotations

import ast
import math
from pathlib import Path

import numpy as np
import pytest
from scipy import stats

import gearuq
from gearuq.failure.api import METHOD_TABLE, MethodEntry, failure_probability
from gearuq.failure.methods import mc
from gearuq.failure.methods.form import series_linear_probability
from gearuq.failure.report import REPORT_STATUS, STATUS_TEXT
from gearuq.model import Evaluation
from gearuq.testing import reliability_problems as rp
from gearuq.testing.problems import standard_normal_space

PACKAGE = Path(gearuq.__file__).parent


# =========================================================================== layout
def _imports(path: Path, module: str) -> set[str]:
    """Modules of gearuq that ``path`` imports, function-level imports included, imports
    under ``if TYPE_CHECKING:`` excluded."""
    tree = ast.parse(path.read_text())
    skip: set[int] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.If) and "TYPE_CHECKING" in ast.unparse(node.test):
            skip |= {id(n) for n in ast.walk(node)}
    package = module if path.name == "__init__.py" else module.rpartition(".")[0]
    out = set()
    for node in ast.walk(tree):
        if id(node) in skip:
            continue
        if isinstance(node, ast.Import):
            out |= {a.name for a in node.names if a.name.startswith("gearuq")}
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                base = ".".join(package.split(".")[: len(package.split(".")) - node.level + 1]
                                + ([base] if base else []))
            if base.startswith("gearuq"):
                out.add(base)
                out |= {f"{base}.{a.name}" for a in node.names}
    return out


def _module_graph() -> dict[str, set[str]]:
    files = {}
    for path in PACKAGE.rglob("*.py"):
        rel = path.relative_to(PACKAGE.parent).with_suffix("")
        name = ".".join(rel.parts[:-1] if rel.name == "__init__" else rel.parts)
        files[name] = path
    graph = {}
    for name, path in files.items():
        # an import of a package executes its __init__, an import of a module the module
        graph[name] = {m for m in _imports(path, name) if m in files and m != name}
    return graph


@pytest.mark.e2e
def test_no_import_cycle_in_gearuq():
    """Tarjan's strongly connected components over every gearuq module: none larger than one.

    Function-level imports count (they only hide a cycle); a package's own ``__init__`` is
    left out of the edges *into* its submodules' parents, since importing ``a.b`` runs
    ``a/__init__`` first whatever imports what."""
    graph = _module_graph()
    index, low, stack, on, sccs = {}, {}, [], set(), []

    def visit(v: str, counter: list[int]) -> None:
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on.add(v)
        for w in graph[v]:
            if v.startswith(w + "."):  # a submodule importing its parent package's name
                continue
            if w not in index:
                visit(w, counter)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            sccs.append(comp)

    counter = [0]
    for v in graph:
        if v not in index:
            visit(v, counter)
    cycles = [sorted(c) for c in sccs if len(c) > 1]
    assert cycles == [], f"import cycles: {cycles}"


def test_one_integrity_error_class():
    from gearuq import io
    from gearuq.execution import IntegrityError

    assert io.IntegrityError is IntegrityError


def test_status_tables_are_complete_and_plugin_codes_start_at_16():
    assert set(REPORT_STATUS) == set(STATUS_TEXT) == set(range(10))
    with pytest.raises(ValueError, match="plugin codes start at 16"):
        Evaluation(data={}, status=np.zeros(1, np.int8), status_meanings={5: "mine"})
    Evaluation(data={}, status=np.zeros(1, np.int8), status_meanings={16: "mine"})


def test_a_method_joins_by_one_table_entry(monkeypatch):
    """A new method is one row: its settings are validated and its runner called."""
    monkeypatch.setitem(METHOD_TABLE, "mc_twice",
                        MethodEntry(mc.SETTINGS, mc.run, "crude Monte Carlo again"))
    rep = failure_probability(rp.offset_model(), rp.offset_space(), "g", method="mc_twice",
                              n_samples=1000, rng=1, executor="serial")
    assert int(rep["n_model_runs"]) == 1000
    with pytest.raises(ValueError, match="unknown setting"):
        failure_probability(rp.offset_model(), rp.offset_space(), "g", method="mc_twice",
                            n_sample=10)


# =========================================================================== defects
def test_window_outside_the_instants_is_refused():
    model = rp.gaussian_process_model()
    space = gearuq.ParameterSpace.normal(**{n: (0.0, 1.0) for n in model.parameter_names})
    limit = gearuq.LimitState.upper("y", 3.0, window=(5.0, 30.0))
    with pytest.raises(ValueError, match=r"window \[5, 30\] reaches outside"):
        failure_probability(model, space, limit, np.linspace(0.0, 20.0, 101), method="mc",
                            n_samples=10)


@pytest.mark.e2e
def test_series_form_is_deterministic_and_exact_on_half_spaces():
    """Four half-spaces in the plane: the polar integral against the closed form (the safe
    set is a rectangle in coordinates rotated by 45 degrees)."""
    a = np.array([[1.0, 1.0], [-1.0, -1.0], [1.0, -1.0], [-1.0, 1.0]]) / math.sqrt(2)
    b = np.array([2.5, 2.5, 2.8, 2.8])

    # the safe set is the rectangle |u.a1| < 2.5, |u.a3| < 2.8 in rotated coordinates
    exact = 1.0 - (1 - 2 * stats.norm.sf(2.5)) * (1 - 2 * stats.norm.sf(2.8))
    assert series_linear_probability(a, b) == pytest.approx(exact, rel=1e-8)
    assert series_linear_probability(a, b) == series_linear_probability(a, b)
    # three independent directions in three dimensions: the fixed directional average
    p3 = series_linear_probability(np.eye(3), np.array([2.0, 2.0, 2.0]))
    assert p3 == pytest.approx(1 - (1 - stats.norm.sf(2.0)) ** 3, rel=3e-3)


def test_nan_outputs_widen_the_mc_interval_and_set_a_status():
    """g = 3 - x1 with NaN where x1 > 3.2: dropping the NaN samples halves Pf."""
    rep = failure_probability(rp.nan_tail_model(), standard_normal_space(2), "g", method="mc",
                              n_samples=200_000, rng=3, executor="serial")
    assert int(rep["status"]) == 6 and int(rep["n_invalid"]) > 0
    assert float(rep["pf_lower"]) <= rp.NAN_TAIL_PF <= float(rep["pf_upper"])
    assert float(rep["pf"]) < 0.7 * rp.NAN_TAIL_PF  # counts the invalid as safe, and says so
    assert "invalid" in rep.attrs["message"]


def test_nan_outputs_widen_the_subset_interval():
    rep = failure_probability(rp.nan_tail_model(), standard_normal_space(2), "g",
                              method="subset", rng=4, executor="serial")
    assert int(rep["status"]) == 6
    assert float(rep["pf_lower"]) <= rp.NAN_TAIL_PF <= float(rep["pf_upper"])


@pytest.mark.parametrize("method", ["mc", "subset", "importance"])
def test_every_run_failing_is_a_model_failure(method):
    model = gearuq.FunctionModel(lambda x1, x2: np.full_like(x1, np.nan), ["x1", "x2"], ["g"],
                                 name="always_nan")
    settings = {"n_samples": 200} if method == "mc" else {}
    rep = failure_probability(model, standard_normal_space(2), "g", method=method, rng=1,
                              executor="serial", **settings)
    assert int(rep["status"]) == 2 and math.isnan(float(rep["pf"]))
    assert int(rep["pf_is_upper_bound"]) == 0


@pytest.mark.e2e
def test_coarse_time_grid_sets_a_status_and_a_fine_one_holds():
    """A stationary Gaussian process at 5 instants per mean period: the grid misses
    first passages; at 150 per period the estimate agrees with a finer reference."""
    model = rp.gaussian_process_model()
    space = gearuq.ParameterSpace.normal(**{n: (0.0, 1.0) for n in model.parameter_names})
    limit = gearuq.LimitState.upper("y", 3.0)
    coarse = failure_probability(model, space, limit, np.linspace(0.0, 20.0, 28), method="mc",
                                 n_samples=20_000, rng=1, executor="serial")
    fine = failure_probability(model, space, limit, np.linspace(0.0, 20.0, 800), method="mc",
                               n_samples=20_000, rng=1, executor="serial")
    assert int(coarse["status"]) == 7 and "refine" in coarse.attrs["message"]
    assert int(fine["status"]) == 0
    # the coarse interval misses the fine estimate: the status was needed
    assert float(coarse["pf_upper"]) < float(fine["pf_lower"])


def test_akmcs_without_a_failing_run_gives_no_bound():
    """Pf = 3.4e-6 with a population of 2e4: nothing fails, so AK-MCS cannot bound Pf."""
    rep = failure_probability(rp.offset_model(), rp.offset_space(), "g", method="akmcs",
                              n_mc=20_000, max_mc=20_000, max_runs=30, rng=2,
                              executor="serial")
    assert int(rep["status"]) == 8
    assert math.isnan(float(rep["pf"])) and math.isnan(float(rep["pf_upper"]))
    assert "never seen the failure domain" in rep.attrs["message"]


def test_akmcs_missed_cov_target_is_not_status_0():
    rep = failure_probability(rp.resistance_load_model(), rp.resistance_load_space(), "g",
                              method="akmcs", n_mc=2000, max_mc=2000, target_cov=0.05,
                              rng=3, executor="serial")
    assert int(rep["status"]) != 0 and "CoV" in rep.attrs["message"]


@pytest.mark.e2e
@pytest.mark.parametrize("seed", [11, 12, 13])
def test_importance_sampling_on_four_design_points(seed):
    """Four branches of comparable weight: the default search finds all four (or says it
    may not have) and the interval holds the quadrature reference."""
    p = rp.reliability_problems()["four_branch"]
    rep = failure_probability(p["model"], p["space"], "g", method="importance", rng=seed,
                              executor="serial")
    holds = float(rep["pf_lower"]) <= p["pf"] <= float(rep["pf_upper"])
    assert holds or int(rep["status"]) != 0
    assert int(rep["status"]) == 0 and rep.sizes["design_point"] == 4
