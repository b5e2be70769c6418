"""The run context's former home, kept importable: every name now lives in :mod:`gearuq.runs`,
the floor below both estimator wings (the engines and the failure package)."""

from gearuq.runs import (
    check_positive_int,
    merge_model_options,
    provenance,
    resolve_model,
    resolve_model_and_space,
    resolve_seed,
    space_json,
)

__all__ = ["resolve_model", "resolve_model_and_space", "resolve_seed", "provenance",
           "check_positive_int", "merge_model_options", "space_json"]
