"""``fuzzynav run ... --trace PATH.csv``: one CSV row per control step, for pandas or MATLAB.

Columns (SI units; the header is the first line)::

    time_s,x_m,y_m,heading_rad,d_t,d_o,phi_t,phi_o,v_left,v_right,
    controller_left_v,controller_right_v,disturbance

``x_m, y_m, heading_rad``: the robot centre's pose (heading continuous, not wrapped).
``d_t .. phi_o``: the four inputs exactly as the controller received them, the
disturbance included; ``d_o`` and ``phi_o`` are empty when nothing is detected.
``v_left, v_right``: the voltages applied from this step to the next, after the
saturation; ``controller_*_v``: the controller's output before it. The last row is the
final state, with no command: its voltages are empty. Numbers are written with
``repr`` (shortest text that reads back as the same float), so a trace is exact.
"""

from __future__ import annotations

import csv
import math
import os
import sys
from pathlib import Path

TRACE_COLUMNS = (
    "time_s",
    "x_m",
    "y_m",
    "heading_rad",
    "d_t",
    "d_o",
    "phi_t",
    "phi_o",
    "v_left",
    "v_right",
    "controller_left_v",
    "controller_right_v",
    "disturbance",
)


def _cell(value: float) -> str:
    value = float(value)
    return repr(value) if math.isfinite(value) else ""


def trace_rows(log):
    """The trace's rows (lists of strings) for a :class:`world.simulation.SimulationLog`."""
    for k in range(len(log)):
        x, y, heading = log.pose[k]
        yield [
            _cell(log.time_s[k]),
            _cell(x),
            _cell(y),
            _cell(heading),
            *(_cell(v) for v in log.inputs[k]),
            *(_cell(v) for v in log.voltages_v[k]),
            *(_cell(v) for v in log.controller_output_v[k]),
            _cell(log.disturbance[k]),
        ]


def write_trace(log, path: str | Path) -> Path:
    """Write the trace to ``path`` through a temporary file beside it, so that an
    existing file is replaced only by a complete one."""
    path = Path(path)
    partial = path.with_name(f".{path.name}.partial")
    try:
        with partial.open("w", newline="", encoding="utf-8") as fh:
            writer = csv.writer(fh)
            writer.writerow(TRACE_COLUMNS)
            writer.writerows(trace_rows(log))
        os.replace(partial, path)
    except BaseException:
        partial.unlink(missing_ok=True)
        raise
    return path


def add_run_options(parser) -> None:
    parser.add_argument(
        "--trace",
        type=Path,
        default=None,
        metavar="PATH.csv",
        help="write one CSV row per control step (pose, the four inputs, the voltages)",
    )


def run_hook(args, sim):
    path = getattr(args, "trace", None)
    if path is None:
        return None
    from fuzzynav.app.cli import UsageError

    if path.exists() and path.is_dir():
        raise UsageError(f"--trace {path}: is a folder")
    if not path.parent.is_dir():
        raise UsageError(f"--trace {path}: folder {path.parent} does not exist")
    if not os.access(path.parent, os.W_OK):
        raise UsageError(f"--trace {path}: folder {path.parent} is not writable")

    def write(result, interrupted: bool) -> None:
        write_trace(result.log, path)
        note = " (interrupted run)" if interrupted else ""
        print(f"fuzzynav: trace written to {path}{note}", file=sys.stderr)

    return write
