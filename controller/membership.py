"""Membership functions with MATLAB Fuzzy Logic Toolbox names, parameter order and edge
conventions.

Each shape has two implementations that give bit-for-bit the same numbers:

* a vectorised one, ``f(x, params)`` on a numpy array (used for batches, for sampling the
  output terms on the defuzzification grid and for plots), and
* a scalar one, ``f_scalar(x, *params)`` in plain Python floats, used by the single-sample
  fast path of :class:`controller.fuzzy.FuzzySystem`.  The Gaussian shapes need ``exp``,
  and ``math.exp`` and ``numpy.exp`` differ in the last bit for a few percent of
  arguments, so the scalar Gaussian variants return the *exponent(s)* and the caller
  applies ``numpy.exp`` (see :func:`gaussmf_exponent`).

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
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

__all__ = [
    "trimf",
    "trapmf",
    "linsmf",
    "linzmf",
    "gaussmf",
    "gauss2mf",
    "trimf_scalar",
    "trapmf_scalar",
    "linsmf_scalar",
    "linzmf_scalar",
    "gaussmf_exponent",
    "gauss2mf_exponents",
    "Shape",
    "SHAPES",
    "check_params",
    "evaluate_mf",
]


def _arr(x) -> np.ndarray:
    return np.asarray(x, dtype=float)


# --------------------------------------------------------------------------- vectorised


def trimf(x, params: Sequence[float]) -> np.ndarray:
    """Triangular MF, params [a b c]."""
    a, b, c = (float(p) for p in params)
    x = _arr(x)
    y = np.zeros(x.shape)
    if a < b:
        y = np.where((a < x) & (x < b), (x - a) / (b - a), y)
    if b < c:
        y = np.where((b < x) & (x < c), (c - x) / (c - b), y)
    return np.where(x == b, 1.0, y)


def trapmf(x, params: Sequence[float]) -> np.ndarray:
    """Trapezoidal MF, params [a b c d]."""
    a, b, c, d = (float(p) for p in params)
    x = _arr(x)
    y1 = np.where(x >= b, 1.0, 0.0)
    if a < b:
        y1 = np.where((a <= x) & (x < b), (x - a) / (b - a), y1)
    y2 = np.where(x <= c, 1.0, 0.0)
    if c < d:
        y2 = np.where((c < x) & (x <= d), (d - x) / (d - c), y2)
    return np.minimum(y1, y2)


def linsmf(x, params: Sequence[float]) -> np.ndarray:
    """Linear S-shaped saturation MF (0 -> 1), params [a b] (foot, shoulder)."""
    a, b = (float(p) for p in params)
    x = _arr(x)
    if a < b:
        y = np.where(x > b, 1.0, 0.0)
        return np.where((a <= x) & (x <= b), (x - a) / (b - a), y)
    return np.where(x >= a, 1.0, 0.0)


def linzmf(x, params: Sequence[float]) -> np.ndarray:
    """Linear Z-shaped saturation MF (1 -> 0), params [a b] (shoulder, foot)."""
    a, b = (float(p) for p in params)
    x = _arr(x)
    if a < b:
        y = np.where(x < a, 1.0, 0.0)
        return np.where((a <= x) & (x <= b), (b - x) / (b - a), y)
    return np.where(x < a, 1.0, 0.0)


def gaussmf(x, params: Sequence[float]) -> np.ndarray:
    """Gaussian MF, params [sigma c] (MATLAB order: width first)."""
    sigma, c = (float(p) for p in params)
    x = _arr(x)
    d = x - c
    y = np.exp(-(d * d) / (2.0 * sigma * sigma))
    return np.where(np.isnan(x), 0.0, y)


def gauss2mf(x, params: Sequence[float]) -> np.ndarray:
    """Two-sided Gaussian MF, params [sigma1 c1 sigma2 c2]."""
    s1, c1, s2, c2 = (float(p) for p in params)
    x = _arr(x)
    d1 = x - c1
    d2 = x - c2
    y1 = np.where(x < c1, np.exp(-(d1 * d1) / (2.0 * s1 * s1)), 1.0)
    y2 = np.where(x > c2, np.exp(-(d2 * d2) / (2.0 * s2 * s2)), 1.0)
    return np.where(np.isnan(x), 0.0, y1 * y2)


# --------------------------------------------------------------------------- scalar
# Same arithmetic, operation by operation, as the vectorised versions above, so the
# results are identical to the last bit.  (x != x) is the NaN test.


def trimf_scalar(x: float, a: float, b: float, c: float) -> float:
    if x == b:
        return 1.0
    if a < x < b:
        return (x - a) / (b - a)
    if b < x < c:
        return (c - x) / (c - b)
    return 0.0


def trapmf_scalar(x: float, a: float, b: float, c: float, d: float) -> float:
    if x != x:
        return 0.0
    if x >= b:
        y1 = 1.0
    elif a <= x:  # and x < b, so a < b
        y1 = (x - a) / (b - a)
    else:
        y1 = 0.0
    if x <= c:
        y2 = 1.0
    elif x <= d:  # and x > c, so c < d
        y2 = (d - x) / (d - c)
    else:
        y2 = 0.0
    return y1 if y1 < y2 else y2


def linsmf_scalar(x: float, a: float, b: float) -> float:
    if a < b:
        if x > b:
            return 1.0
        if a <= x:  # and x <= b
            return (x - a) / (b - a)
        return 0.0
    return 1.0 if x >= a else 0.0


def linzmf_scalar(x: float, a: float, b: float) -> float:
    if a < b:
        if x < a:
            return 1.0
        if x <= b:  # and x >= a
            return (b - x) / (b - a)
        return 0.0
    return 1.0 if x < a else 0.0


def gaussmf_exponent(x: float, sigma: float, c: float) -> float:
    """The exponent of gaussmf; membership = numpy.exp(exponent) (NaN for NaN x)."""
    d = x - c
    return -(d * d) / (2.0 * sigma * sigma)


def gauss2mf_exponents(x: float, s1: float, c1: float, s2: float, c2: float) -> tuple[float, float]:
    """The two exponents of gauss2mf (0.0 for a side that is flat at 1)."""
    if x < c1:
        d1 = x - c1
        e1 = -(d1 * d1) / (2.0 * s1 * s1)
    else:
        e1 = 0.0
    if x > c2:
        d2 = x - c2
        e2 = -(d2 * d2) / (2.0 * s2 * s2)
    else:
        e2 = 0.0
    return e1, e2


# --------------------------------------------------------------------------- registry


@dataclass(frozen=True)
class Shape:
    name: str
    param_names: tuple[str, ...]
    func: Callable[[np.ndarray, Sequence[float]], np.ndarray]
    description: str

    @property
    def n_params(self) -> int:
        return len(self.param_names)


SHAPES: dict[str, Shape] = {
    s.name: s
    for s in (
        Shape("trimf", ("a", "b", "c"), trimf, "triangle: feet a, c; peak b"),
        Shape("trapmf", ("a", "b", "c", "d"), trapmf, "trapezoid: feet a, d; shoulders b, c"),
        Shape("linsmf", ("a", "b"), linsmf, "linear S: 0 below a, 1 above b"),
        Shape("linzmf", ("a", "b"), linzmf, "linear Z: 1 below a, 0 above b"),
        Shape("gaussmf", ("sigma", "c"), gaussmf, "Gaussian: width sigma, centre c"),
        Shape(
            "gauss2mf",
            ("sigma1", "c1", "sigma2", "c2"),
            gauss2mf,
            "two-sided Gaussian: left (sigma1, c1), right (sigma2, c2)",
        ),
    )
}


def check_params(shape: str, params: Sequence[float]) -> tuple[float, ...]:
    """Validate a shape name and its parameters; return them as a tuple of floats.

    Raises ValueError with a message that says what is wrong (callers add where).
    """
    if shape not in SHAPES:
        raise ValueError(
            f"unknown membership function shape {shape!r} (supported: {', '.join(SHAPES)})"
        )
    sh = SHAPES[shape]
    try:
        vals = tuple(float(p) for p in params)
    except (TypeError, ValueError):
        raise ValueError(f"{shape} parameters must be numbers, got {params!r}") from None
    if len(vals) != sh.n_params:
        raise ValueError(
            f"{shape} takes {sh.n_params} parameters [{' '.join(sh.param_names)}], "
            f"got {len(vals)}: {list(params)!r}"
        )
    if not all(math.isfinite(v) for v in vals):
        raise ValueError(f"{shape} parameters must be finite, got {list(vals)!r}")
    if shape == "trimf":
        a, b, c = vals
        if not (a <= b <= c):
            raise ValueError(f"trimf needs a <= b <= c, got {list(vals)!r}")
    elif shape == "trapmf":
        a, b, c, d = vals
        if not (a <= b and c <= d):
            raise ValueError(f"trapmf needs a <= b and c <= d, got {list(vals)!r}")
    elif shape in ("linsmf", "linzmf"):
        a, b = vals
        if not a <= b:
            raise ValueError(f"{shape} needs a <= b, got {list(vals)!r}")
    elif shape == "gaussmf":
        if not vals[0] > 0:
            raise ValueError(f"gaussmf needs sigma > 0, got {list(vals)!r}")
    elif shape == "gauss2mf":
        if not (vals[0] > 0 and vals[2] > 0):
            raise ValueError(f"gauss2mf needs sigma1 > 0 and sigma2 > 0, got {list(vals)!r}")
    return vals


def evaluate_mf(shape: str, x, params: Sequence[float]) -> np.ndarray:
    """Evaluate a membership function by shape name (vectorised)."""
    return SHAPES[shape].func(x, check_params(shape, params))


# --------------------------------------------------------------------------- fast kernels
# Used by the engine's batch path: fewer numpy operations than the MATLAB-style
# piecewise definitions above, and provably the same numbers to the last bit (the test
# suite checks it): with a < b, (x-a)/(b-a) <= 1 for x <= b and >= 1 for x >= b after
# rounding (rounding is monotone), so clipping the ramps to [0, 1] and taking their min
# gives exactly the piecewise values; fmax(NaN, 0) = 0 gives the NaN convention;
# -(p/q) = p/(-q) exactly. Degenerate parameters (a == b, ...) use the reference.


def fast_kernel(shape: str, params: Sequence[float]) -> Callable[[np.ndarray], np.ndarray]:
    """A function x (1-D float array) -> memberships, identical to SHAPES[shape].func."""
    p = check_params(shape, params)
    if shape == "trimf" and p[0] < p[1] < p[2]:
        a, b, c = p
        d1, d2 = b - a, c - b

        def k(x):
            y = np.minimum((x - a) / d1, (c - x) / d2)
            return np.fmax(y, 0.0, out=y)

        return k
    if shape == "trapmf" and p[0] < p[1] and p[2] < p[3]:
        a, b, c, d = p
        d1, d2 = b - a, d - c

        def k(x):
            y = np.minimum((x - a) / d1, (d - x) / d2)
            np.fmax(y, 0.0, out=y)
            return np.fmin(y, 1.0, out=y)

        return k
    if shape == "linsmf" and p[0] < p[1]:
        a, b = p
        d1 = b - a

        def k(x):
            y = (x - a) / d1
            np.fmax(y, 0.0, out=y)
            return np.fmin(y, 1.0, out=y)

        return k
    if shape == "linzmf" and p[0] < p[1]:
        a, b = p
        d1 = b - a

        def k(x):
            y = (b - x) / d1
            np.fmax(y, 0.0, out=y)
            return np.fmin(y, 1.0, out=y)

        return k
    if shape == "gaussmf":
        sigma, c = p
        negden = -(2.0 * sigma * sigma)

        def k(x):
            d = x - c
            y = np.multiply(d, d, out=d)
            np.divide(y, negden, out=y)
            np.exp(y, out=y)
            return np.fmax(y, 0.0, out=y)

        return k
    func = SHAPES[shape].func
    return lambda x: func(x, p)
