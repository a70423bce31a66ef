"""Every run as a rerun recording: the 2D world, the paper's time series and more.

``record_run(result, path)`` writes one finished (or interrupted) run to a ``.rrd`` file;
:class:`~fuzzynav.app.recordings.live.LiveRecorder` appends the steps of a running
simulation in chunks, for the viewer (re-exported here, where the viewer imports it).
Both go through :class:`~fuzzynav.app.recordings.columns.ColumnWriter` and send whole
columns on the timelines ``sim_time`` (a duration, nanosecond resolution) and ``step``
(the log's row: the ``--trace`` CSV's row), never one call per step:
``rr.send_columns`` with the archetypes' ``columns``, an entity at a time
(:mod:`.sending`); the obstacles and the target only where they change; styles
(colours, names, radii) once, as static components (``rr.log(..., static=True)``).
Related series share one entity (a plot) as instances: each entity costs a chunk with
its own row ids and times, which for one entity per series made most of a file and of
the time to write it.

Entities (``{id}`` is the obstacle id, ``{sensor}`` left / front / right)::

    /world                                  the map; y is up (see "Orientation" below)
      /robot/footprint                      LineStrips2D: closed outline of the real footprint
      /robot/heading                        Arrows2D from the centre along the heading
      /robot/trail                          LineStrips2D: the segment travelled in each step
                                            (the default view shows every segment up to the cursor)
      /robot/trail_disturbed                the same where the inputs were disturbed
      /obstacles/{id}/body                  Points2D of the obstacle's radius (moving ones move)
      /obstacles/{id}/safe_ring             LineStrips2D circle, 0.25 m beyond the surface,
                                            about the obstacle at every row where it moves
      /obstacles/{id}/path                  LineStrips2D segments of a moving obstacle's path
      /target                               Points2D, radius = arrival tolerance
      /start, /ideal_line, /scale           static: the start, the straight start-target line,
                                            a 1 m scale bar
      /robot/sensed                         ideal perception: LineStrips2D to the centre of
                                            the obstacle the controller reacts to
      /sensors/{sensor}/beam                ultrasonic perception: the cone, as long as the
                                            reading
      /sensors/{sensor}/hit                 Points2D: the echo (none when nothing echoes)
      /events/closest/{id}, /events/moving_{id}  from their time on: the robot at each
                                            closest approach; a moving obstacle then (its
                                            track static); a collision
    /plots                                  Scalars: one entity per plot, one instance
                                            per series (named in the legend; the order
                                            is :func:`.columns.plot_layout`'s, each plot
                                            an entry of :data:`.series.PLOTS`)
      /distance          target, obstacle {id+1}...        paper Fig. 13 (centre to centre;
                                                           s2: 18, s3: 23, as every panel)
      /angles/phi_t, /angles/heading                       Fig. 14, one panel
      /obstacle_angles   obstacle {id+1}...                Fig. 15 (bearing from the heading;
                                                           NaN where it crosses +-pi)
      /voltage           left, right (applied), left and right before the limit, the
                         +-12 V limit (one name for both lines)   Fig. 16
      /inputs/distances  d_t, d_o (m) as the controller saw them
      /inputs/angles     phi_t, phi_o (rad) as the controller saw them
      /clearance         obstacle {id+1}..., the 0.25 m safe distance (footprint to surface)
      /wheels            w_LW, w_RW (rad/s)
      /velocity          v_MH (m/s), w_JH (rad/s)
      /current           i_L1, i_L2 (A)
      /ranges            left, front, right sensor readings (m); NaN = no echo
      /disturbance       the value added to the inputs
      /internals         fuzzynav: alpha and the planner offset (its flags: /internals)
      /<plot>/events/<kind>  every plot: SeriesPoints at the events' times on its
                         curves, a colour and legend entry per kind (:mod:`.plot_events`)
    /rules                                  fuzzy controllers only
      /firing            BarChart per decision: the bar at abscissa k is rule Rk (float32);
                         null at the last row (no decision)
      /firing/scale      static BarChart: a grey bar of 1 at abscissa 0 (the axis 0 to 1)
      /strongest         StateChange: the strongest rule where it changes
      /heatmap           static Tensor: rules x time (binned, max per bin)
      /heatmap/image, /rows, /times, /ticks   static: the same as a colour-mapped
                         DepthImage, every row named (R1 ... Rn), seconds under it
      /texts             static TextDocument: every rule in words
    /fuzzy/inputs/{name}, /fuzzy/outputs/{name}   a controller with a fis: the membership
                         functions, the input's value / the aggregated output and its
                         centroid at each decision (the viewer's inference view)
    /internals/flags/{yield_or_pass,edge,target_doubted}   fuzzynav: StateChange lanes
    /events/log                             TextLog: closest approaches, disturbance, end
    /events/lanes/{closest_approach,disturbance,outcome}   StateChange lanes
    /meta                                   static TextDocuments
      /run, /metrics, /scenario, /rules, /robot, /summary

The default blueprint (:mod:`.blueprint`; a live recording sends it first, so that a
viewer opening the stream uses it at once, and again at the end with the legends
placed; ``record_run``, whose file appears whole, once at the end) puts the world on
the left and the paper's figures stacked on the right, with tabs for the plant, the
sensors, the rules and the run's documents. The application id
(:func:`.blueprint.application_id`) is
``fuzzynav-<scenario>-<controller>-<geometry>-<key of the scenario's content>``, so
recordings whose layouts differ keep their own in a viewer. docs/recordings.md says what
every entity and tab shows; docs/robustness.md how files are written (whole, beside the
target, renamed; a partial run as ``<stem>.partial.rrd``; ``record_run`` sends a long
run :data:`SEND_ROWS` rows at a time).

Row conventions follow :mod:`world.simulation`: row k holds the state at ``time_s[k]``;
the voltages of the last row are NaN (no decision follows it), and are logged as NaN.
A sensor reading of ``inf`` (no echo) is logged as NaN so that plots show a gap. The
hit point is drawn on the beam's axis at the reading's distance: the log keeps the
range, not which ray of the cone echoed. Readings are held between sensor updates
(25 Hz) while the robot moves on, so a hit point may lag its obstacle by one update.

Orientation: rerun's 2D views draw y downwards (rerun issue #1387). ``/world`` carries
a static ``Transform3D`` that mirrors y, and the default view has origin ``/``, so the
map is drawn with y up, as in the paper's figures; the logged coordinates are the
simulation's own.

``rerun`` is imported inside the functions: the command line imports
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
    """Every static part (styles, the world's statics, documents), the events, and the
    inference at each decision; returns the fuzzy views' names."""
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
    aggregated outputs of its decisions), however long the run (issue 26)."""
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
    from fuzzynav.safe_files import check_output_path, partial_path

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
            target = partial_path(path)
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
