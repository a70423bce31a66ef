"""A small, fast, vectorised Mamdani fuzzy inference engine (MATLAB-compatible semantics).

:class:`FuzzySystem` holds the inputs, outputs and rules (:class:`Term`,
:class:`Variable`, :class:`Rule` and :func:`rule_sentence` are
:mod:`controller.fuzzy_data`'s, imported here). ``evaluate_one(x)`` infers one row (the
control loop), ``evaluate(X)`` many; the two agree to the last bit. The inference is
MATLAB's default Mamdani: AND min (an OR rule, MATLAB's connection 2, the OR max; a NOT
term, MATLAB's negative index, ``1 - mu``), the rule weight times the firing strength,
implication min, aggregation max, centroid over ``n_points`` (101) grid points of the
output range; every other choice MATLAB offers is :mod:`controller.inference`'s, picked
with ``FuzzySystem(..., inference=Inference(...))``. A NaN input is nothing sensed; an
output no rule fired is the middle of its range; inputs are not clipped to their ranges
(all of it, and how it is computed, in docs/api.md, "The engine's conventions").
"""

from __future__ import annotations

import dataclasses
import threading
from collections.abc import Sequence
from typing import Any

import numpy as np

from . import membership as mf
from .fuzzy_data import Aggregation, Rule, Term, Variable, _check_structure, rule_sentence
from .inference import DEFAULT as DEFAULT_INFERENCE
from .inference import Inference, aggregate, defuzzify

__all__ = [
    "Term",
    "Variable",
    "Rule",
    "FuzzySystem",
    "Aggregation",
    "Inference",
    "DEFAULT_POINTS",
]

DEFAULT_POINTS = 101

_BLOCK = 16384  # rows per block of memberships / firing strengths in evaluate()
_CHUNK = 512  # rows per block of the grid aggregation (its buffers stay in cache)
# Up to this many rows, evaluate() runs the single-row path per row: the batch path's
# fixed cost is then more than the rows cost one by one; the crossover is measured in
# bench/bench_fuzzy.py.
_ROW_BY_ROW_MAX = 16

# the single-row path's numpy calls, looked up once
_array, _concatenate, _isnan = np.array, np.concatenate, np.isnan
_minimum, _maximum = np.minimum, np.maximum
_min_reduce, _max_reduce, _prod_reduce = np.minimum.reduce, np.maximum.reduce, np.multiply.reduce
_accumulate = np.add.accumulate


class _Workspace:
    """Reusable buffers for one thread's batch evaluations (fresh multi-megabyte arrays
    cost a page fault per 4 KiB page on every call, which on a VM is most of the time)."""

    def __init__(self, n_rules: int, n_slots: int, n_points: int):
        self.cap = 0
        self.n_rules, self.n_slots = n_rules, n_slots
        self.a = np.empty((n_points, _CHUNK))
        self.t = np.empty((n_points, _CHUNK))

    def reserve(self, n: int):
        if n > self.cap:
            self.cap = n
            self.F = np.empty((self.n_rules, n))
            self.S = np.zeros((self.n_slots, n))  # slots no rule concludes stay 0
            self.one = np.ones(n)
            self.zero = np.zeros(n)


def _centroids(terms, levels, a, t, gridcol, mid: float, y) -> None:
    """The batch path's crisp values of one output for a chunk of n rows, written into
    ``y`` (n,): the aggregate, in ``a`` (grid point, sample), is the max over the output's
    terms ``terms`` (compiled in :meth:`FuzzySystem._compile`) of min(level, MF) with the
    slots' levels ``levels`` (slot, n); then its centroid on the grid ``gridcol`` (G, 1),
    ``mid`` where it is zero everywhere. ``t`` is a work buffer shaped as ``a``."""
    G = a.shape[0]
    n = a.shape[1]
    filled = False
    for sl, g0, g1, mcol in terms:
        s = levels[sl]
        if not filled:
            if g0 == 0 and g1 == G:
                np.minimum(mcol, s, out=a)
                filled = True
                continue
            a.fill(0.0)
            filled = True
        tt = t[g0:g1]
        np.minimum(mcol, s, out=tt)
        np.maximum(a[g0:g1], tt, out=a[g0:g1])
    if not filled:
        a.fill(0.0)
    np.multiply(a, gridcol, out=t)
    # sums over the grid in grid order, as in the single path: numpy reduces axis 0
    # sequentially for >= 2 columns but pairwise for a single one, hence the cumsum
    # (sequential) for n == 1
    if n >= 2:
        num = np.add.reduce(t, axis=0)
        den = np.add.reduce(a, axis=0)
    else:
        num = np.cumsum(t[:, 0])[-1:]
        den = np.cumsum(a[:, 0])[-1:]
    y[:] = mid
    np.divide(num, den, out=y, where=den > 0.0)


class FuzzySystem:
    """A Mamdani FIS. Immutable: the ``with_*`` methods return new systems.

    Parameters
    ----------
    inputs, outputs : sequences of :class:`Variable` (order = column order of X / Y).
    rules : sequence of :class:`Rule`.
    name, description : free text (kept by the .toml and .fis writers).
    n_points : number of points of the defuzzification grid of every output (>= 2).
    inference : :class:`~controller.inference.Inference`, the AND, OR, implication,
        aggregation and defuzzification methods (MATLAB's defaults if omitted).
    unsensed_none : inputs whose NONE in a rule means "sensed nothing" (module doc).

    Evaluation from several threads is fine (each thread gets its own work buffers).
    """

    def __init__(
        self,
        inputs: Sequence[Variable],
        outputs: Sequence[Variable],
        rules: Sequence[Rule],
        *,
        name: str = "fuzzy",
        description: str = "",
        n_points: int = DEFAULT_POINTS,
        inference: Inference = DEFAULT_INFERENCE,
        unsensed_none: Sequence[str] = (),
    ):
        if not isinstance(inference, Inference):
            raise ValueError(f"inference must be an Inference, got {inference!r}")
        self.inference = inference
        self.name = str(name)
        self.description = str(description)
        self.inputs: tuple[Variable, ...] = tuple(inputs)
        self.outputs: tuple[Variable, ...] = tuple(outputs)
        self.rules: tuple[Rule, ...] = tuple(rules)
        if (
            isinstance(n_points, bool)
            or not isinstance(n_points, (int, np.integer))
            or n_points < 2
        ):
            raise ValueError(f"n_points must be an integer >= 2, got {n_points!r}")
        self.n_points = int(n_points)
        _check_structure(self.inputs, self.outputs, self.rules)
        names = [v.name for v in self.inputs]
        if isinstance(unsensed_none, str) or any(n not in names for n in unsensed_none):
            raise ValueError(
                f"unsensed_none = {unsensed_none!r}: must name inputs of the system ({', '.join(names)})"
            )
        #: inputs whose NONE in a rule means "sensed nothing" (module doc); () = MATLAB's
        self.unsensed_none: tuple[str, ...] = tuple(dict.fromkeys(unsensed_none))
        self._gated = [names.index(n) for n in self.unsensed_none]
        self._gated_systems: dict[tuple[bool, ...], tuple[FuzzySystem | None, list[int]]] = {}
        self._compile()

    def _arguments(self) -> dict:
        """The constructor's arguments, by name (for :meth:`replace` and pickling)."""
        return dict(
            inputs=self.inputs,
            outputs=self.outputs,
            rules=self.rules,
            name=self.name,
            description=self.description,
            n_points=self.n_points,
            inference=self.inference,
            unsensed_none=self.unsensed_none,
        )

    # pickling (e.g. for a multiprocessing optimiser): rebuild the compiled parts
    def __getstate__(self):
        return self._arguments()

    def __setstate__(self, state):
        self.__init__(state.pop("inputs"), state.pop("outputs"), state.pop("rules"), **state)

    @property
    def input_names(self) -> list[str]:
        return [v.name for v in self.inputs]

    @property
    def output_names(self) -> list[str]:
        return [v.name for v in self.outputs]

    @property
    def n_inputs(self) -> int:
        return len(self.inputs)

    @property
    def n_outputs(self) -> int:
        return len(self.outputs)

    def rule_text(self, i: int) -> str:
        """Rule i (0-based) in words, e.g. 'IF d_t IS VL AND phi_t IS VN THEN left IS L
        AND right IS VS' (with ' WEIGHT w' if w != 1)."""
        return rule_sentence(self.inputs, self.outputs, self.rules[i])

    def __repr__(self):
        return (
            f"FuzzySystem({self.name!r}, inputs={self.input_names}, "
            f"outputs={self.output_names}, rules={len(self.rules)}, n_points={self.n_points}"
            + ("" if self.inference == DEFAULT_INFERENCE else f", {self.inference}")
            + ")"
        )

    # ------------------------------------------------------------------ compile
    def _compile(self):
        """The tables both paths read (module docstring)."""
        n_out = len(self.outputs)
        self._compile_rows()
        self._compile_rules()
        # consequent slots: slot o * kmax + k = (output o, term k) -> rules concluding it
        kmax = max(len(v.terms) for v in self.outputs)
        self._kmax = kmax
        slots: list[list[int]] = [[] for _ in range(n_out * kmax)]
        for r_i, r in enumerate(self.rules):
            for o, k in enumerate(r.consequent):
                if k is not None:
                    slots[o * kmax + k].append(r_i)
        self._slot_rules = [(sl, rs) for sl, rs in enumerate(slots) if rs]
        # the single-row path's slot levels, term-major (k * n_out + o): per slot its
        # rules' positions, padded with the position of the rule that never fires
        width = max(len(rs) for rs in slots)
        idx = np.full((width, kmax * n_out), self._dummy, dtype=np.intp)
        for k in range(kmax):
            for o in range(n_out):
                for q, r_i in enumerate(slots[o * kmax + k]):
                    idx[q, k * n_out + o] = self._position[r_i]
        self._slot_idx = idx
        self._compile_grid(slots)
        self._tls = threading.local()

    def _compile_rows(self):
        """The membership vector's rows: input terms grouped by family, gates, 1, 0, NOTs."""
        families: dict[str, list[tuple[int, int]]] = {}
        for i, v in enumerate(self.inputs):
            for j, term in enumerate(v.terms):
                families.setdefault(term.shape, []).append((i, j))
        self._term_row = [[0] * len(v.terms) for v in self.inputs]
        self._families = []  # per family: (formula, input columns, parameter columns)
        self._batch_terms = []  # per term: (row, input column, formula, parameters)
        row = 0
        for shape, members in families.items():
            formula = mf.SHAPES[shape].formula
            params = np.array([self.inputs[i].terms[j].params for i, j in members]) + 0.0
            columns = [np.ascontiguousarray(c) for c in params.T]
            self._families.append((formula, np.array([i for i, _ in members]), columns))
            for i, j in members:
                self._term_row[i][j] = row
                self._batch_terms.append((row, i, formula, self.inputs[i].terms[j].params))
                row += 1
        # the gates: isnan of every input (the single-row path computes them in one call)
        self._gate_row = {g: row + g for g in self._gated}
        row += len(self.inputs) if self._gated else 0
        self._ONE, self._ZERO = row, row + 1
        self._one_zero = np.array([1.0, 0.0])
        row += 2
        negated = sorted(
            {
                (i, ~k)
                for r in self.rules
                for i, k in enumerate(r.antecedent)
                if k is not None and k < 0
            }
        )
        self._not_row = {key: row + q for q, key in enumerate(negated)}
        self._nots = [(self._not_row[key], self._term_row[key[0]][key[1]]) for key in negated]
        self._not_src = np.array([src for _, src in self._nots], dtype=np.intp)
        self._n_cols = row + len(negated)

    def _rule_rows_of(self, rule: Rule) -> tuple[list[int], list[int]]:
        """A rule's antecedent rows (input order) and its gate rows."""
        rows = []
        for i, k in enumerate(rule.antecedent):
            if k is not None:
                rows.append(self._term_row[i][k] if k >= 0 else self._not_row[(i, ~k)])
        gates = [self._gate_row[g] for g in self._gated if rule.antecedent[g] is None]
        return rows, gates

    def _compile_rules(self):
        """Per rule its rows (the batch path); the single-row path's index matrices, the
        AND rules first, then a rule that never fires, then the OR rules."""
        self._rule_plan = []
        ands, ors = [], []
        for r_i, rule in enumerate(self.rules):
            rows, gates = self._rule_rows_of(rule)
            if rule.connection == "and":
                self._rule_plan.append((True, rows + gates, []))
                ands.append(r_i)
            else:
                self._rule_plan.append((False, rows, gates))
                ors.append(r_i)
        self._dummy = len(ands)
        order = ands + [-1] + ors
        self._position = {r_i: q for q, r_i in enumerate(order) if r_i >= 0}
        self._rule_pos = np.array([self._position[r] for r in range(len(self.rules))])

        def matrix(rules, which, pad, extra=None):
            lists = [self._rule_plan[r][which] for r in rules] + ([extra] if extra else [])
            width = max([len(lst) for lst in lists] + [1])
            idx = np.full((width, len(lists)), pad, dtype=np.intp)
            for c, lst in enumerate(lists):
                idx[: len(lst), c] = lst
            return idx

        self._and_idx = matrix(ands, 1, self._ONE, extra=[self._ZERO])
        self._or_idx = matrix(ors, 1, self._ZERO) if ors else None
        gated_or = ors and any(self._rule_plan[r][2] for r in ors)
        self._or_gate_idx = matrix(ors, 2, self._ONE) if gated_or else None
        self._W = np.array([r.weight for r in self.rules], dtype=float)
        self._weighted = not bool(np.all(self._W == 1.0))
        self._W_pos = np.ones(len(order))
        self._W_pos[self._rule_pos] = self._W

    def _compile_grid(self, slots: list[list[int]]):
        """The output grids and every output term sampled on its grid, once; per (o, k)
        the span of grid points where the term is not 0 (outside it min(level, 0) = 0
        cannot raise the max)."""
        n_out, kmax, G = len(self.outputs), self._kmax, self.n_points
        self._grid = np.empty((n_out, G))
        self._mfg = np.zeros((n_out, kmax, G))
        self._agg_terms = []
        for o, v in enumerate(self.outputs):
            self._grid[o] = np.linspace(v.range[0], v.range[1], G)
            terms = []
            for k, term in enumerate(v.terms):
                self._mfg[o, k] = term(self._grid[o])
                nz = np.flatnonzero(self._mfg[o, k])
                if nz.size and slots[o * kmax + k]:
                    g0, g1 = int(nz[0]), int(nz[-1]) + 1
                    terms.append(
                        (o * kmax + k, g0, g1, np.ascontiguousarray(self._mfg[o, k, g0:g1, None]))
                    )
            # widest support first: if it covers the whole grid it initialises the
            # aggregate directly (no zero fill, no max)
            terms.sort(key=lambda q: q[1] - q[2])
            self._agg_terms.append(terms)
        # single-row layout: sampled terms as (term, output, grid point); the weights
        # of the two sums [g, 1] as (output, 2, grid point)
        self._mfgK4 = np.ascontiguousarray(self._mfg.transpose(1, 0, 2)[:, :, None, :])
        self._s_shape = (kmax, n_out, 1, 1)
        grid2 = np.ones((n_out, 2, G))
        grid2[:, 0, :] = self._grid
        self._grid2 = grid2
        self._gridcol = [np.ascontiguousarray(self._grid[o][:, None]) for o in range(n_out)]
        self._mid = [0.5 * (v.range[0] + v.range[1]) for v in self.outputs]
        # the plain path (any inference but the default): per output, the rules that
        # conclude on it (in rule order) and their terms on the grid, (rule, point, 1)
        self._plain = not self.inference.is_default
        self._rule_terms = []
        for o in range(n_out):
            rs = [r_i for r_i, r in enumerate(self.rules) if r.consequent[o] is not None]
            ks = [k for k in (r.consequent[o] for r in self.rules) if k is not None]
            self._rule_terms.append((rs, np.ascontiguousarray(self._mfg[o, ks, :, None])))

    # ------------------------------------------------------------------ one row
    def _strengths_one(self, x) -> np.ndarray:
        """One row's weighted firing strengths, by position (AND rules, the rule that
        never fires, OR rules): each family's formula once, then gathers and reduces."""
        if len(x) != len(self.inputs):
            raise ValueError(f"expected {len(self.inputs)} inputs {self.input_names}, got {len(x)}")
        xa = _array(x, dtype=float)
        with mf.quiet():
            parts = [formula(xa[cols], *params) for formula, cols, params in self._families]
        if self._gated:
            parts.append(_isnan(xa))
        parts.append(self._one_zero)
        M = _concatenate(parts)
        if self._nots:
            M = _concatenate((M, 1.0 - M[self._not_src]))
        both = _prod_reduce if self.inference.and_method == "prod" else _min_reduce
        F = both(M[self._and_idx], 0)
        if self._or_idx is not None:
            F = _concatenate((F, self._or_fold(M[self._or_idx], M)))
        if self._weighted:
            F = F * self._W_pos
        return F

    def _or_fold(self, L: np.ndarray, M: np.ndarray) -> np.ndarray:
        """The OR rules' strengths from their rows ``L`` (row, rule), gated."""
        if self.inference.or_method == "max":
            G = _max_reduce(L, 0)
        else:  # probor, a + b - a * b, in input order
            G = L[0]
            for nxt in L[1:]:
                G = (G + nxt) - G * nxt
        if self._or_gate_idx is not None:
            G = _minimum(G, _min_reduce(M[self._or_gate_idx], 0))
        return G

    def _agg_one(self, x):
        """Single-row path: (aggregated (n_out, 1, G), outputs list), operation for
        operation the batch's arithmetic (module docstring)."""
        F = self._strengths_one(x)
        if self._plain:
            aggs, Y = self._plain_outputs(F[self._rule_pos][:, None])
            return np.stack([a[:, 0] for a in aggs])[:, None, :], Y[0].tolist()
        s = _max_reduce(F[self._slot_idx], 0).reshape(self._s_shape)
        agg = _max_reduce(_minimum(s, self._mfgK4), 0)  # (n_out, 1, G)
        sums = _accumulate(agg * self._grid2, 2)[:, :, -1].tolist()  # [[num, den], ...]
        out = []
        for (nu, de), mid in zip(sums, self._mid):
            out.append(nu / de if de > 0.0 else mid)
        return agg, out

    def evaluate_one(self, x: Sequence[float] | np.ndarray) -> np.ndarray:
        """Crisp outputs for one input vector (n_inputs,) -> (n_outputs,), identical to
        ``evaluate(np.array([x]))[0]``. Built for the control loop."""
        return np.array(self._agg_one(x)[1])

    def evaluate_one_list(self, x: Sequence[float]) -> list[float]:
        """Like :meth:`evaluate_one` but returns a plain list."""
        return self._agg_one(x)[1]

    def aggregated(self, x: Sequence[float]) -> Aggregation:
        """For one input vector: the output grids, the aggregated output membership on
        them (by default the max over terms of min(level, MF)) and the crisp outputs
        (= evaluate_one)."""
        agg, out = self._agg_one(x)
        return Aggregation(self._grid.copy(), agg[:, 0, :], np.array(out))

    # ------------------------------------------------------------------ many rows
    def _workspace(self, n: int) -> _Workspace:
        ws = getattr(self._tls, "ws", None)
        if ws is None:
            ws = _Workspace(len(self.rules), len(self.outputs) * self._kmax, self.n_points)
            self._tls.ws = ws
        ws.reserve(n)
        return ws

    def _check_X(self, X) -> np.ndarray:
        X = np.asarray(X, dtype=float)
        if X.ndim != 2 or X.shape[1] != len(self.inputs):
            raise ValueError(
                f"X must have shape (N, {len(self.inputs)}) with columns "
                f"{self.input_names}, got shape {X.shape}"
            )
        return X

    def _complete_rows(self, rows: list, XT: np.ndarray, one: np.ndarray, zero: np.ndarray):
        """Fill the rows after the input terms' (gates, 1, 0, NOTs) for samples XT."""
        for g, row in self._gate_row.items():
            rows[row] = np.isnan(XT[g]).astype(float)
        rows[self._ONE], rows[self._ZERO] = one, zero
        for row, src in self._nots:
            rows[row] = 1.0 - rows[src]

    def _rule_strengths(self, rows: list, F: np.ndarray) -> None:
        """The weighted firing strengths, rule by rule over the samples, into F (rule,
        sample), from the membership rows ``rows`` (the single-row path's operations)."""
        both = np.multiply if self.inference.and_method == "prod" else np.minimum
        probor = self.inference.or_method == "probor"
        for out, (is_and, rr, gates) in zip(F, self._rule_plan):
            np.copyto(out, rows[rr[0]])
            for q in rr[1:]:
                if is_and:
                    both(out, rows[q], out=out)
                elif probor:
                    t = out * rows[q]
                    np.add(out, rows[q], out=out)
                    np.subtract(out, t, out=out)
                else:
                    np.maximum(out, rows[q], out=out)
            for q in gates:
                np.minimum(out, rows[q], out=out)
        if self._weighted:
            F *= self._W[:, None]

    def _block_levels(self, Xb: np.ndarray) -> _Workspace:
        """Memberships, firing strengths (ws.F) and consequent-slot levels (ws.S) of the
        rows Xb, in the first len(Xb) columns of the thread's work buffers."""
        n = Xb.shape[0]
        ws = self._workspace(n)
        XT = np.ascontiguousarray(Xb.T)
        rows: list[Any] = [None] * self._n_cols
        with mf.quiet():
            for row, i, formula, params in self._batch_terms:
                rows[row] = formula(XT[i], *params)
        self._complete_rows(rows, XT, ws.one[:n], ws.zero[:n])
        self._rule_strengths(rows, ws.F[:, :n])
        S = ws.S
        for sl, rs in self._slot_rules:
            out = S[sl, :n]
            np.copyto(out, ws.F[rs[0], :n])
            for q in rs[1:]:
                np.maximum(out, ws.F[q, :n], out=out)
        return ws

    def firing_strengths(self, X) -> np.ndarray:
        """(N, n_rules) firing strengths: the AND (min or product) or the OR (max or
        probor) over the inputs a rule uses, times the rule weight (the level at which
        the rule clips, or by which it scales, its consequent terms)."""
        X = self._check_X(X)
        out = np.empty((X.shape[0], len(self.rules)))
        for b0 in range(0, X.shape[0], _BLOCK):
            Xb = X[b0 : b0 + _BLOCK]
            ws = self._block_levels(Xb)
            out[b0 : b0 + len(Xb)] = ws.F[:, : len(Xb)].T
        return out

    def memberships(self, X) -> list[np.ndarray]:
        """Per input, an (N, n_terms) array of the memberships of its terms."""
        X = self._check_X(X)
        out = []
        for i, v in enumerate(self.inputs):
            out.append(
                np.stack([t(X[:, i]) for t in v.terms], axis=1)
                if X.shape[0]
                else np.empty((0, len(v.terms)))
            )
        return out

    def evaluate(self, X) -> np.ndarray:
        """Crisp outputs for a batch: X (N, n_inputs) -> (N, n_outputs).

        Up to ``_ROW_BY_ROW_MAX`` rows go through :meth:`evaluate_one`'s path one by one
        (as fast as it for one row), more through the block-wise batch path; both give
        the same bits (module docstring)."""
        X = self._check_X(X)
        N = X.shape[0]
        if self._plain:
            return self._plain_evaluate(X)
        if N <= _ROW_BY_ROW_MAX:
            return np.array([self._agg_one(x)[1] for x in X.tolist()]).reshape(N, len(self.outputs))
        Y = np.empty((N, len(self.outputs)))
        for b0 in range(0, N, _BLOCK):
            Xb = X[b0 : b0 + _BLOCK]
            nb = Xb.shape[0]
            ws = self._block_levels(Xb)
            S = ws.S
            for c0 in range(0, nb, _CHUNK):
                n = min(_CHUNK, nb - c0)
                a = ws.a[:, :n]  # aggregated membership: (grid point, sample)
                t = ws.t[:, :n]
                for o, terms in enumerate(self._agg_terms):
                    y = Y[b0 + c0 : b0 + c0 + n, o]
                    _centroids(terms, S[:, c0 : c0 + n], a, t, self._gridcol[o], self._mid[o], y)
        return Y

    def _plain_outputs(self, F: np.ndarray) -> tuple[list[np.ndarray], np.ndarray]:
        """From the weighted firing strengths ``F`` (rule, sample): the aggregates (one
        (G, n) per output, :func:`~controller.inference.aggregate`) and the crisp outputs
        (n, n_out)."""
        aggs = [
            aggregate(self.inference, terms, F[rules])
            if rules
            else np.zeros((self.n_points, F.shape[1]))
            for rules, terms in self._rule_terms
        ]
        Y = np.empty((F.shape[1], len(self.outputs)))
        for o, agg in enumerate(aggs):
            Y[:, o] = defuzzify(self.inference.defuzz_method, self._grid[o], agg, self._mid[o])
        return aggs, Y

    def _plain_evaluate(self, X: np.ndarray) -> np.ndarray:
        """:meth:`evaluate` for any inference but the default (the plain path)."""
        Y = np.empty((X.shape[0], len(self.outputs)))
        step = 128  # (rule, grid point, sample) temporaries of a few MB at most
        for b0 in range(0, X.shape[0], step):
            Xb = X[b0 : b0 + step]
            F = self._block_levels(Xb).F[:, : len(Xb)]
            Y[b0 : b0 + len(Xb)] = self._plain_outputs(F)[1]
        return Y

    def aggregated_many(self, X) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """:meth:`aggregated` of every row of a batch X (N, n_inputs), through the batch
        path: the output grids (n_out, G), the aggregated memberships (N, n_out, G) and
        the crisp outputs (N, n_out), the same bits as row by row (module docstring)."""
        X = self._check_X(X)
        n_rows, n_out = X.shape[0], len(self.outputs)
        memberships = np.empty((n_rows, n_out, self.n_points))
        Y = np.empty((n_rows, n_out))
        if self._plain:
            step = 128  # as _plain_evaluate
            for b0 in range(0, n_rows, step):
                Xb = X[b0 : b0 + step]
                aggs, Y[b0 : b0 + len(Xb)] = self._plain_outputs(
                    self._block_levels(Xb).F[:, : len(Xb)]
                )
                for o, agg in enumerate(aggs):
                    memberships[b0 : b0 + len(Xb), o] = agg.T
            return self._grid.copy(), memberships, Y
        for b0 in range(0, n_rows, _BLOCK):
            Xb = X[b0 : b0 + _BLOCK]
            ws = self._block_levels(Xb)
            for c0 in range(0, len(Xb), _CHUNK):
                n = min(_CHUNK, len(Xb) - c0)
                rows = slice(b0 + c0, b0 + c0 + n)
                a, t = ws.a[:, :n], ws.t[:, :n]
                for o, terms in enumerate(self._agg_terms):
                    levels = ws.S[:, c0 : c0 + n]
                    _centroids(terms, levels, a, t, self._gridcol[o], self._mid[o], Y[rows, o])
                    memberships[rows, o] = a.T
        return self._grid.copy(), memberships, Y

    def gated_system(self, sensed: Sequence[bool]) -> tuple[FuzzySystem | None, list[int]]:
        """With ``unsensed_none``: the system that decides where each gated input is
        sensed (True) or not, and the indices of its rules in this one. A rule with NONE
        for a sensed gated input is left out; None if no rule is left (nothing fires)."""
        key = tuple(bool(b) for b in sensed)
        if key not in self._gated_systems:
            kept = [
                k
                for k, rule in enumerate(self.rules)
                if all(rule.antecedent[i] is not None for i, on in zip(self._gated, key) if on)
            ]
            system = (
                self.replace(rules=[self.rules[k] for k in kept], unsensed_none=())
                if kept
                else None
            )
            self._gated_systems[key] = (system, kept)
        return self._gated_systems[key]

    # ------------------------------------------------------------------ parameters
    def _variables(self) -> tuple[Variable, ...]:
        return self.inputs + self.outputs

    def parameter_vector(self) -> np.ndarray:
        """All membership-function parameters, flat: inputs then outputs, terms in
        order, parameters in MATLAB order (what the optimisers change); names in
        :meth:`parameter_names`."""
        return np.array([p for v in self._variables() for t in v.terms for p in t.params])

    def parameter_names(self) -> list[str]:
        """Names for :meth:`parameter_vector`, e.g. 'd_t.VS.a', 'phi_t.Z.sigma'."""
        return [
            f"{v.name}.{t.name}.{pn}"
            for v in self._variables()
            for t in v.terms
            for pn in mf.SHAPES[t.shape].param_names
        ]

    def with_parameter_vector(self, vec) -> FuzzySystem:
        """A copy with the membership parameters replaced by ``vec`` (same layout as
        :meth:`parameter_vector`). Raises ValueError for a wrong length or an invalid
        shape (e.g. a trimf with a > b, a gaussmf with sigma <= 0)."""
        vec = np.asarray(vec, dtype=float).ravel()
        n = sum(len(t.params) for v in self._variables() for t in v.terms)
        if vec.size != n:
            raise ValueError(f"parameter vector must have {n} entries, got {vec.size}")
        it = iter(vec.tolist())

        def rebuild(v):
            terms = []
            for t in v.terms:
                params = tuple(next(it) for _ in t.params)
                try:
                    terms.append(dataclasses.replace(t, params=params))
                except ValueError as e:
                    raise ValueError(f"variable {v.name!r}: {e}") from None
            return dataclasses.replace(v, terms=tuple(terms))

        ins = [rebuild(v) for v in self.inputs]
        outs = [rebuild(v) for v in self.outputs]
        return self.replace(inputs=ins, outputs=outs)

    def with_term_params(
        self, variable: str, term: str, params: Sequence[float], shape: str | None = None
    ) -> FuzzySystem:
        """A copy with one term's parameters (and optionally its shape) replaced."""
        found = False

        def rebuild(v):
            nonlocal found
            if v.name != variable:
                return v
            k = v.term_index(term)
            old = v.terms[k]
            terms = list(v.terms)
            terms[k] = dataclasses.replace(old, shape=shape or old.shape, params=tuple(params))
            found = True
            return dataclasses.replace(v, terms=tuple(terms))

        ins = [rebuild(v) for v in self.inputs]
        outs = [rebuild(v) for v in self.outputs]
        if not found:
            raise KeyError(
                f"no variable {variable!r} (have {self.input_names + self.output_names})"
            )
        return self.replace(inputs=ins, outputs=outs)

    def replace(self, **kw) -> FuzzySystem:
        """A copy with some constructor arguments replaced (inputs, outputs, rules, name,
        description, n_points, inference, unsensed_none)."""
        args = self._arguments()
        args.update(kw)
        return FuzzySystem(args.pop("inputs"), args.pop("outputs"), args.pop("rules"), **args)

    def with_rules(self, rules: Sequence[Rule]) -> FuzzySystem:
        return self.replace(rules=rules)

    def with_n_points(self, n_points: int) -> FuzzySystem:
        return self.replace(n_points=n_points)

    def with_inference(self, **choices: str) -> FuzzySystem:
        """A copy with some inference choices replaced, e.g. ``defuzz_method="mom"``
        (:class:`~controller.inference.Inference`'s fields)."""
        return self.replace(inference=self.inference.replace(**choices))

    def __eq__(self, other):
        """Same variables (names, ranges, terms), rules, grid and inference: the same
        function. The system name, description and the variables' units/descriptions are
        ignored."""
        if not isinstance(other, FuzzySystem):
            return NotImplemented
        return (
            self.inputs,
            self.outputs,
            self.rules,
            self.n_points,
            self.inference,
            self.unsensed_none,
        ) == (
            other.inputs,
            other.outputs,
            other.rules,
            other.n_points,
            other.inference,
            other.unsensed_none,
        )

    __hash__ = None  # type: ignore[assignment]
