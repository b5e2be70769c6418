"""Fast batched adaptive Runge-Kutta integration of many independent ODE samples.

Each sample ``i`` is the initial-value problem ``y' = rhs(t, y, params[i])``,
``y(t0[i]) = y0[i]``, integrated on its own with its own step-size control and written at
the output instants ``t_eval`` by the method's dense output. The outer loop over samples runs
in a compiled numba kernel, optionally in parallel threads over sample blocks (the kernel
releases the GIL); a failing sample never
raises, it records a status code and keeps what it computed.

Methods
-------
``"dopri5"``
    Dormand-Prince 5(4), FSAL, Hairer's 4th-order continuous extension (Hairer, Norsett and
    Wanner, *Solving ODEs I*, II.5 and II.6; code ``DOPRI5``), with Hairer's PI step-size
    controller (beta = 0.04).
``"dop853"``
    Hairer's DOP853: 8th-order solution, 5th/3rd-order combined error estimator, 7th-order
    dense output built from three extra stages only in steps that need it.
``"rk4"``
    The classical 4th-order method, fixed step only (``fixed_step=``); cubic Hermite dense
    output.

How ``rhs`` reaches the compiled kernel
---------------------------------------
The kernel takes ``rhs`` and ``switch`` as numba *first-class function* arguments typed by
the explicit signature ``void(float64, float64[::1], float64[::1], float64[::1])``. Each
kernel variant (method x event treatment) is therefore compiled once for every right-hand
side, on first use, and cached on disk (``cache=True``); a new ``rhs`` only costs the
compilation of ``rhs`` itself, and a call compiles only the variant it uses. Passing a
dispatcher as a plain (specialising) argument was tried first: numba 0.68 keys such
specialisations by the dispatcher object, so every process misses the cache, recompiles and
adds a new cache file. The price of the function pointer is that ``rhs`` is not inlined
into the integrator; docs/ode.md gives the measured cost.

Switching surfaces
------------------
With ``switch`` and ``n_switch > 0`` the kernel watches ``n_switch`` switching functions
``g(t, y, p)``. When a component changes sign within a step (tested at the step end, at the
interpolated quarter points, and at the predicted extremum of g where g comes close to the
surface), the first root is located on the dense-output interpolant by Brent's method and
the step is re-taken so that it ends just past the root (re-located on the re-taken step
until it ends within a tolerance of it). This keeps the order of the method for
piecewise-smooth right-hand sides (dead zones, backlash, clearances). With
``freeze_sides=True`` the rhs can read the side of every surface from ``p`` and evaluate all
stages of a step on one side; the trial step is then smooth, error-tested as it is and
truncated at the root on its own interpolant, which halves the cost per event. See
docs/ode.md for the measured accuracy and the limits (grazing contacts).

Modules
-------
``api`` (:func:`solve_batch`, :class:`ODEResult`, the argument validation), ``kernel`` (the
integration loop, one compiled variant per method and event treatment), ``events``
(switching-surface location), ``stages`` (Runge-Kutta stages, error norms, dense output),
``tableaux`` (coefficients and per-method constants), ``constants`` (status codes).
"""

from .api import DEFAULT_VARIANTS, ODEResult, precompile, solve_batch
from .constants import (
    RTOL_MIN,
    STATUS_MEANINGS,
    STATUS_NONFINITE,
    STATUS_OK,
    STATUS_STEP_LIMIT,
    STATUS_STEP_UNDERFLOW,
)
from .kernel import KERNEL_SIGNATURE, RHS_SIGNATURE, get_kernel
from .tableaux import METHODS

__all__ = [
    "ODEResult",
    "solve_batch",
    "METHODS",
    "RHS_SIGNATURE",
    "KERNEL_SIGNATURE",
    "RTOL_MIN",
    "get_kernel",
    "precompile",
    "DEFAULT_VARIANTS",
    "STATUS_OK",
    "STATUS_STEP_LIMIT",
    "STATUS_STEP_UNDERFLOW",
    "STATUS_NONFINITE",
    "STATUS_MEANINGS",
]
