"""The typed configuration: the models of task-set, scenario and sweep files, and the one
loader that reads, applies overrides and validates them (every error at once).

Layer: above model, analysis, world, sim and control (it builds their runtime objects once
from a valid file), below coupling. The modules:

- `rtsim.config.fields` — numbers with range and unit, choices, names (the metadata);
- `rtsim.config.taskset`, `rtsim.config.scenario`, `rtsim.config.sweep` —
  the models, the runtime objects built from them, and the loaders (``load_taskset``,
  ``load_scenario``; a sweep file is read here, `rtsim.config.sweep.read_sweep`, and its
  names get their meaning from the registered sweep kinds above this layer:
  ``rtsim.sweep.load_sweep``);
- `rtsim.config.load` — TOML → overrides → validate, the steps every loader shares;
  `rtsim.config.errors` — the one-line messages;
- `rtsim.config.dotted` — dotted paths (``--set``, ``overrides=``, sweep grids);
- `rtsim.config.schema`, `rtsim.config.docs` — JSON Schemas and the ranges page.
"""
