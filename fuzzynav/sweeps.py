"""Sweeps from Python: :func:`sweep` and its rows (:class:`SweepRow`).

Part of :mod:`fuzzynav.api` (which re-exports both); the command line's ``fuzzynav
sweep`` runs the same studies (:mod:`fuzzynav.app.experiments.studies`).
"""

from __future__ import annotations

import contextlib
import logging
import warnings
from collections.abc import Callable, Iterator, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, TypeAlias, TypedDict, cast

from fuzzynav.controller.checker import check_controller
from fuzzynav.controller.interface import Controller, ControllerFunction
from fuzzynav.world.run_limits import Outcome
from fuzzynav.world.scenario import Scenario

if TYPE_CHECKING:
    from fuzzynav.app.experiments.executor import Executor
    from fuzzynav.app.experiments.resultlog import ResultLog
    from fuzzynav.app.experiments.studies import LayoutJob

__all__ = ["SweepRow", "sweep"]

#: What a sweep has to say besides its rows goes to the ``fuzzynav`` logger (silent
#: unless the program configures logging); a fallback to the pymunk engine is a warning.
_LOG = logging.getLogger("fuzzynav")
_LOG.addHandler(logging.NullHandler())

#: What ``scenarios`` takes: a scenario file, a folder of them, a shipped name, a
#: Scenario, or a list of any of these.
ScenarioSource: TypeAlias = str | Path | Scenario
Scenarios: TypeAlias = ScenarioSource | Sequence[ScenarioSource]


class SweepRow(TypedDict, total=False):
    """One run of a sweep, as ``fuzzynav sweep --out`` writes it (a number that does not
    apply, such as the time to target of a run that never arrived, is None).

    The study: ``index``, ``controller``, ``parts_off``, ``family`` (``set:...`` for
    scenarios of one's own), ``seed``, ``perception``, ``options`` (only when not the
    defaults) and ``fingerprint`` (what made it). The run: ``outcome``, ``reached``,
    ``collided``, ``success`` (reached without collision), the path and clearances in
    metres, the time to target in seconds, and the benchmark ratios against the
    shortest path that keeps the clearance.
    """

    index: int
    controller: str
    parts_off: list[str]
    family: str
    seed: int
    perception: str
    options: dict[str, object]
    fingerprint: str
    outcome: Outcome
    reached: bool
    collided: bool
    success: bool
    path_length_m: float | None
    straight_line_m: float
    straight_ratio: float | None
    min_clearance_m: float | None
    min_safety_distance_m: float | None
    time_to_target_s: float | None
    n_obstacles: int
    shortest_path_m: float | None
    path_ratio: float | None
    optimal_time_s: float | None
    time_ratio: float | None
    score: float | None


def sweep(
    controller: str | Controller | ControllerFunction = "paper",
    n: int | None = None,
    seed: int | None = None,
    family: str = "standard",
    perception: str = "ideal",
    geometry: str = "husky",
    *,
    scenarios: Scenarios | None = None,
    workers: int = 1,
    executor: str | None = None,
    scheduler: str | None = None,
    progress: Callable[[int, int], None] | None = None,
    engine: str = "batch",
    out: str | Path | None = None,
    resume: bool = False,
) -> list[SweepRow]:
    """Run ``controller`` on ``n`` seeded random layouts of ``family``, or on ``scenarios``.

    Parameters
    ----------
    controller : str or controller object
        A registered name (``fuzzynav sweep --help`` lists them; a controller of your
        own joins with :func:`fuzzynav.register_controller`), ``"module:factory"``, a
        controller object (a copy drives each run; it must pickle to run in worker
        processes), or one plain function as :func:`fuzzynav.simulate` takes it (a
        vectorised one runs on the batch engine as it is).
    n : int, optional
        How many layouts (layouts 0 .. n - 1 of the family and seed); default the
        command line's (``fuzzynav sweep --n``). Not with ``scenarios``.
    seed : int, optional
        The layouts' seed (the same seed gives the same layouts everywhere); default the
        command line's. Not with ``scenarios``.
    family : str
        The layout family (``"standard"``, ``"clutter"``, ...; see ``fuzzynav sweep
        --help``).
    perception, geometry : str
        As :func:`fuzzynav.simulate`.
    scenarios : str, Path, Scenario or list of them, optional
        Run these instead of generated layouts: a scenario file, a folder of scenario
        files (``*.toml``, in name order), a shipped scenario's name, a
        :class:`~fuzzynav.world.scenario.Scenario` (validated as a file is), or a list of
        any of these. Rows are in their order; their ``family`` is ``set:`` and the
        set's digest.
    workers : int
        Processes (or dask threads) to spread the runs over; 1 with no ``executor``:
        this process.
    executor : {"serial", "local", "dask"}, optional
        Where the runs go (``fuzzynav sweep --executor``); default ``serial`` for one
        worker, else ``local``.
    scheduler : str, optional
        A dask scheduler's address (``executor="dask"`` only).
    progress : callable, optional
        Called as ``progress(done, total)`` at the start and as rows arrive: after
        each run on the pymunk engine, after each batch of runs (up to a few hundred,
        finishing together) on the batch engine.
    engine : {"batch", "pymunk"}
        ``batch``: the runs in lockstep as numpy arrays (world/batch.py; the command
        line's default); ``pymunk``: one world at a time, the reference. Controllers the
        batch engine cannot drive (fuzzynav's, one of yours without ``batched``) run on
        pymunk.
    out : str or Path, optional
        Write every row to this JSON-lines file as it finishes (``--out``): an existing
        file is refused unless ``resume``.
    resume : bool
        Keep the rows already in ``out`` and run only the others (``--resume``).

    Returns
    -------
    list of dict
        One row per run, in layout (or scenario) order: the fields ``fuzzynav sweep
        --out`` writes (index, outcome, success, path_length_m, min_clearance_m,
        time_to_target_s, shortest_path_m, ...). A number that does not apply is None.
    """
    from fuzzynav.app.experiments.studies import run_jobs

    if not isinstance(controller, str):
        from fuzzynav.controller.function import as_controller

        controller = as_controller(controller)  # a plain function is a controller too
        check_controller(controller)  # every problem named before a run starts
    jobs = _jobs(controller, n, seed, family, perception, geometry, scenarios)
    with _study_runner(executor, workers, scheduler, out, resume, jobs) as (runner, log):
        rows = run_jobs(
            jobs, runner, log=log, progress=progress, engine=engine, on_fallback=_warn_fallback
        )
    if log is not None and log.dropped_partial_line:
        _LOG.warning("%s: an unfinished last line was dropped and run again", log.shown)
    return cast(list[SweepRow], rows)


def _warn_fallback(message: str) -> None:
    """A study the batch engine cannot drive runs on pymunk: said, as the command line says it."""
    warnings.warn(message, UserWarning, stacklevel=2)


def _jobs(
    controller: str | Controller | ControllerFunction,
    n: int | None,
    seed: int | None,
    family: str,
    perception: str,
    geometry: str,
    scenarios: Scenarios | None,
) -> Sequence[LayoutJob]:
    """The jobs of :func:`sweep`'s study, every argument checked as the command line's."""
    from fuzzynav.app.args import integer_value
    from fuzzynav.app.experiments import sweep as sweep_command
    from fuzzynav.app.experiments.studies import sweep_jobs
    from fuzzynav.app.experiments.study_sources import scenario_list, scenario_set_jobs
    from fuzzynav.world.layouts import generate_layout

    options = {} if geometry == "husky" else {"geometry": geometry}
    if scenarios is not None:
        if n is not None or seed is not None:
            raise ValueError("n, seed: the layouts' count and seed; not with scenarios")
        footprint = (0.0, 0.0) if geometry == "paper" else None
        return scenario_set_jobs(
            scenario_list(scenarios, footprint), controller, perception, options
        )
    n = sweep_command.DEFAULT_N if n is None else n
    seed = sweep_command.DEFAULT_SEED if seed is None else seed
    integer_value(seed, "seed", 0)  # as --seed
    if isinstance(controller, str):
        sweep_command.check_sweep(controller, n, family)
        return sweep_jobs(controller, n, seed, family, perception, (), options)
    sweep_command.check_sweep("p", n, family)  # n and family, as --n and --family
    layouts = (generate_layout(family, seed, i) for i in range(n))
    return scenario_set_jobs(layouts, controller, perception, options)


@contextlib.contextmanager
def _study_runner(
    kind: str | None,
    workers: int,
    scheduler: str | None,
    out: str | Path | None,
    resume: bool,
    jobs: Sequence[LayoutJob],
) -> Iterator[tuple[Executor, ResultLog | None]]:
    """(executor, result log or None) for a study from Python, closed after it."""
    from fuzzynav.app.experiments.executor import make_executor
    from fuzzynav.app.experiments.resultlog import ResultLog
    from fuzzynav.app.experiments.rows import check_row, describe_row, row_key
    from fuzzynav.safe_files import check_output_path

    if resume and out is None:
        raise ValueError("resume: give out, the .jsonl file to resume")
    kind = kind or ("local" if workers > 1 else "serial")
    with contextlib.ExitStack() as stack:
        log = None
        if out is not None:
            check_output_path(out, "out", stream_ok=False)
            log = ResultLog(out, resume=resume, key=row_key, check_row=check_row)
            log.check_belongs({job.key() for job in jobs}, describe_row)
            stack.enter_context(log)
        executor = make_executor(kind, workers=workers, scheduler=scheduler)
        stack.callback(executor.close)
        yield executor, log
