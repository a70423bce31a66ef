"""What the teaching views draw with: the sizes of the rule grid, the inputs' colours
and units, :class:`Inference` (everything drawn at one input vector, from the engine's
own teaching calls), sampled membership functions, SVG paths, number formats, and the
rules grouped into blocks and read as sentences. Used by :mod:`.views` (the inference
view) and :mod:`.rule_table`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from fuzzynav.app import palette

CELL_W = 66.0  # width of one variable's column in the rule grid (SVG units)
CELL_H = 17.0  # height of one rule row
NUM_W = 46.0  # width of the rule-number column
CURVE_POINTS = 21  # samples of a membership function in a rule cell

INPUT_LINE = "#dc2626"
# The paper's four inputs each have a colour, the same in the term plots, in the rule
# grid and on the arena (where d_t, phi_t, d_o and phi_o are drawn on the robot): the
# target's pair teal, the obstacle's pair magenta.
TARGET_INPUT = palette.TARGET_INPUT  # (app.palette: one palette everywhere)
OBSTACLE_INPUT = palette.OBSTACLE_INPUT
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
NONE_SENSED = "none sensed"  # what an input not sensed (d_o, phi_o: NaN) reads as

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
        return NONE_SENSED if math.isnan(value) else f"{value}"
    return f"{value:.2f} {unit}".strip()


def _fmt_degree(d: float) -> str:
    """A degree readable however small: 0.55, 0.031, 0.0004, <0.0001 (never a bare 0.00:
    a rule of strength > 0 fires; but a Gaussian's far tail, 9.4e-09, read as noise)."""
    if d <= 0.0:
        return "0"
    if d >= 0.095:
        return f"{d:.2f}"
    if d < 1e-4:
        return "<0.0001"
    return f"{d:.2g}"


INPUT_W, INPUT_H = 150.0, 46.0
PALETTE = palette.VIEWER_SERIES


def _choice(fis, field: str, default: str) -> str:
    """One of the system's inference choices (controller/inference.py)."""
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
