"""Parameter spaces: named random variables, Gaussian-copula dependence and sampling rules.

A :class:`ParameterSpace` is an ordered set of named univariate marginals (chaospy
distributions) with an optional Gaussian copula (Nataf model). It draws reproducible designs
with the rules ``"random"``, ``"lhs"``, ``"sobol"`` and ``"halton"`` from one integer seed,
converts itself to a chaospy joint distribution and to a SALib problem, and serialises to JSON
so that results carry the exact space they were computed from.

Modules:

* :mod:`~gearuq.space.marginals` -- :class:`Marginal` and the distribution kinds (:data:`KINDS`);
* :mod:`~gearuq.space.copula` -- correlation input, checks, rank/Pearson -> normal-space
  conversion (Nataf);
* :mod:`~gearuq.space.sampling` -- the sampling rules (:data:`RULES`) on the unit hypercube;
* :mod:`~gearuq.space.adapters` -- chaospy and SALib conversions;
* :mod:`~gearuq.space.nominal` -- marginals around a model's nominal values (the model object is
  passed in; the space never looks a model up by name);
* :mod:`~gearuq.space.parameter_space` -- :class:`ParameterSpace`.

The correlation matrix of a space is that of the underlying standard normals; rank
(Spearman, Kendall) or Pearson targets are converted on request (``correlation_type``).
"""

from gearuq import _chaospy  # noqa: F401 - first chaospy import, logging left as it was
from gearuq.space.copula import CORRELATION_TYPES
from gearuq.space.marginals import KINDS, Marginal
from gearuq.space.parameter_space import ParameterSpace
from gearuq.space.sampling import RULES, as_generator

__all__ = ["ParameterSpace", "Marginal", "RULES", "KINDS", "CORRELATION_TYPES", "as_generator"]
