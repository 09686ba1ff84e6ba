"""The typed configuration: the models of task-set, scenario and sweep files, and the one
loader that reads, applies overrides and validates them (every error at once).

Layer: above model, analysis, world, sim and control (it builds their runtime objects once
from a valid file), below coupling. The modules:

- :mod:`rtsim.config.fields` — numbers with range and unit, choices, names (the metadata);
- :mod:`rtsim.config.taskset`, :mod:`rtsim.config.scenario`, :mod:`rtsim.config.sweep` —
  the models, and the runtime objects built from them;
- :mod:`rtsim.config.load` — read → TOML → overrides → validate (``load_taskset``; the
  scenario's ``load_scenario`` is in :mod:`rtsim.config.scenario`); :mod:`rtsim.config.errors`
  — the one-line messages;
- :mod:`rtsim.config.dotted` — dotted paths (``--set``, ``overrides=``, sweep grids);
- :mod:`rtsim.config.schema`, :mod:`rtsim.config.docs` — JSON Schemas and the ranges page.
"""
