"""Polynomial chaos expansions (PCE): regression, sparse regression (hybrid LAR/OMP), quadrature.

A chaos expansion ``y(x) ~ sum_k c_k psi_k(z(x))`` is written in the *germ* ``z``, the
independent standardised variables behind the parameter space, with ``psi_k`` the orthonormal
polynomials of the germ (Legendre for independent uniforms, probabilists' Hermite otherwise,
through the Nataf map for correlated spaces); see :mod:`~gearuq.engines.pce.basis`.

Modules, in the order data flows:

* :mod:`~gearuq.engines.pce.basis` -- multi-indices, orthonormal polynomials, germ maps;
* :mod:`~gearuq.engines.pce.regression` -- least squares, LOO and corrected LOO errors, the
  incremental hybrid LAR/OMP path;
* :mod:`~gearuq.engines.pce.state` -- the fitting settings (:class:`ChaosSettings`) and the
  fitted state (:class:`ChaosFit`);
* :mod:`~gearuq.engines.pce.fitting` -- training data from a Dataset or arrays, least squares,
  sparse and quadrature fits;
* :mod:`~gearuq.engines.pce.storage` -- ``to_dataset`` / ``from_dataset``;
* :mod:`~gearuq.engines.pce.surrogate` -- :class:`PolynomialChaos` (``fit`` on any labelled
  result, predictions, moments, Sobol' indices, reliability);
* :mod:`~gearuq.engines.pce.pipeline` -- :func:`polynomial_chaos` (design -> evaluate through
  the chunked, storable path -> fit) and :func:`compare_mc_surrogate`.

Methods: ``"regression"`` (ordinary least squares, one QR for all output columns, closed-form
leave-one-out error), ``"sparse"`` (least angle regression or orthogonal matching pursuit
along which every prefix is refitted by least squares and scored by its corrected
leave-one-out error, Blatman and Sudret 2011) and ``"quadrature"`` (spectral projection on a
Gauss tensor or Smolyak grid of the germ). Failed model samples (``status != 0``) are
excluded from the fit and counted in ``n_failed``.
"""

from gearuq.engines.pce.basis import multi_indices
from gearuq.engines.pce.pipeline import (
    chaos_design,
    compare_mc_surrogate,
    polynomial_chaos,
    surrogate_reliability,
)
from gearuq.engines.pce.surrogate import METHODS, ChaosFit, ChaosSettings, PolynomialChaos

__all__ = [
    "PolynomialChaos",
    "ChaosSettings",
    "ChaosFit",
    "polynomial_chaos",
    "chaos_design",
    "multi_indices",
    "surrogate_reliability",
    "compare_mc_surrogate",
    "METHODS",
]
