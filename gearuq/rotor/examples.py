"""Ready-made rotors (``*_example()`` factories) for tests, docs and studies."""

from __future__ import annotations

from gearuq.rotor.assembly import Rotor
from gearuq.rotor.bearing import BearingElement
from gearuq.rotor.disk import DiskElement
from gearuq.rotor.element import Material, steel
from gearuq.rotor.shaft import ShaftLine

__all__ = ["friswell_example"]


def friswell_example(n_elements: int = 6, *, bearing_stiffness: float = 1e6,
                     material: Material = steel, **element_options: object) -> Rotor:
    """Friswell et al., Dynamics of Rotating Machines (2010), Example 5.9.1.

    Steel shaft 1.5 m long, 50 mm diameter, ``n_elements`` equal Timoshenko elements; rigid
    disks 70 mm wide with 50 mm bore at 0.5 m (outer diameter 0.28 m) and 1.0 m (0.35 m);
    isotropic bearings of ``bearing_stiffness`` in x and y at both ends, no damping.
    ``n_elements`` must be a multiple of 3 (disks on nodes).
    """
    if n_elements % 3 or n_elements < 3:
        raise ValueError(f"n_elements={n_elements} is outside its valid set: multiples of 3")
    shaft = ShaftLine.from_sections([1.5], [0.05], n_elements, material=material,
                                    name="shaft")
    elements = shaft.elements(**element_options) + [
        DiskElement.from_geometry(shaft.node_at(0.5), 0.07, 0.05, 0.28, material),
        DiskElement.from_geometry(shaft.node_at(1.0), 0.07, 0.05, 0.35, material),
        BearingElement(shaft.node_at(0.0), bearing_stiffness, bearing_stiffness,
                       label="bearing 1"),
        BearingElement(shaft.node_at(1.5), bearing_stiffness, bearing_stiffness,
                       label="bearing 2"),
    ]
    return Rotor(elements, shafts=[shaft], name="Friswell example 5.9.1")
