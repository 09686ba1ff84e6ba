"""The typed configuration: the models of task-set, scenario and sweep files, and the one
loader that reads, applies overrides and validates them (every error at once).

Layer: above model, analysis, world, sim and control (it builds their runtime objects once
from a valid file), below coupling. The modules:

- `rtsim.config.fields` — numbers with range and unit, choices, names (the metadata);
- `rtsim.config.taskset`, `rtsim.config.scenario`, `rtsim.config.sweep` —
  the models, and the runtime objects built from them;
- `rtsim.config.load` — read → TOML → overrides → validate (``load_taskset``; the
  scenario's ``load_scenario`` is in `rtsim.config.scenario`); `rtsim.config.errors`
  — the one-line messages;
- `rtsim.config.dotted` — dotted paths (``--set``, ``overrides=``, sweep grids);
- `rtsim.config.schema`, `rtsim.config.docs` — JSON Schemas and the ranges page.
"""
