"""``mesh_oscillator``: SDOF gear mesh with a general force-deflection function (Eritenel and
Parker (2013)).

``m x'' + c x' + C(x, t) f(x, t) = F(t)`` with the separation function ``C`` (contact loss),
a periodic force-deflection function ``f`` from the LTCA, a table or an analytic form, its
Taylor-Fourier expansion, the method of multiple scales to first and second order (frequency
response, all branches, stability, onset of contact loss, the four response regions) and
numerical frequency sweeps through the shared integrator. Theory and every deviation from
Eritenel and Parker: docs/theory/mesh_oscillator.md.

Modules: :mod:`.forces` (force-deflection functions), :mod:`.expansion` (Eqs. 3-14),
:mod:`.slowflow` and :mod:`.continuation` (multiple scales, compiled), :mod:`.perturbation`
(frequency response), :mod:`.kernels`, :mod:`.sweeps` and :mod:`.timedomain` (numerical
integration), :mod:`.model` and :mod:`.evaluate` (the plugin), :mod:`.bench` (speed against
error), :mod:`.derivation` (symbolic derivation, needs sympy).
"""

from gearuq_plugins.mesh_oscillator.expansion import mean_deflection
from gearuq_plugins.mesh_oscillator.forces import (
    ContactSegment,
    ForceDeflection,
    LoadDeflectionTable,
    Periodic,
    PolynomialForce,
    SegmentForce,
    TableFamily,
)
from gearuq_plugins.mesh_oscillator.model import MeshOscillator

__all__ = [
    "ContactSegment",
    "ForceDeflection",
    "LoadDeflectionTable",
    "MeshOscillator",
    "Periodic",
    "PolynomialForce",
    "SegmentForce",
    "TableFamily",
    "mean_deflection",
]
