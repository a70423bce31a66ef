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
stderr and no traceback; 130 after Ctrl-C (what was interrupted is said); 143 after
SIGTERM (handled as Ctrl-C); 141 when the reader of stdout went away.
"""

from __future__ import annotations

import sys

try:  # a Ctrl-C while even these load ends quietly, as one in main() does
    import argparse
    import json
    import os
    import signal
    import textwrap
    from pathlib import Path

    # The vocabulary the command modules share (only the standard library below it).
    from fuzzynav.app.args import (
        EXIT_BAD_INPUT,
        EXIT_BROKEN_PIPE,
        EXIT_INTERRUPTED,
        UsageError,
        _json_default,
        add_field_of_view_option,
        add_geometry_option,
        add_off_option,
        describe_os_error,
        float_in,
        print_json,
        scenario_help,
        scenario_label,
        seed_type,
        switch_parts_off,
    )
except KeyboardInterrupt:  # pragma: no cover - a matter of milliseconds
    print("fuzzynav: interrupted", file=sys.stderr)
    raise SystemExit(130) from None

# Only the standard library at import time: a Ctrl-C while numpy and the rest load must
# reach main()'s handler (no traceback), so everything else is imported inside it.

__all__ = ["COMMAND_DOCS", "UsageError", "build_parser", "main"]  # what others import

EXIT_TERMINATED = 143  # 128 + SIGTERM: `kill PID` ends a command as Ctrl-C does


class _Terminated:
    """Whether SIGTERM arrived during :func:`main` (it is then raised as Ctrl-C)."""

    received = False


def _on_sigterm(signum, frame):
    # SIGTERM is handled as Ctrl-C everywhere: every command's Ctrl-C path
    # says what was kept and removes its temporary files; only the exit status differs.
    _Terminated.received = True
    raise KeyboardInterrupt


def add_run_options(parser: argparse.ArgumentParser) -> None:
    from fuzzynav.app.args import SENSOR_NOISE_LIMITS_M, SONAR_SIDE_LIMITS_DEG
    from fuzzynav.controller.registry import controller_names
    from fuzzynav.world.perception import PERCEPTION_MODES
    from fuzzynav.world.run_limits import MAX_CONTROL_PERIOD_S, MIN_CONTROL_PERIOD_S

    parser.add_argument(
        "--controller",
        default="paper",
        choices=controller_names(),
        help="which controller drives (default: paper)",
    )
    parser.add_argument(
        "--fis",
        type=Path,
        help="drive with a MATLAB .fis file of your own instead (4 inputs, 2 outputs)",
    )
    parser.add_argument(
        "--perception",
        default="ideal",
        choices=PERCEPTION_MODES,
        help="ideal: exact nearest obstacle; ultrasonic: the three range sensors",
    )
    add_geometry_option(parser)
    add_field_of_view_option(parser)
    parser.add_argument(
        "--sonar-side",
        type=float_in(*SONAR_SIDE_LIMITS_DEG, " degrees"),
        metavar="DEG",
        help="mount the side sonars at +-DEG (default 45; 15 leaves no blind sector ahead)",
    )
    parser.add_argument(
        "--seed", type=seed_type, default=0, help="seeds the sensor noise (default 0)"
    )
    parser.add_argument(
        "--noise",
        type=float_in(*SENSOR_NOISE_LIMITS_M, " m"),
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


def cmd_parts(args) -> int:
    """List fuzzynav's parts (assets/rules/fuzzynav_parts.toml): the names ``--off`` takes."""
    from fuzzynav.controller.navigator.parts import PARTS_PATH, load_parts

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
    from fuzzynav.safe_files import check_distinct_outputs

    # before anything runs: two outputs on one file would lose one of them
    check_distinct_outputs(
        (f"--{name}", getattr(args, name, None)) for name in ("trace", "rrd", "figures")
    )

    sim = build_simulation(
        args.scenario,
        args.controller,
        perception=args.perception,
        seed=args.seed,
        fis_path=args.fis,
        control_period_s=args.dt,
        sensor_noise_std_m=args.noise,
        geometry=args.geometry,
        field_of_view_deg=args.field_of_view,
        sonar_side_deg=args.sonar_side,
    )
    from fuzzynav.resources import escape_controls

    label = escape_controls(args.fis.name) if args.fis else args.controller
    if getattr(sim.controller, "bound_by_name", False):
        print(
            f"fuzzynav: {escape_controls(str(args.fis))}: its variables are in another order; "
            "bound by name (d_t, d_o, phi_t, phi_o; left, right)",
            file=sys.stderr,
        )
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
    row = summary(result, label, escape_controls(scenario_label(args.scenario)))
    # `--rrd /dev/stdout | rerun -`: the recording has the standard output; the table
    # goes to stderr then, so that nothing is appended to the recording's bytes
    to_stderr = _stdout_is_an_output(args)
    if args.json:
        if to_stderr:
            print(json.dumps(row, indent=2, default=_json_default), file=sys.stderr)
        else:
            print_json(row)
        return 0
    from rich.markup import escape as markup

    # names from files are text, never rich markup ("[link=...]" would make rich send
    # the terminal a hyperlink escape sequence)
    table = Table(
        title=markup(
            f"{result.scenario.name} — {label}, {args.perception} perception, "
            f"{args.geometry} geometry"
        )
    )
    table.add_column("metric")
    table.add_column("value", justify="right")
    for key, value in row.items():
        if isinstance(value, float):
            value = f"{value:.4f}"
        table.add_row(key, markup(str(value)))
    Console(stderr=to_stderr).print(table)
    return 0


def _stdout_is_an_output(args) -> bool:
    """Whether ``--rrd`` or ``--trace`` names this process's standard output (e.g.
    ``/dev/stdout`` or ``/dev/fd/1``)."""
    try:
        out = os.fstat(sys.stdout.fileno())
    except (OSError, ValueError, AttributeError):  # no real stdout (a test's capture)
        return False
    for option in ("rrd", "trace"):
        path = getattr(args, option, None)
        if path is None:
            continue
        try:
            info = os.stat(path)
        except OSError:
            continue
        if (info.st_dev, info.st_ino) == (out.st_dev, out.st_ino):
            return True
    return False


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
                print(f"fuzzynav: error: {_escaped(exc)}", file=sys.stderr)
    if failure is not None:
        raise failure


EXTENSION_MODULES = (
    "fuzzynav.app.fis_commands",
    "fuzzynav.app.experiments.tuning",
    "fuzzynav.app.experiments.sweep",
    "fuzzynav.app.experiments.compare",
    "fuzzynav.app.recordings.record",
    "fuzzynav.app.figures.run_figures",
    "fuzzynav.app.figures.report",
    "fuzzynav.app.viewer.serve",
    "fuzzynav.app.experiments.paper_fit_command",
    "fuzzynav.app.recordings.trace",
)


def _extensions() -> list:
    """The extension modules, imported."""
    import importlib

    return [importlib.import_module(name) for name in EXTENSION_MODULES]


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
            "fuzzynav fis export baseline_fis/ --controller baseline",
            "fuzzynav fis export fuzzynav_fis/ --controller fuzzynav",
        ],
    ),
    "fis export": (
        "Write a controller's rule base as MATLAB .fis: one per block (goal, avoid) for "
        "fuzzynav and baseline; the paper's rule bases read Table 1's NONE as the text has "
        "it, which a .fis cannot say, so they are refused (their TOML files are the rule base).",
        [
            "fuzzynav fis export blocks/ --controller baseline",
            "fuzzynav fis export nav/ --controller fuzzynav",
        ],
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
    "compare-runs": (
        "Compare two recordings entity by entity on the run's timeline, a NaN equal to a "
        "NaN, leaving out the wall time, the command line and the recording's id: exit 0 "
        "when they hold the same run, 1 when they differ (each difference a line), 2 when "
        "one cannot be read.",
        [
            "fuzzynav run s1 --rrd a.rrd",
            "fuzzynav compare-runs a.rrd b.rrd",
        ],
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
    if "fit-paper" in sub.choices:  # see _check_fit_paper_default
        from fuzzynav.app.args import add_force_option

        add_force_option(sub.choices["fit-paper"], "the default ./paper.toml")
    _finish_help(sub)
    return parser


#: fit-paper's output without --out (app/experiments/paper_fit_command.py's default).
FIT_PAPER_DEFAULT_OUT = "paper.toml"


def _check_fit_paper_default(args) -> None:
    """``fit-paper`` without ``--out`` writes ./paper.toml: an earlier fit there is never
    replaced unless ``--force``, checked by the one output guard before the
    fit starts. (Here, not in paper_fit.py, which is another piece of work's.)"""
    if getattr(args, "command", None) != "fit-paper" or getattr(args, "out", None) is not None:
        return
    from fuzzynav.safe_files import check_output_path

    check_output_path(
        Path.cwd() / FIT_PAPER_DEFAULT_OUT,
        "--out",
        replace=getattr(args, "force", False),
        folder=True,  # fit-paper itself checks that it can be written
    )


def _escaped(message) -> str:
    """An error message with every control character escaped: file names, addresses
    and values in it come from the user, and none may drive the terminal."""
    from fuzzynav.resources import escape_controls

    return escape_controls(str(message))


def main(argv=None) -> int:
    """The command line; returns the exit status (see the module docstring). Ctrl-C at
    any moment, from loading the libraries on, ends with a line, never a traceback.
    SIGTERM is the same as Ctrl-C, with exit status 143."""
    _Terminated.received = False
    try:
        previous = signal.signal(signal.SIGTERM, _on_sigterm)
    except ValueError:  # not the main thread: leave signals to whoever owns them
        previous = None
    try:
        code = _main(argv)
    finally:
        if previous is not None:
            signal.signal(signal.SIGTERM, previous)
    if code == EXIT_INTERRUPTED and _Terminated.received:
        return EXIT_TERMINATED
    return code


def _main(argv) -> int:
    try:
        parser = build_parser()
        try:
            args = parser.parse_args(argv)
        except SystemExit as exc:  # --help (0), or argparse refused the input (2, said why)
            return exc.code if isinstance(exc.code, int) else EXIT_BAD_INPUT
        return _dispatch(args)
    except KeyboardInterrupt:
        what = " (SIGTERM)" if _Terminated.received else ""
        print(f"fuzzynav: interrupted{what}", file=sys.stderr)
        return EXIT_INTERRUPTED


def _dispatch(args) -> int:
    try:
        _check_fit_paper_default(args)
        return args.func(args) or 0
    except (UsageError, ValueError) as exc:  # ScenarioError, FisFormatError are ValueErrors
        print(f"fuzzynav: error: {_escaped(exc)}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except BrokenPipeError:
        # The reader left early (`fuzzynav run s1 --json | head -3`): not an error of
        # ours. Python's advice: point stdout at devnull so the exit's flush stays quiet.
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return EXIT_BROKEN_PIPE
    except OSError as exc:  # a read-only folder, a full disk, a file that vanished
        print(f"fuzzynav: error: {_escaped(describe_os_error(exc))}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except MemoryError:
        print(
            "fuzzynav: error: out of memory (a limit this should have met is missing)",
            file=sys.stderr,
        )
        return EXIT_BAD_INPUT


if __name__ == "__main__":
    sys.exit(main())
