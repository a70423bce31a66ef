"""The Mamdani inference choices, with the MATLAB Fuzzy Logic Toolbox's names and meanings.

A :class:`~controller.fuzzy.FuzzySystem` infers with one :class:`Inference`:

* ``and_method``: how a rule combines its antecedents: ``min`` or ``prod`` (the product,
  in input order); an input the rule does not use takes no part;
* ``or_method``: how an OR rule (``Rule(connection="or")``, a .fis rule's connection 2)
  combines its antecedents: ``max`` or ``probor`` (``a + b - a*b``, in input order);
* ``imp_method`` (implication): the rule's output set is ``min(w, MF)`` (clipped at the
  weighted firing strength ``w``) or ``w * MF`` (scaled);
* ``agg_method`` (aggregation over the rules, in rule order): ``max``, ``sum`` (not
  clipped to 1, as in MATLAB) or ``probor`` (``a + b - a*b``, folded rule by rule);
* ``defuzz_method`` on the output's evenly spaced grid (MATLAB's ``evalfis`` works on
  that discretised universe too, 101 points by default):

  - ``centroid``: ``sum(g * mu) / sum(mu)``;
  - ``bisector``: the first grid point at which the running sum of ``mu`` (grid order)
    reaches half the total: a grid point, not an interpolated one;
  - ``mom``: the mean of the grid points where ``mu`` is at its maximum;
  - ``som`` / ``lom``: of the grid points where ``mu`` is at its maximum, the one
    smallest / largest **in magnitude** (distance to 0; the first of equals), as MATLAB
    defines them: on -10..10 with a plateau from -8 to -2, SOM is -2 and LOM is -8
    (scikit-fuzzy's som/lom take the smallest / largest value instead: -8 and -2).

When the aggregate is zero on the whole grid (no rule fired for that output, or the
fired terms vanish on every grid point), every method gives the middle of the range, as
MATLAB's ``evalfis`` does.

The defaults are MATLAB's defaults for a Mamdani system: min, max, min, max, centroid.
"""

from __future__ import annotations

from dataclasses import dataclass, fields

import numpy as np

__all__ = ["Inference", "CHOICES", "FIS_KEYS", "TOML_KEYS", "DEFAULT", "aggregate", "defuzzify"]

#: The allowed values of each choice, the default first.
CHOICES: dict[str, tuple[str, ...]] = {
    "and_method": ("min", "prod"),
    "or_method": ("max", "probor"),
    "imp_method": ("min", "prod"),
    "agg_method": ("max", "sum", "probor"),
    "defuzz_method": ("centroid", "bisector", "mom", "som", "lom"),
}
#: Each choice's key in a .fis file's [System] section.
FIS_KEYS = {
    "and_method": "AndMethod",
    "or_method": "OrMethod",
    "imp_method": "ImpMethod",
    "agg_method": "AggMethod",
    "defuzz_method": "DefuzzMethod",
}
#: Each choice's key in a TOML rule base's [system] table.
TOML_KEYS = {
    "and_method": "and",
    "or_method": "or",
    "imp_method": "implication",
    "agg_method": "aggregation",
    "defuzz_method": "defuzzification",
}


@dataclass(frozen=True)
class Inference:
    """The five choices (module docstring); the defaults are MATLAB's."""

    and_method: str = "min"
    or_method: str = "max"
    imp_method: str = "min"
    agg_method: str = "max"
    defuzz_method: str = "centroid"

    def __post_init__(self):
        for f in fields(self):
            value = getattr(self, f.name)
            allowed = CHOICES[f.name]
            if value not in allowed:
                raise ValueError(
                    f"{f.name} = {value!r}: must be one of {', '.join(map(repr, allowed))}"
                )

    @property
    def is_default(self) -> bool:
        """Whether inference takes the engine's fast path: MATLAB's default min AND, min
        implication, max aggregation and centroid (any OR method: it only changes how
        OR rules fire)."""
        return (self.and_method, self.imp_method, self.agg_method, self.defuzz_method) == (
            "min",
            "min",
            "max",
            "centroid",
        )

    def as_dict(self) -> dict[str, str]:
        return {f.name: getattr(self, f.name) for f in fields(self)}

    def replace(self, **changes) -> Inference:
        unknown = sorted(set(changes) - set(CHOICES))
        if unknown:
            raise ValueError(f"unknown inference choices {unknown} (known: {list(CHOICES)})")
        return Inference(**{**self.as_dict(), **changes})


DEFAULT = Inference()


def aggregate(inference: Inference, terms: np.ndarray, levels: np.ndarray) -> np.ndarray:
    """One output's aggregate (grid point, sample) from the rules that conclude on it:
    ``terms``, their consequent terms on the output's grid (rule, grid point, 1), and
    ``levels``, their weighted firing strengths (rule, sample); the implication, then the
    aggregation folded over the rules in rule order (MATLAB's order)."""
    imp = np.minimum if inference.imp_method == "min" else np.multiply
    implied = imp(terms, levels[:, None, :])  # (rule, grid point, sample)
    method = inference.agg_method
    if method == "max":
        return np.maximum.reduce(implied, axis=0)
    if method == "sum":  # a reduce over the first axis adds the rules one by one
        return np.add.reduce(implied, axis=0)
    agg = implied[0].copy()  # probor: a + b - a * b, rule by rule
    for nxt in implied[1:]:
        agg = (agg + nxt) - agg * nxt
    return agg


def _grid_sum(a: np.ndarray) -> np.ndarray:
    """Sums over axis 0 (the grid) in grid order, whatever the number of columns (a
    cumulative sum is sequential; a reduce over a single column would be pairwise)."""
    return np.cumsum(a, axis=0)[-1]


def defuzzify(method: str, grid: np.ndarray, agg: np.ndarray, mid: float) -> np.ndarray:
    """Crisp values of the aggregates ``agg`` (grid point, sample) on ``grid`` (G,):
    (n,) values; ``mid`` where an aggregate is zero everywhere (module docstring)."""
    total = _grid_sum(agg)
    fired = total > 0.0
    out = np.full(agg.shape[1], mid)
    if method == "centroid":
        num = _grid_sum(agg * grid[:, None])
        np.divide(num, total, out=out, where=fired)
        return out
    if method == "bisector":
        reached = np.cumsum(agg, axis=0) >= 0.5 * total
        value = grid[np.argmax(reached, axis=0)]
    else:
        at_max = agg == agg.max(axis=0)
        if method == "mom":
            value = _grid_sum(np.where(at_max, grid[:, None], 0.0)) / at_max.sum(axis=0)
        elif method == "som":
            value = grid[np.argmin(np.where(at_max, np.abs(grid)[:, None], np.inf), axis=0)]
        elif method == "lom":
            value = grid[np.argmax(np.where(at_max, np.abs(grid)[:, None], -1.0), axis=0)]
        else:
            raise ValueError(f"unknown defuzzification method {method!r}")
    np.copyto(out, value, where=fired)
    return out
