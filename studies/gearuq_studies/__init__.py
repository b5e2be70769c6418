"""Packaged studies, registered under the ``gearuq.studies`` entry-point group.

A study is a function ``run(out, **settings) -> int`` that writes netCDF and PNG files into
``out`` and prints its summary; ``gearuq studies`` lists them, ``gearuq study NAME`` runs one
and ``gearuq demo`` runs the default. Studies use only the public API (models come from the
registry), so they are worked examples as well.
"""
