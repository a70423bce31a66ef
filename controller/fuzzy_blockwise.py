"""A fuzzy system's batch path: many rows of one system, block by block.

:class:`BlockwiseEvaluation` gives :class:`controller.fuzzy.FuzzySystem` its methods for
a batch ``X`` (N, n_inputs): :meth:`~BlockwiseEvaluation.evaluate`,
:meth:`~BlockwiseEvaluation.firing_strengths`, :meth:`~BlockwiseEvaluation.memberships`
and :meth:`~BlockwiseEvaluation.aggregated_many`. It works block-wise with each thread's
reusable buffers (:class:`_Workspace`) and lays the aggregate out as (grid point, sample)
(:func:`_centroids`); the plain path (any inference but the default) folds the rules'
implied sets (:func:`controller.inference.aggregate`). The single-sample path and the
compiled tables both paths read are :mod:`controller.fuzzy`'s, whose docstring says why
the two give the same bits.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from . import membership as mf
from .fuzzy_data import Rule, Variable
from .inference import Inference, aggregate, defuzzify

_BLOCK = 16384  # rows per block of memberships / firing strengths in evaluate()
_CHUNK = 512  # rows per block of the grid aggregation (its buffers stay in cache)
# Up to this many rows, evaluate() runs the single-row path per row: the batch path's
# fixed cost (~0.3-0.5 ms of numpy calls) is then more than the rows cost one by one
# (15-25 us each); the crossover is measured in bench/bench_fuzzy.py.
_ROW_BY_ROW_MAX = 16


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


class BlockwiseEvaluation:
    """The batch path (module doc); mixed into ``FuzzySystem``, whose ``_compile`` sets
    the tables read here."""

    inputs: tuple[Variable, ...]
    outputs: tuple[Variable, ...]
    rules: tuple[Rule, ...]
    n_points: int
    inference: Inference
    input_names: Any  # FuzzySystem.input_names
    _agg_one: Any  # FuzzySystem._agg_one
    _gated: list[int]
    _gated_groups: Any  # UnsensedNone._gated_groups
    _tls: Any
    _kmax: int
    _n_cols: int
    _ONE: int
    _batch_terms: list
    _rule_rows: list
    _W: np.ndarray
    _weighted: bool
    _slot_rules: list
    _plain: bool
    _agg_terms: list
    _grid: np.ndarray
    _gridcol: list
    _mid: list
    _rule_terms: list

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

    def _block_levels(self, Xb: np.ndarray) -> _Workspace:
        """Memberships, firing strengths (ws.F) and consequent-slot levels (ws.S) of the
        rows Xb, in the first len(Xb) columns of the thread's work buffers."""
        n = Xb.shape[0]
        ws = self._workspace(n)
        F, S = ws.F, ws.S
        XT = np.ascontiguousarray(Xb.T)
        rows: list[Any] = [None] * self._n_cols
        with mf.quiet():
            for row, i, formula, params in self._batch_terms:
                rows[row] = formula(XT[i], *params)
        rows[self._ONE] = ws.one[:n]
        for r_i, rr in enumerate(self._rule_rows):
            out = F[r_i, :n]
            if len(rr) == 1:
                np.copyto(out, rows[rr[0]])
            else:
                both = np.multiply if self.inference.and_method == "prod" else np.minimum
                both(rows[rr[0]], rows[rr[1]], out=out)
                for q in rr[2:]:
                    both(out, rows[q], out=out)
        if self._weighted:
            F[:, :n] *= self._W[:, None]
        for sl, rs in self._slot_rules:
            out = S[sl, :n]
            np.copyto(out, F[rs[0], :n])
            for q in rs[1:]:
                np.maximum(out, F[q, :n], out=out)
        return ws

    def firing_strengths(self, X) -> np.ndarray:
        """(N, n_rules) firing strengths: the AND (min or product) over the inputs a rule
        uses, times the rule weight (the level at which the rule clips, or by which it
        scales, its consequent terms)."""
        X = self._check_X(X)
        if self._gated:
            out = np.zeros((X.shape[0], len(self.rules)))
            for rows, system, kept in self._gated_groups(X):
                if system is not None:
                    out[np.ix_(rows, kept)] = system.firing_strengths(X[rows])
            return out
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

    # ------------------------------------------------------------------ inference
    def evaluate(self, X) -> np.ndarray:
        """Crisp outputs for a batch: X (N, n_inputs) -> (N, n_outputs).

        Up to ``_ROW_BY_ROW_MAX`` rows go through :meth:`evaluate_one`'s path one by one
        (as fast as it for one row), more through the block-wise batch path; both give
        the same bits (module docstring)."""
        X = self._check_X(X)
        N = X.shape[0]
        if self._gated:
            Y = np.empty((N, len(self.outputs)))
            for rows, system, _ in self._gated_groups(X):
                Y[rows] = self._mid if system is None else system.evaluate(X[rows])
            return Y
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
        if self._gated:
            for rows, system, _ in self._gated_groups(X):
                if system is None:
                    memberships[rows], Y[rows] = 0.0, self._mid
                else:
                    _, memberships[rows], Y[rows] = system.aggregated_many(X[rows])
            return self._grid.copy(), memberships, Y
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
