"""Every run as a rerun recording: the 2D world, the paper's time series and more.

``record_run(result, path)`` writes one finished (or interrupted) run to a ``.rrd`` file;
:class:`LiveRecorder` appends the steps of a running simulation in chunks, for the
viewer. Both send whole columns on the timeline ``sim_time`` (a duration, nanosecond
resolution), never one call per step: the entities that have a row at every step go
out together as one Arrow record batch (``RecordingStream.send_record_batch``: one
chunk per entity, as ``send_columns`` would make, for one call instead of ~20); the
obstacles and the target, logged only where they change, with ``send_columns``;
styles (colours, names, radii) once, as static components. Related series share one
entity (a plot) as instances: each entity costs a chunk with its own row ids and times,
which for one entity per series made most of a file and of the time to write it.

Entities (``{id}`` is the obstacle id, ``{sensor}`` left / front / right)::

    /world                                  the map; y is up (see "Orientation" below)
      /robot/footprint                      LineStrips2D: closed outline of the real footprint
      /robot/heading                        Arrows2D from the centre along the heading
      /robot/trail                          LineStrips2D: the segment travelled in each step
                                            (the default view shows every segment up to the cursor)
      /obstacles/{id}/body                  Points2D of the obstacle's radius (moving ones move)
      /obstacles/{id}/safe_ring             LineStrips2D circle, 0.25 m beyond the surface,
                                            sent once and moved by a Transform3D translation
      /obstacles/{id}/path                  LineStrips2D segments of a moving obstacle's path
      /target                               Points2D, radius = arrival tolerance
      /start, /ideal_line, /scale           static: the start, the straight start-target line,
                                            a 1 m scale bar
      /robot/sensed                         ideal perception: LineStrips2D to the centre of
                                            the obstacle the controller reacts to
      /sensors/{sensor}/beam                ultrasonic perception: the cone, as long as the
                                            reading
      /sensors/{sensor}/hit                 Points2D: the echo (none when nothing echoes)
      /events/closest, /events/moving_{id}  static: the robot at each closest approach; a
                                            moving obstacle then, and its track
    /plots                                  Scalars: one entity per plot, one instance
                                            per series (named in the legend; the order
                                            is :func:`plot_layout`'s)
      /distance          target, obstacle {id}...          paper Fig. 13 (centre to centre;
                                                           s2: 18, s3: 23, as every panel)
      /angles/phi_t, /angles/heading                       Fig. 14, one panel
      /obstacle_angles   obstacle {id}...                  Fig. 15 (bearing from the heading)
      /voltage           left, right (applied), left and right before the limit, the
                         +-12 V limit (one name for both lines)   Fig. 16
      /inputs/distances  d_t, d_o (m) as the controller saw them
      /inputs/angles     phi_t, phi_o (rad) as the controller saw them
      /clearance         obstacle {id}..., the 0.25 m safe distance (footprint to surface)
      /wheels            w_LW, w_RW (rad/s)
      /velocity          v_MH (m/s), w_JH (rad/s)
      /current           i_L1, i_L2 (A)
      /ranges            left, front, right sensor readings (m); NaN = no echo
      /disturbance       the value added to the inputs
    /rules                                  fuzzy controllers only
      /firing            BarChart per decision: the bar at abscissa k is rule Rk (float32);
                         null at the last row (no decision)
      /strongest         StateChange: the strongest rule where it changes
      /heatmap           static Tensor: rules x time (binned, max per bin)
      /texts             static TextDocument: every rule in words
    /fuzzy/inputs/{name}, /fuzzy/outputs/{name}   a controller with a fis: the membership
                         functions, the input's value / the aggregated output and its
                         centroid at each decision (the viewer's inference view)
    /events/log                             TextLog: closest approaches, disturbance, end
    /events/lanes/{closest_approach,disturbance,outcome}   StateChange lanes
    /meta                                   static TextDocuments
      /run, /metrics, /scenario, /rules, /robot, /summary

The default blueprint (a live recording sends it first, so that a viewer opening the
stream uses it at once, and again at the end with the legends placed; ``record_run``,
whose file appears whole, once at the end) puts the world on the left and the paper's
figures stacked on the right, with tabs for the plant, the sensors, the rules and the
run's documents. The application id (:func:`application_id`) is
``fuzzynav-<scenario>-<controller>-<geometry>-<key of the scenario's content>``, so
recordings whose layouts differ keep their own in a viewer. docs/recordings.md says what
every entity and tab shows; docs/robustness.md how files are written (whole, beside the
target, renamed; a partial run as ``<stem>.partial.rrd``).

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

``rerun`` and ``pyarrow`` are imported inside the functions: the command line imports
this module for its options on every call.
"""

from __future__ import annotations

import copy
import dataclasses
import functools
import json
import math
import platform
import re
import shlex
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

from fuzzynav.safe_files import check_writable_file  # noqa: F401  (re-exported)

TIMELINE = "sim_time"
APPLICATION_ID = "fuzzynav"
SAFE_DISTANCE_M = 0.25
HEADING_ARROW_M = 0.7
#: Draw orders in the world view (higher on top): beams under everything the robot is.
BEAM_ORDER, OBSTACLE_ORDER, TRAIL_ORDER, ROBOT_ORDER, HEADING_ORDER = 10, 20, 30, 40, 50
RING_SEGMENTS = 48

# Colours (RGB).
ROBOT = (40, 110, 220)
TRAIL = (40, 110, 220)
HEADING = (0, 140, 120)  # teal: neither the trail's blue nor a sensor's or an obstacle's
SENSED = (240, 180, 0)  # the line to the obstacle the controller reacts to
EVENT = (20, 20, 20)
# Red, orange, purple... are obstacles 0, 1, 2 in every plot and figure: the right wheel
# is drawn black-ish, the limits light grey.
RIGHT = (40, 40, 40)
LIMIT = (185, 185, 185)
TARGET = (30, 160, 60)
OBSTACLE = (200, 60, 50)
SAFE_RING = (140, 140, 140)
START = (235, 235, 235)
SCALE = (200, 200, 200)
OBSTACLE_PATH = (150, 60, 160)
SENSOR_COLORS = {"left": (0, 170, 200), "front": (120, 120, 120), "right": (200, 0, 170)}
SERIES_PALETTE = [
    (31, 119, 180),
    (214, 39, 40),
    (44, 160, 44),
    (255, 127, 14),
    (148, 103, 189),
    (140, 86, 75),
    (227, 119, 194),
    (127, 127, 127),
    (188, 189, 34),
    (23, 190, 207),
]
# Obstacle series: no green (the target's) and no blue (the robot's).
OBSTACLE_PALETTE = [
    (214, 39, 40),
    (255, 127, 14),
    (148, 103, 189),
    (140, 86, 75),
    (227, 119, 194),
    (188, 189, 34),
    (23, 190, 207),
    (127, 127, 127),
]


# ---------------------------------------------------------------------------------------
# Checks


# ---------------------------------------------------------------------------------------
# Geometry helpers (vectorised over steps)


def _time_column(time_s: np.ndarray):
    import rerun as rr

    nanos = np.round(np.asarray(time_s, dtype=float) * 1e9).astype(np.int64)
    return rr.TimeColumn(TIMELINE, duration=nanos.astype("timedelta64[ns]"))


def _wrap(angle):
    return np.mod(angle + math.pi, 2.0 * math.pi) - math.pi


def footprint_outlines(pose: np.ndarray, length_m: float, width_m: float) -> np.ndarray:
    """(n, 5, 2): the closed outline of the footprint at every pose."""
    hl, hw = 0.5 * length_m, 0.5 * width_m
    corners = np.array([(hl, hw), (-hl, hw), (-hl, -hw), (hl, -hw), (hl, hw)])
    c, s = np.cos(pose[:, 2])[:, None], np.sin(pose[:, 2])[:, None]
    x = pose[:, 0:1] + c * corners[:, 0] - s * corners[:, 1]
    y = pose[:, 1:2] + s * corners[:, 0] + c * corners[:, 1]
    return np.stack([x, y], axis=-1)


def _circle(radius: float) -> np.ndarray:
    a = np.linspace(0.0, 2.0 * math.pi, RING_SEGMENTS + 1)
    return np.stack([radius * np.cos(a), radius * np.sin(a)], axis=-1)


def sensor_geometry(pose: np.ndarray, sensor_config) -> tuple[np.ndarray, np.ndarray]:
    """(origins (n, k, 2), directions (n, k)) of the k sensors at every pose, the same
    geometry as ``RangeSensorArray.beam_geometry``."""
    mounts = sensor_config.mounts
    mx = np.array([m.x_m for m in mounts])
    my = np.array([m.y_m for m in mounts])
    ma = np.array([m.angle_rad for m in mounts])
    h = pose[:, 2:3]
    c, s = np.cos(h), np.sin(h)
    ox = pose[:, 0:1] + c * mx - s * my
    oy = pose[:, 1:2] + s * mx + c * my
    return np.stack([ox, oy], axis=-1), h + ma


def obstacle_bearings(pose: np.ndarray, obstacle_xy: np.ndarray) -> np.ndarray:
    """(n, n_obstacles): bearing of each obstacle's centre from the heading, (-pi, pi]."""
    dx = obstacle_xy[:, :, 0] - pose[:, 0:1]
    dy = obstacle_xy[:, :, 1] - pose[:, 1:2]
    out = _wrap(np.arctan2(dy, dx) - pose[:, 2:3])
    return np.where(out == -math.pi, math.pi, out)


def target_geometry(pose: np.ndarray, target_xy: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(distance, bearing phi_t) of the target at every pose."""
    dx = target_xy[:, 0] - pose[:, 0]
    dy = target_xy[:, 1] - pose[:, 1]
    phi = _wrap(np.arctan2(dy, dx) - pose[:, 2])
    return np.hypot(dx, dy), np.where(phi == -math.pi, math.pi, phi)


# ---------------------------------------------------------------------------------------
# What a run is recorded with


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


def controller_fis(controller):
    """The controller's ``FuzzySystem`` (its ``fis`` attribute), or None."""
    fis = getattr(controller, "fis", None) if controller is not None else None
    if fis is None or not hasattr(fis, "firing_strengths"):
        return None
    return fis


def has_internals(controller) -> bool:
    """Whether the controller logs its inner state (fuzzynav's ``decisions``: per call,
    the two voltages and the :data:`INTERNALS`); that state is then recorded, from the
    log of the controller that drove or, failing that, replayed through a copy."""
    inner = getattr(controller, "inner", controller)  # the viewer wraps its controller
    return controller is not None and isinstance(getattr(inner, "decisions", None), list)


def rule_system(controller):
    """The fuzzy system whose rules' firing a recording plots: the controller's ``fis``
    (fed the four logged inputs), else for a controller that logs its decisions its
    ``merged`` blocks (fed the blocks' inputs it logged); None if neither."""
    fis = controller_fis(controller)
    if fis is not None:
        return fis
    inner = getattr(controller, "inner", controller)
    merged = getattr(inner, "merged", None) if has_internals(controller) else None
    return merged if hasattr(merged, "firing_strengths") else None


def controller_replica(controller):
    """A fresh copy of a controller that explains itself, through which the logged inputs
    are replayed to record its inner state when it did not log its decisions; else None."""
    if not has_internals(controller):
        return None
    inner = getattr(controller, "inner", controller)
    replica = copy.deepcopy(inner)
    replica.reset()
    return replica


INTERNALS_PATH = "/plots/internals"
INTERNALS = (
    "avoidance weight alpha",
    "planner offset (rad)",
    "yield (1) / pass first (-1)",
    "following an edge (1)",
    "target reading doubted (1)",
)


def controller_label(controller) -> str:
    if controller is None:
        return "unknown"
    name = getattr(controller, "name", None)
    if isinstance(name, str) and name:
        return name
    return type(controller).__name__


RULES_PATH = "/rules/firing"  # BarChart per step: every rule's firing strength (float32)
RULES_HEATMAP_PATH = "/rules/heatmap"  # static Tensor, rules x time bins (max per bin)
RULES_TEXT_PATH = "/rules/texts"  # static TextDocument: R1 ... Rn in words
RULES_STRONGEST_PATH = "/rules/strongest"  # StateChange: the strongest rule where it changes
#: The most time bins of the rule heatmap (a long run is binned: the max per bin).
HEATMAP_MAX_BINS = 1500


def _plot_spec(obstacle_ids, sensor_names, voltage_limit_v: float = 12.0) -> list[tuple]:
    """(path, series names, colours, widths) of every plot but the rules."""
    ids = list(obstacle_ids)
    obstacles = [f"obstacle {i}" for i in ids]
    obstacle_colors = [OBSTACLE_PALETTE[c % len(OBSTACLE_PALETTE)] for c in range(len(ids))]
    grey = (120, 120, 120)
    p = SERIES_PALETTE
    limit = voltage_limit_v
    k = len(ids)
    return [
        ("/plots/distance", ["target"] + obstacles, [TARGET] + obstacle_colors, [2.0] + [1.5] * k),
        ("/plots/angles/phi_t", ["phi_t"], [p[0]], [1.5]),
        ("/plots/angles/heading", ["heading"], [HEADING], [1.5]),
        ("/plots/obstacle_angles", obstacles, obstacle_colors, [1.5] * k),
        (
            "/plots/voltage",
            # (the two limits share one name: one legend entry)
            ["left", "right", "left, before limit", "right, before limit"]
            + [f"±{limit:g} V limit"] * 2,
            [p[0], RIGHT, (150, 190, 230), (150, 150, 150), LIMIT, LIMIT],
            [2.0, 2.0, 1.0, 1.0, 1.0, 1.0],
        ),
        ("/plots/inputs/distances", ["d_t", "d_o"], [p[0], p[1]], [1.5] * 2),
        ("/plots/inputs/angles", ["phi_t", "phi_o"], [p[2], p[3]], [1.5] * 2),
        (
            "/plots/clearance",
            obstacles + [f"safe {SAFE_DISTANCE_M} m"],
            obstacle_colors + [grey],
            [1.5] * k + [1.0],
        ),
        ("/plots/wheels", ["w_LW (rad/s)", "w_RW (rad/s)"], [p[0], RIGHT], [1.5] * 2),
        ("/plots/velocity", ["v_MH (m/s)", "w_JH (rad/s)"], p[2:4], [1.5] * 2),
        ("/plots/current", ["i_L1 left (A)", "i_L2 right (A)"], [p[0], RIGHT], [1.5] * 2),
        (
            "/plots/ranges",
            [f"{m} (m)" for m in sensor_names],
            [SENSOR_COLORS.get(m, grey) for m in sensor_names],
            [1.5] * len(sensor_names),
        ),
        ("/plots/disturbance", ["disturbance"], [p[7]], [1.5]),
    ]


def plot_layout(
    obstacle_ids, sensor_names, n_rules: int = 0, voltage_limit_v: float = 12.0
) -> dict[str, list[str]]:
    """Every plot entity of a recording and the names of its series, in instance order
    (instance j of a row of ``path`` is series ``names[j]``); a plot without series (no
    obstacles) is not logged."""
    layout = {
        path: names
        for path, names, _, _ in _plot_spec(obstacle_ids, sensor_names, voltage_limit_v)
        if names
    }
    return layout


# ---------------------------------------------------------------------------------------
# Static styling: one record batch for every entity's colours, radii, labels and names


@functools.cache
def _component_types() -> dict:
    """(archetype, field) -> (descriptor, arrow type), read once from the SDK itself, so
    that the record batches below carry exactly the metadata ``rr.log`` would."""
    import rerun as rr

    samples = (
        rr.SeriesLines(names="x", colors=[(0, 0, 0)], widths=1.0),
        rr.Scalars(scalars=[0.0]),
        rr.Points2D(positions=[(0, 0)], radii=1.0, colors=[(0, 0, 0)], labels="x", draw_order=1.0),
        rr.LineStrips2D(
            strips=[[(0, 0), (1, 1)]], radii=1.0, colors=[(0, 0, 0)], labels="x", draw_order=1.0
        ),
        rr.Arrows2D(
            vectors=[(1, 0)], origins=[(0, 0)], radii=0.1, colors=[(0, 0, 0)], draw_order=1.0
        ),
        rr.BarChart(
            values=np.zeros(2, dtype=np.float32),
            color=(0, 0, 0),
            abscissa=np.zeros(2, dtype=np.float32),
        ),
    )
    out = {}
    for sample in samples:
        for batch in sample.as_component_batches():
            d = batch.component_descriptor()
            archetype = d.archetype.rsplit(".", 1)[-1]
            out[(archetype, d.component.split(":", 1)[1])] = (d, batch.as_arrow_array().type)
    return out


class _ArrowBatch:
    """A ready Arrow array as a component batch (rerun's ComponentBatchLike protocol)."""

    def __init__(self, descriptor, array):
        self._descriptor, self._array = descriptor, array

    def component_descriptor(self):
        return self._descriptor

    def as_arrow_array(self):
        return self._array


def _vec2_array(archetype: str, name: str, xy):
    """2D vectors (positions, origins, vectors) as the component's Arrow array."""
    import pyarrow as pa

    _, arrow_type = _component_types()[(archetype, name)]
    flat = pa.array(np.ascontiguousarray(xy, dtype=np.float32).reshape(-1))
    return pa.FixedSizeListArray.from_arrays(flat, type=arrow_type)


def _strips_array(strips: np.ndarray):
    """Line strips from an (n, k, 2) array (strip i has k points) as the LineStrip2D
    Arrow array, straight from numpy (the SDK's converter loops over strips in Python)."""
    import pyarrow as pa

    _, arrow_type = _component_types()[("LineStrips2D", "strips")]
    n, k = strips.shape[0], strips.shape[1]
    flat = pa.array(np.ascontiguousarray(strips, dtype=np.float32).reshape(-1))
    points = pa.FixedSizeListArray.from_arrays(flat, type=arrow_type.value_type)
    offsets = pa.array(np.arange(0, n * k + 1, k, dtype=np.int32))
    return pa.ListArray.from_arrays(offsets, points, type=arrow_type)


def _tensor_rows(values: np.ndarray):
    """Rows of float32 vectors (n, k) as the TensorData Arrow array of a BarChart's
    ``values`` (one tensor of shape [k] per row), built straight from numpy: the SDK's
    converter takes a 2D array for one tensor."""
    import pyarrow as pa

    _, arrow_type = _component_types()[("BarChart", "values")]
    values = np.ascontiguousarray(values, dtype=np.float32)
    n, k = values.shape
    shape = pa.ListArray.from_arrays(
        pa.array(np.arange(n + 1, dtype=np.int32)),
        pa.array(np.full(n, k, dtype=np.uint64)),
        type=arrow_type.field("shape").type,
    )
    names = pa.nulls(n, arrow_type.field("names").type)
    union = arrow_type.field("buffer").type
    children = []
    for child in union:
        if child.name == "F32":
            children.append(
                pa.ListArray.from_arrays(
                    pa.array(np.arange(0, n * k + 1, k, dtype=np.int32)),
                    pa.array(values.reshape(-1)),
                    type=child.type,
                )
            )
        else:
            children.append(pa.array([], type=child.type))
    code = union.type_codes[[child.name for child in union].index("F32")]
    buffer = pa.Array.from_buffers(
        union,
        n,
        [
            None,
            pa.py_buffer(np.full(n, code, dtype=np.int8).tobytes()),
            pa.py_buffer(np.arange(n, dtype=np.int32).tobytes()),
        ],
        children=children,
    )
    return pa.StructArray.from_arrays([shape, names, buffer], fields=list(arrow_type))


def _translation_columns(xy: np.ndarray):
    """Transform3D translation columns (x, y, 0) for ``send_columns``."""
    import rerun as rr

    xyz = np.zeros((len(xy), 3), dtype=np.float32)
    xyz[:, :2] = xy
    return rr.Transform3D.columns(translation=xyz)


def rule_heatmap(strengths: np.ndarray, max_bins: int) -> np.ndarray:
    """(rules, bins) float32: the firing strengths (rows, rules) binned over time, each
    bin the largest strength of its rows; one column per row if there are few."""
    strengths = np.asarray(strengths, dtype=np.float32)
    n = len(strengths)
    if n <= max_bins:
        return np.ascontiguousarray(strengths.T)
    edges = np.linspace(0, n, max_bins + 1).astype(int)
    return np.ascontiguousarray(np.maximum.reduceat(strengths, edges[:-1], axis=0).T)


def _column(archetype: str, name: str, array, lengths=None):
    """A ready Arrow array as a ``send_columns`` column: one instance per row unless
    ``lengths`` says how many each row holds."""
    import rerun as rr

    descriptor, _ = _component_types()[(archetype, name)]
    return rr.ComponentColumn(descriptor, _ArrowBatch(descriptor, array), lengths=lengths)


@functools.cache
def _component_field(entity: str, archetype: str, name: str):
    import pyarrow as pa

    descriptor, arrow_type = _component_types()[(archetype, name)]
    field = pa.field(
        f"{entity}:{descriptor.component}",
        pa.list_(arrow_type),
        metadata={
            "rerun:entity_path": entity,
            "rerun:archetype": descriptor.archetype,
            "rerun:component": descriptor.component,
            "rerun:component_type": descriptor.component_type,
            "rerun:kind": "data",
        },
    )
    return field, arrow_type


class _StaticBatch:
    """Static components of many entities, sent as one record batch (one chunk each)."""

    def __init__(self):
        self.fields: list = []
        self.arrays: list = []

    def add(self, entity: str, archetype: str, **components) -> None:
        import pyarrow as pa

        for name, value in components.items():
            values = value if isinstance(value, list) else [value]  # a list: instances
            if name in ("colors", "color"):
                values = [_rgba(v) for v in values]
            field, arrow_type = _component_field(entity, archetype, name)
            self.fields.append(field)
            self.arrays.append(pa.array([values], type=field.type))

    def add_array(self, entity: str, archetype: str, name: str, instances) -> None:
        """One component given as its Arrow array of instances."""
        import pyarrow as pa

        field, _ = _component_field(entity, archetype, name)
        self.fields.append(field)
        offsets = pa.array([0, len(instances)], type=pa.int32())
        self.arrays.append(pa.ListArray.from_arrays(offsets, instances))

    def add_archetype(self, entity: str, archetype) -> None:
        """Every component of an ``rr`` archetype, with the SDK's own descriptors."""
        import pyarrow as pa

        for batch in archetype.as_component_batches():
            d = batch.component_descriptor()
            array = batch.as_arrow_array()
            self.fields.append(
                pa.field(
                    f"{entity}:{d.component}",
                    pa.list_(array.type),
                    metadata={
                        "rerun:entity_path": entity,
                        "rerun:archetype": d.archetype or "",
                        "rerun:component": d.component,
                        "rerun:component_type": d.component_type or "",
                        "rerun:kind": "data",
                    },
                )
            )
            self.arrays.append(
                pa.ListArray.from_arrays(pa.array([0, len(array)], type=pa.int32()), array)
            )

    def send(self, rec) -> None:
        import pyarrow as pa

        if not self.fields:
            return
        batch = pa.RecordBatch.from_arrays(self.arrays, schema=pa.schema(self.fields))
        rec.send_record_batch(batch, index=None)
        self.fields, self.arrays = [], []


class _RowBatch:
    """Whole columns of many entities that share one time column (one row per step),
    sent as a single Arrow record batch: ``Chunk.from_record_batch`` makes one chunk per
    entity, the chunks ``send_columns`` would make, for one call instead of one per
    entity (about 0.3 ms each, which adds up over ~70 series and every live chunk)."""

    def __init__(self, time_s: np.ndarray):
        import pyarrow as pa

        nanos = np.round(np.asarray(time_s, dtype=float) * 1e9).astype(np.int64)
        self.n = len(nanos)
        self.fields = [pa.field(TIMELINE, pa.duration("ns"))]
        self.arrays = [pa.array(nanos.astype("timedelta64[ns]"), type=pa.duration("ns"))]
        self.unit_offsets = pa.array(np.arange(self.n + 1, dtype=np.int32))

    def add(
        self, entity: str, archetype: str, name: str, instances, lengths=None, absent=None
    ) -> None:
        """``instances``: the component's Arrow array; one per row, or ``lengths[i]``
        of them in row i. Rows where ``absent`` is true hold no value at all (null: the
        viewer shows the latest row before), not an empty list (which clears it)."""
        import pyarrow as pa

        field, _ = _component_field(entity, archetype, name)
        if lengths is None:
            offsets = self.unit_offsets
        else:
            offsets = pa.array(np.concatenate([[0], np.cumsum(lengths)]).astype(np.int32))
        mask = None if absent is None else pa.array(np.asarray(absent, bool))
        self.fields.append(field)
        self.arrays.append(pa.ListArray.from_arrays(offsets, instances, mask=mask))

    def add_series(self, entity: str, columns) -> None:
        """Scalars: ``columns`` (n rows, k series) as k instances per row."""
        import pyarrow as pa

        columns = np.ascontiguousarray(columns, dtype=np.float64)
        k = columns.shape[1]
        values = pa.array(columns.reshape(-1), type=pa.float64())
        self.add(
            entity,
            "Scalars",
            "scalars",
            values,
            lengths=None if k == 1 else np.full(self.n, k, dtype=np.int32),
        )

    def send(self, rec) -> None:
        import pyarrow as pa

        if len(self.fields) > 1:
            batch = pa.RecordBatch.from_arrays(self.arrays, schema=pa.schema(self.fields))
            rec.send_record_batch(batch, index=TIMELINE)


# ---------------------------------------------------------------------------------------
# The column writer shared by record_run and LiveRecorder


class _ColumnWriter:
    """Sends rows [start, end) of a SimulationLog as columns; remembers what it sent so
    that the next chunk continues it (trail segments, obstacle changes, styles)."""

    def __init__(
        self,
        rec,
        *,
        footprint_m,
        sensor_config,
        voltage_limit_v: float,
        fis=None,
        tolerance_m: float = 0.15,
        controller=None,
        perception: str | None = None,
        geometry: str = "husky",
    ):
        self.rec = rec
        # Ideal perception uses no range sensor: no beams are drawn, but the line to the
        # obstacle the controller reacts to (the nearest: by clearance, or centre to
        # centre in the paper's geometry).
        self.draw_beams = perception != "ideal"
        self.geometry = geometry
        self.controller = controller
        self.internals = has_internals(controller)
        # A decision: the voltages, the internals, then the inputs of the blocks' rules.
        blocks = rule_system(controller) if self.internals and fis is None else None
        self.blocks = blocks
        self.decision_width = 2 + len(INTERNALS) + (len(blocks.inputs) if blocks else 0)
        self.internals_source: str | None = None  # "decisions" or "replay", from chunk 1
        self.replica = None
        self.replica_error: str | None = None
        self.footprint_m = (float(footprint_m[0]), float(footprint_m[1]))
        self.sensor_config = sensor_config
        self.sensor_names = [m.name for m in sensor_config.mounts]
        self.voltage_limit_v = float(voltage_limit_v)
        self.fis = fis
        self.fis_error: str | None = None
        self.tolerance_m = float(tolerance_m)
        self.sent = 0
        self._styled: set[str] = set()
        self._plot_styles: dict[str, tuple] = {}
        self._static = self.static = _StaticBatch()
        self._obstacles: dict[int, tuple[bool, tuple[float, float]]] = {}
        self._target: tuple[float, float] | None = None
        self.obstacle_ids: list[int] = []
        self.n_rules = 0
        self.rule_times: list[np.ndarray] = []  # for the heatmap, sent at the end
        self.rule_strengths: list[np.ndarray] = []
        self._rings: set[int] = set()
        self._legend_samples: dict[str, list[np.ndarray]] = {}

    # -- low level ---------------------------------------------------------------------

    def _send(self, path: str, tc, columns) -> None:
        self.rec.send_columns(path, indexes=[tc], columns=columns, strict=True)

    def _style(self, path: str, archetype: str, **components) -> None:
        """Static styling of an entity, sent with the chunk's other styles."""
        if path not in self._styled:
            self._styled.add(path)
            self._static.add(path, archetype, **components)

    def _plot(self, path: str, names, colors, widths, columns) -> None:
        """One plot entity: ``columns`` (n, k) are k series, named ``names``."""
        if not names:  # e.g. obstacle angles without obstacles
            return
        style = (tuple(names), tuple(colors), tuple(widths))
        if self._plot_styles.get(path) != style:  # new, or obstacles were added
            self._plot_styles[path] = style
            self._static.add(
                path, "SeriesLines", names=list(names), colors=list(colors), widths=list(widths)
            )
        self._rows.add_series(path, columns)
        self._legend_samples.setdefault(path, []).append(np.array(columns, dtype=float))

    def legend_corners(self) -> dict:
        """Per plot view, where its legend goes and the value range that leaves it room
        (:func:`_legend_placement`): ``{view origin: (corner, range or None)}``. The
        two angle entities share one view (/plots/angles), as Fig. 14 shows both."""
        samples = {}
        for path, parts in self._legend_samples.items():
            widths = {p.shape[1] for p in parts if p.ndim == 2}
            if len(widths) == 1:  # (obstacles added mid-run change the width: skip)
                samples[path] = np.concatenate(parts)
        angles = [
            samples.pop(p) for p in ("/plots/angles/phi_t", "/plots/angles/heading") if p in samples
        ]
        if len(angles) == 2 and len(angles[0]) == len(angles[1]):
            samples["/plots/angles"] = np.hstack(angles)
        placements = {}
        for path, values in samples.items():
            names = self._plot_styles.get(path, ((),))[0] or ("phi_t", "heading")
            placement = _legend_placement(values, len(set(names)))
            if placement is not None:
                placements[path] = placement
                finite = values[np.isfinite(values)]
                lo, hi = float(finite.min()), float(finite.max())
                pad = 0.05 * (hi - lo if hi > lo else max(abs(hi), 1.0))
                placements[f"{path}#data"] = (lo - pad, hi + pad)  # (a view without legend)
        return placements

    def _series(self, log, start, end, pose, target, ranges, inputs):
        """(path, names, colors, widths, columns) of every plot, in :func:`plot_layout`'s
        order; ``columns`` is (rows, series)."""
        n = end - start
        ids = list(log.obstacle_ids)
        d_t, phi_t = target_geometry(pose, target)
        bearings = obstacle_bearings(pose, log.obstacle_xy[start:end]) if ids else np.zeros((n, 0))
        limit = self.voltage_limit_v
        constant = np.ones((n, 1))
        lg = log.lg_state[start:end]
        columns = {
            "/plots/distance": np.column_stack([d_t, log.center_distance_m[start:end]]),
            "/plots/angles/phi_t": phi_t[:, None],
            "/plots/angles/heading": pose[:, 2:3],
            "/plots/obstacle_angles": bearings,
            "/plots/voltage": np.column_stack(
                [
                    log.voltages_v[start:end],
                    log.controller_output_v[start:end],
                    limit * constant,
                    -limit * constant,
                ]
            ),
            "/plots/inputs/distances": inputs[:, [0, 1]],
            "/plots/inputs/angles": inputs[:, [2, 3]],
            "/plots/clearance": np.column_stack(
                [log.clearance_m[start:end], SAFE_DISTANCE_M * constant]
            ),
            "/plots/wheels": lg[:, 0:2],
            "/plots/velocity": lg[:, 2:4],
            "/plots/current": lg[:, 4:6],
            "/plots/ranges": np.where(np.isinf(ranges), np.nan, ranges),
            "/plots/disturbance": log.disturbance[start:end, None],
        }
        return [
            (path, names, colors, widths, columns[path])
            for path, names, colors, widths in _plot_spec(ids, self.sensor_names, limit)
        ]

    # -- one chunk ---------------------------------------------------------------------

    def send(self, log, start: int, end: int, *, send_static: bool = True) -> None:
        """Send rows [start, end); with ``send_static`` also the static components
        collected so far (else the caller sends ``self.static``)."""
        if end <= start:
            return
        t = log.time_s[start:end]
        rows = self._rows = _RowBatch(t)
        self._rows_time = t
        pose = log.pose[start:end]

        # -- the robot
        self._style(
            "/world/robot/footprint",
            "LineStrips2D",
            colors=ROBOT,
            radii=0.015,
            draw_order=float(ROBOT_ORDER),
        )
        rows.add(
            "/world/robot/footprint",
            "LineStrips2D",
            "strips",
            _strips_array(footprint_outlines(pose, *self.footprint_m)),
        )
        self._style(
            "/world/robot/heading",
            "Arrows2D",
            colors=HEADING,
            radii=0.035,
            draw_order=float(HEADING_ORDER),
        )
        heading = np.stack([np.cos(pose[:, 2]), np.sin(pose[:, 2])], axis=-1) * HEADING_ARROW_M
        rows.add(
            "/world/robot/heading",
            "Arrows2D",
            "origins",
            _vec2_array("Arrows2D", "origins", pose[:, :2]),
        )
        rows.add(
            "/world/robot/heading",
            "Arrows2D",
            "vectors",
            _vec2_array("Arrows2D", "vectors", heading),
        )
        previous = log.pose[start - 1, :2] if start > 0 else pose[0, :2]
        starts = np.vstack([previous[None, :], pose[:-1, :2]])
        self._style(
            "/world/robot/trail",
            "LineStrips2D",
            colors=TRAIL,
            radii=0.02,
            draw_order=float(TRAIL_ORDER),
        )
        rows.add(
            "/world/robot/trail",
            "LineStrips2D",
            "strips",
            _strips_array(np.stack([starts, pose[:, :2]], axis=1)),
        )

        # -- the target (only the rows where it moved: latest-at keeps it in between)
        target = log.target_xy[start:end]
        keep = np.ones(len(t), bool)
        keep[1:] = np.any(target[1:] != target[:-1], axis=1)
        if self._target is not None:
            keep[0] = bool(np.any(target[0] != np.asarray(self._target)))
        if keep.any():
            k = np.flatnonzero(keep)
            self._style(
                "/world/target", "Points2D", colors=TARGET, radii=self.tolerance_m, labels="target"
            )
            self._send(
                "/world/target",
                _time_column(t[k]),
                [_column("Points2D", "positions", _vec2_array("Points2D", "positions", target[k]))],
            )
        self._target = (float(target[-1, 0]), float(target[-1, 1]))

        # -- the obstacles
        self.obstacle_ids = list(log.obstacle_ids)
        for col, oid in enumerate(log.obstacle_ids):
            self._send_obstacle(log, col, oid, start, end, t)

        # -- the sensors, or (ideal perception) the obstacle the controller reacts to
        ranges = log.ranges_m[start:end]
        if self.draw_beams:
            self._send_beams(pose, ranges, rows)
        else:
            self._send_sensed(log, start, end, pose, rows)

        # -- time series: one entity per plot, one instance (series) per column
        inputs = log.inputs[start:end]
        for path, names, colors, widths, columns in self._series(
            log, start, end, pose, target, ranges, inputs
        ):
            self._plot(path, names, colors, widths, columns)

        # -- rule firing strengths (rows with a decision: the last row has none)
        decided = np.all(np.isfinite(log.controller_output_v[start:end]), axis=1)
        if self.fis is not None and self.fis_error is None:
            try:
                strengths = np.asarray(self.fis.firing_strengths(inputs), dtype=float)
            except Exception as exc:  # a fuzzy system of another shape: record why not
                self.fis_error = f"{type(exc).__name__}: {exc}"
            else:
                self._plot_rules(strengths, decided)
        if self.internals and self.replica_error is None:
            self._internals(log, start, end)
        if send_static:
            self._static.send(self.rec)
        rows.send(self.rec)
        self.sent = end

    def _send_sensed(self, log, start: int, end: int, pose, rows) -> None:
        """A line from the robot's centre to the centre of the obstacle the controller
        reacts to (the nearest, as ideal perception picks it), where it senses one."""
        d_o = log.inputs[start:end, 1]
        n = end - start
        if log.obstacle_xy.shape[1] == 0:
            sensed = np.zeros(n, bool)
            centres = np.zeros((n, 2))
        else:
            near = log.center_distance_m if self.geometry == "paper" else log.clearance_m
            near = np.where(np.isfinite(near[start:end]), near[start:end], np.inf)
            k = np.argmin(near, axis=1)
            centres = log.obstacle_xy[start:end][np.arange(n), k]
            sensed = np.isfinite(d_o) & np.all(np.isfinite(centres), axis=1)
        self._style(
            "/world/robot/sensed",
            "LineStrips2D",
            colors=SENSED,
            radii=0.025,
            draw_order=float(ROBOT_ORDER - 1),
        )
        strips = np.stack([pose[sensed, :2], centres[sensed]], axis=1)
        rows.add(
            "/world/robot/sensed",
            "LineStrips2D",
            "strips",
            _strips_array(strips),
            lengths=sensed.astype(np.int32),
        )

    def _send_beams(self, pose, ranges, rows) -> None:
        """The range sensors' cones, as long as their readings, and their echoes."""
        origins, directions = sensor_geometry(pose, self.sensor_config)
        max_range = float(self.sensor_config.max_range_m)
        half = 0.5 * float(self.sensor_config.beam_width_rad)
        for k, name in enumerate(self.sensor_names):
            color = SENSOR_COLORS.get(name, (100, 100, 100))
            r = ranges[:, k]
            echo = np.isfinite(r)
            length = np.where(echo, r, max_range)[:, None]
            o = origins[:, k]
            d = directions[:, k][:, None]
            left = o + length * np.hstack([np.cos(d + half), np.sin(d + half)])
            right = o + length * np.hstack([np.cos(d - half), np.sin(d - half)])
            self._style(
                f"/world/sensors/{name}/beam",
                "LineStrips2D",
                colors=(*color, 110),
                radii=0.006,
                draw_order=float(BEAM_ORDER),
            )
            rows.add(
                f"/world/sensors/{name}/beam",
                "LineStrips2D",
                "strips",
                _strips_array(np.stack([o, left, right, o], axis=1)),
            )
            hits = (o + np.where(echo, r, 0.0)[:, None] * np.hstack([np.cos(d), np.sin(d)]))[echo]
            self._style(f"/world/sensors/{name}/hit", "Points2D", colors=color, radii=0.06)
            rows.add(
                f"/world/sensors/{name}/hit",
                "Points2D",
                "positions",
                _vec2_array("Points2D", "positions", hits),
                lengths=echo.astype(np.int32),
            )

    def _plot_rules(self, strengths: np.ndarray, decided: np.ndarray) -> None:
        """Every rule's firing strength at every row with a decision as one bar chart
        (bar k-1 is rule Rk, its abscissa k; float32), and kept for the run's heatmap
        (:meth:`send_heatmap`). A row without a decision (the last) has no strengths:
        nothing is logged there, so the chart at the end shows the last decision's. One
        bar chart, not 40 lines in a 10-colour palette that made R1, R11 and R21 alike."""
        strengths = np.ascontiguousarray(strengths, dtype=np.float32)
        decided = np.asarray(decided, bool)
        self.n_rules = strengths.shape[1]
        if RULES_PATH not in self._styled:  # bar k at abscissa k + 1: rule R(k+1)
            self._style(RULES_PATH, "BarChart", color=(230, 160, 40))
            numbers = np.arange(1, self.n_rules + 1, dtype=np.float32)[None, :]
            self._static.add_array(RULES_PATH, "BarChart", "abscissa", _tensor_rows(numbers))
        self._rows.add(
            RULES_PATH,
            "BarChart",
            "values",
            _tensor_rows(strengths[decided]),
            lengths=decided.astype(np.int32),
            absent=~decided,  # the chart at the final instant shows the last decision
        )
        self.rule_times.append(np.asarray(self._rows_time, dtype=float)[decided])
        self.rule_strengths.append(strengths[decided])

    def send_heatmap(self, static: _StaticBatch) -> None:
        """The rule firing of the whole run as a heatmap: rules down, time across (at
        most :data:`HEATMAP_MAX_BINS` bins, each the max over its rows, so a brief
        firing stays visible), with the rules in words beside it."""
        if not self.rule_strengths:
            return
        import rerun as rr

        times = np.concatenate(self.rule_times)
        strengths = np.nan_to_num(np.concatenate(self.rule_strengths), nan=0.0)
        heatmap = rule_heatmap(strengths, HEATMAP_MAX_BINS)
        bins = heatmap.shape[1]
        span = f"{times[0]:.2f} s to {times[-1]:.2f} s" if len(times) else "no rows"
        per_bin = (times[-1] - times[0]) / max(bins - 1, 1) if len(times) > 1 else 0.0
        static.add_archetype(
            RULES_HEATMAP_PATH,
            rr.Tensor(
                heatmap,
                dim_names=[
                    f"rule R1-R{heatmap.shape[0]}",
                    f"time {span}, {per_bin:.3g} s a column",
                ],
                value_range=[0.0, 1.0],
            ),
        )
        # The strongest rule at each decision, where it changes: a labelled lane in s.
        if len(times):
            top = np.argmax(strengths, axis=1)
            fired = strengths[np.arange(len(top)), top] > 0
            state = np.where(fired, top, -1)
            change = np.ones(len(state), bool)
            change[1:] = state[1:] != state[:-1]
            labels = [f"R{k + 1}" if k >= 0 else "none fires" for k in state[change]]
            self.rec.send_columns(
                RULES_STRONGEST_PATH,
                indexes=[_time_column(times[change])],
                columns=rr.StateChange.columns(state=labels),
                strict=True,
            )
        lines = [
            f"# Rule firing, {span}",
            "",
            f"Heatmap: row k is rule R(k+1), {bins} columns over the run "
            f"({len(times)} steps, the largest strength in each column).",
            "Bar chart: bar k is rule R(k+1) at the time cursor.",
            "",
        ]
        lines += [f"- **R{k + 1}**: {text}" for k, text in enumerate(self.rule_texts())]
        static.add_archetype(
            RULES_TEXT_PATH, rr.TextDocument("\n".join(lines), media_type=rr.MediaType.MARKDOWN)
        )

    def rule_texts(self) -> list[str]:
        system = self.fis if self.fis is not None else self.blocks
        if system is None or not hasattr(system, "rule_text"):
            return [f"(rule {k + 1})" for k in range(self.n_rules)]
        return [system.rule_text(k) for k in range(min(self.n_rules, len(system.rules)))]

    def _internals(self, log, start: int, end: int) -> None:
        """Plot the controller's inner state on rows [start, end): from the decisions it
        logged while it drove (``decisions``), when they line up with the run (the same
        voltages, row for row), else by replaying the rows through the replica. Either
        way the state must come with exactly the voltages the run logged; if not (the
        controller was changed mid-run, say), nothing more is plotted and the metadata
        says why."""
        decided_v = log.controller_output_v[start:end]
        decided = np.all(np.isfinite(decided_v), axis=1)  # the last row has no decision
        out = np.full((end - start, len(INTERNALS)), np.nan)
        try:
            logged = self._logged_decisions(start, end, decided)
            decisions = logged if logged is not None else self._replay(log, start, end, decided)
        except ValueError as exc:  # decisions of another shape than this writer expects
            self.replica_error = f"its decisions do not fit ({exc})"
            return
        voltages, state = decisions[:, :2], decisions[:, 2 : 2 + len(INTERNALS)]
        # NaN (no decision to compare) counts as differing.
        differs = np.flatnonzero(~np.all(np.abs(voltages - decided_v[decided]) <= 1e-9, axis=1))
        if len(differs):
            k = start + np.flatnonzero(decided)[differs[0]]
            how = "logged decisions differ" if logged is not None else "replay differs"
            self.replica_error = f"its {how} from the run at t = {log.time_s[k]:.2f} s"
            return
        out[decided] = state
        self._plot(
            INTERNALS_PATH,
            list(INTERNALS),
            [SERIES_PALETTE[k % len(SERIES_PALETTE)] for k in range(len(INTERNALS))],
            [1.5] * len(INTERNALS),
            out,
        )
        if self.blocks is not None:
            strengths = np.full((end - start, len(self.blocks.rules)), np.nan)
            if decided.any():
                strengths[decided] = self.blocks.firing_strengths(
                    decisions[:, 2 + len(INTERNALS) :]
                )
            self._plot_rules(strengths, decided)

    def _logged_decisions(self, start: int, end: int, decided: np.ndarray):
        """The driving controller's own decisions for the decided rows of [start, end)
        as an array (voltages, then the state); None to replay the rows instead (the
        first chunk chooses: a controller that did not log its decisions from the run's
        start is replayed throughout)."""
        inner = getattr(self.controller, "inner", self.controller)  # the viewer's wrapper
        decisions = getattr(inner, "decisions", None)
        rows = np.flatnonzero(decided) + start
        covered = isinstance(decisions, list) and (not len(rows) or rows[-1] < len(decisions))
        if self.internals_source is None:
            self.internals_source = "decisions" if covered and start == 0 else "replay"
        if self.internals_source == "replay":
            return None
        if not covered:  # swapped for another controller mid-run: nothing to line up
            return np.full((len(rows), self.decision_width), np.nan)
        return np.array([decisions[k] for k in rows], dtype=float).reshape(
            len(rows), self.decision_width
        )

    def _replay(self, log, start: int, end: int, decided: np.ndarray):
        """The decisions of the decided rows of [start, end), replayed through a copy
        of the controller (made at the first chunk); a replay that departs from the run
        stops there (its later rows are NaN)."""
        if self.replica is None:
            self.replica = controller_replica(self.controller)
        replica = self.replica
        rows = np.flatnonzero(decided) + start
        result = np.full((len(rows), self.decision_width), np.nan)
        for j, k in enumerate(rows):
            replica(log.inputs[k], ranges_m=log.ranges_m[k])
            result[j] = replica.decisions[-1]
            if np.any(np.abs(result[j, :2] - log.controller_output_v[k]) > 1e-9):
                break
        return result

    def _send_obstacle(self, log, col: int, oid: int, start: int, end: int, t) -> None:
        xy = log.obstacle_xy[start:end, col]
        present = np.all(np.isfinite(xy), axis=1)
        radius = float(log.obstacle_radii_m[col])
        prev = self._obstacles.get(oid)
        # Rows where the obstacle appears, moves or vanishes (latest-at keeps the rest).
        changed = np.ones(len(xy), bool)
        same_presence = present[1:] == present[:-1]
        same_place = np.all(xy[1:] == xy[:-1], axis=1) | ~present[1:]
        changed[1:] = ~(same_presence & same_place)
        if prev is not None:
            was_present, was_xy = prev
            changed[0] = not (
                present[0] == was_present and (not present[0] or tuple(xy[0]) == was_xy)
            )
        rows = np.flatnonzero(changed)
        base = f"/world/obstacles/{oid}"
        if len(rows):
            tc = _time_column(t[rows])
            lengths = present[rows].astype(np.int32)
            pos = xy[rows][present[rows]]
            # the obstacle's colour in every plot and figure (OBSTACLE_PALETTE by column)
            self._style(
                f"{base}/body",
                "Points2D",
                colors=OBSTACLE_PALETTE[col % len(OBSTACLE_PALETTE)],
                radii=radius,
                labels=f"obstacle {oid}",
                draw_order=float(OBSTACLE_ORDER),
            )
            self._send(
                f"{base}/body",
                tc,
                [
                    _column(
                        "Points2D", "positions", _vec2_array("Points2D", "positions", pos), lengths
                    )
                ],
            )
            # The safe ring: one static circle around the origin, moved by a translation
            # where the obstacle moves (12 bytes a row, not 49 points).
            # The circle is sent where the obstacle appears or vanishes, the translation
            # where it moves.
            ring_path = f"{base}/safe_ring"
            shown_now = present[rows]
            before = np.empty_like(shown_now)
            before[1:] = shown_now[:-1]
            before[0] = (not shown_now[0]) if prev is None else prev[0]
            flips = np.flatnonzero(shown_now != before)
            self._style(ring_path, "LineStrips2D", colors=SAFE_RING, radii=0.01)
            if len(flips):
                circle = _circle(radius + SAFE_DISTANCE_M)
                strips = np.repeat(circle[None], int(shown_now[flips].sum()), axis=0)
                self._send(
                    ring_path,
                    _time_column(t[rows[flips]]),
                    [
                        _column(
                            "LineStrips2D",
                            "strips",
                            _strips_array(strips),
                            shown_now[flips].astype(np.int32),
                        )
                    ],
                )
            if shown_now.any():
                self.rec.send_columns(
                    ring_path,
                    indexes=[_time_column(t[rows[shown_now]])],
                    columns=_translation_columns(pos),
                    strict=True,
                )
            # The path: a segment for every move between two present rows.
            present_rows = rows[present[rows]]
            if len(present_rows):
                points = xy[present_rows]
                before = np.vstack([[np.nan, np.nan], points[:-1]])
                # A row right after an absence starts afresh (no segment across a gap).
                gap = np.ones(len(present_rows), bool)
                gap[1:] = np.diff(np.searchsorted(rows, present_rows)) != 1
                if prev is not None and prev[0]:
                    before[0] = prev[1]
                    gap[0] = rows[0] != present_rows[0]
                moved = ~gap & np.any(before != points, axis=1)
                if moved.any():
                    segs = np.stack([before[moved], points[moved]], axis=1)
                    self._style(f"{base}/path", "LineStrips2D", colors=OBSTACLE_PATH, radii=0.015)
                    self._send(
                        f"{base}/path",
                        _time_column(t[present_rows[moved]]),
                        [_column("LineStrips2D", "strips", _strips_array(segs))],
                    )
        last = len(xy) - 1
        self._obstacles[oid] = (
            bool(present[last]),
            (float(xy[last, 0]), float(xy[last, 1])) if present[last] else (math.nan, math.nan),
        )


def _rgba(color) -> int:
    """(r, g, b) or (r, g, b, a) packed as 0xRRGGBBAA, rerun's colour component."""
    r, g, b, a = (tuple(color) + (255,))[:4]
    return (int(r) << 24) | (int(g) << 16) | (int(b) << 8) | int(a)


# ---------------------------------------------------------------------------------------
# Static parts: the world's frame, start and line, metadata, blueprint


def _static_world(static: _StaticBatch, scenario) -> None:
    """The y-up mirror of /world, the start and the straight start-target line."""
    import rerun as rr

    static.add_archetype("/world", rr.Transform3D(scale=[1.0, -1.0, 1.0]))
    # Light, with a dark rim: visible on rerun's dark theme and on a light one.
    static.add_archetype(
        "/world/start",
        rr.Points2D(
            positions=[scenario.start, scenario.start],
            radii=[0.12, 0.08],
            colors=[(20, 20, 20), START],
            labels=["", "start"],
        ),
    )
    # A scale: a 1 m bar with 10 cm ticks, just below and left of the start (the view's
    # bounds always hold the start with a 1 m margin).
    x0, bar_y = scenario.start[0] - 0.8, scenario.start[1] - 0.75
    strips = [[(x0 + 0.3, bar_y), (x0 + 1.3, bar_y)]]
    strips += [
        [(x0 + 0.3 + 0.1 * k, bar_y), (x0 + 0.3 + 0.1 * k, bar_y + (0.1 if k % 5 == 0 else 0.05))]
        for k in range(11)
    ]
    static.add_archetype(
        "/world/scale",
        rr.LineStrips2D(
            strips=strips, colors=[SCALE] * len(strips), radii=0.012, labels=["1 m"] + [""] * 10
        ),
    )
    static.add_archetype(
        "/world/ideal_line",
        rr.LineStrips2D(
            strips=[[scenario.start, scenario.target]], colors=[(170, 170, 170)], radii=0.01
        ),
    )


def _markdown_table(rows: dict) -> str:
    lines = ["| key | value |", "|---|---|"]
    for key, value in rows.items():
        if isinstance(value, float):
            value = f"{value:.6g}"
        lines.append(f"| {key} | {value} |")
    return "\n".join(lines)


def _json_safe(value):
    if isinstance(value, float) and not math.isfinite(value):
        return None
    if isinstance(value, dict):
        return {k: _json_safe(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_json_safe(v) for v in value]
    if isinstance(value, (np.floating, np.integer)):
        return _json_safe(value.item())
    return value


_VERSIONED = {
    "fuzzynav": None,
    "rerun-sdk": "rerun",
    "numpy": "numpy",
    "scipy": "scipy",
    "pymunk": "pymunk",
    "matplotlib": "matplotlib",
    "viser": "viser",
}


@functools.cache
def package_versions() -> dict:
    """Python, platform, the packages a run depends on, and the git revision (once per
    process: reading distribution metadata costs milliseconds a package)."""
    from importlib import metadata

    out = {"python": platform.python_version(), "platform": platform.platform()}
    for name, module in _VERSIONED.items():
        version = getattr(sys.modules.get(module), "__version__", None) if module else None
        if not isinstance(version, str):
            try:
                version = metadata.version(name)
            except metadata.PackageNotFoundError:
                version = "not installed"
        out[name] = version
    revision = _git_revision()
    if revision:  # only from a checkout of this project
        out["git"] = revision
    return out


def _git_revision() -> str | None:
    """The checkout's revision when fuzzynav runs from a git checkout of this project
    (an editable install); None for an installed wheel, which says its version instead
    of the revision of whatever repository it happens to sit in."""
    root = Path(__file__).resolve().parents[2]
    if not (
        (root / ".git").exists()
        and (root / "fuzzynav" / "__init__.py").is_file()
        and (root / "pyproject.toml").is_file()
    ):
        return None
    try:
        done = subprocess.run(
            ["git", "describe", "--always", "--dirty", "--abbrev=12"],
            cwd=root,
            capture_output=True,
            text=True,
            timeout=5,
        )
    except (OSError, subprocess.SubprocessError):
        return None
    return done.stdout.strip() if done.returncode == 0 and done.stdout.strip() else None


def command_line() -> str:
    return " ".join(shlex.quote(a) for a in [Path(sys.argv[0]).name] + sys.argv[1:])


def reproduce_command(
    scenario,
    controller,
    perception,
    seed,
    control_period_s,
    *,
    geometry: str = "husky",
    noise_std_m: float = 0.0,
    voltage_limit_v: float = 12.0,
    parameters=None,
):
    """The run's :class:`app.runs.Reproduction`: the ``fuzzynav run`` command with every
    option that changes the run, and what it cannot carry."""
    from fuzzynav.app.runs import reproduce

    return reproduce(
        scenario,
        controller,
        perception=perception,
        seed=seed,
        control_period_s=control_period_s,
        geometry=geometry,
        noise_std_m=noise_std_m,
        voltage_limit_v=voltage_limit_v,
        parameters=parameters,
    )


def wrap_command(command: str, width: int = 72) -> str:
    """A shell command on several lines (`` \\`` continuations, one option and its value
    a line where the line would grow past ``width``): the same command to a shell."""
    words = shlex.split(command)
    lines, current = [], ""
    k = 0
    while k < len(words):
        piece = shlex.quote(words[k])
        if words[k].startswith("--") and k + 1 < len(words) and not words[k + 1].startswith("--"):
            piece += " " + shlex.quote(words[k + 1])
            k += 1
        k += 1
        if current and len(current) + 1 + len(piece) > width:
            lines.append(current)
            current = "    " + piece
        else:
            current = f"{current} {piece}" if current else piece
    lines.append(current)
    return " \\\n".join(lines)


def _rules_text(fis, first: int = 1) -> str:
    """A rule base as its rules numbered from ``first``, then its TOML file."""
    try:
        from fuzzynav.controller.rulebase import dumps_toml

        rules = dumps_toml(fis)
    except Exception:  # a system the TOML writer refuses: list the rules instead
        rules = "\n".join(f"R{k + 1}: {fis.rule_text(k)}" for k in range(len(fis.rules)))
    numbered = "\n".join(f"# R{first + k}: {fis.rule_text(k)}" for k in range(len(fis.rules)))
    return numbered + "\n\n" + rules


def _metadata(
    static: _StaticBatch,
    *,
    scenario,
    controller,
    fis,
    parameters,
    sensor_config,
    seed,
    perception,
    control_period_s,
    voltage_limit_v,
    extra_metadata,
    geometry: str = "husky",
) -> None:
    """The run's documents: /meta/run (with the versions), /meta/scenario, /meta/rules,
    /meta/robot (with the sensors)."""
    import rerun as rr

    def doc(path, text, markdown=True):
        media = rr.MediaType.MARKDOWN if markdown else rr.MediaType.TEXT
        static.add_archetype(path, rr.TextDocument(text, media_type=media))

    doc("/meta/scenario", scenario.to_toml(), markdown=False)
    inner = getattr(controller, "inner", controller)  # the viewer wraps its controller
    blocks = getattr(inner, "rule_blocks", None)
    if fis is not None:
        doc("/meta/rules", _rules_text(fis), markdown=False)
    elif callable(blocks):  # fuzzynav: its blocks and its crisp parameters
        # Numbered on through the blocks, as the recording's rule plot numbers them.
        parts, first = [], 1
        for name, block in blocks().items():
            parts.append(f"# ===== block {name!r} =====\n{_rules_text(block, first)}")
            first += len(block.rules)
        params = getattr(inner, "params_toml", None)
        if callable(params):
            parts.append("# ===== crisp parameters =====\n" + params())
        doc("/meta/rules", "\n".join(parts), markdown=False)
    else:
        attrs = (
            {k: v for k, v in vars(controller).items() if not k.startswith("_")}
            if controller is not None and hasattr(controller, "__dict__")
            else {}
        )
        doc(
            "/meta/rules",
            f"controller {controller_label(controller)!r} is not fuzzy: no rule "
            f"base.\nparameters: {json.dumps(_json_safe(attrs), default=repr)}\n",
            markdown=False,
        )
    robot = ["# robot (HuskyParameters)"]
    robot += [f"{f.name} = {getattr(parameters, f.name)!r}" for f in dataclasses.fields(parameters)]
    robot += ["", "# sensors (SensorConfig)"]
    robot += [
        f"{f.name} = {getattr(sensor_config, f.name)!r}"
        for f in dataclasses.fields(sensor_config)
        if f.name != "mounts"
    ]
    robot += [
        f"mount {m.name}: x = {m.x_m!r} m, y = {m.y_m!r} m, angle = {m.angle_rad!r} rad"
        for m in sensor_config.mounts
    ]
    doc("/meta/robot", "\n".join(robot) + "\n", markdown=False)
    from fuzzynav.app.runs import scenario_digest

    again = reproduce_command(
        scenario,
        controller,
        perception,
        seed,
        control_period_s,
        geometry=geometry,
        noise_std_m=sensor_config.noise_std_m,
        voltage_limit_v=voltage_limit_v,
        parameters=parameters,
    )
    run = {
        "scenario": scenario.name,
        "scenario file": getattr(scenario, "source", ""),
        "scenario sha256": scenario_digest(scenario),
        "controller": controller_label(controller),
        "perception": perception,
        "geometry": geometry,
        "seed": seed,
        "sensor noise (m)": sensor_config.noise_std_m,
        "control period (s)": control_period_s,
        "voltage limit (V)": voltage_limit_v,
        "reproduce": "`" + again.command + "`",
    }
    if again.notes:
        run["reproduce needs"] = "; ".join(again.notes)
    run["command line"] = "`" + command_line() + "`"
    parts_off = tuple(getattr(inner, "parts_off", None) or ())
    if parts_off:  # fuzzynav with parts switched off (assets/rules/fuzzynav_parts.toml)
        run = {
            **dict(list(run.items())[:4]),
            "parts off": ", ".join(parts_off),
            **dict(list(run.items())[4:]),
        }
    for key, value in (extra_metadata or {}).items():
        run[str(key)] = value
    # The commands again below the table, one option a line: a table cell does not
    # wrap, and a long command was cut at the panel's edge.
    commands = {"reproduce": again.command}
    line = str(run.get("command line", "")).strip("`")
    if line:
        commands["command line"] = line
    shown = "".join(
        f"\n\n## {what}\n\n```sh\n{wrap_command(text)}\n```" for what, text in commands.items()
    )
    doc(
        "/meta/run",
        "# Run\n\n"
        + _markdown_table(run)
        + shown
        + "\n\n# Versions\n\n"
        + _markdown_table(package_versions()),
    )


def _metrics(static: _StaticBatch, metrics: dict, outcome: str) -> None:
    import rerun as rr

    rows = {"outcome": outcome, **metrics}
    text = (
        "# Metrics\n\n"
        + _markdown_table(rows)
        + "\n\n```json\n"
        + json.dumps(_json_safe(rows), indent=2, default=repr)
        + "\n```\n"
    )
    static.add_archetype("/meta/metrics", rr.TextDocument(text, media_type=rr.MediaType.MARKDOWN))


# ---------------------------------------------------------------------------------------
# The fuzzy logic at the time cursor (a controller with a ``fis``)

FUZZY_PATH = "/fuzzy"
#: Each variable's membership plot spans FUZZY_W x 1 in its view (x: its range).
FUZZY_W = 4.0
FUZZY_POINTS = 31  # samples of an aggregated output drawn per decision


def _text_array(texts):
    import pyarrow as pa

    _, arrow_type = _component_types()[("LineStrips2D", "labels")]
    return pa.array(list(texts), type=arrow_type)


def _send_fuzzy(rec, static: _StaticBatch, fis, log) -> list[str]:
    """The viewer's inference view, replayed from the recording: every input's and
    output's membership functions (static), at each decision the input's value as a
    vertical line on its terms (labelled with the value), and each output's aggregated
    membership with its centroid (the controller's output then, labelled). Returns the
    variables drawn (``inputs/d_t``, ``outputs/left``, ...)."""
    import rerun as rr

    decided = np.all(np.isfinite(log.controller_output_v), axis=1)
    rows = np.flatnonzero(decided)
    if not len(rows):
        return []
    static.add_archetype(FUZZY_PATH, rr.Transform3D(scale=[1.0, -1.0, 1.0]))  # y up
    tc = _time_column(log.time_s[rows])
    aggregated = [fis.aggregated(log.inputs[r]) for r in rows]
    drawn = []
    variables = [("inputs", k, v) for k, v in enumerate(fis.inputs)]
    variables += [("outputs", k, v) for k, v in enumerate(fis.outputs)]
    for kind, k, var in variables:
        lo, hi = (float(v) for v in var.range)
        unit = getattr(var, "unit", "") or ""
        base = f"{FUZZY_PATH}/{kind}/{var.name}"

        def sx(value, lo=lo, hi=hi):
            return FUZZY_W * (np.asarray(value, dtype=float) - lo) / (hi - lo)

        x = np.linspace(lo, hi, 401)
        curves = [np.asarray(t(x), float) for t in var.terms]
        colours = [SERIES_PALETTE[j % len(SERIES_PALETTE)] for j in range(len(var.terms))]
        static.add_archetype(
            f"{base}/terms",
            rr.LineStrips2D(
                strips=[np.column_stack([sx(x), y]) for y in curves],
                colors=colours,
                radii=0.012,
                labels=[t.name for t in var.terms],
                show_labels=False,  # (a strip's label sits mid-range: at the peaks instead)
            ),
        )
        # each term's name above its peak (the middle of a plateau)
        peaks = []
        for y in curves:
            top = np.flatnonzero(y >= y.max() - 1e-9)
            peaks.append((float(sx(x[top[len(top) // 2]])), 1.0))
        static.add_archetype(
            f"{base}/term_names",
            rr.Points2D(
                positions=peaks,
                radii=0.001,
                colors=colours,
                labels=[t.name for t in var.terms],
            ),
        )
        static.add_archetype(
            f"{base}/axis",
            rr.Points2D(
                positions=[(0.0, -0.12), (FUZZY_W, -0.12), (0.5 * FUZZY_W, 1.32)],
                radii=0.001,
                colors=[(90, 90, 90)] * 3,
                labels=[f"{lo:.3g} {unit}", f"{hi:.3g} {unit}", f"{kind[:-1]} {var.name} ({unit})"],
            ),
        )
        static.add_archetype(
            f"{base}/frame",
            rr.LineStrips2D(
                strips=[[(0, 0), (FUZZY_W, 0)], [(0, 0), (0, 1)]],
                colors=[(150, 150, 150)] * 2,
                radii=0.005,
            ),
        )
        if kind == "inputs":
            value = log.inputs[rows, k]
            text = [f"{var.name} = {v:.3g} {unit}" for v in value if np.isfinite(v)]
        else:
            value = np.array([a.output[k] for a in aggregated])
            method = getattr(getattr(fis, "inference", None), "defuzz_method", "centroid")
            text = [f"{var.name} = {v:.2f} {unit} ({method})" for v in value]
            grid = aggregated[0].grid[k]
            take = np.linspace(0, len(grid) - 1, FUZZY_POINTS).round().astype(int)
            heights = np.array([a.membership[k] for a in aggregated])[:, take]
            xs = np.broadcast_to(sx(grid[take]), heights.shape)
            shape = np.stack([xs, heights], axis=-1)
            static.add(f"{base}/aggregated", "LineStrips2D", colors=(230, 160, 40), radii=0.02)
            rec.send_columns(
                f"{base}/aggregated",
                indexes=[tc],
                columns=[_column("LineStrips2D", "strips", _strips_array(shape))],
                strict=True,
            )
        seen = np.isfinite(value)
        at = np.clip(sx(value[seen]), 0.0, FUZZY_W)
        marker = np.stack(
            [
                np.column_stack([at, np.zeros_like(at)]),
                np.column_stack([at, np.full_like(at, 1.08)]),
            ],
            axis=1,
        )
        static.add(f"{base}/value", "LineStrips2D", colors=(20, 20, 20), radii=0.018)
        rec.send_columns(
            f"{base}/value",
            indexes=[tc],
            columns=[
                _column("LineStrips2D", "strips", _strips_array(marker), seen.astype(np.int32)),
                _column("LineStrips2D", "labels", _text_array(text), seen.astype(np.int32)),
            ],
            strict=True,
        )
        drawn.append(f"{kind}/{var.name}")
    return drawn


# ---------------------------------------------------------------------------------------
# Events: closest approaches, the disturbance window, the end (issue 28)

EVENTS_LOG_PATH = "/events/log"  # TextLog at each event's time
EVENTS_LANES = "/events/lanes"  # StateChange lanes: closest, disturbance, outcome
EVENTS_WORLD = "/world/events"  # static: where the robot was at each event


@dataclasses.dataclass(frozen=True)
class Event:
    """One event of a run: its time (s), what ("closest", "disturbance on/off",
    "reached", "collided", "timeout"), the obstacle (closest only) and its text."""

    time_s: float
    kind: str
    text: str
    obstacle: int | None = None
    distance_m: float | None = None


def run_events(result) -> list[Event]:
    """The run's events in time order: each obstacle's closest approach (centre to
    centre, as the paper's section 4 gives them, with the footprint clearance then),
    the disturbance window's start and end, and the outcome at the run's end."""
    log = result.log
    events: list[Event] = []
    if not len(log):
        return events
    t = log.time_s
    for col, oid in enumerate(log.obstacle_ids):
        d = np.where(
            np.isfinite(log.center_distance_m[:, col]), log.center_distance_m[:, col], np.inf
        )
        k = int(np.argmin(d))
        if not math.isfinite(d[k]):
            continue
        clearance = float(log.clearance_m[k, col])
        surface = (
            ""
            if getattr(result, "geometry", "husky") == "paper"
            else (f", footprint clearance {clearance:.2f} m")
        )
        events.append(
            Event(
                float(t[k]),
                "closest",
                f"closest to obstacle {oid}: {d[k]:.2f} m centre to centre{surface}",
                oid,
                float(d[k]),
            )
        )
    window = getattr(result.scenario, "disturbance", None)
    if window is not None:
        for when, what in ((window.start_s, "on"), (window.stop_s, "off")):
            if t[0] <= when <= t[-1]:
                events.append(
                    Event(
                        float(when),
                        f"disturbance {what}",
                        f"disturbance {what} ({window.amplitude:g} sin({window.angular_frequency_rad_s:g} t) "
                        f"on the inputs from {window.start_s:g} s to {window.stop_s:g} s)",
                    )
                )
    outcome = getattr(result, "outcome", None) or "running"
    end = float(t[-1])
    m = result.metrics or {}
    if outcome == "reached":
        text = f"reached the target at {m.get('time_to_target_s', end):.2f} s"
    elif outcome == "collided":
        text = f"collided at {end:.2f} s"
    else:
        text = f"{outcome} at {end:.2f} s"
    events.append(Event(end, outcome, text))
    return sorted(events, key=lambda e: e.time_s)


def _send_events(rec, static: _StaticBatch, result) -> list[Event]:
    """The events as a text log and state lanes on the timeline, and, in the world,
    a marker where the robot was at each closest approach and each moving obstacle
    drawn where it was then, with its whole track."""
    import rerun as rr

    events = run_events(result)
    if not events:
        return events
    log = result.log
    times = np.array([e.time_s for e in events])
    rec.send_columns(
        EVENTS_LOG_PATH,
        indexes=[_time_column(times)],
        columns=rr.TextLog.columns(
            text=[f"{e.time_s:7.2f} s  {e.text}" for e in events],
            level=["WARN" if e.kind in ("collided", "timeout") else "INFO" for e in events],
        ),
        strict=True,
    )
    t0 = float(log.time_s[0])
    lanes = {
        "closest approach": [(t0, "-")]
        + [
            (e.time_s, f"obstacle {e.obstacle}: {e.distance_m:.2f} m")
            for e in events
            if e.kind == "closest"
        ],
        # (the end is an instant: the lane says from the start how the run ends)
        "outcome": [(t0, f"driving, then {events[-1].text}")],
    }
    if any(e.kind.startswith("disturbance") for e in events):
        lanes["disturbance"] = [(t0, "off")] + [
            (e.time_s, "on" if e.kind.endswith("on") else "off")
            for e in events
            if e.kind.startswith("disturbance")
        ]
    for lane, changes in lanes.items():
        changes = sorted(changes, key=lambda c: c[0])
        rec.send_columns(
            f"{EVENTS_LANES}/{lane.replace(' ', '_')}",
            indexes=[_time_column(np.array([c[0] for c in changes]))],
            columns=rr.StateChange.columns(state=[c[1] for c in changes]),
            strict=True,
        )
    # where the robot and the obstacle were at each closest approach
    closest = [e for e in events if e.kind == "closest"]
    if closest:
        rows = [int(np.searchsorted(log.time_s, e.time_s)) for e in closest]
        static.add_archetype(
            f"{EVENTS_WORLD}/closest",
            rr.Points2D(
                positions=[log.pose[k, :2] for k in rows],
                radii=0.07,
                colors=[EVENT] * len(rows),
                labels=[f"{e.distance_m:.2f} m at {e.time_s:.1f} s" for e in closest],
                draw_order=float(HEADING_ORDER + 1),
            ),
        )
        for e, k in zip(closest, rows):
            col = list(log.obstacle_ids).index(e.obstacle)
            xy = log.obstacle_xy[:, col]
            present = np.all(np.isfinite(xy), axis=1)
            if not present.any() or np.ptp(xy[present], axis=0).max() <= 1e-9:
                continue  # a static obstacle is drawn where it is
            color = OBSTACLE_PALETTE[col % len(OBSTACLE_PALETTE)]
            radius = float(log.obstacle_radii_m[col])
            static.add_archetype(
                f"{EVENTS_WORLD}/moving_{e.obstacle}/track",
                rr.LineStrips2D(
                    strips=[xy[present]],
                    colors=[(*color, 140)],
                    radii=0.012,
                    draw_order=float(OBSTACLE_ORDER - 1),
                ),
            )
            static.add_archetype(
                f"{EVENTS_WORLD}/moving_{e.obstacle}/at_closest",
                rr.LineStrips2D(
                    strips=[_circle(radius) + xy[k]],
                    colors=[color],
                    radii=0.015,
                    labels=[f"obstacle {e.obstacle} at {e.time_s:.1f} s"],
                    draw_order=float(OBSTACLE_ORDER),
                ),
            )
    return events


def _summary(static: _StaticBatch, result, controller, events) -> None:
    """/meta/summary: the outcome, Table 4's metrics beside the paper's published values
    (s1-s3, the paper and baseline controllers), and the events."""
    import rerun as rr

    from fuzzynav.world.metrics import TABLE4_ROWS

    m = result.metrics or {}
    name = controller_label(controller)
    stem = scenario_stem(result.scenario)
    lines = [
        f"# {result.scenario.name}",
        "",
        f"**{getattr(result, 'outcome', 'running')}** — {name} controller, "
        f"{result.perception} perception, {getattr(result, 'geometry', 'husky')} geometry, "
        f"seed {result.seed}",
        "",
    ]
    published = None
    try:
        from fuzzynav.app.published import published_table4

        published = published_table4(name, stem)
    except Exception:  # the paper's numbers are optional here
        published = None
    head = "| metric | this run | paper | difference |" if published else "| metric | this run |"
    lines += [head, "|---|---|---|---|" if published else "|---|---|"]
    for key in (*TABLE4_ROWS, "time_to_target_s", "min_clearance_m", "voltage_jumps"):
        value = m.get(key)
        ours = (
            "—"
            if value is None or (isinstance(value, float) and not math.isfinite(value))
            else f"{value:.4g}"
        )
        if published:
            paper = published.get(key)
            if paper is None or value is None or not math.isfinite(float(value)):
                lines.append(f"| {key} | {ours} | {'—' if paper is None else f'{paper:.4g}'} | — |")
            else:
                diff = 100.0 * (float(value) - paper) / paper if paper else float("nan")
                lines.append(f"| {key} | {ours} | {paper:.4g} | {diff:+.1f} % |")
        else:
            lines.append(f"| {key} | {ours} |")
    if not published:
        lines += [
            "",
            "(The paper publishes Table 4 for s1-s3 and its own controller and ref. [19].)",
        ]
    paper_events = {}
    if name == "paper" and stem in ("s1", "s2", "s3"):
        try:
            from fuzzynav.app.experiments.paper_fit import paper_results

            for ev in paper_results().get("events", {}).get(stem, []):
                paper_events[int(ev["obstacle"])] = ev
        except Exception:
            paper_events = {}
    lines += ["", "## Events", ""]
    for e in events:
        extra = ""
        ev = paper_events.get(e.obstacle) if e.kind == "closest" else None
        if ev:
            when = f"{ev['time_s']:g} s, " if ev.get("time_s") is not None else ""
            extra = (
                f" (paper: {when}{ev['distance_m']:g} m)"
                if ev.get("distance_m") is not None
                else ""
            )
        lines.append(f"- {e.time_s:.2f} s: {e.text}{extra}")
    static.add_archetype(
        "/meta/summary", rr.TextDocument("\n".join(lines) + "\n", media_type=rr.MediaType.MARKDOWN)
    )


def scenario_stem(scenario) -> str:
    """A scenario's short name: its file's stem (s1) or its name."""
    source = getattr(scenario, "source", "") or ""
    return Path(source).stem if source and source != "<memory>" else scenario.name


def _world_bounds(scenario, log=None) -> tuple[list[float], list[float]]:
    """The world view's bounds: the robot's whole path (or, before it has one, the
    start), the target, and the obstacles near them, with a 1 m margin. A moving
    obstacle counts only where it comes within 2 m of that area, so a long run's view
    is the robot's, not the path of an obstacle that left for the horizon."""
    xs = [scenario.start[0], scenario.target[0]]
    ys = [scenario.start[1], scenario.target[1]]
    if log is not None and len(log):
        xy = log.pose[:, :2]
        xy = xy[np.all(np.isfinite(xy), axis=1)]
        if len(xy):
            xs += [float(xy[:, 0].min()), float(xy[:, 0].max())]
            ys += [float(xy[:, 1].min()), float(xy[:, 1].max())]
    near = 2.0
    lo_x, hi_x, lo_y, hi_y = min(xs) - near, max(xs) + near, min(ys) - near, max(ys) + near

    def keep(points, radii):
        for (x, y), r in zip(points, radii):
            if lo_x <= x <= hi_x and lo_y <= y <= hi_y:
                xs.extend((x - r, x + r))
                ys.extend((y - r, y + r))

    keep([o.position for o in scenario.obstacles], [o.radius_m for o in scenario.obstacles])
    if log is not None and len(log) and log.obstacle_xy.size:
        radii = np.repeat(log.obstacle_radii_m[None, :], len(log), axis=0).reshape(-1)
        points = log.obstacle_xy.reshape(-1, 2)
        finite = np.all(np.isfinite(points), axis=1)
        inside = (
            finite
            & (points[:, 0] >= lo_x)
            & (points[:, 0] <= hi_x)
            & (points[:, 1] >= lo_y)
            & (points[:, 1] <= hi_y)
        )
        if inside.any():
            p, r = points[inside], radii[inside]
            xs += [float((p[:, 0] - r).min()), float((p[:, 0] + r).max())]
            ys += [float((p[:, 1] - r).min()), float((p[:, 1] + r).max())]
    margin = 1.0
    return [min(xs) - margin, max(xs) + margin], [min(ys) - margin, max(ys) + margin]


#: The plot area of a stacked panel at 1600 x 1000 (px) and a legend entry's height: a
#: legend of k entries covers about (k * LEGEND_ENTRY_PX + 12) / PLOT_PX of a panel.
PLOT_PX = 140.0
LEGEND_ENTRY_PX = 23.0
LEGEND_WIDTH = 0.24  # of the time axis
#: How far the value axis may be stretched to give the legend empty room (x its span).
MAX_HEADROOM = 2.6


def _legend_placement(series: np.ndarray, n_entries: int):
    """(corner, value range or None) for a plot's legend, so that it covers no data
    (rerun draws the legend over the plot): the corner whose legend-sized box holds the
    fewest points of ``series`` (rows, k); if even that one holds some, the value axis
    is stretched away from the data on that side (by at most :data:`MAX_HEADROOM`), so
    the legend sits over empty room; else the data's range with a 5 % margin (always
    set: rerun's own range left curves that start with a gap off the panel). None
    without data."""
    import rerun.blueprint as rrb

    values = np.asarray(series, dtype=float)
    if values.ndim != 2 or not values.size:
        return None
    n = len(values)
    t = np.repeat(np.linspace(0.0, 1.0, n)[:, None], values.shape[1], axis=1).reshape(-1)
    v = values.reshape(-1)
    ok = np.isfinite(v)
    if not ok.any():
        return None
    t, v = t[ok], v[ok]
    lo, hi = float(v.min()), float(v.max())
    span = hi - lo if hi > lo else max(abs(hi), 1.0)
    pad = 0.05 * span  # rerun's own margin, about
    lo_r, hi_r = lo - pad, hi + pad
    vn = (v - lo_r) / (hi_r - lo_r)
    h = min(0.95, (n_entries * LEGEND_ENTRY_PX + 14.0) / PLOT_PX)
    w = LEGEND_WIDTH
    boxes = {
        rrb.Corner2D.LeftTop: (t < w) & (vn > 1 - h),
        rrb.Corner2D.RightTop: (t > 1 - w) & (vn > 1 - h),
        rrb.Corner2D.LeftBottom: (t < w) & (vn < h),
        rrb.Corner2D.RightBottom: (t > 1 - w) & (vn < h),
    }
    counts = {corner: int(np.count_nonzero(inside)) for corner, inside in boxes.items()}
    corner = min(counts, key=counts.get)
    if counts[corner] == 0:  # the data's own range (rerun's auto range misjudged series
        return corner, (lo_r, hi_r)  # that start with a gap, e.g. d_o before any sighting)
    # Stretch the axis so that the data under the legend's box move out of it: on the
    # box's side, the data's extreme inside the box's time span sets the room needed.
    top = corner in (rrb.Corner2D.LeftTop, rrb.Corner2D.RightTop)
    left = corner in (rrb.Corner2D.LeftTop, rrb.Corner2D.LeftBottom)
    best = None
    for c_top in (True, False):
        for c_left in (True, False):
            in_time = (t < w) if c_left else (t > 1 - w)
            if not in_time.any():
                extreme = hi_r if c_top else lo_r
            else:
                extreme = float(v[in_time].max() if c_top else v[in_time].min())
            # new range [a, b] with the legend box (h of it) beyond ``extreme``
            if c_top:
                b = lo_r + (max(extreme + pad, lo_r) - lo_r) / (1.0 - h)
                a, b = lo_r, max(b, hi_r)
            else:
                a = hi_r - (hi_r - min(extreme - pad, hi_r)) / (1.0 - h)
                a, b = min(a, lo_r), hi_r
            stretch = (b - a) / (hi_r - lo_r)
            if best is None or stretch < best[0]:
                best = (stretch, c_top, c_left, (a, b))
    stretch, top, left, value_range = best
    corner = {
        (True, True): rrb.Corner2D.LeftTop,
        (True, False): rrb.Corner2D.RightTop,
        (False, True): rrb.Corner2D.LeftBottom,
        (False, False): rrb.Corner2D.RightBottom,
    }[(top, left)]
    if stretch > MAX_HEADROOM:  # rather some overlap than flattened curves
        return min(counts, key=counts.get), (lo_r, hi_r)
    return corner, (float(value_range[0]), float(value_range[1]))


#: The panels of a recording and the paper's figure each draws (app.figures.run_figures's kinds).
PAPER_KIND = {
    "/plots/distance": "distances",
    "/plots/angles": "angles",
    "/plots/obstacle_angles": "obstacle_angles",
    "/plots/voltage": "voltages",
}


def figure_tag(scenario_label: str, path: str) -> str:
    """`` (Fig. 18)`` for s2's distance panel: the paper's number of the figure a panel
    draws (:func:`app.figures.run_figures.paper_figure_number`, one numbering everywhere), or ""."""
    from fuzzynav.app.figures.run_figures import paper_figure_number

    kind = PAPER_KIND.get(path)
    number = paper_figure_number(scenario_label, kind) if kind else None
    return f" (Fig. {number})" if number is not None else ""


def blueprint(
    scenario,
    obstacle_ids=(),
    n_rules: int = 0,
    log=None,
    internals: bool = False,
    legend_corners=None,
    fuzzy=(),
):
    """The default layout: the world on the left, the paper's plots stacked on the right
    (further tabs: plant, sensors, rules, internals, run information).

    It depends on the run only through what the recording's application id already
    fixes (:func:`application_id`: the scenario's content, the geometry and the
    controller: obstacle ids, whether rules and internals exist) and through the world's
    bounds and the legends' corners, so that two recordings opened in one viewer do not
    share, or fight over, one layout."""
    import rerun.blueprint as rrb

    x_range, y_range = _world_bounds(scenario, log)
    # The view's origin is "/", where /world's mirror applies: scene y = -world y.
    bounds = rrb.VisualBounds2D(x_range=x_range, y_range=[-y_range[1], -y_range[0]])
    everything = rrb.VisibleTimeRanges(
        timeline=TIMELINE,
        start=rrb.TimeRangeBoundary.infinite(),
        end=rrb.TimeRangeBoundary.cursor_relative(),
    )
    overrides = {"/world/robot/trail": everything}
    for oid in obstacle_ids:
        overrides[f"/world/obstacles/{oid}/path"] = everything
    world = rrb.Spatial2DView(
        origin="/",
        contents=["/world/**"],
        name="world (y up)",
        visual_bounds=bounds,
        overrides=overrides,
    )

    # Every plot shows the whole run, like the paper's figures (the viewer would
    # otherwise show a window around the time cursor): unbounded both ways, so that the
    # layout holds for any run, not only this one's time span.
    whole_run = rrb.TimeRange(
        start=rrb.TimeRangeBoundary.infinite(), end=rrb.TimeRangeBoundary.infinite()
    )
    placements = dict(legend_corners or {})
    from fuzzynav.app.figures.run_figures import numbered_scenario

    label = numbered_scenario(scenario) or ""  # the paper's numbers for s1-s3 only

    def plot(origin, name, *, contents=None, legend=True, **kw):
        # (Linking the axes to the global range would drop this view range in 0.41.)
        axis = rrb.TimeAxis(view_range=whole_run)
        placement = placements.get(origin)
        corner, value_range = None, None
        if placement is not None:
            corner, value_range = placement if isinstance(placement, tuple) else (placement, None)
        if not legend:  # the panel's name says what its series are
            kw["plot_legend"] = rrb.PlotLegend(visible=False)
            value_range = placements.get(f"{origin}#data", value_range)
        elif corner is not None:
            kw["plot_legend"] = rrb.PlotLegend(corner=corner)
        if value_range is not None:
            kw["axis_y"] = rrb.ScalarAxis(range=value_range)
        if contents is not None:
            kw["contents"] = contents
        return rrb.TimeSeriesView(
            origin=origin, name=name + figure_tag(label, origin), axis_x=axis, **kw
        )

    lanes = rrb.StateTimelineView(
        origin=EVENTS_LANES,
        name="events: closest approach (centre to centre), disturbance, outcome",
    )
    paper = rrb.Vertical(
        lanes,
        plot("/plots/distance", "distance to the target and each obstacle, centre to centre, m"),
        plot(
            "/plots/angles",
            "target angle phi_t and heading, rad",
            contents=["/plots/angles/**"],
        ),
        plot("/plots/obstacle_angles", "obstacle angles from the heading, rad"),
        # Five series: a legend would cover the start; the name says which is which.
        plot(
            "/plots/voltage",
            "wheel voltages, V: blue left, black right (pale: before the limit), grey ±12 V",
            legend=False,
        ),
        row_shares=[1.15, 1.2, 1.15, 1.15, 1.35],
        name="paper figures",
    )
    plant = rrb.Vertical(
        plot("/plots/wheels", "wheel speeds w_LW, w_RW, rad/s"),
        plot("/plots/velocity", "v_MH, m/s, and w_JH, rad/s"),
        plot("/plots/current", "motor currents i_L1, i_L2, A"),
        plot(
            "/plots/inputs/distances",
            "inputs d_t, d_o, m, as the controller saw them (d_o gap: nothing sensed)",
        ),
        plot(
            "/plots/inputs/angles",
            "inputs phi_t, phi_o, rad, as the controller saw them (phi_o gap: nothing sensed)",
        ),
        name="plant and inputs",
    )
    sensing = rrb.Vertical(
        plot("/plots/ranges", "sensor ranges, m (gap: no echo)"),
        plot("/plots/clearance", "footprint clearance, m, and the 0.25 m safe distance"),
        plot(
            "/plots/disturbance",
            "disturbance added to every input (m on d_t, d_o; rad on phi_t, phi_o)",
            legend=False,
        ),
        name="sensors and safety",
    )
    tabs = [paper, plant, sensing]
    if n_rules:
        tabs.append(
            rrb.Vertical(
                rrb.StateTimelineView(
                    origin=RULES_STRONGEST_PATH,
                    name="the strongest rule at each decision (s)",
                ),
                rrb.BarChartView(
                    origin=RULES_PATH,
                    name="rule firing strength (0-1) at the time cursor, bar k = rule Rk",
                    plot_legend=rrb.PlotLegend(visible=False),
                ),
                rrb.TensorView(
                    origin=RULES_HEATMAP_PATH,
                    name="rule firing over the run: rows R1 (top) to Rn, time across, "
                    "dark 0 to yellow 1",
                    scalar_mapping=rrb.TensorScalarMapping(colormap="viridis"),
                    view_fit="Fill",
                ),
                rrb.TextDocumentView(origin=RULES_TEXT_PATH, name="the rules"),
                row_shares=[1, 2, 2, 2],
                name="rules",
            )
        )
    if fuzzy:  # the inference at the time cursor, as the viewer's inference view
        views = [
            rrb.Spatial2DView(
                origin="/",
                contents=[f"{FUZZY_PATH}/{name}/**"],
                name=f"{name.replace('/', ' ')} at the cursor",
                visual_bounds=rrb.VisualBounds2D(
                    x_range=[-0.6, FUZZY_W + 0.6], y_range=[-1.45, 0.25]
                ),
            )
            for name in fuzzy
        ]
        tabs.append(
            rrb.Vertical(
                rrb.Grid(*views, grid_columns=2),
                rrb.BarChartView(
                    origin=RULES_PATH,
                    name="rule firing strength (0-1) at the cursor, bar k = rule Rk",
                    plot_legend=rrb.PlotLegend(visible=False),
                ),
                row_shares=[3, 1],
                name="fuzzy logic",
            )
        )
    if internals:
        tabs.append(
            plot(INTERNALS_PATH, "fuzzynav: arbitration, planner, yield, escape, doubted target")
        )
    tabs.append(
        rrb.Tabs(
            *[
                rrb.TextDocumentView(origin=f"/meta/{name}", name=name)
                for name in ("run", "metrics", "scenario", "rules", "robot")
            ],
            name="run information",
        )
    )
    # Short tab names (a long one hid "run information"); the internals' tab says whose.
    if internals:
        tabs[-2] = rrb.Vertical(tabs[-2], name="internals")
    right = rrb.Tabs(*tabs, active_tab=0)
    left = rrb.Vertical(
        world,
        rrb.Tabs(
            rrb.TextDocumentView(origin="/meta/summary", name="summary"),
            rrb.TextLogView(origin=EVENTS_LOG_PATH, name="events"),
            active_tab=0,
        ),
        row_shares=[5, 3],
    )
    return rrb.Blueprint(
        rrb.Horizontal(left, right, column_shares=[1, 1]),
        rrb.BlueprintPanel(state="collapsed"),
        rrb.SelectionPanel(state="collapsed"),
        rrb.TimePanel(timeline=TIMELINE, state="collapsed", play_state="following"),
        auto_views=False,
    )


class RecordingError(ValueError):
    """A recording that could not be written (the message says which file, why, and
    that any old file at the path is unchanged)."""


def _id_part(text: str) -> str:
    return re.sub(r"[^A-Za-z0-9_]+", "_", str(text)).strip("_")[:60] or "run"


def application_id(scenario, controller, geometry: str = "husky") -> str:
    """``fuzzynav-<scenario>-<controller>-<geometry>-<key>``: rerun keeps one layout per
    application id, so every recording whose layout can differ gets its own. The
    scenario is its file's stem (s1) or its name; ``key`` is 8 hex digits of a sha256 over
    what fixes the layout besides: the scenario's content (its obstacles and the world
    view's bounds: two ``layout.toml`` files in different folders differ here), the
    geometry, and the controller's rule count and internals (the rules tab). Two runs of
    one scenario, geometry and controller share a layout; their bounds and legend
    corners come from their runs, so they may differ a little (the later one's wins)."""
    import hashlib

    from fuzzynav.app.runs import scenario_digest

    source = getattr(scenario, "source", "") or ""
    label = Path(source).stem if source and source != "<memory>" else scenario.name
    name = controller_label(controller)
    n_rules = len(getattr(rule_system(controller), "rules", ()))
    layout = "|".join(
        (scenario_digest(scenario), geometry, name, str(n_rules), str(has_internals(controller)))
    )
    key = hashlib.sha256(layout.encode("utf-8")).hexdigest()[:8]
    # (rerun 0.41 takes letters, digits, "-" and "_" in an application id.)
    parts = (APPLICATION_ID, _id_part(label), _id_part(name), _id_part(geometry), key)
    return "-".join(parts)


def _open_stream(path, application_id: str = APPLICATION_ID, recording_name: str | None = None):
    """A recording stream saving to ``path`` (rerun's file sink)."""
    import rerun as rr

    rec = rr.RecordingStream(application_id)
    rec.save(str(path))
    if recording_name:
        rec.send_recording_name(recording_name)
    return rec


def _not_written(path: Path, reason: str) -> RecordingError:
    old = "the file there before is unchanged" if path.exists() else "nothing was written there"
    return RecordingError(f"--rrd {path}: the recording was not written ({reason}); {old}")


def write_recording_bytes(path, data: bytes) -> Path:
    """Write a finished recording: to a temporary file beside ``path``, flushed to disk,
    renamed over ``path`` only when complete (:mod:`fuzzynav.safe_files`). A full disk or an
    unwritable folder raises :class:`RecordingError` and leaves ``path`` as it was; an
    interrupt (Ctrl-C) removes the temporary file and propagates."""
    from fuzzynav.safe_files import commit, discard, is_stream_target, temporary_beside

    path = Path(path)
    if is_stream_target(path):  # never renamed over: written as it goes (issue 26)
        from fuzzynav.safe_files import write_bytes_atomically

        try:
            return write_bytes_atomically(path, data)
        except OSError as exc:
            raise _not_written(path, exc.strerror or str(exc)) from None
    try:
        tmp = temporary_beside(path)
    except OSError as exc:
        raise _not_written(path, f"cannot write in its folder: {exc.strerror or exc}") from None
    try:
        with open(tmp, "wb") as stream:
            stream.write(data)
        return commit(tmp, path)
    except OSError as exc:
        discard(tmp, path)
        raise _not_written(path, exc.strerror or str(exc)) from None
    except BaseException:
        discard(tmp, path)
        raise


# ---------------------------------------------------------------------------------------
# Public API


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
    sensor_config = _sensor_config(sensors)
    parameters = _parameters(parameters)
    fis = controller_fis(controller)
    scenario = result.scenario
    log = result.log
    import rerun as rr

    from fuzzynav.safe_files import is_stream_target

    if not is_stream_target(path):  # a pipe or a terminal is written as a stream
        check_writable_file(path)
    # Everything goes to memory first, then to disk in one piece (write_recording_bytes):
    # a full disk or a Ctrl-C can then never leave half a file, nor cost an old one.
    rec = rr.RecordingStream(
        application_id(scenario, controller, getattr(result, "geometry", "husky"))
    )
    stream = rec.binary_stream()
    rec.send_recording_name(f"{scenario.name} · {controller_label(controller)}")
    try:
        # One layout, at the end with the legends placed: the file appears whole (renamed
        # into place), so no viewer sees it loading (LiveRecorder sends one first too).
        n_rules = len(getattr(rule_system(controller), "rules", ()))
        layout = (scenario, list(log.obstacle_ids), n_rules, log)
        writer = _ColumnWriter(
            rec,
            footprint_m=(parameters.footprint_length_m, parameters.footprint_width_m),
            sensor_config=sensor_config,
            voltage_limit_v=voltage_limit_v,
            fis=fis,
            tolerance_m=scenario.tolerance_m,
            controller=controller,
            perception=result.perception,
            geometry=getattr(result, "geometry", "husky"),
        )
        writer.send(log, 0, len(log), send_static=False)
        # Every static part in one record batch: styles, the world's statics, documents.
        extra = dict(extra_metadata or {})
        if writer.fis_error:
            extra["rule firing"] = f"not recorded ({writer.fis_error})"
        if writer.replica_error:
            extra["controller internals"] = f"not recorded ({writer.replica_error})"
        _static_world(writer.static, scenario)
        _metadata(
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
        _metrics(writer.static, result.metrics, result.outcome)
        events = _send_events(rec, writer.static, result)
        _summary(writer.static, result, controller, events)
        fuzzy = (
            _send_fuzzy(rec, writer.static, fis, log)
            if fis is not None and writer.fis_error is None
            else []
        )
        writer.send_heatmap(writer.static)
        writer.static.send(rec)
        # Again, now with the legends placed where the data leave room.
        rec.send_blueprint(
            blueprint(
                *layout,
                internals=has_internals(controller),
                legend_corners=writer.legend_corners(),
                fuzzy=fuzzy,
            )
        )
    finally:
        rec.disconnect()  # flushes and ends the stream (its footer)
    return write_recording_bytes(path, stream.read(flush=False) or b"")


class LiveRecorder:
    """Append a running simulation to a recording, a chunk of steps at a time.

    ::

        recorder = LiveRecorder("run.rrd")        # or LiveRecorder(stream=rr.RecordingStream(...))
        while not sim.done:
            sim.step()
            recorder.update(sim)                  # sends the new rows every chunk_steps
        recorder.close(sim)                       # the rest, the metrics, the file's footer

    ``update`` may be called as often as one likes: rows are sent when ``chunk_steps``
    of them are waiting and ``min_interval_s`` of wall time has passed since the last
    send, or when the run has ended. A chunk costs a few tens of milliseconds whatever
    its size (one chunk per entity, ~75 entities for a fuzzy controller), so the interval
    keeps a fast-forwarded viewer from spending its time recording. The controller, sensors, robot
    parameters and voltage limit are read from the simulation. A simulation that is
    ``reset()`` starts a new log: close this recorder and open a new one
    (``update`` raises ValueError when the log has shrunk).

    Parameters
    ----------
    path : str or Path, optional
        The ``.rrd`` file; or pass ``stream``, an open ``rr.RecordingStream`` whose sinks
        the caller chose (a viewer, a gRPC server...).
    chunk_steps : int
        How many steps to collect before sending them (default 50: one second of
        simulated time at the default 20 ms period).
    min_interval_s : float
        Wall time between two sends at least (default 0.5 s; 0 for none).
    """

    def __init__(
        self,
        path=None,
        *,
        stream=None,
        chunk_steps: int = 50,
        min_interval_s: float = 0.5,
        extra_metadata: dict | None = None,
    ):
        if (path is None) == (stream is None):
            raise ValueError("LiveRecorder needs exactly one of path and stream")
        if int(chunk_steps) < 1:
            raise ValueError(f"chunk_steps = {chunk_steps!r}: must be >= 1")
        self.path = Path(path) if path is not None else None
        self._tmp: Path | None = None
        self.kept_partial: Path | None = None
        if self.path is not None:
            from fuzzynav.safe_files import temporary_beside

            check_writable_file(self.path)
            try:  # written beside the target, renamed over it by close()
                self._tmp = temporary_beside(self.path)
            except OSError as exc:
                raise _not_written(self.path, exc.strerror or str(exc)) from None
        if not (math.isfinite(min_interval_s) and min_interval_s >= 0):
            raise ValueError(f"min_interval_s = {min_interval_s!r}: must be >= 0")
        self.chunk_steps = int(chunk_steps)
        self.min_interval_s = float(min_interval_s)
        self._last_send = -math.inf
        self.extra_metadata = dict(extra_metadata or {})
        # A file's stream opens with the first update, when its application id (the
        # scenario and controller) is known.
        self._rec = stream
        self._owns_stream = stream is None
        self._writer: _ColumnWriter | None = None
        self._sim = None
        self.closed = False

    @property
    def rows_sent(self) -> int:
        return self._writer.sent if self._writer is not None else 0

    def _open(self, sim=None) -> None:
        if self._rec is None:
            app_id = (
                application_id(sim.scenario, sim.controller, sim.geometry)
                if sim
                else APPLICATION_ID
            )
            self._rec = _open_stream(self._tmp, app_id)

    def _failed(self, exc: BaseException) -> RecordingError:
        """Close the file after a failed write (a full disk) and keep what was written
        under a name that says it is partial; the error to raise."""
        from fuzzynav.safe_files import discard

        self.closed = True
        try:
            if self._rec is not None and self._owns_stream:
                self._rec.disconnect()
        except Exception:  # the stream is broken already; what matters is the file
            pass
        reason = getattr(exc, "strerror", None) or str(exc) or type(exc).__name__
        if self._tmp is None:
            return RecordingError(f"recording stream failed ({reason})")
        self.kept_partial = discard(self._tmp, self.path, keep_partial=True)
        kept = f"; what was written is in {self.kept_partial}" if self.kept_partial else ""
        return RecordingError(str(_not_written(self.path, reason)) + kept)

    def _start(self, sim) -> None:
        self._open(sim)
        params = sim.model.parameters
        self._writer = _ColumnWriter(
            self._rec,
            footprint_m=(params.footprint_length_m, params.footprint_width_m),
            sensor_config=sim.sensors.config,
            voltage_limit_v=sim.voltage_limit_v,
            fis=controller_fis(sim.controller),
            tolerance_m=sim.scenario.tolerance_m,
            controller=sim.controller,
            perception=sim.perception.mode,
            geometry=sim.geometry,
        )
        self._rec.send_recording_name(f"{sim.scenario.name} · {controller_label(sim.controller)}")
        ids = sim.arena.obstacle_arrays()[2]
        n_rules = len(getattr(rule_system(sim.controller), "rules", ()))
        self._rec.send_blueprint(
            blueprint(sim.scenario, ids, n_rules, internals=self._writer.internals)
        )
        # Sent with the first chunk's styles.
        _static_world(self._writer.static, sim.scenario)
        self._metadata(sim, self._writer.static)

    def _metadata(self, sim, static) -> None:
        extra = dict(self.extra_metadata)
        if self._writer is not None and self._writer.fis_error:
            extra["rule firing"] = f"not recorded ({self._writer.fis_error})"
        if self._writer is not None and self._writer.replica_error:
            extra["controller internals"] = f"not recorded ({self._writer.replica_error})"
        _metadata(
            static,
            scenario=sim.scenario,
            controller=sim.controller,
            fis=controller_fis(sim.controller),
            parameters=sim.model.parameters,
            sensor_config=sim.sensors.config,
            seed=sim.seed,
            perception=sim.perception.mode,
            control_period_s=sim.control_period_s,
            voltage_limit_v=sim.voltage_limit_v,
            extra_metadata=extra,
            geometry=sim.geometry,
        )

    def update(self, sim, *, force: bool = False) -> int:
        """Send the rows logged since the last chunk if ``chunk_steps`` of them wait and
        ``min_interval_s`` has passed (or the run is over, or ``force``). Returns how
        many rows were sent."""
        if self.closed:
            raise ValueError("LiveRecorder.update after close()")
        if self._sim is not None and sim is not self._sim:
            raise ValueError("LiveRecorder records one simulation; open another for this one")
        try:
            return self._update(sim, force)
        except (OSError, RuntimeError) as exc:  # rerun's sink: "No space left on device"
            raise self._failed(exc) from None

    def _update(self, sim, force: bool) -> int:
        if self._writer is None:
            self._sim = sim
            self._start(sim)
        n = _log_length(sim)
        sent = self._writer.sent
        if n < sent:
            raise ValueError(
                f"the simulation's log shrank from {sent} to {n} rows (reset?): "
                f"close this recorder and open a new one"
            )
        if n == sent:
            return 0
        if not (force or sim.done):
            if n - sent < self.chunk_steps:
                return 0
            if time.monotonic() - self._last_send < self.min_interval_s:
                return 0
        self._writer.send(sim.log, sent, n)
        self._last_send = time.monotonic()
        return n - sent

    def close(self, sim=None, *, extra_metadata: dict | None = None) -> None:
        """Send what is left, the metrics and the final layout; close the file and, for
        a path, rename it into place (a failure keeps the old file at the path and the
        partial one as ``<stem>.partial.rrd``: :class:`RecordingError`)."""
        if self.closed:
            return
        sim = sim if sim is not None else self._sim
        if sim is not None and self._writer is not None and _log_length(sim) < self._writer.sent:
            sim = None  # reset since: its log and metrics belong to another run
        try:
            self._close(sim, extra_metadata)
        except (OSError, RuntimeError) as exc:
            raise self._failed(exc) from None
        except BaseException:  # Ctrl-C: keep what there is, under a name that says so
            self._failed(KeyboardInterrupt("interrupted"))
            raise
        if self._tmp is not None:
            from fuzzynav.safe_files import commit

            try:
                commit(self._tmp, self.path)
            except OSError as exc:
                raise self._failed(exc) from None

    def _close(self, sim, extra_metadata) -> None:
        self._open(sim)
        try:
            if sim is not None:
                self.update(sim, force=True)
                if extra_metadata:
                    self.extra_metadata.update(extra_metadata)
                static = self._writer.static
                static.send(self._rec)  # what is pending (nothing sent yet if no rows)
                self._metadata(sim, static)
                result = sim.result() if _log_length(sim) else None  # no metrics of nothing
                if result is not None:
                    _metrics(static, result.metrics, result.outcome)
                    events = _send_events(self._rec, static, result)
                    _summary(static, result, sim.controller, events)
                self._writer.send_heatmap(static)
                static.send(self._rec)
                w = self._writer
                self._rec.send_blueprint(
                    blueprint(
                        sim.scenario,
                        w.obstacle_ids,
                        w.n_rules,
                        result.log if result is not None else None,
                        internals=w.internals,
                        legend_corners=w.legend_corners(),
                    )
                )
        finally:
            self.closed = True
            self._rec.flush()
            if self._owns_stream:
                self._rec.disconnect()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()
        return False


def _log_length(sim) -> int:
    """Rows in the simulation's log without copying it (the buffer's count if exposed)."""
    buffer = getattr(sim, "_log", None)
    n = getattr(buffer, "n", None)
    return int(n) if isinstance(n, int) else len(sim.log)


# ---------------------------------------------------------------------------------------
# Command line: fuzzynav run ... --rrd PATH


def add_run_options(parser) -> None:
    parser.add_argument(
        "--rrd",
        type=Path,
        default=None,
        metavar="PATH",
        help="write a rerun recording of the run (open it with: rerun PATH)",
    )
    from fuzzynav.app.runs import add_digest_options

    add_digest_options(parser)


def run_hook(args, sim):
    """``run --rrd PATH``: the recording is written when the run ends, whole, in place
    of any old file; after Ctrl-C the partial run goes to ``<stem>.partial.rrd`` (marked
    interrupted inside) and PATH is left as it was. First, with or without ``--rrd``,
    ``--scenario-sha256`` and ``--fis-sha256`` (a recording's reproduce command) are
    checked: a scenario or rule base other than the recorded one is refused."""
    from fuzzynav.app.runs import check_digests

    check_digests(args, sim)
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
            record_run(
                result,
                target,
                controller=sim.controller,
                sensors=sim.sensors,
                parameters=sim.model.parameters,
                voltage_limit_v=sim.voltage_limit_v,
                extra_metadata=extra,
            )
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
