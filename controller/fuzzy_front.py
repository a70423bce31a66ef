"""The single-sample path's generated front end (:meth:`FuzzySystem._agg_one`).

Kept for the bench row "fuzzy engine, one evaluation (bench/bench_fuzzy.py) <= 30 us" of
docs/speed.md (issue 24 item 6): per rule base, straight-line Python is generated and
exec'd that takes the input vector to the memberships, the firing strengths and the
consequent slots' levels. Measured on the paper's rule base, this front costs 8 us a
call against 90 us for the plain form (the scalar membership functions of
:mod:`controller.membership` called in loops over terms and rules), which would put one
evaluation near 110 us, far over the row's aim.

The code contains only variable names made here and float literals written with repr()
(which reads back exactly); the arithmetic is operation for operation the one of the
vectorised membership functions, so the results are identical to the batch path's.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np

__all__ = ["generate_front"]


def _literal(value: float) -> str:
    """A float as Python source for the generated single-sample code: repr() (which
    reads back exactly) for a finite number, names bound in its namespace for inf and
    NaN (repr gives 'inf', which is no Python literal)."""
    value = float(value)
    if math.isfinite(value):
        return repr(value)
    if math.isnan(value):
        return "_NAN"
    return "_INF" if value > 0 else "(-_INF)"


def _plain_divisor(value: float) -> bool:
    """Whether Python's float division by ``value`` is numpy's (not 0, not inf)."""
    return value != 0.0 and math.isfinite(value)


def _gauss_exp(d: float, den: float, clip: bool) -> float:
    """``exp(-(d * d) / den)`` with numpy's IEEE division (x / 0 is inf, 0 / 0 NaN, no
    exception), as the vectorised gaussmf/gauss2mf compute it when 2 sigma^2 under- or
    overflows; ``clip`` maps NaN to 0 as the batch gaussmf kernel's fmax does."""
    with np.errstate(all="ignore"):
        y = np.exp(-(np.float64(d) * np.float64(d)) / np.float64(den))
        return float(np.fmax(y, 0.0)) if clip else float(y)


def generate_front(system, per_rule: bool = False) -> Callable:
    """Generate straight-line Python for the single-sample path of ``system``:
    x -> the level of every consequent slot (max over its rules of the weighted firing
    strength), or with ``per_rule`` x -> every rule's weighted firing strength (the
    aggregation other than max, :mod:`controller.inference`, needs each rule's). The
    AND of a rule is ``system.inference.and_method``: min, or the product in input order.

    The code contains only variable names made here and float literals written with
    repr() (which reads back exactly); the arithmetic is operation for operation the
    one of the vectorised membership functions, so the results are identical."""
    lines = ["def front(x):"]
    n_in = len(system.inputs)
    lines.append(f"    if len(x) != {n_in}:")
    lines.append("        raise ValueError(_msg % len(x))")
    r = _literal
    for i, v in enumerate(system.inputs):
        xi = f"x{i}"
        lines.append(f"    {xi} = float(x[{i}])")
        body = []
        names = []
        for j, term in enumerate(v.terms):
            m = f"m{i}_{j}"
            names.append(m)
            p = term.params
            if term.shape == "trimf":
                a, b, c = p
                body.append(f"if {xi} == {r(b)}: {m} = 1.0")
                if a < b:
                    body.append(f"elif {r(a)} < {xi} < {r(b)}: {m} = ({xi} - {r(a)}) / {r(b - a)}")
                if b < c:
                    body.append(f"elif {r(b)} < {xi} < {r(c)}: {m} = ({r(c)} - {xi}) / {r(c - b)}")
                body.append(f"else: {m} = 0.0")
            elif term.shape == "trapmf":
                a, b, c, d = p
                body.append(f"if {xi} >= {r(b)}: y1 = 1.0")
                if a < b:
                    body.append(f"elif {r(a)} <= {xi}: y1 = ({xi} - {r(a)}) / {r(b - a)}")
                body.append("else: y1 = 0.0")
                body.append(f"if {xi} <= {r(c)}: y2 = 1.0")
                if c < d:
                    body.append(f"elif {xi} <= {r(d)}: y2 = ({r(d)} - {xi}) / {r(d - c)}")
                body.append("else: y2 = 0.0")
                body.append(f"{m} = y1 if y1 < y2 else y2")
            elif term.shape == "linsmf":
                a, b = p
                if a < b:
                    body.append(f"if {xi} > {r(b)}: {m} = 1.0")
                    body.append(f"elif {r(a)} <= {xi}: {m} = ({xi} - {r(a)}) / {r(b - a)}")
                    body.append(f"else: {m} = 0.0")
                else:
                    body.append(f"{m} = 1.0 if {xi} >= {r(a)} else 0.0")
            elif term.shape == "linzmf":
                a, b = p
                if a < b:
                    body.append(f"if {xi} < {r(a)}: {m} = 1.0")
                    body.append(f"elif {xi} <= {r(b)}: {m} = ({r(b)} - {xi}) / {r(b - a)}")
                    body.append(f"else: {m} = 0.0")
                else:
                    body.append(f"{m} = 1.0 if {xi} < {r(a)} else 0.0")
            elif term.shape == "gaussmf":
                s, c = p
                den = 2.0 * s * s
                body.append(f"d = {xi} - {r(c)}")
                if _plain_divisor(den):
                    body.append(f"{m} = _float(_exp(-(d * d) / {r(den)}))")
                else:  # 2 sigma^2 under- or overflows: numpy's IEEE division
                    body.append(f"{m} = _gauss_exp(d, {r(den)}, True)")
            elif term.shape == "gauss2mf":
                s1, c1, s2, c2 = p
                # a flat side is exactly 1.0, as the vectorised np.where gives
                den1, den2 = 2.0 * s1 * s1, 2.0 * s2 * s2
                g1 = (
                    f"_float(_exp(-(d * d) / {r(den1)}))"
                    if _plain_divisor(den1)
                    else f"_gauss_exp(d, {r(den1)}, False)"
                )
                g2 = (
                    f"_float(_exp(-(d * d) / {r(den2)}))"
                    if _plain_divisor(den2)
                    else f"_gauss_exp(d, {r(den2)}, False)"
                )
                body.append(f"if {xi} < {r(c1)}:")
                body.append(f"    d = {xi} - {r(c1)}")
                body.append(f"    y1 = {g1}")
                body.append("else: y1 = 1.0")
                body.append(f"if {xi} > {r(c2)}:")
                body.append(f"    d = {xi} - {r(c2)}")
                body.append(f"    y2 = {g2}")
                body.append("else: y2 = 1.0")
                body.append(f"{m} = y1 * y2")
            else:  # pragma: no cover - check_params guards this
                raise AssertionError(term.shape)
        # NaN: nothing sensed, every membership 0
        lines.append(f"    if {xi} != {xi}:")
        lines.append("        " + " = ".join(names + ["0.0"]))
        lines.append("    else:")
        lines += ["        " + b for b in body]
    # firing strengths
    row_name = {}
    for i, v in enumerate(system.inputs):
        for j in range(len(v.terms)):
            row_name[system._batch_terms_row(i, j)] = f"m{i}_{j}"
    for r_i, (rows, rule) in enumerate(zip(system._rule_rows, system.rules)):
        ms = [row_name[rw] for rw in rows]
        f = f"f{r_i}"
        if len(ms) == 1:
            lines.append(f"    {f} = {ms[0]}")
        elif system.inference.and_method == "prod":
            lines.append(f"    {f} = {' * '.join(ms)}")  # left to right, as np.multiply
        else:
            # numpy.minimum(a, b) semantics for non-NaN values: b if b < a else a
            lines.append(f"    {f} = {ms[1]} if {ms[1]} < {ms[0]} else {ms[0]}")
            for mm in ms[2:]:
                lines.append(f"    {f} = {mm} if {mm} < {f} else {f}")
        if system._weighted:
            lines.append(f"    {f} = {f} * {r(rule.weight)}")
    if per_rule:
        lines.append(f"    return [{', '.join(f'f{r_i}' for r_i in range(len(system.rules)))}]")
    else:
        lines += _slot_levels(system)
    src = "\n".join(lines) + "\n"
    # numpy's exp, as the vectorised gaussmf uses (math.exp differs in the last bit
    # for a few percent of arguments); on a float it runs the same loop
    ns: dict[str, Any] = {
        "_exp": np.exp,
        "_float": float,
        "_gauss_exp": _gauss_exp,
        "_INF": math.inf,
        "_NAN": math.nan,
        "_msg": f"expected {n_in} inputs {system.input_names}, got %d",
    }
    exec(compile(src, f"<fuzzy front {system.name}>", "exec"), ns)
    system._front_src = src
    return ns["front"]


def _slot_levels(system) -> list[str]:
    """The generated lines from the firing strengths f0.. to the slot levels."""
    lines = []
    # slot levels, term-major (k * n_out + o): the layout of system._mfgK4. The max
    # over a slot's rules is written as the comparisons max() makes (keep the first
    # of equals), which costs a third of a call to max() with many arguments.
    n_out, kmax = len(system.outputs), system._kmax
    used = dict(system._slot_rules)
    out = []
    for k in range(kmax):
        for o in range(n_out):
            rs = used.get(o * kmax + k)
            if not rs:
                out.append("0.0")
            elif len(rs) == 1:
                out.append(f"f{rs[0]}")
            else:
                lvl = f"l{k}_{o}"
                lines.append(f"    {lvl} = f{rs[1]} if f{rs[1]} > f{rs[0]} else f{rs[0]}")
                for q in rs[2:]:
                    lines.append(f"    {lvl} = f{q} if f{q} > {lvl} else {lvl}")
                out.append(lvl)
    lines.append(f"    return [{', '.join(out)}]")
    return lines
