"""The rule table of the inference view (MATLAB's rule viewer): a row per rule, a
column per variable; antecedent terms filled up to their degree, consequents clipped at
the rule's strength; headers that stay at the top and the aggregated sets with their
centroids pinned at the bottom; every row a hover target for its sentence.

The row outlines never change and are sent once (:func:`rows_skeleton`, in
:func:`app.viewer.views.defs_html`); a step sends the few things that move.
"""

from __future__ import annotations

import html
import math

import numpy as np

from fuzzynav.app.viewer.drawing import (
    ANTECEDENT_FILL,
    CELL_H,
    CELL_W,
    CONSEQUENT_FILL,
    FIRING_ROW,
    NUM_W,
    OUTLINE,
    UNITS,
    Inference,
    _choice,
    _clipped_use,
    _defuzz_word,
    _fmt_degree,
    _fmt_value,
    _path,
    _scaled_use,
    _simplify,
    _x_of,
    input_colour,
    rule_blocks,
)


def _and_word(fis) -> str:
    """How a rule's strength comes from its degrees, in words (the AND method)."""
    return "their product" if _choice(fis, "and_method", "min") == "prod" else "the smallest"


def _rule_columns(ins, outs):
    """(width, x of column c): the rule grid's geometry, shared by the header, the rows
    and the aggregated row (three SVGs that must line up)."""
    width = NUM_W + (len(ins) + len(outs)) * CELL_W + 10.0  # a gap between inputs and outputs

    def col_x(c):
        return NUM_W + c * CELL_W + (10.0 if c >= len(ins) else 0.0)

    return width, col_x


def _svg_open(width: float, height: float, cls: str, extra: str = "") -> str:
    return (
        f"<svg viewBox='0 0 {width:.0f} {height:.0f}' style='width:100%;display:block'"
        f" font-family='system-ui,sans-serif' class='{cls}'{extra}>"
    )


# The rule grid's click handler (an event attribute: viser's HTML element sets its
# content as innerHTML, where a <script> never runs). A click on a row opens that rule
# large in an overlay of the page's own (``#fz-zoom``, outside the replaced HTML): the
# row and the column headers drawn again by SVG ``<use>`` of the live grid (so the
# zoomed row follows every step and every paused drag), the rule as a sentence, its
# antecedents' degrees and its share of the block's firing strength, read again from
# the grid four times a second. Close: its button, Escape, or a click outside it.
_ZOOM_JS = (
    "(function(ev){var t=ev.target,k=t&&t.getAttribute&&t.getAttribute('data-rule');"
    "if(!k)return;var G='@G',H='@H',g=document.getElementById(G);if(!g)return;"
    "var y=+t.getAttribute('y'),vb=g.viewBox.baseVal;"
    "var old=document.getElementById('fz-zoom');if(old&&old.fzClose)old.fzClose();"
    "var d=document.createElement('div');d.id='fz-zoom';d.className='fz-zoom';"
    "d.setAttribute('data-rule',k);d.style.cssText='position:fixed;left:50%;top:50%;"
    "transform:translate(-50%,-50%);width:min(94vw,1100px);max-height:92vh;overflow:auto;"
    "background:#fff;border:2px solid #0f172a;border-radius:8px;box-shadow:0 8px 32px #0007;"
    "z-index:10000;padding:12px 16px;font:17px system-ui,sans-serif;color:#0f172a';"
    "d.innerHTML=\"<div style='display:flex;justify-content:space-between;align-items:center'>"
    "<b style='font-size:1.35em'>Rule \"+k+\"</b><button class='fz-zoom-close' "
    "style='font-size:0.9em;padding:2px 10px'>close \u2715</button></div>"
    "<div class='fz-zoom-sentence' style='margin:6px 0 10px;font-size:1.1em'></div>"
    "<svg viewBox='0 0 @W 26' style='width:100%;display:block'><use href='#@H' width='@W' "
    "height='26'/></svg><svg class='fz-zoom-row' viewBox='0 \"+y+\" @W @R' "
    "style='width:100%;display:block;border:1px solid #94a3b8'><use href='#@G' width='@W' "
    "height='\"+vb.height+\"'/></svg><div class='fz-zoom-numbers' style='margin-top:10px;"
    "line-height:1.5'></div>\";"
    "var s=document.getElementById('@Us'+k);"
    "d.querySelector('.fz-zoom-sentence').textContent=s?s.textContent:'';"
    "function upd(){var g=document.getElementById(G);if(!g)return;var f=g.querySelectorAll("
    "'.fz-firing'),sum=0,me=null;for(var i=0;i<f.length;i++){var v=+f[i].getAttribute("
    "'data-strength');sum+=v;if(f[i].getAttribute('data-rule')==k)me=f[i];}"
    "var n=d.querySelector('.fz-zoom-numbers');if(!me){n.textContent='It does not fire now "
    "(strength 0): it adds nothing to the outputs.';return;}var st=+me.getAttribute("
    "'data-strength');n.textContent='If: '+me.getAttribute('data-degrees')+'. Strength '+"
    "me.getAttribute('data-shown')+' ('+me.getAttribute('data-and')+'): '+"
    "(100*st/sum).toFixed(0)+' % of the firing strength of its block, which its '+"
    "'consequents carry into the aggregated sets.';}"
    "function esc(e){if(e.key==='Escape')close();}"
    "function out(e){if(!d.contains(e.target))close();}"
    "function close(){clearInterval(d.fzTimer);document.removeEventListener('keydown',esc);"
    "document.removeEventListener('pointerdown',out,true);d.remove();}"
    "d.fzClose=close;d.querySelector('.fz-zoom-close').onclick=close;"
    "document.addEventListener('keydown',esc);"
    "setTimeout(function(){document.addEventListener('pointerdown',out,true);},0);"
    "document.body.appendChild(d);upd();d.fzTimer=setInterval(upd,250);})(event)"
)


def _zoom_function_js() -> str:
    """:data:`_ZOOM_JS` as one page-wide function, ``fzZoom(event, G, H, U, W, R)``."""
    js = _ZOOM_JS.replace(
        "var G='@G',H='@H',g=document.getElementById(G)", "var g=document.getElementById(G)"
    ).replace("'@Us'+k", "U+'s'+k")
    for token, name in (("@W", "W"), ("@H", "H"), ("@G", "G"), ("@R", "R")):
        js = js.replace(token, f'"+{name}+"')
    assert js.startswith("(function(ev){") and js.endswith("})(event)")
    return (
        "window.fzZoom=function(ev,G,H,U,W,R){"
        + js[len("(function(ev){") : -len("})(event)")]
        + "};"
    )


#: Defines ``fzZoom`` once, with the system's definitions (:func:`views.defs_html`): an
#: image that cannot load runs its onerror (a <script> in viser's HTML never runs). Each
#: step's rows then carry a short onclick calling it, not the whole handler.
ZOOM_DEFINITION_HTML = (
    "<img class='fz-zoom-def' alt='' src='data:,' style='display:none' onerror=\""
    + html.escape(_zoom_function_js(), quote=True)
    + '">'
)


def _zoom_attr(grid_id: str, head_id: str, uid: str, width: float) -> str:
    call = f"window.fzZoom&&fzZoom(event,'{grid_id}','{head_id}','{uid}',{width:.0f},{CELL_H:.0f})"
    return f" id='{grid_id}' onclick=\"{call}\""


def rules_head_svg(inf: Inference, ins, outs, head_id: str | None = None) -> str:
    """The rule grid's column headers: each variable's name and value (the centroid for
    an output). Sticky: it stays at the top of the panel while the rules scroll."""
    fis = inf.fis
    width, col_x = _rule_columns(ins, outs)
    extra = f" id='{head_id}'" if head_id else ""
    parts = [_svg_open(width, 26.0, "fz-rule-head-svg", extra)]
    parts.append("<text x='2' y='11' font-size='8.5' fill='#475569'>rule</text>")
    for c, i in enumerate(ins):
        var = fis.inputs[i]
        value = float(inf.inputs[i])
        parts.append(
            f"<text x='{col_x(c) + 2:.0f}' y='11' font-size='9.5' font-weight='600'"
            f" class='fz-col-name'>{html.escape(inf.input_labels[i])}</text>"
            f"<text x='{col_x(c) + 2:.0f}' y='22' font-size='8.5'"
            f" fill='{input_colour(inf.input_labels[i])}'>"
            # (the column is narrow: "none", the term plots say "none sensed")
            f"{'none' if math.isnan(value) else html.escape(_fmt_value(value, UNITS.get(var.name, var.unit or '')))}</text>"
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
    _, col_x = _rule_columns(ins, outs)
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


def rules_rows_svg(
    inf: Inference, rules, ins, outs, uid: str = "fz", skeleton=None, block_id=None
) -> str:
    """MATLAB's rule viewer for one block: a row per rule in ``rules``, a column per
    variable. Each row has a transparent hit area (``fz-hit``, ``data-rule``): hovering
    it shows the rule as a sentence (:func:`defs_html`). ``skeleton``: the id of this
    block's row outlines in :func:`defs_html` when ``rules`` are all its rules (they
    are then referred to, not sent again)."""
    fis = inf.fis
    width, col_x = _rule_columns(ins, outs)
    height = max(len(rules), 1) * CELL_H + 2.0
    extra = _zoom_attr(f"{block_id}g", f"{block_id}h", uid, width) if block_id else ""
    parts = [_svg_open(width, height, "fz-rules", extra)]
    if not rules:
        parts.append(
            f"<text x='4' y='{CELL_H - 4:.0f}' font-size='9' fill='#64748b'>"
            "no rule of this block fires</text></svg>"
        )
        return "".join(parts)
    fills, labels, hits = [], [], []
    for row, r in enumerate(rules):
        s = float(inf.strengths[r])
        y0 = row * CELL_H
        hits.append(f"<rect data-rule='{r + 1}' y='{y0:.0f}'/>")
        if s <= 0.0:
            continue
        parts.append(_firing_highlight(inf, r, s, y0, ins, width))
        labels.append(
            f"<rect x='0' y='{y0 + 1:.0f}' width='{NUM_W - 4:.0f}' height='{CELL_H - 2:.0f}'"
            f" fill='{FIRING_ROW}'/><text x='2' y='{y0 + 12:.1f}'>{r + 1}"
            f" {_fmt_degree(s)}</text>"
        )
        fills += _row_fills(inf, r, s, y0, ins, outs, col_x, uid)
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
    parts += _input_lines(inf, ins, col_x, len(rules) * CELL_H)
    # Hover areas, one per row, on top (transparent).
    parts.append(
        "<g class='fz-hit' fill='transparent' pointer-events='all' style='cursor:zoom-in'>"
        f"{''.join(hits)}</g>".replace(
            "<rect ", f"<rect width='{width:.0f}' height='{CELL_H:.0f}' "
        )
    )
    parts.append("</svg>")
    return "".join(parts)


def _firing_highlight(inf: Inference, r: int, s: float, y0: float, ins, width: float) -> str:
    """A firing rule's row highlight, carrying its strength and its clauses' degrees."""
    fis = inf.fis
    rule = fis.rules[r]
    degrees = "; ".join(
        f"{inf.input_labels[i]} is {fis.inputs[i].terms[k].name} "
        f"{_fmt_degree(float(inf.memberships[i][k]))}"
        for i in ins
        for k in (rule.antecedent[i],)
        if k is not None
    )
    return (
        f"<rect class='fz-firing' data-rule='{r + 1}' data-strength='{s:.6g}'"
        f" data-shown='{_fmt_degree(s)}' data-degrees='{html.escape(degrees, quote=True)}'"
        f" data-and='{_and_word(fis)}' x='0'"
        f" y='{y0:.1f}' width='{width:.0f}' height='{CELL_H:.0f}' fill='{FIRING_ROW}'/>"
    )


def _row_fills(inf: Inference, r: int, s: float, y0: float, ins, outs, col_x, uid: str) -> list:
    """A firing rule's cells filled to their degree (a consequent scaled under ``prod``
    implication, clipped otherwise)."""
    fis = inf.fis
    rule = fis.rules[r]
    pad = 2.0
    w, h = CELL_W - 2 * pad, CELL_H - 2 * pad
    fills = []
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
    return fills


def _input_lines(inf: Inference, ins, col_x, bottom: float) -> list[str]:
    """The input values as vertical lines through every row of their column."""
    pad = 2.0
    lines = []
    for c, i in enumerate(ins):
        var = inf.fis.inputs[i]
        lo, hi = var.range
        xline = _x_of(float(inf.inputs[i]), lo, hi, col_x(c) + pad, CELL_W - 2 * pad)
        if xline is not None:
            lines.append(
                f"<line class='fz-input-line' x1='{xline:.1f}' x2='{xline:.1f}' y1='0' "
                f"y2='{bottom:.0f}' stroke='{input_colour(inf.input_labels[i])}'"
                " stroke-width='1.2'/>"
            )
    return lines


def rules_aggregate_svg(inf: Inference, ins, outs, weights=None) -> str:
    """The aggregated output set of each output of the block, with its centroid, under
    its column. Sticky: pinned at the bottom of the panel while the rules scroll.

    ``weights``: output name -> the weight the controller gives it now (fuzzynav's
    blocks); a set that no rule reaches is a fallback worth a red word only when its
    weight is above zero."""
    fis = inf.fis
    width, col_x = _rule_columns(ins, outs)
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
        f"<text x='2' y='{y0 + 12:.1f}' font-size='8.5' fill='#334155'>aggregated</text>"
        f"<text x='2' y='{y0 + 27:.1f}' font-size='8.5' fill='#334155'>{_defuzz_word(fis)}</text>"
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
    block_id=None,
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
        f"{rules_head_svg(inf, ins, outs, f'{block_id}h' if block_id else None)}</div>"
        "<div class='fz-rule-rows'>"
        + rules_rows_svg(inf, shown, ins, outs, uid, None if only_firing else skeleton, block_id)
        + "</div><div class='fz-rule-agg' style='position:sticky;bottom:0;z-index:3;"
        "background:#fff;border-top:1px solid #cbd5e1'>"
        f"{rules_aggregate_svg(inf, ins, outs, weights)}</div></div>"
    )
