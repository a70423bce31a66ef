"""One fuzzy structure, N rows, N parameter sets: the batch engine's fuzzy evaluation.

A tuning generation runs many candidates at once: the same terms, shapes and rules
(one structure) with different membership parameters per candidate. :class:`BatchFuzzy`
holds K parameter sets of one structure and evaluates N rows, each with the set its
``groups`` entry names; :func:`evaluate_rows` takes an (N, P) matrix of parameter
vectors (:meth:`FuzzySystem.parameter_vector` layout), one per row.

The inference is :meth:`FuzzySystem.evaluate`'s (Mamdani min/max, centroid on the
``n_points`` grid, NaN = nothing sensed, no rule fired = middle of the range):

* with one parameter set the rows go through :meth:`FuzzySystem.evaluate` itself, so
  the numbers are its numbers, bit for bit;
* with several, the input memberships are the families' formulas of
  :mod:`controller.membership` with per-row parameter columns (the same operations as
  with one set, so the same bits), the firing strengths and slot levels are min/max
  (exact), and the centroid's two sums run in grid order as ``evaluate``'s: equal to
  ``evaluate`` row by row, bit for bit (tests/test_batch.py checks it).

Inference choices other than the default (:mod:`controller.inference`: product AND or
implication, sum or probor aggregation, another defuzzification) are supported the cheap
way: each parameter set's rows go through its own :meth:`FuzzySystem.evaluate` (its
plain path), so the numbers are again ``evaluate``'s, bit for bit; only the speed-up of
one pass over all sets is lost. The inference is part of the structure: the sets of one
batch share it.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from fuzzynav.controller.fuzzy import FuzzySystem
from fuzzynav.controller.membership import SHAPES, quiet

__all__ = ["BatchFuzzy", "evaluate_rows", "same_structure"]

# Rows per block of the grid aggregation: its (rows, grid) buffers stay in the cache.
_ROWS_PER_BLOCK = 1024


def _structure(system: FuzzySystem) -> tuple:
    """What must be equal for two systems to share one batch: everything but the
    membership parameters (and the free-text names)."""
    return (
        tuple((v.name, v.range, tuple((t.name, t.shape) for t in v.terms)) for v in system.inputs),
        tuple((v.name, v.range, tuple((t.name, t.shape) for t in v.terms)) for v in system.outputs),
        system.rules,
        system.n_points,
        system.inference,
    )


def same_structure(a: FuzzySystem, b: FuzzySystem) -> bool:
    """Whether ``a`` and ``b`` differ at most in their membership parameters."""
    return _structure(a) == _structure(b)


class BatchFuzzy:
    """K parameter sets of one fuzzy structure, evaluated on N rows at once.

    Parameters
    ----------
    systems : sequence of FuzzySystem
        The parameter sets, all of one structure (same variables, ranges, term names
        and shapes, rules, grid, inference); set ``k`` is ``systems[k]``.

    Raises
    ------
    ValueError
        No system, or systems whose structures differ (the message names the first).
    """

    def __init__(self, systems: Sequence[FuzzySystem]):
        systems = list(systems)
        if not systems:
            raise ValueError("BatchFuzzy needs at least one fuzzy system")
        first = systems[0]
        for k, other in enumerate(systems[1:], start=1):
            if not same_structure(first, other):
                raise ValueError(
                    f"systems[{k}] ({other.name!r}) has another structure than systems[0] "
                    f"({first.name!r}): one batch takes one structure (variables, terms, "
                    "shapes, rules, grid, inference) with per-row parameters"
                )
        self.systems = systems
        self.structure = first
        self.n_sets = len(systems)
        # Per input term: (membership row, input column, the family's formula, its
        # parameters as columns of K values: column p[k] is set k's p-th parameter).
        self._input_terms = []
        for i, variable in enumerate(first.inputs):
            for j, term in enumerate(variable.terms):
                params = np.array([s.inputs[i].terms[j].params for s in systems], dtype=float)
                self._input_terms.append(
                    (first._batch_terms_row(i, j), i, SHAPES[term.shape].formula, params.T.copy())
                )
        # Every set's output terms sampled on the grid once: (K, n_out, kmax, G).
        self._mfg = np.stack([s._mfg for s in systems])
        # the same, as (output, term, grid point, set): a gather by set is one take
        self._mfgT = np.ascontiguousarray(self._mfg.transpose(1, 2, 3, 0))
        self._grid = first._grid
        self._mid = np.array(first._mid)

    def evaluate(self, X, groups=None) -> np.ndarray:
        """Crisp outputs (N, n_outputs) of the rows ``X`` (N, n_inputs).

        Parameters
        ----------
        X : array (N, n_inputs)
            The inputs, one row per sample (NaN = nothing sensed).
        groups : int array (N,), optional
            The parameter set of each row (0 .. K-1); all rows use set 0 if omitted.
        """
        system = self.structure
        X = system._check_X(X)
        n = X.shape[0]
        if groups is None:
            groups = np.zeros(n, dtype=np.intp)
        else:
            groups = np.asarray(groups, dtype=np.intp).reshape(-1)
            if groups.shape != (n,):
                raise ValueError(f"groups has shape {groups.shape}; X has {n} rows")
            if n and (groups.min() < 0 or groups.max() >= self.n_sets):
                raise ValueError(
                    f"groups: every entry must be from 0 to {self.n_sets - 1} "
                    f"(got {groups.min()} .. {groups.max()})"
                )
        if self.n_sets == 1:
            return self.systems[0].evaluate(X)
        if not system.inference.is_default:
            # the plain path of each set on its own rows (module docstring)
            Y = np.empty((n, system.n_outputs))
            for k in np.unique(groups).tolist():
                rows = groups == k
                Y[rows] = self.systems[k].evaluate(X[rows])
            return Y
        Y = np.empty((n, system.n_outputs))
        for b0 in range(0, n, _ROWS_PER_BLOCK):
            Y[b0 : b0 + _ROWS_PER_BLOCK] = self._evaluate_block(
                X[b0 : b0 + _ROWS_PER_BLOCK], groups[b0 : b0 + _ROWS_PER_BLOCK]
            )
        return Y

    def _evaluate_block(self, X: np.ndarray, groups: np.ndarray) -> np.ndarray:
        system = self.structure
        n = X.shape[0]
        rows: list = [None] * system._n_cols
        with quiet():
            for row, i, formula, columns in self._input_terms:
                rows[row] = formula(X[:, i], *(column[groups] for column in columns))
        rows[system._ONE] = np.ones(n)
        F = np.empty((len(system.rules), n))
        for r_i, rr in enumerate(system._rule_rows):
            if len(rr) == 1:
                F[r_i] = rows[rr[0]]
            else:
                np.minimum(rows[rr[0]], rows[rr[1]], out=F[r_i])
                for q in rr[2:]:
                    np.minimum(F[r_i], rows[q], out=F[r_i])
        if system._weighted:
            F *= system._W[:, None]
        kmax = system._kmax
        G = system.n_points
        Y = np.empty((n, system.n_outputs))
        # Laid out as (grid point, row), as FuzzySystem.evaluate: its sums over the grid
        # run in grid order (a reduce over axis 0 of >= 2 columns, a cumsum for one),
        # so each row's centroid is evaluate's to the bit, in a batch of any size.
        aggregate = np.zeros((G, n))
        clipped = np.empty((G, n))
        weighted = np.empty((G, n))
        for o in range(system.n_outputs):
            aggregate.fill(0.0)
            for slot, rule_list in system._slot_rules:
                if slot // kmax != o:
                    continue
                level = F[rule_list[0]].copy()
                for q in rule_list[1:]:
                    np.maximum(level, F[q], out=level)
                # min(level, term on the grid) per row, then max over the terms: the
                # Mamdani aggregate, with each row's own sampled output term.
                np.minimum(self._mfgT[o, slot % kmax][:, groups], level, out=clipped)
                np.maximum(aggregate, clipped, out=aggregate)
            np.multiply(aggregate, system._gridcol[o], out=weighted)
            if n >= 2:
                numerator = np.add.reduce(weighted, axis=0)
                denominator = np.add.reduce(aggregate, axis=0)
            else:
                numerator = np.cumsum(weighted[:, 0])[-1:]
                denominator = np.cumsum(aggregate[:, 0])[-1:]
            y = np.full(n, self._mid[o])
            np.divide(numerator, denominator, out=y, where=denominator > 0.0)
            Y[:, o] = y
        return Y


def evaluate_rows(system: FuzzySystem, X, parameters) -> np.ndarray:
    """Crisp outputs of ``system``'s structure on rows ``X`` (N, n_inputs), row ``i``
    with the membership parameters ``parameters[i]`` (N, P) in
    :meth:`FuzzySystem.parameter_vector` layout. Equal rows share one parameter set."""
    X = system._check_X(X)
    parameters = np.asarray(parameters, dtype=float)
    n_params = system.parameter_vector().size
    if parameters.shape != (X.shape[0], n_params):
        raise ValueError(
            f"parameters has shape {parameters.shape}: need ({X.shape[0]}, {n_params}), "
            "one parameter vector per row of X"
        )
    unique, groups = np.unique(parameters, axis=0, return_inverse=True)
    systems = [system.with_parameter_vector(p) for p in unique]
    return BatchFuzzy(systems).evaluate(X, groups.reshape(-1))
