"""A small, fast, vectorised Mamdani fuzzy inference engine (MATLAB-compatible semantics).

Inference (the MATLAB Fuzzy Logic Toolbox defaults for a Mamdani FIS; the other choices
MATLAB offers -- AND = product, implication = product, aggregation = sum or probabilistic
OR, defuzzification = bisector, mean / smallest / largest of maximum -- are
:mod:`controller.inference`'s, picked with ``FuzzySystem(..., inference=Inference(...))``):

* AND = min over the inputs a rule uses (an input marked ``None`` -- the paper's NONE --
  takes no part in the rule);
* the rule weight multiplies the firing strength;
* implication = min (the consequent term is clipped at the weighted firing strength);
* aggregation = max over rules;
* defuzzification = centroid over an evenly spaced grid of the output range,
  ``np.linspace(lo, hi, n_points)``, 101 points by default (MATLAB's default):
  ``sum(g * agg(g)) / sum(agg(g))``.

Conventions that are not obvious:

* **NaN input = nothing sensed.** Every membership of a NaN input is 0, so a rule that
  uses that input does not fire, while a rule with NONE for it is unaffected.
* **NONE, two readings.** By default (MATLAB's rule editor) a rule's NONE for an input
  means the input takes no part in the rule. ``unsensed_none`` names inputs for which
  NONE reads as the paper's text has it for d_o ("for more distance, it is 'none'"): a
  rule with NONE for such an input holds only while that input sensed nothing (NaN).
  Evaluated exactly: each row is decided by the rules its sensed inputs allow (the
  others fire at 0); a ``.fis`` cannot say this, and the writer refuses it.
* **No rule fired -> middle of the range.** When the aggregated membership of an output
  is zero over the whole grid (no rule fired for that output, or the fired terms vanish on
  every grid point), the output is ``(lo + hi) / 2``, which is MATLAB's ``evalfis``
  convention (MATLAB also prints a warning; we do not, this runs in a control loop).
* Inputs are **not** clipped to their ranges (MATLAB warns but does not clip either):
  the membership functions are simply evaluated where the value lies; +-inf is allowed.

Speed (the numbers are in bench/bench_fuzzy.py):

* the max over rules of min(w_r, MF_{c_r}(grid)) is computed per consequent term,
  max_k min(max_{r: c_r = k} w_r, MF_k(grid)) (exactly equal), with every output term
  sampled on the grid once and only over the grid points where it is not zero;
* :meth:`FuzzySystem.evaluate` (batch) works block-wise with reusable buffers (fresh
  multi-megabyte temporaries cost a page fault per 4 KiB page on every call) and lays
  the aggregate out as (grid point, sample) so every numpy call works on long rows;
* :meth:`FuzzySystem.evaluate_one` (the control loop) runs memberships, firing strengths
  and per-term levels as generated straight-line Python (:mod:`controller.fuzzy_front`:
  numpy calls on tiny arrays cost 1-3 us each), then a handful of numpy calls on the grid.

Those tricks are the default inference's. Any other choice takes the plain path: each
rule's implied set on the grid, folded over the rules in rule order
(:func:`controller.inference.aggregate`), then :func:`controller.inference.defuzzify`;
one code for one row and for many, so the two agree to the last bit there too.

The membership parameters as one flat vector (what the optimisers change) and the copies
built from one are :mod:`controller.fuzzy_params`'s; the ``FuzzySystem`` methods of the
same names call it.

``evaluate_one(x)`` and ``evaluate(X)[i]`` are identical to the last bit: they do the
same floating-point operations (min and max are exact; the memberships are each family's
formula and the scalar source generated from the same table entry, held to the same
bits by tests/test_membership_family.py; exp is numpy's in both, as math.exp differs in the last bit for a few
percent of arguments; the two centroid sums run in grid order in both: a cumsum in one,
a reduce over axis 0 of >= 2 columns in the other).
"""

from __future__ import annotations

import math
import threading
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np

from . import fuzzy_params
from . import membership as mf
from .fuzzy_front import generate_front
from .fuzzy_none import UnsensedNone
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


# --------------------------------------------------------------------------- data


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


@dataclass(frozen=True)
class Rule:
    """One rule. ``antecedent[i]`` is the index of a term of input i, or None (NONE: the
    input takes no part). ``consequent[o]`` is the index of a term of output o, or None
    (the rule says nothing about that output). ``weight`` in [0, 1] multiplies the firing
    strength. Indices are 0-based (a .fis file counts from 1)."""

    antecedent: tuple[int | None, ...]
    consequent: tuple[int | None, ...]
    weight: float = 1.0

    def __post_init__(self):
        def norm(seq, what):
            out = []
            for v in seq:
                if v is None:
                    out.append(None)
                elif isinstance(v, (int, np.integer)) and not isinstance(v, bool) and v >= 0:
                    out.append(int(v))
                else:
                    raise ValueError(
                        f"rule {what} entries must be term indices >= 0 or None, got {v!r}"
                    )
            return tuple(out)

        object.__setattr__(self, "antecedent", norm(self.antecedent, "antecedent"))
        object.__setattr__(self, "consequent", norm(self.consequent, "consequent"))
        w = float(self.weight)
        if not (math.isfinite(w) and 0.0 <= w <= 1.0):
            raise ValueError(f"rule weight must be in [0, 1], got {self.weight!r}")
        object.__setattr__(self, "weight", w)
        if all(a is None for a in self.antecedent):
            raise ValueError("rule has no antecedent (every input is NONE)")
        if all(c is None for c in self.consequent):
            raise ValueError("rule has no consequent (every output is NONE)")


class Aggregation(NamedTuple):
    """What :meth:`FuzzySystem.aggregated` returns (one input vector)."""

    grid: np.ndarray  # (n_outputs, n_points): the output grids
    membership: np.ndarray  # (n_outputs, n_points): the aggregated output membership
    output: np.ndarray  # (n_outputs,): the crisp outputs (= evaluate_one)


# --------------------------------------------------------------------------- engine

# the single-sample path's numpy calls, looked up once
_array, _minimum, _max_reduce, _accumulate = (
    np.array,
    np.minimum,
    np.maximum.reduce,
    np.add.accumulate,
)

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


def rule_sentence(inputs: Sequence[Variable], outputs: Sequence[Variable], rule: Rule) -> str:
    """A rule in words: 'IF d_t IS VL AND phi_t IS VN THEN left IS L AND right IS VS'
    (with ' WEIGHT w' if w != 1); the rule-base reader parses the same sentence back."""

    def clause(variables, indices):
        return " AND ".join(
            f"{v.name} IS {v.terms[k].name}" for v, k in zip(variables, indices) if k is not None
        )

    text = f"IF {clause(inputs, rule.antecedent)} THEN {clause(outputs, rule.consequent)}"
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
            if idx is not None and idx >= len(var.terms):
                raise ValueError(
                    f"rule {r_i + 1}: term index {idx} out of range for "
                    f"{var.name!r} ({len(var.terms)} terms)"
                )


class FuzzySystem(UnsensedNone):
    """A Mamdani FIS. Immutable: the ``with_*`` methods return new systems.

    Parameters
    ----------
    inputs, outputs : sequences of :class:`Variable` (order = column order of X / Y).
    rules : sequence of :class:`Rule`.
    name, description : free text (kept by the .toml and .fis writers).
    n_points : number of points of the defuzzification grid of every output (>= 2).
    inference : :class:`~controller.inference.Inference`, the AND, implication,
        aggregation and defuzzification methods (MATLAB's defaults if omitted).

    Not thread-safe to *mutate* (it is never mutated); evaluation from several threads is
    fine (each thread gets its own work buffers).
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
        _n_in, n_out, _R = len(self.inputs), len(self.outputs), len(self.rules)
        # membership rows: input terms (input-major), then ONE (for NONE), then ZERO
        col = []
        t = 0
        for v in self.inputs:
            col.append(list(range(t, t + len(v.terms))))
            t += len(v.terms)
        self._n_cols = t + 2
        self._ONE, self._ZERO = t, t + 1
        # per input term: (membership row, input column, the family's formula, params)
        self._batch_terms = [
            (col[i][j], i, mf.SHAPES[term.shape].formula, term.params)
            for i, v in enumerate(self.inputs)
            for j, term in enumerate(v.terms)
        ]
        # per rule: the membership rows it takes the min of
        self._rule_rows = [
            [col[i][idx] for i, idx in enumerate(r.antecedent) if idx is not None]
            for r in self.rules
        ]
        self._W = np.array([r.weight for r in self.rules], dtype=float)
        self._weighted = not bool(np.all(self._W == 1.0))
        # consequent slots: slot o * kmax + k = (output o, term k) -> rules concluding it
        kmax = max(len(v.terms) for v in self.outputs)
        self._kmax = kmax
        slots: list[list[int]] = [[] for _ in range(n_out * kmax)]
        for r_i, r in enumerate(self.rules):
            for o, k in enumerate(r.consequent):
                if k is not None:
                    slots[o * kmax + k].append(r_i)
        self._slot_rules = [(sl, rs) for sl, rs in enumerate(slots) if rs]

        # output grids and every output term sampled on its grid, once; per (o, k) the
        # span of grid points where the term is not 0 (outside it min(level, 0) = 0
        # cannot raise the max)
        G = self.n_points
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
        # single path layout: sampled terms as (term, output, grid point); the weights
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
            ks = [self.rules[r_i].consequent[o] for r_i in rs]
            self._rule_terms.append((rs, np.ascontiguousarray(self._mfg[o, ks, :, None])))
        self._front = generate_front(self, per_rule=self._plain)
        self._tls = threading.local()

    def _batch_terms_row(self, i: int, j: int) -> int:
        return sum(len(v.terms) for v in self.inputs[:i]) + j

    # ------------------------------------------------------------------ batch pieces
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
        rows = [None] * self._n_cols
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

    def _agg_one(self, x):
        """Single-sample path: (aggregated (n_out, 1, G), outputs list); operation for
        operation the batch's arithmetic (min/max are exact; the sums run in grid order:
        an accumulate here, a reduce over axis 0 of >= 2 columns there). The ufuncs are
        called directly: the ndarray methods and np.cumsum add a Python wrapper each."""
        if self._gated:
            system = self._gated_one(x)
            if system is None:
                return np.zeros((len(self.outputs), 1, self.n_points)), list(self._mid)
            return system._agg_one(x)
        if type(x) is np.ndarray:
            x = x.tolist()  # Python floats: much faster than numpy scalars below
        if self._plain:
            aggs, Y = self._plain_outputs(_array(self._front(x))[:, None])
            return np.stack([a[:, 0] for a in aggs])[:, None, :], Y[0].tolist()
        s = _array(self._front(x)).reshape(self._s_shape)
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
        """Like :meth:`evaluate_one` but returns a plain list (saves ~1 us)."""
        return self._agg_one(x)[1]

    def aggregated(self, x: Sequence[float]) -> Aggregation:
        """For one input vector: the output grids, the aggregated output membership on
        them (by default the max over terms of min(level, MF)) and the crisp outputs
        (= evaluate_one)."""
        agg, out = self._agg_one(x)
        return Aggregation(self._grid.copy(), agg[:, 0, :], np.array(out))

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

    # ------------------------------------------------------------------ parameters
    def parameter_vector(self) -> np.ndarray:
        """All membership-function parameters, flat (:func:`.fuzzy_params.parameter_vector`)."""
        return fuzzy_params.parameter_vector(self)

    def parameter_names(self) -> list[str]:
        """Names for :meth:`parameter_vector`, e.g. 'd_t.VS.a', 'phi_t.Z.sigma'."""
        return fuzzy_params.parameter_names(self)

    def with_parameter_vector(self, vec) -> FuzzySystem:
        """A copy with the membership parameters replaced by ``vec`` (same layout as
        :meth:`parameter_vector`; :func:`.fuzzy_params.with_parameter_vector`)."""
        return fuzzy_params.with_parameter_vector(self, vec)

    def with_term_params(
        self, variable: str, term: str, params: Sequence[float], shape: str | None = None
    ) -> FuzzySystem:
        """A copy with one term's parameters (and optionally its shape) replaced."""
        return fuzzy_params.with_term_params(self, variable, term, params, shape)

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
