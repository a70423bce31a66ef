"""The viewer's teaching views, as pure functions from a fuzzy system to HTML and SVG.

- :func:`inference_html`: MATLAB's rule viewer for any Mamdani system at one input
  vector: each input's membership functions with the value as a vertical line and each
  term's degree; every rule as a row (antecedent terms filled up to their degree, the
  consequent clipped at the rule's strength; firing rows highlighted); the aggregated
  output set of each output with its centroid; "no rule fires: fallback" said when so.
  Rules that share no variable (fuzzynav's goal and avoidance blocks, merged into one
  system) are drawn as separate blocks, each with only its own columns.
- :func:`surface_grid` / :func:`surface_png`: the control surface, crisp outputs over
  a plane of two inputs, as a heatmap image.
- :func:`marker_style`: the operating point on the surfaces as a few bytes of CSS: the
  heatmaps are sent once, only this moves (see :mod:`app.viewer.server`).

Nothing here knows viser or the simulation; the strings are shown with viser's HTML
element (which sets them as innerHTML).
"""

from __future__ import annotations

import html
import io
import math
from dataclasses import dataclass

import numpy as np

CELL_W = 66.0  # width of one variable's column in the rule grid (SVG units)
CELL_H = 17.0  # height of one rule row
NUM_W = 46.0  # width of the rule-number column
CURVE_POINTS = 21  # samples of a membership function in a rule cell

INPUT_LINE = "#dc2626"
# The paper's four inputs each have a colour, the same in the term plots, in the rule
# grid and on the arena (where d_t, phi_t, d_o and phi_o are drawn on the robot): the
# target's pair teal, the obstacle's pair magenta.
TARGET_INPUT = "#0d9488"
OBSTACLE_INPUT = "#c026d3"
INPUT_COLOURS = {
    "d_t": TARGET_INPUT,
    "phi_t": TARGET_INPUT,
    "d_o": OBSTACLE_INPUT,
    "phi_o": OBSTACLE_INPUT,
}


def input_colour(name: str) -> str:
    return INPUT_COLOURS.get(name, INPUT_LINE)


ANTECEDENT_FILL = "#f59e0b"
CONSEQUENT_FILL = "#2563eb"
FIRING_ROW = "#fef3c7"
OUTLINE = "#94a3b8"
BOLD = " font-weight='700'"

# How the teaching views name a controller's inputs when the engine's name would
# mislead: fuzzynav's goal block is fed the planner's bearing in an input named phi_t,
# which is not the target bearing the status line calls phi_t.
UNITS = {
    "d_t": "m",
    "d_o": "m",
    "phi_t": "rad",
    "phi_o": "rad",
    "left": "m",
    "front": "m",
    "right": "m",
}


@dataclass
class Inference:
    """Everything the inference view draws, at one input vector."""

    fis: object  # FuzzySystem
    inputs: np.ndarray  # (n_inputs,)
    memberships: list  # per input: (n_terms,) degrees
    strengths: np.ndarray  # (n_rules,)
    grid: np.ndarray  # (n_outputs, n_points)
    aggregate: np.ndarray  # (n_outputs, n_points)
    centroids: np.ndarray  # (n_outputs,)
    input_labels: list
    output_labels: list

    @property
    def n_firing(self) -> int:
        """Rules with a non-zero strength (every one counts, however weak)."""
        return int(np.sum(self.strengths > 0.0))

    @property
    def fallback(self) -> list[bool]:
        """Per output: no rule gives it any membership, so the engine's fallback (the
        middle of its range) is the output."""
        return [not bool(np.any(a > 0.0)) for a in self.aggregate]


def infer(fis, x, input_labels=None, output_labels=None) -> Inference:
    """Run the engine's own teaching calls (memberships, firing strengths, aggregated)."""
    x = np.asarray(x, dtype=float).reshape(-1)[: fis.n_inputs]
    memberships = [m[0] for m in fis.memberships(np.asarray([x]))]
    strengths = np.asarray(fis.firing_strengths(np.asarray([x])))[0]
    grid, aggregate, centroids = fis.aggregated(x)
    return Inference(
        fis,
        x,
        memberships,
        strengths,
        np.asarray(grid),
        np.asarray(aggregate),
        np.asarray(centroids),
        list(input_labels or fis.input_names),
        list(output_labels or fis.output_names),
    )


def rule_blocks(fis) -> list[tuple[list[int], list[int], list[int]]]:
    """Rules grouped by the variables they share: [(rule indices, input indices,
    output indices)], in rule order. One block for an ordinary system; fuzzynav's
    merged goal + avoidance system gives two."""
    n_in = fis.n_inputs
    parent = list(range(n_in + fis.n_outputs))

    def find(a):
        while parent[a] != a:
            parent[a] = parent[parent[a]]
            a = parent[a]
        return a

    used = []
    for rule in fis.rules:
        vs = [i for i, k in enumerate(rule.antecedent) if k is not None]
        vs += [n_in + j for j, k in enumerate(rule.consequent) if k is not None]
        used.append(vs)
        for v in vs[1:]:
            parent[find(v)] = find(vs[0])
    blocks: dict[int, tuple[list, set]] = {}
    for r, vs in enumerate(used):
        root = find(vs[0])
        blocks.setdefault(root, ([], set()))
        blocks[root][0].append(r)
        blocks[root][1].update(vs)
    out = []
    for rules, vs in sorted(blocks.values(), key=lambda b: b[0][0]):
        ins = sorted(v for v in vs if v < n_in)
        outs = sorted(v - n_in for v in vs if v >= n_in)
        out.append((rules, ins, outs))
    return out


def _sample(variable, n: int = CURVE_POINTS) -> tuple[np.ndarray, list[np.ndarray]]:
    lo, hi = variable.range
    xs = np.linspace(lo, hi, n)
    # Add each term's own break points, so that triangles keep their corners.
    breaks = [p for t in variable.terms for p in t.params if lo < p < hi]
    xs = np.unique(np.concatenate([xs, np.asarray(breaks, dtype=float)]))
    return xs, [np.clip(np.asarray(t(xs), dtype=float), 0.0, 1.0) for t in variable.terms]


def _path(xs, ys, x0, y0, w, h, lo, hi, closed=False) -> str:
    """An SVG path of (xs, ys) in the box (x0, y0, w, h); y = 1 at the top."""
    px = x0 + (np.asarray(xs) - lo) / (hi - lo) * w
    py = y0 + h - np.asarray(ys) * h
    pts = " ".join(f"{a:.1f},{b:.1f}" for a, b in zip(px, py))
    if closed:
        return f"M{px[0]:.1f},{y0 + h:.1f} L{pts} L{px[-1]:.1f},{y0 + h:.1f}Z"
    return f"M{pts}"


def _simplify(xs, ys, tol: float = 1e-3):
    """The points of a polyline where its slope changes (a clipped and aggregated set
    is piecewise linear on its grid: most grid points lie on straight runs)."""
    xs, ys = np.asarray(xs, dtype=float), np.asarray(ys, dtype=float)
    if len(xs) <= 2:
        return xs, ys
    keep = np.ones(len(xs), dtype=bool)
    # the middle point of each triple is dropped when it lies on the chord of the others
    x0, x1, x2 = xs[:-2], xs[1:-1], xs[2:]
    y0, y1, y2 = ys[:-2], ys[1:-1], ys[2:]
    span = np.where(x2 - x0 == 0, 1.0, x2 - x0)
    on_chord = np.abs(y0 + (y2 - y0) * (x1 - x0) / span - y1) <= tol
    keep[1:-1] = ~on_chord
    return xs[keep], ys[keep]


def _x_of(value, lo, hi, x0, w) -> float | None:
    if not math.isfinite(value):
        return None
    return x0 + (min(max(value, lo), hi) - lo) / (hi - lo) * w


def _fmt_value(value: float, unit: str) -> str:
    if not math.isfinite(value):
        return "none sensed" if math.isnan(value) else f"{value}"
    return f"{value:.2f} {unit}".strip()


def _fmt_degree(d: float) -> str:
    """A degree readable however small: 0.55, 0.031, 0.0004 (never a bare 0.00)."""
    if d <= 0.0:
        return "0"
    if d >= 0.095:
        return f"{d:.2f}"
    return f"{d:.2g}"


INPUT_W, INPUT_H = 150.0, 46.0
PALETTE = ("#7c3aed", "#0891b2", "#16a34a", "#ea580c", "#db2777", "#475569", "#65a30d")


def defs_html(fis, uid: str, input_labels=None, output_labels=None) -> str:
    """Every term's outline, once: for the input plots and for the rule cells. Sent when
    the system changes; :func:`inference_html` refers to these (SVG ``<use>``), so that
    what it sends at every step is the few things that move.

    Also every rule as a sentence, hidden, with the CSS that shows one while the pointer
    is on its row of the rule grid (``:has``): the sentences cost nothing per step."""
    w, h = CELL_W - 4.0, CELL_H - 4.0
    defs = []
    for kind, variables in (("in", fis.inputs), ("out", fis.outputs)):
        for v, var in enumerate(variables):
            lo, hi = var.range
            xs, curves = _sample(var)
            big_xs, big_curves = _sample(var, 61)
            for k, ys in enumerate(curves):
                # t: a rule cell's outline, f: its area; T, F: the same in an input plot.
                big = big_curves[k]
                defs += [
                    f"<path id='{uid}{kind}{v}t{k}' d='{_path(xs, ys, 0, 0, w, h, lo, hi)}'/>",
                    f"<path id='{uid}{kind}{v}f{k}' d='{_path(xs, ys, 0, 0, w, h, lo, hi, True)}'/>",
                    f"<path id='{uid}{kind}{v}T{k}' "
                    f"d='{_path(big_xs, big, 0, 0, INPUT_W, INPUT_H, lo, hi)}'/>",
                    f"<path id='{uid}{kind}{v}F{k}' "
                    f"d='{_path(big_xs, big, 0, 0, INPUT_W, INPUT_H, lo, hi, True)}'/>",
                ]
    sentences = "".join(
        f"<div id='{uid}s{r + 1}' class='fz-sentence'>"
        f"{html.escape(rule_sentence(fis, r, input_labels, output_labels))}</div>"
        for r in range(len(fis.rules))
    )
    hover = "".join(
        f"body:has(.fz-hit [data-rule='{r + 1}']:hover) #{uid}s{r + 1}{{display:block}}"
        for r in range(len(fis.rules))
    )
    return (
        "<svg width='0' height='0' style='position:absolute' aria-hidden='true'>"
        f"<defs>{''.join(defs)}{rows_skeleton(fis, uid)}</defs></svg>"
        f"<style>.fz-sentence{{display:none;position:fixed;left:12px;bottom:64px;z-index:1000;"
        "max-width:380px;padding:6px 8px;border-radius:4px;background:#0f172a;color:#fff;"
        f"font:13px system-ui,sans-serif;box-shadow:0 2px 8px #0005}}{hover}</style>"
        f"<div class='fz-sentences'>{sentences}</div>"
    )


def inputs_svg(inf: Inference, indices=None, uid: str = "fz") -> str:
    """Each input's terms with the value as a red line and each term's degree."""
    fis = inf.fis
    indices = list(range(fis.n_inputs)) if indices is None else list(indices)
    w, h, gap = INPUT_W, INPUT_H, 40.0
    cols = 2
    rows = math.ceil(len(indices) / cols)
    width = cols * w + (cols - 1) * 16 + 8
    height = rows * (h + gap) + 4
    parts = [
        f"<svg viewBox='0 0 {width:.0f} {height:.0f}' style='width:100%;display:block'"
        " font-family='system-ui,sans-serif'>"
    ]
    palette = PALETTE
    for slot, i in enumerate(indices):
        var = fis.inputs[i]
        lo, hi = var.range
        x0 = 4 + (slot % cols) * (w + 16)
        y0 = 14 + (slot // cols) * (h + gap)
        value = float(inf.inputs[i])
        label = inf.input_labels[i]
        colour = input_colour(label)
        parts.append(
            f"<text x='{x0:.0f}' y='{y0 - 3:.0f}' font-size='10' font-weight='600'"
            f" fill='{colour if colour != INPUT_LINE else '#0f172a'}'>"
            f"{html.escape(label)} = {html.escape(_fmt_value(value, UNITS.get(var.name, var.unit or '')))}</text>"
        )
        parts.append(
            f"<rect x='{x0:.0f}' y='{y0:.0f}' width='{w:.0f}' height='{h:.0f}' fill='#f8fafc'"
            " stroke='#e2e8f0'/>"
        )
        degrees = inf.memberships[i]
        for k in range(len(var.terms)):
            colour = palette[k % len(palette)]
            d = float(degrees[k])
            if d > 0:
                parts.append(
                    _clipped_use(f"{uid}in{i}F{k}", f"{uid}ci{i}k{k}", x0, y0, w, h, d, colour, 0.3)
                )
            parts.append(
                f"<use href='#{uid}in{i}T{k}' x='{x0:.0f}' y='{y0:.0f}' fill='none' "
                f"stroke='{colour}' stroke-width='1.3'/>"
            )
        xline = _x_of(value, lo, hi, x0, w)
        if xline is not None:
            parts.append(
                f"<line x1='{xline:.1f}' x2='{xline:.1f}' y1='{y0:.0f}' y2='{y0 + h:.0f}' "
                f"stroke='{input_colour(label)}' stroke-width='1.8'/>"
            )
        # The terms' degrees under the plot, in the curves' colours (two lines if need be).
        tx, ty = x0, y0 + h + 11
        for k, term in enumerate(var.terms):
            d = float(degrees[k])
            colour = palette[k % len(palette)]
            text = f"{term.name} {_fmt_degree(d)}"
            if tx + 5.6 * len(text) > x0 + w:
                tx, ty = x0, ty + 10
            weight = "700" if d > 0 else "400"
            opacity = "1" if d > 0 else "0.55"
            parts.append(
                f"<text x='{tx:.0f}' y='{ty:.0f}' font-size='9' fill='{colour}' "
                f"font-weight='{weight}' opacity='{opacity}' class='fz-degree'>{html.escape(text)}</text>"
            )
            tx += 5.6 * len(text) + 6
    parts.append("</svg>")
    return "".join(parts)


def _choice(fis, field: str, default: str) -> str:
    """One of the system's inference choices (controller/inference.py, issue 27)."""
    return getattr(getattr(fis, "inference", None), field, default)


def _defuzz_word(fis) -> str:
    """The defuzzification method as the views name it: centroid, bisector, MOM..."""
    method = _choice(fis, "defuzz_method", "centroid")
    return method if method in ("centroid", "bisector") else method.upper()


def _scaled_use(ref, x0, y0, w, h, level, fill, opacity) -> str:
    """A term's area (``ref``, drawn in a w x h box at (x0, y0)) scaled by ``level``: the
    level * membership of the product implication."""
    return (
        f"<g transform='translate({x0:.1f},{y0 + h * (1.0 - level):.1f}) scale(1,{level:.4f})'>"
        f"<use href='#{ref}' fill='{fill}' fill-opacity='{opacity}' stroke='none'/></g>"
    )


def _clipped_use(ref, clip_id, x0, y0, w, h, level, fill, opacity) -> str:
    """A term's area (``ref``, drawn in a w x h box at (x0, y0)) cut at ``level``: the
    min(membership, level) of Mamdani's implication, drawn with a clip rectangle."""
    top = h * (1.0 - level)
    return (
        f"<g transform='translate({x0:.1f},{y0:.1f})'><clipPath id='{clip_id}'>"
        f"<rect x='0' y='{top:.1f}' width='{w:.1f}' height='{h - top + 0.5:.1f}'/></clipPath>"
        f"<use href='#{ref}' clip-path='url(#{clip_id})' fill='{fill}' fill-opacity='{opacity}'"
        " stroke='none'/></g>"
    )


def _rule_columns(fis, ins, outs):
    """(width, x of column c): the rule grid's geometry, shared by the header, the rows
    and the aggregated row (three SVGs that must line up)."""
    width = NUM_W + (len(ins) + len(outs)) * CELL_W + 10.0  # a gap between inputs and outputs

    def col_x(c):
        return NUM_W + c * CELL_W + (10.0 if c >= len(ins) else 0.0)

    return width, col_x


def _svg_open(width: float, height: float, cls: str) -> str:
    return (
        f"<svg viewBox='0 0 {width:.0f} {height:.0f}' style='width:100%;display:block'"
        f" font-family='system-ui,sans-serif' class='{cls}'>"
    )


def rules_head_svg(inf: Inference, ins, outs) -> str:
    """The rule grid's column headers: each variable's name and value (the centroid for
    an output). Sticky: it stays at the top of the panel while the rules scroll."""
    fis = inf.fis
    width, col_x = _rule_columns(fis, ins, outs)
    parts = [_svg_open(width, 26.0, "fz-rule-head-svg")]
    parts.append("<text x='2' y='11' font-size='8.5' fill='#475569'>rule</text>")
    for c, i in enumerate(ins):
        var = fis.inputs[i]
        value = float(inf.inputs[i])
        parts.append(
            f"<text x='{col_x(c) + 2:.0f}' y='11' font-size='9.5' font-weight='600'"
            f" class='fz-col-name'>{html.escape(inf.input_labels[i])}</text>"
            f"<text x='{col_x(c) + 2:.0f}' y='22' font-size='8.5'"
            f" fill='{input_colour(inf.input_labels[i])}'>"
            f"{html.escape(_fmt_value(value, UNITS.get(var.name, var.unit or '')))}</text>"
        )
    for c, j in enumerate(outs, start=len(ins)):
        var = fis.outputs[j]
        parts.append(
            f"<text x='{col_x(c) + 2:.0f}' y='11' font-size='9.5' font-weight='600'"
            f" class='fz-col-name'>{html.escape(inf.output_labels[j])}</text>"
            f"<text x='{col_x(c) + 2:.0f}' y='22' font-size='8.5' fill='{CONSEQUENT_FILL}'>"
            f"{inf.centroids[j]:.2f} {html.escape(var.unit or '')}</text>"
        )
    parts.append("</svg>")
    return "".join(parts)


def _row_outlines(fis, rules, ins, outs, uid: str) -> str:
    """What never changes in a rule grid: each row's number and its terms' outlines
    (references to :func:`defs_html`'s paths)."""
    _, col_x = _rule_columns(fis, ins, outs)
    parts = []
    for row, r in enumerate(rules):
        rule = fis.rules[r]
        y0 = row * CELL_H
        parts.append(
            f"<text x='2' y='{y0 + 12:.1f}' font-size='9' stroke='none' fill='#94a3b8'"
            f" class='fz-rule-no'>{r + 1}</text>"
        )
        cells = [("in", i, rule.antecedent[i]) for i in ins] + [
            ("out", j, rule.consequent[j]) for j in outs
        ]
        for c, (kind, v, k) in enumerate(cells):
            if k is not None:
                parts.append(
                    f"<use href='#{uid}{kind}{v}t{k}' x='{col_x(c) + 2:.0f}' y='{y0 + 2:.0f}'/>"
                )
    return f"<g fill='none' stroke='{OUTLINE}' stroke-width='0.8'>{''.join(parts)}</g>"


def rows_skeleton(fis, uid: str) -> str:
    """Every block's row outlines as an SVG group (``{uid}rows{b}``), for
    :func:`defs_html`: a step then sends a reference, not the 40 rows again."""
    return "".join(
        f"<g id='{uid}rows{b}'>{_row_outlines(fis, rules, ins, outs, uid)}</g>"
        for b, (rules, ins, outs) in enumerate(rule_blocks(fis))
    )


def rules_rows_svg(inf: Inference, rules, ins, outs, uid: str = "fz", skeleton=None) -> str:
    """MATLAB's rule viewer for one block: a row per rule in ``rules``, a column per
    variable. Each row has a transparent hit area (``fz-hit``, ``data-rule``): hovering
    it shows the rule as a sentence (:func:`defs_html`). ``skeleton``: the id of this
    block's row outlines in :func:`defs_html` when ``rules`` are all its rules (they
    are then referred to, not sent again)."""
    fis = inf.fis
    width, col_x = _rule_columns(fis, ins, outs)
    height = max(len(rules), 1) * CELL_H + 2.0
    parts = [_svg_open(width, height, "fz-rules")]
    if not rules:
        parts.append(
            f"<text x='4' y='{CELL_H - 4:.0f}' font-size='9' fill='#64748b'>"
            "no rule of this block fires</text></svg>"
        )
        return "".join(parts)
    pad = 2.0
    w, h = CELL_W - 2 * pad, CELL_H - 2 * pad
    fills, labels, hits = [], [], []
    for row, r in enumerate(rules):
        rule = fis.rules[r]
        s = float(inf.strengths[r])
        y0 = row * CELL_H
        hits.append(f"<rect data-rule='{r + 1}' y='{y0:.0f}'/>")
        if s <= 0.0:
            continue
        parts.append(
            f"<rect class='fz-firing' data-rule='{r + 1}' data-strength='{s:.6g}' x='0'"
            f" y='{y0:.1f}' width='{width:.0f}' height='{CELL_H:.0f}' fill='{FIRING_ROW}'/>"
        )
        labels.append(
            f"<rect x='0' y='{y0 + 1:.0f}' width='{NUM_W - 4:.0f}' height='{CELL_H - 2:.0f}'"
            f" fill='{FIRING_ROW}'/><text x='2' y='{y0 + 12:.1f}'>{r + 1}"
            f" {_fmt_degree(s)}</text>"
        )
        cells = [("in", i, rule.antecedent[i]) for i in ins] + [
            ("out", j, rule.consequent[j]) for j in outs
        ]
        for c, (kind, v, k) in enumerate(cells):
            if k is None:
                continue
            level = float(inf.memberships[v][k]) if kind == "in" else s
            if level > 0 and kind == "out" and _choice(fis, "imp_method", "min") == "prod":
                fills.append(
                    _scaled_use(
                        f"{uid}out{v}f{k}", col_x(c) + pad, y0 + pad, w, h, s, CONSEQUENT_FILL, 0.85
                    )
                )
            elif level > 0:
                fill = ANTECEDENT_FILL if kind == "in" else CONSEQUENT_FILL
                fills.append(
                    _clipped_use(
                        f"{uid}{kind}{v}f{k}",
                        f"{uid}c{r}_{c}",
                        col_x(c) + pad,
                        y0 + pad,
                        w,
                        h,
                        level,
                        fill,
                        0.85,
                    )
                )
    # Outlines over the row highlights, fills over the outlines.
    if skeleton is not None:
        parts.append(f"<use href='#{skeleton}'/>")
    else:
        parts.append(_row_outlines(fis, rules, ins, outs, uid))
    if fills:
        parts.append(
            f"<g fill-opacity='0.8' stroke='#334155' stroke-width='0.6'>{''.join(fills)}</g>"
        )
    if labels:
        parts.append(
            f"<g font-size='9' font-weight='700' fill='#0f172a' class='fz-strengths'>"
            f"{''.join(labels)}</g>"
        )
    # The input values as vertical lines through every row of their column.
    bottom = len(rules) * CELL_H
    for c, i in enumerate(ins):
        var = fis.inputs[i]
        lo, hi = var.range
        xline = _x_of(float(inf.inputs[i]), lo, hi, col_x(c) + pad, CELL_W - 2 * pad)
        if xline is not None:
            parts.append(
                f"<line class='fz-input-line' x1='{xline:.1f}' x2='{xline:.1f}' y1='0' "
                f"y2='{bottom:.0f}' stroke='{input_colour(inf.input_labels[i])}'"
                " stroke-width='1.2'/>"
            )
    # Hover areas, one per row, on top (transparent).
    parts.append(
        "<g class='fz-hit' fill='transparent' pointer-events='all' style='cursor:help'>"
        f"{''.join(hits)}</g>".replace(
            "<rect ", f"<rect width='{width:.0f}' height='{CELL_H:.0f}' "
        )
    )
    parts.append("</svg>")
    return "".join(parts)


def rules_aggregate_svg(inf: Inference, ins, outs, weights=None) -> str:
    """The aggregated output set of each output of the block, with its centroid, under
    its column. Sticky: pinned at the bottom of the panel while the rules scroll.

    ``weights``: output name -> the weight the controller gives it now (fuzzynav's
    blocks); a set that no rule reaches is a fallback worth a red word only when its
    weight is above zero."""
    fis = inf.fis
    width, col_x = _rule_columns(fis, ins, outs)
    agg_h = CELL_H * 1.6
    y0 = 4.0
    parts = [_svg_open(width, agg_h + 18.0, "fz-aggregate-svg")]
    pad = 2.0
    for c, j in enumerate(outs, start=len(ins)):
        var = fis.outputs[j]
        lo, hi = var.range
        x0, w = col_x(c) + pad, CELL_W - 2 * pad
        a = inf.aggregate[j]
        peak = float(a.max()) if len(a) else 0.0
        # A set only a few per cent high is invisible at scale 1: drawn taller, and said;
        # one above 1 (sum aggregation) is drawn lower, and its height said.
        zoom = 1.0 if 0.25 <= peak <= 1.0 or peak <= 0 else 1.0 / peak
        parts.append(
            f"<rect x='{x0:.1f}' y='{y0:.1f}' width='{w:.1f}' height='{agg_h:.1f}' fill='#eff6ff'"
            " stroke='#bfdbfe'/>"
        )
        if peak > 0:
            parts.append(
                f"<path class='fz-aggregate' d='{_path(*_simplify(inf.grid[j], np.minimum(a * zoom, 1.0)), x0, y0, w, agg_h, lo, hi, True)}'"
                f" fill='{CONSEQUENT_FILL}' fill-opacity='0.55'/>"
            )
        xc = _x_of(float(inf.centroids[j]), lo, hi, x0, w)
        if xc is not None:
            parts.append(
                f"<line class='fz-centroid' x1='{xc:.1f}' x2='{xc:.1f}' y1='{y0 - 2:.1f}' "
                f"y2='{y0 + agg_h + 2:.1f}' stroke='#0f172a' stroke-width='1.6'/>"
            )
        unused = weights is not None and weights.get(inf.output_labels[j], 1.0) <= 0.0
        note = (
            ("unused" if unused else "fallback")
            if peak <= 0
            else (f"×{zoom:.0f}" if zoom > 1 else f"peak {peak:.2f}" if zoom < 1 else "")
        )
        if note:
            red = peak <= 0 and not unused
            parts.append(
                f"<text x='{x0 + 1:.1f}' y='{y0 + agg_h + 10:.1f}' font-size='8'"
                f" fill='{'#b91c1c' if red else '#475569'}'>{note}</text>"
            )
        parts.append(
            f"<text x='{x0 + 1:.1f}' y='{y0 + agg_h + 10:.1f}' dx='{w - 2:.1f}' font-size='8'"
            f" text-anchor='end' fill='#0f172a'>{inf.centroids[j]:.2f}</text>"
        )
    parts.append(
        f"<text x='2' y='{y0 + 10:.1f}' font-size='8.5' fill='#334155'>aggregated</text>"
        f"<text x='2' y='{y0 + 21:.1f}' font-size='8.5' fill='#334155'>{_defuzz_word(fis)}</text>"
        "</svg>"
    )
    return "".join(parts)


def rules_html(
    inf: Inference,
    rules,
    ins,
    outs,
    uid: str = "fz",
    *,
    only_firing=False,
    weights=None,
    skeleton=None,
) -> str:
    """One block's rule grid: the headers stuck to the top of the panel, the rows (all,
    or the firing ones only), the aggregated sets and centroids pinned at the bottom.

    The panel itself scrolls (not a box inside this HTML, which is replaced at every
    update and would jump back to its top): a reader keeps their place while the robot
    drives."""
    shown = [r for r in rules if inf.strengths[r] > 0.0] if only_firing else list(rules)
    return (
        "<div class='fz-rule-block'>"
        "<div class='fz-rule-head' style='position:sticky;top:0;z-index:3;background:#fff;"
        "border-bottom:1px solid #cbd5e1'>"
        f"{rules_head_svg(inf, ins, outs)}</div>"
        "<div class='fz-rule-rows'>"
        f"{rules_rows_svg(inf, shown, ins, outs, uid, None if only_firing else skeleton)}</div>"
        "<div class='fz-rule-agg' style='position:sticky;bottom:0;z-index:3;background:#fff;"
        "border-top:1px solid #cbd5e1'>"
        f"{rules_aggregate_svg(inf, ins, outs, weights)}</div></div>"
    )


def rule_sentence(fis, r: int, input_labels=None, output_labels=None) -> str:
    """Rule ``r`` (0-based) as a sentence: 'Rule 12: if d_t is VL and phi_t is Z, then
    left is F and right is F.'"""
    rule = fis.rules[r]
    ins = list(input_labels or fis.input_names)
    outs = list(output_labels or fis.output_names)
    cond = " and ".join(
        f"{ins[i]} is {fis.inputs[i].terms[k].name}"
        for i, k in enumerate(rule.antecedent)
        if k is not None
    )
    then = " and ".join(
        f"{outs[j]} is {fis.outputs[j].terms[k].name}"
        for j, k in enumerate(rule.consequent)
        if k is not None
    )
    weight = f" (weight {rule.weight:g})" if rule.weight != 1.0 else ""
    return f"Rule {r + 1}: if {cond}, then {then}{weight}."


def inference_html(
    inf: Inference,
    *,
    uid: str = "fz",
    large: bool = False,
    crisp: dict | None = None,
    only_firing: bool = False,
    weights: dict | None = None,
    notes: dict | None = None,
) -> str:
    """The whole inference view: summary, inputs, rule grid(s), aggregated outputs.

    ``weights``: output label -> the weight the controller gives that output now
    (fuzzynav: the avoidance block's alpha); an output no rule reaches is a fallback to
    alarm about only when its weight is above zero. ``notes``: input label -> what it
    is, said once under the summary (fuzzynav's phi_plan). ``large`` (presentation
    mode) also lists the firing rules as sentences."""
    fs = "1.25em" if large else "0.85em"
    n, total = inf.n_firing, len(inf.strengths)
    fallback = inf.fallback

    def used(j):
        return weights is None or weights.get(inf.output_labels[j], 1.0) > 0.0

    lines = []
    if n == 0 or all(fallback):
        lines.append(
            "<div class='fz-fallback' style='padding:4px 6px;border-radius:4px;"
            "background:#fee2e2;color:#991b1b;font-weight:600'>No rule fires: fallback. "
            "Every output takes the middle of its range (the engine's and MATLAB's "
            "convention).</div>"
        )
    else:
        best = int(np.argmax(inf.strengths))
        lines.append(
            f"<div class='fz-summary'><b>{n} of {total} rules fire</b> (strength &gt; 0); "
            f"strongest: rule {best + 1} at {_fmt_degree(float(inf.strengths[best]))}.</div>"
        )
        names = [inf.output_labels[j] for j, f in enumerate(fallback) if f and used(j)]
        idle = [inf.output_labels[j] for j, f in enumerate(fallback) if f and not used(j)]
        if names:
            lines.append(
                "<div class='fz-fallback' style='color:#991b1b'>No rule concludes on "
                f"{html.escape(', '.join(names))}: fallback to the middle of its range.</div>"
            )
        if idle:
            lines.append(
                "<div class='fz-idle' style='color:#475569'>No rule concludes on "
                f"{html.escape(', '.join(idle))}: nothing calls for it, and its weight is 0 "
                "now, so it does not steer.</div>"
            )
    centroid_text = ", ".join(
        f"{html.escape(name)} = {c:.2f}" for name, c in zip(inf.output_labels, inf.centroids)
    )
    lines.append(f"<div>Outputs ({_defuzz_word(inf.fis)}): {centroid_text}</div>")
    for name, text in (notes or {}).items():
        lines.append(
            f"<div style='color:#475569'><b>{html.escape(name)}</b>: {html.escape(text)}</div>"
        )
    if large and n:
        order = [int(r) for r in np.argsort(-inf.strengths, kind="stable") if inf.strengths[r] > 0]
        items = "".join(
            f"<li><b>{_fmt_degree(float(inf.strengths[r]))}</b> "
            f"{html.escape(rule_sentence(inf.fis, r, inf.input_labels, inf.output_labels))}</li>"
            for r in order[:6]
        )
        more = f"<div>… and {len(order) - 6} more</div>" if len(order) > 6 else ""
        lines.append(
            "<div class='fz-firing-sentences' style='margin-top:4px'><b>Firing rules, "
            f"strongest first</b><ul style='margin:2px 0 0 18px;padding:0'>{items}</ul>"
            f"{more}</div>"
        )
    if crisp:
        rows = "".join(
            f"<tr><td style='white-space:nowrap;padding-right:6px'><b>{html.escape(k)}</b></td>"
            f"<td>{html.escape(v)}</td></tr>"
            for k, v in crisp.items()
        )
        lines.append(
            "<div style='font-weight:600;margin-top:4px'>Crisp parts</div>"
            f"<table style='width:100%'>{rows}</table>"
        )
    blocks = rule_blocks(inf.fis)
    for b, (rules, ins, outs) in enumerate(blocks):
        if len(blocks) > 1:
            names = ", ".join(inf.output_labels[j] for j in outs)
            lines.append(
                f"<div style='font-weight:700;margin-top:8px'>Block {b + 1}: "
                f"{len(rules)} rules → {html.escape(names)}</div>"
            )
        lines.append("<div style='font-weight:600;margin-top:6px'>Inputs and their terms</div>")
        lines.append(inputs_svg(inf, ins, uid))
        lines.append(
            "<div style='font-weight:600;margin-top:6px'>Rules"
            + (" that fire" if only_firing else "")
            + " (yellow: antecedent degree, blue: consequent "
            + ("scaled by" if _choice(inf.fis, "imp_method", "min") == "prod" else "clipped at")
            + " the rule's strength; hover a row to read it)</div>"
        )
        lines.append(
            rules_html(
                inf,
                rules,
                ins,
                outs,
                uid,
                only_firing=only_firing,
                weights=weights,
                skeleton=f"{uid}rows{b}",
            )
        )
    return (
        f"<div class='fz-inference' style='font-family:system-ui,sans-serif;font-size:{fs};"
        f"padding:0 4px'>{''.join(lines)}</div>"
    )


# -- control surfaces ------------------------------------------------------------------


@dataclass
class Surface:
    """Crisp outputs over a plane of two inputs (the others held)."""

    title: str
    x_name: str
    y_name: str
    x: np.ndarray  # (nx,)
    y: np.ndarray  # (ny,)
    values: dict  # name -> (ny, nx)


def surface_grid(fis, x_index, y_index, x_range, y_range, held, n: int = 41) -> tuple:
    """Evaluate ``fis`` on an n x n grid of inputs ``x_index`` and ``y_index`` with the
    other inputs at ``held`` (a full input vector). Returns (xs, ys, outputs (ny, nx, n_out))."""
    xs = np.linspace(*x_range, n)
    ys = np.linspace(*y_range, n)
    gx, gy = np.meshgrid(xs, ys)
    X = np.tile(np.asarray(held, dtype=float), (gx.size, 1))
    X[:, x_index] = gx.ravel()
    X[:, y_index] = gy.ravel()
    Y = fis.evaluate(X)
    return xs, ys, Y.reshape(n, n, -1)


def diverging_rgb(values: np.ndarray, limit: float) -> np.ndarray:
    """Blue (negative) - white - red (positive), symmetric about 0, for a heatmap."""
    t = np.clip(np.asarray(values, dtype=float) / max(limit, 1e-9), -1.0, 1.0)
    pos = np.array([220, 38, 38], float)
    neg = np.array([37, 99, 235], float)
    white = np.array([255, 255, 255], float)
    a = np.abs(t)[..., None]
    col = np.where(t[..., None] >= 0, white + a * (pos - white), white + a * (neg - white))
    col = np.where(np.isfinite(values)[..., None], col, 200.0)
    return col.astype(np.uint8)


def surface_png(values: np.ndarray, limit: float, scale: int = 4) -> bytes:
    """The heatmap (rows = y from the top, so flipped: +y up) as PNG bytes."""
    from PIL import Image

    rgb = diverging_rgb(values[::-1], limit)
    img = Image.fromarray(rgb, "RGB").resize(
        (rgb.shape[1] * scale, rgb.shape[0] * scale), Image.NEAREST
    )
    buf = io.BytesIO()
    img.save(buf, format="PNG", optimize=True)
    return buf.getvalue()


def timeline_png(times, strengths, columns: int = 240, row_px: int = 3) -> bytes:
    """The rule-firing strip: a row per rule (rule 1 at the top), time to the right,
    each cell the strongest firing in its time bin (white 0 to orange 1)."""
    from PIL import Image

    n, n_rules = strengths.shape
    cols = max(1, min(columns, n))
    edges = np.linspace(0, n, cols + 1).astype(int)
    binned = np.zeros((n_rules, cols))
    for c in range(cols):
        a, b = edges[c], max(edges[c + 1], edges[c] + 1)
        binned[:, c] = strengths[a:b].max(axis=0)
    level = np.clip(binned, 0.0, 1.0)[..., None]
    white, orange = np.array([255.0, 255.0, 255.0]), np.array([234.0, 88.0, 12.0])
    rgb = (white + level * (orange - white)).astype(np.uint8)
    img = Image.fromarray(rgb, "RGB").resize((cols * 2, n_rules * row_px), Image.NEAREST)
    buf = io.BytesIO()
    img.save(buf, format="PNG", optimize=True)
    return buf.getvalue()


def marker_fraction(value_x, value_y, x_range, y_range) -> tuple[float, float] | None:
    """Where the operating point sits on a heatmap, as fractions (left, top), or None
    when it is off the plane (an input not sensed)."""
    if not (math.isfinite(value_x) and math.isfinite(value_y)):
        return None
    fx = (value_x - x_range[0]) / (x_range[1] - x_range[0])
    fy = (value_y - y_range[0]) / (y_range[1] - y_range[0])
    return float(np.clip(fx, 0.0, 1.0)), float(np.clip(1.0 - fy, 0.0, 1.0))


def marker_style(markers: dict) -> str:
    """CSS that places each marker (element id -> (left, top) fractions or None)."""
    rules = []
    for element_id, where in markers.items():
        if where is None:
            rules.append(f"#{element_id}{{display:none!important}}")
        else:
            rules.append(
                f"#{element_id}{{display:block!important;left:{100 * where[0]:.1f}%;"
                f"top:{100 * where[1]:.1f}%}}"
            )
    return "<style>" + "".join(rules) + "</style>"
