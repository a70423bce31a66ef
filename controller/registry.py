"""Controllers by name, as the command line and the viewer offer them.

Each factory is imported lazily so that choosing ``p`` never loads the fuzzy engine.
"""

from __future__ import annotations

from importlib import import_module
from pathlib import Path

# name -> (module, factory function, one-line description)
_FACTORIES: dict[str, tuple[str, str, str]] = {
    "paper": (
        "fuzzynav.controller.paper",
        "paper_controller",
        "the paper's Table 1: 40 Mamdani rules, our tuned membership functions",
    ),
    "baseline": (
        "fuzzynav.controller.baseline",
        "baseline_controller",
        "stand-in for the paper's reference [19]: goal-seeking + avoidance blocks",
    ),
    "fuzzynav": (
        "fuzzynav.controller.fuzzynav",
        "fuzzynav_controller",
        "fuzzynav's own navigator: sector avoidance that takes precedence",
    ),
    "p": (
        "fuzzynav.controller.proportional",
        "ProportionalController",
        "proportional go-to-goal, obstacle-blind (a teaching contrast)",
    ),
}


def controller_names() -> list[str]:
    """Names whose module is present (a controller still being written is not offered)."""
    names = []
    for name, (module, _, _) in _FACTORIES.items():
        try:
            import_module(module)
        except ModuleNotFoundError:
            continue
        names.append(name)
    return names


def describe(name: str) -> str:
    return _FACTORIES[name][2]


def make_controller(
    name: str = "paper", fis_path: str | Path | None = None, geometry: str = "husky"
):
    """A fresh controller by name, or a fuzzy controller read from a MATLAB ``.fis`` file.

    ``geometry`` picks the paper controller's rule base: the one tuned for the Husky's
    footprint, or the one fitted to the paper's Table 4 in its point-robot geometry.
    Other controllers have one design for both.

    Raises
    ------
    ValueError
        Unknown name, or a ``.fis`` file that cannot be used (the message names it).
    """
    if fis_path is not None:
        from fuzzynav.controller.fis_controller import FisController

        return FisController.from_fis(fis_path)
    if name not in _FACTORIES:
        raise ValueError(f"controller = {name!r}: unknown (choose from {', '.join(_FACTORIES)})")
    module, factory, _ = _FACTORIES[name]
    if name == "paper":
        return getattr(import_module(module), factory)(geometry=geometry)
    return getattr(import_module(module), factory)()
