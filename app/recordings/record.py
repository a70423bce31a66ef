"""Every run as a rerun recording: the 2D world, the paper's time series and more.

``record_run(result, path)`` writes one finished (or interrupted) run to a ``.rrd`` file;
:class:`~fuzzynav.app.recordings.live.LiveRecorder` (re-exported here, where the viewer
imports it) appends the steps of a running simulation in chunks. Both go through
:class:`~fuzzynav.app.recordings.columns.ColumnWriter`, which sends whole columns on the
timeline ``sim_time``, never one call per step; the layout is :mod:`.blueprint`'s. What
each entity and tab shows: docs/recordings.md; how the files are written (whole, beside
the target, renamed; a partial run as ``<stem>.partial.rrd``): docs/robustness.md.

``rerun`` and ``pyarrow`` are imported inside the functions: the command line imports
this module for its options on every call.
"""

from __future__ import annotations

import sys
from pathlib import Path

from fuzzynav.app.provenance import command_line
from fuzzynav.safe_files import check_writable_file

from . import blueprint as blueprints
from . import documents
from .blueprint import application_id
from .columns import ColumnWriter
from .events import send_events
from .files import RecordingError, recording_sink
from .fuzzy import fuzzy_view, send_fuzzy_rows
from .internals import controller_fis, has_internals, rule_system
from .live import LiveRecorder
from .plot_events import send_plot_events
from .scene import static_world

#: What other rooms import from here (the viewer: the live recorder; the tests: the error).
__all__ = [
    "LiveRecorder",
    "RecordingError",
    "add_run_options",
    "record_run",
    "record_simulation",
    "run_hook",
]

#: The most rows ``record_run`` sends at once (100 s of a run at the default 20 ms).
SEND_ROWS = 5000


def _sensor_config(sensors):
    from fuzzynav.world.sensors import SensorConfig

    if sensors is None:
        return SensorConfig()
    return getattr(sensors, "config", sensors)


def _parameters(parameters):
    if parameters is not None:
        return parameters
    from fuzzynav.world.husky import HuskyModel

    return HuskyModel.default().parameters


def record_run(
    result,
    path,
    *,
    controller=None,
    sensors=None,
    extra_metadata=None,
    parameters=None,
    voltage_limit_v: float = 12.0,
) -> Path:
    """Write a run (a ``SimulationResult``, finished or partial) to a rerun recording.

    Parameters
    ----------
    result : SimulationResult
    path : str or Path
        The ``.rrd`` file (overwritten).
    controller : optional
        The controller that drove; with a ``fis`` attribute (a ``FuzzySystem``) the
        firing strength of every rule is recorded and the rule base stored.
    sensors : RangeSensorArray or SensorConfig, optional
        For the beams' geometry (default: ``SensorConfig()``).
    extra_metadata : dict, optional
        Added to the ``/meta/run`` document (e.g. ``{"interrupted": True}``).
    parameters : HuskyParameters, optional
        The robot's parameters (footprint, stored in ``/meta/robot``); default: the
        paper's (``HuskyModel.default()``).
    voltage_limit_v : float
        The saturation drawn on the voltage plot.

    Returns the path written.
    """
    path = Path(path)
    from fuzzynav.safe_files import is_stream_target

    if not is_stream_target(path):  # a pipe or a terminal is written as a stream
        check_writable_file(path)
    # Streamed: rerun's file sink writes each block as it is encoded, through a pipe, to
    # a temporary file beside the target that is renamed into place only when whole
    # (recording_sink): a long run's recording is never held in memory, and a full disk
    # or a Ctrl-C can never leave half a file, nor cost an old one.
    with recording_sink(path) as sink:
        _record(
            result,
            sink,
            controller=controller,
            sensor_config=_sensor_config(sensors),
            parameters=_parameters(parameters),
            extra_metadata=extra_metadata,
            voltage_limit_v=voltage_limit_v,
        )
    return path


def _column_writer(rec, result, *, controller, fis, sensor_config, parameters, voltage_limit_v):
    """The writer of ``result``'s columns to ``rec``, its legends placed from the log."""
    import numpy as np

    log = result.log
    decided = np.all(np.isfinite(log.controller_output_v), axis=1)
    return ColumnWriter(
        rec,
        footprint_m=(parameters.footprint_length_m, parameters.footprint_width_m),
        sensor_config=sensor_config,
        voltage_limit_v=voltage_limit_v,
        fis=fis,
        tolerance_m=result.scenario.tolerance_m,
        controller=controller,
        perception=result.perception,
        geometry=getattr(result, "geometry", "husky"),
        # known in advance: the rule heatmap is binned as the rows come
        decisions=int(np.count_nonzero(decided)),
        legends_from_log=True,  # placed from the log, not from kept rows
    )


def _send_rows(rec, writer, log) -> None:
    """The log's rows, a block of :data:`SEND_ROWS` at a time: the Arrow arrays built to
    send them, and the bytes encoded from them, stay as large as one block, however long
    the run."""
    for first in range(0, len(log), SEND_ROWS):
        writer.send(log, first, min(first + SEND_ROWS, len(log)), send_static=False)
        # Wait until the block has left for the pipe: rerun's sink queues without
        # bound, and on a slow disk (or a machine short of memory, whose page cache
        # is written back slowly) a 2,000 s run at 1 ms queued 300 MB more there.
        # (Not after the last block: the close flushes, and a short run has one.)
        if first + SEND_ROWS < len(log):
            rec.flush()


def _send_statics(
    rec,
    writer,
    result,
    *,
    controller,
    fis,
    sensor_config,
    parameters,
    extra_metadata,
    voltage_limit_v,
) -> list:
    """Every static part in one record batch (styles, the world's statics, documents),
    the events, and the inference at each decision; returns the fuzzy views' names."""
    scenario = result.scenario
    log = result.log
    extra = dict(extra_metadata or {})
    if writer.fis_error:
        extra["rule firing"] = f"not recorded ({writer.fis_error})"
    if writer.replica_error:
        extra["controller internals"] = f"not recorded ({writer.replica_error})"
    static_world(writer.static, scenario)
    documents.metadata(
        writer.static,
        scenario=scenario,
        controller=controller,
        fis=fis,
        parameters=parameters,
        sensor_config=sensor_config,
        seed=result.seed,
        perception=result.perception,
        control_period_s=result.control_period_s,
        voltage_limit_v=voltage_limit_v,
        extra_metadata=extra,
        geometry=getattr(result, "geometry", "husky"),
    )
    documents.metrics(writer.static, result.metrics, result.outcome)
    events = send_events(rec, writer.static, result)
    writer.legend_extra = send_plot_events(rec, writer, log, events, writer.static)
    documents.summary(writer.static, result, controller, events)
    fuzzy = []
    if fis is not None and writer.fis_error is None:
        fuzzy = fuzzy_view(writer.static, fis, log)
        for first in range(0, len(log) if fuzzy else 0, SEND_ROWS):
            send_fuzzy_rows(rec, fis, log, first, min(first + SEND_ROWS, len(log)))
    writer.send_heatmap(writer.static)
    writer.static.send(rec)
    return fuzzy


def _record(
    result, sink: str, *, controller, sensor_config, parameters, extra_metadata, voltage_limit_v
) -> None:
    """Send the recording of ``result`` to rerun's file sink ``sink``, a block of
    :data:`SEND_ROWS` rows at a time: what is held is one block's (its Arrow arrays, the
    aggregated outputs of its decisions), however long the run."""
    import rerun as rr

    fis = controller_fis(controller)
    scenario = result.scenario
    log = result.log
    geometry = getattr(result, "geometry", "husky")
    run_options = dict(
        perception=result.perception,
        seed=result.seed,
        noise_std_m=sensor_config.noise_std_m,
        control_period_s=result.control_period_s,
    )
    rec = rr.RecordingStream(
        application_id(
            scenario,
            controller,
            geometry,
            voltage_limit_v=voltage_limit_v,
            parameters=parameters,
            **run_options,
        )
    )
    try:
        rec.save(sink)
        rec.send_recording_name(
            blueprints.recording_name(scenario, controller, geometry, **run_options)
        )
        # One layout, at the end with the legends placed: the file appears whole (renamed
        # into place), so no viewer sees it loading (LiveRecorder sends one first too).
        n_rules = len(getattr(rule_system(controller), "rules", ()))
        layout = (scenario, list(log.obstacle_ids), n_rules, log)
        common = dict(
            controller=controller,
            fis=fis,
            sensor_config=sensor_config,
            parameters=parameters,
            voltage_limit_v=voltage_limit_v,
        )
        writer = _column_writer(rec, result, **common)
        _send_rows(rec, writer, log)
        fuzzy = _send_statics(rec, writer, result, extra_metadata=extra_metadata, **common)
        # Again, now with the legends placed where the data leave room.
        rec.send_blueprint(
            blueprints.blueprint(
                *layout,
                internals=has_internals(controller),
                legend_corners=writer.legend_corners(log),
                fuzzy=fuzzy,
                perception=result.perception,
            )
        )
    finally:
        rec.disconnect()  # flushes and ends the stream (its footer), closes the sink


def record_simulation(sim, result, path, *, extra_metadata=None) -> Path:
    """:func:`record_run` for a run of the simulation ``sim`` (its controller, sensors,
    robot parameters and saturation). Returns the path written."""
    return record_run(
        result,
        path,
        controller=sim.controller,
        sensors=sim.sensors,
        parameters=sim.model.parameters,
        voltage_limit_v=sim.voltage_limit_v,
        extra_metadata=extra_metadata,
    )


# ---------------------------------------------------------------------------------------
# Command line: fuzzynav run ... --rrd PATH


def add_run_options(parser) -> None:
    parser.add_argument(
        "--rrd",
        type=Path,
        metavar="PATH",
        help="write a rerun recording of the run (open it with: rerun PATH)",
    )
    from fuzzynav.app.provenance import add_pin_options
    from fuzzynav.app.runs import add_digest_options

    add_digest_options(parser)
    add_pin_options(parser)


def run_hook(args, sim):
    """``run --rrd PATH``: the recording is written when the run ends, whole, in place
    of any old file; after Ctrl-C the partial run goes to ``<stem>.partial.rrd`` (marked
    interrupted inside) and PATH is left as it was. First, with or without ``--rrd``,
    ``--scenario-sha256`` and ``--fis-sha256`` (a recording's reproduce command) are
    checked, and ``--rules-sha256`` and ``--fuzzynav-version``: a scenario, rule base,
    controller or fuzzynav other than the recorded one is refused."""
    from fuzzynav.app.provenance import check_pins
    from fuzzynav.app.runs import check_digests

    check_digests(args, sim)
    check_pins(args, sim)
    path = getattr(args, "rrd", None)
    if path is None:
        return None
    from fuzzynav.app.args import run_inputs
    from fuzzynav.safe_files import check_output_path, free_path, partial_path

    check_output_path(path, "--rrd", run_inputs(args))  # not an input, nor a shipped file
    argv = command_line()

    from fuzzynav.resources import escape_controls

    def write(result, interrupted: bool) -> None:
        extra = {"command line": "`" + argv + "`"}
        target = Path(path)
        shown, shown_path = escape_controls(str(target)), escape_controls(str(path))
        if interrupted:
            extra["interrupted"] = (
                f"yes (Ctrl-C at t = {result.log.time_s[-1]:.2f} s)"
                if len(result.log)
                else "yes (before the first step)"
            )
            target = free_path(partial_path(path))  # never over an earlier partial run
        try:
            record_simulation(sim, result, target, extra_metadata=extra)
        except KeyboardInterrupt:
            print(
                f"fuzzynav: interrupted while writing the recording: {shown} not written "
                f"({'the old file is unchanged' if target.exists() else 'no file made'})",
                file=sys.stderr,
            )
            raise
        if interrupted:
            shown = escape_controls(str(target))
            print(
                f"fuzzynav: the run was interrupted: its recording so far is in {shown} "
                f"(marked interrupted; {shown_path} is unchanged)",
                file=sys.stderr,
            )
        else:
            print(
                f"fuzzynav: recording written to {shown} (open it with: rerun {shown})",
                file=sys.stderr,
            )

    return write


def add_commands(subparsers) -> None:
    """``fuzzynav compare-runs A.rrd B.rrd`` (:mod:`.compare`)."""
    from .compare import add_compare_command

    add_compare_command(subparsers)
