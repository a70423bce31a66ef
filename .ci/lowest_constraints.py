"""Print a pip constraints file pinning every runtime dependency at its declared lower
bound (``numpy>=1.26,<3`` -> ``numpy==1.26.0``), read from pyproject.toml, so that the
lowest-versions job tests exactly what the package claims to support."""

import re
import sys
import tomllib
from pathlib import Path

pyproject = tomllib.loads((Path(__file__).resolve().parents[1] / "pyproject.toml").read_text())
for requirement in pyproject["project"]["dependencies"]:
    match = re.fullmatch(r"\s*([A-Za-z0-9_.-]+)\s*>=\s*([0-9.]+)\s*(,.*)?", requirement)
    if not match:
        sys.exit(f"pyproject.toml: dependency {requirement!r} has no '>=' lower bound")
    name, version = match.group(1), match.group(2)
    parts = version.split(".")
    while len(parts) < 3:
        parts.append("0")
    print(f"{name}=={'.'.join(parts)}")
