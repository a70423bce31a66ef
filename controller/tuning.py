"""What a tuner needs from a controller: a small, bounded parameter vector.

A :class:`Tunable` maps a vector of positive widths/offsets (so that ordering
constraints such as ``a <= b <= c`` hold by construction) to a fresh controller, and
writes the shipped rule base(s) for a vector. ``fuzzynav tune`` (``app/experiments/tuning.py``)
runs differential evolution over it. Tunables must be picklable (they are sent to the
worker processes).
"""

from __future__ import annotations

from importlib import import_module
from pathlib import Path
from typing import Protocol, runtime_checkable

import numpy as np

__all__ = ["Tunable", "tunable", "TUNABLE_NAMES"]

# name -> module whose ``tunable()`` returns the Tunable (imported lazily)
_MODULES = {"paper": "fuzzynav.controller.paper", "fuzzynav": "fuzzynav.controller.fuzzynav_tuning"}
TUNABLE_NAMES = tuple(_MODULES)


@runtime_checkable
class Tunable(Protocol):
    name: str

    def parameter_names(self) -> list[str]: ...

    def initial_vector(self) -> np.ndarray: ...

    def bounds(self) -> list[tuple[float, float]]: ...

    def build(self, vector):
        """A fresh controller for ``vector``."""

    def save(self, vector, path: Path | None = None) -> list[Path]:
        """Write the rule base(s) for ``vector`` (default: the shipped file); the paths."""


def tunable(name: str) -> Tunable:
    """The :class:`Tunable` of controller ``name`` ("paper" or "fuzzynav").

    Raises
    ------
    ValueError
        Unknown name, or a controller whose module does not exist (yet).
    """
    if name not in _MODULES:
        raise ValueError(f"controller = {name!r}: not tunable (choose from {', '.join(_MODULES)})")
    try:
        module = import_module(_MODULES[name])
    except ModuleNotFoundError as exc:
        if exc.name != _MODULES[name]:
            raise
        raise ValueError(
            f"controller = {name!r}: module {_MODULES[name]} does not exist yet"
        ) from None
    factory = getattr(module, "tunable", None)
    if factory is None:
        raise ValueError(f"controller = {name!r}: {_MODULES[name]} defines no tunable()")
    return factory()
