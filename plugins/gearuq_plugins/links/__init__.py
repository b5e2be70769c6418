"""``links``: fidelity links between the built-in models (``gearuq.registry.get_link``).

Each module builds one :class:`gearuq.links.FidelityLink` and is registered under the
entry-point group ``gearuq.links`` as ``"HIGH->LOW"``. The links reach the models only through
``gearuq.registry.get_model`` (plugins never import each other); what the maps share with the
models is generic gear mechanics from ``gearuq.gears``. Equations, what each link neglects and
its measured correlation with its high-fidelity model: docs/theory/fidelity_links.md.

- :mod:`.helical_pair`: ``helical_pair -> mesh_oscillator`` (dynamic mesh force).
- :mod:`.geared_rotor`: ``geared_rotor -> mesh_oscillator`` (``dte_rms_max`` over a speed range).
"""
