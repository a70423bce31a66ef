"""``fuzzynav tune``, ``fuzzynav sweep`` and ``fuzzynav compare`` (issue 3).

``sweep`` runs a controller on seeded random layouts (:mod:`world.layouts`) and reports
how often it succeeds; ``compare`` runs controllers on s1-s3 and prints the paper's
Table 4 rows beside the published numbers. ``tune`` lives in :mod:`app.experiments.tuning`.

A sweep run "succeeds" when the target is reached without a collision; the stricter
"safe success" also asks for a minimum clearance >= 0.25 m (the paper's safe distance).
"""

from __future__ import annotations

import functools
import json
import math
import statistics
import time
from dataclasses import dataclass
from pathlib import Path

from fuzzynav.app.args import (
    UsageError,
    add_geometry_option,
    add_off_option,
    integer_in,
    off_flag,
    parse_off,
    print_json,
    seed_type,
)

# The rows of both engines come from one function (app/experiments/batch_runs.py).
from fuzzynav.app.experiments.batch_runs import layout_row, run_benchmark
from fuzzynav.app.provenance import fuzzynav_version
from fuzzynav.app.published import PAPER_TABLE4  # noqa: F401  (tests read it here)
from fuzzynav.resources import escape_controls
from fuzzynav.world.metrics import TABLE4_ROWS  # noqa: F401  (report and tests read it here)

SAFE_CLEARANCE_M = 0.25

# Paper Table 4 (notes section 2): method of ref. [19] | proposed, for S1 / S2 / S3.
SCENARIOS = ("s1", "s2", "s3")


# --------------------------------------------------------------------------- sweep


@dataclass(frozen=True)
class LayoutJob:
    """One run of a study: layout ``index`` of ``family`` for ``seed``, driven by
    ``controller`` (``parts_off`` switched off) in ``perception``; ``options`` are
    further keyword options of :func:`app.runs.build_simulation`, as sorted (name,
    value) pairs (hashable, picklable). Everything the run's result depends on: the
    same job gives the same row on any executor and any worker."""

    family: str
    seed: int
    index: int
    controller: str
    perception: str = "ideal"
    parts_off: tuple[str, ...] = ()
    options: tuple[tuple[str, object], ...] = ()

    def key(self) -> tuple:
        return (
            *_study_key(
                self.controller,
                tuple(self.parts_off),
                self.family,
                self.seed,
                self.perception,
                self.options,
            ),
            self.index,
        )

    def fingerprint(self) -> str:
        """:func:`study_fingerprint` of this job's study."""
        return study_fingerprint(
            self.controller, self.parts_off, self.family, self.seed, self.perception, self.options
        )


@functools.lru_cache(maxsize=256)
def _study_key(controller, parts_off, family, seed, perception, options) -> tuple:
    # the part of a job's key its whole study shares: made once, not once a job (a
    # sweep of 100,000 layouts took seconds to key before its first run)
    return (
        controller,
        parts_off,
        family,
        seed,
        perception,
        json.dumps(dict(options), sort_keys=True),
        study_fingerprint(controller, parts_off, family, seed, perception, options),
    )


#: The largest number of layouts one sweep (or compare's sweep, per controller) runs:
#: 100,000 runs are hours on a machine and a few hundred MB of rows; past it a typing
#: slip (``--n 100000000``) would build gigabytes of jobs before the first run.
MAX_LAYOUTS = 100_000


def _rules_digest(controller: str) -> str:
    """SHA-256 of what a controller's runs are made with besides the code: its shipped
    rule bases (``assets/rules/<controller>*.toml``) and the robot (``husky.toml``)."""
    import hashlib

    from fuzzynav.resources import MAX_INPUT_BYTES, asset_path, read_user_bytes

    digest = hashlib.sha256()
    rules = asset_path("rules")
    files = sorted(
        p for p in rules.glob("*.toml") if p.name.split("_")[0].split(".")[0] == controller
    )
    for path in [*files, asset_path("husky.toml")]:
        digest.update(path.name.encode() + b"\0")
        digest.update(read_user_bytes(path, "shipped file", MAX_INPUT_BYTES))
    return digest.hexdigest()


_DIGESTS: dict[str, str] = {}


def study_fingerprint(controller, parts_off, family, seed, perception, options) -> str:
    """What made a row, as 16 hex digits: the fuzzynav version, the controller and the
    digest of its rule bases and robot, the parts off, the perception, the options
    (geometry, engine...), the seed and the family. ``--resume`` keeps only rows with
    the fingerprint of the study it runs: a row of another version or rule base is
    never merged in."""
    return _fingerprint(
        controller, tuple(parts_off), family, seed, perception, tuple(sorted(dict(options).items()))
    )


@functools.lru_cache(maxsize=256)
def _fingerprint(controller, parts_off, family, seed, perception, options) -> str:
    # cached: every job's key asks for it (a sweep of 100,000 layouts once, not 100,000 times)
    import hashlib

    if controller not in _DIGESTS:
        _DIGESTS[controller] = _rules_digest(controller)
    what = json.dumps(
        [
            fuzzynav_version(),
            controller,
            _DIGESTS[controller],
            list(parts_off),
            family,
            seed,
            perception,
            dict(options),
        ],
        sort_keys=True,
    )
    return hashlib.sha256(what.encode()).hexdigest()[:16]


def row_key(row: dict) -> tuple:
    """The identity of a row (:meth:`LayoutJob.key` of the job that made it)."""
    return (
        row["controller"],
        tuple(row["parts_off"]),
        row["family"],
        row["seed"],
        row["perception"],
        json.dumps(row.get("options", {}), sort_keys=True),
        row["fingerprint"],
        row["index"],
    )


_ROW_NUMBERS = (
    "path_length_m",
    "straight_line_m",
    "straight_ratio",
    "min_clearance_m",
    "min_safety_distance_m",
    "time_to_target_s",
    "shortest_path_m",
    "path_ratio",
    "optimal_time_s",
    "time_ratio",
    "score",
)


def check_row(row: dict) -> None:
    """Raise ValueError naming the field and its value unless ``row`` is a row as
    :func:`run_layout_row` writes it: every field there, of its type and in its range,
    and consistent (success = reached without collision). What ``--resume`` reads
    back is checked with it before it is trusted."""
    from fuzzynav.resources import shown
    from fuzzynav.world.scenario import MAX_OBSTACLES
    from fuzzynav.world.simulation import OUTCOMES

    def bad(name, why):
        return ValueError(f"{name} = {shown(row.get(name))}: {why}")

    def integer(name, low, high):
        value = row[name]
        if isinstance(value, bool) or not isinstance(value, int) or not low <= value <= high:
            raise bad(name, f"must be an integer from {low} to {high}")

    def text(name):
        value = row[name]
        if not isinstance(value, str) or not 0 < len(value) <= 200:
            raise bad(name, "must be a name (a string of 1 to 200 characters)")

    for name in ("index", "controller", "parts_off", "family", "seed", "perception"):
        if name not in row:
            raise ValueError(f"{name} missing")
    integer("index", 0, MAX_LAYOUTS - 1)
    integer("seed", 0, 2**63 - 1)
    for name in ("controller", "family", "perception"):
        text(name)
    parts = row["parts_off"]
    if not isinstance(parts, list) or not all(isinstance(p, str) for p in parts):
        raise bad("parts_off", "must be a list of part names")
    if "options" in row and not (
        isinstance(row["options"], dict)
        and all(isinstance(v, str | int | float | bool) for v in row["options"].values())
    ):
        raise bad("options", "must be an object of option names and plain values")
    fingerprint = row.get("fingerprint")
    if not (isinstance(fingerprint, str) and len(fingerprint) == 16):
        raise bad(
            "fingerprint",
            "missing or malformed: written by another fuzzynav version (before issue 26)",
        )
    for name in ("outcome", "reached", "collided", "success", "n_obstacles", *_ROW_NUMBERS):
        if name not in row:
            raise ValueError(f"{name} missing")
    if row["outcome"] not in OUTCOMES:
        raise bad("outcome", f"must be one of {', '.join(OUTCOMES)}")
    for name in ("reached", "collided", "success"):
        if not isinstance(row[name], bool):
            raise bad(name, "must be true or false")
    if row["success"] != (row["reached"] and not row["collided"]):
        raise bad("success", "must be reached and not collided")
    if (row["outcome"] == "reached") != row["reached"]:
        raise bad("reached", f"does not match outcome {row['outcome']!r}")
    if row["outcome"] == "collided" and not row["collided"]:
        raise bad("collided", "does not match outcome 'collided'")
    integer("n_obstacles", 0, MAX_OBSTACLES)
    for name in _ROW_NUMBERS:
        value = row[name]
        if value is None:
            continue
        if (
            isinstance(value, bool)
            or not isinstance(value, int | float)
            or not math.isfinite(value)
        ):
            raise bad(name, "must be a finite number or null")
    if row["straight_line_m"] is None or row["straight_line_m"] <= 0:
        raise bad("straight_line_m", "must be a distance > 0")
    for name in ("path_length_m", "shortest_path_m", "optimal_time_s", "time_to_target_s"):
        if row[name] is not None and row[name] < 0:
            raise bad(name, "must be >= 0")
    if row["score"] is not None and not 0 <= row["score"] <= 1:
        raise bad("score", "must be from 0 to 1")


def describe_row(row: dict) -> str:
    """What a row of a results file is, for a refusal: its study's options, and whether
    it is the fingerprint alone that differs."""
    return ", ".join(
        f"{name} {row.get(name)!r}"
        for name in ("controller", "family", "seed", "perception", "index", "fingerprint")
        if name in row
    )


def run_layout(job: LayoutJob) -> dict:
    """The row of one job (top level: what an executor sends to a worker)."""
    return run_layout_row(
        job.family,
        job.seed,
        job.index,
        controller=job.controller,
        perception=job.perception,
        parts_off=job.parts_off,
        **dict(job.options),
    )


def run_task(item) -> list[dict]:
    """One executor task: ``("batch", jobs)`` on the batch engine, or ``("pymunk",
    job)`` on the pymunk engine; a list of rows either way (top level)."""
    from fuzzynav.app.experiments.batch_runs import run_layout_batch

    kind, payload = item
    if kind == "batch":
        return run_layout_batch(payload)
    return [run_layout(payload)]


def run_layout_row(
    family: str,
    seed: int,
    index: int,
    *,
    controller: str,
    perception: str = "ideal",
    parts_off=(),
    **options,
) -> dict:
    """Run layout ``index`` of ``family``/``seed``; its row (what ``--out`` writes).

    ``options`` go to :func:`app.runs.build_simulation` as keywords. The row: the job
    (index, controller, parts_off, family, seed, perception, and options if any), the
    outcome (outcome, reached, collided, success = reached without collision), the
    run's path_length_m, min_clearance_m, min_safety_distance_m (what the safe distance
    is judged on in the run's geometry), time_to_target_s, straight_line_m and
    straight_ratio (path / straight line), n_obstacles, and the benchmark metrics of
    :func:`world.metrics.benchmark_metrics` (shortest_path_m, path_ratio,
    optimal_time_s, time_ratio, score). Non-finite numbers are None.
    """
    from fuzzynav.app.runs import build_simulation
    from fuzzynav.world.layouts import generate_layout

    scenario = generate_layout(family, seed, index)
    sim = build_simulation(scenario, controller, perception=perception, seed=seed, **options)
    if parts_off:
        sim.controller.set_parts_off(list(parts_off))
    result = sim.run()
    job = LayoutJob(
        family, seed, index, controller, perception, tuple(parts_off), tuple(options.items())
    )
    return layout_row(job, scenario, result.metrics, sim.model, sim.voltage_limit_v)


def _median(values):
    values = [v for v in values if v is not None and math.isfinite(v)]
    return statistics.median(values) if values else None


def _mean(values):
    values = [v for v in values if v is not None and math.isfinite(v)]
    return statistics.fmean(values) if values else None


def check_sweep(controller, n, family, parts_off=()) -> tuple[str, ...]:
    """Refuse a sweep that cannot run (before any run); the parts off, normalised."""
    from fuzzynav.controller.registry import controller_names, make_controller
    from fuzzynav.world.layouts import FAMILIES

    if not 1 <= n <= MAX_LAYOUTS:
        raise ValueError(f"n = {n}: must be from 1 to {MAX_LAYOUTS}")
    if family not in FAMILIES:
        raise ValueError(f"family = {family!r}: must be one of {', '.join(FAMILIES)}")
    if controller not in controller_names():
        raise ValueError(
            f"controller = {controller!r}: choose from {', '.join(controller_names())}"
        )
    parts_off = tuple(parts_off)
    if parts_off:
        probe = make_controller(controller)
        if not hasattr(probe, "set_parts_off"):
            raise ValueError(
                f"parts_off = {list(parts_off)}: {controller} has no parts to switch off"
            )
        probe.set_parts_off(list(parts_off))  # an unknown part is refused before any run
        parts_off = tuple(probe.parts_off)
    return parts_off


def sweep_jobs(
    controller, n, seed, family="standard", perception="ideal", parts_off=(), options=None
) -> list[LayoutJob]:
    """The jobs of one sweep: layouts 0..n-1."""
    opts = tuple(sorted((options or {}).items()))
    return [
        LayoutJob(family, seed, i, controller, perception, tuple(parts_off), opts) for i in range(n)
    ]


def run_jobs(
    jobs, executor=None, *, log=None, progress=None, engine="pymunk", on_fallback=None
) -> list[dict]:
    """The rows of ``jobs``, in the jobs' order, whatever order they finish in.

    ``executor``: an :class:`app.experiments.executor.Executor` (default: serial). ``log``: an open
    :class:`app.experiments.resultlog.ResultLog`; the jobs it holds rows of are not run again, each
    new row is written to it as it arrives, and rows of other studies are refused.
    ``progress(done, total)`` after each row (and once at the start). ``engine``:
    ``pymunk`` (one task per run) or ``batch`` (:mod:`app.experiments.batch_runs`: batches of runs
    as tasks; controllers it cannot drive run on pymunk, and ``on_fallback(message)``
    is told so).
    """
    if engine not in ("pymunk", "batch"):
        raise ValueError(f"engine = {engine!r}: must be pymunk or batch")
    from fuzzynav.app.experiments.executor import SerialExecutor

    executor = executor or SerialExecutor()
    keys = [job.key() for job in jobs]
    found = {}
    if log is not None:
        log.check_belongs(keys)
        found = {k: log.rows[k] for k in keys if k in log.rows}
    todo = [job for job, k in zip(jobs, keys) if k not in found]
    if progress:
        progress(len(found), len(jobs))
    wanted = set(keys)
    if engine == "batch":
        from fuzzynav.app.experiments.batch_runs import tasks

        items, fallbacks = tasks(todo, executor.workers)
        for message in fallbacks:
            if on_fallback is not None:
                on_fallback(message)
        results = executor.imap_unordered(run_task, items)
    else:
        results = executor.imap_unordered(run_layout, todo)
    try:
        for batch in results:
            for row in batch if engine == "batch" else [batch]:
                if row_key(row) not in wanted:  # made by a worker with other code or rules
                    raise ValueError(
                        f"a worker's row is not of this study ({describe_row(row)}, this "
                        f"study's fingerprint {todo[0].fingerprint()}): every worker needs "
                        "the same fuzzynav version and rule bases as this machine"
                    )
                if log is not None:
                    log.write(row)
                found[row_key(row)] = row
            if progress:
                progress(len(found), len(jobs))
    finally:
        results.close()
    return [found[k] for k in keys]


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


def write_failures(out: dict, directory, progress=None, source: str = "") -> list[dict]:
    """For every failed run of the sweep ``out``: its layout as a scenario file and a
    rerun recording of the run, in ``directory`` (which must exist).

    The scenario file runs again with ``fuzzynav run FILE --controller C --perception P
    --seed S`` (the command is in its header and in the recording); the run is driven
    again here to record it, and must end as it did in the sweep. Returns one dict per
    failure: index, outcome, ``scenario_file``, ``recording``.
    """
    from fuzzynav.app.recordings.record import record_run
    from fuzzynav.app.runs import build_simulation
    from fuzzynav.safe_files import write_text_atomically
    from fuzzynav.world.layouts import generate_layout
    from fuzzynav.world.scenario import load_scenario

    directory = Path(directory)
    family, seed = out["family"], out["seed"]
    controller, perception = out["controller"], out["perception"]
    parts_off = out.get("parts_off") or []
    options = out.get("options") or {}
    off = off_flag(parts_off)
    written = []
    for done, run in enumerate(failed_runs(out), start=1):
        stem = f"{family}_seed{seed}_{run['index']:03d}"
        scenario_file = directory / f"{stem}.toml"
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
            # --out and edited, or made elsewhere: bad input, not a crash (issue 26)
            raise ValueError(
                f"{scenario_file}: the run ended '{result.outcome}' when driven "
                f"again, '{run['outcome']}' in the sweep's row"
                + (f" ({source})" if source else "")
                + ": that row does not hold this run's result"
            )
        recording = directory / f"{stem}_{controller}_{perception}.rrd"
        record_run(
            result,
            recording,
            controller=sim.controller,
            sensors=sim.sensors,
            parameters=sim.model.parameters,
            voltage_limit_v=sim.voltage_limit_v,
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


class StudyInterrupted(Exception):
    """Ctrl-C during a study: what was kept has been said on stderr (exit status 130)."""


def _progress_bar(label: str, quiet: bool):
    from rich.console import Console
    from rich.progress import (
        BarColumn,
        MofNCompleteColumn,
        Progress,
        ProgressColumn,
        TextColumn,
        TimeElapsedColumn,
        TimeRemainingColumn,
    )
    from rich.text import Text

    class RateColumn(ProgressColumn):
        def render(self, task):
            speed = task.finished_speed or task.speed
            return Text(f"{speed:.2f} runs/s" if speed else "- runs/s", style="progress.data.speed")

    return Progress(
        TextColumn(label),
        BarColumn(),
        MofNCompleteColumn(),
        RateColumn(),
        TimeElapsedColumn(),
        TextColumn("elapsed,"),
        TimeRemainingColumn(),
        TextColumn("left"),
        console=Console(stderr=True),
        disable=quiet,
    )


def run_study(jobs, args, label: str, quiet: bool) -> tuple[list[dict], float]:
    """``jobs`` on the executor of ``args`` (``--executor/--workers/--scheduler``) with a
    progress bar, each row into ``--out`` as it arrives (``--resume``: the rows there
    are kept); (rows in the jobs' order, wall time in s). Ctrl-C: every finished row is
    kept in ``--out``, a message says so, :class:`StudyInterrupted` is raised."""
    import contextlib
    import sys

    from fuzzynav.app.experiments.executor import executor_from_args
    from fuzzynav.app.experiments.resultlog import ResultLog

    out = getattr(args, "out", None)
    if getattr(args, "resume", False) and out is None:
        raise UsageError("--resume: give the --out PATH.jsonl to resume")
    log = None
    if out is not None:
        from fuzzynav.safe_files import check_output_path

        # never the installed package's files, a device, a pipe or /dev/zero
        check_output_path(out, "--out", stream_ok=False)
        log = ResultLog(out, resume=args.resume, key=row_key, check_row=check_row)
        log.check_belongs((job.key() for job in jobs), describe_row)  # before a worker starts
    start = time.perf_counter()
    try:
        with contextlib.ExitStack() as stack:
            if log is not None:
                # locked before the workers start: a second run on this file refuses
                # here, naming this one's process id
                stack.enter_context(log)
            executor = stack.enter_context(executor_from_args(args, jobs=len(jobs)))
            with _progress_bar(f"{label} ({executor.describe()})", quiet) as bar:
                task = bar.add_task("runs", total=len(jobs))

                def progress(done, total):
                    bar.update(task, completed=done, total=total)

                rows = run_jobs(
                    jobs,
                    executor,
                    log=log,
                    progress=progress,
                    engine=getattr(args, "engine", "pymunk"),
                    on_fallback=lambda message: print(f"fuzzynav: {message}", file=sys.stderr),
                )
    except KeyboardInterrupt:
        if log is not None:
            log.close()
            # read back: Ctrl-C may land after a row reached the file, before it was counted
            on_file = ResultLog(log.path, resume=True, key=row_key, check_row=check_row).rows
            kept = sum(1 for job in jobs if job.key() in on_file)
            print(
                f"fuzzynav: interrupted: {kept} of {len(jobs)} runs are in {log.shown}; "
                f"the same command with --resume runs the other {len(jobs) - kept}",
                file=sys.stderr,
            )
        else:
            print(
                "fuzzynav: interrupted: the finished runs were not kept (give --out "
                "PATH.jsonl to keep every run as it finishes, and --resume to go on)",
                file=sys.stderr,
            )
        raise StudyInterrupted from None
    if log is not None and log.dropped_partial_line and not quiet:
        print(f"{log.shown}: an unfinished last line was dropped and run again", file=sys.stderr)
    return rows, time.perf_counter() - start


def _fmt(value, digits=3):
    if value is None:
        return "-"
    if isinstance(value, bool):
        return "yes" if value else "no"
    if isinstance(value, float):
        return f"{value:.{digits}f}"
    return str(value)


def _options(args) -> dict:
    """Keyword options of build_simulation that a command passes to every run: its
    ``--geometry`` when it has one and it is not the default (so that a row of the
    default study stays as it was)."""
    geometry = getattr(args, "geometry", "husky")
    return {} if geometry == "husky" else {"geometry": geometry}


def cmd_sweep(args) -> int:
    from rich.console import Console
    from rich.table import Table

    if args.failures is not None:
        from fuzzynav.app.figures.run_figures import check_writable_dir

        check_writable_dir(args.failures, "--failures")  # before the sweep, not after
    beside = args.beside
    if beside == "auto":
        beside = "paper" if args.controller != "paper" else "none"
    from fuzzynav.world.perception import check_geometry

    check_geometry(getattr(args, "geometry", "husky"), args.perception)  # before any run
    parts_off = check_sweep(args.controller, args.n, args.family, parse_off(args.off))
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
    table = Table(
        title=f"sweep: {args.family} layouts, seed {args.seed}, {args.perception} perception"
    )
    table.add_column("metric")
    table.add_column(label, justify="right")
    if other is not None:
        table.add_column(beside, justify="right")
    for key, value in out.items():
        if key not in ("runs", "controller"):
            table.add_row(key, _fmt(value), *([_fmt(other[key])] if other is not None else []))
    Console().print(table)
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


def _write_failures_with_bar(out, directory, quiet, source=""):
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
            out, directory, progress=lambda done: bar.update(task, completed=done), source=source
        )


# --------------------------------------------------------------------------- compare


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
    """The jobs of compare's sweep: every controller on the same layouts, in turn."""
    return [
        job
        for name in controllers
        for job in sweep_jobs(name, sweep_n, sweep_seed, family, perception, (), options)
    ]


def cmd_compare(args) -> int:
    from rich.console import Console
    from rich.table import Table

    from fuzzynav.app.experiments.executor import executor_from_args
    from fuzzynav.controller.registry import controller_names

    offered = controller_names()
    wanted = args.controllers or [c for c in ("paper", "baseline", "fuzzynav", "p") if c in offered]
    for name in wanted:
        if name not in offered:
            raise UsageError(
                f"--controllers: {name!r} is not available (have {', '.join(offered)})"
            )
    if args.sweep_n < 0:
        raise UsageError(f"--sweep-n {args.sweep_n}: must be >= 0")
    if args.out is not None and args.sweep_n == 0:
        raise UsageError("--out: only the sweep's runs are written; give --sweep-n N > 0")
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
    table = Table(title=f"Table 4, ours (paper's published value) — {args.perception} perception")
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
    for row in out["rows"]:
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
    console.print(table)
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
        st = Table(title=f"sweep: {args.sweep_n} {args.family} layouts, seed {args.sweep_seed}")
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
        for s in out["sweeps"]:
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
        console.print(st)
        if args.out is not None:
            from rich.markup import escape as markup

            console.print(markup(f"every sweep run: {escape_controls(str(args.out))}"))
    return 0


# --------------------------------------------------------------------------- CLI


def _csv(text: str) -> list[str]:
    return [t.strip() for t in text.split(",") if t.strip()]


def add_study_output_options(parser) -> None:
    """``--out PATH.jsonl`` and ``--resume``."""
    parser.add_argument(
        "--out",
        type=Path,
        default=None,
        metavar="PATH.jsonl",
        help="write every run as one JSON line as it finishes (docs/experiments.md); an "
        "existing file is refused unless --resume",
    )
    parser.add_argument(
        "--resume",
        action="store_true",
        help="go on with the --out file: the runs in it are not run again",
    )


def add_commands(subparsers) -> None:
    from fuzzynav.app.experiments import tuning
    from fuzzynav.app.experiments.batch_runs import add_engine_option
    from fuzzynav.app.experiments.executor import add_executor_options
    from fuzzynav.controller.registry import controller_names
    from fuzzynav.world.layouts import FAMILIES
    from fuzzynav.world.perception import PERCEPTION_MODES

    tuning.add_commands(subparsers)

    p = subparsers.add_parser(
        "sweep", help="run a controller on seeded random layouts; success rate"
    )
    add_geometry_option(p)
    p.add_argument(
        "--n",
        type=integer_in(1, MAX_LAYOUTS),
        default=200,
        help=f"number of layouts (default 200, at most {MAX_LAYOUTS})",
    )
    p.add_argument("--seed", type=seed_type, default=1, help="layout seed (default 1)")
    p.add_argument(
        "--family", default="standard", choices=FAMILIES, help="layout family (default standard)"
    )
    p.add_argument(
        "--controller",
        default="paper",
        choices=controller_names(),
        help="the controller swept (default paper)",
    )
    p.add_argument(
        "--perception",
        default="ideal",
        choices=PERCEPTION_MODES,
        help="ideal: exact nearest obstacle; ultrasonic: the three range sensors (default ideal)",
    )
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
        default=None,
        metavar="DIR",
        help="write every failed run of --controller to DIR: its layout as a "
        "scenario file (to run again) and a rerun recording (1-4 MB "
        "each)",
    )
    p.set_defaults(func=cmd_sweep)

    c = subparsers.add_parser(
        "compare", help="the paper's Table 4: controllers on s1-s3 beside the paper"
    )
    add_geometry_option(c)
    c.add_argument(
        "--controllers",
        type=_csv,
        default=None,
        help="comma-separated (default: paper,baseline,fuzzynav,p where available)",
    )
    c.add_argument(
        "--perception",
        default="ideal",
        choices=PERCEPTION_MODES,
        help="ideal: exact nearest obstacle; ultrasonic: the three range sensors (default ideal)",
    )
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
