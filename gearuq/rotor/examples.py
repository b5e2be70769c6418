"""Ready-made rotors (``*_example()`` factories) for tests, docs and studies."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from gearuq.rotor.assembly import Rotor
from gearuq.rotor.bearing import BearingElement
from gearuq.rotor.disk import DiskElement
from gearuq.rotor.element import Material, check_positive, steel
from gearuq.rotor.mesh import HelicalMeshElement
from gearuq.rotor.shaft import ShaftLine

__all__ = ["friswell_example", "gear_steel", "seed002_rotor", "shaft_end_hub"]


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


#: Through-hardened gear steel (E 206 GPa, nu 0.3 as in the LTCA compliance; rho 7850).
gear_steel = Material("gear steel", E=206e9, G=206e9 / 2.6, rho=7850.0)

#: Yuan et al. (2020), Sec. 2.2: shaft sections (length, outer diameter) [m], shaft 1 left to right.
SEED002_SECTIONS = ((0.100, 0.070), (0.110, 0.090), (0.220, 0.110), (0.110, 0.090),
                    (0.060, 0.070))

#: Node positions [m] of shaft 1 (13 elements; ours, Yuan et al. Fig. 5 is not legible): a 40 mm
#: coupling stub, bearing 1 centred on its 60 mm seat at 0.070, the gear at the middle of the
#: 220 mm seat (0.320), bearing 2 centred on the 60 mm seat at 0.570. Shaft 2 is the mirror
#: image (seed: its section lengths are those of shaft 1 reversed).
SEED002_SHAFT1_NODES = (0.0, 0.040, 0.070, 0.100, 0.155, 0.210, 0.265, 0.320, 0.375, 0.430,
                        0.485, 0.540, 0.570, 0.600)


def _section_diameters(node_z: tuple[float, ...], sections) -> list[float]:
    """Outer diameter of each element from the section table (element midpoints)."""
    ends = np.cumsum([s[0] for s in sections])
    mids = 0.5 * (np.asarray(node_z[:-1]) + np.asarray(node_z[1:]))
    return [sections[int(np.searchsorted(ends, m))][1] for m in mids]


def shaft_end_hub(node: int, inertia: float, bore: float, material: Material = gear_steel,
                  *, width: float = 0.100, spin_ratio: float = 1.0,
                  name: str = "inertia") -> DiskElement:
    """A steel hub of polar inertia ``inertia`` on a shaft end of diameter ``bore``.

    An annulus of width ``width`` (100 mm) whose outer diameter gives ``inertia``:
    ``D = (32 J / (rho pi w) + d^4)^(1/4)``; its mass and diametral inertia follow, so a
    larger drive or load inertia also loads the shaft end laterally, as a real hub does.
    """
    J = check_positive(name, inertia, "kg m^2")
    D = (32.0 * J / (material.rho * math.pi * width) + bore**4) ** 0.25
    return DiskElement.from_geometry(node, width, bore, D, material, spin_ratio=spin_ratio)


def seed002_rotor(
    mesh_stiffness: float,
    *,
    pair: Any = None,
    bearing_radial_stiffness: float = 5.0e8,
    bearing_axial_stiffness: float = 2.0e8,
    bearing_damping: float = 0.0,
    mesh_damping: float = 0.0,
    material: Material = gear_steel,
    moment_arm: str = "pitch_point",
    drive_inertia: float | None = None,
    load_inertia: float | None = None,
) -> Rotor:
    """The helical geared rotor of Yuan, Liu and Liu (2020) (Sec. 2.2, Table 1, Fig. 5).

    Two solid shafts of five sections (diameters 70, 90, 110, 90, 70 mm; lengths
    100/110/220/110/60 mm and the mirror image), 13 Timoshenko elements each, the 30/30 pair
    of Table 1 on rigid gear bodies (width 40 mm, bore = the 110 mm shaft seat, outer
    diameter ``sqrt((d_f^2 + d_a^2)/2)``: the body to the root circle plus half the tooth
    ring), four identical rolling-element bearings, and the 12-DOF mesh. Shaft 2 turns at
    ``-z1/z2`` times shaft 1; the centre line is along +x (pinion at the origin), so ``y`` is
    the tangential direction of the paper's bearing accelerations.

    Parameters
    ----------
    mesh_stiffness : float
        Mean mesh stiffness of the mesh element [N/m] (the linearised mesh; the
        time-varying part is applied by the dynamics).
    pair : HelicalGearPair, optional
        Default: :func:`gearuq.gears.geometry.seed002_pair`.
    bearing_radial_stiffness, bearing_axial_stiffness : float
        Per bearing [N/m] (the paper prints none; see docs/theory/geared_rotor.md).
    bearing_damping : float
        Radial and axial damping per bearing [N s/m].
    mesh_damping : float
        Viscous mesh damping [N s/m] (default 0: modal damping is used instead).
    material : Material
        Shaft and gear-body material.
    moment_arm : {"pitch_point", "base_circle"}
        Mesh element arms (``"base_circle"``: Yuan et al. Eq. 8 as printed).
    drive_inertia, load_inertia : float or None
        Polar inertia [kg m^2] on the free ends of shaft 1 (input) and shaft 2 (output), the
        part of the drive and of the load that turns with the shaft end (a coupling hub:
        :func:`shaft_end_hub`); ``None``: none (the paper's rotor, Fig. 5); else > 0.

    Returns
    -------
    Rotor
        With tags ``input``, ``output``, ``pinion``, ``gear``, ``bearing 1`` .. ``bearing 4``.
    """
    from gearuq.gears.geometry import seed002_pair

    pair = seed002_pair() if pair is None else pair
    check_positive("mesh_stiffness", mesh_stiffness, "N/m", allow_zero=True)
    z1 = SEED002_SHAFT1_NODES
    z2 = tuple(round(z1[-1] - z, 12) for z in reversed(z1))
    ratio = -pair.z1 / pair.z2
    gear_plane = 0.320
    shaft1 = ShaftLine(z1, _section_diameters(z1, SEED002_SECTIONS), material=material,
                       name="shaft 1")
    sections2 = tuple(reversed(SEED002_SECTIONS))
    offset = gear_plane - (z1[-1] - gear_plane)  # aligns the two gear planes
    shaft2 = ShaftLine(tuple(z + offset for z in z2), _section_diameters(z2, sections2),
                       material=material, first_node=shaft1.last_node + 1,
                       axis=(pair.centre_distance, 0.0), spin_ratio=ratio, name="shaft 2")
    pinion, gear = shaft1.node_at(gear_plane), shaft2.node_at(gear_plane)
    body_d = math.sqrt(0.5 * (pair.df1**2 + pair.da1**2)), math.sqrt(
        0.5 * (pair.df2**2 + pair.da2**2))
    seat = 0.110
    disks = [
        DiskElement.from_geometry(pinion, pair.b1, seat, body_d[0], material),
        DiskElement.from_geometry(gear, pair.b2, seat, body_d[1], material, spin_ratio=ratio),
    ]
    end_d = SEED002_SECTIONS[0][1]
    if drive_inertia is not None:
        disks.append(shaft_end_hub(shaft1.first_node, drive_inertia, end_d, material,
                                   name="drive_inertia"))
    if load_inertia is not None:
        disks.append(shaft_end_hub(shaft2.last_node, load_inertia, end_d, material,
                                   spin_ratio=ratio, name="load_inertia"))
    kr, ka, cb = bearing_radial_stiffness, bearing_axial_stiffness, bearing_damping
    check_positive("bearing_radial_stiffness", kr, "N/m")
    check_positive("bearing_axial_stiffness", ka, "N/m")
    bearing_nodes = (shaft1.node_at(0.070), shaft1.node_at(0.570),
                     shaft2.node_at(offset + 0.030), shaft2.node_at(offset + 0.530))
    bearings = [BearingElement(n, kr, kr, ka, cb, cb, cb, label=f"bearing {i + 1}")
                for i, n in enumerate(bearing_nodes)]
    mesh = HelicalMeshElement.from_pair(pair, pinion, gear, stiffness=mesh_stiffness,
                                        damping=mesh_damping, moment_arm=moment_arm)
    tags = {"input": shaft1.first_node, "output": shaft2.last_node, "pinion": pinion,
            "gear": gear} | {b.label: b.node for b in bearings}
    return Rotor(shaft1.elements() + shaft2.elements() + disks + bearings + [mesh],
                 shafts=[shaft1, shaft2], name="Yuan et al.'s helical geared rotor", tags=tags)
