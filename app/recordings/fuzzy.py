"""The fuzzy logic at the time cursor (a controller with a ``fis``): the viewer's
inference view, replayed from the recording under ``/fuzzy``: its static part once
(:func:`fuzzy_view`), the decisions a block of rows at a time (:func:`send_fuzzy_rows`)."""

from __future__ import annotations

import numpy as np

from .sending import Columns, Statics
from .style import AGGREGATED, TERM_PALETTE, VALUE

FUZZY_PATH = "/fuzzy"
#: Each variable's membership plot spans FUZZY_W x 1 in its view (x: its range).
FUZZY_W = 4.0
FUZZY_POINTS = 31  # samples of an aggregated output drawn per decision


#: Where a variable's value is written: under the middle of its axis.
VALUE_LABEL_AT = (0.5 * FUZZY_W, -0.12)
#: The least distance between two term names in a row (a name of two letters is about
#: 0.3 wide in a view of the tab, at 1600 x 1000).
TERM_NAME_GAP = 0.5
#: The two rows of term names, a label's height apart (0.12 apart, phi_t's N, Z and P
#: sat on one another).
TERM_NAME_ROWS = (1.06, 1.3)


def term_name_positions(peaks) -> list[tuple[float, float]]:
    """Where the term names go: above their peaks (x in 0..FUZZY_W), pushed apart to at
    least TERM_NAME_GAP within 0..FUZZY_W, and a name whose neighbour had to move is put
    on alternating rows."""
    xs = np.asarray(peaks, dtype=float)
    order = np.argsort(xs, kind="stable")
    placed = xs[order].copy()
    for _ in range(200):
        gaps = np.diff(placed)
        short = gaps < TERM_NAME_GAP - 1e-9
        if not short.any():
            break
        push = np.where(short, 0.5 * (TERM_NAME_GAP - gaps), 0.0)
        placed[:-1] -= push
        placed[1:] += push
        placed = np.clip(placed, 0.0, FUZZY_W)
    moved = np.abs(placed - xs[order]) > 1e-9
    rows = np.full(len(xs), TERM_NAME_ROWS[0])
    for i in range(1, len(placed)):
        if moved[i] or moved[i - 1]:
            rows[i] = TERM_NAME_ROWS[1] if rows[i - 1] == TERM_NAME_ROWS[0] else TERM_NAME_ROWS[0]
    out = [(0.0, 0.0)] * len(xs)
    for k, i in enumerate(order):
        out[i] = (float(placed[k]), float(rows[k]))
    return out


def _variables(fis):
    variables = [("inputs", k, v) for k, v in enumerate(fis.inputs)]
    return variables + [("outputs", k, v) for k, v in enumerate(fis.outputs)]


def _decided(log, start: int = 0, end: int | None = None) -> np.ndarray:
    """The rows of [start, end) with a decision (finite voltages: the last row has none)."""
    end = len(log) if end is None else end
    decided = np.all(np.isfinite(log.controller_output_v[start:end]), axis=1)
    return np.flatnonzero(decided) + start


def _scale(var):
    lo, hi = (float(v) for v in var.range)

    def sx(value):
        return FUZZY_W * (np.asarray(value, dtype=float) - lo) / (hi - lo)

    return lo, hi, sx


def fuzzy_view(static: Statics, fis, log) -> list[str]:
    """The static part of the viewer's inference view, replayed from the recording:
    every input's and output's membership functions, labels and frame, and the styles of
    the per-decision entities that :func:`send_fuzzy_rows` sends. Returns the variables
    drawn (``inputs/d_t``, ``outputs/left``, ...); none for a run without a decision."""
    import rerun as rr

    if not len(_decided(log)):
        return []
    static.add_archetype(FUZZY_PATH, rr.Transform3D(scale=[1.0, -1.0, 1.0]))  # y up
    drawn = []
    for kind, _, var in _variables(fis):
        lo, hi, sx = _scale(var)
        unit = getattr(var, "unit", "") or ""
        base = f"{FUZZY_PATH}/{kind}/{var.name}"
        x = np.linspace(lo, hi, 401)
        curves = [np.asarray(t(x), float) for t in var.terms]
        colours = [TERM_PALETTE[j % len(TERM_PALETTE)] for j in range(len(var.terms))]
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
        # each term's name above its peak (the middle of a plateau), moved apart where
        # peaks crowd (phi_t's N, Z and P read "NZP") and staggered in two rows
        peaks = []
        for y in curves:
            top = np.flatnonzero(y >= y.max() - 1e-9)
            peaks.append(float(sx(x[top[len(top) // 2]])))
        static.add_archetype(
            f"{base}/term_names",
            rr.Points2D(
                positions=term_name_positions(peaks),
                radii=0.001,
                colors=colours,
                labels=[t.name for t in var.terms],
            ),
        )
        # the range's ends, with the unit (the view's name says the variable: a name
        # over the plot sat on the term names, "input d_t (m)" on L)
        static.add_archetype(
            f"{base}/axis",
            rr.Points2D(
                positions=[(0.0, -0.12), (FUZZY_W, -0.12)],
                radii=0.001,
                colors=[(90, 90, 90)] * 2,
                labels=[f"{lo:.3g} {unit}", f"{hi:.3g} {unit}"],
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
        if kind == "outputs":
            static.add(f"{base}/aggregated", "LineStrips2D", colors=AGGREGATED, radii=0.02)
        static.add(f"{base}/value", "LineStrips2D", colors=VALUE, radii=0.018)
        # the value's text: centred under the axis, between its end labels (on the line
        # it was cut at the view's edge and crossed by the line it names)
        static.add(
            f"{base}/value_label",
            "Points2D",
            positions=[VALUE_LABEL_AT],
            colors=VALUE,
            radii=0.001,
        )
        drawn.append(f"{kind}/{var.name}")
    return drawn


def _aggregated_rows(fis, inputs: np.ndarray):
    """(grids (n_out, G), memberships (n, n_out, G), outputs (n, n_out)) of the rows'
    inputs: the fuzzy engine's batch path (the same bits as row by row, a tenth of the
    time: row by row it was most of a paper run's recording), else ``aggregated`` a row
    at a time for a system that has only that."""
    many = getattr(fis, "aggregated_many", None)
    if many is not None:
        return many(inputs)
    rows = [fis.aggregated(x) for x in inputs]
    return (
        rows[0].grid,
        np.array([a.membership for a in rows]),
        np.array([a.output for a in rows]),
    )


def send_fuzzy_rows(rec, fis, log, start: int, end: int) -> None:
    """The inference view at each decision of rows [start, end) (a block at a time: the
    aggregated outputs of a long run are never all in memory): each input's value as a
    vertical line on its terms (labelled with the value), and each output's aggregated
    membership with its centroid (the controller's output then, labelled)."""
    rows = _decided(log, start, end)
    if not len(rows):
        return
    # every entity's columns on the decided rows, sent an entity at a time
    batch = Columns(log.time_s[rows], rows)
    grids, memberships, outputs = _aggregated_rows(fis, log.inputs[rows])
    for kind, k, var in _variables(fis):
        _, _, sx = _scale(var)
        unit = getattr(var, "unit", "") or ""
        base = f"{FUZZY_PATH}/{kind}/{var.name}"
        if kind == "inputs":
            value = log.inputs[rows, k]
            # Python floats, filtered by numpy: a numpy scalar a label was 5x slower
            finite = value[np.isfinite(value)].tolist()
            text = [f"{var.name} = {v:.3g} {unit}" for v in finite]
        else:
            value = outputs[:, k]
            method = getattr(getattr(fis, "inference", None), "defuzz_method", "centroid")
            text = [f"{var.name} = {v:.2f} {unit} ({method})" for v in value.tolist()]
            grid = grids[k]
            take = np.linspace(0, len(grid) - 1, FUZZY_POINTS).round().astype(int)
            heights = memberships[:, k, take]
            xs = np.broadcast_to(sx(grid[take]), heights.shape)
            shape = np.stack([xs, heights], axis=-1)
            batch.add(f"{base}/aggregated", "LineStrips2D", "strips", shape)
        seen = np.isfinite(value)
        at = np.clip(sx(value[seen]), 0.0, FUZZY_W)
        marker = np.stack(
            [
                np.column_stack([at, np.zeros_like(at)]),
                np.column_stack([at, np.full_like(at, 1.08)]),
            ],
            axis=1,
        )
        lengths = seen.astype(np.int32)
        batch.add(f"{base}/value", "LineStrips2D", "strips", marker, lengths)
        batch.add(f"{base}/value_label", "Points2D", "labels", text, lengths)
    batch.send(rec)
