"""A study: many runs of seeded layouts, their rows, and where they run.

A study is a list of :class:`LayoutJob` (layout ``index`` of a family and seed, one
controller, perception and options); each job gives one row (:func:`run_layout_row`),
the same on any executor and any worker. This module holds what every study shares: the
jobs and their keys, the fingerprint that says what made a row (``--resume`` keeps only
rows of the study it runs), running jobs on an executor (:func:`run_jobs`) and, for the
commands, with a progress bar, ``--out`` and Ctrl-C (:func:`run_study`). A row's key and
the check of a row read back are :mod:`.rows`'. ``sweep`` (:mod:`.sweep`) and ``compare``'s sweep
(:mod:`.compare`) are studies; so is the ablation (scripts/fuzzynav_ablation.py).

A run "succeeds" when the target is reached without a collision; the stricter "safe
success" also asks for a minimum clearance >= 0.25 m (the paper's safe distance).
"""

from __future__ import annotations

import collections
import copy
import functools
import json
import time
from collections.abc import Iterator, Sequence, Set
from dataclasses import dataclass, field
from pathlib import Path

from fuzzynav.app.args import UsageError

# The rows of both engines come from one function (app/experiments/batch_runs.py).
from fuzzynav.app.experiments.batch_runs import layout_row
from fuzzynav.app.experiments.rows import check_row, describe_row, row_key
from fuzzynav.app.provenance import fuzzynav_version

SAFE_CLEARANCE_M = 0.25


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
    #: a scenario of a set (:mod:`.study_sources`; None: the family's layout ``index``)
    scenario: object = field(default=None, compare=False, repr=False)
    #: a controller object (None: the registry's ``controller``); copied for each run
    controller_object: object = field(default=None, compare=False, repr=False)

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


def _rules_digest(controller: str, geometry: str) -> str:
    """What a study's runs are made with besides the code: the rules of a fresh
    controller of that name (:func:`app.runs.rules_digest`; none for a controller
    object's label, which carries its own digest) and the robot (``husky.toml``)."""
    import hashlib

    from fuzzynav.app.runs import rules_digest
    from fuzzynav.controller.registry import make_controller
    from fuzzynav.resources import MAX_INPUT_BYTES, asset_path, read_user_bytes

    try:
        rules = rules_digest(make_controller(controller, geometry=geometry))
    except (ValueError, ImportError, AttributeError):  # a controller object's label
        rules = None
    digest = hashlib.sha256(f"{rules}\0".encode())
    robot = asset_path("husky.toml")
    digest.update(read_user_bytes(robot, "shipped file", MAX_INPUT_BYTES))
    return digest.hexdigest()


_DIGESTS: dict[tuple[str, str], str] = {}


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

    rules_key = (controller, dict(options).get("geometry", "husky"))
    if rules_key not in _DIGESTS:
        _DIGESTS[rules_key] = _rules_digest(*rules_key)
    what = json.dumps(
        [
            fuzzynav_version(),
            controller,
            _DIGESTS[rules_key],
            list(parts_off),
            family,
            seed,
            perception,
            dict(options),
        ],
        sort_keys=True,
    )
    return hashlib.sha256(what.encode()).hexdigest()[:16]


def run_layout(job: LayoutJob) -> dict:
    """The row of one job (top level: what an executor sends to a worker)."""
    return run_layout_row(
        job.family,
        job.seed,
        job.index,
        controller=job.controller,
        perception=job.perception,
        parts_off=job.parts_off,
        scenario=job.scenario,
        controller_object=job.controller_object,
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
    scenario=None,
    controller_object=None,
    **options,
) -> dict:
    """Run layout ``index`` of ``family``/``seed``; its row (what ``--out`` writes).

    ``scenario`` and ``controller_object``, when given, are run in place of the
    family's layout and the registry's ``controller`` (a copy of the object: every run
    starts from the same state). ``options`` go to :func:`app.runs.build_simulation` as keywords. The row: the job
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

    if scenario is None:
        scenario = generate_layout(family, seed, index)
    sim = build_simulation(
        scenario,
        controller,
        perception=perception,
        seed=seed,
        controller_object=None if controller_object is None else copy.deepcopy(controller_object),
        **options,
    )
    if parts_off:
        sim.controller.set_parts_off(list(parts_off))
    result = sim.run()
    job = LayoutJob(
        family, seed, index, controller, perception, tuple(parts_off), tuple(options.items())
    )
    return layout_row(job, scenario, result.metrics, sim.model, sim.voltage_limit_v)


class LayoutJobs(Sequence):
    """The jobs of one or more sweeps (layouts 0..n-1 of a study each), made when
    asked for: iterating, indexing and counting them builds no list (a sweep of
    100,000 layouts of two controllers built and keyed 200,000 jobs, 2 s and 80 MB,
    before its first run). ``a + b`` chains them; slicing gives a list.
    :attr:`keys` is the set of their keys, tested without building it."""

    def __init__(self, parts=()):
        # (family, seed, controller, perception, parts_off, options, n) per sweep
        self.parts = tuple(parts)

    def __len__(self) -> int:
        return sum(part[-1] for part in self.parts)

    def _job(self, part, index: int) -> LayoutJob:
        family, seed, controller, perception, parts_off, options, _ = part
        return LayoutJob(family, seed, index, controller, perception, parts_off, options)

    def __iter__(self) -> Iterator[LayoutJob]:
        for part in self.parts:
            for index in range(part[-1]):
                yield self._job(part, index)

    def __getitem__(self, item):
        if isinstance(item, slice):
            return [self[i] for i in range(*item.indices(len(self)))]
        if isinstance(item, bool) or not isinstance(item, int):
            raise TypeError(f"job indices are integers, not {type(item).__name__}")
        i = item + len(self) if item < 0 else item
        if i >= 0:
            for part in self.parts:
                if i < part[-1]:
                    return self._job(part, i)
                i -= part[-1]
        raise IndexError(f"job {item} of {len(self)}")

    def __add__(self, other):
        if isinstance(other, LayoutJobs):
            return LayoutJobs(self.parts + other.parts)
        return list(self) + list(other)

    def __radd__(self, other):
        return list(other) + list(self)

    @property
    def keys(self) -> JobKeys:
        return JobKeys(self)

    def study_counts(self, done=frozenset()) -> dict[tuple, int]:
        """How many of the jobs not ``done`` (keys) each study has, by (controller,
        perception, parts off, options): what the batch engine cuts into batches."""
        left = collections.Counter(key[:-1] for key in done)
        counts: dict[tuple, int] = {}
        for family, seed, controller, perception, parts_off, options, n in self.parts:
            study = _study_key(controller, parts_off, family, seed, perception, options)
            taken = min(n, left.pop(study, 0))
            what = (controller, perception, parts_off, options)
            counts[what] = counts.get(what, 0) + n - taken
        return counts


class JobKeys(Set):
    """The keys of :class:`LayoutJobs`, as a set: ``key in keys`` compares the study's
    part of the key and the index range, without a set of every key."""

    def __init__(self, jobs: LayoutJobs):
        self.jobs = jobs
        self._studies: dict[tuple, int] = {}
        for part in jobs.parts:
            family, seed, controller, perception, parts_off, options, n = part
            study = _study_key(controller, parts_off, family, seed, perception, options)
            self._studies[study] = max(n, self._studies.get(study, 0))

    def __contains__(self, key) -> bool:
        if not isinstance(key, tuple) or not key:
            return False
        index = key[-1]
        n = self._studies.get(key[:-1])
        return n is not None and isinstance(index, int) and 0 <= index < n

    def __iter__(self):
        seen = set()
        for job in self.jobs:  # (a study chained twice gives its keys once)
            key = job.key()
            if key not in seen:
                seen.add(key)
                yield key

    def __len__(self) -> int:
        return sum(self._studies.values())


def sweep_jobs(
    controller, n, seed, family="standard", perception="ideal", parts_off=(), options=None
) -> LayoutJobs:
    """The jobs of one sweep: layouts 0..n-1, made as they are asked for."""
    opts = tuple(sorted((options or {}).items()))
    return LayoutJobs([(family, seed, controller, perception, tuple(parts_off), opts, int(n))])


def run_jobs(
    jobs, executor=None, *, log=None, progress=None, engine="pymunk", on_fallback=None, on_row=None
) -> list[dict]:
    """The rows of ``jobs``, in the jobs' order, whatever order they finish in.

    ``executor``: an :class:`app.experiments.executor.Executor` (default: serial). ``log``: an open
    :class:`app.experiments.resultlog.ResultLog`; the jobs it holds rows of are not run again, each
    new row is written to it as it arrives, and rows of other studies are refused.
    ``progress(done, total)`` after each row (and once at the start); ``on_row(row)``
    with each new row as it arrives (what a Ctrl-C keeps). ``engine``:
    ``pymunk`` (one task per run) or ``batch`` (:mod:`app.experiments.batch_runs`: batches of runs
    as tasks; controllers it cannot drive run on pymunk, and ``on_fallback(message)``
    is told so).
    """
    if engine not in ("pymunk", "batch"):
        raise ValueError(f"engine = {engine!r}: must be pymunk or batch")
    from fuzzynav.app.experiments.executor import SerialExecutor

    executor = executor or SerialExecutor()
    # LayoutJobs (a sweep) are made and keyed as they go to the executor; a list of
    # jobs (compare's, a test's) is keyed once here.
    keys = jobs.keys if isinstance(jobs, LayoutJobs) else {job.key() for job in jobs}
    found = {}
    if log is not None:
        log.check_belongs(keys)  # every row there is of these jobs, or refused
        found = dict(log.rows)
    done = frozenset(found)
    todo = (job for job in jobs if job.key() not in done)
    if progress:
        progress(len(found), len(jobs))
    if engine == "batch":
        from fuzzynav.app.experiments.batch_runs import lazy_tasks, tasks

        if isinstance(jobs, LayoutJobs):
            items, fallbacks, n_items = lazy_tasks(todo, jobs.study_counts(done), executor.workers)
        else:
            items, fallbacks = tasks(list(todo), executor.workers)
            n_items = len(items)
        for message in fallbacks:
            if on_fallback is not None:
                on_fallback(message)
        results = executor.imap_unordered(run_task, items, total=n_items)
    else:
        results = executor.imap_unordered(run_layout, todo, total=len(jobs) - len(done))
    try:
        for batch in results:
            for row in batch if engine == "batch" else [batch]:
                if row_key(row) not in keys:  # made by a worker with other code or rules
                    first = next(job for job in jobs if job.key() not in done)
                    raise ValueError(
                        f"a worker's row is not of this study ({describe_row(row)}, this "
                        f"study's fingerprint {first.fingerprint()}): every worker needs "
                        "the same fuzzynav version and rule bases as this machine"
                    )
                if log is not None:
                    log.write(row)
                found[row_key(row)] = row
                if on_row is not None:
                    on_row(row)
            if progress:
                progress(len(found), len(jobs))
    finally:
        results.close()
    return [found[job.key()] for job in jobs]


class StudyInterrupted(Exception):
    """Ctrl-C during a study: what was kept has been said on stderr (exit status 130)."""


def progress_bar(label: str, quiet: bool):
    """The commands' progress bar of runs (done / total, runs/s, times), on stderr."""
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
        keys = jobs.keys if isinstance(jobs, LayoutJobs) else (job.key() for job in jobs)
        log.check_belongs(keys, describe_row)  # before a worker starts
    start = time.perf_counter()
    try:
        with contextlib.ExitStack() as stack:
            if log is not None:
                # locked before the workers start: a second run on this file refuses
                # here, naming this one's process id
                stack.enter_context(log)
            executor = stack.enter_context(executor_from_args(args, jobs=len(jobs)))
            with progress_bar(f"{label} ({executor.describe()})", quiet) as bar:
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


def _options(args) -> dict:
    """Keyword options of build_simulation that a command passes to every run: its
    ``--geometry`` when it has one and it is not the default (so that a row of the
    default study stays as it was), and its ``--field-of-view`` when given."""
    geometry = getattr(args, "geometry", "husky")
    options = {} if geometry == "husky" else {"geometry": geometry}
    field = getattr(args, "field_of_view", None)
    if field is not None:
        options["field_of_view_deg"] = field
    return options


def add_study_output_options(parser) -> None:
    """``--out PATH.jsonl`` and ``--resume``."""
    parser.add_argument(
        "--out",
        type=Path,
        metavar="PATH.jsonl",
        help="write every run as one JSON line as it finishes (docs/experiments.md); an "
        "existing file is refused unless --resume",
    )
    parser.add_argument(
        "--resume",
        action="store_true",
        help="go on with the --out file: the runs in it are not run again",
    )
