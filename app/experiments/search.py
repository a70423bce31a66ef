"""``tune``'s search: differential evolution, CMA-ES or a local search over the objective.

The cost of a parameter vector and the runs it is made of are :mod:`.objective`'s; the
command (``fuzzynav tune``) that calls :func:`tune` is :mod:`.tuning`'s.

``method="de"`` (the default): ``scipy.optimize.differential_evolution`` runs with a fixed
seed, ``updating="deferred"``, ``polish=False`` and the starting vector in its initial
population; the cost of a generation is mapped over the executor (:mod:`.executor`) in
order, so the result does not depend on the executor or the number of workers.
``radius`` narrows every bound to the starting value +- radius times the bound's span (a
local DE around a vector that already works). ``method="cmaes"``: pycma's CMA-ES from
the starting vector (:mod:`.evolution`), never worse than it. ``method="nelder-mead"``
or ``"powell"``: ``scipy.optimize.minimize`` from the starting vector, within the
bounds, ``maxiter`` iterations (deterministic, one process).
"""

from __future__ import annotations

import math

import numpy as np

from fuzzynav.app.experiments.objective import (
    CLEARANCE_WEIGHT,
    STALL_S,
    Case,
    Objective,
    outcome_cost,
)


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
        objective, list(zip(lo, hi)), start, sigma0, maxiter, popsize, seed, mapper, report
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
    tunable,
    cases: list[Case],
    *,
    maxiter: int,
    popsize: int = 1,
    seed: int = 0,
    workers: int = 1,
    executor=None,
    on_generation=None,
    x0=None,
    control_period_s: float = 0.05,
    method: str = "de",
    free=None,
    radius: float | None = None,
    clearance_weight: float = CLEARANCE_WEIGHT,
    on_evaluation=None,
    sigma0: float = 0.15,
    engine: str = "pymunk",
    on_fallback=None,
):
    """Minimise the cost (module docstring); returns scipy's OptimizeResult with ``.x`` the
    tunable's WHOLE vector (also when ``free`` restricts the search), ``.fun``, ``.nfev``,
    ``.nit``. ``on_generation(step, best cost, best vector)`` is called after every DE
    generation or local-search iteration; ``on_evaluation(count, best cost so far)`` after
    every candidate of a local search (one process: Powell's iterations are long).
    ``executor`` (:mod:`app.experiments.executor`): where DE evaluates its population (a local
    search is sequential and runs here); without one, ``workers > 1`` is a local pool.
    ``engine="batch"``: DE and CMA-ES run each generation's candidates x cases as
    batches (:func:`app.experiments.batch_runs.batch_mapper`); a tunable whose controller cannot be
    batched uses the pymunk engine, and ``on_fallback(message)`` is told."""
    all_bounds = np.asarray(tunable.bounds(), float)
    x0 = np.asarray(tunable.initial_vector() if x0 is None else x0, float)
    x0 = np.clip(x0, all_bounds[:, 0], all_bounds[:, 1])
    objective = Objective(
        tunable,
        cases,
        control_period_s,
        clearance_weight,
        base=x0 if free is not None else None,
        free=free,
    )
    lo, hi, start = _search_box(all_bounds, x0, free, radius)
    generation = [0]
    batched = None
    if engine == "batch" and method in ("de", "cmaes"):
        from fuzzynav.app.experiments.batch_runs import batch_mapper

        stall_s = getattr(tunable, "stall_cutoff_s", STALL_S)
        batched, reason = batch_mapper(objective, start, executor, outcome_cost, stall_s)
        if batched is None and on_fallback is not None:
            on_fallback(reason)

    def callback(intermediate_result):
        generation[0] += 1
        if on_generation is not None:
            on_generation(
                generation[0], float(intermediate_result.fun), objective.full(intermediate_result.x)
            )

    def report(k, best_f, best_x, sigma):
        generation[0] = k
        if on_generation is not None:
            on_generation(k, best_f, objective.full(best_x))

    if method == "de":
        result = _differential_evolution(
            objective,
            lo,
            hi,
            start,
            batched=batched,
            executor=executor,
            workers=workers,
            seed=seed,
            maxiter=maxiter,
            popsize=popsize,
            callback=callback,
        )
    elif method in ("nelder-mead", "powell"):
        result = _local_search(objective, lo, hi, start, method, maxiter, callback, on_evaluation)
    elif method == "cmaes":
        if batched is not None:
            mapper = batched
        elif executor is not None and executor.kind != "serial":
            mapper = executor.map
        else:
            mapper = _serial_map
        result = _cmaes(
            objective, lo, hi, start, sigma0, maxiter, popsize, seed, mapper, batched, report
        )
    else:
        raise ValueError(f"method = {method!r}: must be de, cmaes, nelder-mead or powell")
    result.x = objective.full(result.x)
    result.fun = float(result.fun)
    result.nit = int(getattr(result, "nit", generation[0]))
    return result
