"""Sphinx configuration of the gearuq documentation site.

Build: ``python -m sphinx -W --keep-going -b html docs docs/_build/html`` (after
``pip install -e ".[docs]"``). The Markdown pages are read by MyST-Parser, the API reference
is generated from the numpydoc docstrings by autodoc/autosummary, and the gallery scripts in
``docs/gallery/`` are run by sphinx-gallery at every build.
"""

from __future__ import annotations

import os

import gearuq

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

# MathJax is loaded from its CDN by default; GEARUQ_DOCS_MATHJAX points the pages at a local
# copy instead (for building and viewing offline).
if os.environ.get("GEARUQ_DOCS_MATHJAX"):
    mathjax_path = os.environ["GEARUQ_DOCS_MATHJAX"]

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
