"""The run context every estimator shares: model and space resolution, seeds, provenance and
the routing of model options.

Both estimator wings (the engines: Monte Carlo, polynomial chaos, Sobol', Morris,
multi-fidelity; and the failure package) stand on this module, so neither imports the other
for it. ``rng=None`` means the same everywhere (a fresh seed from OS entropy, recorded so the
run can be repeated), every result carries the same provenance keys, and every estimator
takes its model's options the same way: ``model_options={...}``, with ``**`` keywords only for
the method's own settings (:func:`route_keywords`).
"""

from __future__ import annotations

import json
import warnings
from collections.abc import Collection, Mapping
from datetime import datetime, timezone
from typing import Any

import numpy as np

from gearuq._version import __version__
from gearuq.model import Model, Request
from gearuq.space import ParameterSpace

__all__ = ["resolve_model", "resolve_model_and_space", "resolve_seed", "provenance",
           "check_positive_int", "merge_model_options", "route_keywords", "space_json",
           "setting_text"]

_MAX_SEED = 2**63 - 1


def resolve_seed(rng: Any = None) -> int:
    """Integer seed to use and record for a run.

    Parameters
    ----------
    rng : int, numpy.random.Generator, numpy.random.SeedSequence or None
        An int in ``[0, 2**63 - 1]`` is used as is. ``None`` draws one from fresh OS entropy
        (``SeedSequence``); a Generator or SeedSequence gives one deterministically. Either
        way the recorded seed alone reproduces the design.
    """
    if rng is None:
        return int(np.random.SeedSequence().entropy % _MAX_SEED)
    if isinstance(rng, np.random.Generator):
        return int(rng.integers(0, _MAX_SEED))
    if isinstance(rng, np.random.SeedSequence):
        return int(rng.generate_state(1, np.uint64)[0] % _MAX_SEED)
    if isinstance(rng, (bool, np.bool_)) or not isinstance(rng, (int, np.integer)):
        raise ValueError(f"rng: expected an int seed, a numpy Generator or None, got {rng!r}")
    if not 0 <= rng <= _MAX_SEED:
        raise ValueError(f"rng: seed must lie in [0, 2**63 - 1], got {rng}")
    return int(rng)


def resolve_model(model: Any) -> Model:
    """A model instance from an instance or a registered name."""
    if isinstance(model, str):
        from gearuq.registry import get_model

        model = get_model(model)
    if not isinstance(model, Model):
        raise TypeError(
            f"model: expected a gearuq Model or a registered model name, got "
            f"{type(model).__name__}")
    return model


def resolve_model_and_space(model: Any, space: Any) -> tuple[Model, ParameterSpace]:
    """Resolve a model (instance or registered name) and a space (or a mapping of marginals).

    ``space=None`` takes the model's :meth:`~gearuq.model.Model.default_space`.

    Raises
    ------
    TypeError
        If ``space`` is neither a ParameterSpace nor a mapping.
    ValueError
        If the space has parameters the model does not know (the message lists both sets),
        or no space is given and the model has no default space.
    """
    model = resolve_model(model)
    if space is None:
        space = model.default_space()
        if space is None:
            raise ValueError(f"space: model {model.name!r} has no default space; give one")
    if not isinstance(space, ParameterSpace):
        if isinstance(space, Mapping):
            space = ParameterSpace(space)
        else:
            raise TypeError(f"space: expected a ParameterSpace, got {type(space).__name__}")
    unknown = [k for k in space.names if k not in model.parameter_names]
    if unknown:
        raise ValueError(
            f"space parameter(s) {', '.join(map(repr, unknown))} not in model {model.name!r}; "
            f"model parameters: {', '.join(model.parameter_names)}")
    return model, space


def check_positive_int(name: str, value: Any) -> int:
    """``value`` as a positive int, or a ValueError naming ``name``."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer)):
        raise ValueError(f"{name}: expected a positive integer, got {value!r}")
    if value <= 0:
        raise ValueError(f"{name}: must be positive, got {value}")
    return int(value)


def space_json(space: ParameterSpace) -> str:
    """The space as JSON (its repr when it cannot be serialised)."""
    try:
        return space.to_json()
    except ValueError:
        return repr(space)


def provenance(engine: str, model: Model, request: Request | None, space: ParameterSpace | None,
               seed: int | None, **settings: Any) -> dict[str, Any]:
    """Provenance attributes shared by every engine's result.

    Keys: ``gearuq_version``, ``engine``, ``model``, ``model_version``, ``model_settings``,
    ``model_nominal_overrides`` (JSON, :meth:`~gearuq.model.Model.with_nominal`),
    ``outputs``, ``options`` (JSON), ``space`` (JSON), ``seed``, ``created`` (UTC ISO 8601)
    and the engine's own ``settings`` (each as its own key; dicts as JSON).
    """
    attrs: dict[str, Any] = {
        "gearuq_version": __version__,
        "engine": engine,
        "model": model.name,
        "model_version": str(model.version),
        "model_settings": json.dumps(model.settings(), sort_keys=True, default=repr),
        "model_nominal_overrides": json.dumps(dict(model.nominal_overrides), sort_keys=True),
        "created": datetime.now(timezone.utc).isoformat(timespec="seconds"),
    }
    if request is not None:
        attrs["outputs"] = " ".join(request.outputs)
        attrs["options"] = request.options_json()
    if space is not None:
        attrs["space"] = space_json(space)
    if seed is not None:
        attrs["seed"] = int(seed)
    for k, v in settings.items():
        attrs[k] = json.dumps(v, sort_keys=True, default=setting_text) \
            if isinstance(v, (dict, list)) \
            else ("none" if v is None else v)
    return attrs


def setting_text(value: Any) -> str:
    """A setting JSON cannot hold, as text that is the same in every process: a function by
    its qualified name (its repr holds a memory address), anything else by its repr."""
    if callable(value) and hasattr(value, "__qualname__"):
        return f"{value.__module__}.{value.__qualname__}"
    return repr(value)


def merge_model_options(model_options: Mapping[str, Any] | None, options: Mapping[str, Any],
                        engine: str, *, stacklevel: int = 3) -> dict[str, Any]:
    """Model options of an engine call: ``model_options=`` merged with model options given as
    keywords (the deprecated shape: the keywords warn, naming the new spelling); one name
    given both ways is refused. ``stacklevel`` counts from the engine that calls this
    function (3: its caller's line)."""
    both = sorted(set(model_options or {}) & set(options))
    if both:
        raise ValueError(f"{engine}: model option(s) {both} given both in model_options and as "
                         "keywords; give each once")
    if options:
        _warn_keyword_options(engine, options, stacklevel + 1)
    return {**dict(model_options or {}), **dict(options)}


def _warn_keyword_options(engine: str, options: Mapping[str, Any], stacklevel: int) -> None:
    names = ", ".join(f"{k}=" for k in options)
    spelling = ", ".join(f"{k!r}: {v!r}" for k, v in options.items())
    warnings.warn(f"model options as keywords are deprecated ({engine}: {names}) and will be "
                  f"refused in the next release; write model_options={{{spelling}}}",
                  DeprecationWarning, stacklevel=stacklevel)


def route_keywords(engine: str, model: Model, model_options: Mapping[str, Any] | None,
                   keywords: Mapping[str, Any], method_settings: Collection[str],
                   *, legacy_model_options: bool) -> tuple[dict[str, Any], dict[str, Any]]:
    """Split an estimator's ``**`` keywords into (method settings, model options).

    A keyword named in ``method_settings`` is a setting of the method. Any other keyword that
    the model declares as an option is a model option when ``legacy_model_options`` (the
    deprecated shape, with a DeprecationWarning naming the new spelling) and refused
    otherwise. A name that is both a method setting and a model option is refused when given
    as a keyword alone, since the caller may have meant either: ``model_options=`` holding
    the same name makes the keyword the method's without doubt.

    Raises
    ------
    ValueError
        For a name that is both a method setting and a model option (and absent from
        ``model_options``), a model option given both ways, or a model option given as a
        keyword where keywords are only method settings. The message names the keyword and
        the spelling to use.
    """
    model_options = dict(model_options or {})
    declared = set(model.option_names)
    settings = {k: v for k, v in keywords.items() if k in method_settings}
    ambiguous = sorted(k for k in settings if k in declared and k not in model_options)
    if ambiguous:
        raise ValueError(
            f"{engine}: {', '.join(map(repr, ambiguous))} is both a setting of {engine} and an "
            f"option of model {model.name!r}; as a keyword it is the method's setting: give "
            f"the model's value in model_options={{{ambiguous[0]!r}: ...}} as well to say so")
    rest = {k: v for k, v in keywords.items() if k not in method_settings}
    options = {k: v for k, v in rest.items() if k in declared}
    if options and not legacy_model_options:
        k = next(iter(options))
        raise ValueError(
            f"{engine}: {k!r} is an option of model {model.name!r}, not a setting of {engine}; "
            f"write model_options={{{k!r}: {options[k]!r}}}")
    merged = merge_model_options(model_options, options, engine, stacklevel=4)
    unknown = {k: v for k, v in rest.items() if k not in declared}
    if legacy_model_options:
        # an unknown name stays with the model options, whose validation names the valid set
        merged.update(unknown)
    else:
        settings.update(unknown)  # the method's validation names its valid settings
    return settings, merged
