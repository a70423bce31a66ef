"""A population of controllers on many layouts at once: :func:`evaluate`.

Part of :mod:`fuzzynav.api` (which re-exports it). Every candidate x layout run goes
to the lockstep batch engine (:mod:`fuzzynav.world.batch`) in batches of many
candidates, as ``fuzzynav tune --engine batch`` evaluates a generation; controllers it
cannot drive run one at a time on the pymunk engine, with a warning.
"""

from __future__ import annotations

import math
import numbers
import warnings
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt

from fuzzynav.world.scenario import Scenario

if TYPE_CHECKING:
    from fuzzynav.sweeps import Scenarios

__all__ = ["Evaluation", "evaluate"]

#: Runs per batch at most: a batch's arrays stay small, and ``progress`` moves.
BATCH_RUNS = 1000


@dataclass(frozen=True)
class Evaluation:
    """What :func:`evaluate` measured: one run per candidate and layout.

    Attributes
    ----------
    metrics : list of list of dict
        ``metrics[i][j]``: candidate ``i`` on layout ``j``, the run's metrics with
        ``run.result.metrics``' keys (``outcome``, ``reached``, ``collided``,
        ``path_length_m``, ``min_clearance_m``, ``time_to_target_s``, ``steps``, ...;
        None for a number that does not apply; no wall time).
    costs : numpy.ndarray or None
        (candidates, layouts): ``cost(metrics[i][j])``; None without a ``cost``.
    scenarios : list of Scenario
        The layouts, in order.
    engines : list of str
        Per candidate, the engine that ran it: ``"batch"`` or ``"pymunk"``.
    """

    metrics: list[list[dict[str, Any]]]
    costs: npt.NDArray[np.float64] | None
    scenarios: list[Scenario]
    engines: list[str]

    @property
    def success(self) -> npt.NDArray[np.bool_]:
        """(candidates, layouts): reached the target without a collision."""
        return np.array(
            [[bool(m["reached"] and not m["collided"]) for m in row] for row in self.metrics],
            dtype=bool,
        ).reshape(len(self.metrics), len(self.scenarios))

    @property
    def mean_costs(self) -> npt.NDArray[np.float64]:
        """Per candidate, the mean of its costs over the layouts (lower is better)."""
        if self.costs is None:
            raise ValueError("mean_costs: evaluate was given no cost")
        return np.asarray(self.costs.mean(axis=1), dtype=np.float64)


def evaluate(
    controllers: Sequence[object],
    layouts: int | Scenarios = 30,
    cost: Callable[[Mapping[str, Any]], float] | None = None,
    *,
    family: str = "standard",
    seed: int | None = None,
    start: int = 0,
    perception: str = "ideal",
    geometry: str = "husky",
    control_period_s: float = 0.02,
    progress: bool | Callable[[int, int], None] = False,
) -> Evaluation:
    """Run every controller on every layout, candidates batched together.

    Parameters
    ----------
    controllers : sequence of controller objects
        The candidates (e.g. :meth:`fuzzynav.app.experiments.search.DesignSearch.build`
        of each vector a search asks for), or registered names. Candidates of one kind
        (and, for fuzzy ones, one rule structure) share batches.
    layouts : int, or scenarios
        An int: that many seeded layouts of ``family`` (``start``, ``start + 1``, ...),
        as :func:`fuzzynav.sweep` makes them; or what ``sweep``'s ``scenarios`` takes
        (names, files, a folder, :class:`~fuzzynav.world.scenario.Scenario` objects, a
        list of them).
    cost : callable, optional
        ``cost(metrics) -> float`` of one run (lower is better); fills ``costs``.
    family, seed, start : str, int, int
        The generated layouts' family, seed (default ``fuzzynav sweep``'s) and first
        index; the runs' sensor noise is seeded with ``seed`` as a sweep's (0 for
        scenarios).
    perception, geometry : str
        As :func:`fuzzynav.simulate`.
    control_period_s : float
        The controllers' period, s.
    progress : bool or callable
        True: a progress bar on stderr; a callable: ``progress(done, total)`` runs
        after each batch.

    Returns
    -------
    Evaluation
        ``metrics[i][j]`` and ``costs[i, j]`` of candidate ``i`` on layout ``j``: equal to
        ``simulate(scenarios[j], controllers[i], seed=...)``'s (the engines agree to
        rounding, about 1e-14 m).
    """
    from fuzzynav.controller.registry import make_controller

    if isinstance(controllers, str) or not isinstance(controllers, Sequence):
        raise ValueError("controllers: a list of controllers (or names), one per candidate")
    if not controllers:
        raise ValueError("controllers: none given")
    if cost is not None and not callable(cost):
        raise TypeError(f"cost = {cost!r}: not callable (cost(metrics) -> float of one run)")
    candidates = [
        make_controller(c, geometry=geometry) if isinstance(c, str) else c for c in controllers
    ]
    scenarios, run_seed = _layouts(layouts, family, seed, start, geometry)
    options = {
        "perception": perception,
        "geometry": geometry,
        "control_period_s": control_period_s,
        "seed": run_seed,
    }
    metrics: list[list[dict[str, Any]]] = [[] for _ in candidates]
    engines = ["batch"] * len(candidates)
    total = len(candidates) * len(scenarios)
    with _reporter(progress, total) as report:
        for group, batchable in _groups(candidates):
            if not batchable:
                for k in group:
                    engines[k] = "pymunk"
                    metrics[k] = _pymunk_metrics(candidates[k], scenarios, options, report)
                continue
            for k, found in _batch_metrics(candidates, group, scenarios, options, report):
                metrics[k] = found
    costs = None
    if cost is not None:
        costs = np.array([[_cost_of(cost, m) for m in row] for row in metrics], dtype=np.float64)
    return Evaluation(metrics, costs, scenarios, engines)


def _cost_of(cost: Callable[[Mapping[str, Any]], float], metrics: Mapping[str, Any]) -> float:
    """``cost(metrics)`` as a float; ValueError naming what it returned otherwise."""
    value = cost(metrics)
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        from fuzzynav.resources import shorten

        raise ValueError(
            f"cost returned {shorten(repr(value), 80)}: must return a real number (lower is better)"
        )
    return float(value)


def _layouts(
    layouts: int | Scenarios, family: str, seed: int | None, start: int, geometry: str
) -> tuple[list[Scenario], int]:
    """The scenarios of ``layouts`` and the runs' noise seed, checked as sweep's."""
    from fuzzynav.app.args import integer_value
    from fuzzynav.app.experiments import sweep as sweep_command
    from fuzzynav.app.experiments.study_sources import scenario_list
    from fuzzynav.world.layouts import generate_layout

    if isinstance(layouts, numbers.Integral) and not isinstance(layouts, bool):
        layouts = int(layouts)
        seed = sweep_command.DEFAULT_SEED if seed is None else seed
        integer_value(seed, "seed", 0)
        integer_value(start, "start", 0)
        sweep_command.check_sweep("p", layouts, family)  # the count and family, as --n
        return [generate_layout(family, seed, start + i) for i in range(layouts)], seed
    if isinstance(layouts, bool | numbers.Number):
        raise ValueError(
            f"layouts = {layouts!r}: an integer (how many layouts) or scenarios (names, "
            "files, a folder, Scenario objects, a list of them)"
        )
    if seed is not None or start:
        raise ValueError("seed, start: for generated layouts (an int); not with scenarios")
    footprint = (0.0, 0.0) if geometry == "paper" else None
    return scenario_list(layouts, footprint), 0


def _groups(candidates: list[object]) -> list[tuple[list[int], bool]]:
    """The candidates' indices by kind, and whether the batch engine drives that kind;
    a kind that cannot be batched is warned of."""
    from fuzzynav.controller.batch import NotBatchable, batch_controller

    kinds: dict[type, list[int]] = {}
    for k, candidate in enumerate(candidates):
        kinds.setdefault(type(candidate), []).append(k)
    out = []
    for group in kinds.values():
        try:
            batch_controller([candidates[k] for k in group], np.arange(len(group)))
        except NotBatchable as exc:
            warnings.warn(
                f"fuzzynav.evaluate: {exc}: its {len(group)} candidates run on the pymunk "
                "engine, one run at a time",
                RuntimeWarning,
                stacklevel=3,
            )
            out.append((group, False))
            continue
        out.append((group, True))
    return out


def _batch_metrics(candidates, group, scenarios, options, report):
    """(candidate index, its metrics per layout) of ``group`` on the batch engine, in
    batches of at most :data:`BATCH_RUNS` runs (whole candidates when they fit)."""
    from fuzzynav.controller.batch import batch_controller
    from fuzzynav.world.batch import run_batch

    per_batch = max(1, BATCH_RUNS // len(scenarios))
    n_batches = math.ceil(len(group) / per_batch)
    per_batch = math.ceil(len(group) / n_batches)  # evened out
    for first in range(0, len(group), per_batch):
        part = group[first : first + per_batch]
        run_sets = np.repeat(np.arange(len(part)), len(scenarios))
        result = run_batch(
            [s for _ in part for s in scenarios],
            batch_controller([candidates[k] for k in part], run_sets),
            perception=options["perception"],
            geometry=options["geometry"],
            control_period_s=options["control_period_s"],
            seeds=options["seed"],
        )
        report(len(run_sets))
        for p, k in enumerate(part):
            yield k, [result.metrics(p * len(scenarios) + j) for j in range(len(scenarios))]


def _pymunk_metrics(candidate, scenarios, options, report) -> list[dict[str, Any]]:
    """The candidate's metrics per scenario, one run at a time (as :func:`simulate`)."""
    import copy

    from fuzzynav.app.runs import build_simulation

    found = []
    for scenario in scenarios:
        sim = build_simulation(
            scenario,
            "paper",
            perception=options["perception"],
            seed=options["seed"],
            control_period_s=options["control_period_s"],
            controller_object=copy.deepcopy(candidate),
            geometry=options["geometry"],
        )
        metrics = dict(sim.run().metrics)
        metrics.pop("wall_time_s", None)  # as the batch engine's: no wall time per run
        found.append(metrics)
        report(1)
    return found


class _reporter:
    """A context giving ``report(runs)``: the runs just finished, to a rich progress bar
    (``progress=True``), the user's ``progress(done, total)``, or nowhere."""

    def __init__(self, progress: bool | Callable[[int, int], None], total: int) -> None:
        self._progress, self._total, self._done = progress, total, 0
        self._bar: Any = None

    def __enter__(self) -> Callable[[int], None]:
        if self._progress is True:
            from fuzzynav.app.experiments.studies import progress_bar

            self._bar = progress_bar("evaluate", quiet=False).__enter__()
            self._task = self._bar.add_task("runs", total=self._total)
        elif callable(self._progress):
            self._progress(0, self._total)
        elif self._progress is not False and self._progress is not None:
            raise ValueError(f"progress = {self._progress!r}: True, False or a callable")
        return self._report

    def _report(self, runs: int) -> None:
        self._done += runs
        if self._bar is not None:
            self._bar.update(self._task, completed=self._done)
        elif callable(self._progress):
            self._progress(self._done, self._total)

    def __exit__(self, *exc: object) -> None:
        if self._bar is not None:
            self._bar.__exit__(*exc)
