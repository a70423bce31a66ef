"""Rerun's components as Arrow arrays, built straight from numpy, and the batches that
send them.

A recording sends whole columns on the timeline :data:`TIMELINE`, never one call per
step: :class:`RowBatch` holds the columns of many entities that share one time column
and sends them as one Arrow record batch (one chunk per entity, as ``send_columns``
would make); :class:`StaticBatch` does the same for static components (styles,
documents). The component descriptors and Arrow types are read once from the SDK
(:func:`component_types`), so that the batches carry exactly what ``rr.log`` would.

``rerun`` and ``pyarrow`` are imported inside the functions: the command line imports
the recordings for their options on every call.
"""

from __future__ import annotations

import functools

import numpy as np

from .style import rgba

TIMELINE = "sim_time"
#: The second timeline: the log's row, the control step (row N of the ``--trace`` CSV,
#: the first row after its header being 0), to jump to a row of the trace.
STEP_TIMELINE = "step"


def time_indexes(time_s: np.ndarray, steps) -> list:
    """The ``send_columns`` indexes of rows at ``time_s`` (s), the log's rows ``steps``."""
    import rerun as rr

    nanos = np.round(np.asarray(time_s, dtype=float) * 1e9).astype(np.int64)
    return [
        rr.TimeColumn(TIMELINE, duration=nanos.astype("timedelta64[ns]")),
        rr.TimeColumn(STEP_TIMELINE, sequence=np.asarray(steps, dtype=np.int64)),
    ]


def steps_at(log_time_s: np.ndarray, time_s) -> np.ndarray:
    """The log's row at each of ``time_s`` (the last at or before it)."""
    rows = np.searchsorted(log_time_s, np.asarray(time_s, dtype=float) + 1e-9, side="right") - 1
    return np.clip(rows, 0, max(len(log_time_s) - 1, 0)).astype(np.int64)


@functools.cache
def component_types() -> dict:
    """(archetype, field) -> (descriptor, arrow type), read once from the SDK itself, so
    that the record batches below carry exactly the metadata ``rr.log`` would."""
    import rerun as rr

    samples = (
        rr.SeriesLines(names="x", colors=[(0, 0, 0)], widths=1.0),
        rr.SeriesPoints(names="x", colors=[(0, 0, 0)], markers="circle", marker_sizes=1.0),
        rr.Scalars(scalars=[0.0]),
        rr.Points2D(positions=[(0, 0)], radii=1.0, colors=[(0, 0, 0)], labels="x", draw_order=1.0),
        rr.LineStrips2D(
            strips=[[(0, 0), (1, 1)]], radii=1.0, colors=[(0, 0, 0)], labels="x", draw_order=1.0
        ),
        rr.Arrows2D(
            vectors=[(1, 0)], origins=[(0, 0)], radii=0.1, colors=[(0, 0, 0)], draw_order=1.0
        ),
        rr.Transform3D(translation=[0.0, 0.0, 0.0]),
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


def vec2_array(archetype: str, name: str, xy):
    """2D vectors (positions, origins, vectors) as the component's Arrow array."""
    import pyarrow as pa

    _, arrow_type = component_types()[(archetype, name)]
    flat = pa.array(np.ascontiguousarray(xy, dtype=np.float32).reshape(-1))
    return pa.FixedSizeListArray.from_arrays(flat, type=arrow_type)


def vec3_array(xy):
    """2D points as Transform3D translations (x, y, 0), the component's Arrow array."""
    import pyarrow as pa

    _, arrow_type = component_types()[("Transform3D", "translation")]
    xyz = np.zeros((len(xy), 3), dtype=np.float32)
    xyz[:, :2] = xy
    return pa.FixedSizeListArray.from_arrays(pa.array(xyz.reshape(-1)), type=arrow_type)


def strips_array(strips: np.ndarray):
    """Line strips from an (n, k, 2) array (strip i has k points) as the LineStrip2D
    Arrow array, straight from numpy (the SDK's converter loops over strips in Python)."""
    import pyarrow as pa

    _, arrow_type = component_types()[("LineStrips2D", "strips")]
    n, k = strips.shape[0], strips.shape[1]
    flat = pa.array(np.ascontiguousarray(strips, dtype=np.float32).reshape(-1))
    points = pa.FixedSizeListArray.from_arrays(flat, type=arrow_type.value_type)
    offsets = pa.array(np.arange(0, n * k + 1, k, dtype=np.int32))
    return pa.ListArray.from_arrays(offsets, points, type=arrow_type)


def tensor_rows(values: np.ndarray):
    """Rows of float32 vectors (n, k) as the TensorData Arrow array of a BarChart's
    ``values`` (one tensor of shape [k] per row), built straight from numpy: the SDK's
    converter takes a 2D array for one tensor."""
    import pyarrow as pa

    _, arrow_type = component_types()[("BarChart", "values")]
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


def column(archetype: str, name: str, array, lengths=None):
    """A ready Arrow array as a ``send_columns`` column: one instance per row unless
    ``lengths`` says how many each row holds."""
    import rerun as rr

    descriptor, _ = component_types()[(archetype, name)]
    return rr.ComponentColumn(descriptor, _ArrowBatch(descriptor, array), lengths=lengths)


@functools.cache
def component_field(entity: str, archetype: str, name: str):
    import pyarrow as pa

    descriptor, arrow_type = component_types()[(archetype, name)]
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


class StaticBatch:
    """Static components of many entities, sent as one record batch (one chunk each)."""

    def __init__(self):
        self.fields: list = []
        self.arrays: list = []

    def add(self, entity: str, archetype: str, **components) -> None:
        import pyarrow as pa

        for name, value in components.items():
            values = value if isinstance(value, list) else [value]  # a list: instances
            if name in ("colors", "color"):
                values = [rgba(v) for v in values]
            field, arrow_type = component_field(entity, archetype, name)
            self.fields.append(field)
            self.arrays.append(pa.array([values], type=field.type))

    def add_array(self, entity: str, archetype: str, name: str, instances) -> None:
        """One component given as its Arrow array of instances."""
        import pyarrow as pa

        field, _ = component_field(entity, archetype, name)
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


class RowBatch:
    """Whole columns of many entities that share one time column (one row per step),
    sent as a single Arrow record batch: ``Chunk.from_record_batch`` makes one chunk per
    entity, the chunks ``send_columns`` would make, for one call instead of one per
    entity (about 0.3 ms each, which adds up over ~70 series and every live chunk)."""

    def __init__(self, time_s: np.ndarray, steps):
        import pyarrow as pa

        nanos = np.round(np.asarray(time_s, dtype=float) * 1e9).astype(np.int64)
        self.n = len(nanos)
        self.fields = [pa.field(TIMELINE, pa.duration("ns")), pa.field(STEP_TIMELINE, pa.int64())]
        self.arrays = [
            pa.array(nanos.astype("timedelta64[ns]"), type=pa.duration("ns")),
            pa.array(np.asarray(steps, dtype=np.int64), type=pa.int64()),
        ]
        self.unit_offsets = pa.array(np.arange(self.n + 1, dtype=np.int32))

    def add(
        self, entity: str, archetype: str, name: str, instances, lengths=None, absent=None
    ) -> None:
        """``instances``: the component's Arrow array; one per row, or ``lengths[i]``
        of them in row i. Rows where ``absent`` is true hold no value at all (null: the
        viewer shows the latest row before), not an empty list (which clears it)."""
        import pyarrow as pa

        field, _ = component_field(entity, archetype, name)
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

        if len(self.fields) > 2:
            batch = pa.RecordBatch.from_arrays(self.arrays, schema=pa.schema(self.fields))
            rec.send_record_batch(batch, index=[TIMELINE, STEP_TIMELINE])


def text_array(texts):
    import pyarrow as pa

    _, arrow_type = component_types()[("LineStrips2D", "labels")]
    return pa.array(list(texts), type=arrow_type)
