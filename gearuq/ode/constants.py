"""Status codes and numerical constants shared by the compiled kernel and the front end."""

from __future__ import annotations

import numpy as np

# Status codes; the same values as gearuq.model (checked by the tests). They are repeated
# here rather than imported so that importing the integrator does not import xarray.
STATUS_OK = 0
STATUS_STEP_LIMIT = 1
STATUS_STEP_UNDERFLOW = 2
STATUS_NONFINITE = 3
STATUS_MEANINGS: dict[int, str] = {
    STATUS_OK: "ok",
    STATUS_STEP_LIMIT: "step_limit_reached",
    STATUS_STEP_UNDERFLOW: "step_size_underflow",
    STATUS_NONFINITE: "non_finite_state",
}

EPS = float(np.finfo(np.float64).eps)
#: Smallest rtol accepted: below this the error estimate is dominated by rounding.
RTOL_MIN = 100.0 * EPS
#: A step below this fraction of |t| counts as a step-size underflow.
HMIN_REL = 1e-14
#: Root of a switching function: bracket width target relative to the step (plus 4 ulp of t).
ROOT_XTOL_REL = 1e-12
