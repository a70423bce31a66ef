"""Tuning from Python: a small ask/tell search over a controller's design numbers.

:class:`DesignSearch` is pycma's CMA-ES over a controller's :class:`Tunable`
(``fuzzynav tune``'s parameter space: for the paper controller, the 12 numbers of
:mod:`controller.paper_design`, whose bounds keep every design rule by construction).
It asks for vectors inside the bounds, takes their costs, and keeps the best; a
vector from outside the bounds (a start of one's own, a candidate a user made) is
projected onto them (:meth:`DesignSearch.project`), never refused. The cost is yours:
:func:`tune` calls ``cost(controller)`` for each candidate, so an objective can be a
scenario run, a sweep, a check of a few inputs.

Options are validated with documented defaults (:data:`DEFAULTS`), as pycma's are.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

__all__ = ["DEFAULTS", "DesignSearch", "TuneResult", "tune"]

#: The search's options and their defaults: first step as a fraction of each bound's
#: span, candidates per generation, the seed of every draw.
DEFAULTS: dict[str, float | int] = {"sigma0": 0.2, "popsize": 12, "seed": 0}
_SIGMA_RANGE = (1e-6, 1.0)
_POPSIZE_RANGE = (4, 10_000)


def _option(options: dict, name: str) -> Any:
    value = options.get(name, DEFAULTS[name])
    if name == "sigma0":
        ok = isinstance(value, int | float) and not isinstance(value, bool)
        if not (ok and _SIGMA_RANGE[0] <= value <= _SIGMA_RANGE[1]):
            raise ValueError(f"sigma0 = {value!r}: a number from {_SIGMA_RANGE[0]:g} to 1")
        return float(value)
    low, high = _POPSIZE_RANGE if name == "popsize" else (0, 2**32 - 1)
    if isinstance(value, bool) or not isinstance(value, int) or not low <= value <= high:
        raise ValueError(f"{name} = {value!r}: an integer from {low} to {high}")
    return value


class DesignSearch:
    """Ask/tell CMA-ES over a controller's design numbers.

    Parameters
    ----------
    controller : str or Tunable
        A registered controller with a tunable (``"paper"``, ``"fuzzynav"``), or a
        :class:`controller.tuning.Tunable` object.
    x0 : sequence of float, optional
        Where to start (projected onto the bounds); default the tunable's own start.
    **options
        ``sigma0`` (first step, a fraction of each span; default 0.2), ``popsize``
        (candidates per generation; default 12), ``seed`` (default 0). Unknown names
        are refused.

    Examples
    --------
    >>> search = DesignSearch("paper", popsize=4)
    >>> for _ in range(2):
    ...     vectors = search.ask()
    ...     search.tell(vectors, [float(v.sum()) for v in vectors])
    >>> search.evaluations
    8
    """

    def __init__(self, controller: str | Any = "paper", x0=None, **options):
        import cma

        from fuzzynav.controller.tuning import Tunable, tunable

        unknown = sorted(set(options) - set(DEFAULTS))
        if unknown:
            raise ValueError(f"options {unknown}: unknown (known: {', '.join(DEFAULTS)})")
        self.tunable = tunable(controller) if isinstance(controller, str) else controller
        if not isinstance(self.tunable, Tunable):
            raise ValueError(f"controller = {controller!r}: not a name or a Tunable")
        self.sigma0 = _option(options, "sigma0")
        self.popsize = _option(options, "popsize")
        self.seed = _option(options, "seed")
        self.parameter_names = list(self.tunable.parameter_names())
        self.low, self.high = np.array(self.tunable.bounds(), dtype=float).T
        start = self.tunable.initial_vector() if x0 is None else x0
        start = self.project(start)
        rng = np.random.default_rng(self.seed)
        unit = (start - self.low) / (self.high - self.low)
        self._pad = len(unit) == 1  # pycma searches two dimensions at least
        self._es = cma.CMAEvolutionStrategy(
            np.append(unit, 0.5) if self._pad else unit,
            self.sigma0,
            {
                "bounds": [0.0, 1.0],
                "popsize": self.popsize,
                "randn": lambda *shape: rng.standard_normal(shape),
                "seed": math.nan,  # the draws are rng's alone
                "verbose": -9,
                "verb_disp": 0,
                "verb_log": 0,
            },
        )
        self._asked: list[np.ndarray] = []
        self.best_vector = start
        self.best_cost = math.inf
        self.generation = 0
        self.evaluations = 0

    def project(self, vector: Sequence[float]) -> np.ndarray:
        """The point of the bounds box nearest to ``vector`` (the repair of an
        infeasible candidate: inside the box, every design rule holds).

        Parameters
        ----------
        vector : sequence of float
            One number per parameter.

        Raises
        ------
        ValueError
            A vector of the wrong length or with a NaN.
        """
        v = np.asarray(vector, dtype=float)
        if v.shape != self.low.shape or np.isnan(v).any():
            raise ValueError(
                f"vector {v.tolist()}: needs {len(self.low)} numbers "
                f"({', '.join(self.parameter_names)}), none NaN"
            )
        return np.clip(v, self.low, self.high)

    def ask(self) -> list[np.ndarray]:
        """This generation's candidates, each inside the bounds."""
        self._asked = [np.asarray(u, dtype=float) for u in self._es.ask()]
        n = len(self.low)
        return [self.low + np.clip(u[:n], 0.0, 1.0) * (self.high - self.low) for u in self._asked]

    def tell(self, vectors: Sequence[Sequence[float]], costs: Sequence[float]) -> None:
        """The costs of the vectors :meth:`ask` gave (in its order; NaN or inf: worst).

        Parameters
        ----------
        vectors : sequence of vectors
            What :meth:`ask` returned.
        costs : sequence of float
            One cost per vector; lower is better.
        """
        if len(vectors) != len(self._asked) or len(costs) != len(self._asked):
            raise ValueError(
                f"tell: {len(vectors)} vectors and {len(costs)} costs for the "
                f"{len(self._asked)} asked"
            )
        values = [float(c) if math.isfinite(float(c)) else 1e300 for c in costs]
        k = int(np.argmin(values))
        if values[k] < self.best_cost:
            self.best_cost, self.best_vector = values[k], self.project(vectors[k])
        self._es.tell(self._asked, values)
        self.generation += 1
        self.evaluations += len(values)

    def build(self, vector: Sequence[float] | None = None) -> Any:
        """A fresh controller for ``vector`` (default the best so far), projected.

        Parameters
        ----------
        vector : sequence of float, optional
            The design numbers.
        """
        return self.tunable.build(self.project(self.best_vector if vector is None else vector))


@dataclass
class TuneResult:
    """What :func:`tune` found.

    Attributes
    ----------
    vector : numpy.ndarray
        The best design numbers.
    cost : float
        Their cost.
    controller : object
        A controller built from them.
    parameter_names : list of str
        The numbers' names.
    history : list of float
        The best cost after each generation.
    """

    vector: np.ndarray
    cost: float
    controller: Any
    parameter_names: list[str]
    history: list[float] = field(default_factory=list)


def tune(
    cost: Callable[[Any], float],
    controller: str | Any = "paper",
    *,
    generations: int = 10,
    x0: Sequence[float] | None = None,
    progress: Callable[[int, float], None] | None = None,
    sigma0: float = 0.2,
    popsize: int = 12,
    seed: int = 0,
) -> TuneResult:
    """Minimise ``cost(controller)`` over a controller's design numbers (CMA-ES).

    The search space is ``fuzzynav tune``'s: for the paper controller the 12 numbers of
    its design layout, whose bounds keep every design rule; a start outside the bounds
    is projected onto them. For ask/tell control, use
    :class:`fuzzynav.app.experiments.design_search.DesignSearch`.

    Parameters
    ----------
    cost : callable
        ``cost(controller) -> float`` for each candidate's fresh controller (lower is
        better; NaN and inf count as worst): a run, a sweep, a few inputs...
    controller : str or Tunable
        A registered controller with design numbers (``"paper"``, ``"fuzzynav"``) or a
        :class:`fuzzynav.controller.tuning.Tunable`.
    generations : int
        Generations of the search.
    x0 : sequence of float, optional
        Where to start; default the layout's own start.
    progress : callable, optional
        ``progress(generation, best cost)`` after each generation.
    sigma0 : float
        The first step, a fraction of each number's span (1e-6 to 1).
    popsize : int
        Candidates per generation (4 to 10,000).
    seed : int
        Seeds every draw: the same arguments give the same result.

    Returns
    -------
    TuneResult
        ``.vector``, ``.cost``, ``.controller`` (built from the vector),
        ``.parameter_names``, ``.history`` (the best cost after each generation).
    """
    if isinstance(generations, bool) or not isinstance(generations, int) or generations < 1:
        raise ValueError(f"generations = {generations!r}: an integer >= 1")
    search = DesignSearch(controller, x0=x0, sigma0=sigma0, popsize=popsize, seed=seed)
    history = []
    for generation in range(1, generations + 1):
        vectors = search.ask()
        search.tell(vectors, [cost(search.tunable.build(v)) for v in vectors])
        history.append(search.best_cost)
        if progress is not None:
            progress(generation, search.best_cost)
    return TuneResult(
        search.best_vector, search.best_cost, search.build(), search.parameter_names, history
    )
