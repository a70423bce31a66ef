"""fuzzynav: a Mamdani fuzzy navigator driving a skid-steer Husky past obstacles.

``fuzzynav run SCENARIO``      one headless run; a table, or ``--json``

Further sub-commands and ``run`` options come from the modules in
:data:`EXTENSION_MODULES`. Each may define any of

- ``add_commands(subparsers)``: add sub-commands (each sets ``func`` on its parser);
- ``add_run_options(parser)``: add options to ``run``;
- ``run_hook(args, sim)``: called before a ``run`` starts; returns None or a callback
  ``(result, interrupted) -> None`` called when it ends (also after Ctrl-C).

Exit status: 0 when a run completed, whatever its outcome; 2 for bad input or a file
that could not be read or written (a read-only folder, a full disk), with the error on
stderr and no traceback; 130 after Ctrl-C (what was interrupted is said); 141 when the
reader of stdout went away.
"""

from __future__ import annotations

import sys

try:  # a Ctrl-C while even these load ends quietly, as one in main() does
    import argparse
    import json
    import math
    import os
    import shlex
    import textwrap
    from pathlib import Path
except KeyboardInterrupt:  # pragma: no cover - a matter of milliseconds
    print("fuzzynav: interrupted", file=sys.stderr)
    raise SystemExit(130) from None

# Only the standard library at import time: a Ctrl-C while numpy and the rest load must
# reach main()'s handler (no traceback), so everything else is imported inside it.

EXIT_BAD_INPUT = 2
EXIT_INTERRUPTED = 130
EXIT_BROKEN_PIPE = 141  # 128 + SIGPIPE, as a shell reports a process its pipe closed on


class UsageError(Exception):
    """Bad input from the user: printed on stderr, exit status 2."""


def integer_in(low: int, high: int | None = None):
    """An argparse ``type``: an integer in ``[low, high]``; anything else is refused
    with the value named (``argument --seed: '-3': must be an integer >= 0``)."""

    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            value = None
        if value is None or value < low or (high is not None and value > high):
            bound = f">= {low}" if high is None else f"from {low} to {high}"
            raise argparse.ArgumentTypeError(f"{text!r}: must be an integer {bound}")
        return value

    parse.__name__ = "integer"
    return parse


seed_type = integer_in(0)


def float_in(low: float, high: float, unit: str = ""):
    """An argparse ``type``: a finite number in ``[low, high]``; NaN, inf and anything
    out of range are refused with the value and the bounds named
    (``argument --dt: '1e-05': must be a number from 0.001 to 1 s``)."""

    def parse(text: str) -> float:
        try:
            value = float(text)
        except ValueError:
            value = math.nan
        if not (math.isfinite(value) and low <= value <= high):
            raise argparse.ArgumentTypeError(
                f"{text[:40]!r}: must be a number from {low:g} to {high:g}{unit}"
            )
        return value

    parse.__name__ = "number"
    return parse


def _json_default(value):
    if isinstance(value, float) and not math.isfinite(value):
        return None
    raise TypeError(f"not JSON serialisable: {value!r}")


def print_json(data) -> None:
    print(json.dumps(data, indent=2, default=_json_default, allow_nan=False))


def scenario_label(name_or_path: str) -> str:
    from fuzzynav.world.scenario import resolve_scenario_path

    path = resolve_scenario_path(name_or_path)
    return path.stem if path.parent.name == "scenarios" and path.exists() else str(name_or_path)


def add_run_options(parser: argparse.ArgumentParser) -> None:
    from fuzzynav.controller.registry import controller_names
    from fuzzynav.world.perception import PERCEPTION_MODES
    from fuzzynav.world.simulation import MAX_CONTROL_PERIOD_S, MIN_CONTROL_PERIOD_S

    parser.add_argument(
        "--controller",
        default="paper",
        choices=controller_names(),
        help="which controller drives (default: paper)",
    )
    parser.add_argument(
        "--fis",
        type=Path,
        default=None,
        help="drive with a MATLAB .fis file of your own instead (4 inputs, 2 outputs)",
    )
    parser.add_argument(
        "--perception",
        default="ideal",
        choices=PERCEPTION_MODES,
        help="ideal: exact nearest obstacle; ultrasonic: the three range sensors",
    )
    add_geometry_option(parser)
    parser.add_argument(
        "--seed", type=seed_type, default=0, help="seeds the sensor noise (default 0)"
    )
    parser.add_argument(
        "--noise",
        type=float_in(0.0, 10.0, " m"),
        default=0.0,
        metavar="STD_M",
        help="sensor noise standard deviation in metres (default 0)",
    )
    parser.add_argument(
        "--dt",
        type=float_in(MIN_CONTROL_PERIOD_S, MAX_CONTROL_PERIOD_S, " s"),
        default=0.02,
        metavar="SECONDS",
        help=f"control period (default 0.02 s; from {MIN_CONTROL_PERIOD_S:g} to "
        f"{MAX_CONTROL_PERIOD_S:g} s)",
    )
    add_off_option(parser)


def add_geometry_option(parser: argparse.ArgumentParser) -> None:
    from fuzzynav.world.perception import GEOMETRIES

    parser.add_argument(
        "--geometry",
        default="husky",
        choices=GEOMETRIES,
        help="husky: the real 0.99 x 0.67 m footprint (default); paper: the paper's point "
        "robot, inputs and distances centre to centre (Eqs. 7-12), ideal perception only",
    )


def add_off_option(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--off",
        default="",
        metavar="PART[,PART...]",
        help="fuzzynav only: switch these parts off, e.g. 'edge following' "
        "(the names: fuzzynav parts)",
    )


def parse_off(off: str) -> list[str]:
    """``--off "echo memory, edge following"`` -> the part names."""
    return [name.strip() for name in off.split(",") if name.strip()]


def off_flag(parts_off) -> str:
    """The ``--off`` that switches these parts off again in a command line ("" for none)."""
    return f" --off {shlex.quote(','.join(parts_off))}" if parts_off else ""


def switch_parts_off(controller, off: str, label: str) -> tuple[str, ...]:
    """Apply ``--off PART[,PART...]`` to a controller that has parts (fuzzynav); returns
    the parts now off. Any other controller, or an unknown part, is refused."""
    names = parse_off(off)
    if not names:
        return ()
    if not hasattr(controller, "set_parts_off"):
        raise UsageError(f"--off {off!r}: only fuzzynav has parts to switch off (here: {label})")
    controller.set_parts_off(names)
    return controller.parts_off


def cmd_parts(args) -> int:
    """List fuzzynav's parts (assets/rules/fuzzynav_parts.toml): the names ``--off`` takes."""
    from fuzzynav.controller.fuzzynav_parts import PARTS_PATH, load_parts

    parts = load_parts()
    if args.json:
        print_json(
            [{"name": p.name, "what_off_does": p.what, "item": p.item, "off": p.off} for p in parts]
        )
        return 0
    from rich.console import Console
    from rich.table import Table

    table = Table(title=f"fuzzynav's parts ({PARTS_PATH.name}): --off NAME[,NAME...]")
    for column in ("name", "switched off", "by"):
        table.add_column(column, overflow="fold")
    for p in parts:
        table.add_row(p.name, p.what, ", ".join(f"{k} = {v:g}" for k, v in p.off.items()))
    Console().print(table)
    return 0


def cmd_run(args) -> int:
    from rich.console import Console
    from rich.table import Table

    from fuzzynav.app.runs import build_simulation, summary

    sim = build_simulation(
        args.scenario,
        args.controller,
        perception=args.perception,
        seed=args.seed,
        fis_path=args.fis,
        control_period_s=args.dt,
        sensor_noise_std_m=args.noise,
        geometry=args.geometry,
    )
    label = args.fis.name if args.fis else args.controller
    parts_off = switch_parts_off(sim.controller, args.off, label)
    if parts_off:
        label = f"{label} without {', '.join(parts_off)}"
    hooks = [m.run_hook(args, sim) for m in _extensions() if hasattr(m, "run_hook")]
    try:
        result = sim.run()
    except KeyboardInterrupt:
        print("fuzzynav: interrupted: writing what was asked for the partial run", file=sys.stderr)
        _finish_hooks(hooks, sim.result(), interrupted=True)
        raise
    _finish_hooks(hooks, result, interrupted=False)
    row = summary(result, label, scenario_label(args.scenario))
    if args.json:
        print_json(row)
        return 0
    table = Table(
        title=f"{result.scenario.name} — {label}, {args.perception} perception, "
        f"{args.geometry} geometry"
    )
    table.add_column("metric")
    table.add_column("value", justify="right")
    for key, value in row.items():
        if isinstance(value, float):
            value = f"{value:.4f}"
        table.add_row(key, str(value))
    Console().print(table)
    return 0


def _finish_hooks(hooks, result, interrupted: bool) -> None:
    """Call every hook (recording, figures) even when one fails (a full disk for the
    figures must not cost the recording); then raise the first failure."""
    failure = None
    for hook in hooks:
        if hook is None:
            continue
        try:
            hook(result, interrupted=interrupted)
        except Exception as exc:  # reported once every hook has had its turn
            if failure is None:
                failure = exc
            else:
                print(f"fuzzynav: error: {exc}", file=sys.stderr)
    if failure is not None:
        raise failure


EXTENSION_MODULES = (
    "fuzzynav.app.fis_commands",
    "fuzzynav.app.experiments",
    "fuzzynav.app.recording",
    "fuzzynav.app.figures",
    "fuzzynav.app.report",
    "fuzzynav.app.serve",
    "fuzzynav.app.paper_fit",
    "fuzzynav.app.trace",
)


def _extensions() -> list:
    """The extension modules that exist (one still being written is skipped)."""
    import importlib

    found = []
    for name in EXTENSION_MODULES:
        try:
            found.append(importlib.import_module(name))
        except ModuleNotFoundError as exc:
            if exc.name != name:
                raise
    return found


def scenario_help() -> str:
    """The help of a SCENARIO argument: the shipped names, or a path."""
    from fuzzynav.world.scenario import scenario_names

    return f"a shipped scenario ({', '.join(scenario_names())}) or the path of a scenario TOML file"


#: What each sub-command is for, at more length than its one-line help, and examples
#: that run as written (tests/test_package.py runs every parser over them).
COMMAND_DOCS = {
    "run": (
        "Run one scenario headless, to its end (target reached, collision or time out), "
        "and print its metrics: path length, deviation from the start-target line (MAD, "
        "RMSE), minimum distance to an obstacle.",
        [
            "fuzzynav run s1",
            "fuzzynav run s2 --controller fuzzynav --perception ultrasonic --json",
            "fuzzynav run s3 --rrd s3.rrd --figures figures/",
        ],
    ),
    "parts": (
        "List fuzzynav's parts (echo memory, bearing planner, ...): the names that "
        "'run --off' and 'sweep --off' switch off.",
        ["fuzzynav parts", "fuzzynav parts --json"],
    ),
    "fis": (
        "Work with MATLAB Fuzzy Logic Toolbox .fis files (GNU Octave's fuzzy-logic-toolkit "
        "reads them as the same system).",
        [
            "fuzzynav fis export paper.fis",
            "fuzzynav fis export fuzzynav_fis/ --controller fuzzynav",
        ],
    ),
    "fis export": (
        "Write a controller's rule base as MATLAB .fis: one file for paper, one per block "
        "(goal, avoid) for fuzzynav and baseline.",
        ["fuzzynav fis export paper.fis", "fuzzynav fis export blocks/ --controller baseline"],
    ),
    "tune": (
        "Tune a controller's membership functions by differential evolution (or a local "
        "search) on s1-s3 and, optionally, seeded random layouts. Writes the tuned file "
        "where --out says, with the command that reproduces it in its header.",
        [
            "fuzzynav tune --maxiter 5 --out my_paper.toml",
            "fuzzynav tune --controller paper --layouts standard --n 20 --out tuned.toml",
        ],
    ),
    "sweep": (
        "Run a controller on seeded random layouts of one family and report how often "
        "it reaches the target without collision, beside another controller on the same "
        "layouts.",
        ["fuzzynav sweep --n 50", "fuzzynav sweep --controller fuzzynav --family clutter --json"],
    ),
    "compare": (
        "The paper's Table 4: every controller on s1-s3 beside the paper's numbers, and a "
        "held-out sweep of random layouts.",
        ["fuzzynav compare", "fuzzynav compare --controllers paper,fuzzynav --sweep-n 0"],
    ),
    "report": (
        "Recordings (.rrd), the paper's figures and Table 4 for s1-s3 and every "
        "controller, written into one folder.",
        ["fuzzynav report out/report"],
    ),
    "serve": (
        "Start the browser viewer: drag obstacles and the target while the robot drives, "
        "and watch the fuzzy inference. Binds 127.0.0.1 unless --host says otherwise.",
        ["fuzzynav serve", "fuzzynav serve s2 --controller fuzzynav --port 8081"],
    ),
    "fit-paper": (
        "Reconstruct the paper controller's membership functions (not printed in the "
        "paper) from 12 design numbers that keep the design rules, by fitting s1-s3, run "
        "in the paper's point-robot geometry from the scenarios' start, to the paper's "
        "Table 4, the events and the story of its section 4 (--husky: and to the Husky "
        "geometry's bounds). Long: tens of minutes on two cores.",
        [
            "fuzzynav fit-paper --maxiter 2 --popsize 2 --out trial.toml",
            "fuzzynav fit-paper --husky --seed 1 --out paper.toml",
        ],
    ),
    "demo": (
        "The browser viewer on scenario s1 with default settings (what 'make demo' runs).",
        ["fuzzynav demo"],
    ),
}


def _finish_help(sub, prefix: str = "") -> None:
    """Give every sub-command a description and examples (from :data:`COMMAND_DOCS`)."""
    helps = {action.dest: action.help for action in sub._choices_actions}
    for name, parser in sub.choices.items():
        key = f"{prefix}{name}"
        description, examples = COMMAND_DOCS.get(key, (helps.get(name) or "", []))
        parser.description = textwrap.fill(description, width=78)
        parser.formatter_class = argparse.RawDescriptionHelpFormatter
        if examples:
            parser.epilog = "examples:\n" + "\n".join(f"  {e}" for e in examples)
        for action in parser._actions:
            if isinstance(action, argparse._SubParsersAction):
                _finish_help(action, prefix=f"{key} ")


def build_parser() -> argparse.ArgumentParser:
    from fuzzynav import __version__

    parser = argparse.ArgumentParser(
        prog="fuzzynav",
        description=__doc__.split("\n\n")[0],
        epilog="examples:\n  fuzzynav demo\n  fuzzynav run s1\n  fuzzynav COMMAND --help",
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("--version", action="version", version=f"fuzzynav {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    run = sub.add_parser("run", help="run one scenario headless and print its metrics")
    run.add_argument("scenario", help=scenario_help())
    add_run_options(run)
    run.add_argument("--json", action="store_true", help="print one JSON object")
    run.set_defaults(func=cmd_run)
    parts = sub.add_parser("parts", help="fuzzynav's parts, which --off switches off")
    parts.add_argument("--json", action="store_true", help="print one JSON list")
    parts.set_defaults(func=cmd_parts)
    for module in _extensions():
        if hasattr(module, "add_run_options"):
            module.add_run_options(run)
        if hasattr(module, "add_commands"):
            module.add_commands(sub)
    _finish_help(sub)
    return parser


def describe_os_error(exc: OSError) -> str:
    """An OSError as one line: what, which file, why (``cannot write out/a.png: No
    space left on device``)."""
    reason = exc.strerror or str(exc) or type(exc).__name__
    name = exc.filename if exc.filename is not None else None
    return f"{name}: {reason}" if name is not None else reason


def main(argv=None) -> int:
    """The command line; returns the exit status (see the module docstring). Ctrl-C at
    any moment, from loading the libraries on, ends with a line, never a traceback."""
    try:
        parser = build_parser()
        try:
            args = parser.parse_args(argv)
        except SystemExit as exc:  # --help (0), or argparse refused the input (2, said why)
            return exc.code if isinstance(exc.code, int) else EXIT_BAD_INPUT
        return _dispatch(args)
    except KeyboardInterrupt:
        print("fuzzynav: interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED


def _dispatch(args) -> int:
    try:
        return args.func(args) or 0
    except (UsageError, ValueError) as exc:  # ScenarioError, FisFormatError are ValueErrors
        print(f"fuzzynav: error: {exc}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except BrokenPipeError:
        # The reader left early (`fuzzynav run s1 --json | head -3`): not an error of
        # ours. Python's advice: point stdout at devnull so the exit's flush stays quiet.
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return EXIT_BROKEN_PIPE
    except OSError as exc:  # a read-only folder, a full disk, a file that vanished
        print(f"fuzzynav: error: {describe_os_error(exc)}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except MemoryError:
        print(
            "fuzzynav: error: out of memory (a limit this should have met is missing)",
            file=sys.stderr,
        )
        return EXIT_BAD_INPUT


if __name__ == "__main__":
    sys.exit(main())
