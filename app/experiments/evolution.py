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


class BoxCMA:
    """pycma's CMA-ES as ask/tell on the box ``bounds`` ((low, high) per parameter):
    the one wrapper of pycma, under :func:`cmaes` (fit-paper, ``tune``) and
    :class:`~fuzzynav.app.experiments.search.DesignSearch`.

    It searches in coordinates scaled to [0, 1] from ``x0`` (clipped into the box) with
    first step ``sigma0`` (a fraction of each bound's span); every candidate it asks
    for lies in the box. Seeded: the normal draws come from
    ``numpy.random.default_rng(seed)``, never numpy's global state. ``popsize``
    candidates a generation (at least 4). pycma's own stopping rules are never
    consulted: the caller's count of generations is the count.

    Raises
    ------
    ValueError
        ``sigma0`` outside :data:`SIGMA_RANGE` (NaN included).
    """

    def __init__(self, bounds, x0, sigma0: float, popsize: int, seed: int, maxiter=None):
        import cma

        if not (isinstance(sigma0, int | float) and SIGMA_RANGE[0] <= sigma0 <= SIGMA_RANGE[1]):
            raise ValueError(
                f"sigma0 = {sigma0!r}: must be a number from {SIGMA_RANGE[0]:g} to "
                f"{SIGMA_RANGE[1]:g}"
            )
        rng = np.random.default_rng(seed)
        self.low, self.high = np.array(bounds, dtype=float).T
        self.span = self.high - self.low
        start = np.clip((np.asarray(x0, float) - self.low) / self.span, 0.0, 1.0)
        options = {
            "bounds": [0.0, 1.0],
            "popsize": max(popsize, 4),
            "randn": lambda *shape: rng.standard_normal(shape),
            "seed": math.nan,  # pycma then seeds nothing: the draws are rng's alone
            "verbose": -9,  # no messages, no warnings printed
            "verb_disp": 0,
            "verb_log": 0,  # no outcmaes/ folder
        }
        if maxiter is not None:
            options["maxiter"] = maxiter
        if len(start) == 1:
            # pycma searches at least two dimensions; a second, unused coordinate
            # keeps a one-parameter search possible (the cost never sees it)
            start = np.append(start, 0.5)
        self._es = cma.CMAEvolutionStrategy(start, sigma0, options)
        self._asked = np.empty((0, len(start)))
        self.best_vector, self.best_cost = np.asarray(x0, float), math.inf
        self.generation = self.evaluations = 0

    @property
    def sigma(self) -> float:
        """The step now, in the scaled coordinates."""
        return float(self._es.sigma)

    def ask(self) -> np.ndarray:
        """This generation's candidates, one a row, each inside the box."""
        self._asked = np.asarray(self._es.ask(), dtype=float)
        return self.low + np.clip(self._asked[:, : len(self.low)], 0.0, 1.0) * self.span

    def tell(self, xs, values) -> None:
        """The costs of the candidates :meth:`ask` gave, in its order (NaN or inf: worst);
        keeps the best."""
        values = np.array(values, dtype=float)
        if len(xs) != len(self._asked) or len(values) != len(self._asked):
            raise ValueError(
                f"tell: {len(xs)} vectors and {len(values)} costs for the {len(self._asked)} asked"
            )
        ranked = np.where(np.isfinite(values), values, np.inf)  # a NaN is never the best
        k = int(np.argmin(ranked))
        if ranked[k] < self.best_cost:
            self.best_cost, self.best_vector = float(ranked[k]), np.array(xs[k], dtype=float)
        self._es.tell(list(self._asked), [v if math.isfinite(v) else 1e300 for v in values])
        self.generation += 1
        self.evaluations += len(values)


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
    """:class:`BoxCMA` for ``maxiter`` generations: ``pool_map(f, xs)`` evaluates a
    population (in order), e.g. a multiprocessing pool's map, or the batch engine's
    mapper. ``on_generation(generation, best cost, best x, sigma)`` after each
    generation. Returns (best x, best cost, generations, evaluations).

    Raises
    ------
    ValueError
        ``sigma0`` outside :data:`SIGMA_RANGE` (NaN included).
    """
    search = BoxCMA(bounds, x0, sigma0, popsize, seed, maxiter=maxiter)
    for generation in range(1, maxiter + 1):
        xs = search.ask()
        search.tell(xs, pool_map(cost, list(xs)))
        if on_generation is not None:
            on_generation(generation, search.best_cost, search.best_vector, search.sigma)
    return search.best_vector, search.best_cost, maxiter, search.evaluations


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
