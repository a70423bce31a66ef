"""``fuzzynav sweep``: a controller on seeded random layouts (:mod:`world.layouts`), and
how often it succeeds; ``--beside`` sweeps a second controller on the same layouts,
``--failures`` writes every failed run as a scenario file and a recording.

The jobs, their rows and how they run are a study's (:mod:`.studies`); here they are
summarised (:func:`summarize`: success and safe-success rates, medians) and shown.
"""

from __future__ import annotations

import math
import os
import statistics
import time
from pathlib import Path

from fuzzynav.app.args import (
    add_field_of_view_option,
    add_force_option,
    add_geometry_option,
    add_off_option,
    add_perception_option,
    comma_list,
    integer_in,
    integer_value,
    off_flag,
    print_json,
    seed_type,
)
from fuzzynav.app.experiments.rows import MAX_LAYOUTS
from fuzzynav.app.experiments.studies import (
    SAFE_CLEARANCE_M,
    StudyInterrupted,
    _options,
    add_study_output_options,
    run_jobs,
    run_study,
    sweep_jobs,
)
from fuzzynav.resources import escape_controls

#: The command line's and the API's defaults: one place for both.
DEFAULT_N = 200
DEFAULT_SEED = 1


def _median(values):
    values = [v for v in values if v is not None and math.isfinite(v)]
    return statistics.median(values) if values else None


def _mean(values):
    values = [v for v in values if v is not None and math.isfinite(v)]
    return statistics.fmean(values) if values else None


def check_sweep(controller, n, family, parts_off=()) -> tuple[str, ...]:
    """Refuse a sweep that cannot run (before any run); the parts off, normalised."""
    from fuzzynav.controller.interface import PartsController
    from fuzzynav.controller.registry import controller_entry, make_controller
    from fuzzynav.world.layouts import FAMILIES

    integer_value(n, "n", 1, MAX_LAYOUTS)  # --n's rule: 2.5 and True are no counts
    if family not in FAMILIES:
        raise ValueError(f"family = {family!r}: must be one of {', '.join(FAMILIES)}")
    controller_entry(controller)  # a registered name or "module:factory", else ValueError
    parts_off = tuple(parts_off)
    if parts_off:
        probe = make_controller(controller)
        if not isinstance(probe, PartsController):
            raise ValueError(
                f"parts_off = {list(parts_off)}: {controller} has no parts to switch off"
            )
        probe.set_parts_off(list(parts_off))  # an unknown part is refused before any run
        parts_off = tuple(probe.parts_off)
    return parts_off


#: The keys of a sweep's row that :func:`summarize` reads.
SUMMARY_KEYS = ("controller", "parts_off", "family", "perception", "seed", "success",
                "reached", "collided", "outcome", "path_length_m", "path_ratio",
                "time_ratio", "score", "straight_ratio", "shortest_path_m",
                "min_clearance_m")  # fmt: skip


def summarize(rows: list[dict], *, wall_time_s: float | None = None) -> dict:
    """The summary of one sweep's rows (one controller, family, seed, perception)."""
    first = rows[0]
    n = len(rows)
    ok = [r for r in rows if r["success"]]
    # judged on the distance the geometry judges safety on (app/runs.py)
    safe = [
        r
        for r in ok
        if r.get("min_safety_distance_m", r["min_clearance_m"]) is None
        or r.get("min_safety_distance_m", r["min_clearance_m"]) >= SAFE_CLEARANCE_M
    ]
    return {
        "controller": first["controller"],
        "parts_off": list(first["parts_off"]),
        "family": first["family"],
        "perception": first["perception"],
        **({"options": first["options"]} if "options" in first else {}),
        "n": n,
        "seed": first["seed"],
        "success_rate": len(ok) / n,
        "safe_success_rate": len(safe) / n,
        "reached": sum(r["reached"] for r in rows),
        "collisions": sum(r["collided"] for r in rows),
        "timeouts": sum(r["outcome"] == "timeout" for r in rows),
        "median_path_length_m": _median([r["path_length_m"] for r in ok]),
        "median_path_ratio": _median([r["path_ratio"] for r in ok]),
        "median_time_ratio": _median([r["time_ratio"] for r in ok]),
        "mean_score": _mean([r["score"] for r in rows]),
        "median_straight_ratio": _median([r["straight_ratio"] for r in ok]),
        "median_shortest_path_m": _median([r["shortest_path_m"] for r in rows]),
        "no_reference_path": sum(r["shortest_path_m"] is None for r in rows),
        "median_min_clearance_m": _median([r["min_clearance_m"] for r in rows]),
        "wall_time_s": wall_time_s,
        "runs": rows,
    }


def sweep(
    controller: str,
    n: int,
    seed: int,
    family: str = "standard",
    perception: str = "ideal",
    *,
    executor=None,
    log=None,
    progress=None,
    parts_off: tuple[str, ...] = (),
    options: dict | None = None,
    engine: str = "pymunk",
) -> dict:
    """Run ``n`` layouts; the summary dict ``sweep --json`` prints (with per-run rows).

    ``parts_off``: fuzzynav's parts to switch off (``assets/rules/fuzzynav_parts.toml``);
    ``options``: keyword options of :func:`app.runs.build_simulation` for every run;
    ``executor``, ``log``, ``progress``, ``engine``: as :func:`run_jobs`.
    """
    parts_off = check_sweep(controller, n, family, parts_off)
    start = time.perf_counter()
    jobs = sweep_jobs(controller, n, seed, family, perception, parts_off, options)
    rows = run_jobs(jobs, executor, log=log, progress=progress, engine=engine)
    return summarize(rows, wall_time_s=time.perf_counter() - start)


def failed_runs(out: dict) -> list[dict]:
    """The runs of a sweep that did not reach their target without a collision."""
    return [r for r in out["runs"] if not (r["reached"] and not r["collided"])]


def failure_paths(
    directory, family: str, seed: int, controller: str, perception: str, index: int
) -> tuple[Path, Path]:
    """Where ``--failures DIR`` puts layout ``index``'s scenario file and recording."""
    stem = f"{family}_seed{seed}_{index:03d}"
    directory = Path(directory)
    return directory / f"{stem}.toml", directory / f"{stem}_{controller}_{perception}.rrd"


def check_failures_dir(directory, args) -> None:
    """Before the sweep: ValueError when ``directory`` holds a file that a failed run of
    these ``args`` (any of its ``--n`` layouts) would be written to, unless ``--force``."""
    from fuzzynav.safe_files import OutputScope

    if getattr(args, "force", False):
        return
    present = set(os.listdir(directory))
    names = {
        path.name: path
        for index in range(args.n)
        for path in failure_paths(
            directory, args.family, args.seed, args.controller, args.perception, index
        )
    }
    OutputScope("--failures").check(names[name] for name in sorted(present & names.keys()))


def write_failures(
    out: dict, directory, progress=None, source: str = "", overwrite: bool = False
) -> list[dict]:
    """For every failed run of the sweep ``out``: its layout as a scenario file and a
    rerun recording of the run, in ``directory`` (which must exist). No file there is
    replaced (ValueError naming it, before any is written) unless ``overwrite``.

    The scenario file runs again with ``fuzzynav run FILE --controller C --perception P
    --seed S`` (the command is in its header and in the recording); the run is driven
    again here to record it, and must end as it did in the sweep. Returns one dict per
    failure: index, outcome, ``scenario_file``, ``recording``.
    """
    from fuzzynav.safe_files import OutputScope

    family, seed = out["family"], out["seed"]
    controller, perception = out["controller"], out["perception"]
    runs = failed_runs(out)
    outputs = OutputScope("--failures", overwrite=overwrite)
    outputs.check(
        path
        for run in runs
        for path in failure_paths(directory, family, seed, controller, perception, run["index"])
    )
    with outputs:  # a name checked, then taken meanwhile, is refused at its write
        return _write_failures(out, runs, directory, progress, source)


def _write_failures(out: dict, runs, directory, progress, source: str) -> list[dict]:
    from fuzzynav.app.recordings.record import record_simulation
    from fuzzynav.app.runs import build_simulation
    from fuzzynav.safe_files import write_text_atomically
    from fuzzynav.world.layouts import generate_layout
    from fuzzynav.world.scenario import load_scenario

    family, seed = out["family"], out["seed"]
    controller, perception = out["controller"], out["perception"]
    parts_off = out.get("parts_off") or []
    options = out.get("options") or {}
    off = off_flag(parts_off)
    written = []
    for done, run in enumerate(runs, start=1):
        scenario_file, recording = failure_paths(
            directory, family, seed, controller, perception, run["index"]
        )
        command = (
            f"fuzzynav run {scenario_file} --controller {controller}{off} "
            f"--perception {perception} --seed {seed}"
        )
        write_text_atomically(
            scenario_file,
            f"# {family} layout #{run['index']} of seed {seed}, written by `fuzzynav sweep "
            f"--failures`: {controller} ({perception} perception) ended '{run['outcome']}'.\n"
            f"# Again: {command}\n\n" + generate_layout(family, seed, run["index"]).to_toml(),
        )
        sim = build_simulation(
            load_scenario(scenario_file), controller, perception=perception, seed=seed, **options
        )
        if parts_off:
            sim.controller.set_parts_off(parts_off)
        result = sim.run()
        if (result.outcome, result.metrics["collided"]) != (run["outcome"], run["collided"]):
            # Rows run here are deterministic; one that disagrees was read back from
            # --out and edited, or made elsewhere: bad input, not a crash
            raise ValueError(
                f"{scenario_file}: the run ended '{result.outcome}' when driven "
                f"again, '{run['outcome']}' in the sweep's row"
                + (f" ({source})" if source else "")
                + ": that row does not hold this run's result"
            )
        record_simulation(
            sim,
            result,
            recording,
            extra_metadata={"sweep": f"{family} layout #{run['index']} of seed {seed}"},
        )
        written.append(
            {
                "index": run["index"],
                "outcome": run["outcome"],
                "scenario_file": str(scenario_file),
                "recording": str(recording),
            }
        )
        if progress:
            progress(done)
    return written


def _fmt(value, digits=3):
    if value is None:
        return "-"
    if isinstance(value, bool):
        return "yes" if value else "no"
    if isinstance(value, float):
        return f"{value:.{digits}f}"
    return str(value)


def summary_table(out: dict, label: str, other: dict | None = None, beside: str = ""):
    """The table ``fuzzynav sweep`` prints of a summary (:func:`summarize`), with
    ``other``'s column (the ``--beside`` controller's) when given: a rich Table."""
    from rich.table import Table

    table = Table(
        title=f"sweep: {out['family']} layouts, seed {out['seed']}, {out['perception']} perception"
    )
    table.add_column("metric")
    table.add_column(label, justify="right")
    if other is not None:
        table.add_column(beside, justify="right")
    for key, value in out.items():
        if key not in ("runs", "controller"):
            table.add_row(key, _fmt(value), *([_fmt(other[key])] if other is not None else []))
    return table


def cmd_sweep(args) -> int:
    from rich.console import Console
    from rich.table import Table

    if args.failures is not None:
        from fuzzynav.app.figures.run_figures import check_writable_dir

        check_writable_dir(args.failures, "--failures")  # before the sweep, not after
        check_failures_dir(args.failures, args)
    beside = args.beside
    if beside == "auto":
        beside = "paper" if args.controller != "paper" else "none"
    from fuzzynav.world.perception import check_geometry

    check_geometry(getattr(args, "geometry", "husky"), args.perception)  # before any run
    parts_off = check_sweep(args.controller, args.n, args.family, comma_list(args.off))
    label = args.controller + (f" without {', '.join(parts_off)}" if parts_off else "")
    options = _options(args)
    jobs = sweep_jobs(
        args.controller, args.n, args.seed, args.family, args.perception, parts_off, options
    )
    with_beside = beside not in ("none", args.controller)
    if with_beside:
        # the same layouts, so that the two rates are comparable run for run
        jobs += sweep_jobs(beside, args.n, args.seed, args.family, args.perception, (), options)
    try:
        rows, wall_time_s = run_study(
            jobs, args, f"sweep {label}" + (f" and {beside}" if with_beside else ""), args.json
        )
    except StudyInterrupted:
        return 130
    out = summarize(rows[: args.n], wall_time_s=wall_time_s)
    other = summarize(rows[args.n :], wall_time_s=wall_time_s) if with_beside else None
    failures = (
        _write_failures_with_bar(
            out,
            args.failures,
            args.json,
            f"rows read back from --out {args.out}" if args.resume else "",
            overwrite=getattr(args, "force", False),
        )
        if args.failures is not None
        else None
    )
    if args.json:
        if other is not None:
            out["beside"] = {k: v for k, v in other.items() if k != "runs"}
        if failures is not None:
            out["failures"] = failures
        print_json(out)
        return 0
    Console().print(summary_table(out, label, other, beside))
    if args.out is not None:
        print(f"every run: {escape_controls(str(args.out))}")
    if failures:
        listing = Table(
            title=f"{len(failures)} failed run(s) of {args.controller}: "
            f"layouts and recordings in {args.failures}"
        )
        for column in ("layout", "outcome", "scenario file", "recording"):
            listing.add_column(column, overflow="fold")
        for f in failures:
            listing.add_row(
                f"#{f['index']}",
                f["outcome"],
                Path(f["scenario_file"]).name,
                Path(f["recording"]).name,
            )
        Console().print(listing)
        print(f"open one with: rerun {escape_controls(failures[0]['recording'])}")
    elif failures is not None:
        print(f"no failed runs: nothing written to {escape_controls(str(args.failures))}")
    return 0


def _write_failures_with_bar(out, directory, quiet, source="", overwrite=False):
    from rich.console import Console
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn

    n = len(failed_runs(out))
    with Progress(
        TextColumn("recording failed runs"),
        BarColumn(),
        MofNCompleteColumn(),
        console=Console(stderr=True),
        disable=quiet or n == 0,
    ) as bar:
        task = bar.add_task("failures", total=n)
        return write_failures(
            out,
            directory,
            progress=lambda done: bar.update(task, completed=done),
            source=source,
            overwrite=overwrite,
        )


def add_commands(subparsers) -> None:
    from fuzzynav.app.experiments.batch_runs import add_engine_option
    from fuzzynav.app.experiments.executor import add_executor_options
    from fuzzynav.controller.registry import controller_names
    from fuzzynav.world.layouts import FAMILIES

    p = subparsers.add_parser(
        "sweep", help="run a controller on seeded random layouts; success rate"
    )
    add_geometry_option(p)
    add_field_of_view_option(p)
    p.add_argument(
        "--n",
        type=integer_in(1, MAX_LAYOUTS),
        default=DEFAULT_N,
        help=f"number of layouts (default {DEFAULT_N}, at most {MAX_LAYOUTS})",
    )
    p.add_argument(
        "--seed", type=seed_type, default=DEFAULT_SEED, help=f"layout seed (default {DEFAULT_SEED})"
    )
    p.add_argument(
        "--family", default="standard", choices=FAMILIES, help="layout family (default standard)"
    )
    p.add_argument(
        "--controller",
        default="paper",
        choices=controller_names(),
        help="the controller swept (default paper)",
    )
    add_perception_option(p)
    add_executor_options(p)
    add_engine_option(p)
    add_study_output_options(p)
    p.add_argument(
        "--beside",
        default="auto",
        choices=("auto", "none", *controller_names()),
        help="also sweep this controller on the same layouts and print it beside "
        "(default: paper, unless --controller is paper; none: skip)",
    )
    add_off_option(p)
    p.add_argument("--json", action="store_true", help="print one JSON object (with every run)")
    p.add_argument(
        "--failures",
        type=Path,
        metavar="DIR",
        help="write every failed run of --controller to DIR: its layout as a "
        "scenario file (to run again) and a rerun recording (1-4 MB "
        "each); a file already there is never replaced without --force",
    )
    add_force_option(p, "files already in --failures DIR")
    p.set_defaults(func=cmd_sweep)
