"""``fuzzynav tune``, ``fuzzynav sweep`` and ``fuzzynav compare`` (issue 3).

``sweep`` runs a controller on seeded random layouts (:mod:`world.layouts`) and reports
how often it succeeds; ``compare`` runs controllers on s1-s3 and prints the paper's
Table 4 rows beside the published numbers. ``tune`` lives in :mod:`app.tuning`.

A sweep run "succeeds" when the target is reached without a collision; the stricter
"safe success" also asks for a minimum clearance >= 0.25 m (the paper's safe distance).
"""

from __future__ import annotations

import math
import statistics
import time
from pathlib import Path

SAFE_CLEARANCE_M = 0.25

# Paper Table 4 (notes section 2): method of ref. [19] | proposed, for S1 / S2 / S3.
PAPER_TABLE4 = {
    "baseline": {  # the paper's ref. [19]; our baseline is only a stand-in for it
        "path_length_m": (12.4996, 20.7641, 22.0387),
        "mad_m": (0.7037, 2.6611, 2.8844),
        "rmse_m": (0.8964, 3.2797, 3.4752),
        "min_center_distance_m": (0.3891, 2.22, 2.3),
    },
    "paper": {
        "path_length_m": (11.8332, 11.8672, 11.8263),
        "mad_m": (0.3653, 0.5727, 0.6298),
        "rmse_m": (0.4825, 0.7449, 0.7474),
        "min_center_distance_m": (0.2557, 0.3834, 0.6398),
    },
}
TABLE4_ROWS = ("path_length_m", "mad_m", "rmse_m", "min_center_distance_m")
SCENARIOS = ("s1", "s2", "s3")


# --------------------------------------------------------------------------- sweep


def _sweep_one(job):
    """One layout run (top level: picklable for a worker pool)."""
    family, seed, index, controller, perception, parts_off = job
    from fuzzynav.app.runs import build_simulation
    from fuzzynav.world.layouts import generate_layout

    scenario = generate_layout(family, seed, index)
    sim = build_simulation(scenario, controller, perception=perception, seed=seed)
    if parts_off:
        sim.controller.set_parts_off(parts_off)
    result = sim.run()
    m = result.metrics
    straight = math.dist(scenario.start, scenario.target)
    return {
        "index": index,
        "outcome": result.outcome,
        "reached": bool(m["reached"]),
        "collided": bool(m["collided"]),
        "path_length_m": m["path_length_m"],
        "path_ratio": m["path_length_m"] / straight,
        "min_clearance_m": m["min_clearance_m"],
        "time_to_target_s": m["time_to_target_s"],
        "n_obstacles": len(scenario.obstacles),
    }


def _median(values):
    values = [v for v in values if v is not None and math.isfinite(v)]
    return statistics.median(values) if values else None


def sweep(
    controller: str,
    n: int,
    seed: int,
    family: str = "standard",
    perception: str = "ideal",
    workers: int = 1,
    progress=None,
    parts_off: tuple[str, ...] = (),
) -> dict:
    """Run ``n`` layouts; the summary dict ``sweep --json`` prints (with per-run rows).
    ``parts_off``: fuzzynav's parts to switch off (``assets/rules/fuzzynav_parts.toml``)."""
    from fuzzynav.controller.registry import controller_names, make_controller
    from fuzzynav.world.layouts import FAMILIES

    if n < 1:
        raise ValueError(f"n = {n}: must be >= 1")
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
        probe.set_parts_off(parts_off)  # an unknown part is refused before any run
        parts_off = probe.parts_off
    jobs = [(family, seed, i, controller, perception, parts_off) for i in range(n)]
    start = time.perf_counter()
    runs = []
    if workers > 1:
        import multiprocessing as mp

        with mp.get_context("fork").Pool(min(workers, n)) as pool:
            for row in pool.imap(_sweep_one, jobs):
                runs.append(row)
                if progress:
                    progress(len(runs))
    else:
        for job in jobs:
            runs.append(_sweep_one(job))
            if progress:
                progress(len(runs))
    ok = [r for r in runs if r["reached"] and not r["collided"]]
    safe = [
        r for r in ok if r["min_clearance_m"] is None or r["min_clearance_m"] >= SAFE_CLEARANCE_M
    ]
    return {
        "controller": controller,
        "parts_off": list(parts_off),
        "family": family,
        "perception": perception,
        "n": n,
        "seed": seed,
        "success_rate": len(ok) / n,
        "safe_success_rate": len(safe) / n,
        "reached": sum(r["reached"] for r in runs),
        "collisions": sum(r["collided"] for r in runs),
        "timeouts": sum(r["outcome"] == "timeout" for r in runs),
        "median_path_length_m": _median([r["path_length_m"] for r in ok]),
        "median_path_ratio": _median([r["path_ratio"] for r in ok]),
        "median_min_clearance_m": _median([r["min_clearance_m"] for r in runs]),
        "wall_time_s": time.perf_counter() - start,
        "runs": runs,
    }


def failed_runs(out: dict) -> list[dict]:
    """The runs of a sweep that did not reach their target without a collision."""
    return [r for r in out["runs"] if not (r["reached"] and not r["collided"])]


def write_failures(out: dict, directory, progress=None) -> list[dict]:
    """For every failed run of the sweep ``out``: its layout as a scenario file and a
    rerun recording of the run, in ``directory`` (which must exist).

    The scenario file runs again with ``fuzzynav run FILE --controller C --perception P
    --seed S`` (the command is in its header and in the recording); the run is driven
    again here to record it, and must end as it did in the sweep. Returns one dict per
    failure: index, outcome, ``scenario_file``, ``recording``.
    """
    from fuzzynav.app.cli import off_flag
    from fuzzynav.app.recording import record_run
    from fuzzynav.app.runs import build_simulation
    from fuzzynav.world.layouts import generate_layout
    from fuzzynav.world.scenario import load_scenario

    directory = Path(directory)
    family, seed = out["family"], out["seed"]
    controller, perception = out["controller"], out["perception"]
    parts_off = out.get("parts_off") or []
    off = off_flag(parts_off)
    written = []
    for done, run in enumerate(failed_runs(out), start=1):
        stem = f"{family}_seed{seed}_{run['index']:03d}"
        scenario_file = directory / f"{stem}.toml"
        command = (
            f"fuzzynav run {scenario_file} --controller {controller}{off} "
            f"--perception {perception} --seed {seed}"
        )
        scenario_file.write_text(
            f"# {family} layout #{run['index']} of seed {seed}, written by `fuzzynav sweep "
            f"--failures`: {controller} ({perception} perception) ended '{run['outcome']}'.\n"
            f"# Again: {command}\n\n" + generate_layout(family, seed, run["index"]).to_toml(),
            encoding="utf-8",
        )
        sim = build_simulation(
            load_scenario(scenario_file), controller, perception=perception, seed=seed
        )
        if parts_off:
            sim.controller.set_parts_off(parts_off)
        result = sim.run()
        if (result.outcome, result.metrics["collided"]) != (run["outcome"], run["collided"]):
            raise RuntimeError(
                f"{scenario_file}: the run ended '{result.outcome}' when driven "
                f"again, '{run['outcome']}' in the sweep"
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


def _sweep_with_bar(
    controller, n, seed, family, perception, workers, quiet, label="", parts_off=()
):
    from rich.console import Console
    from rich.progress import (
        BarColumn,
        MofNCompleteColumn,
        Progress,
        TextColumn,
        TimeRemainingColumn,
    )

    with Progress(
        TextColumn(f"sweep {label or controller}"),
        BarColumn(),
        MofNCompleteColumn(),
        TimeRemainingColumn(),
        console=Console(stderr=True),
        disable=quiet,
    ) as bar:
        task = bar.add_task("sweep", total=n)
        return sweep(
            controller,
            n,
            seed,
            family,
            perception,
            workers,
            progress=lambda done: bar.update(task, completed=done),
            parts_off=parts_off,
        )


def _fmt(value, digits=3):
    if value is None:
        return "-"
    if isinstance(value, bool):
        return "yes" if value else "no"
    if isinstance(value, float):
        return f"{value:.{digits}f}"
    return str(value)


def cmd_sweep(args) -> int:
    from rich.console import Console
    from rich.table import Table

    from fuzzynav.app.cli import parse_off, print_json

    _check_workers(args.workers)
    if args.failures is not None:
        from fuzzynav.app.figures import check_writable_dir

        check_writable_dir(args.failures, "--failures")  # before the sweep, not after
    beside = args.beside
    if beside == "auto":
        beside = "paper" if args.controller != "paper" else "none"
    parts_off = parse_off(args.off)
    label = args.controller + (f" without {', '.join(parts_off)}" if parts_off else "")
    out = _sweep_with_bar(
        args.controller,
        args.n,
        args.seed,
        args.family,
        args.perception,
        args.workers,
        args.json,
        label=label,
        parts_off=parts_off,
    )
    other = None
    if beside not in ("none", args.controller):
        # the same layouts, so that the two rates are comparable run for run
        other = _sweep_with_bar(
            beside, args.n, args.seed, args.family, args.perception, args.workers, args.json
        )
    failures = (
        _write_failures_with_bar(out, args.failures, args.json)
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
        print(f"open one with: rerun {failures[0]['recording']}")
    elif failures is not None:
        print(f"no failed runs: nothing written to {args.failures}")
    return 0


def _write_failures_with_bar(out, directory, quiet):
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
            out, directory, progress=lambda done: bar.update(task, completed=done)
        )


# --------------------------------------------------------------------------- compare


def table4_row(controller: str, scenario: str, index: int, result) -> dict:
    """One row of our Table 4: a run's metrics beside the paper's published numbers
    (``index`` is the scenario's column in the paper's table)."""
    m = result.metrics
    published = PAPER_TABLE4.get(controller)
    return {
        "controller": controller,
        "scenario": scenario,
        **{k: m[k] for k in TABLE4_ROWS},
        "min_clearance_m": m["min_clearance_m"],
        "time_to_target_s": m["time_to_target_s"],
        "reached": m["reached"],
        "collided": m["collided"],
        "outcome": result.outcome,
        "paper": {k: published[k][index] for k in TABLE4_ROWS} if published else None,
    }


def compare(
    controllers: list[str],
    perception: str = "ideal",
    sweep_n: int = 0,
    sweep_seed: int = 1,
    family: str = "standard",
    workers: int = 1,
    quiet: bool = True,
) -> dict:
    """Runs of each controller on s1-s3 (and optionally a sweep); the ``compare --json`` object."""
    from fuzzynav.app.runs import run_scenario

    rows = [
        table4_row(name, scenario, i, run_scenario(scenario, name, perception=perception, seed=0))
        for name in controllers
        for i, scenario in enumerate(SCENARIOS)
    ]
    sweeps = []
    if sweep_n > 0:
        for name in controllers:
            s = _sweep_with_bar(name, sweep_n, sweep_seed, family, perception, workers, quiet)
            s.pop("runs")
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


def cmd_compare(args) -> int:
    from rich.console import Console
    from rich.table import Table

    from fuzzynav.app.cli import UsageError, print_json
    from fuzzynav.controller.registry import controller_names

    offered = controller_names()
    wanted = args.controllers or [c for c in ("paper", "baseline", "fuzzynav", "p") if c in offered]
    for name in wanted:
        if name not in offered:
            raise UsageError(
                f"--controllers: {name!r} is not available (have {', '.join(offered)})"
            )
    _check_workers(args.workers)
    if args.sweep_n < 0:
        raise UsageError(f"--sweep-n {args.sweep_n}: must be >= 0")
    out = compare(
        wanted,
        args.perception,
        args.sweep_n,
        args.sweep_seed,
        args.family,
        args.workers,
        quiet=args.json,
    )
    if args.json:
        print_json(out)
        return 0
    console = Console()
    if not console.is_terminal:
        console = Console(width=200)
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
        )
    console.print(table)
    if "baseline" in wanted:
        console.print(
            "baseline: a STAND-IN for the paper's ref. [19] (controller/baseline.py); the "
            "numbers in brackets on its rows are the paper's ref. [19] numbers, not the stand-in's."
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
            "median path / straight",
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
                _fmt(s["median_min_clearance_m"]),
            )
        console.print(st)
    return 0


# --------------------------------------------------------------------------- CLI


def _check_workers(workers: int) -> None:
    from fuzzynav.app.cli import UsageError

    if not 1 <= workers <= 2:
        raise UsageError(f"--workers {workers}: must be 1 or 2 (the machine has 2 shared cores)")


def _csv(text: str) -> list[str]:
    return [t.strip() for t in text.split(",") if t.strip()]


def add_commands(subparsers) -> None:
    from fuzzynav.app import tuning
    from fuzzynav.app.cli import add_off_option, integer_in, seed_type
    from fuzzynav.controller.registry import controller_names
    from fuzzynav.world.layouts import FAMILIES
    from fuzzynav.world.perception import PERCEPTION_MODES

    tuning.add_commands(subparsers)

    p = subparsers.add_parser(
        "sweep", help="run a controller on seeded random layouts; success rate"
    )
    p.add_argument("--n", type=integer_in(1), default=200, help="number of layouts (default 200)")
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
    p.add_argument("--workers", type=int, default=1, help="worker processes, 1 or 2 (default 1)")
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
        type=int,
        default=100,
        help="also sweep N random layouts per controller (default 100; 0: none)",
    )
    c.add_argument(
        "--sweep-seed",
        type=seed_type,
        default=5,
        help="seed of that sweep (default 5, a seed no controller was designed or tuned on)",
    )
    c.add_argument("--family", default="standard", choices=FAMILIES, help="family of that sweep")
    c.add_argument(
        "--workers", type=int, default=2, help="worker processes for the sweep, 1 or 2 (default 2)"
    )
    c.add_argument("--json", action="store_true", help="print one JSON object")
    c.set_defaults(func=cmd_compare)
