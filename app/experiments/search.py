"""Tuning: the one search over a controller's design numbers, from Python and for
``fuzzynav tune``.

:func:`tune` minimises a cost over a :class:`~fuzzynav.controller.tuning.Tunable`'s
vector: your ``cost(controller)``, or the objective of ``fuzzynav tune``'s runs
(``cases``: :mod:`.objective`). :class:`DesignSearch` is the same CMA-ES as ask/tell,
for a loop of one's own (with :func:`fuzzynav.evaluate`, a population on the batch
engine). The CMA-ES itself is :mod:`.evolution`'s (the one wrapper of pycma).

``method="cmaes"`` (Python's default): pycma's CMA-ES from the starting vector, never
worse than it. ``method="de"`` (the command's default):
``scipy.optimize.differential_evolution`` runs with a fixed seed,
``updating="deferred"``, ``polish=False`` and the starting vector in its initial
population. A generation's candidates are mapped over the executor (:mod:`.executor`) in
order, so the result does not depend on the executor or the number of workers.
``radius`` narrows every bound to the starting value +- radius times the bound's span (a
local search around a vector that already works). ``method="nelder-mead"`` or
``"powell"``: ``scipy.optimize.minimize`` from the starting vector, within the bounds,
``generations`` iterations (deterministic, one process).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from fuzzynav.app.experiments.evolution import BoxCMA
from fuzzynav.app.experiments.objective import (
    CLEARANCE_WEIGHT,
    STALL_S,
    Case,
    Objective,
    full_vector,
    outcome_cost,
)

__all__ = ["DEFAULTS", "DesignSearch", "TuneResult", "tune"]

#: DesignSearch's options and their defaults: first step as a fraction of each bound's
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


def _tunable(controller) -> Any:
    """The Tunable of a registered name, or ``controller`` itself when it is one."""
    from fuzzynav.controller.tuning import Tunable, tunable

    found = tunable(controller) if isinstance(controller, str) else controller
    if not isinstance(found, Tunable):
        raise ValueError(f"controller = {controller!r}: not a name or a Tunable")
    return found


class DesignSearch(BoxCMA):
    """Ask/tell CMA-ES over a controller's design numbers.

    ``fuzzynav tune``'s parameter space: for the paper controller, the 12 numbers of
    :mod:`controller.paper_design`, whose bounds keep every design rule by
    construction. It asks for vectors inside the bounds, takes their costs and keeps the
    best; a vector from outside the bounds (a start of one's own, a candidate a user
    made) is projected onto them (:meth:`project`), never refused.

    Parameters
    ----------
    controller : str or Tunable
        A registered controller with a tunable (``"paper"``, ``"fuzzynav"``), or a
        :class:`controller.tuning.Tunable` object.
    x0 : sequence of float, optional
        Where to start (projected onto the bounds); default the tunable's own start.
    options : keyword arguments
        ``sigma0`` (first step, a fraction of each span; default 0.2), ``popsize``
        (candidates per generation; default 12), ``seed`` (default 0): :data:`DEFAULTS`,
        checked as pycma checks its own. Unknown names are refused.

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
        unknown = sorted(set(options) - set(DEFAULTS))
        if unknown:
            raise ValueError(f"options {unknown}: unknown (known: {', '.join(DEFAULTS)})")
        self.tunable = _tunable(controller)
        self.sigma0 = _option(options, "sigma0")
        self.popsize = _option(options, "popsize")
        self.seed = _option(options, "seed")
        self.parameter_names = list(self.tunable.parameter_names())
        bounds = np.array(self.tunable.bounds(), dtype=float)
        self.low, self.high = bounds.T
        start = self.project(self.tunable.initial_vector() if x0 is None else x0)
        super().__init__(bounds, start, self.sigma0, self.popsize, self.seed)

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

    def ask(self) -> list[np.ndarray]:  # type: ignore[override]  # a list, as pycma's
        """This generation's candidates, each inside the bounds."""
        return list(super().ask())

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
        The best design numbers (the tunable's whole vector, also when ``free``
        restricted the search).
    cost : float
        Their cost.
    controller : object
        A controller built from them.
    parameter_names : list of str
        The numbers' names.
    history : list of float
        The best cost after each generation (iteration, for a local search).
    generations : int
        Generations (iterations) run.
    evaluations : int
        Costs computed.
    """

    vector: np.ndarray
    cost: float
    controller: Any
    parameter_names: list[str]
    history: list[float] = field(default_factory=list)
    generations: int = 0
    evaluations: int = 0


class _ControllerCost:
    """A cost of controllers as a cost of (free parts of) vectors; picklable when the
    cost is, so that a pool can evaluate a generation."""

    def __init__(self, tunable, cost, base=None, free=None):
        self.tunable, self.cost = tunable, cost
        self.base = None if base is None else np.asarray(base, float).copy()
        self.free = None if free is None else np.asarray(free, int)

    def full(self, vector) -> np.ndarray:
        """The tunable's whole vector for an argument of this cost."""
        return full_vector(vector, self.base, self.free)

    def __call__(self, vector) -> float:
        return float(self.cost(self.tunable.build(self.full(vector))))


def _search_box(all_bounds, x0, free, radius):
    """``(lo, hi, start)`` of the searched parameters (``free``, None: all): their
    bounds, narrowed to ``x0`` +- ``radius`` x span when given, and the start inside."""
    sel = np.arange(len(x0)) if free is None else np.asarray(free, int)
    lo, hi = all_bounds[sel, 0], all_bounds[sel, 1]
    if radius is not None:
        span = radius * (hi - lo)
        lo, hi = np.maximum(lo, x0[sel] - span), np.minimum(hi, x0[sel] + span)
    # A start on a bound can round to just outside it in scipy's [0, 1] scaling.
    margin = 1e-9 * (hi - lo)
    start = np.clip(x0[sel], lo + margin, hi - margin)
    return lo, hi, start


def _differential_evolution(objective, lo, hi, start, *, batched, executor, workers, **kwargs):
    """scipy's DE over the box (seeded, ``updating="deferred"``, no polish), its
    population mapped by ``batched`` (the batch engine), a local pool of ``workers``,
    the ``executor``, or in this process."""
    from scipy.optimize import differential_evolution

    kwargs = dict(
        bounds=list(zip(lo, hi)),
        x0=start,
        updating="deferred",
        polish=False,
        tol=0.0,
        **kwargs,
    )
    if batched is not None:
        return differential_evolution(objective, workers=batched, **kwargs)
    if executor is None and workers > 1:
        from fuzzynav.app.experiments.executor import LocalExecutor

        with LocalExecutor(workers) as pool:
            return differential_evolution(objective, workers=pool.map, **kwargs)
    if executor is not None and executor.kind != "serial":
        # the population of a generation, mapped in order: the same result anywhere
        return differential_evolution(objective, workers=executor.map, **kwargs)
    return differential_evolution(objective, **kwargs)


def _local_search(objective, lo, hi, start, method, maxiter, callback, on_evaluation):
    """scipy's Nelder-Mead or Powell from ``start`` within the box, in this process;
    ``on_evaluation(count, best cost so far)`` after every candidate."""
    from scipy.optimize import Bounds, minimize

    options = (
        {"maxiter": maxiter, "xatol": 1e-4, "fatol": 1e-6}
        if method == "nelder-mead"
        else {"maxiter": maxiter, "xtol": 1e-4, "ftol": 1e-6}
    )
    seen = [0, math.inf]

    def counted(vector):
        cost = objective(vector)
        seen[0], seen[1] = seen[0] + 1, min(seen[1], cost)
        if on_evaluation is not None:
            on_evaluation(seen[0], seen[1])
        return cost

    return minimize(
        counted, start, method=method, bounds=Bounds(lo, hi), options=options, callback=callback
    )


def _cmaes(objective, lo, hi, start, sigma0, maxiter, popsize, seed, mapper, batched, report):
    """pycma's CMA-ES from ``start`` (:func:`.evolution.cmaes`) as scipy's
    OptimizeResult, never worse than the start."""
    from scipy.optimize import OptimizeResult

    from fuzzynav.app.experiments.evolution import cmaes

    x, fun, nit, nfev = cmaes(
        objective,
        list(zip(lo, hi)),
        start,
        sigma0,
        maxiter,
        popsize,
        seed,
        mapper,
        lambda k, best_f, best_x, sigma: report(k, best_f, best_x),
    )
    # CMA-ES returns its best candidate, never the start itself: a polish from a
    # sharp optimum could otherwise hand back something worse than it was given.
    start_cost = float(objective(start) if batched is None else batched(None, [start])[0])
    if start_cost <= fun:
        x, fun = start.copy(), start_cost
    return OptimizeResult(x=x, fun=fun, nit=nit, nfev=nfev + 1)


def _serial_map(f, xs):
    return [f(x) for x in xs]


def tune(
    cost: Callable[[Any], float] | None = None,
    controller: str | Any = "paper",
    *,
    cases: Sequence[Case] | None = None,
    population_cost: Callable[[list[Any]], Sequence[float]] | None = None,
    method: str = "cmaes",
    generations: int = 10,
    x0: Sequence[float] | None = None,
    free: Sequence[int] | None = None,
    radius: float | None = None,
    sigma0: float = DEFAULTS["sigma0"],
    popsize: int = DEFAULTS["popsize"],
    seed: int = DEFAULTS["seed"],
    progress: bool | Callable[[int, float], None] | None = None,
    on_generation: Callable[[int, float, np.ndarray], None] | None = None,
    on_evaluation: Callable[[int, float], None] | None = None,
    executor: Any = None,
    workers: int = 1,
    engine: str = "pymunk",
    on_fallback: Callable[[str], None] | None = None,
    control_period_s: float = 0.05,
    clearance_weight: float = CLEARANCE_WEIGHT,
) -> TuneResult:
    """Minimise a cost over a controller's design numbers (CMA-ES by default).

    The space is ``fuzzynav tune``'s: for the paper controller the 12 numbers of its
    design layout, whose bounds keep every design rule. Ask/tell: :class:`DesignSearch`.

    Parameters
    ----------
    cost, population_cost : callable, optional
        ``cost(controller) -> float`` of each candidate's fresh controller (lower is
        better; NaN and inf count as worst); or, for CMA-ES and DE, ``population_cost(
        controllers) -> costs`` of a generation at once (:func:`fuzzynav.evaluate`).
    controller : str or Tunable
        A registered controller with design numbers (``"paper"``, ``"fuzzynav"``) or a
        :class:`fuzzynav.controller.tuning.Tunable`.
    cases : list of Case, optional
        Or ``fuzzynav tune``'s objective, the mean cost of these runs
        (:class:`~fuzzynav.app.experiments.objective.Objective`, ``build_cases``).
    method : {"cmaes", "de", "nelder-mead", "powell"}
        The search (module docstring).
    generations : int
        Generations of the search (iterations of a local search).
    x0, free, radius : optional
        Where to start (default the tunable's own start); the indices searched (the
        rest stay at the start); every bound narrowed to the start +- radius x span.
    sigma0, popsize, seed : float, int, int
        CMA-ES's first step, a fraction of each span (1e-6 to 1); candidates a
        generation (CMA-ES, at least 4; DE: scipy's multiplier of the numbers searched);
        the seed of every draw (the same arguments give the same result).
    progress : bool or callable, optional
        True: a progress bar on stderr; a callable: ``progress(generation, best cost)``.
    on_generation, on_evaluation, on_fallback : callable, optional
        ``on_generation(generation, best cost, best whole vector)`` after each
        generation; ``on_evaluation(count, best cost)`` after each candidate of a local
        search; ``on_fallback(message)`` when ``engine="batch"`` falls back to pymunk.
    executor, workers : Executor, int
        Where a generation is evaluated (:mod:`.executor`); without one, a local pool of
        ``workers`` processes when above 1. A local search runs here.
    engine : {"pymunk", "batch"}
        With ``cases``, CMA-ES and DE: ``batch`` runs a generation's candidates x cases
        on the batch engine (:func:`.batch_runs.batch_mapper`).
    control_period_s, clearance_weight : float
        With ``cases``: the runs' control period (s); the cost per metre of clearance
        below the safe distance.

    Returns
    -------
    TuneResult
    """
    _check_tune_arguments(
        cost, population_cost, engine, generations=generations, popsize=popsize, seed=seed,
        workers=workers, radius=radius, control_period_s=control_period_s,
        clearance_weight=clearance_weight,
    )  # fmt: skip
    tunable = _tunable(controller)
    all_bounds, x0, free = _start_and_free(tunable, x0, free)
    objective = _objective(
        tunable, (cost, population_cost, cases), x0, free, control_period_s, clearance_weight
    )
    lo, hi, start = _search_box(all_bounds, x0, free, radius)
    batched = None
    if population_cost is not None:
        batched = _population_mapper(objective, population_cost, method)
    elif engine == "batch" and cases is not None and method in ("de", "cmaes"):
        batched = _batch_mapper(objective, start, executor, on_fallback)
    with _generation_reporter(progress, generations, objective, on_generation) as report:
        result = _search(
            objective, method, lo, hi, start, generations, popsize, seed, sigma0,
            executor, workers, batched, report, on_evaluation,
        )  # fmt: skip
    vector, steps = objective.full(result.x), int(getattr(result, "nit", len(report.history)))
    return TuneResult(
        vector, float(result.fun), tunable.build(vector), list(tunable.parameter_names()),
        report.history, steps, int(result.nfev),
    )  # fmt: skip


#: tune's numbers and their ranges: the command line's (``fuzzynav tune --maxiter``,
#: ``--popsize``, ``--seed``, ``--workers``, ``--radius``, ``--dt``, ``--clearance-weight``).
_TUNE_INTEGERS = {"generations": (1, 100_000), "popsize": (1, 1000), "seed": (0, None)}
_TUNE_NUMBERS = {"radius": (1e-9, 1e3, ""), "clearance_weight": (0.0, 1e9, "")}


def _check_tune_arguments(cost, population_cost, engine: str, **values) -> None:
    """TypeError for a cost that is not callable; ValueError naming an unknown engine or
    the first of tune's numeric arguments outside the command line's range for it (a
    NaN, a negative seed, ``popsize=0``, a string)."""
    for name, given in (("cost", cost), ("population_cost", population_cost)):
        if given is not None and not callable(given):
            raise TypeError(f"{name} = {given!r}: not callable (a function of the controller)")
    if engine not in ("pymunk", "batch"):
        raise ValueError(f"engine = {engine!r}: must be pymunk or batch")
    from fuzzynav.app.args import integer_value, number_value
    from fuzzynav.app.experiments.executor import MAX_WORKERS
    from fuzzynav.world.run_limits import MAX_CONTROL_PERIOD_S, MIN_CONTROL_PERIOD_S

    integers = {**_TUNE_INTEGERS, "workers": (1, MAX_WORKERS)}
    numbers = {
        **_TUNE_NUMBERS,
        "control_period_s": (MIN_CONTROL_PERIOD_S, MAX_CONTROL_PERIOD_S, " s"),
    }
    for name, value in values.items():
        if name in integers:
            integer_value(value, name, *integers[name])
        elif value is not None:  # radius: None means no narrowing
            number_value(value, name, *numbers[name])


def _start_and_free(tunable, x0, free) -> tuple[np.ndarray, np.ndarray, list[int] | None]:
    """The tunable's bounds, the start (``x0`` checked and clipped into them) and the
    indices searched (``free`` checked)."""
    all_bounds = np.asarray(tunable.bounds(), float)
    start = np.clip(_start_vector(x0, tunable, len(all_bounds)), *all_bounds.T)
    return all_bounds, start, _free_indices(free, len(all_bounds))


def _start_vector(x0, tunable, size: int) -> np.ndarray:
    """The search's start: the tunable's own, or ``x0``, ``size`` finite numbers."""
    if x0 is None:
        return np.asarray(tunable.initial_vector(), float)
    try:
        vector = np.asarray(x0, float)
    except (TypeError, ValueError):
        vector = None
    if vector is None or vector.shape != (size,) or not np.isfinite(vector).all():
        from fuzzynav.resources import shorten

        raise ValueError(
            f"x0 = {shorten(repr(x0), 120)}: must be {size} finite numbers, one per "
            "design number of the controller"
        )
    return vector


def _free_indices(free, size: int) -> list[int] | None:
    """``free`` as a list of distinct indices of the vector (None: every number)."""
    if free is None:
        return None
    rule = f"must be distinct integers from 0 to {size - 1}, at least one"
    if isinstance(free, str | bytes) or not isinstance(free, Sequence | np.ndarray):
        raise ValueError(f"free = {free!r}: {rule}")
    indices = []
    for value in free:
        if isinstance(value, bool) or not isinstance(value, int | np.integer):
            raise ValueError(f"free = {list(free)!r}: {rule} ({value!r} is not an integer)")
        indices.append(int(value))
    if not indices or len(set(indices)) != len(indices) or not all(0 <= k < size for k in indices):
        raise ValueError(f"free = {indices!r}: {rule}")
    return indices


def _objective(tunable, costs, x0, free, control_period_s, clearance_weight) -> Any:
    """The vector's cost :func:`tune` minimises, of one of ``costs`` (a cost of a
    controller, of a population of them, or the runs' objective of cases) over the
    ``free`` indices, the rest at ``x0``."""
    cost, population_cost, cases = costs
    if sum(c is not None for c in costs) != 1:
        raise ValueError("tune: give a cost, a population_cost or cases (runs), one of them")
    base = x0 if free is not None else None
    if cases is not None:
        return Objective(
            tunable, list(cases), control_period_s, clearance_weight, base=base, free=free
        )
    return _ControllerCost(tunable, cost or population_cost, base=base, free=free)


def _population_mapper(objective, population_cost, method: str):
    """A map-like ``mapper(function, vectors) -> costs`` that builds a generation's
    controllers and prices them in one call of ``population_cost``."""
    if method not in ("cmaes", "de"):
        raise ValueError(f"population_cost: for cmaes and de, not {method!r}")

    def mapper(_function, vectors):
        controllers = [objective.tunable.build(objective.full(v)) for v in vectors]
        costs = [float(c) for c in population_cost(controllers)]
        if len(costs) != len(controllers):
            raise ValueError(
                f"population_cost: {len(costs)} costs for {len(controllers)} controllers"
            )
        return costs

    return mapper


def _batch_mapper(objective, start, executor, on_fallback):
    """The batch engine's mapper of a generation, or None (``on_fallback`` told why)."""
    from fuzzynav.app.experiments.batch_runs import batch_mapper

    stall_s = getattr(objective.tunable, "stall_cutoff_s", STALL_S)
    batched, reason = batch_mapper(objective, start, executor, outcome_cost, stall_s)
    if batched is None and on_fallback is not None:
        on_fallback(reason)
    return batched


def _search(
    objective, method, lo, hi, start, generations, popsize, seed, sigma0,
    executor, workers, batched, report, on_evaluation,
):  # fmt: skip
    """scipy's OptimizeResult of ``method`` over the box; ``report(step, best cost,
    best searched vector)`` after each generation or iteration."""

    def callback(intermediate_result):
        report(None, float(intermediate_result.fun), intermediate_result.x)

    if method == "de":
        return _differential_evolution(
            objective,
            lo,
            hi,
            start,
            batched=batched,
            executor=executor,
            workers=workers,
            seed=seed,
            maxiter=generations,
            popsize=popsize,
            callback=callback,
        )
    if method in ("nelder-mead", "powell"):
        return _local_search(objective, lo, hi, start, method, generations, callback, on_evaluation)
    if method == "cmaes":
        if batched is not None:
            mapper = batched
        elif executor is not None and executor.kind != "serial":
            mapper = executor.map
        elif executor is None and workers > 1:
            from fuzzynav.app.experiments.executor import LocalExecutor

            with LocalExecutor(workers) as pool:
                return _cmaes(
                    objective, lo, hi, start, sigma0, generations, popsize, seed, pool.map,
                    batched, report,
                )  # fmt: skip
        else:
            mapper = _serial_map
        return _cmaes(
            objective, lo, hi, start, sigma0, generations, popsize, seed, mapper, batched, report
        )
    raise ValueError(f"method = {method!r}: must be cmaes, de, nelder-mead or powell")


class _generation_reporter:
    """A context giving ``report(step, best cost, best searched vector)``: it keeps the
    history and tells ``progress`` (True: a bar on stderr) and ``on_generation``."""

    def __init__(self, progress, generations: int, objective, on_generation) -> None:
        if not (progress is None or isinstance(progress, bool) or callable(progress)):
            raise ValueError(f"progress = {progress!r}: True, False or a callable")
        self.progress, self.generations = progress, generations
        self.objective, self.on_generation = objective, on_generation
        self.history: list[float] = []
        self._bar: Any = None

    def __enter__(self):
        if self.progress is True:
            from rich.console import Console
            from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

            self._bar = Progress(
                TextColumn("generation {task.completed}/{task.total}"),
                BarColumn(),
                TextColumn("best cost {task.fields[best]}"),
                TimeElapsedColumn(),
                console=Console(stderr=True),
            ).__enter__()
            self._task = self._bar.add_task("tune", total=self.generations, best="-")
        return self

    def __call__(self, step, best_cost: float, best_vector) -> None:
        self.history.append(best_cost)
        step = len(self.history) if step is None else step
        if self.on_generation is not None:
            self.on_generation(step, best_cost, self.objective.full(best_vector))
        if self._bar is not None:
            self._bar.update(self._task, completed=step, best=f"{best_cost:.4f}")
        elif callable(self.progress):
            self.progress(step, best_cost)

    def __exit__(self, *exc: object) -> None:
        if self._bar is not None:
            self._bar.__exit__(*exc)
