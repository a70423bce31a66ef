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
#: The controller's inputs and outputs, in the order the loop passes and takes them.
INPUT_NAMES = ("d_t", "d_o", "phi_t", "phi_o")
OUTPUT_NAMES = ("left", "right")
#: The readings of Table 1's NONE (issue 35). "matlab": MATLAB's rule editor's "none",
#: the input takes no part in the rule (the engine's own semantics). "unsensed": the
#: paper's text, "for more distance, it is 'none'": a rule with NONE for d_o holds only
#: while no obstacle is sensed (d_o NaN), so the goal rules 1-25 are off while one is.
NONE_READINGS = ("matlab", "unsensed")
GATED_INPUT = INPUT_NAMES.index("d_o")


def binding(names, expected, what: str, source: str) -> tuple[int, ...] | None:
    """How a system's variables (``names``) bind to the controller's (``expected``):
    None when by position (in order, or names that are none of the expected ones,
    e.g. MATLAB's ``input1``); the index of each expected variable among ``names``
    when those are exactly the expected names in another order (bound by name).

    Raises
    ------
    ValueError
        Some of the names are the controller's but not all of them, or one twice: the
        file cannot be bound either way, and binding by position would drive the robot
        with a wrong input (issue 26).
    """
    names = tuple(names)
    if names == tuple(expected):
        return None
    known = [n for n in names if n in expected]
    if not known:
        return None
    if sorted(names) == sorted(expected):
        return tuple(names.index(n) for n in expected)
    raise ValueError(
        f"{source}: {what} named {', '.join(map(repr, names))}: some are the robot's "
        f"({', '.join(expected)}) and some are not (or one is there twice), so they can be "
        f"bound neither by name nor by position; name them {', '.join(expected)} (in any "
        "order), or none of them so"
    )


def reordered(fis: FuzzySystem, inputs=None, outputs=None) -> FuzzySystem:
    """The same system with its inputs (outputs) in the order ``inputs`` (``outputs``)
    gives: new variable k is old variable ``inputs[k]``; each rule's terms follow."""
    import dataclasses

    inputs = tuple(range(fis.n_inputs)) if inputs is None else tuple(inputs)
    outputs = tuple(range(fis.n_outputs)) if outputs is None else tuple(outputs)
    rules = [
        dataclasses.replace(
            rule,
            antecedent=tuple(rule.antecedent[k] for k in inputs),
            consequent=tuple(rule.consequent[k] for k in outputs),
        )
        for rule in fis.rules
    ]
    return FuzzySystem(
        [fis.inputs[k] for k in inputs],
        [fis.outputs[k] for k in outputs],
        rules,
        name=fis.name,
        description=fis.description,
        n_points=fis.n_points,
        inference=fis.inference,
    )


class FisController:
    """Wraps a :class:`~controller.fuzzy.FuzzySystem`; stateless.

    Attributes
    ----------
    fis : FuzzySystem
        The system, exposed for the viewer's teaching panel and the recordings
        (firing strengths, aggregated outputs).
    """

    needs_ranges = False

    def __init__(
        self,
        fis: FuzzySystem,
        name: str | None = None,
        source: str = "<memory>",
        none_reading: str = "matlab",
    ):
        if fis.n_inputs != N_INPUTS or fis.n_outputs != N_OUTPUTS:
            raise ValueError(
                f"{source}: fuzzy system {fis.name!r} has {fis.n_inputs} inputs and "
                f"{fis.n_outputs} outputs; the robot needs {N_INPUTS} inputs "
                f"(d_t, d_o, phi_t, phi_o) and {N_OUTPUTS} outputs (left, right voltage)"
            )
        # A file's Input1 named phi_t is phi_t, wherever it stands (issue 26): the system
        # is reordered into the loop's order once, so that everything that reads it
        # (the viewer's panel, the recordings' firing strengths) sees the same order.
        inputs = binding([v.name for v in fis.inputs], INPUT_NAMES, "inputs", source)
        outputs = binding([v.name for v in fis.outputs], OUTPUT_NAMES, "outputs", source)
        self.bound_by_name = inputs is not None or outputs is not None
        if self.bound_by_name:
            fis = reordered(fis, inputs, outputs)
        self.fis = fis
        self.name = name or fis.name
        self.source = source
        if none_reading not in NONE_READINGS:
            raise ValueError(
                f"{source}: none_reading {none_reading!r}: choose from {', '.join(NONE_READINGS)}"
            )
        #: how Table 1's NONE for d_o reads (:data:`NONE_READINGS`)
        self.none_reading = none_reading
        #: with the "unsensed" reading, the rules that hold while an obstacle is sensed
        self.sensed_fis = sensed_system(fis) if none_reading == "unsensed" else fis

    @classmethod
    def from_fis(cls, path: str | Path) -> FisController:
        return cls(read_fis(path), source=str(path))

    @classmethod
    def from_toml(cls, path: str | Path, name: str | None = None) -> FisController:
        return cls(read_toml(path), name=name, source=str(path))

    def reset(self) -> None:
        """Stateless: nothing to reset."""

    def system_for(self, inputs) -> FuzzySystem:
        """The system that decides at ``inputs``: with the "unsensed" reading of NONE,
        the obstacle rules alone while d_o is sensed."""
        return self.fis if np.isnan(inputs[GATED_INPUT]) else self.sensed_fis

    def __call__(self, inputs) -> np.ndarray:
        x = np.asarray(inputs, dtype=float)
        return self.system_for(x).evaluate_one(x)


def sensed_system(fis: FuzzySystem) -> FuzzySystem:
    """``fis`` without the rules that have NONE for d_o: what decides while an obstacle is
    sensed under the text's reading of NONE. (While none is sensed, d_o is NaN, every rule
    that uses it is 0 and the whole system gives the same answer.)"""
    rules = [r for r in fis.rules if r.antecedent[GATED_INPUT] is not None]
    if not rules:
        raise ValueError(f"{fis.name}: no rule uses d_o, so NONE cannot gate anything")
    return fis.with_rules(rules)
