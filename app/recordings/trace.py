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

Optional columns (``--trace-columns obstacles,rules``), after those:
``obstacle_<id>_x_m, obstacle_<id>_y_m`` each obstacle's centre (empty while it is
absent); ``rule_R<k>_strength`` each rule's firing strength (0-1) at the inputs the
controller received, for a controller with one rule base (the paper's, a ``--fis``
file; empty on the last row, which has no decision).
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


#: What ``--trace-columns`` may add.
OPTIONAL_COLUMNS = ("obstacles", "rules")


def trace_columns(log, extra=(), fis=None) -> list[str]:
    """The trace's header: :data:`TRACE_COLUMNS`, then the optional columns asked for."""
    names = list(TRACE_COLUMNS)
    if "obstacles" in extra:
        for oid in log.obstacle_ids:
            names += [f"obstacle_{oid}_x_m", f"obstacle_{oid}_y_m"]
    if "rules" in extra and fis is not None:
        names += [f"rule_R{k + 1}_strength" for k in range(len(fis.rules))]
    return names


def trace_rows(log, extra=(), fis=None):
    """The trace's rows (lists of strings) for a :class:`world.simulation.SimulationLog`,
    with the optional columns ``extra`` (:data:`OPTIONAL_COLUMNS`)."""
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
        more = np.zeros((end - start, 0))
        if "obstacles" in extra and len(log.obstacle_ids):
            more = np.asarray(log.obstacle_xy[start:end], dtype=float).reshape(end - start, -1)
        if "rules" in extra and fis is not None:
            strengths = np.asarray(fis.firing_strengths(log.inputs[start:end]), dtype=float)
            decided = np.all(np.isfinite(log.controller_output_v[start:end]), axis=1)
            strengths[~decided] = np.nan
            more = np.hstack([more, strengths])
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
                *(_cell(v) for v in more[k - start]),
            ]


#: Rows encoded at a time: the text of a 2,000,000-step trace (about 400 MB) never sits
#: in memory whole, only this many rows of it.
TRACE_CHUNK_ROWS = 256


def _trace_chunks(log, extra=(), fis=None):
    buffer = io.StringIO(newline="")
    writer = csv.writer(buffer)
    writer.writerow(trace_columns(log, extra, fis))
    for k, row in enumerate(trace_rows(log, extra, fis), start=1):
        writer.writerow(row)
        if k % TRACE_CHUNK_ROWS == 0:
            yield buffer.getvalue().encode("utf-8")
            buffer.seek(0)
            buffer.truncate()
    yield buffer.getvalue().encode("utf-8")


def write_trace(log, path: str | Path, extra=(), fis=None) -> Path:
    """Write the trace to ``path`` whole or not at all (an existing file is replaced
    only by a complete one), a few thousand rows at a time; a pipe gets it as a
    stream. ``extra``: optional columns (:data:`OPTIONAL_COLUMNS`; the rules' need the
    controller's ``fis``). OSError naming ``path`` on failure."""
    return write_chunks_atomically(path, _trace_chunks(log, tuple(extra), fis))


def _trace_extra(text) -> tuple[str, ...]:
    """``--trace-columns obstacles,rules`` as a tuple; ValueError for another word."""
    if not text:
        return ()
    words = tuple(w.strip() for w in str(text).split(",") if w.strip())
    unknown = [w for w in words if w not in OPTIONAL_COLUMNS]
    if unknown:
        raise ValueError(
            f"--trace-columns {', '.join(unknown)}: not one of {', '.join(OPTIONAL_COLUMNS)}"
        )
    return words


def add_run_options(parser) -> None:
    parser.add_argument(
        "--trace",
        type=Path,
        metavar="PATH.csv",
        help="write one CSV row per control step (pose, the four inputs, the voltages)",
    )
    parser.add_argument(
        "--trace-columns",
        metavar="obstacles,rules",
        help="--trace's optional columns: each obstacle's centre (obstacles), each rule's "
        "firing strength (rules: a controller with one rule base)",
    )


def run_hook(args, sim):
    path = getattr(args, "trace", None)
    if path is None:
        return None
    from fuzzynav.app.args import run_inputs

    # before the run, not after it; never over the run's scenario or .fis, nor a file
    # of the installed package
    check_output_path(path, "--trace", run_inputs(args))
    extra = _trace_extra(getattr(args, "trace_columns", None))
    fis = getattr(getattr(sim.controller, "inner", sim.controller), "fis", None)
    if "rules" in extra and fis is None:
        raise ValueError("--trace-columns rules: the controller has no single rule base")

    def write(result, interrupted: bool) -> None:
        write_trace(result.log, path, extra, fis)
        note = " (interrupted run)" if interrupted else ""
        print(f"fuzzynav: trace written to {escape_controls(str(path))}{note}", file=sys.stderr)

    return write
