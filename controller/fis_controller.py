"""A fuzzy system as a controller for the loop: four inputs in, two wheel voltages out.

The inputs are the paper's ``(d_t, d_o, phi_t, phi_o)`` and the outputs the left and
right wheel voltages; the loop saturates them. Any Mamdani system with 4 inputs and 2
outputs works, so a MATLAB user can drive the robot with a ``.fis`` file of their own.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from fuzzynav.controller.fis import read_fis
from fuzzynav.controller.fuzzy import FuzzySystem
from fuzzynav.controller.rulebase import read_toml

N_INPUTS, N_OUTPUTS = 4, 2


class FisController:
    """Wraps a :class:`~controller.fuzzy.FuzzySystem`; stateless.

    Attributes
    ----------
    fis : FuzzySystem
        The system, exposed for the viewer's teaching panel and the recordings
        (firing strengths, aggregated outputs).
    """

    needs_ranges = False

    def __init__(self, fis: FuzzySystem, name: str | None = None, source: str = "<memory>"):
        if fis.n_inputs != N_INPUTS or fis.n_outputs != N_OUTPUTS:
            raise ValueError(
                f"{source}: fuzzy system {fis.name!r} has {fis.n_inputs} inputs and "
                f"{fis.n_outputs} outputs; the robot needs {N_INPUTS} inputs "
                f"(d_t, d_o, phi_t, phi_o) and {N_OUTPUTS} outputs (left, right voltage)"
            )
        self.fis = fis
        self.name = name or fis.name
        self.source = source

    @classmethod
    def from_fis(cls, path: str | Path) -> FisController:
        return cls(read_fis(path), source=str(path))

    @classmethod
    def from_toml(cls, path: str | Path, name: str | None = None) -> FisController:
        return cls(read_toml(path), name=name, source=str(path))

    def reset(self) -> None:
        """Stateless: nothing to reset."""

    def __call__(self, inputs) -> np.ndarray:
        return self.fis.evaluate_one(np.asarray(inputs, dtype=float))
