"""Load a script or an example of the repository as a module (they are not in the
package): ``load_file(ROOT / "scripts" / "paper_search.py")``."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path
from types import ModuleType


def load_file(path: Path, name: str | None = None) -> ModuleType:
    """The module at ``path``, under ``name`` (its stem by default). Its folder is on
    ``sys.path`` while it loads, so a script that imports the one beside it loads too."""
    folder = str(path.parent)
    sys.path.insert(0, folder)
    try:
        spec = importlib.util.spec_from_file_location(name or path.stem, path)
        module = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(module)
    finally:
        sys.path.remove(folder)
    return module
