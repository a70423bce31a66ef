"""The fuzzy logic at the time cursor (a controller with a ``fis``): the viewer's
inference view, replayed from the recording under ``/fuzzy``."""

from __future__ import annotations

import numpy as np

from .arrow import StaticBatch, column, strips_array, text_array, time_column
from .style import SERIES_PALETTE

FUZZY_PATH = "/fuzzy"
#: Each variable's membership plot spans FUZZY_W x 1 in its view (x: its range).
FUZZY_W = 4.0
FUZZY_POINTS = 31  # samples of an aggregated output drawn per decision


def send_fuzzy(rec, static: StaticBatch, fis, log) -> list[str]:
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
    tc = time_column(log.time_s[rows])
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
                columns=[column("LineStrips2D", "strips", strips_array(shape))],
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
                column("LineStrips2D", "strips", strips_array(marker), seen.astype(np.int32)),
                column("LineStrips2D", "labels", text_array(text), seen.astype(np.int32)),
            ],
            strict=True,
        )
        drawn.append(f"{kind}/{var.name}")
    return drawn
