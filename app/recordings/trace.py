"""``fuzzynav run ... --trace PATH.csv``: one CSV row per control step, for pandas or MATLAB.

Columns (SI units, each name ending in its unit; the header is the first line)::

    time_s,x_m,y_m,heading_rad,d_t_m,d_o_m,phi_t_rad,phi_o_rad,
    true_d_t_m,true_phi_t_rad,v_left_v,v_right_v,
    controller_left_v,controller_right_v,disturbance_m_or_rad

``x_m, y_m, heading_rad``: the robot centre's pose (heading continuous, not wrapped).
``d_t_m .. phi_o_rad``: the four inputs exactly as the controller received them, the
disturbance included; ``d_o_m`` and ``phi_o_rad`` are empty when nothing is detected.
``true_d_t_m, true_phi_t_rad``: the target's distance and bearing from the pose, without
the disturbance (Eqs. 7 and 10). ``v_left_v, v_right_v``: the voltages applied from this
step to the next, after the saturation; ``controller_*_v``: the controller's output
before it. ``disturbance_m_or_rad``: the value added to every input (metres on the
distances, radians on the angles). The last row is the final state, with no command: its
voltages are empty. Numbers are written with ``repr`` (shortest text that reads back as
the same float), so a trace is exact.
"""

from __future__ import annotations

import csv
import io
import math
import sys
from pathlib import Path

from fuzzynav.resources import escape_controls
from fuzzynav.safe_files import check_output_path, write_chunks_atomically

TRACE_COLUMNS = (
    "time_s",
    "x_m",
    "y_m",
    "heading_rad",
    "d_t_m",
    "d_o_m",
    "phi_t_rad",
    "phi_o_rad",
    "true_d_t_m",
    "true_phi_t_rad",
    "v_left_v",
    "v_right_v",
    "controller_left_v",
    "controller_right_v",
    "disturbance_m_or_rad",
)


def _cell(value: float) -> str:
    value = float(value)
    return repr(value) if math.isfinite(value) else ""


def trace_rows(log):
    """The trace's rows (lists of strings) for a :class:`world.simulation.SimulationLog`."""
    import numpy as np

    from fuzzynav.world.geometry import wrap_angle

    # the true inputs a block at a time: a long run's trace never holds whole columns
    for start in range(0, len(log), TRACE_CHUNK_ROWS):
        end = min(start + TRACE_CHUNK_ROWS, len(log))
        pose, target = log.pose[start:end], log.target_xy[start:end]
        dx = target[:, 0] - pose[:, 0]
        dy = target[:, 1] - pose[:, 1]
        true_d_t = np.hypot(dx, dy)
        true_phi_t = np.atleast_1d(wrap_angle(np.arctan2(dy, dx) - pose[:, 2]))
        for k in range(start, end):
            x, y, heading = log.pose[k]
            yield [
                _cell(log.time_s[k]),
                _cell(x),
                _cell(y),
                _cell(heading),
                *(_cell(v) for v in log.inputs[k]),
                _cell(true_d_t[k - start]),
                _cell(true_phi_t[k - start]),
                *(_cell(v) for v in log.voltages_v[k]),
                *(_cell(v) for v in log.controller_output_v[k]),
                _cell(log.disturbance[k]),
            ]


#: Rows encoded at a time: the text of a 2,000,000-step trace (about 400 MB) never sits
#: in memory whole, only this many rows of it.
TRACE_CHUNK_ROWS = 256


def _trace_chunks(log):
    buffer = io.StringIO(newline="")
    writer = csv.writer(buffer)
    writer.writerow(TRACE_COLUMNS)
    for k, row in enumerate(trace_rows(log), start=1):
        writer.writerow(row)
        if k % TRACE_CHUNK_ROWS == 0:
            yield buffer.getvalue().encode("utf-8")
            buffer.seek(0)
            buffer.truncate()
    yield buffer.getvalue().encode("utf-8")


def write_trace(log, path: str | Path) -> Path:
    """Write the trace to ``path`` whole or not at all (an existing file is replaced
    only by a complete one), a few thousand rows at a time; a pipe gets it as a
    stream. OSError naming ``path`` on failure."""
    return write_chunks_atomically(path, _trace_chunks(log))


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
    from fuzzynav.app.args import run_inputs

    # before the run, not after it; never over the run's scenario or .fis, nor a file
    # of the installed package
    check_output_path(path, "--trace", run_inputs(args))

    def write(result, interrupted: bool) -> None:
        write_trace(result.log, path)
        note = " (interrupted run)" if interrupted else ""
        print(f"fuzzynav: trace written to {escape_controls(str(path))}{note}", file=sys.stderr)

    return write
