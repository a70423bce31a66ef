"""fuzzynav: the Pahlavan-Khankalantary fuzzy navigator on a linear-graph Husky model.

The Python interface (:mod:`fuzzynav.api`, documented in docs/api.md)::

    import fuzzynav
    run = fuzzynav.simulate("s1", controller="paper", perception="ideal")
    print(run.outcome, run.metrics["path_length_m"], run.trace["x_m"][-1])

:func:`simulate`, :func:`sweep`, :func:`load_scenario`, :func:`make_controller`,
:func:`read_fis` and :func:`write_fis` are loaded on first use, so that ``import
fuzzynav`` and ``fuzzynav --version`` stay fast.

One import package, laid out in the repository as separate folders and joined here by
setuptools' ``package-dir`` mapping (``pyproject.toml``):

- :mod:`fuzzynav.world`       (``world/``)      the physics: LG Husky model, pymunk arena, sensors;
- :mod:`fuzzynav.controller`  (``controller/``) the fuzzy engine, rule bases, the controllers;
- :mod:`fuzzynav.app`         (``app/``)        command line, viewer, recordings, figures;
- :mod:`fuzzynav.assets`      (``assets/``)     data: robot parameters, rule bases, scenarios.

This folder holds the package's front door (``__init__``, ``__main__``, ``api`` and
the sweeps it re-exports, ``sweeps``).
"""

from __future__ import annotations

import os
from typing import TYPE_CHECKING


def _join_checkout_folders() -> None:
    """Imported straight from a checkout (Python started in its root puts this folder
    first on ``sys.path``, ahead of the install), the subpackages are this folder's
    siblings ``world/``, ``controller/``, ``app/``, ``assets/``: looked for there too,
    as the ``package-dir`` mapping of the install joins them. An installed package has
    them inside and is left alone."""
    here = os.path.dirname(os.path.abspath(__file__))
    root = os.path.dirname(here)
    if os.path.isdir(os.path.join(here, "world")):
        return
    if os.path.isfile(os.path.join(root, "pyproject.toml")) and all(
        os.path.isfile(os.path.join(root, folder, "__init__.py"))
        for folder in ("world", "controller", "app")
    ):
        __path__.append(root)


_join_checkout_folders()
if TYPE_CHECKING:  # what type checkers see behind the lazy __getattr__ below
    from fuzzynav.api import (
        ControllerCheckError,
        DesignSearch,
        Evaluation,
        Outcome,
        Run,
        SweepInterrupted,
        SweepRow,
        check_controller,
        evaluate,
        load_scenario,
        make_controller,
        read_fis,
        register_controller,
        serve,
        simulate,
        summarize,
        sweep,
        tune,
        write_fis,
    )

    __version__: str

__all__ = [
    "__version__",
    "Outcome",
    "SweepRow",
    "Run",
    "simulate",
    "sweep",
    "summarize",
    "SweepInterrupted",
    "evaluate",
    "Evaluation",
    "serve",
    "tune",
    "DesignSearch",
    "load_scenario",
    "make_controller",
    "register_controller",
    "check_controller",
    "ControllerCheckError",
    "read_fis",
    "write_fis",
]

_API = frozenset(__all__) - {"__version__"}


def __getattr__(name: str) -> object:
    # Read on first use: importlib.metadata costs tens of milliseconds at every start of
    # the command line, and a Ctrl-C in them could not be caught yet.
    if name == "__version__":
        from importlib.metadata import PackageNotFoundError, version

        try:
            return version("fuzzynav")
        except PackageNotFoundError:  # imported from a checkout that was never installed
            return "0+unknown"
    if name in _API:
        # numpy, scipy and pymunk load here, not at `import fuzzynav`.
        from fuzzynav import api

        return getattr(api, name)
    raise AttributeError(f"module 'fuzzynav' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))
