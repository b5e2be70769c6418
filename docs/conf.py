"""Sphinx configuration of the gearuq documentation site.

Build: ``python -m sphinx -W --keep-going -b html docs docs/_build/html`` (after
``pip install -e ".[docs]"``). The Markdown pages are read by MyST-Parser, the API reference
is generated from the numpydoc docstrings by autodoc/autosummary, and the gallery scripts in
``docs/gallery/`` are run by sphinx-gallery; a rebuild reruns only the scripts that changed, or
all of them when the library changed (:func:`library_fingerprint`).
"""

from __future__ import annotations

import os
import sys
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
sys.path.insert(0, str(Path(__file__).parent))  # _gallery_routes, sphinx-gallery's reset hook

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
# gallery/ holds the sources sphinx-gallery turns into auto_examples/; _vendor/ the npm MathJax
exclude_patterns = ["_build", "Thumbs.db", ".DS_Store", "gallery", "_vendor"]

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

# MathJax, offline: the site ships its own copy of MathJax 3 (the single-file bundle
# tex-mml-svg.js: SVG output, fonts inside, nothing else fetched), taken from the npm package
# `mathjax` that `npm install --prefix docs/_vendor mathjax@3.2.2` puts in docs/_vendor (.ci/run
# does; docs/dependencies.md says why). Without it the pages fall back to Sphinx's CDN URL and
# need a network to show equations; the build itself never fetches anything.
# GEARUQ_DOCS_MATHJAX overrides both: a directory, a file (MathJax.js of MathJax 2, e.g.
# Debian's libjs-mathjax in /usr/share/javascript/mathjax, or a v3/v4 bundle) or a URL; a
# MathJax 2 entry point gets the TeX configuration MathJax 2 needs.
VENDORED_MATHJAX = Path(__file__).parent / "_vendor/node_modules/mathjax/es5/tex-mml-svg.js"
html_static_path: list[str] = []
_mathjax_local, _mathjax2_local = _local_mathjax(os.environ.get("GEARUQ_DOCS_MATHJAX", ""))
if _mathjax_local:
    mathjax_path = _mathjax_local
elif VENDORED_MATHJAX.is_file():
    # only the one file goes into _static (the npm package holds 24 MB of other components)
    _staged = Path(__file__).parent / "_vendor/static/mathjax"
    _staged.mkdir(parents=True, exist_ok=True)
    if not (_staged / VENDORED_MATHJAX.name).is_file() or (
            _staged / VENDORED_MATHJAX.name).stat().st_size != VENDORED_MATHJAX.stat().st_size:
        import shutil

        shutil.copy2(VENDORED_MATHJAX, _staged / VENDORED_MATHJAX.name)
    html_static_path.append("_vendor/static")
    mathjax_path = f"mathjax/{VENDORED_MATHJAX.name}"  # relative: served from _static
else:
    print("gearuq docs: no vendored MathJax (npm install --prefix docs/_vendor "
          "mathjax@3.2.2): the pages load it from the CDN and need a network for equations")
if _mathjax2_local:
    mathjax2_config = _mathjax2_local


def library_fingerprint() -> str:
    """A digest of what the gallery's outputs depend on besides the scripts themselves.

    The Python sources of gearuq and its plugins (the scripts call no study), and the versions
    of the libraries the scripts call. sphinx-gallery reruns an example only when the script's
    own digest changed (its ``.md5`` beside the output); :func:`_expire_gallery_outputs` makes
    a change of the library rerun every example too.
    """
    import hashlib
    from importlib import import_module
    from importlib.metadata import PackageNotFoundError, version

    digest = hashlib.sha256()
    for package in ("gearuq", "gearuq_plugins"):
        root = Path(import_module(package).__file__).parent
        for path in sorted(root.rglob("*.py")):
            digest.update(str(path.relative_to(root)).encode() + b"\0" + path.read_bytes())
    for dist in ("numpy", "scipy", "numba", "xarray", "matplotlib", "openturns",
                 "sphinx-gallery"):
        try:
            digest.update(f"{dist}=={version(dist)}\n".encode())
        except PackageNotFoundError:
            digest.update(f"{dist} absent\n".encode())
    return digest.hexdigest()


def _expire_gallery_outputs(gallery: Path) -> None:
    """Rerun every gallery example when the library changed since their outputs were made.

    Outputs of a build are kept (a rebuild with neither the scripts nor the library changed
    reruns nothing); the digest of the library they were made with sits beside them, and a
    different one removes the examples' ``.md5`` files, the marks sphinx-gallery keeps them by.
    """
    stamp = gallery / "library.sha256"
    now = library_fingerprint()
    if stamp.is_file() and stamp.read_text().strip() == now:
        return
    for md5 in gallery.glob("*.py.md5"):
        md5.unlink()
    gallery.mkdir(parents=True, exist_ok=True)
    stamp.write_text(now + "\n")


def setup(app: object) -> None:
    """Expire stale gallery outputs before sphinx-gallery looks at them (it listens to the
    same event at the default priority, 500)."""
    app.connect("builder-inited", lambda app: _expire_gallery_outputs(
        Path(app.srcdir) / "auto_examples"), priority=400)

sphinx_gallery_conf = {
    "examples_dirs": "gallery",
    "gallery_dirs": "auto_examples",
    "filename_pattern": r"/plot_",
    "download_all_examples": False,
    "remove_config_comments": True,
    "within_subsection_order": "FileNameSortKey",
    "matplotlib_animations": False,
    "image_scrapers": ("matplotlib",),
    # per example: the kernels' route (docs/_gallery_routes.py)
    "reset_modules": ("matplotlib", "_gallery_routes.before_example"),
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
