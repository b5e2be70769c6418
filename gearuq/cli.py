"""The ``gearuq`` command line."""

from __future__ import annotations

import argparse
import json
import math
import os
import re
import sys
import tempfile
from collections.abc import Sequence
from typing import Any

from gearuq._version import __version__


def _int_at_least(lowest: int, note: str = "") -> Any:
    """An argparse type: an integer >= ``lowest`` (argparse adds the option's name)."""
    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(
                f"{text!r} is not an integer; valid: integers >= {lowest}{note}") from None
        if value < lowest:
            raise argparse.ArgumentTypeError(
                f"{value} is outside its valid range: integers >= {lowest}{note}")
        return value

    parse.__name__ = f"integer >= {lowest}"
    return parse


def _finite_float(text: str) -> float:
    """An argparse type: a finite number (argparse adds the option's name)."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
    if not math.isfinite(value):
        raise argparse.ArgumentTypeError(f"{text!r} is not a finite number")
    return value


_finite_float.__name__ = "float"
_positive_int = _int_at_least(1)
#: A seed: numpy's generators take the integers 0 .. 2**63 - 1.
_seed = _int_at_least(0)


def _folder(text: str) -> str:
    """An argparse type: a folder name that is not empty (``""`` would write into the current
    folder without saying so) and not an existing file."""
    import pathlib

    if not text.strip():
        raise argparse.ArgumentTypeError("an empty folder name; give a folder to write into, "
                                         "e.g. results")
    path = pathlib.Path(text)
    if path.exists() and not path.is_dir():
        raise argparse.ArgumentTypeError(f"{text!r} is an existing file, not a folder; give a "
                                         "folder to write into")
    # the folder itself is made later, by the command (a refused option elsewhere must not
    # leave it behind); whether it can be made is asked now, of its nearest existing parent,
    # by making and removing a scratch folder there (permission bits say nothing for root or
    # on read-only and virtual file systems)
    parent = next((p for p in (path.absolute(), *path.absolute().parents) if p.exists()), None)
    if parent is None or not parent.is_dir():
        raise argparse.ArgumentTypeError(f"{text!r}: {parent} is not a folder; give a folder to "
                                         "write into")
    try:
        os.rmdir(tempfile.mkdtemp(prefix=".gearuq-probe-", dir=parent))
    except OSError as exc:
        raise argparse.ArgumentTypeError(
            f"{text!r}: cannot write into {parent} ({exc.strerror or exc}); give a folder you "
            "can write to") from None
    return text


def _cmd_models(args: argparse.Namespace) -> int:
    from gearuq import registry

    if args.name is None and getattr(args, "stage", None):
        raise ValueError("models: --stage builds one model from the stage; give its NAME, e.g. "
                         "`gearuq models geared_rotor --stage FILE`")
    if args.name is None:
        rows = registry.describe_models()
        width = max((len(r.name) for r in rows), default=4)
        print(f"{'name':<{width}}  version  description")
        for r in rows:
            if r.error:
                print(f"{r.name:<{width}}  BROKEN   {r.error}")
            else:
                print(f"{r.name:<{width}}  {r.version:<7}  {r.description}")
        return 0
    if getattr(args, "stage", None) is not None:
        model = registry.get_model(args.name, stage=_read_stage(args.stage))
        print(f"built from the stage {args.stage}")
    else:
        model = registry.get_model(args.name)
    print(f"{model.name} {model.version}: {model.description}\n")
    print("parameters:")
    w = max(len(p.name) for p in model.parameters)
    for p in model.parameters:
        print(f"  {p.name:<{w}}  nominal {p.nominal:<12g} range {p.range_text():<28} "
              f"{p.description}")
    print("\noutputs:")
    w = max(len(o.name) for o in model.outputs)
    wu = max(len(o.units) for o in model.outputs) + 2
    for o in model.outputs:
        print(f"  {o.name:<{w}}  {'[' + o.units + ']':<{wu}}  dims {', '.join(o.dims):<14} "
              f"{o.description}")
    if model.options:
        print("\noptions (keyword arguments of response, monte_carlo, ...):")
        w = max(len(o.name) for o in model.options)
        for o in model.options:
            print(f"  {o.name:<{w}}  default {o.default!r:<12} valid {o.valid_text():<30} "
                  f"{o.description}")
    space = model.default_space()
    if space is not None:
        print("\ndefault parameter space (default_space()):")
        print("  " + repr(space).replace("\n", "\n  "))
    return 0


def _cmd_studies(args: argparse.Namespace) -> int:
    from gearuq import registry

    rows = registry.describe_studies()
    if not rows:
        print("no studies registered")
        return 0
    width = max(len(r.name) for r in rows)
    print(f"{'name':<{width}}  description")
    for r in rows:
        mark = " (gearuq demo)" if r.name == registry.DEFAULT_STUDY else ""
        print(f"{r.name:<{width}}  {('BROKEN ' + r.error) if r.error else r.description}{mark}")
    return 0


def _numpydoc_parameters(doc: str | None) -> dict[str, str]:
    """``name -> description`` from the Parameters section of a numpydoc docstring."""
    import inspect

    lines = inspect.cleandoc(doc or "").splitlines()
    heads = [i for i, line in enumerate(lines[:-1]) if line.strip() == "Parameters"
             and lines[i + 1].strip() and set(lines[i + 1].strip()) == {"-"}]
    out: dict[str, str] = {}
    current: list[str] = []
    for line in lines[heads[0] + 2:] if heads else []:
        if not line.strip():
            continue
        if not line.startswith(" "):  # "name : type", or the next section's heading
            if ":" not in line:
                break
            current = [n.strip() for n in line.split(":")[0].split(",")]
            out.update({n: "" for n in current})
        else:
            for n in current:
                out[n] = f"{out[n]} {line.strip()}".strip()
    return out


def _names_list(text: str) -> tuple[str, ...]:
    """A comma-separated list of names on the command line, as the tuple a study takes."""
    names = tuple(part.strip() for part in text.split(",") if part.strip())
    if not names:
        raise argparse.ArgumentTypeError(f"expected comma-separated names, got {text!r}")
    return names


def _option_type(annotation: object, default: object) -> Any:
    """The command-line type of a study setting: from its default, else its annotation."""
    if isinstance(default, bool):
        return bool
    if isinstance(default, tuple) and all(isinstance(item, str) for item in default):
        return _names_list
    if isinstance(default, (int, float, str)):
        return type(default)
    import inspect

    if annotation is inspect.Parameter.empty:
        return str  # no annotation, no typed default: the text as given
    text = annotation if isinstance(annotation, str) else getattr(annotation, "__name__", "")
    for word, kind in (("bool", bool), ("int", int), ("float", float), ("str", str),
                       ("Path", str), ("Any", str)):
        if word in str(text).replace("None", "").split(" | ") or str(text).startswith(word):
            return kind
    return None


def study_parser(name: str, study: object) -> argparse.ArgumentParser:
    """The command line of one study, derived from its run function.

    One option per keyword of ``study``'s signature (``--n-base`` for ``n_base``), typed by
    its default value or its annotation, with the help text of its numpydoc Parameters
    entry; ``--out`` and ``--quick`` come first. Settings left out take the study's defaults.

    Parameters
    ----------
    name : str
        The study's registered name (shown as the program name).
    study : callable
        Its run function ``run(out, quick=False, **settings)``.

    Returns
    -------
    argparse.ArgumentParser
        Parses the arguments after ``gearuq study NAME``; only options given on the command
        line appear in the namespace.
    """
    import inspect

    doc = inspect.getdoc(study) or ""
    helps = _numpydoc_parameters(doc)
    parser = argparse.ArgumentParser(
        prog=f"gearuq study {name}", argument_default=argparse.SUPPRESS,
        description=doc.split("\n\n")[0] + "\n\nOptions not given take the study's defaults.")
    parameters = inspect.signature(study).parameters
    for pname, par in parameters.items():
        if par.kind not in (par.POSITIONAL_OR_KEYWORD, par.KEYWORD_ONLY):
            continue
        flag = "--" + pname.replace("_", "-")
        text = re.sub(r":\w+:`~?([^`]+)`", r"\1", helps.get(pname, ""))  # Sphinx roles
        if pname == "out":
            parser.add_argument(flag, type=_folder, metavar="DIR",
                                help=f"output folder (default: gearuq_{name})")
            continue
        default = None if par.default is par.empty else par.default
        kind = _option_type(par.annotation, default)
        shown = f" (default: {default!r})" if default is not None else ""
        if kind is bool:
            parser.add_argument(flag, action=argparse.BooleanOptionalAction,
                                help=(text or pname) + shown)
        elif kind is _names_list:
            parser.add_argument(flag, type=kind, metavar="NAME[,NAME...]",
                                help=(text or pname) + f" (default: {','.join(default)})")
        elif kind is float:  # NaN and inf refused here, by the option's name
            parser.add_argument(flag, type=_finite_float, metavar="FLOAT",
                                help=(text or pname) + shown)
        elif kind is int and pname == "seed":
            parser.add_argument(flag, type=_seed, metavar="INT", help=(text or pname) + shown)
        elif kind is not None:
            parser.add_argument(flag, type=kind, metavar=kind.__name__.upper(),
                                help=(text or pname) + shown)
    return parser


def _cmd_study(args: argparse.Namespace) -> int:
    import inspect

    from gearuq import registry

    if args.name is None:
        args.study_parser.print_help()
        return 0 if args.help else 2
    study = registry.get_study(args.name)
    if (args.quick or "--quick" in args.rest) and "quick" not in inspect.signature(
            study).parameters:
        raise ValueError(f"study {args.name!r} has no quick mode; run it without --quick")
    own = study_parser(args.name, study)
    rest = list(args.rest) + (["--help"] if args.help else [])
    settings = vars(own.parse_args(rest))
    if args.out is not None:
        settings.setdefault("out", args.out)
    settings.setdefault("out", f"gearuq_{args.name}")
    if settings.pop("quick", False) or args.quick:
        settings["quick"] = True
    return int(study(**settings) or 0)


def _cmd_info(args: argparse.Namespace) -> int:
    from gearuq import io

    ds = io.load(args.file)
    print(f"{args.file}: gearuq result")
    print(f"  dims: {', '.join(f'{k}={v}' for k, v in ds.sizes.items())}")
    print("  variables:")
    for name, var in ds.data_vars.items():
        units = var.attrs.get("units", "")
        role = var.attrs.get("role", "")
        print(f"    {name:<24} {'(' + ', '.join(var.dims) + ')':<24} [{units}] {role}")
    if "status" in ds:
        from gearuq.failure.report import describe_status

        print(f"  {describe_status(ds)}")
    print("  provenance:")
    for key, value in ds.attrs.items():
        text = str(value)
        if text.startswith("{") or text.startswith("["):
            try:
                text = json.dumps(json.loads(text))
            except ValueError:
                pass
        if len(text) > 300 and not args.full:
            text = text[:297] + "..."
        print(f"    {key}: {text}")
    return 0


def _cmd_export(args: argparse.Namespace) -> int:
    from pathlib import Path

    from gearuq import io

    if not args.csv:
        raise ValueError("export: choose a format: --csv (one file per group of variables "
                         "sharing dims, units in the headers); --xlsx is not offered: no "
                         "spreadsheet writer is among gearuq's dependencies")
    ds = io.load(args.file)
    out = args.out or str(Path(args.file).with_suffix("")) + "_csv"
    written = io.export_csv(ds, out)
    print(f"{args.file}: {len(written) - 1} CSV file(s) and the provenance into {out}/")
    for path in written:
        print(f"  {path.name}")
    return 0


def _cmd_demo(args: argparse.Namespace) -> int:
    from gearuq import registry

    run = registry.get_study(registry.DEFAULT_STUDY)
    return int(run(out=args.out, n_samples=args.n_samples, seed=args.seed,
                   executor=args.executor, progress=not args.quiet, store=args.store,
                   keep_chunks=args.keep_chunks) or 0)


def _cmd_compile(args: argparse.Namespace) -> int:
    import inspect
    import time

    import numpy as np

    from gearuq import registry
    from gearuq._firstcall import kernels_route
    from gearuq.bench.core import MODEL_FIRST_CALLS

    names = args.names or registry.list_models()
    width = max((len(n) for n in names), default=4)
    for name in names:
        model = registry.get_model(name)
        precompile = getattr(model, "precompile", None)
        if not callable(precompile) and name in MODEL_FIRST_CALLS:
            # small first calls run uncompiled kernels as plain Python (gearuq._firstcall):
            # the nominal first call, compiling forced, fills the cache instead
            start = time.perf_counter()
            spec = MODEL_FIRST_CALLS[name]
            t = None if spec["t"] is None else np.linspace(*spec["t"][:2], int(spec["t"][2]))
            with kernels_route("compiled"):
                model.response({}, t, outputs=spec["outputs"])
            print(f"{name:<{width}}  its nominal first call, compiled, done in "
                  f"{time.perf_counter() - start:.1f} s", flush=True)
            continue
        if not callable(precompile):
            print(f"{name:<{width}}  no precompile() step: anything this model compiles is "
                  "compiled on its first call", flush=True)
            continue
        try:
            verbose = "verbose" in inspect.signature(precompile).parameters
        except (TypeError, ValueError):
            verbose = False
        print(f"{name:<{width}}  precompile(): compiling, or loading from the on-disk cache, "
              f"what its calls need{' (item by item below)' if verbose else ''}", flush=True)
        start = time.perf_counter()
        with kernels_route("compiled"):
            reported = precompile(verbose=True) if verbose else precompile()
        elapsed = time.perf_counter() - start
        detail = ""
        if isinstance(reported, (int, float)) and not isinstance(reported, bool):
            detail = f" (the model reports {float(reported):.1f} s of compiling or loading)"
        elif isinstance(reported, str) and reported.strip():
            detail = f": {reported.strip()}"
        print(f"{name:<{width}}  precompile() done in {elapsed:.1f} s{detail}", flush=True)
    return 0


BUILTIN_BENCHES = ("integrator", "startup", "surrogate", "memory", "reliability")


def _cmd_bench(args: argparse.Namespace) -> int:
    from gearuq import registry

    if args.what == "list":
        for name in (*BUILTIN_BENCHES, *registry.list_benchmarks()):
            print(name)
        return 0
    given = [flag for flag, value in (("--coverage", args.coverage), ("--seeds", args.seeds),
                                      ("--problems", args.problems),
                                      ("--workers", args.workers != 1)) if value]
    if given and args.what != "reliability":
        raise ValueError(f"bench {args.what}: {', '.join(given)} belong(s) to `gearuq bench "
                         "reliability` and would be ignored here")
    if args.what not in BUILTIN_BENCHES:
        plugins = registry.list_benchmarks()
        if args.what not in plugins:
            raise ValueError(
                f"bench: unknown benchmark {args.what!r}; valid: built-in "
                f"{', '.join(BUILTIN_BENCHES)}; from plugins: {', '.join(plugins) or 'none'}")
        registry.get_benchmark(args.what)(args.out, quick=args.quick)
        return 0
    if args.what == "reliability":
        from gearuq.bench.reliability import main as run_reliability

        return int(run_reliability(quick=args.quick, out=args.out, with_coverage=args.coverage,
                                   seeds=args.seeds, workers=args.workers,
                                   problems=list(args.problems) if args.problems
                                   else None) or 0)
    if args.what == "memory":
        from gearuq.bench.memory import run as run_memory

        run_memory(args.out, quick=args.quick)
        return 0
    if args.what == "surrogate":
        from gearuq.bench.surrogate import run

        run(args.out, quick=args.quick)  # returns the measured table; prints the report
        return 0
    from gearuq.bench import run_bench

    return run_bench(args.what, out=args.out, quick=args.quick)


def _rotor_speeds(text: str) -> int:
    """An argparse type: 0 (skip the geared rotor's run-up) or an integer >= 2."""
    value = _int_at_least(0, " (0 skips the run-up, else at least 2)")(text)
    if value == 1:
        raise argparse.ArgumentTypeError("1 is outside its valid range: 0 (skip the run-up) or "
                                         "integers >= 2 (a range has two ends)")
    return value


def _read_stage(text: str) -> Any:
    """A stage file (TOML), or the name of a shipped stage (GearStage.examples())."""
    from pathlib import Path

    from gearuq.gears.stage import GearStage

    if not text.strip():
        raise ValueError(f"stage: empty; give a stage file (TOML) or the name of a shipped "
                         f"stage: {', '.join(GearStage.examples())}")
    if Path(text).is_dir():
        raise ValueError(f"stage: {text!r} is a folder; give a stage file (TOML) or the "
                         "name of a shipped stage (GearStage.examples())")
    is_file = any(c in text for c in "./\\")
    return GearStage.from_toml(text) if is_file else GearStage.example(text)


def _cmd_run(args: argparse.Namespace) -> int:
    from gearuq.stage_analysis import analyse_stage, write_stage_results

    stage = _read_stage(args.stage)
    problem = None
    if stage.reliability and not args.no_reliability:
        from gearuq.stage_analysis import reliability, reliability_problem

        problem = reliability_problem(stage)  # its names checked before the long steps
    ds = analyse_stage(stage, progress=not args.quiet, stage_file=str(args.stage),
                       n_speeds=args.n_speeds, rotor_speeds=args.rotor_speeds)
    out = args.out or f"gearuq_{stage.name}"
    rel = None
    if problem is not None:
        rel = reliability(stage, progress=not args.quiet, problem=problem)
    paths = write_stage_results(ds, out, reliability=rel,
                                reliability_settings=stage.reliability_settings)
    for kind, path in paths.items():
        print(f"{kind:<10} {path}")
    print(f"mesh stiffness {ds.attrs['mesh_stiffness_N_per_um']:.1f} N/um "
          f"({ds.attrs['mesh_stiffness_definition']})")
    if rel is not None:
        rep = rel[0]
        print(f"pf {float(rep['pf']):.3g} [{float(rep['pf_lower']):.3g}, "
              f"{float(rep['pf_upper']):.3g}] in {int(rep['n_model_runs'])} runs, status "
              f"{int(rep['status'])}: {rep.attrs.get('message', '')}")
    return 0


def build_parser() -> argparse.ArgumentParser:
    """Return the argument parser of the ``gearuq`` command."""
    parser = argparse.ArgumentParser(
        prog="gearuq",
        description="Reliability and uncertainty quantification of gear dynamics.",
    )
    parser.add_argument("--version", action="version", version=f"gearuq {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")

    p = sub.add_parser("models", help="list registered models, or describe one",
                       description="Without NAME: table of registered models. With NAME: its "
                                   "parameters (units, nominal, valid range) and outputs.")
    p.add_argument("name", nargs="?", help="model to describe")
    p.add_argument("--stage", default=None, metavar="FILE",
                   help="describe the model built from this stage file (docs/stage.md)")
    p.set_defaults(func=_cmd_models)

    p = sub.add_parser("info", help="what a result file holds and how it was made",
                       description="Print dims, variables with units, failed samples and "
                                   "provenance of a gearuq netCDF result.")
    p.add_argument("file", help="a .nc file written by gearuq")
    p.add_argument("--full", action="store_true", help="do not shorten long attributes")
    p.set_defaults(func=_cmd_info)

    p = sub.add_parser("export", help="a result as CSV files with units in the headers",
                       description="Write a gearuq netCDF result as CSV files: one per group "
                                   "of variables sharing dims, 'name [units]' headers, the "
                                   "provenance in provenance.json beside them.")
    p.add_argument("file", help="a .nc file written by gearuq")
    p.add_argument("--csv", action="store_true", help="write CSV files (the one format)")
    p.add_argument("--out", default=None, type=_folder,
                   help="folder for the files (default: FILE without .nc, plus _csv)")
    p.set_defaults(func=_cmd_export)

    p = sub.add_parser("demo", help="run the built-in helical-pair reliability study",
                       description="10^4-sample Monte Carlo reliability of the helical "
                                   "gear pair of Li, Hu and Han (their Table 2 space): R(t), "
                                   "beta, fitted distributions; "
                                   "writes netCDF and PNG into --out.")
    p.add_argument("--out", default="gearuq_demo", type=_folder,
                   help="output folder (default: gearuq_demo)")
    p.add_argument("--n-samples", type=_int_at_least(3, " (the distribution fits need 3)"),
                   default=10_000, help="Monte Carlo samples (at least 3)")
    p.add_argument("--seed", type=_seed, default=20240607, help="random seed (>= 0)")
    p.add_argument("--executor", default=None, help="serial | processes | dask scheduler address")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.add_argument("--store", default=None, type=_folder,
                   help="chunk store folder (default: OUT/chunks-<hash of the settings>); an "
                        "interrupted run resumes from it")
    p.add_argument("--keep-chunks", action=argparse.BooleanOptionalAction, default=False,
                   help="keep the chunk store after the result is written (default: remove it)")
    p.set_defaults(func=_cmd_demo)

    p = sub.add_parser("studies", help="list the packaged studies",
                       description="Studies registered under the 'gearuq.studies' entry-point "
                                   "group (run one with `gearuq study NAME`).")
    p.set_defaults(func=_cmd_studies)

    p = sub.add_parser("study", help="run a packaged study", add_help=False,
                       description="Run a study registered under 'gearuq.studies'. "
                                   "`gearuq study NAME --help` lists the study's own options "
                                   "(seed, sample counts, executor...).")
    p.add_argument("-h", "--help", action="store_true",
                   help="show this help, or with NAME the study's own options")
    p.add_argument("--out", default=None, type=_folder,
                   help="output folder (default: gearuq_<name>)")
    p.add_argument("--quick", action="store_true",
                   help="a quick version of the study (smaller questions, fewer runs)")
    p.add_argument("name", nargs="?", help="study name (see `gearuq studies`)")
    p.add_argument("rest", nargs=argparse.REMAINDER, metavar="...",
                   help="the study's own options (see `gearuq study NAME --help`)")
    p.set_defaults(func=_cmd_study, study_parser=p)

    p = sub.add_parser("compile", help="compile the models' kernels once (numba cache)",
                       description="Compile, or load from the on-disk numba cache, what a "
                                   "default call of each model needs, so that no later first "
                                   "call pays it (optional: first calls compile on demand).")
    p.add_argument("names", nargs="*", help="models (default: all registered)")
    p.set_defaults(func=_cmd_compile)

    p = sub.add_parser("bench", help="work-precision benchmarks",
                       description="Speed against error, side by side in one run.")
    p.add_argument("what", metavar="WHAT",
                   help="integrator: work-precision of the batched ODE solver on helical_pair; "
                        "startup: first-call times from an empty and a filled compile cache; "
                        "surrogate: PCE / Sobol-MC speed against error on analytic benchmarks; "
                        "memory: peak RSS and wall time of Monte Carlo against sample count; "
                        "reliability: every failure-probability method side by side (with "
                        "--coverage: interval coverage over many seeds); or a "
                        "benchmark a plugin registers (`gearuq bench list`)")
    p.add_argument("--out", default="gearuq_bench", type=_folder, help="output folder")
    p.add_argument("--quick", action="store_true", help="fewer samples and tolerances")
    p.add_argument("--coverage", action="store_true",
                   help="reliability only: mean, bias, empirical against reported CoV and "
                        "interval coverage of every method over many seeds (20 by default), "
                        "the helical pair included")
    p.add_argument("--seeds", type=_positive_int, default=None,
                   help="seeds per row (--coverage)")
    p.add_argument("--problems", default=None, type=_names_list, metavar="NAME[,NAME...]",
                   help="comma-separated problems (--coverage): run only their rows and "
                        "replace only those rows of the docs tables")
    p.add_argument("--workers", type=_positive_int, default=1,
                   help="parallel processes over the seeds (--coverage)")
    p.set_defaults(func=_cmd_bench)

    p = sub.add_parser("run", help="analyse a gear stage file: geometry, ISO 6336-1, LTCA, "
                       "run-up; netCDF, CSV and an HTML report",
                       description="The deterministic analysis of a stage (docs/stage.md).")
    p.add_argument("stage", help="stage file (TOML), or the name of a shipped stage "
                   "(GearStage.examples(), e.g. e_axle_27_79)")
    p.add_argument("--out", default=None, type=_folder,
                   help="output folder (default: gearuq_<stage name>)")
    p.add_argument("--n-speeds", type=_int_at_least(2), default=1000,
                   help="speeds of the run-up (at least 2)")
    p.add_argument("--rotor-speeds", type=_rotor_speeds, default=32,
                   help="speeds of the geared rotor's harmonic-balance run-up (0: skip it; "
                        "otherwise at least 2)")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.add_argument("--no-reliability", action="store_true",
                   help="skip the [reliability] step of the file (failure probability, Sobol')")
    p.set_defaults(func=_cmd_run)
    return parser


def _remove_if_made_empty(folder: str | None, made: bool) -> None:
    """Remove an output folder this command made and left empty (a refused option)."""
    if made and folder and os.path.isdir(folder):
        try:
            os.rmdir(folder)  # only if empty
        except OSError:
            pass


#: Commands whose kernels compile from the first call (see :func:`main`).
_MANY_CALLS = (_cmd_demo, _cmd_study, _cmd_bench, _cmd_run)


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``gearuq`` console script."""
    parser = build_parser()
    args = parser.parse_args(argv)
    if not getattr(args, "func", None):
        parser.print_help()
        return 0
    # runs of many model calls, and benchmarks that time warm kernels: compile from the first
    # call instead of running small first calls as plain Python (gearuq._firstcall); through
    # the environment, so that worker processes do the same; restored afterwards
    forced = args.func in _MANY_CALLS and "GEARUQ_KERNELS" not in os.environ
    if forced:
        os.environ["GEARUQ_KERNELS"] = "compiled"
    out = getattr(args, "out", None)
    made_out = bool(out) and not os.path.exists(out)
    try:
        return int(args.func(args) or 0)
    except KeyboardInterrupt:
        if os.environ.get("GEARUQ_TRACEBACK"):
            raise
        print("\ngearuq: interrupted. What was computed is kept: a run that stores its chunks "
              "(gearuq demo, --store, a study's store) takes them up again when the same "
              "command is run again.", file=sys.stderr)
        return 130
    except BrokenPipeError:
        # the reader of the output went away (`gearuq models | head`): nothing left to say;
        # stdout pointed at devnull so that the interpreter's final flush does not fail too
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 1
    except (ValueError, TypeError, OSError, ImportError) as exc:
        # what a user's input or machine can cause (a bad file or value, a full disk, an
        # unreachable scheduler); GEARUQ_TRACEBACK=1 shows where it was raised
        if os.environ.get("GEARUQ_TRACEBACK"):
            raise
        print(f"gearuq: error: {exc}", file=sys.stderr)
        _remove_if_made_empty(out, made_out)
        return 2
    finally:
        if forced:
            os.environ.pop("GEARUQ_KERNELS", None)


if __name__ == "__main__":
    sys.exit(main())
