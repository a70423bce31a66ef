"""CMA-ES (covariance matrix adaptation evolution strategy) on a box: pycma's, seeded.

For objectives that are expensive, non-smooth and of a few dozen parameters, such as
the cost of whole simulated runs: it needs far fewer evaluations than differential
evolution there (the paper fit went from no arriving run after 4 DE generations of 138
candidates to all three arriving within 30 generations of 16). Used by
``fuzzynav fit-paper`` and ``fuzzynav tune --method cmaes``.

The strategy is pycma's (``cma``, Hansen's reference implementation: its step-size and
covariance updates, its boundary handling); this module only fixes what fuzzynav's
commands promise of it: coordinates scaled to the box, a seed that repeats a search
exactly and never touches numpy's global random state, ``popsize`` candidates a
generation evaluated through the caller's map (a pool's, a cluster's or the batch
engine's), and exactly ``maxiter`` generations (pycma's own stopping rules are not
consulted: the command's count is the count).
"""

from __future__ import annotations

import math

import numpy as np

from fuzzynav.app.args import float_in

#: The first step CMA-ES accepts, as a fraction of each bound's span: below it the
#: search never moves, above it every candidate lands on a bound.
SIGMA_RANGE = (1e-6, 1.0)


def cmaes(
    cost,
    bounds,
    x0,
    sigma0: float,
    maxiter: int,
    popsize: int,
    seed: int,
    pool_map,
    on_generation=None,
):
    """pycma's CMA-ES on the box ``bounds`` ((low, high) per parameter), from ``x0`` with
    first step ``sigma0`` (a fraction of each bound's span), searching in coordinates
    scaled to [0, 1]; pycma's boundary transformation keeps every candidate inside the
    box, so ``cost`` is only ever called there. ``max(popsize, 4)`` candidates a
    generation, ``maxiter`` generations. Seeded: the same arguments give the same result
    (the normal draws come from ``numpy.random.default_rng(seed)``, not from numpy's
    global state). ``pool_map(f, xs)`` evaluates a population (in order), e.g. a
    multiprocessing pool's map. ``on_generation(generation, best cost, best x, sigma)``
    after each generation. Returns (best x, best cost, generations, evaluations).

    Raises
    ------
    ValueError
        ``sigma0`` outside :data:`SIGMA_RANGE` (NaN included).
    """
    import cma

    if not (isinstance(sigma0, int | float) and SIGMA_RANGE[0] <= sigma0 <= SIGMA_RANGE[1]):
        raise ValueError(
            f"sigma0 = {sigma0!r}: must be a number from {SIGMA_RANGE[0]:g} to {SIGMA_RANGE[1]:g}"
        )
    rng = np.random.default_rng(seed)
    lo, hi = np.array(bounds, dtype=float).T
    span = hi - lo
    n = len(lo)
    lam = max(popsize, 4)
    start = np.clip((np.asarray(x0, float) - lo) / span, 0.0, 1.0)
    options = {
        "bounds": [0.0, 1.0],
        "popsize": lam,
        "randn": lambda *shape: rng.standard_normal(shape),
        "seed": math.nan,  # pycma then seeds nothing: the draws are rng's alone
        "maxiter": maxiter,
        "verbose": -9,  # no messages, no warnings printed
        "verb_disp": 0,
        "verb_log": 0,  # no outcmaes/ folder
    }
    if n == 1:
        # pycma searches at least two dimensions; a second, unused coordinate
        # keeps a one-parameter search possible (the cost never sees it)
        start = np.append(start, 0.5)
    es = cma.CMAEvolutionStrategy(start, sigma0, options)
    best_x, best_f, evaluations = np.asarray(x0, float), math.inf, 0
    for generation in range(1, maxiter + 1):
        unit = np.asarray(es.ask(), dtype=float)
        xs = lo + np.clip(unit[:, :n], 0.0, 1.0) * span
        values = np.array(pool_map(cost, list(xs)), dtype=float)
        evaluations += len(xs)
        k = int(np.argmin(values))
        if values[k] < best_f:
            best_f, best_x = float(values[k]), xs[k].copy()
        es.tell(list(unit), [v if math.isfinite(v) else 1e300 for v in values])
        if on_generation is not None:
            on_generation(generation, best_f, best_x, float(es.sigma))
    return best_x, best_f, maxiter, evaluations


def add_sigma_option(parser) -> None:
    """``--sigma``: CMA-ES's first step, for the commands that offer it."""

    parser.add_argument(
        "--sigma",
        # a fraction of the span: 0, a negative step or NaN ran every generation at cost
        # inf and wrote its file
        type=float_in(SIGMA_RANGE[0], SIGMA_RANGE[1]),
        default=0.15,
        metavar="FRACTION",
        help="cmaes: the first step, a fraction of each bound's span (default 0.15)",
    )
