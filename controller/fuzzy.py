"""A small, fast, vectorised Mamdani fuzzy inference engine (MATLAB-compatible semantics).

:class:`FuzzySystem` holds the inputs, outputs and rules (:class:`Term`,
:class:`Variable`, :class:`Rule` and :func:`rule_sentence` are
:mod:`controller.fuzzy_data`'s, imported here). ``evaluate_one(x)`` infers one row (the
control loop; this module), ``evaluate(X)`` many (:mod:`controller.fuzzy_blockwise`,
mixed in); the two agree to the last bit. The inference is MATLAB's default Mamdani:
AND min, the rule weight times the firing strength, implication min, aggregation max,
centroid over ``n_points`` (101) grid points of the output range; every other choice
MATLAB offers is :mod:`controller.inference`'s, picked with
``FuzzySystem(..., inference=Inference(...))``. A NaN input is nothing sensed; an output
no rule fired is the middle of its range; inputs are not clipped to their ranges (all
of it in docs/api.md, "The engine's conventions"). The membership parameters as one
flat vector (what the optimisers change) are :mod:`controller.fuzzy_params`'s.
"""

from __future__ import annotations

import threading
from collections.abc import Sequence

import numpy as np

from . import fuzzy_params
from . import membership as mf
from .fuzzy_blockwise import BlockwiseEvaluation
from .fuzzy_data import Aggregation, Rule, Term, Variable, _check_structure, rule_sentence
from .fuzzy_front import generate_front
from .fuzzy_none import UnsensedNone
from .inference import DEFAULT as DEFAULT_INFERENCE
from .inference import Inference

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


# --------------------------------------------------------------------------- engine

# the single-sample path's numpy calls, looked up once
_array, _minimum, _max_reduce, _accumulate = (
    np.array,
    np.minimum,
    np.maximum.reduce,
    np.add.accumulate,
)


class FuzzySystem(UnsensedNone, BlockwiseEvaluation):
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

    # ------------------------------------------------------------------ one row
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
