"""The controllers fuzzynav offers: each registered once, here, with what it can do.

Every list of controller names (``--controller`` choices, the viewer's dropdown,
``sweep``, ``compare``, ``tune``, ``fis export``, the batch engine) reads this registry;
none is written anywhere else. A controller of your own joins them all with one call::

    from fuzzynav.controller.registry import register_controller
    register_controller("mine", MyController, description="my go-to-goal law")

after which ``fuzzynav.simulate("s1", "mine")``, ``fuzzynav.sweep("mine")`` and the
viewer offer it. A ``"package.module:factory"`` name needs no registration: the factory
is imported where it runs (worker processes and dask workers included).

Factories of the shipped controllers are imported lazily, so that choosing ``p``
never loads the fuzzy engine.
"""

from __future__ import annotations

import functools
import re
from collections.abc import Callable
from dataclasses import dataclass
from importlib import import_module
from pathlib import Path
from typing import TYPE_CHECKING, Any, cast

from fuzzynav.resources import shown

if TYPE_CHECKING:  # numpy is not loaded to list the names
    from fuzzynav.controller.interface import Controller

__all__ = [
    "ControllerEntry",
    "register_controller",
    "unregister_controller",
    "controller_names",
    "controller_entry",
    "describe",
    "make_controller",
    "import_factory",
]

#: A registered name: a letter, then letters, digits, ``_`` or ``-``.
NAME_PATTERN = re.compile(r"[A-Za-z][A-Za-z0-9_-]{0,39}")
#: ``package.module:factory``: a factory found by import, not by registration.
IMPORT_PATTERN = re.compile(r"[A-Za-z_][\w.]*:[A-Za-z_]\w*")


@dataclass(frozen=True)
class ControllerEntry:
    """One registered controller.

    Attributes
    ----------
    name : str
        What ``--controller`` and the API call it.
    description : str
        One line, shown in ``--help`` and the viewer.
    factory : callable or str
        Makes a fresh controller (no arguments, or ``geometry=`` when
        ``geometry_aware``); a ``"module:attribute"`` string is imported on first use.
    geometry_aware : bool
        The factory takes ``geometry`` (``"husky"`` or ``"paper"``) and builds the
        design for that robot.
    batchable : bool
        Its controllers have a batch form (:class:`controller.interface.Batchable`), so
        the lockstep batch engine can drive it.
    tunable : str or None
        ``"module:attribute"`` of a function returning its
        :class:`controller.tuning.Tunable` (``fuzzynav tune``), or None.
    fis_export : bool
        Made of fuzzy systems ``fuzzynav fis export`` can write.
    """

    name: str
    description: str
    factory: Callable[..., Any] | str
    geometry_aware: bool = False
    batchable: bool = False
    tunable: str | None = None
    fis_export: bool = False

    def build(self, geometry: str = "husky") -> Controller:
        """A fresh controller for ``geometry`` (other controllers have one design).

        Parameters
        ----------
        geometry : str
            ``"husky"`` or ``"paper"``; passed to the factory when it is
            geometry-aware.

        Raises
        ------
        ValueError
            The factory cannot be imported, fails, or makes something that is not a
            controller (an object with ``reset()`` that is called on the inputs); the
            message names the controller and its factory.
        """
        factory = _imported(self.factory) if isinstance(self.factory, str) else self.factory
        where = f"controller {self.name!r} (factory {_factory_label(self.factory)})"
        try:
            made = factory(geometry=geometry) if self.geometry_aware else factory()
        except TypeError as exc:
            args = "geometry=" if self.geometry_aware else "no arguments"
            raise ValueError(f"{where}: calling it with {args} failed: {exc}") from exc
        except ValueError as exc:  # a controller function that decides nothing usable
            raise ValueError(f"{where}: {exc}") from exc
        except Exception as exc:  # noqa: BLE001 - a user's factory may raise anything
            raise ValueError(f"{where}: it raised {exc!r}") from exc
        if not (callable(getattr(made, "reset", None)) and callable(made)):
            raise ValueError(
                f"{where}: made {shown(made)}, not a controller (an object with reset() "
                "and __call__(inputs) -> (left, right) voltages)"
            )
        return cast("Controller", made)


_REGISTRY: dict[str, ControllerEntry] = {}


def register_controller(
    name: str,
    factory: Callable[..., Any] | str,
    *,
    description: str,
    geometry_aware: bool = False,
    batchable: bool | None = None,
    tunable: str | None = None,
    fis_export: bool = False,
    replace: bool = False,
) -> ControllerEntry:
    """Offer a controller everywhere fuzzynav offers controllers.

    Parameters
    ----------
    name : str
        Its name (a letter, then up to 39 letters, digits, ``_`` or ``-``).
    factory : callable or str
        Makes a fresh controller (a class or a function of no arguments), or its
        ``"module:attribute"``.
    description : str
        One line saying what it is.
    geometry_aware : bool
        The factory takes ``geometry=``.
    batchable : bool, optional
        Its class declares ``batched`` (the batch engine can drive it). Default:
        detected when ``factory`` is the class (or carries ``batched``); False for a
        ``"module:attribute"`` factory, which is not imported here.
    tunable : str, optional
        ``"module:attribute"`` of its :class:`controller.tuning.Tunable` factory.
    fis_export : bool
        ``fuzzynav fis export`` can write its fuzzy systems.
    replace : bool
        Replace a registration of the same name (else that is refused).

    Returns
    -------
    ControllerEntry
        The registration.

    Raises
    ------
    ValueError
        A malformed name, a name taken (without ``replace``), a factory that is not
        callable, or an empty description.
    """
    if not isinstance(name, str) or not NAME_PATTERN.fullmatch(name):
        raise ValueError(
            f"controller name {name!r}: a letter, then up to 39 letters, digits, _ or -"
        )
    flags = {"geometry_aware": geometry_aware, "fis_export": fis_export, "replace": replace}
    for flag, value in {**flags, "batchable": batchable}.items():
        if not isinstance(value, bool) and not (flag == "batchable" and value is None):
            # "no" is true: batchable="no" sent a controller to the batch engine
            raise TypeError(f"controller {name!r}: {flag} = {value!r}: must be True or False")
    if tunable is not None and not (isinstance(tunable, str) and IMPORT_PATTERN.fullmatch(tunable)):
        raise ValueError(f"controller {name!r}: tunable = {tunable!r}: give 'module:attribute'")
    if name in _REGISTRY and not replace:
        raise ValueError(f"controller name {name!r}: already registered (pass replace=True)")
    if isinstance(factory, str):
        if not IMPORT_PATTERN.fullmatch(factory):
            raise ValueError(f"factory {factory!r}: give a callable or 'module:attribute'")
    elif not callable(factory):
        raise ValueError(f"factory {factory!r}: not callable")
    if not isinstance(description, str) or not description.strip():
        raise ValueError(f"controller {name!r}: give a one-line description")
    if not isinstance(factory, str):
        from fuzzynav.controller.function import function_controller, is_controller_function

        if is_controller_function(factory) and not geometry_aware:
            # a controller written as one function, not a factory: wrapped
            factory = functools.partial(function_controller, factory)
            if batchable is None:
                batchable = _declares_batched(type(factory()))
    if batchable is None:
        batchable = not isinstance(factory, str) and _declares_batched(factory)
    entry = ControllerEntry(
        name, description.strip(), factory, geometry_aware, bool(batchable), tunable, fis_export
    )
    _REGISTRY[name] = entry
    return entry


def unregister_controller(name: str) -> None:
    """Withdraw a registration (a test's, a notebook's).

    Parameters
    ----------
    name : str
        A registered name; an unknown one is refused.
    """
    if name not in _REGISTRY:
        raise ValueError(f"controller {name!r}: not registered")
    del _REGISTRY[name]


def import_factory(spec: str) -> Callable[..., Any]:
    """The attribute ``spec = "module:attribute"`` names, imported.

    Parameters
    ----------
    spec : str
        ``"package.module:attribute"``.

    Raises
    ------
    ValueError
        The module is missing or fails on import, it has no such attribute, or the
        attribute is not callable (the message names ``spec`` and the cause).
    """
    module_name, _, attribute = spec.partition(":")
    try:
        module = import_module(module_name)
    except Exception as exc:  # noqa: BLE001 - a user's module may raise anything on import
        raise ValueError(f"factory {spec!r}: importing {module_name} failed: {exc!r}") from exc
    if not hasattr(module, attribute):
        raise ValueError(f"factory {spec!r}: module {module_name} has no {attribute!r}")
    found = getattr(module, attribute)
    if not callable(found):
        raise ValueError(f"factory {spec!r}: {shown(found)} is not callable")
    return cast("Callable[..., Any]", found)


def _imported(spec: str) -> Callable[..., Any]:
    """The factory ``spec`` names; a controller written as one function, wrapped."""
    from fuzzynav.controller.function import function_controller, is_controller_function

    factory = import_factory(spec)
    if is_controller_function(factory):
        return functools.partial(function_controller, factory)
    return factory


def _factory_label(factory: Callable[..., Any] | str) -> str:
    if isinstance(factory, str):
        return repr(factory)
    if isinstance(factory, functools.partial):
        return _factory_label(factory.args[0])
    return getattr(factory, "__qualname__", None) or type(factory).__name__


def _declares_batched(factory: object) -> bool:
    """A controller class (or a factory carrying the attribute) that declares a batch
    form (:class:`controller.interface.Batchable`)."""
    return callable(getattr(factory, "batched", None))


def controller_names(
    *,
    batchable: bool | None = None,
    tunable: bool | None = None,
    fis_export: bool | None = None,
) -> list[str]:
    """Registered names, in registration order (no registered module is imported).

    Parameters
    ----------
    batchable, tunable, fis_export : bool, optional
        Keep only the controllers that have (True) or lack (False) that capability.

    Returns
    -------
    list of str
        The names.
    """
    wanted = {"batchable": batchable, "tunable": tunable, "fis_export": fis_export}
    names = []
    for entry in _REGISTRY.values():
        has = {
            "batchable": entry.batchable,
            "tunable": entry.tunable is not None,
            "fis_export": entry.fis_export,
        }
        if any(want is not None and has[key] != want for key, want in wanted.items()):
            continue
        names.append(entry.name)  # listed, never imported: one broken module breaks no list
    return names


def controller_entry(name: str) -> ControllerEntry:
    """The registration of ``name``, or of a ``"module:factory"`` name (unregistered).

    Parameters
    ----------
    name : str
        A registered name or ``"module:factory"``.

    Returns
    -------
    ControllerEntry
        Its registration.

    Raises
    ------
    ValueError
        Unknown name (the message lists the known ones).
    """
    if isinstance(name, str) and name in _REGISTRY:
        return _REGISTRY[name]
    if isinstance(name, str) and IMPORT_PATTERN.fullmatch(name):
        # imported now, as it is about to drive: a class's batch form is detected
        factory = _imported(name)
        if isinstance(factory, functools.partial):  # a function: its wrapper's class says
            try:
                factory = type(factory())
            except ValueError as exc:
                raise ValueError(f"controller {name!r}: {exc}") from exc
        batchable = _declares_batched(factory)
        return ControllerEntry(name, f"imported from {name}", name, batchable=batchable)
    raise ValueError(
        f"controller = {name!r}: unknown (choose from {', '.join(controller_names())}, or "
        "give 'module:factory')"
    )


def describe(name: str) -> str:
    """The one-line description of ``name``.

    Parameters
    ----------
    name : str
        A registered name.
    """
    return controller_entry(name).description


def make_controller(
    name: str = "paper", fis_path: str | Path | None = None, geometry: str = "husky"
) -> Controller:
    """A fresh controller by name, or a fuzzy controller read from a MATLAB ``.fis`` file.

    Parameters
    ----------
    name : str
        A registered name or ``"module:factory"``.
    fis_path : str or Path, optional
        A ``.fis`` file: its fuzzy system drives (``name`` is then ignored).
    geometry : str
        Picks the design of a geometry-aware controller (the paper's rule base tuned
        for the Husky's footprint, or fitted in the paper's point-robot geometry).

    Returns
    -------
    Controller
        The controller.

    Raises
    ------
    ValueError
        Unknown name, a factory that cannot be imported or makes no controller, or a
        ``.fis`` file that cannot be used (the message names it).
    """
    if fis_path is not None:
        from fuzzynav.controller.fis_controller import FisController

        return FisController.from_fis(fis_path)
    return controller_entry(name).build(geometry)


# The shipped controllers: registered once, here (the order is the order offered).
register_controller(
    "paper",
    "fuzzynav.controller.paper:paper_controller",
    description="the paper's Table 1: 40 Mamdani rules, our tuned membership functions",
    geometry_aware=True,
    batchable=True,
    tunable="fuzzynav.controller.paper:tunable",
    fis_export=True,
)
register_controller(
    "baseline",
    "fuzzynav.controller.baseline:baseline_controller",
    description="stand-in for the paper's reference [19]: goal-seeking + avoidance blocks",
    batchable=True,
    fis_export=True,
)
register_controller(
    "fuzzynav",
    "fuzzynav.controller.navigator.controller:fuzzynav_controller",
    description="fuzzynav's own navigator: sector avoidance that takes precedence",
    tunable="fuzzynav.controller.navigator.tuning:tunable",
    fis_export=True,
)
register_controller(
    "p",
    "fuzzynav.controller.proportional:ProportionalController",
    description="proportional go-to-goal, obstacle-blind (a teaching contrast)",
    batchable=True,
)
