"""Studies on the lockstep batch engine (:mod:`world.batch`): sweeps' rows, executor
tasks, and the Python entry point a notebook calls.

``--engine batch`` (the default of ``sweep``, ``compare``, ``tune`` and ``fit-paper``)
puts a study's runs into batches of up to :data:`MAX_BATCH` runs; each batch is one
executor task (:func:`run_task`), so batches spread over a local pool or a Dask
cluster as single runs do. A row depends only on its job: the batch engine computes
every run's numbers row by row (no operation mixes runs), so a run gives the same bits
whatever batch it is in, and ``--resume`` and any number of workers give the same
rows (tests/test_batch.py).

Controllers the batch engine cannot drive (the registry's ``batchable`` flag lists
the ones it can) run on the pymunk engine, one task per run, and the command says so.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Iterable, Sequence

import numpy as np

#: Runs per batch task at most: a batch's arrays stay in the cache's neighbourhood, and
#: Ctrl-C loses at most one batch per worker (its rows come back when it ends).
MAX_BATCH = 500
#: Runs per batch task at least (when there are that many): below it, a step's fixed
#: cost (a few hundred numpy calls) outweighs the runs it advances.
MIN_BATCH = 100
#: The options of app.runs.build_simulation a batch takes.
_RUN_OPTIONS = ("geometry", "control_period_s", "sensor_noise_std_m", "field_of_view_deg")


def not_batchable_reason(
    controller: str, parts_off=(), options=None, controller_object=None
) -> str | None:
    """Why ``controller`` (a registry name, or ``controller_object``, a controller)
    cannot run on the batch engine, or None."""
    from fuzzynav.controller.interface import capabilities
    from fuzzynav.controller.registry import controller_entry, controller_names

    options = dict(options or {})
    if controller_object is not None:
        batchable = "batch" in capabilities(controller_object)
    else:
        batchable = controller_entry(controller).batchable
    if not batchable:
        return (
            f"controller {controller!r} cannot be batched (the batch engine drives "
            f"{', '.join(controller_names(batchable=True))}: stateless controllers; "
            "fuzzynav's navigator keeps a memory and plans)"
        )
    if parts_off:
        return f"parts_off {list(parts_off)}: only fuzzynav has parts to switch off"
    unknown = sorted(set(options) - set(_RUN_OPTIONS))
    if unknown:
        return f"options {unknown}: the batch engine takes {', '.join(_RUN_OPTIONS)}"
    return None


def _scenario(job):
    from fuzzynav.world.layouts import generate_layout

    scenario = job.scenario or generate_layout(job.family, job.seed, job.index)
    field = dict(job.options).get("field_of_view_deg")
    return scenario if field is None else scenario.replace(field_of_view_deg=field)


def layout_row(job, scenario, metrics: dict, model, voltage_limit_v: float) -> dict:
    """The row of ``job`` from its run's ``metrics`` (:func:`world.metrics.compute_metrics`
    keys): one function for both engines (pymunk and :mod:`world.batch`)."""
    from types import SimpleNamespace

    from fuzzynav.app.experiments.resultlog import finite_or_none

    m = metrics
    options = dict(job.options)
    straight = math.dist(scenario.start, scenario.target)
    run = SimpleNamespace(scenario=scenario, metrics=m, geometry=options.get("geometry", "husky"))
    row = {
        "index": job.index,
        "controller": job.controller,
        "parts_off": list(job.parts_off),
        "family": job.family,
        "scenario": scenario_label(scenario),
        "seed": job.seed,
        "perception": job.perception,
        **({"options": options} if options else {}),
        # what made it, computed where it ran: a worker with another version or rule
        # base gives rows the study refuses (experiments.run_jobs)
        "fingerprint": job.fingerprint(),
        "outcome": m["outcome"],
        "reached": bool(m["reached"]),
        "collided": bool(m["collided"]),
        "success": bool(m["reached"] and not m["collided"]),
        "path_length_m": m["path_length_m"],
        "straight_line_m": straight,
        "straight_ratio": m["path_length_m"] / straight,
        "min_clearance_m": m["min_clearance_m"],
        "min_safety_distance_m": m.get("min_safety_distance_m", m["min_clearance_m"]),
        "time_to_target_s": m["time_to_target_s"],
        "n_obstacles": len(scenario.obstacles),
        **run_benchmark(run, model, voltage_limit_v),
    }
    return finite_or_none(row)


def scenario_label(scenario) -> str:
    """A row's name for its scenario: a scenario file's stem (``s1`` for the shipped
    s1), else the scenario's own name (a generated layout's ``standard #3 (seed 1)``)."""
    from pathlib import Path

    source = str(getattr(scenario, "source", "") or "")
    label = Path(source).stem if source.endswith(".toml") else scenario.name
    return (label or "(unnamed)")[:200]  # a name, as rows.check_row reads it back


def run_benchmark(result, model, voltage_limit_v: float) -> dict:
    """The benchmark metrics of a finished run (world/metrics.py): the shortest path
    of its scenario keeping the clearance, for ``model``'s footprint width, and that
    plant's top speed at ``voltage_limit_v``."""
    from fuzzynav.world.metrics import benchmark_metrics, top_speed_mps
    from fuzzynav.world.shortest_path import robot_shortest_path_m

    sc = result.scenario
    m = result.metrics
    # the paper's geometry drives a point robot: the clearance alone inflates obstacles
    point = getattr(result, "geometry", "husky") == "paper"
    width_m = 0.0 if point else model.parameters.footprint_width_m
    shortest = robot_shortest_path_m(sc.start, sc.target, sc.obstacles, width_m)
    return benchmark_metrics(
        success=bool(m["reached"] and not m["collided"]),
        path_length_m=m["path_length_m"],
        time_to_target_s=m["time_to_target_s"],
        shortest_path_m=shortest,
        top_speed_mps=top_speed_mps(model, voltage_limit_v),
    )


def run_layout_batch(jobs: Sequence) -> list[dict]:
    """The rows of ``jobs`` (:class:`app.experiments.studies.LayoutJob`, one controller,
    perception and options), run together on the batch engine; in the jobs' order.
    Top level: what an executor sends to a worker."""
    from fuzzynav.controller.batch import batch_controller
    from fuzzynav.controller.registry import make_controller
    from fuzzynav.world.batch import run_batch
    from fuzzynav.world.husky import HuskyModel
    from fuzzynav.world.sensors import SensorConfig

    jobs = list(jobs)
    first = jobs[0]
    study = (first.controller, first.perception, first.parts_off, first.options)
    for job in jobs:
        if (job.controller, job.perception, job.parts_off, job.options) != study:
            raise ValueError(f"one batch runs one study: {job} differs from {first}")
    reason = not_batchable_reason(
        first.controller, first.parts_off, dict(first.options), first.controller_object
    )
    if reason is not None:
        raise ValueError(reason)
    options = dict(first.options)
    geometry = options.get("geometry", "husky")
    scenarios = [_scenario(job) for job in jobs]
    model = HuskyModel.default()
    result = run_batch(
        scenarios,
        batch_controller(
            make_controller(first.controller, geometry=geometry)
            if first.controller_object is None
            else first.controller_object
        ),
        perception=first.perception,
        geometry=geometry,
        seeds=[job.seed for job in jobs],
        model=model,
        control_period_s=options.get("control_period_s", 0.02),
        sensor_config=SensorConfig(noise_std_m=options.get("sensor_noise_std_m", 0.0)),
    )
    return [
        layout_row(job, scenario, result.metrics(i), model, 12.0)
        for i, (job, scenario) in enumerate(zip(jobs, scenarios))
    ]


def _study(job) -> tuple:
    return (job.controller, job.perception, job.parts_off, job.options)


def _batch_size(count: int, workers: int) -> int:
    """Runs per batch for a study of ``count`` runs: about two batches per worker,
    :data:`MIN_BATCH` to :data:`MAX_BATCH`, evened out."""
    size = math.ceil(count / (2 * max(1, workers)))
    size = max(min(MIN_BATCH, count), min(MAX_BATCH, size))
    return math.ceil(count / math.ceil(count / size))


def tasks(jobs: Sequence, workers: int = 1) -> tuple[list, list[str]]:
    """The executor items of ``jobs`` on the batch engine, and what falls back.

    Jobs of one study (controller, perception, parts off, options) are cut into batches
    of :data:`MIN_BATCH` to :data:`MAX_BATCH` runs, about two per worker; jobs whose
    controller cannot be batched become one pymunk task each. Returns (items, one
    message per study that fell back to the pymunk engine).
    """
    studies: dict[tuple, list] = {}
    for job in jobs:
        studies.setdefault(_study(job), []).append(job)
    items, fallbacks = [], []
    for (controller, _, parts_off, options), group in studies.items():
        reason = not_batchable_reason(
            controller, parts_off, dict(options), group[0].controller_object
        )
        if reason is not None:
            fallbacks.append(f"{reason}: its {len(group)} runs use the pymunk engine")
            items += [("pymunk", job) for job in group]
            continue
        size = _batch_size(len(group), workers)
        items += [("batch", tuple(group[k : k + size])) for k in range(0, len(group), size)]
    return items, fallbacks


def lazy_tasks(jobs: Iterable, counts: dict, workers: int = 1):
    """:func:`tasks` of jobs whose studies come one after the other (a sweep's
    :class:`~fuzzynav.app.experiments.studies.LayoutJobs`), made as they are asked for:
    ``counts`` gives how many jobs each study (controller, perception, parts off,
    options) has. Returns (an iterator of the items, the fallback messages, how many
    items it yields): the same items as :func:`tasks`, no list of them."""
    fallbacks, n_items, sizes = [], 0, {}
    for study, count in counts.items():
        if not count:
            continue
        controller, _, parts_off, options = study
        reason = not_batchable_reason(controller, parts_off, dict(options))
        if reason is not None:
            fallbacks.append(f"{reason}: its {count} runs use the pymunk engine")
            n_items += count
        else:
            sizes[study] = size = _batch_size(count, workers)
            n_items += math.ceil(count / size)

    def items():
        for study, group in itertools.groupby(jobs, key=_study):
            size = sizes.get(study)
            if size is None:
                yield from (("pymunk", job) for job in group)
                continue
            while batch := tuple(itertools.islice(group, size)):
                yield ("batch", batch)

    return items(), fallbacks, n_items


def run_layouts(
    family: str = "standard",
    n: int = 100,
    seed: int = 1,
    *,
    controller="paper",
    perception: str = "ideal",
    geometry: str = "husky",
    indices: Sequence[int] | None = None,
    **run_options,
):
    """Run layouts of a family on the batch engine: the Python entry point (a notebook's).

    Parameters
    ----------
    family, seed : str, int
        The layouts (:mod:`world.layouts`).
    n : int
        Layouts 0 .. n-1 (ignored when ``indices`` is given).
    controller : str, controller, or sequence of controllers
        A registry name (``paper``, ``baseline``, ``p``), a controller object, or one
        controller per run (a tuning generation: one structure, per-run parameters).
    perception, geometry : str
        As :class:`world.simulation.Simulation`.
    indices : sequence of int, optional
        The layout indices to run.
    **run_options
        Further keywords of :func:`world.batch.run_batch` (``control_period_s``,
        ``seeds``, ``sensor_config``, ``record_poses``, ``max_duration_s``...).

    Returns
    -------
    world.batch.BatchResult
        Arrays (N,): ``outcome`` (indices into ``OUTCOMES``; ``.outcomes`` as words),
        ``collided``, ``path_length_m``, ``min_clearance_m``, ``time_to_target_s``...;
        ``metrics(i)`` for one run as a dict.
    """
    from fuzzynav.controller.batch import batch_controller
    from fuzzynav.controller.registry import make_controller
    from fuzzynav.world.batch import run_batch
    from fuzzynav.world.layouts import generate_layout

    indices = list(range(n)) if indices is None else [int(i) for i in indices]
    scenarios = [generate_layout(family, seed, i) for i in indices]
    if isinstance(controller, str):
        ctrl = batch_controller(make_controller(controller, geometry=geometry))
    elif isinstance(controller, (list, tuple)):
        if len(controller) != len(scenarios):
            raise ValueError(f"controller: {len(controller)} controllers for {len(scenarios)} runs")
        ctrl = batch_controller(list(controller), np.arange(len(controller)))
    else:
        ctrl = batch_controller(controller)
    run_options.setdefault("seeds", seed)
    return run_batch(scenarios, ctrl, perception=perception, geometry=geometry, **run_options)


def objective_costs(objective, cost_function, stall_s: float, vectors) -> list[float]:
    """:class:`app.experiments.objective.Objective`'s cost of every vector, all candidates x cases on
    the batch engine (one batch per perception mode); the same per-run cost
    (``cost_function``: :func:`app.experiments.objective.outcome_cost`, given by the caller so
    that this module does not import the tuning's cost) and holes penalty, tuning's stall rule after
    ``stall_s`` s. Top level: an executor task."""
    from fuzzynav.app.experiments.objective import StallRule
    from fuzzynav.controller.batch import batch_controller
    from fuzzynav.world.batch import run_batch

    vectors = [np.asarray(v, dtype=float) for v in vectors]
    costs = [0.0] * len(vectors)
    built, controllers = [], []
    for k, vector in enumerate(vectors):
        try:
            controller = objective.tunable.build(objective.full(vector))
        except ValueError:  # an invalid shape, as Objective.__call__ prices it
            costs[k] = 1e3
            continue
        built.append(k)
        controllers.append(controller)
    if not built:
        return costs
    # per candidate, its runs' costs in the cases' order (as Objective.__call__ averages)
    per_case = {k: [0.0] * len(objective.cases) for k in built}
    for perception in dict.fromkeys(c.perception for c in objective.cases):
        chosen = [j for j, c in enumerate(objective.cases) if c.perception == perception]
        scenarios = [objective.cases[j].scenario for _ in built for j in chosen]
        run_sets = np.repeat(np.arange(len(built)), len(chosen))
        result = run_batch(
            scenarios,
            batch_controller(controllers, run_sets),
            perception=perception,
            control_period_s=objective.control_period_s,
            seeds=0,
            stop_rule=StallRule(stall_s, len(scenarios)),
        )
        outcomes = result.outcomes
        for i, scenario in enumerate(scenarios):
            k = built[int(run_sets[i])]
            per_case[k][chosen[i % len(chosen)]] = cost_function(
                scenario,
                outcomes[i],
                bool(result.collided[i]),
                result.metrics(i),
                float(result.min_target_distance_m[i]),
                float(result.final_target_distance_m[i]),
                perception,
                objective.clearance_weight,
            )
    for k, controller in zip(built, controllers):
        costs[k] = float(np.mean(per_case[k])) + objective.penalty(controller)
    return costs


def batch_mapper(objective, probe_vector, executor, cost_function, stall_s: float):
    """A map-like ``mapper(function, vectors) -> costs`` for DE and CMA-ES that runs a
    whole generation on the batch engine (split over ``executor``'s workers, each part
    one task), and None with the reason when the tunable's controller cannot be
    batched. ``probe_vector`` is built once to ask."""
    import functools

    from fuzzynav.controller.batch import NotBatchable, batch_controller

    try:
        batch_controller(objective.tunable.build(objective.full(probe_vector)))
    except NotBatchable as exc:
        return None, f"{exc}: tuning on the pymunk engine"
    task = functools.partial(objective_costs, objective, cost_function, stall_s)

    def mapper(_function, vectors):
        vectors = list(vectors)
        workers = 1 if executor is None or executor.kind == "serial" else executor.workers
        if workers <= 1 or len(vectors) < 2:
            return task(vectors)
        size = math.ceil(len(vectors) / workers)
        parts = [vectors[k : k + size] for k in range(0, len(vectors), size)]
        return [cost for part in executor.map(task, parts) for cost in part]

    return mapper, None


class FitTrace:
    """What the paper fit measures of a batch's runs besides their metrics, fed by the
    batch engine as a :class:`world.batch_metrics.RunObserver`: the target bearing input
    phi_t of the last logged row (rad, disturbance included) (N,); per obstacle the
    closest centre distance (m) and its first time (s) (N, M), as
    :func:`app.experiments.paper_fit.closest_approaches` reads them from a log; the
    largest applied voltage per wheel (N, 2), V."""

    final_phi_t: np.ndarray
    pass_d: np.ndarray
    pass_t: np.ndarray
    max_v: np.ndarray

    def start(self, n_runs: int, n_columns: int) -> None:
        self.final_phi_t = np.full(n_runs, np.nan)
        self.pass_d = np.full((n_runs, n_columns), np.inf)
        self.pass_t = np.zeros((n_runs, n_columns))
        self.max_v = np.full((n_runs, 2), -np.inf)

    def restart(self, runs) -> None:
        self.final_phi_t[runs] = np.nan
        self.pass_d[runs] = np.inf
        self.pass_t[runs] = 0.0
        self.max_v[runs] = -np.inf

    def widen(self, n_columns: int) -> None:
        extra = n_columns - self.pass_d.shape[1]
        if extra > 0:
            self.pass_d = np.pad(self.pass_d, ((0, 0), (0, extra)), constant_values=np.inf)
            self.pass_t = np.pad(self.pass_t, ((0, 0), (0, extra)))

    def log_rows(self, s, t_row, centre) -> None:
        from fuzzynav.world.kernels import disturbance_values, wrap_angles

        run = s.run
        closer = centre < self.pass_d[run]  # the first least distance
        self.pass_d[run] = np.where(closer, centre, self.pass_d[run])
        self.pass_t[run] = np.where(closer, t_row[:, None], self.pass_t[run])
        # the row's phi_t input as sensed then, disturbance included
        phi_t = wrap_angles(np.arctan2(s.target[:, 1] - s.y, s.target[:, 0] - s.x) - s.h)
        value = disturbance_values(s.disturbance, t_row)
        self.final_phi_t[run] = np.where(value != 0.0, phi_t + value, phi_t)

    def add_voltages(self, runs, volts) -> None:
        self.max_v[runs] = np.maximum(self.max_v[runs], volts)


def fit_measures(
    fit_cost, scenario_names, vectors, geometry: str = "paper", perception: str = "ideal"
) -> list[list[dict] | None]:
    """:meth:`app.experiments.paper_fit.FitCost.measure_all` of every vector on the batch engine:
    every candidate x s1-s3 in one batch (``geometry`` and ``perception``, each
    scenario's own start heading, the fit's period, cap and stall rule); None for a
    vector that builds no system."""
    from fuzzynav.app.experiments.objective import StallRule
    from fuzzynav.controller.batch import batch_controller
    from fuzzynav.controller.fis_controller import FisController
    from fuzzynav.world.batch import run_batch
    from fuzzynav.world.scenario import load_scenario

    out: list = [None] * len(vectors)
    built, controllers, scenarios = [], [], []
    for k, vector in enumerate(vectors):
        vector = np.asarray(vector, dtype=float)
        try:
            system = fit_cost.tunable.system(vector)
        except ValueError:
            continue
        built.append(k)
        controllers.append(
            FisController(system, name="paper", none_reading=fit_cost.reading.none_reading)
        )
        for name in scenario_names:
            scenario = fit_cost.reading.applied(load_scenario(name))
            if fit_cost.stall_s is not None:  # as app.experiments.paper_fit.run_paper_geometry
                scenario = scenario.replace(duration_s=min(scenario.duration_s, 120.0))
            scenarios.append(scenario)
    if not built:
        return out
    run_sets = np.repeat(np.arange(len(built)), len(scenario_names))
    trace = FitTrace()
    result = run_batch(
        scenarios,
        batch_controller(controllers, run_sets),
        perception=perception,
        geometry=geometry,
        seeds=0,
        control_period_s=fit_cost.control_period_s,
        model=fit_cost.model,
        stop_rule=None if fit_cost.stall_s is None else StallRule(fit_cost.stall_s, len(scenarios)),
        observers=[trace],
        record_poses=True,
    )
    for i, scenario in enumerate(scenarios):
        m = result.metrics(i)
        n_obstacles = len(scenario.obstacles)
        measured = {
            "scenario": scenario_names[i % len(scenario_names)],
            "reached": m["reached"],
            "collided": m["collided"],
            "time_to_target_s": m["time_to_target_s"],
            "path_length_m": m["path_length_m"],
            "mad_m": m["mad_m"],
            "rmse_m": m["rmse_m"],
            "min_center_distance_m": m["min_center_distance_m"],
            "min_clearance_m": m.get("min_clearance_m"),
            "passes": [
                (
                    float(trace.pass_t[i, j]),
                    float(trace.pass_d[i, j]),
                )
                for j in range(n_obstacles)
            ],
            "chatter_steps": m["voltage_jumps"],
            "final_phi_t_rad": float(trace.final_phi_t[i]),
            "final_distance_m": float(result.final_target_distance_m[i]),
            "closest_to_target_m": float(result.min_target_distance_m[i]),
            "max_voltage_v": tuple(float(v) for v in trace.max_v[i]),
            "largest_right_offset_m": largest_right_offset(scenario, result.poses[i]),
            "approach_speed_ratio": approach_speed_ratio(
                result.poses[i],
                np.arange(len(result.poses[i])) * fit_cost.control_period_s,
                scenario.target,
            ),
            "horizon_s": load_scenario(scenario_names[i % len(scenario_names)]).duration_s,
            "largest_line_offset_m": largest_line_offset(scenario, result.poses[i]),
            "pass_clearances_m": pass_clearances(
                scenario,
                result.poses[i],
                np.arange(len(result.poses[i])) * fit_cost.control_period_s,
            ),
        }
        k = built[int(run_sets[i])]
        out[k] = (out[k] or []) + [measured]
    return out


def line_offsets(scenario, poses) -> np.ndarray:
    """The robot's centre's signed distance from the start-target line at every pose
    (m; negative: right of the line, looking along it)."""
    start = np.asarray(scenario.start, dtype=float)
    line = np.asarray(scenario.target, dtype=float) - start
    xy = np.asarray(poses, dtype=float)[:, :2] - start
    return (line[0] * xy[:, 1] - line[1] * xy[:, 0]) / float(np.hypot(*line))


def largest_right_offset(scenario, poses) -> float:
    """How far right of the start-target line the robot's centre went (m, 0 if never):
    the paper's s1 comes at its obstacles from the right of that line."""
    return float(max(0.0, -line_offsets(scenario, poses).min()))


#: "The last 2 m" of a run: how near the target its approach speed is measured (m).
APPROACH_M = 2.0


def approach_speed_ratio(poses, time_s, target, within_m: float = APPROACH_M) -> float:
    """The mean speed over the part of the run within ``within_m`` of the target, over
    the run's median speed (both from the logged poses, m/s): 1 for an even pace, near 0
    for a crawl to the target; NaN if the run never came that near or never moved."""
    xy = np.asarray(poses, dtype=float)[:, :2]
    t = np.asarray(time_s, dtype=float)
    step_m = np.hypot(*np.diff(xy, axis=0).T)
    step_s = np.diff(t)
    moving = step_s > 0
    speed = step_m[moving] / step_s[moving]
    near = (np.hypot(*(xy[1:] - np.asarray(target, dtype=float)).T) <= within_m) & moving
    median = float(np.median(speed)) if speed.size else 0.0
    if not near.any() or median <= 0.0:
        return math.nan
    return float(step_m[near].sum() / step_s[near].sum() / median)


def largest_line_offset(scenario, poses) -> float:
    """How far from the start-target line the robot's centre went, either side (m)."""
    return float(np.abs(line_offsets(scenario, poses)).max())


def pass_clearances(scenario, poses, time_s) -> list[float]:
    """Per obstacle, the least clearance from the robot's footprint to its surface over
    the logged poses (m): how close each pass came. Each obstacle moves by its law."""
    from fuzzynav.world.geometry import rectangle_clearances
    from fuzzynav.world.kernels import law_centre, obstacle_law
    from fuzzynav.world.robot import HUSKY

    pose = np.asarray(poses, dtype=float)
    t = np.asarray(time_s, dtype=float)
    length, width = HUSKY.footprint_m
    out = []
    for obstacle in scenario.obstacles:
        cx, cy = law_centre(obstacle_law(obstacle), t)
        clearance = rectangle_clearances(
            np.cos(pose[:, 2]), np.sin(pose[:, 2]), cx - pose[:, 0], cy - pose[:, 1],
            obstacle.radius_m, 0.5 * length, 0.5 * width,
        )  # fmt: skip
        out.append(float(np.min(clearance)))
    return out


def fit_costs(fit_cost, vectors, scenario_names=("s1", "s2", "s3")) -> list[float]:
    """:class:`app.experiments.paper_fit.FitCost` of every vector, measured on the batch engine in
    every mode of :meth:`~app.experiments.paper_fit.FitCost.modes` and combined by its
    :meth:`~app.experiments.paper_fit.FitCost.combine` (so that this module does not import
    paper_fit; top level: a pool task)."""
    per_mode = [
        fit_measures(fit_cost, scenario_names, vectors, geometry, perception)
        for geometry, perception in fit_cost.modes()
    ]
    costs = []
    for k in range(len(vectors)):
        measured = [mode[k] for mode in per_mode]
        if any(m is None for m in measured):
            costs.append(1e6)  # as FitCost: a candidate that cannot run
        else:
            costs.append(fit_cost.combine(measured))
    return costs


def fit_mapper(fit_cost, pool_map=None, workers: int = 1):
    """A map-like ``mapper(function, vectors)`` for the fit's CMA-ES: a whole generation
    as one batch (or one per worker through ``pool_map``)."""
    import functools

    task = functools.partial(_fit_costs_task, fit_cost)

    def mapper(_function, vectors):
        vectors = list(vectors)
        if pool_map is None or workers <= 1 or len(vectors) < 2:
            return task(vectors)
        size = math.ceil(len(vectors) / workers)
        parts = [vectors[k : k + size] for k in range(0, len(vectors), size)]
        return [cost for part in pool_map(task, parts) for cost in part]

    return mapper


def _fit_costs_task(fit_cost, vectors) -> list[float]:
    return fit_costs(fit_cost, vectors)


def add_engine_option(parser) -> None:
    """``--engine batch|pymunk`` (docs/experiments.md)."""
    parser.add_argument(
        "--engine",
        choices=("batch", "pymunk"),
        default="batch",
        help="batch: thousands of runs at once as numpy arrays (world/batch.py; paper, "
        "baseline and p); pymunk: one world at a time, the reference (default batch; "
        "controllers the batch engine cannot drive run on pymunk, said on stderr)",
    )
