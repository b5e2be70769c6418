"""Shared gear mechanics used by the plugins (plugins never import each other).

- :mod:`gearuq.gears.geometry`: involute helical pair geometry, contact ratios
- :mod:`gearuq.gears.iso6336`: ISO 6336-1 method B tooth stiffness
- :mod:`gearuq.gears.contact`: lines of contact in the plane of action
- :mod:`gearuq.gears.compliance`: tooth compliance (potential energy + fillet foundation,
  face-width coupling) and Hertzian line contact
- :mod:`gearuq.gears.deviations`: pitch deviations, reliefs, crowning as initial clearances
- :mod:`gearuq.gears.ltca`: loaded tooth contact analysis over the long period (STE, LPMS, CMS)

Submodules are imported on use so that ``import gearuq`` stays light.
"""
