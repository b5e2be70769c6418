"""Bridges between gearuq and other uncertainty-quantification libraries.

* :mod:`gearuq.interop.openturns` -- a gearuq model and parameter space as an OpenTURNS
  function and joint distribution, and an OpenTURNS distribution as a gearuq
  :class:`~gearuq.space.ParameterSpace` (needs the optional extra
  ``pip install gearuq[openturns]``).

The bridges are imported on demand: ``import gearuq.interop`` never imports OpenTURNS.
"""
