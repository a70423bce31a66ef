"""One inference taken apart, stage by stage: the moment shown in the
Inference tab (live, paused, looked back at, or tried in what-if mode) walked through
Mamdani's five stages, one at a time, each drawn and said in a sentence with its
numbers:

1. fuzzification: each input's value and its terms' degrees;
2. the rules' AND: each firing rule's antecedent degrees combined (min or product, the
   system's AND method) into its strength (times its weight);
3. implication: each firing rule's consequent sets clipped at (min) or scaled by (prod)
   its strength;
4. aggregation: the implied sets of each output combined (max, sum or probor);
5. defuzzification: the crisp output of each aggregated set (centroid, bisector, MOM,
   SOM, LOM).

The numbers are the engine's own (:func:`drawing.infer`: the memberships, the
strengths, the aggregated sets and the outputs), whichever inference choices the system
has; the implied sets of stage 3 are drawn from the output terms on the engine's grid.
Pure functions from an :class:`drawing.Inference` to HTML, as :mod:`.views`.
"""

from __future__ import annotations

import html

import numpy as np

from fuzzynav.app.viewer.drawing import (
    UNITS,
    Inference,
    _choice,
    _defuzz_word,
    _fmt_degree,
    _fmt_value,
)

STAGES = ("Fuzzification", "The rules' AND", "Implication", "Aggregation", "Defuzzification")
N_STAGES = len(STAGES)
MAX_LISTED = 8  # firing rules listed by name in a stage (the strongest first)
W, H = 300.0, 70.0  # one output's plot (SVG units)
COLOURS = ("#2563eb", "#ea580c", "#16a34a", "#9333ea", "#0891b2", "#db2777", "#ca8a04")


def _unit(var) -> str:
    return UNITS.get(var.name, var.unit or "")


def _firing(inf: Inference) -> list[int]:
    order = np.argsort(-inf.strengths, kind="stable")
    return [int(r) for r in order if inf.strengths[r] > 0.0]


def _term_clause(inf: Inference, r: int) -> list[str]:
    fis = inf.fis
    rule = fis.rules[r]
    out = []
    for i, k in enumerate(rule.antecedent):
        if k is None:
            continue
        degree = float(inf.memberships[i][k])
        out.append(
            f"{html.escape(inf.input_labels[i])} is {html.escape(fis.inputs[i].terms[k].name)} "
            f"({_fmt_degree(degree)})"
        )
    return out


def _path(xs, ys, lo, hi, top=1.0) -> str:
    px = (np.asarray(xs) - lo) / (hi - lo) * W
    py = H - np.clip(np.asarray(ys) / top, 0.0, 1.0) * (H - 4)
    return "M" + " L".join(f"{a:.1f},{b:.1f}" for a, b in zip(px, py))


def _plot(inf: Inference, o: int, curves, fill=None, line_at=None) -> str:
    """One output's plot: ``curves`` [(ys, colour)], an optional filled set and a
    vertical line (the crisp output)."""
    var = inf.fis.outputs[o]
    lo, hi = var.range
    xs = inf.grid[o]
    top = max(1.0, float(np.max(fill)) if fill is not None and len(fill) else 1.0)
    parts = [
        f"<svg class='fz-step-plot' viewBox='0 -12 {W:.0f} {H + 36:.0f}' "
        "style='width:100%;display:block' font-family='system-ui,sans-serif'>",
        f"<rect x='0' y='0' width='{W:.0f}' height='{H:.0f}' fill='#f8fafc' stroke='#e2e8f0'/>",
        f"<text x='0' y='-2' font-size='10' font-weight='600'>"
        f"{html.escape(inf.output_labels[o])}</text>",
    ]
    for t in var.terms:  # the output's terms, faint
        parts.append(
            f"<path d='{_path(xs, t(xs), lo, hi, top)}' fill='none' stroke='#cbd5e1' "
            "stroke-width='0.8'/>"
        )
    if fill is not None:
        parts.append(
            f"<path class='fz-step-aggregate' d='{_path(xs, fill, lo, hi, top)} L{W:.1f},{H:.1f} "
            f"L0,{H:.1f} Z' fill='#2563eb33' stroke='#1d4ed8' stroke-width='1.2'/>"
        )
    for ys, colour in curves:
        parts.append(
            f"<path class='fz-step-implied' d='{_path(xs, ys, lo, hi, top)}' fill='none' "
            f"stroke='{colour}' stroke-width='1.4'/>"
        )
    if line_at is not None and np.isfinite(line_at):
        x = (line_at - lo) / (hi - lo) * W
        parts.append(
            f"<line class='fz-step-crisp' x1='{x:.1f}' x2='{x:.1f}' y1='0' y2='{H:.0f}' "
            "stroke='#0f172a' stroke-width='2'/>"
            f"<text x='{min(max(x, 20), W - 20):.1f}' y='{H + 22:.0f}' font-size='10' "
            f"text-anchor='middle'>{line_at:.2f}</text>"
        )
    unit = _unit(var)
    unit = f" {unit}" if unit else ""
    parts.append(
        f"<text x='0' y='{H + 11:.0f}' font-size='9' fill='#64748b'>{lo:g}{unit}</text>"
        f"<text x='{W:.0f}' y='{H + 11:.0f}' font-size='9' fill='#64748b' "
        f"text-anchor='end'>{hi:g}{unit}</text></svg>"
    )
    return "".join(parts)


def implied_sets(inf: Inference, r: int) -> dict[int, np.ndarray]:
    """Rule r's implied set on each output it concludes on: its consequent term clipped
    at (min) or scaled by (prod) its strength."""
    fis = inf.fis
    s = float(inf.strengths[r])
    prod = _choice(fis, "imp_method", "min") == "prod"
    out = {}
    for o, k in enumerate(fis.rules[r].consequent):
        if k is None:
            continue
        mu = np.asarray(fis.outputs[o].terms[k](inf.grid[o]), dtype=float)
        out[o] = mu * s if prod else np.minimum(mu, s)
    return out


def stage_html(inf: Inference, stage: int) -> str:
    """Stage ``stage`` (1..N_STAGES) of the inference ``inf``: a title, a sentence with
    its numbers and its drawing."""
    stage = min(max(int(stage), 1), N_STAGES)
    firing = _firing(inf)
    listed = firing[:MAX_LISTED]
    if stage == 1:
        body = _fuzzification(inf)
    elif stage == 2:
        body = _rule_strengths(inf, firing, listed)
    elif stage == 3:
        body = _implication(inf, listed)
    elif stage == 4:
        body = _aggregation(inf)
    else:
        body = _defuzzification(inf)
    return (
        f"<div class='fz-stepwise' data-stage='{stage}' style='font-family:system-ui,sans-serif;"
        "font-size:0.9em;padding:4px 6px;margin:0 4px 6px;border:2px solid #2563eb;"
        "border-radius:6px;background:#eff6ff'>"
        f"<div class='fz-step-title' style='font-weight:700'>Step {stage} of {N_STAGES}: "
        f"{STAGES[stage - 1]}</div>{''.join(body)}</div>"
    )


def _fuzzification(inf: Inference) -> list[str]:
    """Stage 1: each input's degree on each of its terms."""
    fis = inf.fis
    body = [
        "<p class='fz-step-say'>Each input's value is read on each of its terms: the "
        "degree to which the value is that term (0 to 1).</p><ul>"
    ]
    read = [i for i in range(fis.n_inputs) if any(r.antecedent[i] is not None for r in fis.rules)]
    for i, var in enumerate(fis.inputs):
        if i not in read:  # (the starter reads d_t and phi_t only)
            continue
        value = float(inf.inputs[i])
        label = html.escape(inf.input_labels[i])
        if not np.isfinite(value):
            body.append(f"<li><b>{label}</b> is not sensed: every term has degree 0.</li>")
            continue
        degrees = ", ".join(
            (
                f"<b>{html.escape(t.name)} {_fmt_degree(float(d))}</b>"
                if d > 0
                else f"{html.escape(t.name)} 0"
            )
            for t, d in zip(var.terms, inf.memberships[i])
        )
        body.append(
            f"<li><b>{label}</b> = {html.escape(_fmt_value(value, _unit(var)))}: {degrees}</li>"
        )
    body.append("</ul>")
    return body


def _rule_strengths(inf: Inference, firing, listed) -> list[str]:
    """Stage 2: each firing rule's strength, its terms' degrees combined."""
    fis = inf.fis
    more = len(firing) - len(listed)
    and_prod = _choice(fis, "and_method", "min") == "prod"
    how = "multiplied (AND is prod)" if and_prod else "the smallest is taken (AND is min)"
    body = [
        f"<p class='fz-step-say'>In each rule the degrees of its terms are combined: "
        f"{how}. That is the rule's strength: <b>{len(firing)} of {len(fis.rules)} "
        "rules</b> have one above zero.</p><ul>"
    ]
    for r in listed:
        rule = fis.rules[r]
        clauses = _term_clause(inf, r)
        weight = f" × weight {rule.weight:g}" if rule.weight != 1.0 else ""
        body.append(
            f"<li class='fz-step-rule' data-rule='{r + 1}'>Rule {r + 1}: "
            + (" AND ".join(clauses))
            + f" → {'product' if and_prod else 'min'}{weight} = "
            f"<b>{_fmt_degree(float(inf.strengths[r]))}</b></li>"
        )
    body.append("</ul>")
    if more > 0:
        body.append(f"<p>… and {more} weaker rules.</p>")
    if not firing:
        body.append("<p><b>No rule fires</b>: the outputs will fall back.</p>")
    return body


def _implication(inf: Inference, listed) -> list[str]:
    """Stage 3: each firing rule's conclusion clipped at (or scaled by) its strength."""
    fis = inf.fis
    imp_prod = _choice(fis, "imp_method", "min") == "prod"
    how = (
        "scaled by its strength (implication prod)"
        if imp_prod
        else "clipped at its strength (implication min)"
    )
    body = [
        f"<p class='fz-step-say'>Each firing rule's conclusion, an output term, is {how}: "
        "one coloured set per rule below.</p><ul>"
    ]
    for n, r in enumerate(listed):
        rule = fis.rules[r]
        said = ", ".join(
            f"{html.escape(inf.output_labels[o])} is {html.escape(fis.outputs[o].terms[k].name)}"
            for o, k in enumerate(rule.consequent)
            if k is not None
        )
        body.append(
            f"<li class='fz-step-rule' data-rule='{r + 1}' style='color:"
            f"{COLOURS[n % len(COLOURS)]}'>Rule {r + 1} ({_fmt_degree(float(inf.strengths[r]))}): "
            f"{said}</li>"
        )
    body.append("</ul>")
    sets = {r: implied_sets(inf, r) for r in listed}
    for o in range(fis.n_outputs):
        curves = [
            (sets[r][o], COLOURS[n % len(COLOURS)]) for n, r in enumerate(listed) if o in sets[r]
        ]
        body.append(_plot(inf, o, curves))
    return body


def _aggregation(inf: Inference) -> list[str]:
    """Stage 4: the implied sets of each output combined into one."""
    fis = inf.fis
    agg = _choice(fis, "agg_method", "max")
    how = {
        "max": "the largest of the implied sets at each point (aggregation max)",
        "sum": "the implied sets added at each point (aggregation sum; it can pass 1)",
        "probor": "the implied sets combined by probabilistic OR, a + b − ab (aggregation probor)",
    }.get(agg, f"aggregation {html.escape(agg)}")
    peaks = ", ".join(
        f"{html.escape(inf.output_labels[o])} peaks at {float(np.max(inf.aggregate[o])):.2f}"
        for o in range(fis.n_outputs)
    )
    body = [f"<p class='fz-step-say'>For each output, one set: {how}. {peaks}.</p>"]
    for o in range(fis.n_outputs):
        body.append(_plot(inf, o, [], fill=inf.aggregate[o]))
    return body


def _defuzzification(inf: Inference) -> list[str]:
    """Stage 5: each aggregated set's one number (or the fallback)."""
    fis = inf.fis
    word = _defuzz_word(fis)
    crisp = ", ".join(
        f"<b>{html.escape(inf.output_labels[o])} = "
        f"{html.escape(_fmt_value(float(inf.centroids[o]), fis.outputs[o].unit or ''))}</b>"
        for o in range(fis.n_outputs)
    )
    fallback = [inf.output_labels[o] for o, f in enumerate(inf.fallback) if f]
    note = (
        f" No rule concludes on {html.escape(', '.join(fallback))}: the middle of its "
        "range (the fallback)."
        if fallback
        else ""
    )
    body = [
        f"<p class='fz-step-say'>Each aggregated set gives one number, its {word}: "
        f"{crisp}. These are the wheels' voltages the robot is sent.{note}</p>"
    ]
    for o in range(fis.n_outputs):
        body.append(_plot(inf, o, [], fill=inf.aggregate[o], line_at=float(inf.centroids[o])))
    return body
