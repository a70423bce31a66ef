"""A fuzzy system's membership parameters as one flat vector, and copies with some replaced.

The optimisers (:mod:`controller.tuning`, the paper fit) see a
:class:`~controller.fuzzy.FuzzySystem` as a vector of numbers: every membership-function
parameter, inputs then outputs, terms in order, parameters in MATLAB order. These
functions read that vector, name its entries and build the system a vector describes;
:class:`~controller.fuzzy.FuzzySystem`'s methods of the same names call them.

Nothing here imports :mod:`controller.fuzzy` (which imports this module): new terms and
variables are made with :func:`dataclasses.replace`, which runs their checks as their
constructors do, and new systems with the system's own ``replace``.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence

import numpy as np

from . import membership as mf

__all__ = ["parameter_vector", "parameter_names", "with_parameter_vector", "with_term_params"]


def _variables(system) -> tuple:
    return tuple(system.inputs) + tuple(system.outputs)


def parameter_vector(system) -> np.ndarray:
    """All membership-function parameters, flat: inputs then outputs, terms in order,
    parameters in MATLAB order. See :func:`parameter_names`."""
    return np.array([p for v in _variables(system) for t in v.terms for p in t.params])


def parameter_names(system) -> list[str]:
    """Names for :func:`parameter_vector`, e.g. 'd_t.VS.a', 'phi_t.Z.sigma'."""
    return [
        f"{v.name}.{t.name}.{pn}"
        for v in _variables(system)
        for t in v.terms
        for pn in mf.SHAPES[t.shape].param_names
    ]


def with_parameter_vector(system, vec):
    """A copy of ``system`` with the membership parameters replaced by ``vec`` (same
    layout as :func:`parameter_vector`). Raises ValueError for a wrong length or an
    invalid shape (e.g. a trimf with a > b, a gaussmf with sigma <= 0)."""
    vec = np.asarray(vec, dtype=float).ravel()
    n = sum(len(t.params) for v in _variables(system) for t in v.terms)
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

    ins = [rebuild(v) for v in system.inputs]
    outs = [rebuild(v) for v in system.outputs]
    return system.replace(inputs=ins, outputs=outs)


def with_term_params(
    system, variable: str, term: str, params: Sequence[float], shape: str | None = None
):
    """A copy of ``system`` with one term's parameters (and optionally its shape)
    replaced."""
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

    ins = [rebuild(v) for v in system.inputs]
    outs = [rebuild(v) for v in system.outputs]
    if not found:
        raise KeyError(
            f"no variable {variable!r} (have {system.input_names + system.output_names})"
        )
    return system.replace(inputs=ins, outputs=outs)
