"""What a controller did inside, in a recording: which controller it is, its fuzzy
system, the firing of its rules (a bar chart per decision, a heatmap of the run, the
rules in words) and fuzzynav's inner state (from the decisions it logged while it drove,
or replayed through a copy): the entities' paths, what a controller offers (its
``fis``, its logged ``decisions``), the heatmap's binning and drawing. The column writer
(:class:`~fuzzynav.app.recordings.columns.ColumnWriter`) sends them with a run's rows.
"""

from __future__ import annotations

import copy

import numpy as np

from .sending import Statics


def controller_fis(controller, *, merged: bool = False):
    """The controller's ``FuzzySystem`` (its ``fis`` attribute), or None. With ``merged``
    (the membership figures), a controller of fuzzy blocks (fuzzynav, the baseline: its
    ``rule_blocks``) without a ``fis`` gives its blocks merged into one (``merged``: every
    block's inputs and outputs, under names unique across them)."""
    if controller is None:
        return None
    inner = getattr(controller, "inner", controller)  # the viewer wraps its controller
    fis = getattr(inner, "fis", None)
    if fis is None and merged and callable(getattr(inner, "rule_blocks", None)):
        fis = getattr(inner, "merged", None)
    return fis if hasattr(fis, "firing_strengths") else None


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
#: The state's numbers plotted at INTERNALS_PATH (its first two); its flags (the rest)
#: are lanes of their own (:data:`INTERNAL_FLAGS`): on one axis with the weights, the
#: 0/1 flags hid one another.
INTERNAL_WEIGHTS = INTERNALS[:2]
INTERNAL_FLAGS_PATH = "/internals/flags"
#: Each flag's lane (under INTERNAL_FLAGS_PATH) and its states by value.
INTERNAL_FLAGS = {
    "yield_or_pass": {1.0: "yield", -1.0: "pass first", 0.0: "-"},
    "edge": {1.0: "following an edge", 0.0: "-"},
    "target_doubted": {1.0: "target reading doubted", 0.0: "-"},
}


#: The flags' states' colours in their lanes ("-": the flag is down).
FLAG_COLORS = {
    "-": (215, 215, 215),
    "yield": (230, 160, 40),
    "pass first": (70, 130, 200),
    "following an edge": (150, 110, 200),
    "target reading doubted": (220, 80, 60),
}


def controller_label(controller, unknown: str | None = "unknown") -> str | None:
    """The controller's name (its ``name``, else its class's); ``unknown`` for None."""
    if controller is None:
        return unknown
    name = getattr(controller, "name", None)
    if isinstance(name, str) and name:
        return name
    return type(controller).__name__


RULES_PATH = "/rules/firing"  # BarChart per step: every rule's firing strength (float32)
RULES_HEATMAP_PATH = "/rules/heatmap"  # static Tensor, rules x time bins (max per bin)
RULES_TEXT_PATH = "/rules/texts"  # static TextDocument: R1 ... Rn in words
RULES_STRONGEST_PATH = "/rules/strongest"  # StateChange: the strongest rule where it changes
#: A static bar of height 1 at abscissa 0, in the bar chart's view: rerun's bar chart
#: fits its axis to the bars it draws (0.41 has no axis range for it), so without it
#: the axis followed the strongest rule of the moment.
RULES_SCALE_PATH = f"{RULES_PATH}/scale"
#: The heatmap drawn with its rows named (a rerun tensor view names no row): the same
#: values as a colour-mapped image, R1 ... Rn beside its rows, seconds under its columns.
HEATMAP_IMAGE_PATH = f"{RULES_HEATMAP_PATH}/image"
HEATMAP_ROWS_PATH = f"{RULES_HEATMAP_PATH}/rows"
HEATMAP_TIMES_PATH = f"{RULES_HEATMAP_PATH}/times"
#: The heatmap image is drawn this many rows wide (its columns scaled to it), so that
#: it fills its tab (a panel about as wide as high), whatever the number of bins.
HEATMAP_ASPECT = 1.0
#: Where the row names stand, left of the image (in rows).
HEATMAP_LABEL_X = -2.5
#: The most time bins of the rule heatmap (a long run is binned: the max per bin).
HEATMAP_MAX_BINS = 1500


def rule_heatmap(strengths: np.ndarray, max_bins: int) -> np.ndarray:
    """(rules, bins) float32: the firing strengths (rows, rules) binned over time, each
    bin the largest strength of its rows; one column per row if there are few."""
    strengths = np.asarray(strengths, dtype=np.float32)
    n = len(strengths)
    if n <= max_bins:
        return np.ascontiguousarray(strengths.T)
    edges = np.linspace(0, n, max_bins + 1).astype(int)
    return np.ascontiguousarray(np.maximum.reduceat(strengths, edges[:-1], axis=0).T)


#: Rule strengths a live recording's heatmap keeps in memory (float32) before it writes
#: them to an unnamed temporary file: how long a live run will be is not known while it
#: runs, and the heatmap's bins are fractions of it.
HEAT_MEMORY_BYTES = 8 * 1024**2


class RuleHeat:
    """The run's rule firing as it comes, a chunk of decisions at a time: what the
    heatmap (:func:`rule_heatmap` of all of them) and its caption need, without keeping
    every decision. When their number is known in advance (``expected``, as
    ``record_run`` knows it) and above ``max_bins``, each bin's running maximum is kept,
    which is the same float32 maximum ``rule_heatmap`` takes over the whole run (a
    maximum does not depend on the order). Otherwise (a live recording, whose length
    nobody knows yet) the decisions are kept, beyond :data:`HEAT_MEMORY_BYTES` in an
    unnamed temporary file, and binned a block at a time at the end."""

    def __init__(self, expected: int | None = None, max_bins: int | None = None):
        self.max_bins = int(HEATMAP_MAX_BINS if max_bins is None else max_bins)
        self.count = 0  # decisions seen
        self.first_s: float | None = None
        self.last_s: float | None = None
        self.last_state: int | None = None  # the strongest rule at the last decision
        self.rules = 0
        self.calls = 0
        self._parts: list[np.ndarray] = []
        self._kept_bytes = 0
        self._spool = None  # the decisions that left memory (float32 rows), in order
        self._spooled = 0
        self._bins: np.ndarray | None = None
        self._starts: np.ndarray | None = None
        self.expected = None if expected is None else int(expected)
        if self.expected is not None and self.expected > self.max_bins:
            self._starts = _bin_starts(self.expected, self.max_bins)

    def add(self, times: np.ndarray, strengths: np.ndarray) -> np.ndarray:
        """Take the decisions at ``times`` (their ``strengths``, float32, NaN for a rule
        not evaluated); returns them with NaN as 0, as the heatmap has them."""
        strengths = np.nan_to_num(np.asarray(strengths, dtype=np.float32), nan=0.0)
        self.calls += 1
        if len(times):
            self.first_s = float(times[0]) if self.first_s is None else self.first_s
            self.last_s = float(times[-1])
        m, self.rules = strengths.shape
        if self._starts is None:
            self._keep(strengths)
        elif m:
            if self.count + m > self.expected:
                raise ValueError(f"{self.count + m} decisions, {self.expected} announced")
            if self._bins is None:
                self._bins = np.full((self.max_bins, self.rules), -np.inf, np.float32)
            _bin_maxima(self._bins, self._starts, self.count, strengths)
        self.count += m
        return strengths

    def _keep(self, strengths: np.ndarray) -> None:
        self._parts.append(strengths)
        self._kept_bytes += strengths.nbytes
        if self._kept_bytes > HEAT_MEMORY_BYTES:
            if self._spool is None:
                import tempfile

                self._spool = tempfile.TemporaryFile(prefix="fuzzynav-heat-")
            for part in self._parts:
                if part.size:
                    self._spool.write(np.ascontiguousarray(part).data)
                    self._spooled += len(part)
            self._parts, self._kept_bytes = [], 0

    def heatmap(self) -> np.ndarray:
        """(rules, bins) float32, as :func:`rule_heatmap` of every decision taken."""
        if self._starts is None and self._spool is None:
            return rule_heatmap(np.concatenate(self._parts), self.max_bins)
        if self._starts is None and self.count <= self.max_bins:  # (a bin a row)
            return rule_heatmap(np.concatenate(list(self._kept_blocks())), self.max_bins)
        if self._starts is None:  # spooled: bin a block at a time
            starts = _bin_starts(self.count, self.max_bins)
            bins = np.full((self.max_bins, self.rules), -np.inf, np.float32)
            done = 0
            for rows in self._kept_blocks():
                _bin_maxima(bins, starts, done, rows)
                done += len(rows)
            return np.ascontiguousarray(bins.T)
        if self._bins is None:  # no decision came (the firing could not be evaluated)
            return np.zeros((self.rules, 0), np.float32)
        filled = self._bins
        if self.count < self.expected:  # the firing stopped being recorded mid-run
            filled = filled[: int(np.searchsorted(self._starts, self.count, side="left"))]
        return np.ascontiguousarray(filled.T)

    def _kept_blocks(self):
        """The kept decisions in order, a block at a time: the spool's, then memory's."""
        self._spool.flush()
        self._spool.seek(0)
        block = max(1, HEAT_MEMORY_BYTES // (4 * max(1, self.rules)))
        done = 0
        while done < self._spooled:
            m = min(block, self._spooled - done)
            raw = self._spool.read(m * self.rules * 4)
            yield np.frombuffer(raw, dtype=np.float32).reshape(m, self.rules)
            done += m
        yield from (part for part in self._parts if len(part))


def _bin_starts(n: int, max_bins: int) -> np.ndarray:
    """The first row of each of :func:`rule_heatmap`'s bins of ``n`` rows (n > max_bins:
    strictly increasing, every bin has rows)."""
    return np.linspace(0, n, max_bins + 1).astype(int)[:-1]


def _bin_maxima(bins: np.ndarray, starts: np.ndarray, first_row: int, rows: np.ndarray) -> None:
    """Fold ``rows`` (rows ``first_row`` on) into the running maximum of their bins."""
    index = np.arange(first_row, first_row + len(rows))
    which = np.searchsorted(starts, index, side="right") - 1
    first = np.flatnonzero(np.r_[True, which[1:] != which[:-1]])
    maxima = np.maximum.reduceat(rows, first, axis=0)
    bins[which[first]] = np.maximum(bins[which[first]], maxima)


def heatmap_row_labels(n_rules: int) -> list[int]:
    """The rules (1 to n) named beside the heatmap's rows: every one (with every fifth
    only, R9 was read as R10); the heatmap has a tab of its own, tall enough for a
    label a row (:data:`HEATMAP_PANEL_PX`, :func:`heatmap_row_px`)."""
    return list(range(1, int(n_rules) + 1))


#: The heatmap panel's size at 1600 x 1000 (px, about: its own tab, in the right half)
#: and how far below its anchor point rerun writes a label's middle (5 px, then half its
#: height): the row names are anchored this much above their rows.
HEATMAP_PANEL_PX = (780.0, 880.0)
LABEL_DROP_PX = 14.0
#: How high rerun writes a label (px): a row of the heatmap at least this high.
LABEL_HEIGHT_PX = 16.0


def heatmap_bounds(n_rules: int) -> tuple[list[float], list[float]]:
    """(x range, y range) of the heatmap's view: the image (``HEATMAP_ASPECT * n``
    wide, ``n`` high, y down), the row names on its left, the seconds under it."""
    n = max(int(n_rules), 1)
    width = HEATMAP_ASPECT * n
    return [HEATMAP_LABEL_X - 2.5, width + 1.0], [-1.0, n + 0.12 * n + 3.0]


def heatmap_row_px(n_rules: int) -> float:
    """How high a row of the heatmap is drawn (px) at :data:`HEATMAP_PANEL_PX`."""
    (x0, x1), (y0, y1) = heatmap_bounds(n_rules)
    return min(HEATMAP_PANEL_PX[0] / (x1 - x0), HEATMAP_PANEL_PX[1] / (y1 - y0))


def _label_drop(n_rules: int) -> float:
    """:data:`LABEL_DROP_PX` in the heatmap view's units (rows), at its panel's size."""
    return LABEL_DROP_PX / heatmap_row_px(n_rules)


def time_ticks(first_s: float, last_s: float, most: int = 8) -> list[float]:
    """Round seconds between ``first_s`` and ``last_s`` (at most ``most`` of them)."""
    span = max(float(last_s) - float(first_s), 0.0)
    step = next(
        (s for s in (0.1, 0.2, 0.5, 1, 2, 5, 10, 20, 30, 60, 120, 300, 600) if span / s < most),
        10 ** np.ceil(np.log10(max(span, 1.0))),
    )
    start = np.ceil(first_s / step - 1e-9) * step
    return [float(t) for t in np.arange(start, last_s + 1e-9, step)]


def send_heatmap_image(static: Statics, heatmap: np.ndarray, first_s, per_bin_s) -> None:
    """The heatmap as rerun draws an image, with its rows named: a colour-mapped depth
    image of the same values (viridis, 0 to 1) scaled to :data:`HEATMAP_ASPECT` times
    as wide as high, ``R1`` ... ``Rn`` left of its rows (:func:`heatmap_row_labels`,
    each with a tick on the image's edge) and seconds under its columns."""
    import rerun as rr

    n_rules, bins = heatmap.shape
    scale_x = HEATMAP_ASPECT * n_rules / bins
    static.add_archetype(
        HEATMAP_IMAGE_PATH,
        rr.DepthImage(
            np.ascontiguousarray(heatmap, dtype=np.float32),
            meter=1.0,
            colormap="viridis",
            depth_range=[0.0, 1.0],
        ),
    )
    static.add_archetype(HEATMAP_IMAGE_PATH, rr.Transform3D(scale=[scale_x, 1.0, 1.0]))
    rows = heatmap_row_labels(n_rules)
    drop = _label_drop(n_rules)
    grey = (90, 90, 90)
    static.add_archetype(
        HEATMAP_ROWS_PATH,
        rr.Points2D(
            positions=[(HEATMAP_LABEL_X, k - 0.5 - drop) for k in rows],
            radii=0.01,
            colors=[grey] * len(rows),
            labels=[f"R{k}" for k in rows],
            show_labels=True,
        ),
    )
    ticks = [[(-0.9, k - 0.5), (0.0, k - 0.5)] for k in rows]
    first = float(first_s or 0.0)
    last = first + per_bin_s * (bins - 1)
    times = time_ticks(first, last) if bins > 1 and per_bin_s > 0 else [first]
    xs = [
        ((t - first) / per_bin_s + 0.5) * scale_x if per_bin_s > 0 else 0.5 * scale_x for t in times
    ]
    ticks += [[(x, n_rules), (x, n_rules + 0.6)] for x in xs]
    static.add_archetype(
        f"{RULES_HEATMAP_PATH}/ticks",
        rr.LineStrips2D(ticks, radii=0.08, colors=[grey] * len(ticks)),
    )
    static.add_archetype(
        HEATMAP_TIMES_PATH,
        rr.Points2D(
            positions=[(x, n_rules + 0.6) for x in xs],
            radii=0.01,
            colors=[grey] * len(xs),
            labels=[f"{t + 0.0:g} s" for t in times],
            show_labels=True,
        ),
    )


def bar_chart_rows(values: np.ndarray):
    """Rows of float32 bars (n, k) as a ``send_columns`` column of BarChart values, one
    bar chart a row. rerun 0.41's converters make one tensor of a 2D array and refuse a
    batch of tensors ("Tensors do not support batches"), and ``rr.log`` a row at a time
    took 1.5 ms a row: so the column's Arrow array (TensorData: shape [k], the values as
    F32) is made here from numpy, and handed to the SDK's own batch and descriptor."""
    import pyarrow as pa
    import rerun as rr

    values = np.ascontiguousarray(values, dtype=np.float32)
    n, k = values.shape
    sample = rr.BarChart(values=np.zeros(1, dtype=np.float32)).as_component_batches()
    [arrow_type] = [
        b.as_arrow_array().type
        for b in sample
        if b.component_descriptor().component == "BarChart:values"
    ]
    shape = pa.ListArray.from_arrays(
        pa.array(np.arange(n + 1, dtype=np.int32)),
        pa.array(np.full(n, k, dtype=np.uint64)),
        type=arrow_type.field("shape").type,
    )
    names = pa.nulls(n, arrow_type.field("names").type)
    union = arrow_type.field("buffer").type
    children = [
        pa.ListArray.from_arrays(
            pa.array(np.arange(0, n * k + 1, k, dtype=np.int32)),
            pa.array(values.reshape(-1)),
            type=child.type,
        )
        if child.name == "F32"
        else pa.array([], type=child.type)
        for child in union
    ]
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
    tensors = pa.StructArray.from_arrays([shape, names, buffer], fields=list(arrow_type))
    batch = rr.components.TensorDataBatch(tensors)
    return [rr.ComponentColumn(rr.BarChart.descriptor_values(), batch)]
