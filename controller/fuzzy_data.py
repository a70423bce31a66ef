"""The parts of a fuzzy system: terms, variables, rules, and what they must fit.

:class:`Term` (a membership function by its MATLAB shape name and parameters),
:class:`Variable` (a range and its terms) and :class:`Rule` (term indices of the inputs
and outputs, NOT, AND or OR, and a weight), each checked when made; :func:`_check_structure` checks that
rules fit their variables, :func:`rule_sentence` says a rule in words. The engine that
infers with them is :class:`controller.fuzzy.FuzzySystem`; :class:`Aggregation` is what
its :meth:`~controller.fuzzy.FuzzySystem.aggregated` returns. All are importable from
:mod:`controller.fuzzy` too.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np

from . import membership as mf


@dataclass(frozen=True)
class Term:
    """A linguistic term: name, MATLAB shape name (trimf, trapmf, linsmf, linzmf, gaussmf,
    gauss2mf) and its parameters in MATLAB order."""

    name: str
    shape: str
    params: tuple[float, ...]

    def __post_init__(self):
        if not isinstance(self.name, str) or not self.name:
            raise ValueError(f"term name must be a non-empty string, got {self.name!r}")
        try:
            vals = mf.check_params(self.shape, self.params)
        except ValueError as e:
            raise ValueError(f"term {self.name!r}: {e}") from None
        object.__setattr__(self, "params", vals)

    def __call__(self, x) -> np.ndarray:
        """Membership of x (vectorised)."""
        return mf.SHAPES[self.shape].evaluate(x, self.params)


@dataclass(frozen=True)
class Variable:
    """An input or output variable with its range [lo, hi] and its terms (in order)."""

    name: str
    range: tuple[float, float]
    terms: tuple[Term, ...]
    unit: str = field(default="", compare=False)  # documentation only
    description: str = field(default="", compare=False)  # documentation only

    def __post_init__(self):
        if not isinstance(self.name, str) or not self.name:
            raise ValueError(f"variable name must be a non-empty string, got {self.name!r}")
        try:
            lo, hi = (float(v) for v in self.range)
        except (TypeError, ValueError):
            raise ValueError(
                f"variable {self.name!r}: range must be [lo, hi], got {self.range!r}"
            ) from None
        if not (math.isfinite(lo) and math.isfinite(hi) and lo < hi):
            raise ValueError(
                f"variable {self.name!r}: range needs finite lo < hi, got {[lo, hi]!r}"
            )
        object.__setattr__(self, "range", (lo, hi))
        terms = tuple(self.terms)
        if not terms:
            raise ValueError(f"variable {self.name!r} has no terms")
        for t in terms:
            if not isinstance(t, Term):
                raise ValueError(f"variable {self.name!r}: terms must be Term objects, got {t!r}")
        names = [t.name for t in terms]
        dup = {n for n in names if names.count(n) > 1}
        if dup:
            raise ValueError(f"variable {self.name!r}: duplicate term names {sorted(dup)!r}")
        object.__setattr__(self, "terms", terms)

    @property
    def term_names(self) -> list[str]:
        return [t.name for t in self.terms]

    def term_index(self, name: str) -> int:
        for i, t in enumerate(self.terms):
            if t.name == name:
                return i
        raise KeyError(f"variable {self.name!r} has no term {name!r} (terms: {self.term_names})")


#: How a rule combines its antecedents: MATLAB's ``connection`` 1 (AND) and 2 (OR).
CONNECTIONS = ("and", "or")


def negated(k: int) -> int:
    """The antecedent entry for NOT term ``k``: ``~k`` (= -k - 1, which is also MATLAB's
    1-based negative index of that term)."""
    return ~k


@dataclass(frozen=True)
class Rule:
    """One rule. ``antecedent[i]`` is the index of a term of input i, ``~k`` (= -k - 1)
    for NOT term k (membership 1 - mu), or None (NONE: the input takes no part).
    ``consequent[o]`` is the index of a term of output o, or None (the rule says nothing
    about that output). ``connection`` combines the antecedents: ``"and"`` (the system's
    AND method) or ``"or"`` (its OR method). ``weight`` in [0, 1] multiplies the firing
    strength. Indices are 0-based (a .fis file counts from 1)."""

    antecedent: tuple[int | None, ...]
    consequent: tuple[int | None, ...]
    weight: float = 1.0
    connection: str = "and"

    def __post_init__(self):
        def norm(seq, what, lowest):
            out = []
            for v in seq:
                if v is None:
                    out.append(None)
                elif isinstance(v, (int, np.integer)) and not isinstance(v, bool) and v >= lowest:
                    out.append(int(v))
                else:
                    kinds = "term indices, ~index for NOT," if lowest < 0 else "term indices >= 0"
                    raise ValueError(f"rule {what} entries must be {kinds} or None, got {v!r}")
            return tuple(out)

        object.__setattr__(self, "antecedent", norm(self.antecedent, "antecedent", -(2**62)))
        object.__setattr__(self, "consequent", norm(self.consequent, "consequent", 0))
        w = float(self.weight)
        if not (math.isfinite(w) and 0.0 <= w <= 1.0):
            raise ValueError(f"rule weight must be in [0, 1], got {self.weight!r}")
        object.__setattr__(self, "weight", w)
        if self.connection not in CONNECTIONS:
            raise ValueError(f"rule connection must be 'and' or 'or', got {self.connection!r}")
        if all(a is None for a in self.antecedent):
            raise ValueError("rule has no antecedent (every input is NONE)")
        if all(c is None for c in self.consequent):
            raise ValueError("rule has no consequent (every output is NONE)")


class Aggregation(NamedTuple):
    """What :meth:`FuzzySystem.aggregated` returns (one input vector)."""

    grid: np.ndarray  # (n_outputs, n_points): the output grids
    membership: np.ndarray  # (n_outputs, n_points): the aggregated output membership
    output: np.ndarray  # (n_outputs,): the crisp outputs (= evaluate_one)


def rule_sentence(inputs: Sequence[Variable], outputs: Sequence[Variable], rule: Rule) -> str:
    """A rule in words: 'IF d_t IS VL AND phi_t IS VN THEN left IS L AND right IS VS'
    (OR between the antecedents of an OR rule, 'IS NOT' for a NOT term, ' WEIGHT w' if
    w != 1); the rule-base reader parses the same sentence back."""

    def clause(variables, indices, joint):
        return f" {joint} ".join(
            f"{v.name} IS NOT {v.terms[~k].name}" if k < 0 else f"{v.name} IS {v.terms[k].name}"
            for v, k in zip(variables, indices)
            if k is not None
        )

    condition = clause(inputs, rule.antecedent, rule.connection.upper())
    text = f"IF {condition} THEN {clause(outputs, rule.consequent, 'AND')}"
    if rule.weight != 1.0:
        text += f" WEIGHT {float(rule.weight)!r}"
    return text


def _check_structure(
    inputs: tuple[Variable, ...], outputs: tuple[Variable, ...], rules: tuple[Rule, ...]
) -> None:
    """Refuse a system without inputs, outputs or rules, with duplicate variable names, or
    with a rule that does not fit its variables (ValueError)."""
    if not inputs:
        raise ValueError("a fuzzy system needs at least one input")
    if not outputs:
        raise ValueError("a fuzzy system needs at least one output")
    if not rules:
        raise ValueError("a fuzzy system needs at least one rule")
    for v in inputs + outputs:
        if not isinstance(v, Variable):
            raise ValueError(f"inputs and outputs must be Variable objects, got {v!r}")
    names = [v.name for v in inputs + outputs]
    dup = {n for n in names if names.count(n) > 1}
    if dup:
        raise ValueError(f"duplicate variable names {sorted(dup)!r}")
    for r_i, r in enumerate(rules):
        if not isinstance(r, Rule):
            raise ValueError(f"rule {r_i + 1}: not a Rule object: {r!r}")
        if len(r.antecedent) != len(inputs):
            raise ValueError(
                f"rule {r_i + 1}: antecedent has {len(r.antecedent)} entries, "
                f"the system has {len(inputs)} inputs"
            )
        if len(r.consequent) != len(outputs):
            raise ValueError(
                f"rule {r_i + 1}: consequent has {len(r.consequent)} entries, "
                f"the system has {len(outputs)} outputs"
            )
        for var, idx in zip(inputs + outputs, r.antecedent + r.consequent):
            if idx is not None and (idx >= len(var.terms) or ~idx >= len(var.terms)):
                raise ValueError(
                    f"rule {r_i + 1}: term index {idx} out of range for "
                    f"{var.name!r} ({len(var.terms)} terms)"
                )
