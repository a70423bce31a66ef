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

__all__ = ["__version__"]


def __getattr__(name: str):
    # Read on first use: importlib.metadata costs tens of milliseconds at every start of
    # the command line, and a Ctrl-C in them could not be caught yet (issue 19).
    if name == "__version__":
        from importlib.metadata import PackageNotFoundError, version

        try:
            return version("fuzzynav")
        except PackageNotFoundError:  # imported from a checkout that was never installed
            return "0+unknown"
    raise AttributeError(f"module 'fuzzynav' has no attribute {name!r}")
