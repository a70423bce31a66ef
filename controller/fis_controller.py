"""A fuzzy system as a controller for the loop: four inputs in, two wheel voltages out.

The inputs are the paper's ``(d_t, d_o, phi_t, phi_o)`` and the outputs the left and
right wheel voltages; the loop saturates them. Any Mamdani system with 4 inputs and 2
outputs works, so a MATLAB user can drive the robot with a ``.fis`` file of their own.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np

from fuzzynav.controller.batch import NotBatchable, run_groups
from fuzzynav.controller.fis import read_fis
from fuzzynav.controller.fuzzy import FuzzySystem
from fuzzynav.controller.fuzzy_batch import BatchFuzzy
from fuzzynav.controller.rulebase import read_toml

N_INPUTS, N_OUTPUTS = 4, 2
#: The controller's inputs and outputs, in the order the loop passes and takes them.
INPUT_NAMES = ("d_t", "d_o", "phi_t", "phi_o")
OUTPUT_NAMES = ("left", "right")
#: The readings of Table 1's NONE (docs/paper-controller.md). "matlab": MATLAB's rule
#: editor's "none", the input takes no part in the rule (the engine's default).
#: "unsensed": the paper's text, "for more distance, it is 'none'": a rule with NONE for
#: d_o holds only while no obstacle is sensed (d_o NaN), so the goal rules 1-25 are off
#: while one is (``FuzzySystem(unsensed_none=("d_o",))``; a rule base file says it in its
#: [system]).
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
        with a wrong input.
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
        unsensed_none=fis.unsensed_none,
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
        if none_reading not in NONE_READINGS:
            raise ValueError(
                f"{source}: none_reading {none_reading!r}: choose from {', '.join(NONE_READINGS)}"
            )
        if none_reading == "unsensed" and isinstance(fis, FuzzySystem) and not fis.unsensed_none:
            fis = fis.replace(unsensed_none=(INPUT_NAMES[GATED_INPUT],))
        self.source = source
        self._bind(fis, source)
        self.name = name or self.fis.name

    @property
    def fis(self) -> FuzzySystem:
        return self._fis

    @fis.setter
    def fis(self, system: FuzzySystem) -> None:
        # ``c.fis = read_fis(f)`` binds as FisController(read_fis(f)) does (an
        # assigned system bound by position would drive with its inputs renumbered).
        self._bind(system, "controller.fis")

    def _bind(self, fis: FuzzySystem, source: str) -> None:
        """Take ``fis`` as the controller's system: 4 inputs and 2 outputs, bound by name
        when they are the robot's names in another order (:func:`binding`)."""
        if not isinstance(fis, FuzzySystem):
            raise ValueError(f"{source}: {type(fis).__name__} is not a fuzzy system")
        if fis.n_inputs != N_INPUTS or fis.n_outputs != N_OUTPUTS:
            raise ValueError(
                f"{source}: fuzzy system {fis.name!r} has {fis.n_inputs} inputs and "
                f"{fis.n_outputs} outputs; the robot needs {N_INPUTS} inputs "
                f"(d_t, d_o, phi_t, phi_o) and {N_OUTPUTS} outputs (left, right voltage)"
            )
        # A file's Input1 named phi_t is phi_t, wherever it stands: the system
        # is reordered into the loop's order once, so that everything that reads it
        # (the viewer's panel, the recordings' firing strengths) sees the same order.
        inputs = binding([v.name for v in fis.inputs], INPUT_NAMES, "inputs", source)
        outputs = binding([v.name for v in fis.outputs], OUTPUT_NAMES, "outputs", source)
        if inputs is not None or outputs is not None:
            fis = reordered(fis, inputs, outputs)
        sensed = sensed_system(fis)  # may refuse: nothing is changed then
        self.bound_by_name = inputs is not None or outputs is not None
        self._fis = fis
        #: the rules that hold while an obstacle is sensed (all of them under MATLAB's NONE)
        self.sensed_fis = sensed

    @property
    def none_reading(self) -> str:
        """How Table 1's NONE for d_o reads (:data:`NONE_READINGS`): the system's own."""
        return "unsensed" if self._fis.unsensed_none else "matlab"

    @classmethod
    def from_fis(cls, path: str | Path) -> FisController:
        return cls(read_fis(path), source=str(path))

    @classmethod
    def from_toml(cls, path: str | Path, name: str | None = None) -> FisController:
        return cls(read_toml(path), name=name, source=str(path))

    @classmethod
    def batched(cls, controllers, run_sets=None):
        """The batch engine's form of ``controllers`` (one parameter set each; run ``i``
        uses ``controllers[run_sets[i]]``): :class:`FisBatch`."""
        return FisBatch(controllers, run_sets)

    def reset(self) -> None:
        """Stateless: nothing to reset."""

    def __call__(self, inputs) -> np.ndarray:
        return self.fis.evaluate_one(np.asarray(inputs, dtype=float))


def sensed_system(fis: FuzzySystem) -> FuzzySystem:
    """What decides while an obstacle is sensed: ``fis`` itself under MATLAB's NONE;
    under the text's reading, ``fis`` without the rules that have NONE for d_o (while
    none is sensed, d_o is NaN, every rule that uses it is 0 and ``fis`` decides)."""
    if not fis.unsensed_none:
        return fis
    system, _ = fis.gated_system([True] * len(fis.unsensed_none))
    if system is None:
        raise ValueError(f"{fis.name}: no rule uses {', '.join(fis.unsensed_none)}")
    return system


class FisBatch:
    """Mamdani systems (4 inputs -> 2 voltages) of one structure, a set per run."""

    needs_ranges = False

    def __init__(self, controllers: Sequence[FisController], run_sets=None):
        readings = {c.none_reading for c in controllers}
        if len(readings) > 1:
            raise NotBatchable("one batch reads NONE one way: the controllers mix readings")
        # the text's reading of NONE: the obstacle rules alone where d_o is sensed
        self.fuzzy = BatchFuzzy([c.fis.replace(unsensed_none=()) for c in controllers])
        self.sensed = (
            BatchFuzzy([c.sensed_fis for c in controllers]) if readings == {"unsensed"} else None
        )
        self.run_sets = None if run_sets is None else np.asarray(run_sets, dtype=np.intp)

    def decide(self, inputs, runs, ranges_m=None) -> np.ndarray:
        groups = run_groups(runs, self.run_sets)
        if self.sensed is None:
            return self.fuzzy.evaluate(inputs, groups)
        sensed = ~np.isnan(inputs[:, GATED_INPUT])
        out = np.empty((len(inputs), 2))
        for mask, fuzzy in ((sensed, self.sensed), (~sensed, self.fuzzy)):
            if mask.any():
                out[mask] = fuzzy.evaluate(inputs[mask], None if groups is None else groups[mask])
        return out
