"""Sphinx configuration of the gearuq documentation site.

Build: ``python -m sphinx -W --keep-going -b html docs docs/_build/html`` (after
``pip install -e ".[docs]"``). The Markdown pages are read by MyST-Parser, the API reference
is generated from the numpydoc docstrings by autodoc/autosummary, and the gallery scripts in
``docs/gallery/`` are run by sphinx-gallery at every build.
"""

from __future__ import annotations

import os
from pathlib import Path

import gearuq


def _local_mathjax(value: str) -> tuple[str | None, dict | None]:
    """``mathjax_path`` and ``mathjax2_config`` for GEARUQ_DOCS_MATHJAX (None, None: unset)."""
    if not value:
        return None, None
    if "://" not in value:
        path = Path(value).expanduser().resolve()
        if path.is_dir():
            names = ("MathJax.js", "tex-mml-chtml.js", "es5/tex-mml-chtml.js")
            found = [path / name for name in names if (path / name).is_file()]
            if not found:
                raise ValueError(f"GEARUQ_DOCS_MATHJAX={value!r}: no MathJax.js or "
                                 "tex-mml-chtml.js in that directory")
            path = found[0]
        elif not path.is_file():
            raise ValueError(f"GEARUQ_DOCS_MATHJAX={value!r}: no such file or directory")
        value = path.as_uri()
    if value.split("?")[0].endswith("/MathJax.js"):  # MathJax 2
        if "?" not in value:
            value += "?config=TeX-AMS-MML_HTMLorMML"
        # only Sphinx's delimiters inside the elements MyST marks as math (MyST marks the
        # rest of each page with the ignore class), as MyST configures MathJax 3/4
        return value, {"tex2jax": {"inlineMath": [["\\(", "\\)"]],
                                   "displayMath": [["\\[", "\\]"]],
                                   "processEscapes": True, "processEnvironments": False,
                                   "processClass": "tex2jax_process|mathjax_process|math"},
                       "TeX": {"extensions": ["AMSmath.js", "AMSsymbols.js"]}}
    return value, None


os.environ.setdefault("MPLBACKEND", "Agg")

project = "gearuq"
author = "gearuq developers"
copyright = "gearuq developers"
release = gearuq.__version__
version = release

extensions = [
    "myst_parser",
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.mathjax",
    "numpydoc",
    "sphinx_gallery.gen_gallery",
]

source_suffix = {".rst": "restructuredtext", ".md": "markdown"}
root_doc = "index"
templates_path = ["_templates"]
# gallery/ holds the sources sphinx-gallery turns into auto_examples/
exclude_patterns = ["_build", "Thumbs.db", ".DS_Store", "gallery"]

# MyST: $...$ / $$...$$ and amsmath environments render as MathJax; headings get anchors so
# links like ``architecture.md#status-codes`` resolve.
myst_enable_extensions = ["dollarmath", "amsmath", "colon_fence", "deflist"]
myst_heading_anchors = 3

# API reference: one page per public name, generated at build time.
autosummary_generate = True
autosummary_imported_members = True
# Docstrings write "std / |mean|" for an absolute value: without these, docutils reads |...| as
# an undefined substitution.
rst_prolog = """
.. |mean| replace:: \\|mean\\|
.. |nominal| replace:: \\|nominal\\|
"""
autodoc_default_options = {"members": True, "show-inheritance": False}
autodoc_typehints = "none"  # numpydoc's Parameters sections already give the types
numpydoc_show_class_members = False
numpydoc_class_members_toctree = False
numpydoc_xref_param_type = False

# MathJax: the pages load it from Sphinx's default CDN URL (nothing is fetched at build time,
# so the build itself works offline). GEARUQ_DOCS_MATHJAX points the pages at a local copy
# instead, for viewing them without a network (e.g. a headless-browser check):
#   GEARUQ_DOCS_MATHJAX=/usr/share/javascript/mathjax   (Debian's libjs-mathjax, MathJax 2)
# A directory, a file (MathJax.js of MathJax 2, or a v3/v4 bundle such as tex-mml-chtml.js)
# or a URL; a MathJax 2 entry point gets the TeX configuration MathJax 2 needs.
_mathjax_local, _mathjax2_local = _local_mathjax(os.environ.get("GEARUQ_DOCS_MATHJAX", ""))
if _mathjax_local:
    mathjax_path = _mathjax_local
if _mathjax2_local:
    mathjax2_config = _mathjax2_local

sphinx_gallery_conf = {
    "examples_dirs": "gallery",
    "gallery_dirs": "auto_examples",
    "filename_pattern": r"/plot_",
    "download_all_examples": False,
    "remove_config_comments": True,
    "within_subsection_order": "FileNameSortKey",
    "matplotlib_animations": False,
    "image_scrapers": ("matplotlib",),
    "reset_modules": ("matplotlib",),
    "show_memory": False,
}

html_theme = "pydata_sphinx_theme"
html_title = f"gearuq {release}"
html_theme_options = {
    "navigation_depth": 2,
    "header_links_before_dropdown": 5,
    "show_toc_level": 2,
    "secondary_sidebar_items": ["page-toc"],
}
html_show_sourcelink = False
