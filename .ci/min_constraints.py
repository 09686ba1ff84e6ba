"""Print pip constraints pinning every dependency of rtsim (and its test extra) to the minimum
version pyproject.toml declares (``name>=X`` -> ``name==X``), for the minimum-versions CI step."""

import re
import sys
import tomllib
from pathlib import Path

meta = tomllib.loads((Path(__file__).resolve().parents[1] / "pyproject.toml").read_text())
project = meta["project"]
reqs = list(project["dependencies"]) + list(project["optional-dependencies"]["test"])
seen = set()
for req in reqs:
    m = re.fullmatch(r"\s*([A-Za-z0-9_.-]+)(\[[^\]]*\])?\s*>=\s*([^,;\s]+)\s*", req)
    if m is None:
        if not req.startswith("rtsim"):
            print(f"# unpinned: {req}", file=sys.stderr)
        continue
    name = m.group(1).lower()
    if name in ("setuptools", "wheel"):  # build tools (for the wheel test), not what rtsim runs on
        continue
    if name not in seen:
        seen.add(name)
        print(f"{name}=={m.group(3)}")
