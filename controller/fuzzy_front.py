"""The single-sample path's generated front end (:meth:`FuzzySystem._agg_one`).

Kept for the bench row "fuzzy engine, one evaluation (bench/bench_fuzzy.py) <= 30 us" of
docs/speed.md: per rule base, straight-line Python is generated and
exec'd that takes the input vector to the memberships, the firing strengths and the
consequent slots' levels. Measured on the paper's rule base (bench/bench_fuzzy.py), this
front costs 3 us a call; the memberships alone, computed by the families' numpy formulas
with a call per family (its terms as rows), cost 14 us, which with the firing strengths,
the levels and the 10 us of the grid aggregation would put one evaluation over the aim.

Each term's lines come from its family's scalar source in the table of
:mod:`controller.membership` (``Shape.scalar``): turned once per family into a template
(``x``, ``m`` and the temporaries renamed, every subexpression of the parameters alone
a slot), filled per term with the values of those subexpressions as float literals
written with repr() (which reads back exactly). A division by a slot that is zero
divides as IEEE (numpy) does, and so does one by an expression of ``x``
(:func:`_ieee_div`); every other operation of Python floats is numpy's, so the front's
memberships are the formula's bits (tests/test_membership_family.py holds every family's
source to its formula).
"""

from __future__ import annotations

import ast
import functools
import math
import re
import textwrap
from collections.abc import Callable
from types import CodeType
from typing import Any

import numpy as np

from .membership import SHAPES, check_params, quiet

__all__ = ["generate_front", "scalar_function"]

#: Names a family's scalar source may use besides ``x``, its parameters, temporaries and
#: builtins: numpy's functions on a float give their bits on an array.
SCALAR_NAMES: dict[str, Any] = {"exp": np.exp, "np": np}


def _ieee_div(p: float, q: float) -> float:
    """``p / q`` as numpy divides: by zero into +-inf (NaN for 0 / 0 and NaN / 0)."""
    if q != 0.0:
        return p / q
    if p != p or p == 0.0:
        return math.nan
    return math.copysign(math.inf, p) * math.copysign(1.0, q)


class _IEEEZero(float):
    """A zero divisor that divides as IEEE does (Python raises ZeroDivisionError):
    Python asks a float subclass on the right of ``/`` first."""

    def __rtruediv__(self, other):
        return _ieee_div(float(other), float(self))


def _literal(value: float) -> str:
    """A float as Python source for the generated single-sample code: repr() (which
    reads back exactly) for a finite number, in parentheses if negative, names bound in
    its namespace for inf and NaN (repr gives 'inf', which is no Python literal)."""
    value = float(value)
    if math.isfinite(value):
        text = repr(value)
        return f"({text})" if text.startswith("-") else text
    if math.isnan(value):
        return "_NAN"
    return "_INF" if value > 0 else "(-_INF)"


# The nodes of a subexpression of the parameters alone (a template's slot).
_ARITHMETIC = (ast.BinOp, ast.UnaryOp, ast.Name, ast.Constant, ast.Load, ast.operator, ast.unaryop)
_PLACEHOLDER = re.compile(r"\b(X__|M__|K__(\d+))\b")


class _Template:
    """A family's scalar source as a format string over ``{x}``, ``{m}`` and slots
    ``{k[i]}``, with each slot's subexpression of the parameters (and whether it divides)."""

    def __init__(self, scalar: str, param_names: tuple[str, ...]):
        tree = ast.parse(textwrap.dedent(scalar))
        self.params = param_names
        stored = (n for n in ast.walk(tree) if isinstance(n, ast.Name))
        self.temps = {n.id for n in stored if isinstance(n.ctx, ast.Store)} - {"m", "x"}
        self.slots: dict[str, int] = {}
        self.constants: list[CodeType] = []
        self.divisors: set[int] = set()
        tree = self._visit(tree)
        text = ast.unparse(tree).replace("{", "{{").replace("}", "}}")
        self.text = _PLACEHOLDER.sub(
            lambda g: {"X__": "{x}", "M__": "{m}"}.get(g.group(1), f"{{k[{g.group(2)}]}}"), text
        )

    def _of_params(self, node: ast.AST) -> bool:
        """Whether ``node`` is arithmetic on the parameters alone (and literals)."""
        nodes = list(ast.walk(node))
        return any(isinstance(n, ast.Name) for n in nodes) and all(
            isinstance(n, _ARITHMETIC) and (not isinstance(n, ast.Name) or n.id in self.params)
            for n in nodes
        )

    def _slot(self, node: ast.expr) -> ast.Name:
        key = ast.unparse(node)
        if key not in self.slots:
            self.slots[key] = len(self.constants)
            self.constants.append(compile(ast.Expression(node), "<slot>", "eval"))
        return ast.Name(f"K__{self.slots[key]}", ast.Load())

    def _visit(self, node):
        if isinstance(node, ast.expr) and self._of_params(node):
            return self._slot(node)
        if isinstance(node, ast.Name):
            if node.id == "x":
                node.id = "X__"
            elif node.id == "m":
                node.id = "M__"
            elif node.id in self.temps:
                node.id = f"t_{node.id}"
            return node
        for name, value in ast.iter_fields(node):
            if isinstance(value, list):
                setattr(
                    node, name, [self._visit(v) if isinstance(v, ast.AST) else v for v in value]
                )
            elif isinstance(value, ast.AST):
                setattr(node, name, self._visit(value))
        if isinstance(node, ast.BinOp) and isinstance(node.op, ast.Div):
            right = node.right
            if isinstance(right, ast.Name) and right.id.startswith("K__"):
                self.divisors.add(int(right.id[3:]))
            elif not (
                isinstance(right, ast.Constant)
                and isinstance(right.value, float | int)
                and right.value != 0
            ):
                return ast.Call(ast.Name("_div", ast.Load()), [node.left, right], [])
        return node

    def lines(self, params: tuple[float, ...], x: str, m: str) -> list[str]:
        """The family's lines for one term: input variable ``x``, membership into ``m``."""
        env = dict(zip(self.params, params))
        values = []
        for i, code in enumerate(self.constants):
            v = _constant(code, env)
            if v == 0.0 and i in self.divisors:
                values.append("_ZERO" if math.copysign(1.0, v) > 0 else "_NZERO")
            else:
                values.append(_literal(v))
        return self.text.format(x=x, m=m, k=values).splitlines()


def _constant(code: CodeType, env: dict[str, float]) -> float:
    """A slot's value: in Python floats, or numpy's where Python raises (division by
    zero, overflow); both are IEEE double arithmetic in the source's order."""
    try:
        return float(eval(code, {}, env))
    except (ZeroDivisionError, OverflowError):
        with quiet():
            return float(eval(code, {}, {k: np.float64(v) for k, v in env.items()}))


@functools.lru_cache(maxsize=64)
def _template(scalar: str, param_names: tuple[str, ...]) -> _Template:
    return _Template(scalar, param_names)


def _term_lines(shape: str, params: tuple[float, ...], x: str, m: str) -> list[str]:
    family = SHAPES[shape]
    return _template(family.scalar, family.param_names).lines(params, x, m)


_NAMESPACE: dict[str, Any] = {
    **SCALAR_NAMES,
    "_div": _ieee_div,
    "_ZERO": _IEEEZero(0.0),
    "_NZERO": _IEEEZero(-0.0),
    "_INF": math.inf,
    "_NAN": math.nan,
}


def scalar_function(shape: str, params) -> Callable[[float], float]:
    """One term's membership as the generated front computes it (for tests and checks).

    Parameters
    ----------
    shape : str
        A family of :data:`controller.membership.SHAPES`.
    params : sequence of float
        Its parameters (checked).

    Returns
    -------
    callable
        float -> float: the membership (0 for NaN, as the front's guard gives it).
    """
    body = _term_lines(shape, check_params(shape, params), "x", "m")
    src = "def f(x):\n    if x != x:\n        return 0.0\n"
    src += "".join(f"    {line}\n" for line in body) + "    return m\n"
    ns = dict(_NAMESPACE)
    exec(compile(src, f"<{shape} scalar>", "exec"), ns)
    return ns["f"]


def generate_front(system, per_rule: bool = False) -> Callable:
    """Generate straight-line Python for the single-sample path of ``system``.

    The memberships are the families' scalar sources (module docstring); the firing
    strengths and levels are min/max (exact) and products in input order, as the batch
    path computes them, so the results are identical.

    Parameters
    ----------
    system : FuzzySystem
        The compiled system (its rule rows and slots).
    per_rule : bool
        False: x -> the level of every consequent slot (max over its rules of the
        weighted firing strength); True: x -> every rule's weighted firing strength (the
        aggregation other than max, :mod:`controller.inference`, needs each rule's). The
        AND of a rule is ``system.inference.and_method``: min, or the product in input
        order.
    """
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
            body += _term_lines(term.shape, term.params, xi, m)
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
    ns = {**_NAMESPACE, "_msg": f"expected {n_in} inputs {system.input_names}, got %d"}
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
