"""``fuzzynav compare``: controllers on the paper's scenarios s1-s3, each run's Table 4
row beside the paper's published numbers (:func:`table4_row`; the report's table too),
and optionally a sweep of each on the same seeded layouts (a study: :mod:`.studies`,
summarised as ``sweep`` does, :mod:`.sweep`).
"""

from __future__ import annotations

from fuzzynav.app.args import (
    UsageError,
    add_field_of_view_option,
    add_geometry_option,
    add_perception_option,
    integer_in,
    named_list,
    print_json,
    seed_type,
)
from fuzzynav.app.experiments.batch_runs import run_benchmark
from fuzzynav.app.experiments.rows import MAX_LAYOUTS
from fuzzynav.app.experiments.studies import (
    LayoutJobs,
    StudyInterrupted,
    _options,
    add_study_output_options,
    run_jobs,
    run_study,
    sweep_jobs,
)
from fuzzynav.app.experiments.sweep import _fmt, summarize
from fuzzynav.app.published import PAPER_TABLE4
from fuzzynav.resources import escape_controls
from fuzzynav.world.metrics import TABLE4_ROWS

# Paper Table 4 (notes section 2): method of ref. [19] | proposed, for S1 / S2 / S3.
SCENARIOS = ("s1", "s2", "s3")


def table4_row(controller: str, scenario: str, index: int, result, sim=None) -> dict:
    """One row of our Table 4: a run's metrics beside the paper's published numbers
    (``index`` is the scenario's column in the paper's table), and the benchmark
    metrics (:func:`run_benchmark`; of ``sim``'s plant, the paper's Husky if None)."""
    m = result.metrics
    published = PAPER_TABLE4.get(controller)
    if sim is None:
        from fuzzynav.world.husky import HuskyModel

        model, limit = HuskyModel.default(), 12.0
    else:
        model, limit = sim.model, sim.voltage_limit_v
    return {
        "controller": controller,
        "scenario": scenario,
        **{k: m[k] for k in TABLE4_ROWS},
        "min_clearance_m": m["min_clearance_m"],
        "time_to_target_s": m["time_to_target_s"],
        "reached": m["reached"],
        "collided": m["collided"],
        "outcome": result.outcome,
        **run_benchmark(result, model, limit),
        "paper": {k: published[k][index] for k in TABLE4_ROWS} if published else None,
    }


def run_table4(job) -> dict:
    """One Table 4 row: (controller, scenario, column index, perception, options) ->
    :func:`table4_row` (top level: what an executor sends to a worker)."""
    from fuzzynav.app.experiments.resultlog import finite_or_none
    from fuzzynav.app.runs import build_simulation

    controller, scenario, index, perception, options = job
    sim = build_simulation(scenario, controller, perception=perception, seed=0, **dict(options))
    return finite_or_none(table4_row(controller, scenario, index, sim.run(), sim))


def compare(
    controllers: list[str],
    perception: str = "ideal",
    sweep_n: int = 0,
    sweep_seed: int = 1,
    family: str = "standard",
    *,
    executor=None,
    sweep_rows=None,
    options: dict | None = None,
    engine: str = "pymunk",
) -> dict:
    """Runs of each controller on s1-s3 (and optionally a sweep of each); the
    ``compare --json`` object. ``executor``: where the runs go (default: serial);
    ``sweep_rows``: the sweep's rows, run already (:func:`compare_sweep_jobs`, in
    their order), instead of running them here."""
    from fuzzynav.app.experiments.executor import SerialExecutor

    executor = executor or SerialExecutor()
    opts = tuple(sorted((options or {}).items()))
    rows = executor.map(
        run_table4,
        [
            (name, scenario, i, perception, opts)
            for name in controllers
            for i, scenario in enumerate(SCENARIOS)
        ],
    )
    sweeps = []
    if sweep_n > 0:
        jobs = compare_sweep_jobs(controllers, perception, sweep_n, sweep_seed, family, options)
        if sweep_rows is None:
            sweep_rows = run_jobs(jobs, executor, engine=engine)
        for k in range(len(controllers)):
            s = summarize(sweep_rows[k * sweep_n : (k + 1) * sweep_n])
            s.pop("runs")
            s.pop("wall_time_s")
            sweeps.append(s)
    return {
        "perception": perception,
        "controllers": controllers,
        "rows": rows,
        "sweeps": sweeps,
        "paper_columns": {
            "paper": "the paper's proposed method",
            "baseline": "the paper's ref. [19] (our baseline is only a stand-in)",
        },
    }


def compare_sweep_jobs(controllers, perception, sweep_n, sweep_seed, family, options=None):
    """The jobs of compare's sweep: every controller on the same layouts, in turn (made
    as they run: :class:`~fuzzynav.app.experiments.studies.LayoutJobs`)."""
    jobs = LayoutJobs()
    for name in controllers:
        jobs = jobs + sweep_jobs(name, sweep_n, sweep_seed, family, perception, (), options)
    return jobs


def _wanted_controllers(args) -> list[str]:
    """The controllers ``--controllers`` names (default: every one offered), once the
    options are checked (UsageError otherwise)."""
    from fuzzynav.controller.registry import controller_names

    offered = controller_names()
    wanted = args.controllers or offered
    for name in wanted:
        if name not in offered:
            raise UsageError(
                f"--controllers: {name!r} is not available (have {', '.join(offered)})"
            )
    if args.sweep_n < 0:
        raise UsageError(f"--sweep-n {args.sweep_n}: must be >= 0")
    if args.out is not None and args.sweep_n == 0:
        raise UsageError("--out: only the sweep's runs are written; give --sweep-n N > 0")
    return wanted


def cmd_compare(args) -> int:
    from rich.console import Console

    from fuzzynav.app.experiments.executor import executor_from_args

    wanted = _wanted_controllers(args)
    options = _options(args)
    sweep_rows = None
    if args.sweep_n > 0:
        jobs = compare_sweep_jobs(
            wanted, args.perception, args.sweep_n, args.sweep_seed, args.family, options
        )
        try:
            sweep_rows, _ = run_study(jobs, args, f"sweep of {', '.join(wanted)}", quiet=args.json)
        except StudyInterrupted:
            return 130
    with executor_from_args(args) as executor:
        out = compare(
            wanted,
            args.perception,
            args.sweep_n,
            args.sweep_seed,
            args.family,
            executor=executor,
            sweep_rows=sweep_rows,
            options=options,
            engine=args.engine,
        )
    if args.json:
        print_json(out)
        return 0
    console = Console()
    if not console.is_terminal:
        console = Console(width=220)
    console.print(_table4(out["rows"], args.perception))
    if "baseline" in wanted:
        console.print(
            "baseline: a STAND-IN for the paper's ref. [19] (controller/baseline.py); the "
            "numbers in brackets on its rows are the paper's ref. [19] numbers, not the stand-in's."
        )
    console.print(
        "shortest: the shortest path keeping 0.25 m from the static obstacles (docs/"
        "experiments.md); score = success x optimal time / clip(time, 2, 8 x optimal), "
        "optimal time = shortest / top speed (0.617 m/s)"
    )
    if out["sweeps"]:
        console.print(_sweep_table(out["sweeps"], args.sweep_n, args.family, args.sweep_seed))
        if args.out is not None:
            from rich.markup import escape as markup

            console.print(markup(f"every sweep run: {escape_controls(str(args.out))}"))
    return 0


def _table4(rows: list[dict], perception: str):
    """The Table 4 rows as a rich table, each number beside the paper's in brackets."""
    from rich.table import Table

    table = Table(title=f"Table 4, ours (paper's published value) — {perception} perception")
    for col in (
        "scenario",
        "controller",
        "path m",
        "MAD m",
        "RMSE m",
        "min centre dist m",
        "clearance m",
        "time s",
        "reached",
        "collided",
        "shortest m",
        "path / shortest",
        "time / optimal",
        "score",
    ):
        table.add_column(col, justify="left" if col in ("scenario", "controller") else "right")
    for row in rows:
        paper = row["paper"]
        cells = [_fmt(row[k]) + (f" ({paper[k]:.4g})" if paper else "") for k in TABLE4_ROWS]
        label = row["controller"] + (
            " (stand-in for [19])" if row["controller"] == "baseline" else ""
        )
        table.add_row(
            row["scenario"],
            label,
            *cells,
            _fmt(row["min_clearance_m"]),
            _fmt(row["time_to_target_s"], 1),
            _fmt(row["reached"]),
            _fmt(row["collided"]),
            _fmt(row["shortest_path_m"]),
            _fmt(row["path_ratio"]),
            _fmt(row["time_ratio"], 2),
            _fmt(row["score"]),
        )
    return table


def _sweep_table(sweeps: list[dict], n: int, family: str, seed: int):
    """The sweep's summary per controller as a rich table."""
    from rich.table import Table

    st = Table(title=f"sweep: {n} {family} layouts, seed {seed}")
    for col in (
        "controller",
        "success",
        "safe success",
        "collisions",
        "timeouts",
        "median path m",
        "median path / shortest",
        "median path / straight",
        "median time / optimal",
        "mean score",
        "median clearance m",
    ):
        st.add_column(col, justify="left" if col == "controller" else "right")
    for s in sweeps:
        st.add_row(
            s["controller"],
            f"{100 * s['success_rate']:.1f} %",
            f"{100 * s['safe_success_rate']:.1f} %",
            str(s["collisions"]),
            str(s["timeouts"]),
            _fmt(s["median_path_length_m"]),
            _fmt(s["median_path_ratio"]),
            _fmt(s["median_straight_ratio"]),
            _fmt(s["median_time_ratio"], 2),
            _fmt(s["mean_score"]),
            _fmt(s["median_min_clearance_m"]),
        )
    return st


def add_commands(subparsers) -> None:
    from fuzzynav.app.experiments.batch_runs import add_engine_option
    from fuzzynav.app.experiments.executor import add_executor_options
    from fuzzynav.world.layouts import FAMILIES

    c = subparsers.add_parser(
        "compare", help="the paper's Table 4: controllers on s1-s3 beside the paper"
    )
    add_geometry_option(c)
    add_field_of_view_option(c)
    c.add_argument(
        "--controllers",
        type=named_list,
        help="comma-separated (default: paper,baseline,fuzzynav,p where available)",
    )
    add_perception_option(c)
    c.add_argument(
        "--sweep-n",
        type=integer_in(0, MAX_LAYOUTS),
        default=100,
        help=f"also sweep N random layouts per controller (default 100; 0: none; at most "
        f"{MAX_LAYOUTS})",
    )
    c.add_argument(
        "--sweep-seed",
        type=seed_type,
        default=5,
        help="seed of that sweep (default 5, a seed no controller was designed or tuned on)",
    )
    c.add_argument("--family", default="standard", choices=FAMILIES, help="family of that sweep")
    add_executor_options(c)
    add_engine_option(c)
    add_study_output_options(c)
    c.add_argument("--json", action="store_true", help="print one JSON object")
    c.set_defaults(func=cmd_compare)
