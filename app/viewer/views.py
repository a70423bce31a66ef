"""The viewer's teaching views, as pure functions from a fuzzy system to HTML and SVG.

- :func:`inference_html`: MATLAB's rule viewer for any Mamdani system at one input
  vector: each input's membership functions with the value as a vertical line and each
  term's degree; every rule as a row (antecedent terms filled up to their degree, the
  consequent clipped at the rule's strength; firing rows highlighted); the aggregated
  output set of each output with its centroid; "no rule fires: fallback" said when so.
  Rules that share no variable (fuzzynav's goal and avoidance blocks, merged into one
  system) are drawn as separate blocks, each with only its own columns.
- the rule table is :mod:`.rule_table`'s, the pieces both draw with :mod:`.drawing`'s;
- :func:`surface_grid` / :func:`surface_png`, :func:`timeline_png`, :func:`marker_style`
  (the control surface, the rule-firing strip, the operating point) are
  :mod:`.surface_view`'s, offered here too so that this module is the teaching views'
  one front (``views.infer``, ``views.surface_png``, ...).

Nothing here knows viser or the simulation; the strings are shown with viser's HTML
element (which sets them as innerHTML).
"""

from __future__ import annotations

import html
import math

import numpy as np

from fuzzynav.app.viewer.drawing import (
    CELL_H,
    CELL_W,
    INPUT_H,
    INPUT_LINE,
    INPUT_W,
    OBSTACLE_INPUT,
    PALETTE,
    TARGET_INPUT,
    UNITS,
    Inference,
    _choice,
    _clipped_use,
    _defuzz_word,
    _fmt_degree,
    _fmt_value,
    _path,
    _sample,
    _x_of,
    infer,
    input_colour,
    rule_blocks,
    rule_sentence,
)
from fuzzynav.app.viewer.rule_table import ZOOM_DEFINITION_HTML, rows_skeleton, rules_html
from fuzzynav.app.viewer.surface_view import (
    marker_fraction,
    marker_style,
    surface_grid,
    surface_png,
    timeline_png,
)

__all__ = [
    "OBSTACLE_INPUT",
    "TARGET_INPUT",
    "Inference",
    "defs_html",
    "infer",
    "inference_html",
    "inputs_svg",
    "marker_fraction",
    "marker_style",
    "rule_blocks",
    "rule_sentence",
    "rules_html",
    "surface_grid",
    "surface_png",
    "timeline_png",
]


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
        f"<div class='fz-sentences'>{sentences}</div>{ZOOM_DEFINITION_HTML}"
    )


def _drag_handler(slider_id: str, lo: float, hi: float, smin: float, smax: float) -> str:
    """The inline pointer handler of an input's term plot in what-if mode. viser's HTML
    element sets its content as innerHTML: a <script> never runs, an event attribute
    does. A drag across the plot becomes a drag of that input's what-if slider (its
    element has the slider's id): mouse events at the matching place on the slider's
    track (Mantine listens there), so the value travels as the slider's own (checked,
    synced) update. The slider must be laid out: the What-if folder open."""
    return (
        "(function(ev){var s=document.getElementById('" + slider_id + "');if(!s)return;"
        "s=s.querySelector('.mantine-Slider-trackContainer')||s;"
        "var r=ev.currentTarget.getBoundingClientRect(),q=s.getBoundingClientRect();"
        "if(!(r.width>0&&q.width>0))return;ev.preventDefault();"
        f"function x(e){{var f=Math.min(1,Math.max(0,(e.clientX-r.left)/r.width));"
        f"var v={lo!r}+f*({hi!r}-({lo!r}));var g=(v-({smin!r}))/({smax!r}-({smin!r}));"
        "g=Math.min(1,Math.max(0,g));return q.left+g*q.width;}"
        "function o(e){return {bubbles:true,cancelable:true,clientX:x(e),"
        "clientY:q.top+q.height/2,button:0,buttons:1};}"
        "s.dispatchEvent(new MouseEvent('mousedown',o(ev)));"
        "function m(e){document.dispatchEvent(new MouseEvent('mousemove',o(e)));}"
        "function u(e){window.removeEventListener('pointermove',m);"
        "window.removeEventListener('pointerup',u);"
        "document.dispatchEvent(new MouseEvent('mouseup',o(e)));}"
        "window.addEventListener('pointermove',m);window.addEventListener('pointerup',u);"
        "})(event)"
    )


def inputs_svg(inf: Inference, indices=None, uid: str = "fz", drag: dict | None = None) -> str:
    """Each input's terms with the value as a red line and each term's degree.

    ``drag``: input index -> (slider id, slider min, slider max): in what-if mode that
    input's plot can be dragged across (:func:`_drag_handler`)."""
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
        if drag and i in drag:
            slider_id, smin, smax = drag[i]
            handler = html.escape(_drag_handler(slider_id, lo, hi, smin, smax), quote=True)
            parts.append(
                f"<rect class='fz-drag-input' data-input='{html.escape(label)}' x='{x0:.0f}' "
                f"y='{y0:.0f}' width='{w:.0f}' height='{h:.0f}' fill='transparent' "
                f"style='cursor:ew-resize;touch-action:none' onpointerdown=\"{handler}\">"
                f"<title>drag: {html.escape(label)}</title></rect>"
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


def inference_html(
    inf: Inference,
    *,
    uid: str = "fz",
    large: bool = False,
    crisp: dict | None = None,
    only_firing: bool = False,
    weights: dict | None = None,
    notes: dict | None = None,
    drag: dict | None = None,
) -> str:
    """The whole inference view: summary, inputs, rule grid(s), aggregated outputs.

    ``weights``: output label -> the weight the controller gives that output now
    (fuzzynav: the avoidance block's alpha); an output no rule reaches is a fallback to
    alarm about only when its weight is above zero. ``notes``: input label -> what it
    is, said once under the summary (fuzzynav's phi_plan). ``large`` (presentation
    mode) also lists the firing rules as sentences."""
    fs = "1.25em" if large else "0.85em"
    lines = _summary_lines(inf, weights)
    centroid_text = ", ".join(
        f"{html.escape(name)} = {c:.2f}" for name, c in zip(inf.output_labels, inf.centroids)
    )
    lines.append(f"<div>Outputs ({_defuzz_word(inf.fis)}): {centroid_text}</div>")
    for name, text in (notes or {}).items():
        lines.append(
            f"<div style='color:#475569'><b>{html.escape(name)}</b>: {html.escape(text)}</div>"
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
    lines += _block_lines(inf, uid, only_firing=only_firing, weights=weights, drag=drag)
    if large and inf.n_firing:
        lines.append(_firing_sentences(inf))
    return (
        # (14 px on the right: the panel's overlay scrollbar covered the plots' edge)
        f"<div class='fz-inference' style='font-family:system-ui,sans-serif;font-size:{fs};"
        f"padding:0 14px 0 4px'>{''.join(lines)}</div>"
    )


def _summary_lines(inf: Inference, weights: dict | None) -> list[str]:
    """How many rules fire and the strongest, or the fallback; the outputs no rule
    concludes on (an alarm only where their weight is above zero)."""
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
        return lines
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
    return lines


def _block_lines(
    inf: Inference, uid: str, *, only_firing: bool, weights: dict | None, drag: dict | None
) -> list[str]:
    """Each rule block: its heading (when there are several), its rule grid, then its
    inputs and their terms."""
    lines = []
    blocks = rule_blocks(inf.fis)
    for b, (rules, ins, outs) in enumerate(blocks):
        if len(blocks) > 1:
            names = ", ".join(inf.output_labels[j] for j in outs)
            lines.append(
                f"<div style='font-weight:700;margin-top:8px'>Block {b + 1}: "
                f"{len(rules)} rules → {html.escape(names)}</div>"
            )
        # The rules first, right under the summary: at 1280 x 800, with What-if open or
        # in presentation mode, the grid still shows its rows without a scroll
        # (below the term plots it showed its header and its aggregate only).
        lines.append(
            "<div style='font-weight:600;margin-top:6px'>Rules"
            + (" that fire" if only_firing else "")
            + " (yellow: antecedent degree, blue: consequent "
            + ("scaled by" if _choice(inf.fis, "imp_method", "min") == "prod" else "clipped at")
            + " the rule's strength; hover a row to read it, click it to open it large)</div>"
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
                block_id=f"{uid}b{b}",
            )
        )
        lines.append("<div style='font-weight:600;margin-top:6px'>Inputs and their terms</div>")
        lines.append(inputs_svg(inf, ins, uid, drag))
    return lines


def _firing_sentences(inf: Inference) -> str:
    """The six strongest firing rules as sentences (presentation mode)."""
    order = [int(r) for r in np.argsort(-inf.strengths, kind="stable") if inf.strengths[r] > 0]
    items = "".join(
        f"<li><b>{_fmt_degree(float(inf.strengths[r]))}</b> "
        f"{html.escape(rule_sentence(inf.fis, r, inf.input_labels, inf.output_labels))}</li>"
        for r in order[:6]
    )
    more = f"<div>… and {len(order) - 6} more</div>" if len(order) > 6 else ""
    return (
        "<div class='fz-firing-sentences' style='margin-top:4px'><b>Firing rules, "
        f"strongest first</b><ul style='margin:2px 0 0 18px;padding:0'>{items}</ul>"
        f"{more}</div>"
    )
