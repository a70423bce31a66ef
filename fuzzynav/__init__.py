"""fuzzynav: the Pahlavan-Khankalantary fuzzy navigator on a linear-graph Husky model.

One import package, laid out in the repository as separate folders and joined here by
setuptools' ``package-dir`` mapping (``pyproject.toml``):

- :mod:`fuzzynav.world`       (``world/``)      the physics: LG Husky model, pymunk arena, sensors;
- :mod:`fuzzynav.controller`  (``controller/``) the fuzzy engine, rule bases, the controllers;
- :mod:`fuzzynav.app`         (``app/``)        command line, viewer, recordings, figures;
- :mod:`fuzzynav.assets`      (``assets/``)     data: robot parameters, rule bases, scenarios.

This folder holds only the package's front door (``__init__``, ``__main__``).
"""

from __future__ import annotations

from importlib.metadata import PackageNotFoundError, version

try:
    __version__ = version("fuzzynav")
except PackageNotFoundError:  # imported from a checkout that was never installed
    __version__ = "0+unknown"

__all__ = ["__version__"]
