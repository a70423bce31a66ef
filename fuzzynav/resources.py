"""Where fuzzynav's shipped data lies: the ``fuzzynav.assets`` package.

Read through :mod:`importlib.resources`, so the same code finds the files in a checkout
(editable install) and in an installed wheel. Nothing is ever written there: commands
that produce files write where the user says (``--out``) or into the current folder.
"""

from __future__ import annotations

from importlib.resources import files
from pathlib import Path


def assets_dir() -> Path:
    """The folder of the shipped data (``husky.toml``, ``rules/``, ``scenarios/``)."""
    root = files("fuzzynav.assets")
    # A wheel installs unzipped and an editable install points at the checkout, so the
    # traversable is a real folder; say so plainly if someone zipped the package.
    if not isinstance(root, Path):
        raise RuntimeError(
            f"fuzzynav's assets are not a folder on disk ({root!r}); "
            "install fuzzynav unzipped (pip does)"
        )
    return root


def asset_path(*parts: str) -> Path:
    """A shipped file: ``asset_path("rules", "paper.toml")``."""
    return assets_dir().joinpath(*parts)
