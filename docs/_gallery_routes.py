"""Per-example set-up of the gallery build: sphinx-gallery calls :func:`before_example`
before each example (``reset_modules`` in conf.py).

From an empty numba cache the examples pay the compiles (docs/benchmarks.md, "first
minutes"). The geared rotor's example makes 12 samples of LTCA calls: compiling the LTCA
from its first call costs less than first running it as plain Python for the ski-rental
allowance and then compiling anyway (:data:`EXAMPLE_ROUTES`). The mesh oscillator's example
keeps the default rule: its few calls run as plain Python in under a second, against about
30 s for its compile.
"""

from __future__ import annotations

import os
from pathlib import Path

#: ``GEARUQ_KERNELS`` while an example runs (unless the user set it for the build).
EXAMPLE_ROUTES = {"plot_geared_rotor_speed_range.py": "compiled"}

_USER_ROUTE = os.environ.get("GEARUQ_KERNELS")


def before_example(gallery_conf: dict, fname: str, when: str = "before") -> None:
    """Set the kernels' route for the example ``fname`` (sphinx-gallery's reset hook)."""
    if _USER_ROUTE is not None:
        return
    route = EXAMPLE_ROUTES.get(Path(fname).name)
    if route:
        os.environ["GEARUQ_KERNELS"] = route
    else:
        os.environ.pop("GEARUQ_KERNELS", None)
