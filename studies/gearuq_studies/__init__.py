"""Packaged studies, registered under the ``gearuq.studies`` entry-point group.

A study is a function ``run(out, quick=False, **settings) -> int`` that writes netCDF, PNG
and markdown files into ``out`` and prints its summary; the first line of its docstring is
the description ``gearuq studies`` lists, ``quick=True`` a smaller version (fewer samples,
coarser grids). ``gearuq study NAME [--quick]`` runs one, ``gearuq demo`` runs the default,
and ``python -m gearuq_studies.NAME --help`` shows a study's command line with all its
settings. Studies use only the public API (models come from the registry), so they are
worked examples as well.
"""
