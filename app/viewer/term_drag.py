"""Membership functions shaped by dragging their corners, beside the Editor's
sliders.

Each variable's terms are drawn with a handle on every corner that one of the Editor's
sliders moves. Which slider moves which corner, and how fast, is measured on the
layout itself (a small step of each slider, the corners compared), so it holds for every
layout the Editor edits (the design layout's widths and spacings, the partition and the
27-number ones). A drag of a handle becomes a drag of that slider (the same mouse events
on its track as a what-if plot drag, :func:`views._drag_handler`): the value reaches the
server as the slider's own, checked, update, and the slider's bounds keep every shape
valid. The slider has to be laid out: the plot sits in the slider's own folder.
"""

from __future__ import annotations

import html

from fuzzynav.app.viewer.drawing import PALETTE, _path, _sample
from fuzzynav.app.viewer.views import _drag_handler
from fuzzynav.controller.membership import SHAPES

W, H = 300.0, 56.0


def _variable(fis, group: str):
    """The variable a slider group shapes: an input by name; ``v``: the outputs (left)."""
    if group in fis.input_names:
        return fis.inputs[fis.input_names.index(group)]
    return fis.outputs[0]


def corner_sliders(editor, group: str, names) -> list[tuple[float, str, float]]:
    """(corner x, slider name, d corner / d slider) for each corner of ``group``'s
    variable that a slider of ``names`` moves (the slider moving it most)."""
    fis = editor.controller().fis
    var = _variable(fis, group)
    corners = [
        (k, j, float(p))
        for k, t in enumerate(var.terms)
        if SHAPES[t.shape].positions  # (a width or a spread is no corner to drag)
        for j, p in enumerate(t.params)
    ]
    best: dict[tuple[int, int], tuple[float, str]] = {}
    for name in names:
        lo, hi = editor.bounds[name]
        eps = 1e-3 * (hi - lo)
        i = editor.names.index(name)
        vector = editor.vector.copy()
        step = eps if vector[i] + eps <= hi else -eps
        vector[i] += step
        try:
            moved = _variable(editor._build(vector).fis, group)
        except ValueError:
            continue
        for k, j, p in corners:
            rate = (float(moved.terms[k].params[j]) - p) / step
            if abs(rate) > 1e-6 and abs(rate) > abs(best.get((k, j), (0.0, ""))[0]):
                best[(k, j)] = (rate, name)
    out, seen = [], set()
    for (k, j), (rate, name) in best.items():
        x = next(p for kk, jj, p in corners if (kk, jj) == (k, j))
        key = round(x, 6)
        if key in seen:
            continue
        seen.add(key)
        out.append((x, name, rate))
    return sorted(out)


def terms_drag_svg(editor, group: str, names, slider_ids: dict, slider_ranges: dict) -> str:
    """``group``'s variable with a draggable handle on each corner a slider moves."""
    fis = editor.controller().fis
    var = _variable(fis, group)
    lo, hi = var.range
    xs, curves = _sample(var)
    parts = [
        f"<svg class='fz-term-drag' data-group='{html.escape(group)}' viewBox='-6 -4 "
        f"{W + 12:.0f} {H + 18:.0f}' style='width:100%;display:block;touch-action:none'"
        " font-family='system-ui,sans-serif'>",
        f"<rect class='fz-term-area' x='0' y='0' width='{W:.0f}' height='{H:.0f}' "
        "fill='#f8fafc' stroke='#e2e8f0'/>",
    ]
    if group in fis.input_names:  # the input's value now, moved by CSS (now_css)
        parts.append(
            f"<line class='fz-term-now' data-group='{html.escape(group)}' x1='0' x2='0' "
            f"y1='0' y2='{H:.0f}' stroke='#dc2626' stroke-width='1.5' style='display:none'/>"
        )
    for k, ys in enumerate(curves):
        colour = PALETTE[k % len(PALETTE)]
        parts.append(
            f"<path d='{_path(xs, ys, 0, 0, W, H, lo, hi)}' fill='none' stroke='{colour}' "
            "stroke-width='1.5'/>"
        )
    for x, name, rate in corner_sliders(editor, group, names):
        if name not in slider_ids or not lo <= x <= hi:
            continue
        s_lo, s_hi = slider_ranges[name]
        value = editor.value(name)
        # corner = x + rate * (slider - value): the slider at a corner position c is
        # value + (c - x) / rate; _drag_handler maps plot units to the slider's track
        # linearly, so the track's ends in plot units are given instead of its own.
        a_lo = x + rate * (s_lo - value)
        a_hi = x + rate * (s_hi - value)
        # (the pointer is read against the whole plot, not the handle itself)
        js = _drag_handler(slider_ids[name], lo, hi, a_lo, a_hi).replace(
            "var r=ev.currentTarget.getBoundingClientRect()",
            "var r=ev.currentTarget.ownerSVGElement.querySelector('.fz-term-area')"
            ".getBoundingClientRect()",
        )
        assert "fz-term-area" in js
        handler = html.escape(js, quote=True)
        cx = (x - lo) / (hi - lo) * W
        parts.append(
            f"<circle class='fz-corner' data-slider='{html.escape(name)}' cx='{cx:.1f}' "
            f"cy='{H:.0f}' r='5' fill='#fff' stroke='#0f172a' stroke-width='1.5' "
            f"style='cursor:ew-resize' onpointerdown=\"{handler}\">"
            f"<title>drag: {html.escape(name)}</title></circle>"
        )
    parts.append(
        f"<text x='0' y='{H + 12:.0f}' font-size='9' fill='#64748b'>{lo:g}</text>"
        f"<text x='{W:.0f}' y='{H + 12:.0f}' font-size='9' fill='#64748b' text-anchor='end'>"
        f"{hi:g}</text></svg>"
    )
    return "".join(parts)


def now_css(fis, inputs) -> str:
    """Where each input's value stands on its Editor plot, as CSS (a few bytes at the
    panels' rate; the plots themselves are sent once per system): the red line of
    :func:`terms_drag_svg` moved to the value, hidden when it is not sensed."""
    rules = []
    for name, var, value in zip(fis.input_names, fis.inputs, inputs):
        lo, hi = var.range
        sel = f".fz-term-now[data-group='{name}']"
        if value is None or not lo <= value <= hi:
            rules.append(f"{sel}{{display:none}}")
            continue
        x = (value - lo) / (hi - lo) * W
        rules.append(f"{sel}{{display:inline!important;transform:translateX({x:.1f}px)}}")
    return "<style>" + "".join(rules) + "</style>"


__all__ = ["corner_sliders", "now_css", "terms_drag_svg"]
