"""Testing aids for plugin authors and engine developers.

* :func:`check_model` — the plugin conformance checker (every plugin's tests call it);
* :mod:`gearuq.testing.problems` — analytic UQ test functions with their exact answers
  (Ishigami, Sobol' G-function, linear and four-branch limit states, ...);
* :mod:`gearuq.testing.reliability_problems` — reliability benchmark problems with reference
  failure probabilities.
"""

from gearuq.testing.conformance import check_model

__all__ = ["check_model"]
