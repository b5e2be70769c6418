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


class _ProbedModel:
    """A model named like one with a first-call probe and no precompile(): records the
    route its call was forced to."""

    name = "mesh_excitation"

    def __init__(self) -> None:
        self.routes: list[str | None] = []

    def response(self, params, t, outputs=None):
        from gearuq import _firstcall

        self.routes.append(_firstcall._forced.get())


def test_compile_makes_the_nominal_first_call_compiled_for_models_without_precompile(
        capsys, monkeypatch):
    model = _ProbedModel()
    monkeypatch.setattr(registry, "get_model", {"mesh_excitation": model}.__getitem__)
    assert cli.main(["compile", "mesh_excitation"]) == 0
    # small first calls run interpreted; `gearuq compile` must compile all the same
    assert model.routes == ["compiled"]
    assert "its nominal first call, compiled, done in" in capsys.readouterr().out


def test_runs_of_many_calls_compile_from_the_first_call_and_the_environment_is_restored(
        monkeypatch):
    import os

    seen = []
    monkeypatch.delenv("GEARUQ_KERNELS", raising=False)
    monkeypatch.setattr(registry, "list_benchmarks", lambda: ["probe"])
    monkeypatch.setattr(registry, "get_benchmark",
                        lambda name: lambda out, quick: seen.append(
                            os.environ.get("GEARUQ_KERNELS")))
    assert cli.main(["bench", "probe"]) == 0
    # a benchmark times warm kernels: compiled from the first call, in its workers too
    assert seen == ["compiled"] and "GEARUQ_KERNELS" not in os.environ
    monkeypatch.setenv("GEARUQ_KERNELS", "interpreted")  # the user's choice is kept
    assert cli.main(["bench", "probe"]) == 0
    assert seen[-1] == "interpreted"
