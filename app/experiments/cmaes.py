"""A plain, seeded CMA-ES (covariance matrix adaptation evolution strategy) on a box.

For objectives that are expensive, non-smooth and of a few dozen parameters, such as
the cost of whole simulated runs: it needs far fewer evaluations than differential
evolution there (the paper fit went from no arriving run after 4 DE generations of 138
candidates to all three arriving within 30 generations of 16). Used by
``fuzzynav fit-paper`` and ``fuzzynav tune --method cmaes``.
"""

from __future__ import annotations

import math

import numpy as np

from fuzzynav.app.args import float_in


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
    """A plain (mu/mu_w, lambda)-CMA-ES (Hansen's tutorial, 2016) on the box ``bounds``,
    searching in coordinates scaled to [0, 1]; a candidate outside the box is evaluated
    at its projection plus a quadratic penalty, so the search stays in it. Seeded: the
    same arguments give the same result. ``pool_map(f, xs)`` evaluates a population
    (in order), e.g. a multiprocessing pool's map. Returns (best x, best cost, generations,
    evaluations).

    Raises
    ------
    ValueError
        ``sigma0`` outside :data:`SIGMA_RANGE` (NaN included).
    """
    if not (isinstance(sigma0, int | float) and SIGMA_RANGE[0] <= sigma0 <= SIGMA_RANGE[1]):
        raise ValueError(
            f"sigma0 = {sigma0!r}: must be a number from {SIGMA_RANGE[0]:g} to {SIGMA_RANGE[1]:g}"
        )
    rng = np.random.default_rng(seed)
    lo, hi = np.array(bounds, dtype=float).T
    span = hi - lo
    n = len(lo)
    lam = max(popsize, 4)
    mu = lam // 2
    weights = np.log(mu + 0.5) - np.log(np.arange(1, mu + 1))
    weights /= weights.sum()
    mueff = 1.0 / np.sum(weights**2)
    cc = (4 + mueff / n) / (n + 4 + 2 * mueff / n)
    cs = (mueff + 2) / (n + mueff + 5)
    c1 = 2 / ((n + 1.3) ** 2 + mueff)
    cmu = min(1 - c1, 2 * (mueff - 2 + 1 / mueff) / ((n + 2) ** 2 + mueff))
    damps = 1 + 2 * max(0.0, math.sqrt((mueff - 1) / (n + 1)) - 1) + cs
    chi_n = math.sqrt(n) * (1 - 1 / (4 * n) + 1 / (21 * n * n))
    mean = (np.asarray(x0, float) - lo) / span
    sigma = sigma0
    pc, ps = np.zeros(n), np.zeros(n)
    B, D, C = np.eye(n), np.ones(n), np.eye(n)
    best_x, best_f, evaluations = np.asarray(x0, float), math.inf, 0
    for generation in range(1, maxiter + 1):
        z = rng.standard_normal((lam, n))
        y = z @ (B * D).T
        unit = mean + sigma * y
        inside = np.clip(unit, 0.0, 1.0)
        xs = lo + inside * span
        values = np.array(pool_map(cost, list(xs)), dtype=float)
        values += 1e3 * np.sum((unit - inside) ** 2, axis=1)  # outside the box
        evaluations += lam
        order = np.argsort(values, kind="stable")
        if values[order[0]] < best_f:
            best_f, best_x = float(values[order[0]]), xs[order[0]].copy()
        y_w = weights @ y[order[:mu]]
        mean = mean + sigma * y_w
        c_inv_sqrt = B @ np.diag(1 / D) @ B.T
        ps = (1 - cs) * ps + math.sqrt(cs * (2 - cs) * mueff) * (c_inv_sqrt @ y_w)
        hsig = np.linalg.norm(ps) / math.sqrt(
            1 - (1 - cs) ** (2 * generation)
        ) / chi_n < 1.4 + 2 / (n + 1)
        pc = (1 - cc) * pc + hsig * math.sqrt(cc * (2 - cc) * mueff) * y_w
        artmp = y[order[:mu]]
        C = (
            (1 - c1 - cmu) * C
            + c1 * (np.outer(pc, pc) + (not hsig) * cc * (2 - cc) * C)
            + cmu * (artmp.T * weights) @ artmp
        )
        sigma *= math.exp((cs / damps) * (np.linalg.norm(ps) / chi_n - 1))
        C = np.triu(C) + np.triu(C, 1).T
        eigenvalues, B = np.linalg.eigh(C)
        D = np.sqrt(np.maximum(eigenvalues, 1e-20))
        if on_generation is not None:
            on_generation(generation, best_f, best_x, sigma)
    return best_x, best_f, maxiter, evaluations


#: The first step CMA-ES accepts, as a fraction of each bound's span: below it the
#: search never moves, above it every candidate lands on a bound.
SIGMA_RANGE = (1e-6, 1.0)


def add_sigma_option(parser) -> None:
    """``--sigma``: CMA-ES's first step, for the commands that offer it."""

    parser.add_argument(
        "--sigma",
        # a fraction of the span: 0, a negative step or NaN ran every generation at cost
        # inf and wrote its file (issue 26)
        type=float_in(SIGMA_RANGE[0], SIGMA_RANGE[1]),
        default=0.15,
        metavar="FRACTION",
        help="cmaes: the first step, a fraction of each bound's span (default 0.15)",
    )
