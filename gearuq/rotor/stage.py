"""The finite-element geared rotor of a :class:`gearuq.GearStage`.

Each shaft of the stage becomes a :class:`ShaftLine` of Timoshenko elements with nodes at
every section change, at the gear's mid-face and at every bearing, elements no longer than
``max_element_length``; the gear bodies are rigid disks (bore: the shaft section under the
gear, outer diameter ``sqrt((d_f^2 + d_a^2) / 2)`` as in :func:`seed002_rotor`), the end
inertias steel hubs on the shafts' first ends (:func:`shaft_end_hub`), the bearings linear
spring-dampers, and the pair one 12-DOF mesh element with the stage's mesh stiffness.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from gearuq.rotor.assembly import Rotor
from gearuq.rotor.bearing import BearingElement
from gearuq.rotor.disk import DiskElement
from gearuq.rotor.element import Material
from gearuq.rotor.examples import shaft_end_hub
from gearuq.rotor.mesh import HelicalMeshElement
from gearuq.rotor.shaft import ShaftLine

__all__ = ["stage_material", "stage_rotor", "stage_shaft_line"]


def stage_material(stage: Any) -> Material:
    """The stage's material as a rotor :class:`Material` (``G = E / (2 (1 + nu))``)."""
    from gearuq.gears.stage import to_si

    m = stage.material
    E = to_si(m.young_modulus, "1e6")
    return Material(m.name, E=E, G=E / (2.0 * (1.0 + m.poisson_ratio)), rho=m.density)


def stage_shaft_line(shaft: Any, *, max_element_length: float = 0.02, first_node: int = 0,
                     z0: float = 0.0, **kw: Any) -> ShaftLine:
    """A stage :class:`~gearuq.gears.stage.Shaft` as a :class:`ShaftLine` (SI units).

    Nodes at the section ends, the gear and the bearings; each interval split into equal
    elements no longer than ``max_element_length`` [m]; ``z0`` shifts the shaft along the
    global axis.
    """
    from gearuq.gears.stage import to_si

    ends = np.cumsum([0.0] + [s[0] for s in shaft.sections])
    marks = set(np.round(ends, 9)) | {round(shaft.gear_position, 9)} | {
        round(b.position, 9) for b in shaft.bearings}
    marks = np.array(sorted(marks)) * 1e-3
    z = [marks[0]]
    for a, b in zip(marks[:-1], marks[1:], strict=True):
        n = max(1, math.ceil((b - a) / max_element_length - 1e-9))
        z.extend(a + (b - a) * k / n for k in range(1, n + 1))
    z = np.asarray(z)
    mids = 0.5 * (z[:-1] + z[1:]) * 1e3
    sections = [shaft.section_at(m) for m in mids]
    return ShaftLine(tuple(z + z0), tuple(to_si(s[1], "1e-3") for s in sections),
                     tuple(to_si(s[2], "1e-3") for s in sections), first_node=first_node,
                     **kw)


def stage_rotor(stage: Any, mesh_stiffness: float, *, mesh_damping: float = 0.0,
                max_element_length: float = 0.02, bearing_labels: str = "stage",
                bearings: tuple[float, float, float] | None = None,
                bearing_scale: tuple[float, float, float] | None = None,
                end_inertias: tuple[float | None, float | None] | None = None,
                moment_arm: str = "pitch_point") -> Rotor:
    """The stage's geared rotor with mesh stiffness ``mesh_stiffness`` [N/m].

    Shaft 1 (pinion) on the z axis, shaft 2 (wheel) at ``(a, 0)`` turning at ``-z1/z2``,
    its first end on the same side; the gear planes are aligned. Tags: ``pinion``, ``gear``,
    ``input``, ``output`` and the bearings: ``pinion bearing 1``... ``wheel bearing 2``, or
    with ``bearing_labels="numbered"`` ``bearing 1``, ``bearing 2``... (pinion shaft first).
    ``bearings`` = (radial [N/m], axial [N/m], damping [N s/m]) replaces every bearing's
    values; ``bearing_scale`` = (radial, axial, damping) factors multiply each bearing's own
    stage values instead (one random factor on bearings that differ), ``end_inertias`` =
    (pinion shaft, wheel shaft) [kg m^2] (``None``: no hub) the
    stage's end inertias; ``moment_arm`` goes to the mesh element.

    Raises
    ------
    ValueError
        When the stage has no shafts (``[pinion_shaft]`` and ``[wheel_shaft]``), or when
        both ``bearings`` and ``bearing_scale`` are given.
    """
    from gearuq.gears.stage import to_si

    if bearings is not None and bearing_scale is not None:
        raise ValueError("give bearings= (values for every bearing) or bearing_scale= "
                         "(factors on each bearing's own values), not both")

    if stage.pinion_shaft is None or stage.wheel_shaft is None:
        raise ValueError(f"stage {stage.name!r}: the rotor needs [pinion_shaft] and "
                         "[wheel_shaft] (sections, gear_position, bearings)")
    pair = stage.pair
    material = stage_material(stage)
    zg1 = to_si(stage.pinion_shaft.gear_position, "1e-3")
    zg2 = to_si(stage.wheel_shaft.gear_position, "1e-3")
    ratio = -pair.z1 / pair.z2
    s1 = stage_shaft_line(stage.pinion_shaft, max_element_length=max_element_length,
                          material=material, name="pinion shaft")
    s2 = stage_shaft_line(stage.wheel_shaft, max_element_length=max_element_length,
                          first_node=s1.last_node + 1, z0=zg1 - zg2, material=material,
                          axis=(pair.centre_distance, 0.0), spin_ratio=ratio,
                          name="wheel shaft")
    pinion, gear = s1.node_at(zg1), s2.node_at(zg1)
    elements: list[Any] = s1.elements() + s2.elements()
    tags = {"pinion": pinion, "gear": gear, "input": s1.first_node, "output": s2.first_node
            if stage.wheel_shaft.end_inertia_at == "first" else s2.last_node}
    count = 0
    for j, (label, shaft, line, node, df, da, b, spin, shift) in enumerate((
            ("pinion", stage.pinion_shaft, s1, pinion, pair.df1, pair.da1, pair.b1, 1.0, 0.0),
            ("wheel", stage.wheel_shaft, s2, gear, pair.df2, pair.da2, pair.b2, ratio,
             zg1 - zg2))):
        seat = to_si(shaft.section_at(shaft.gear_position)[1], "1e-3")
        body = math.sqrt(0.5 * (df**2 + da**2))
        elements.append(DiskElement.from_geometry(node, b, seat, body, material,
                                                  spin_ratio=spin))
        inertia = shaft.end_inertia if end_inertias is None else (end_inertias[j] or 0.0)
        if inertia > 0:
            first = shaft.end_inertia_at == "first"
            end_d = to_si(shaft.sections[0 if first else -1][1], "1e-3")
            elements.append(shaft_end_hub(line.first_node if first else line.last_node,
                                          inertia, end_d, material,
                                          spin_ratio=spin, name=f"{label}.end_inertia"))
        for i, brg in enumerate(shaft.bearings):
            bnode = line.node_at(to_si(brg.position, "1e-3") + shift)
            kr, ka = to_si(brg.radial_stiffness, "1e6"), to_si(brg.axial_stiffness, "1e6")
            c = brg.damping
            if bearings is not None:
                kr, ka, c = bearings
            elif bearing_scale is not None:
                kr, ka, c = kr * bearing_scale[0], ka * bearing_scale[1], c * bearing_scale[2]
            count += 1
            tag = f"{label} bearing {i + 1}" if bearing_labels == "stage" else f"bearing {count}"
            elements.append(BearingElement(bnode, kr, kr, ka, c, c, c, label=tag))
            tags[tag] = bnode
    elements.append(HelicalMeshElement.from_pair(pair, pinion, gear, stiffness=mesh_stiffness,
                                                 damping=mesh_damping, moment_arm=moment_arm))
    return Rotor(elements, shafts=[s1, s2], name=f"stage {stage.name}", tags=tags)
