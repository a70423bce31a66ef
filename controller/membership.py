"""The membership-function families: one table, :data:`SHAPES`, with MATLAB Fuzzy Logic
Toolbox names, parameter order and edge conventions.

Each family is one :class:`Shape`: its parameter names, the condition on them, ONE
vectorised numpy formula (parameters scalar or one set per row: the single-sample path
evaluates a family's terms as the rows of one call, the batch path a term's samples) and
its name in a MATLAB ``.fis`` file. The conditions, centres and ramps are small
expressions over the parameter names, parsed (never evaluated as Python). The
scalar engine (:class:`controller.fuzzy.FuzzySystem`), the batch engine
(:mod:`controller.fuzzy_batch`), the rule-base and ``.fis`` formats and the design rules
all read this table: a new family is one :class:`Shape` added here (or at run time with
:func:`register_shape`).

Conventions (MATLAB documentation of trimf, trapmf, linsmf, linzmf, gaussmf, gauss2mf):

* trimf [a b c], a <= b <= c: 0 for x <= a and x >= c, (x-a)/(b-a) on (a, b),
  (c-x)/(c-b) on (b, c), exactly 1 at x == b (so trimf with a == b is 0 left of a and
  jumps to 1 at a; with b == c it is 1 at b and 0 right of it).
* trapmf [a b c d], a <= b, c <= d: min(y1, y2) with y1 = 0 for x < a, (x-a)/(b-a) on
  [a, b), 1 for x >= b; y2 = 1 for x <= c, (d-x)/(d-c) on (c, d], 0 for x > d.
  (b > c is allowed, as in MATLAB: a triangle with a peak below 1.)
* linsmf [a b], a <= b: 0 for x < a, (x-a)/(b-a) on [a, b], 1 for x > b; with a == b a
  step: 0 for x < a, 1 for x >= a.
* linzmf [a b], a <= b: 1 for x < a, (b-x)/(b-a) on [a, b], 0 for x > b; with a == b a
  step: 1 for x < a, 0 for x >= a.
* gaussmf [sigma c], sigma > 0: exp(-(x-c)^2 / (2 sigma^2)).
* gauss2mf [sigma1 c1 sigma2 c2]: left Gaussian (sigma1, c1) for x < c1 (1 above),
  times right Gaussian (sigma2, c2) for x > c2 (1 below).

NaN input means "nothing sensed": every membership of NaN is 0 (all shapes).
+-inf inputs are accepted and give the limits (e.g. linzmf(-inf) = 1).

The formulas are the clipped ramps (fewer numpy operations than the piecewise
definitions above) and give the piecewise values to the last bit: with a < b,
(x-a)/(b-a) <= 1 for x <= b and >= 1 for x >= b after rounding (rounding is monotone),
so clipping the ramps to [0, 1] and taking their min gives exactly the piecewise values;
a degenerate side (a == b, ...) divides by zero into +-inf (a step) or NaN at its corner,
which the NaN-ignoring ``fmin``/``fmax`` settle (``fmax(y, x == b)`` is 1 at a peak, the
clip at 0 elsewhere, and 0 for NaN x); -(p/q) = p/(-q) exactly.
"""

from __future__ import annotations

import ast
import functools
import math
import operator
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

__all__ = [
    "Shape",
    "SHAPES",
    "quiet",
    "register_shape",
    "shape_for_matlab",
    "check_params",
    "trimf",
    "trapmf",
    "linsmf",
    "linzmf",
    "gaussmf",
    "gauss2mf",
]


def quiet() -> np.errstate:
    """numpy's warnings off, as around every call of a formula: what the formulas divide
    by zero or subtract infinities into (degenerate sides, +-inf input) is settled
    inside them."""
    return np.errstate(divide="ignore", invalid="ignore", over="ignore")


_BINARY = {
    ast.Add: operator.add,
    ast.Sub: operator.sub,
    ast.Mult: operator.mul,
    ast.Div: operator.truediv,
}
_UNARY: dict[type[ast.unaryop], Callable[[Any], Any]] = {
    ast.USub: operator.neg,
    ast.UAdd: operator.pos,
    ast.Not: operator.not_,
}
_COMPARE = {
    ast.Lt: operator.lt,
    ast.LtE: operator.le,
    ast.Gt: operator.gt,
    ast.GtE: operator.ge,
    ast.Eq: operator.eq,
    ast.NotEq: operator.ne,
}


_ALLOWED = (
    ast.Constant,
    ast.Name,
    ast.Load,
    ast.Tuple,
    ast.BinOp,
    ast.UnaryOp,
    ast.BoolOp,
    ast.Compare,
    ast.And,
    ast.Or,
    *_BINARY,
    *_UNARY,
    *_COMPARE,
)


class Expression:
    """A small expression over parameter names, parsed once and walked (never run as
    Python): numbers, the names, ``+ - * /``, comparisons (chained too), ``and``,
    ``or``, ``not`` and tuples, e.g. ``"a <= b <= c"`` or ``"(b - a, c - b)"``.

    Parameters
    ----------
    text : str
        The expression.
    names : tuple of str
        The names it may read.

    Raises
    ------
    ValueError
        A syntax error, a name not in ``names`` or another construct.
    """

    def __init__(self, text: str, names: tuple[str, ...]):
        self.text = text
        self.names = names
        try:
            self._tree = ast.parse(text.strip(), mode="eval").body
        except SyntaxError as e:
            raise ValueError(f"expression {text!r}: {e.msg}") from None
        for node in ast.walk(self._tree):
            if isinstance(node, ast.Name) and node.id not in names:
                raise ValueError(f"expression {text!r}: unknown name {node.id!r} (have {names})")
            if not isinstance(node, _ALLOWED):
                raise ValueError(f"expression {text!r}: {type(node).__name__} is not allowed")

    def __call__(self, values: Sequence[float]):
        """The expression's value for ``values`` (one per name, in order)."""
        return self._value(self._tree, dict(zip(self.names, values)))

    def _value(self, node: ast.AST, env: dict[str, float]):
        if isinstance(node, ast.Constant) and isinstance(node.value, int | float):
            return node.value
        if isinstance(node, ast.Name):
            return env[node.id]
        if isinstance(node, ast.Tuple):
            return tuple(self._value(n, env) for n in node.elts)
        if isinstance(node, ast.BinOp) and type(node.op) in _BINARY:
            return _BINARY[type(node.op)](self._value(node.left, env), self._value(node.right, env))
        if isinstance(node, ast.UnaryOp) and type(node.op) in _UNARY:
            return _UNARY[type(node.op)](self._value(node.operand, env))
        if isinstance(node, ast.BoolOp):
            values = (self._value(n, env) for n in node.values)
            return all(values) if isinstance(node.op, ast.And) else any(values)
        if isinstance(node, ast.Compare) and all(type(op) in _COMPARE for op in node.ops):
            left = self._value(node.left, env)
            for op, right_node in zip(node.ops, node.comparators):
                right = self._value(right_node, env)
                if not _COMPARE[type(op)](left, right):
                    return False
                left = right
            return True
        raise ValueError(f"expression {self.text!r}: {ast.unparse(node)!r} is not allowed")


@functools.lru_cache(maxsize=256)
def _expression(text: str, names: tuple[str, ...]) -> Expression:
    """A table's expression, parsed once."""
    return Expression(text, names)


@dataclass(frozen=True)
class Shape:
    """One membership-function family.

    Parameters
    ----------
    name : str
        The shape's name in rule bases and terms (``Term.shape``).
    param_names : tuple of str
        Its parameters, in MATLAB's order.
    requires : str
        The condition on the parameters, an :class:`Expression` over ``param_names``
        (e.g. ``"a <= b <= c"``); the parameters are finite numbers in any case.
    formula : callable
        ``formula(x, *params) -> memberships``, numpy: ``x`` a float array, (n,) or
        (n, k); each parameter a float or an array that broadcasts against ``x`` (one
        value per row). It must not write into ``x`` (into its own temporaries it may);
        NaN x must give 0; numpy's warnings are off around it.
    description : str
        One line for people.
    matlab : str or None
        The name MATLAB's ``.fis`` files give it (default: ``name``); None: the
        ``.fis`` writer refuses it.
    examples : tuple of parameter tuples
        Valid parameter sets, degenerate ones included, for the tests that hold the
        formula with one set and with a set per row to each other.
    centre : str
        Where a term of the family is most itself, an expression over ``param_names``
        (the design rules' centre; "" if it has no such point).
    ramps : str
        The lengths of its linear sides, a tuple expression over ``param_names`` (the
        design rules' widths).
    positions : bool
        Whether every parameter is a position on the variable's axis (a corner the
        viewer's Editor lets one drag); a width or a spread is not.
    """

    name: str
    param_names: tuple[str, ...]
    requires: str
    formula: Callable[..., np.ndarray]
    description: str
    matlab: str | None = ""
    examples: tuple[tuple[float, ...], ...] = ()
    centre: str = ""
    ramps: str = "()"
    positions: bool = False

    def __post_init__(self):
        if self.matlab == "":
            object.__setattr__(self, "matlab", self.name)
        for text in (self.requires, self.centre or "0", self.ramps):
            _expression(text, self.param_names)  # an error shows at once

    def _value(self, text: str, params: Sequence[float]):
        return _expression(text, self.param_names)(params)

    @property
    def n_params(self) -> int:
        """The number of parameters."""
        return len(self.param_names)

    @property
    def func(self) -> Callable[..., np.ndarray]:
        """``f(x, params)``: :meth:`evaluate` (the name the shape functions had)."""
        return self.evaluate

    def holds(self, params: Sequence[float]) -> bool:
        """Whether the parameters meet ``requires``.

        Parameters
        ----------
        params : sequence of float
            ``n_params`` finite numbers.
        """
        return bool(self._value(self.requires, params))

    def centre_of(self, params: Sequence[float]) -> float | None:
        """``centre`` for these parameters (None if the family has none).

        Parameters
        ----------
        params : sequence of float
            A valid parameter set.
        """
        return float(self._value(self.centre, params)) if self.centre else None

    def ramps_of(self, params: Sequence[float]) -> tuple[float, ...]:
        """``ramps`` for these parameters.

        Parameters
        ----------
        params : sequence of float
            A valid parameter set.
        """
        return tuple(float(v) for v in self._value(self.ramps, params))

    def _columns(self, x: np.ndarray, params) -> list:
        """The parameters as the formula takes them: floats for one set (P,), columns
        broadcasting against ``x`` for one set per row (n, P)."""
        p = np.asarray(params, dtype=float) + 0.0  # -0.0 is 0.0 (b - a = -0.0 would flip)
        if p.ndim == 1:
            return [float(v) for v in p]
        cols = [p[:, k] for k in range(p.shape[1])]
        if x.ndim == 2:
            cols = [c[:, None] for c in cols]
        return cols

    def evaluate(self, x, params) -> np.ndarray:
        """Memberships of ``x`` (vectorised; numpy's warnings off).

        Parameters
        ----------
        x : array_like
            The inputs; (n,) or (n, k) for parameters per row.
        params : array_like
            One parameter set (n_params,), or one per row of ``x`` (n, n_params).
            Not checked here (:func:`check_params` checks one set).

        Returns
        -------
        ndarray
            The memberships, shaped as ``x``.
        """
        x = np.asarray(x, dtype=float)
        flat = x.reshape(-1) if x.ndim == 0 else x
        with quiet():
            y = self.formula(flat, *self._columns(flat, params))
        return np.asarray(y).reshape(x.shape)


# --------------------------------------------------------------------------- formulas
# Each returns fresh arrays and may write its own temporaries in place.


def _trimf(x, a, b, c):
    y = np.subtract(x, a)
    y /= b - a
    right = np.subtract(c, x)
    right /= c - b
    np.minimum(y, right, out=y)
    return np.fmax(y, x == b, out=y)  # 1 at the peak (0/0 there if a side is flat), else >= 0


def _trapmf(x, a, b, c, d):
    y = np.subtract(x, a)
    y /= b - a
    right = np.subtract(d, x)
    right /= d - c
    np.fmin(y, right, out=y)
    np.fmax(y, (b <= x) & (x <= c), out=y)
    return np.fmin(y, 1.0, out=y)


def _linsmf(x, a, b):
    y = np.subtract(x, a)
    y /= b - a
    np.fmax(y, x >= b, out=y)
    return np.fmin(y, 1.0, out=y)


def _linzmf(x, a, b):
    y = np.subtract(b, x)
    y /= b - a
    np.fmax(y, 0.0, out=y)
    return np.fmin(y, 1.0, out=y)


def _gaussmf(x, sigma, c):
    y = np.subtract(x, c)
    np.multiply(y, y, out=y)
    y /= (-2.0 * sigma) * sigma  # -(2 sigma sigma) to the bit, a call less on arrays
    np.exp(y, out=y)
    return np.fmax(y, 0.0, out=y)


def _gauss2mf(x, sigma1, c1, sigma2, c2):
    d1 = x - c1
    d2 = x - c2
    e1 = np.where(x >= c1, 0.0, (d1 * d1) / -(2.0 * sigma1 * sigma1))
    e2 = np.where(x <= c2, 0.0, (d2 * d2) / -(2.0 * sigma2 * sigma2))
    y = np.exp(e1) * np.exp(e2)
    return np.fmax(y, 0.0, out=y)


# --------------------------------------------------------------------------- the table

SHAPES: dict[str, Shape] = {}


def register_shape(shape: Shape, *, replace: bool = False) -> Shape:
    """Add a family to :data:`SHAPES` (every engine and format reads it from there).

    Parameters
    ----------
    shape : Shape
        The family.
    replace : bool
        Whether it may replace a family of the same name.

    Returns
    -------
    Shape
        ``shape``.

    Raises
    ------
    ValueError
        The name is taken (and ``replace`` is false), or another family has its MATLAB
        name.
    """
    if not replace and shape.name in SHAPES:
        raise ValueError(f"membership function shape {shape.name!r} is registered already")
    if shape.matlab is not None:
        for other in SHAPES.values():
            if other.name != shape.name and other.matlab == shape.matlab:
                raise ValueError(f"MATLAB name {shape.matlab!r} belongs to {other.name!r}")
    SHAPES[shape.name] = shape
    return shape


def shape_for_matlab(name: str) -> Shape | None:
    """The family a ``.fis`` file calls ``name`` (None if none).

    Parameters
    ----------
    name : str
        The membership-function type as MATLAB writes it (``'trimf'``, ...).
    """
    for shape in SHAPES.values():
        if shape.matlab == name:
            return shape
    return None


for _shape in (
    Shape(
        "trimf",
        ("a", "b", "c"),
        "a <= b <= c",
        _trimf,
        "triangle: feet a, c; peak b",
        examples=((1.0, 3.0, 7.0), (0.0, 0.0, 1.0), (0.0, 1.0, 1.0), (1.0, 1.0, 1.0)),
        centre="b",
        ramps="(b - a, c - b)",
        positions=True,
    ),
    Shape(
        "trapmf",
        ("a", "b", "c", "d"),
        "a <= b and c <= d",
        _trapmf,
        "trapezoid: feet a, d; shoulders b, c",
        examples=(
            (1.0, 2.0, 4.0, 8.0),
            (1.0, 1.0, 5.0, 5.0),
            (0.0, 4.0, 1.0, 5.0),
            (2.0, 2.0, 1.0, 1.0),
            (1.0, 1.0, 1.0, 1.0),
        ),
        positions=True,
    ),
    Shape(
        "linsmf",
        ("a", "b"),
        "a <= b",
        _linsmf,
        "linear S: 0 below a, 1 above b",
        examples=((0.0, 2.0), (1.0, 1.0), (-0.28, 0.65)),
        centre="b",
        ramps="(b - a,)",
        positions=True,
    ),
    Shape(
        "linzmf",
        ("a", "b"),
        "a <= b",
        _linzmf,
        "linear Z: 1 below a, 0 above b",
        examples=((0.0, 2.0), (1.0, 1.0), (0.2, 1.0)),
        centre="a",
        ramps="(b - a,)",
        positions=True,
    ),
    Shape(
        "gaussmf",
        ("sigma", "c"),
        "sigma > 0",
        _gaussmf,
        "Gaussian: width sigma, centre c",
        examples=((0.7, 2.0), (2.3154188676032827, 11.1837778466314), (1e-170, 0.0), (1e200, 0.0)),
        centre="c",
    ),
    Shape(
        "gauss2mf",
        ("sigma1", "c1", "sigma2", "c2"),
        "sigma1 > 0 and sigma2 > 0",
        _gauss2mf,
        "two-sided Gaussian: left (sigma1, c1), right (sigma2, c2)",
        examples=((0.5, 1.0, 1.0, 2.0), (1.0, 2.0, 0.5, 1.0), (1e-170, 0.0, 1e200, 0.0)),
    ),
):
    register_shape(_shape)


def check_params(shape: str, params: Sequence[float]) -> tuple[float, ...]:
    """Validate a shape name and its parameters.

    Parameters
    ----------
    shape : str
        A name in :data:`SHAPES`.
    params : sequence of float
        Its parameters, in the family's order.

    Returns
    -------
    tuple of float
        The parameters.

    Raises
    ------
    ValueError
        With a message that says what is wrong (callers add where).
    """
    if shape not in SHAPES:
        raise ValueError(
            f"unknown membership function shape {shape!r} (supported: {', '.join(SHAPES)})"
        )
    sh = SHAPES[shape]
    try:
        vals = tuple(float(p) + 0.0 for p in params)  # -0.0 as 0.0: b - a = -0.0 flips
    except (TypeError, ValueError):
        raise ValueError(f"{shape} parameters must be numbers, got {params!r}") from None
    if len(vals) != sh.n_params:
        raise ValueError(
            f"{shape} takes {sh.n_params} parameters [{' '.join(sh.param_names)}], "
            f"got {len(vals)}: {list(params)!r}"
        )
    if not all(math.isfinite(v) for v in vals):
        raise ValueError(f"{shape} parameters must be finite, got {list(vals)!r}")
    if not sh.holds(vals):
        raise ValueError(f"{shape} needs {sh.requires}, got {list(vals)!r}")
    return vals


# MATLAB's names as functions f(x, params) (the table's evaluate, bound).
trimf = SHAPES["trimf"].evaluate
trapmf = SHAPES["trapmf"].evaluate
linsmf = SHAPES["linsmf"].evaluate
linzmf = SHAPES["linzmf"].evaluate
gaussmf = SHAPES["gaussmf"].evaluate
gauss2mf = SHAPES["gauss2mf"].evaluate
