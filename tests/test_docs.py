"""Documentation stays in step with the code: every exported name is documented."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import gearuq

DOCS = Path(__file__).resolve().parents[1] / "docs"


def _gen_api():
    spec = importlib.util.spec_from_file_location("gen_api", DOCS / "gen_api.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_every_exported_name_has_a_docstring():
    gen = _gen_api()
    missing = [n for n in gearuq.__all__ if n != "__version__"
               and not gen.summary(getattr(gearuq, n)).strip()]
    assert not missing, f"exported without a docstring: {missing}"


def test_api_reference_is_up_to_date():
    text = _gen_api().render()
    assert (DOCS / "api.md").read_text() == text, "run `python docs/gen_api.py`"
    for name in gearuq.__all__:
        if name != "__version__":
            assert f"`gearuq.{name}`" in text


def test_every_model_has_a_theory_page():
    for name in gearuq.list_models():
        assert (DOCS / "theory" / f"{name}.md").exists(), f"docs/theory/{name}.md missing"
