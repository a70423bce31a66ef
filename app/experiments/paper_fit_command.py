"""``fuzzynav fit-paper``'s command line: its options, their checks, the fit
(:func:`.paper_fit.fit`), the fitted rule base with the command that reproduces it in its
header, and the report. What is fitted, and its cost, are :mod:`.paper_fit`'s.
"""

from __future__ import annotations

import math
import time
from pathlib import Path

from fuzzynav.app.args import UsageError, float_in, integer_in, print_json, seed_type
from fuzzynav.app.experiments.paper_fit import HUSKY_PERCEPTION, SHIPPED_READING, fit, read_fitted
from fuzzynav.app.provenance import reproduce_line


def cmd_fit_paper(args) -> int:
    from rich.console import Console

    from fuzzynav.app.experiments.tuning import check_output_file, fresh_default_out
    from fuzzynav.controller.paper_design import PaperDesignTunable

    if args.husky_only and not args.husky:
        raise UsageError("--husky-only: give --husky too (the Husky geometry's runs are its cost)")
    if not (math.isfinite(args.dt) and 0.001 <= args.dt <= 0.1):
        raise UsageError(f"--dt {args.dt!r}: must be from 0.001 to 0.1 s")
    out = args.out if args.out is not None else Path.cwd() / "paper.toml"
    if not out.parent.is_dir():
        raise UsageError(f"--out {out}: folder {out.parent} does not exist")
    check_output_file(out, "--out", [args.x0])  # not its --x0, nor a shipped rule base
    if args.checkpoint is not None:
        check_output_file(args.checkpoint, "--checkpoint", [out])
    x0 = read_fitted(args.x0) if args.x0 is not None else None
    console = Console(stderr=True)
    started = time.perf_counter()

    def on_generation(k, best):
        console.print(
            f"generation {k}/{args.maxiter}: best cost {best:.4f} ({time.perf_counter() - started:.0f} s)"
        )

    x, best, nit, nfev = fit(
        args.maxiter,
        args.popsize,
        args.seed,
        args.workers,
        args.dt,
        x0,
        on_generation,
        checkpoint=args.checkpoint,
        sigma0=args.sigma,
        husky=args.husky,
        husky_perception=tuple(args.husky_perception.split(",")),
        engine=args.engine,
        husky_weight=args.husky_weight,
        paper_geometry=not args.husky_only,
    )
    elapsed = time.perf_counter() - started
    command = (
        f"fuzzynav fit-paper --maxiter {args.maxiter} --popsize {args.popsize} "
        f"--seed {args.seed} --dt {args.dt:g} --workers {args.workers} --sigma {args.sigma:g}"
        + (" --engine pymunk" if args.engine == "pymunk" else "")
        + (" --husky" if args.husky else "")
        + (" --husky-only" if args.husky_only else "")
        + (
            f" --husky-perception {args.husky_perception}"
            if args.husky and args.husky_perception != ",".join(HUSKY_PERCEPTION)
            else ""
        )
        + (
            f" --husky-weight {args.husky_weight:g}"
            if args.husky and args.husky_weight != 1
            else ""
        )
        + (f" --x0 {args.x0.name}" if args.x0 is not None else "")
    )
    header = (
        reproduce_line(command) + "\n"
        f"(best cost {best:.6f} after {nit} generations, {nfev} candidates, "
        f"{elapsed:.0f} s on {args.workers} workers; cost: app/experiments/paper_fit.py)\n"
        "The start heading is the scenarios' (a reading of the text), never fitted; Table 1's "
        "NONE for d_o reads as the text has it (docs/paper-controller.md)."
    )
    if args.out is None and not getattr(args, "force", False):  # checked at the start
        out = fresh_default_out(out, console, "fit-paper")
    [path] = PaperDesignTunable().save(
        x, out, header=header, unsensed_none=SHIPPED_READING.none_reading == "unsensed"
    )
    summary = {"out": str(path), "cost": best, "generations": nit, "seconds": elapsed}
    if args.json:
        print_json(summary)
    else:
        from rich.markup import escape as markup

        from fuzzynav.resources import escape_controls

        console.print(
            markup(f"wrote {escape_controls(str(path))} (cost {best:.4f}, {elapsed:.0f} s)")
        )
    return 0


def add_commands(subparsers) -> None:
    from fuzzynav.app.experiments.batch_runs import add_engine_option
    from fuzzynav.app.experiments.evolution import add_sigma_option

    p = subparsers.add_parser(
        "fit-paper",
        help="fit the paper controller's membership functions to the paper's Table 4",
    )
    p.add_argument(
        "--maxiter", type=integer_in(1), default=30, metavar="N", help="generations (default 30)"
    )
    p.add_argument(
        "--popsize",
        type=integer_in(1),
        default=16,
        metavar="K",
        help="candidates a generation (default 16)",
    )
    p.add_argument("--seed", type=seed_type, default=0, help="seed of the optimiser (default 0)")
    p.add_argument(
        "--workers", type=integer_in(1), default=2, metavar="N", help="worker processes (default 2)"
    )
    p.add_argument(
        "--dt",
        type=float,
        default=0.05,
        metavar="SECONDS",
        help="control period while fitting (default 0.05 s; the plant is exact at any step)",
    )
    p.add_argument(
        "--x0",
        type=Path,
        metavar="FILE",
        help="start from a fitted file's 'tuned vector:' line",
    )
    p.add_argument(
        "--out",
        type=Path,
        metavar="PATH",
        help="where to write the fitted rule base (default: ./paper.toml)",
    )
    add_sigma_option(p)
    p.add_argument(
        "--husky",
        action="store_true",
        help="also hold s1-s3 in the Husky geometry to its bounds",
    )
    p.add_argument(
        "--husky-only",
        action="store_true",
        help="with --husky: the Husky geometry's runs alone, not the paper's (a rule base "
        "for the Husky only, as rules/paper_husky.toml)",
    )
    p.add_argument(
        "--husky-perception",
        choices=("ideal,ultrasonic", "ideal", "ultrasonic"),
        default="ideal,ultrasonic",
        help="with --husky: the perception modes of its runs (default both)",
    )
    p.add_argument(
        "--husky-weight",
        type=float_in(0.0, 1000.0),
        default=1.0,
        metavar="W",
        help="with --husky: the weight of the Husky runs' hinges against the paper's "
        "numbers (default 1; the shipped rule base: 10, the Husky's bounds first)",
    )
    p.add_argument(
        "--checkpoint",
        type=Path,
        metavar="PATH",
        help="write the best vector so far to this file after every generation (--x0 reads it)",
    )
    p.add_argument("--json", action="store_true", help="print one JSON object at the end")
    add_engine_option(p)
    p.set_defaults(func=cmd_fit_paper)
