"""``fuzzynav tune``: seeded differential evolution of a controller's membership functions.

The cost of a parameter vector, and the runs it is made of, are :mod:`.objective`'s; the
search itself (:func:`tune`) is :mod:`.search`'s.

``--method de`` (the default): ``scipy.optimize.differential_evolution`` runs with a fixed
seed, ``updating="deferred"``, ``polish=False`` and the starting vector in its initial
population; the cost of a generation is mapped over the executor (``--executor
serial|local|dask``, ``--workers``, ``--scheduler``: app/experiments/executor.py) in order, so the
result does not depend on the executor or the number of workers. ``--radius R`` narrows every bound to the starting value +- R times
the bound's span (a local DE around a vector that already works).

``--method nelder-mead`` or ``powell``: ``scipy.optimize.minimize`` from the starting
vector, within the bounds, ``--maxiter`` iterations (deterministic, one process).

The starting vector is the tunable's own (``initial_vector()``), or ``--x0 FILE``: a rule
base whose header has a ``tuned vector:`` line, or a ``--checkpoint`` file. ``--free``
restricts the search to the parameters whose names start with one of the given prefixes
(the others stay at the starting vector). ``--clearance-weight`` sets the weight of the
clearance hinge (default 20 per metre).
"""

from __future__ import annotations

import inspect
import math
import os
import time
from pathlib import Path

import numpy as np

from fuzzynav.app.args import (
    UsageError,
    add_force_option,
    comma_list,
    float_in,
    integer_in,
    named_list,
    print_json,
    seed_type,
)
from fuzzynav.app.experiments.objective import (
    CLEARANCE_MARGIN_M,
    CLEARANCE_WEIGHT,
    SAFE_CLEARANCE_M,
    build_cases,
)
from fuzzynav.app.experiments.search import tune
from fuzzynav.app.provenance import reproduce_line, shell_command
from fuzzynav.resources import escape_controls, shorten
from fuzzynav.safe_files import write_text_atomically


def reproduce_command(args) -> str:
    parts = ["fuzzynav", "tune", "--controller", args.controller]
    if args.scenarios:
        parts += ["--scenarios", ",".join(args.scenarios)]
    if args.layouts and args.n:
        parts += [
            "--layouts",
            args.layouts,
            "--n",
            str(args.n),
            "--layout-seed",
            str(args.layout_seed),
        ]
    parts += ["--perception", ",".join(args.perception)]
    method = getattr(args, "method", "de")
    if method != "de":
        parts += ["--method", method]
    if method == "cmaes":
        parts += ["--sigma", f"{args.sigma:g}"]
    if getattr(args, "x0", None) is not None:
        parts += ["--x0", str(args.x0)]
    if getattr(args, "free", None):
        parts += ["--free", ",".join(args.free)]
    if getattr(args, "radius", None) is not None:
        parts += ["--radius", str(args.radius)]
    if getattr(args, "clearance_weight", CLEARANCE_WEIGHT) != CLEARANCE_WEIGHT:
        parts += ["--clearance-weight", str(args.clearance_weight)]
    parts += ["--maxiter", str(args.maxiter)]
    if method in ("de", "cmaes"):
        parts += ["--popsize", str(args.popsize), "--seed", str(args.seed)]
    parts += ["--dt", str(args.dt)]
    return shell_command(parts)  # --out, --workers, --checkpoint do not change the result


def read_vector(path: Path, names: list[str]) -> np.ndarray:
    """A starting vector from a rule base's ``tuned vector:`` header line (by name) or
    from a ``--checkpoint`` file (whitespace-separated numbers, in order)."""
    from fuzzynav.resources import read_user_text

    # the one safe reader: a FIFO given as --x0 hung here, /dev/zero filled the memory
    text = read_user_text(path, "starting vector (rule base or checkpoint)")
    for line in text.splitlines():
        if line.startswith("# tuned vector:"):
            items = [item.strip() for item in line.split(":", 1)[1].split(",")]
            bad = [item for item in items if item.count("=") != 1]
            if bad:
                raise ValueError(
                    f"{path}: tuned vector: {shorten(bad[0], 60)!r} is not NAME=NUMBER"
                )
            pairs = dict(item.split("=") for item in items)
            missing = [n for n in names if n not in pairs]
            if missing:
                raise ValueError(f"{path}: tuned vector lacks {', '.join(missing)}")
            try:
                values = [float(pairs[n]) for n in names]
            except ValueError as exc:
                raise ValueError(f"{path}: tuned vector: {exc}") from None
            return _finite_vector(values, names, path)
    try:
        values = [float(v) for v in text.split()]
    except ValueError:
        raise ValueError(
            f"{path}: neither a '# tuned vector:' header nor a list of numbers"
        ) from None
    if len(values) != len(names):
        raise ValueError(f"{path}: {len(values)} numbers, the tunable has {len(names)} parameters")
    return _finite_vector(values, names, path)


def _finite_vector(values, names: list[str], path: Path) -> np.ndarray:
    """``values`` as an array; ValueError naming the file and the first number that is
    NaN or infinite (it started a search that failed in scipy)."""
    vector = np.array(values, dtype=float)
    for name, value in zip(names, vector):
        if not math.isfinite(value):
            raise ValueError(f"{path}: {name} = {value}: must be a finite number")
    return vector


def free_indices(names: list[str], prefixes) -> list[int] | None:
    """Indices of the parameters whose names start with one of ``prefixes`` (None: all)."""
    if not prefixes:
        return None
    idx = [i for i, n in enumerate(names) if any(n.startswith(p) for p in prefixes)]
    unused = [p for p in prefixes if not any(n.startswith(p) for n in names)]
    if unused:
        raise ValueError(f"--free {','.join(unused)}: no parameter name starts with it")
    return idx


def check_output_file(path: Path, option: str, inputs=(), *, replace: bool = True) -> Path:
    """Refuse (UsageError) an output path that cannot be written: a directory, a
    missing or read-only folder, a device or pipe, a file inside the installed package,
    one of ``inputs`` (the files the command reads), or with ``replace=False`` (a
    default name, no ``--force``) a file that exists. Creates nothing that stays."""
    import tempfile

    from fuzzynav.safe_files import check_output_path

    path = Path(path)
    if path.is_dir():
        raise UsageError(f"{option} {path}: is a directory, not a file")
    try:  # not the --x0 it starts from, nor a shipped rule base, nor a device
        check_output_path(path, option, inputs, stream_ok=False, replace=replace)
    except ValueError as exc:
        if "does not exist" not in str(exc) and "cannot write there" not in str(exc):
            raise UsageError(str(exc)) from None
    parent = path.parent if str(path.parent) else Path(".")
    if not parent.is_dir():
        raise UsageError(f"{option} {path}: folder {parent} does not exist")
    if path.exists() and not os.access(path, os.W_OK):
        raise UsageError(f"{option} {path}: the file is read-only")
    try:
        fd, probe = tempfile.mkstemp(prefix=".fuzzynav-probe-", dir=parent)
    except OSError as exc:
        raise UsageError(
            f"{option} {path}: cannot write in {parent} ({exc.strerror or exc})"
        ) from None
    os.close(fd)
    os.unlink(probe)
    return path


def add_commands(subparsers) -> None:
    p = subparsers.add_parser(
        "tune", help="tune a controller's membership functions (differential evolution)"
    )
    _add_study_options(p)
    _add_search_options(p)
    _add_output_options(p)
    p.set_defaults(func=cmd_tune)


def _add_study_options(p) -> None:
    """What is tuned, and on which runs: --controller, --scenarios, --layouts, --n,
    --layout-seed, --perception."""
    from fuzzynav.controller.registry import controller_names
    from fuzzynav.world.layouts import FAMILIES
    from fuzzynav.world.perception import PERCEPTION_MODES

    p.add_argument(
        "--controller",
        default="paper",
        choices=controller_names(tunable=True),
        help="the controller whose parameters are tuned (default paper)",
    )
    p.add_argument(
        "--scenarios",
        type=comma_list,
        default=["s1", "s2", "s3"],
        help="comma-separated scenarios (default s1,s2,s3; '' for none)",
    )
    p.add_argument(
        "--layouts",
        choices=FAMILIES,
        metavar="FAMILY",
        help=f"also tune on seeded random layouts of this family ({', '.join(FAMILIES)})",
    )
    p.add_argument("--n", type=integer_in(0), default=0, help="number of layouts (with --layouts)")
    p.add_argument(
        "--layout-seed", type=seed_type, default=0, help="seed of the layouts (default 0)"
    )
    p.add_argument(
        "--perception",
        type=named_list,
        default=["ideal", "ultrasonic"],
        help=f"comma-separated perception modes ({', '.join(PERCEPTION_MODES)}; default both)",
    )


def _add_search_options(p) -> None:
    """How the search runs (:mod:`.search`): --maxiter, --popsize, the executor and the
    engine, --seed, --method, --sigma, --x0, --free, --radius, --clearance-weight, --dt."""
    from fuzzynav.app.experiments.batch_runs import add_engine_option
    from fuzzynav.app.experiments.evolution import add_sigma_option
    from fuzzynav.app.experiments.executor import add_executor_options
    from fuzzynav.world.run_limits import MAX_CONTROL_PERIOD_S, MIN_CONTROL_PERIOD_S

    p.add_argument(
        "--maxiter",
        type=integer_in(1, 100_000),
        default=10,
        metavar="N",
        help="generations (default 10)",
    )
    p.add_argument(
        "--popsize",
        type=integer_in(1, 1000),
        default=4,
        metavar="K",
        help="population = popsize x parameters (default 4)",
    )
    add_executor_options(p)
    add_engine_option(p)
    p.add_argument("--seed", type=seed_type, default=0, help="seed of the optimiser (default 0)")
    p.add_argument(
        "--method",
        choices=("de", "cmaes", "nelder-mead", "powell"),
        default="de",
        help="differential evolution (default), CMA-ES from the start vector (--popsize "
        "candidates a generation, first step --sigma), or a local search from it",
    )
    add_sigma_option(p)
    p.add_argument(
        "--x0",
        type=Path,
        metavar="FILE",
        help="start from this vector: a rule base with a 'tuned vector:' header line, "
        "or a --checkpoint file (default: the tunable's own starting vector)",
    )
    p.add_argument(
        "--free",
        type=named_list,
        metavar="PREFIXES",
        help="tune only the parameters whose names start with one of these "
        "(comma-separated, e.g. phi_t,d_o); the rest stay at the start vector",
    )
    p.add_argument(
        "--radius",
        type=float_in(1e-9, 1e3),
        metavar="FRACTION",
        help="narrow every bound to start +- FRACTION x its span (default: full bounds)",
    )
    p.add_argument(
        "--clearance-weight",
        type=float_in(0.0, 1e9),
        default=CLEARANCE_WEIGHT,
        metavar="COST_PER_M",
        help=f"cost per metre of clearance below {SAFE_CLEARANCE_M + CLEARANCE_MARGIN_M:g} m "
        f"(default {CLEARANCE_WEIGHT:g})",
    )
    p.add_argument(
        "--dt",
        type=float_in(MIN_CONTROL_PERIOD_S, MAX_CONTROL_PERIOD_S, " s"),
        metavar="SECONDS",
        help="control period while tuning (default: the controller's own, 0.05 s for "
        "paper: the plant is exact at any step, runs are checked at 0.02 s "
        "afterwards; fuzzynav's memory counts control calls, so only 0.02 s)",
    )


def _add_output_options(p) -> None:
    """What it writes: --out, --force, --checkpoint, --json."""
    p.add_argument(
        "--out",
        type=Path,
        metavar="PATH",
        help="where to write the tuned file (default: ./CONTROLLER_tuned.toml in the "
        "current folder, never over an existing one unless --force; the shipped files "
        "are never overwritten)",
    )
    add_force_option(p, "the default ./CONTROLLER_tuned.toml")
    p.add_argument(
        "--checkpoint",
        type=Path,
        metavar="PATH",
        help="write the best vector so far to this file after every generation",
    )
    p.add_argument("--json", action="store_true", help="print one JSON object at the end")


def _checked_options(args):
    """``(tunable, its parameter names, x0, free)`` of ``args`` once every option that can be checked before
    the tuning is (UsageError otherwise); fills in the defaults of ``--out`` and ``--dt``."""
    from fuzzynav.controller.tuning import tunable as get_tunable
    from fuzzynav.world.perception import PERCEPTION_MODES

    for mode in args.perception:
        if mode not in PERCEPTION_MODES:
            raise UsageError(f"--perception {mode!r}: must be among {', '.join(PERCEPTION_MODES)}")
    if args.maxiter < 1 or args.popsize < 1:
        raise UsageError("--maxiter and --popsize must be >= 1")
    if args.radius is not None and args.radius <= 0:
        raise UsageError("--radius must be > 0")
    t = get_tunable(args.controller)
    # a path given is asked for; the default name never replaces an earlier result
    # unless --force
    replace = args.out is not None or getattr(args, "force", False)
    if args.out is None:  # never the shipped file: that lives inside the installation
        args.out = Path.cwd() / f"{args.controller}_tuned.toml"
    # Before the tuning: an hour of tuning must not end in "cannot write there".
    check_output_file(args.out, "--out", [args.x0], replace=replace)
    if args.checkpoint is not None:
        check_output_file(args.checkpoint, "--checkpoint", [args.out])
    for name in ("clearance_weight", "radius"):
        value = getattr(args, name)
        if value is not None and not math.isfinite(value):  # called from code, not argparse
            raise UsageError(f"--{name.replace('_', '-')} {value!r}: must be a finite number")
    fixed = getattr(t, "control_period_s", None)  # a controller that counts its calls
    if args.dt is None:
        args.dt = fixed if fixed is not None else 0.05
    elif fixed is not None and abs(args.dt - fixed) > 1e-12:
        raise UsageError(
            f"--dt {args.dt:g}: {t.name} counts its control calls and runs only at "
            f"its control period, {fixed:g} s"
        )
    if not (math.isfinite(args.dt) and args.dt > 0):
        raise UsageError(f"--dt {args.dt!r}: must be a positive number of seconds")
    names = t.parameter_names()
    try:
        x0 = read_vector(args.x0, names) if args.x0 is not None else None
        free = free_indices(names, args.free)
    except (OSError, ValueError) as exc:
        raise UsageError(str(exc)) from None
    return t, names, x0, free


def _write_checkpoint(console, path: Path, x, step: str, gen: int) -> None:
    """The best vector so far, in case the run must be cut short; a warning (and the
    tuning goes on) when it cannot be written."""
    try:  # whole or not at all: the last good checkpoint survives a full disk
        write_text_atomically(path, " ".join(repr(float(v)) for v in x) + "\n")
    except OSError as exc:  # a checkpoint is insurance: the tuning goes on
        from rich.markup import escape as markup

        console.print(
            markup(
                f"fuzzynav: warning: --checkpoint "
                f"{escape_controls(str(path))} not written at {step} "
                f"{gen} ({exc.strerror or exc}); the one before is unchanged; "
                "tuning goes on"
            )
        )


def _tune_with_progress(args, t, cases, x0, free, console, step: str, start: float):
    """:func:`tune` on the executor of ``args`` with a progress bar (lines on stderr when
    it is not a terminal) and ``--checkpoint``; a :class:`.search.TuneResult`."""
    from rich.progress import (
        BarColumn,
        Progress,
        TextColumn,
        TimeElapsedColumn,
        TimeRemainingColumn,
    )

    from fuzzynav.app.experiments.executor import SerialExecutor, executor_from_args

    # DE and CMA-ES evaluate a population a generation (mapped in order: the same result
    # on any executor); a local search is sequential: no pool or cluster for it
    population = args.method in ("de", "cmaes")
    executor = executor_from_args(args) if population else SerialExecutor()
    with (
        executor,
        Progress(
            TextColumn(step + " {task.completed}/{task.total}"),
            BarColumn(),
            TextColumn("best cost {task.fields[best]}"),
            TextColumn("{task.fields[seen]}"),
            TimeElapsedColumn(),
            TimeRemainingColumn(),
            console=console,
            disable=args.json,
        ) as progress,
    ):
        task = progress.add_task("tune", total=args.maxiter, best="-", seen="")

        def on_evaluation(count, best):
            progress.update(task, best=f"{best:.4f}", seen=f"{count} candidates")
            if count % 50 == 0 and not console.is_terminal and not args.json:
                console.print(
                    f"candidate {count}: best cost {best:.4f} ({time.perf_counter() - start:.0f} s)"
                )

        def on_generation(gen, best, x):
            if args.checkpoint is not None:
                _write_checkpoint(console, args.checkpoint, x, step, gen)
            progress.update(task, completed=gen, best=f"{best:.4f}")
            if not console.is_terminal and not args.json:
                console.print(
                    f"{step} {gen}/{args.maxiter}: best cost {best:.4f} "
                    f"({time.perf_counter() - start:.0f} s)"
                )

        result = tune(
            controller=t,
            cases=cases,
            generations=args.maxiter,
            popsize=args.popsize,
            seed=args.seed,
            executor=executor,
            on_generation=on_generation,
            control_period_s=args.dt,
            method=args.method,
            x0=x0,
            free=free,
            radius=args.radius,
            clearance_weight=args.clearance_weight,
            on_evaluation=on_evaluation,
            sigma0=args.sigma,
            engine=getattr(args, "engine", "pymunk"),
            on_fallback=lambda message: console.print(f"fuzzynav: {message}"),
        )
    return result


def fresh_default_out(out: Path, console, command: str) -> Path:
    """``out``, a default name checked free when the command started, or, when a file
    was made there meanwhile (another run of the command), a fresh name beside it, said
    on ``console``: a name the command chose never replaces a file it did not write."""
    from fuzzynav.safe_files import free_path

    if not os.path.lexists(out):
        return out
    fresh = free_path(out)
    console.print(
        escape_controls(
            f"fuzzynav: {out} exists now (not written by this {command}): the result is "
            f"written as {fresh}"
        ),
        markup=False,
        highlight=False,
        soft_wrap=True,
    )
    return fresh


def _save_tuned(t, x, out: Path, header: str) -> list[Path]:
    """The tuned files, the command that reproduces them in their header (a tunable that
    takes no header gets it prepended to its .toml file)."""
    if "header" in inspect.signature(t.save).parameters:
        return t.save(x, out, header=header)
    paths = t.save(x, out)
    for path in paths:
        if path.suffix == ".toml":
            text = path.read_text(encoding="utf-8")
            note = "".join(f"# {line}\n" for line in header.splitlines())
            write_text_atomically(path, note + text)
    return paths


def cmd_tune(args) -> int:
    from rich.console import Console

    default_out = args.out is None and not getattr(args, "force", False)
    t, names, x0, free = _checked_options(args)
    cases = build_cases(args.scenarios, args.perception, args.layouts, args.n, args.layout_seed)
    console = Console(stderr=True)
    command = reproduce_command(args)
    n_free = len(names) if free is None else len(free)
    console.print(
        f"tuning {t.name} ({args.method}): {n_free} of {len(names)} parameters, "
        f"{len(cases)} runs per candidate"
        + (f", population {args.popsize * n_free}" if args.method == "de" else "")
    )
    start = time.perf_counter()
    step = "generation" if args.method == "de" else "iteration"
    result = _tune_with_progress(args, t, cases, x0, free, console, step, start)
    elapsed = time.perf_counter() - start
    header = (
        reproduce_line(command) + "\n"
        f"(best cost {result.cost:.6f} after {result.generations} {step}s, {result.evaluations} candidates; "
        f"cost: app/experiments/objective.py)"
    )
    if default_out:  # checked at the start; made meanwhile (another tune?)
        args.out = fresh_default_out(args.out, console, "tune")
    paths = _save_tuned(t, result.vector, args.out, header)
    out = {
        "controller": t.name,
        "cost": float(result.cost),
        "generations": int(result.generations),
        "evaluations": int(result.evaluations),
        "wall_time_s": elapsed,
        "history": result.history,
        "vector": dict(zip(t.parameter_names(), map(float, result.vector))),
        "written": [str(p) for p in paths],
        "command": command,
    }
    if args.json:
        print_json(out)
    else:
        from rich.markup import escape as markup

        # the paths and the command hold the user's file names: text, escaped
        Console().print(
            markup(
                escape_controls(
                    f"best cost {result.cost:.4f} after {result.generations} {step}s "
                    f"({result.evaluations} candidates, {elapsed:.0f} s); wrote "
                    f"{', '.join(map(str, paths))}",
                )
                + f"\nreproduce with:\n  {escape_controls(command)}"
            )
        )
    return 0
