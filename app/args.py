"""The command line's vocabulary, below every command module: ``UsageError``, the exit
statuses, argument types that name a refused value, the options several commands share
(``--geometry``, ``--perception``, ``--off``), and JSON printing.

Command modules (``experiments``, ``tuning``, ``serve``, ...) import these from here, so
nothing but the entry point imports :mod:`fuzzynav.app.cli`, and no import has to hide
inside a function to dodge a circle. Only the standard library loads at import time
(``fuzzynav --version`` and a Ctrl-C while libraries load stay fast and quiet).
"""

from __future__ import annotations

import argparse
import contextlib
import json
import math
import numbers
import shlex
from pathlib import Path

EXIT_BAD_INPUT = 2
EXIT_INTERRUPTED = 130
EXIT_BROKEN_PIPE = 141  # 128 + SIGPIPE, as a shell reports a process its pipe closed on


#: The run options' ranges (``--noise``, ``--field-of-view``, ``--sonar-side``; ``--dt``'s
#: are world.simulation's MIN/MAX_CONTROL_PERIOD_S): the command line's options and the
#: Python interface's arguments (app.runs.check_run_options) are held to the same ones,
#: by the same rule (:func:`float_in` / :func:`number_value`).
SENSOR_NOISE_LIMITS_M = (0.0, 10.0)
FIELD_OF_VIEW_LIMITS_DEG = (1.0, 360.0)
SONAR_SIDE_LIMITS_DEG = (1.0, 90.0)


class UsageError(Exception):
    """Bad input from the user: printed on stderr, exit status 2."""


def _integer_rule(low: int, high: int | None) -> str:
    return f"must be an integer {f'>= {low}' if high is None else f'from {low} to {high}'}"


def _number_rule(low: float, high: float, unit: str) -> str:
    return f"must be a number from {low:g} to {high:g}{unit}"


def _shown(value) -> str:
    text = repr(value) if not isinstance(value, int) or value.bit_length() < 200 else "<a huge int>"
    return text if len(text) <= 60 else text[:57] + "..."


def integer_value(value, name: str, low: int, high: int | None = None) -> int:
    """An integer argument of the Python interface, checked as the command line's
    :func:`integer_in` checks its option (the same bounds, the same words): ValueError
    ``n = 2.5: must be an integer from 1 to 100000``. A bool (``True``) and a float
    (``2.5``, even ``2.0``) are refused, never taken as a count."""
    if (
        isinstance(value, bool)
        or not isinstance(value, numbers.Integral)
        or value < low
        or (high is not None and value > high)
    ):
        raise ValueError(f"{name} = {_shown(value)}: {_integer_rule(low, high)}")
    return int(value)


def number_value(value, name: str, low: float, high: float, unit: str = "") -> float:
    """A number argument of the Python interface, checked as the command line's
    :func:`float_in` checks its option (the same bounds, the same words): ValueError
    ``sensor_noise_std_m = 1e+300: must be a number from 0 to 10 m``. A bool, NaN,
    inf and anything that is not a real number are refused."""
    if not isinstance(value, bool) and isinstance(value, numbers.Real):
        try:
            number = float(value)
        except (OverflowError, ValueError):
            number = math.nan
        if math.isfinite(number) and low <= number <= high:
            return number
    raise ValueError(f"{name} = {_shown(value)}: {_number_rule(low, high, unit)}")


def integer_in(low: int, high: int | None = None):
    """An argparse ``type``: an integer in ``[low, high]``; anything else is refused
    with the value named (``argument --seed: '-3': must be an integer >= 0``). The
    Python interface checks its arguments with :func:`integer_value`, the same rule."""

    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            value = None
        if value is None or value < low or (high is not None and value > high):
            raise argparse.ArgumentTypeError(f"{text!r}: {_integer_rule(low, high)}")
        return value

    parse.__name__ = "integer"
    return parse


seed_type = integer_in(0)


def float_in(low: float, high: float, unit: str = ""):
    """An argparse ``type``: a finite number in ``[low, high]``; NaN, inf and anything
    out of range are refused with the value and the bounds named
    (``argument --dt: '1e-05': must be a number from 0.001 to 1 s``). The Python
    interface checks its arguments with :func:`number_value`, the same rule."""

    def parse(text: str) -> float:
        try:
            value = float(text)
        except ValueError:
            value = math.nan
        if not (math.isfinite(value) and low <= value <= high):
            raise argparse.ArgumentTypeError(f"{text[:40]!r}: {_number_rule(low, high, unit)}")
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


def add_geometry_option(parser: argparse.ArgumentParser) -> None:
    from fuzzynav.world.perception import GEOMETRIES

    parser.add_argument(
        "--geometry",
        default="husky",
        choices=GEOMETRIES,
        help="husky: the real Husky A200's footprint, husky.toml's (default); paper: the paper's point "
        "robot, inputs and distances centre to centre (Eqs. 7-12), ideal perception only",
    )


def add_field_of_view_option(parser: argparse.ArgumentParser) -> None:
    """``--field-of-view DEG``: ideal perception's field, in place of the scenario's
    (its range, :data:`FIELD_OF_VIEW_LIMITS_DEG`, is the Python interface's too)."""
    parser.add_argument(
        "--field-of-view",
        dest="field_of_view",
        type=float_in(*FIELD_OF_VIEW_LIMITS_DEG, " degrees"),
        metavar="DEG",
        help="ideal perception senses only obstacles whose centre bears within +-DEG/2 of "
        "the heading (default: the scenario's: s1-s3 180, the front half-plane of the "
        "paper's front sonars; generated layouts 360, all around)",
    )


def add_perception_option(parser: argparse.ArgumentParser) -> None:
    """``--perception`` for the commands that drive many runs (sweep, compare)."""
    from fuzzynav.world.perception import PERCEPTION_MODES

    parser.add_argument(
        "--perception",
        default="ideal",
        choices=PERCEPTION_MODES,
        help="ideal: exact nearest obstacle; ultrasonic: the three range sensors (default ideal)",
    )


def add_force_option(parser: argparse.ArgumentParser, what: str) -> None:
    """``--force``: replace ``what``, a file the command names by itself (a default
    output, one in or beside the folder given), when it exists. A path the user gives is
    asked for and needs no ``--force``; a name the command chose never replaces a file
    without it (:func:`fuzzynav.safe_files.check_output_path`, ``replace``)."""
    parser.add_argument(
        "--force",
        action="store_true",
        help=f"replace {what} when it exists (without --force an existing file there is "
        "refused: it may be an earlier result)",
    )


def add_off_option(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--off",
        default="",
        metavar="PART[,PART...]",
        help="fuzzynav only: switch these parts off, e.g. 'edge following' "
        "(the names: fuzzynav parts)",
    )


def comma_list(text: str) -> list[str]:
    """``"a, b,,c"`` -> ``["a", "b", "c"]``: a comma-separated option's items (an argparse
    ``type``)."""
    return [item.strip() for item in text.split(",") if item.strip()]


def named_list(text: str) -> list[str]:
    """An argparse ``type``: a comma-separated option that names at least one item
    (``--controllers ''`` ran every controller, ``--free ''`` searched every number:
    an empty value is refused, as ``,,`` is)."""
    items = comma_list(text)
    if not items:
        raise argparse.ArgumentTypeError(f"{text!r}: names nothing (give NAME[,NAME...])")
    return items


def off_flag(parts_off) -> str:
    """The ``--off`` that switches these parts off again in a command line ("" for none)."""
    return f" --off {shlex.quote(','.join(parts_off))}" if parts_off else ""


def switch_parts_off(controller, off: str, label: str) -> tuple[str, ...]:
    """Apply ``--off PART[,PART...]`` to a controller that has parts (fuzzynav); returns
    the parts now off. Any other controller, or an unknown part, is refused."""
    names = comma_list(off)
    if not names:
        return ()
    if not hasattr(controller, "set_parts_off"):
        raise UsageError(f"--off {off!r}: only fuzzynav has parts to switch off (here: {label})")
    controller.set_parts_off(names)
    return controller.parts_off


def scenario_help() -> str:
    """The help of a SCENARIO argument: the shipped names, or a path."""
    from fuzzynav.world.scenario import scenario_names

    return f"a shipped scenario ({', '.join(scenario_names())}) or the path of a scenario TOML file"


def describe_os_error(exc: OSError) -> str:
    """An OSError as one line: what, which file, why (``cannot write out/a.png: No
    space left on device``)."""
    reason = exc.strerror or str(exc) or type(exc).__name__
    name = exc.filename if exc.filename is not None else None
    return f"{name}: {reason}" if name is not None else reason


def run_inputs(args) -> list[Path]:
    """The files a ``run`` reads (its scenario file, its ``--fis``): no output of the run
    may be one of them."""
    from fuzzynav.world.scenario import resolve_scenario_path

    found = []
    scenario = getattr(args, "scenario", None)
    if scenario is not None:
        with contextlib.suppress(OSError, ValueError):
            found.append(resolve_scenario_path(scenario))
    if getattr(args, "fis", None) is not None:
        found.append(Path(args.fis))
    return found
