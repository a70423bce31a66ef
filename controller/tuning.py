"""What a tuner needs from a controller: a small, bounded parameter vector.

A :class:`Tunable` maps a vector of positive widths/offsets (so that ordering
constraints such as ``a <= b <= c`` hold by construction) to a fresh controller, and
writes the shipped rule base(s) for a vector. ``fuzzynav tune`` (``app/experiments/tuning.py``)
runs differential evolution over it. Tunables must be picklable (they are sent to the
worker processes).
"""

from __future__ import annotations

from pathlib import Path
from typing import Protocol, runtime_checkable

import numpy as np

__all__ = ["Tunable", "tunable"]


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
    """The :class:`Tunable` of controller ``name`` (the registry's ``tunable`` entry).

    Parameters
    ----------
    name : str
        A registered controller that declares a tunable.

    Raises
    ------
    ValueError
        Unknown name, or a controller with no tunable (the message lists those with one).
    """
    from fuzzynav.controller.registry import controller_entry, controller_names, import_factory

    spec = controller_entry(name).tunable
    if spec is None:
        raise ValueError(
            f"controller = {name!r}: not tunable (choose from "
            f"{', '.join(controller_names(tunable=True))})"
        )
    return import_factory(spec)()
