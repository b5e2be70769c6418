"""`gearuq bench` and `gearuq compile` say what is valid and what was done
(issue "The remaining holes", item 6)."""

from __future__ import annotations

from gearuq import cli, registry


def test_unknown_benchmark_lists_every_valid_name(capsys, monkeypatch):
    monkeypatch.setattr(registry, "list_benchmarks", lambda: ["mesh_oscillator"])
    assert cli.main(["bench", "bogus"]) == 2
    err = capsys.readouterr().err
    assert "unknown benchmark 'bogus'" in err
    for name in (*cli.BUILTIN_BENCHES, "mesh_oscillator"):
        assert name in err
    assert set(cli.BUILTIN_BENCHES) == {"integrator", "startup", "surrogate", "memory",
                                        "reliability"}


class _Plain:
    name = "plain"


class _Verbose:
    name = "verbose"

    def __init__(self) -> None:
        self.calls: list[bool] = []

    def precompile(self, verbose: bool = False) -> float:
        self.calls.append(verbose)
        if verbose:
            print("  kernel A 1.0 s")
        return 2.5


class _ReturnsNothing:
    name = "silent"

    def __init__(self) -> None:
        self.called = 0

    def precompile(self) -> None:
        self.called += 1


def test_compile_reports_per_model_what_it_did(capsys, monkeypatch):
    models = {"plain": _Plain(), "verbose": _Verbose(), "silent": _ReturnsNothing()}
    monkeypatch.setattr(registry, "get_model", models.__getitem__)
    assert cli.main(["compile", "plain", "verbose", "silent"]) == 0
    out = capsys.readouterr().out
    lines = out.splitlines()
    assert "nothing to compile" not in out
    assert any(line.startswith("plain") and "no precompile() step" in line for line in lines)
    # a model with precompile() is run, item by item when it can say so
    assert models["verbose"].calls == [True]
    assert "  kernel A 1.0 s" in lines
    assert any(line.startswith("verbose") and "precompile() done in" in line
               and "the model reports 2.5 s" in line for line in lines)
    # a precompile() that returns nothing is run and timed, not a crash
    assert models["silent"].called == 1
    assert any(line.startswith("silent") and "precompile() done in" in line for line in lines)
