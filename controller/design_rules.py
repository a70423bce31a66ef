"""Design rules for the paper controller's membership functions: what a designer would
draw, checked on a rule base.

The paper prints Table 1, the ranges, the term names and the shape families (triangular,
linear S, linear Z, Gaussian), not the parameters (its Figs. 6-11 are missing). A
rule base that passes every rule below could have been drawn by hand in MATLAB's
Fuzzy Logic Designer; one that fails has a fault a reviewer would see in the figure:

``family``
    Only the paper's families: trimf, linsmf, linzmf, gaussmf; at least one gaussmf
    in the system (the paper's blend has Gaussians).
``peak``
    Every term reaches 1 inside its variable's universe (range).
``order``
    The terms are in linguistic order: VS < S < M < L < VL, near < medium < far,
    VN < N < Z < P < VP, by their centres (a triangle's peak, a Gaussian's centre, a
    shoulder's inner corner, where it first or last holds 1).
``width``
    No term narrower than :data:`MIN_WIDTH_FRACTION` (2 %) of its universe at half
    height (within the universe), and no linear ramp (a shoulder's or a triangle's
    side) shorter than that: a near-crisp edge is a switch, not a fuzzy set.
``overlap``
    Neighbouring terms share at least :data:`MIN_OVERLAP` (0.2) somewhere (the largest
    of ``min(mu_a, mu_b)`` over the universe), yet stay distinct: neither holds more
    than :data:`MAX_AT_NEIGHBOUR_CENTRE` (0.7) at the other's centre.
``coverage``
    Inputs only: at no point of the universe is every term below :data:`MIN_COVER`
    (0.1), so that some rule always fires (Table 1 has a rule for every pair of terms
    of each family).
``mirror``
    The angle inputs (phi_t, phi_o) are mirrored about zero: VN(x) = VP(-x),
    N(x) = P(-x), Z(x) = Z(-x).
``span``
    The terms span their universe: the first term's centre lies in the lower half of
    the universe, the last term's in the upper half; for a mirrored angle input, in the
    outer half of each side (VP's centre at least half the universe's upper end) (voltage terms that all stop at
    6 V of a -0.28..14 V universe leave the robot's top half of speeds unused).
``rates``
    Neighbours change at comparable rates: the graded part of each term (where it is
    neither 0 nor 1, measured as ``GRADED_LOW < mu < GRADED_HIGH`` within the universe)
    is within a factor :data:`MAX_RATE_RATIO` (4) of each neighbour's (a 0.13 rad ramp
    beside a 1.0 rad one is a near-crisp switch among fuzzy sets).
``wheels``
    One set of voltage terms for both wheels: the outputs ``left`` and ``right`` have
    the same range and the same terms (Table 1's rules are mirror images).

:func:`violations` lists every fault of a :class:`~fuzzynav.controller.fuzzy.FuzzySystem`
(empty: it passes); the memberships are sampled on a fine grid that includes every
shape's parameters, so a corner between samples is not missed.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from fuzzynav.controller.fuzzy import FuzzySystem, Term, Variable
from fuzzynav.controller.membership import SHAPES

__all__ = [
    "FAMILIES",
    "LINGUISTIC_ORDERS",
    "ANGLE_INPUTS",
    "MIN_WIDTH_FRACTION",
    "MIN_OVERLAP",
    "MAX_AT_NEIGHBOUR_CENTRE",
    "MIN_COVER",
    "MAX_RATE_RATIO",
    "Violation",
    "violations",
    "centre",
]

FAMILIES = ("trimf", "linsmf", "linzmf", "gaussmf")
#: The orders the paper's term names state (upper-cased).
LINGUISTIC_ORDERS = (
    ("VS", "S", "M", "L", "VL"),
    ("NEAR", "MEDIUM", "FAR"),
    ("VN", "N", "Z", "P", "VP"),
)
ANGLE_INPUTS = ("phi_t", "phi_o")
WHEELS = ("left", "right")
MIN_WIDTH_FRACTION = 0.02
MIN_OVERLAP = 0.2
MAX_AT_NEIGHBOUR_CENTRE = 0.7
MIN_COVER = 0.1
MAX_RATE_RATIO = 4.0
# what counts as "graded" (neither 0 nor 1): a Gaussian is never exactly either
GRADED_LOW, GRADED_HIGH = 0.01, 0.99
#: Samples per universe (plus every shape's parameters): 1e-4 of the range.
GRID_POINTS = 10_001
_HALF = 0.5
_TOL = 1e-9  # numerical slack on the comparisons (the shapes are exact to ~1e-16)


@dataclass(frozen=True)
class Violation:
    """One fault: the rule broken, where (variable, term) and by how much (detail)."""

    rule: str
    variable: str
    term: str
    detail: str

    def __str__(self) -> str:
        where = f"{self.variable}.{self.term}" if self.term else self.variable
        return f"[{self.rule}] {where}: {self.detail}"


def centre(term: Term) -> float:
    """Where a term is most itself (same units as its variable): a triangle's peak, a
    Gaussian's centre, a linear Z's last point at 1, a linear S's first point at 1
    (``Shape.centre`` of :data:`controller.membership.SHAPES`)."""
    value = SHAPES[term.shape].centre_of(term.params)
    if value is None:
        raise ValueError(f"term {term.name!r}: shape {term.shape!r} has no centre here")
    return value


def _ramps(term: Term) -> tuple[float, ...]:
    """Lengths of the term's linear sides (units of its variable)."""
    return SHAPES[term.shape].ramps_of(term.params)


def _grid(variable: Variable) -> np.ndarray:
    lo, hi = variable.range
    breaks = [q for t in variable.terms for q in t.params if lo <= q <= hi]
    if any(t.shape == "gaussmf" for t in variable.terms):
        # a Gaussian's half-height points, so the width is measured at them exactly
        breaks += [
            c + s * k
            for t in variable.terms
            if t.shape == "gaussmf"
            for s, c in [t.params]
            for k in (-math.sqrt(2 * math.log(2)), math.sqrt(2 * math.log(2)))
            if lo <= c + s * k <= hi
        ]
    return np.unique(np.concatenate([np.linspace(lo, hi, GRID_POINTS), breaks]))


def _measure(x: np.ndarray, inside: np.ndarray) -> float:
    """Length of the set where ``inside`` holds, from samples (trapezoid on the mask)."""
    dx = np.diff(x)
    both = inside[:-1] & inside[1:]
    return float(dx[both].sum())


def _order(names: list[str]) -> tuple[str, ...] | None:
    upper = [n.upper() for n in names]
    for order in LINGUISTIC_ORDERS:
        if upper == list(order):
            return order
    return None


def _variable_violations(variable: Variable, is_input: bool) -> list[Violation]:
    out: list[Violation] = []
    lo, hi = variable.range
    span = hi - lo
    min_width = MIN_WIDTH_FRACTION * span
    x = _grid(variable)
    mu = np.array([t(x) for t in variable.terms])
    name = variable.name

    def fault(rule: str, term: str, detail: str) -> None:
        out.append(Violation(rule, name, term, detail))

    for k, term in enumerate(variable.terms):
        if term.shape not in FAMILIES:
            fault("family", term.name, f"shape {term.shape} is not one of {', '.join(FAMILIES)}")
            continue
        if mu[k].max() < 1.0 - _TOL:
            fault("peak", term.name, f"never reaches 1 in [{lo:g}, {hi:g}] (max {mu[k].max():.3f})")
        width = _measure(x, mu[k] >= _HALF - _TOL)
        if width < min_width - _TOL:
            fault(
                "width",
                term.name,
                f"{width:.4g} wide at half height, under 2 % of the universe ({min_width:.4g})",
            )
        for ramp in _ramps(term):
            if ramp < min_width - _TOL:
                fault("width", term.name, f"a ramp of {ramp:.4g}, under 2 % ({min_width:.4g})")
    if any(t.shape not in FAMILIES for t in variable.terms):
        return out

    order = _order(variable.term_names)
    if order is None:
        fault("order", "", f"terms {variable.term_names} are not one of the paper's orders")
    centres: list[float] = [centre(t) for t in variable.terms]
    for k in range(len(centres) - 1):
        a, b = variable.terms[k], variable.terms[k + 1]
        if not centres[k] < centres[k + 1]:
            fault(
                "order",
                b.name,
                f"centre {centres[k + 1]:.4g} not above {a.name}'s {centres[k]:.4g}",
            )
        shared = float(np.minimum(mu[k], mu[k + 1]).max())
        if shared < MIN_OVERLAP - _TOL:
            fault("overlap", b.name, f"shares at most {shared:.3f} with {a.name} (< {MIN_OVERLAP})")
        for here, there in ((a, b), (b, a)):
            level = float(here(np.array([centre(there)]))[0])
            if level > MAX_AT_NEIGHBOUR_CENTRE + _TOL:
                fault(
                    "overlap",
                    here.name,
                    f"holds {level:.3f} at {there.name}'s centre "
                    f"{centre(there):.4g} (> {MAX_AT_NEIGHBOUR_CENTRE})",
                )
    # a mirrored input spans each half: its outer terms in the outer half of each side
    lower_middle, middle = (0.5 * lo, 0.5 * hi) if name in ANGLE_INPUTS else (0.5 * (lo + hi),) * 2
    if not centres[0] <= lower_middle + _TOL:
        fault(
            "span",
            variable.terms[0].name,
            f"the first term's centre {centres[0]:.4g} is above {lower_middle:.4g}, the "
            "middle of the universe (of its lower half, for a mirrored input)",
        )
    if not centres[-1] >= middle - _TOL:
        fault(
            "span",
            variable.terms[-1].name,
            f"the last term's centre {centres[-1]:.4g} is below {middle:.4g}: the terms "
            f"leave the upper half of [{lo:g}, {hi:g}] (of its upper half, for a mirrored "
            "input) unused",
        )
    graded = [_measure(x, (m > GRADED_LOW) & (m < GRADED_HIGH)) for m in mu]
    for k in range(len(graded) - 1):
        lower, upper = graded[k], graded[k + 1]
        if (
            min(lower, upper) <= 0.0
            or max(lower, upper) / min(lower, upper) > MAX_RATE_RATIO + _TOL
        ):
            fault(
                "rates",
                variable.terms[k + 1].name,
                f"graded over {upper:.4g} beside {variable.terms[k].name}'s {lower:.4g} "
                f"(more than {MAX_RATE_RATIO:g} times apart)",
            )
    if is_input:
        cover = mu.max(axis=0)
        worst = int(np.argmin(cover))
        if cover[worst] < MIN_COVER - _TOL:
            fault(
                "coverage",
                "",
                f"at {x[worst]:.4g} every term is under {MIN_COVER} (largest {cover[worst]:.3f})",
            )
    if name in ANGLE_INPUTS:
        mirrored = np.array([t(-x) for t in reversed(variable.terms)])
        gap = float(np.abs(mu - mirrored).max())
        if not math.isclose(lo, -hi) or gap > 1e-6:
            fault("mirror", "", f"not mirrored about 0 (largest difference {gap:.3g})")
    return out


def violations(system: FuzzySystem) -> list[Violation]:
    """Every design-rule fault of ``system`` (module doc); empty if it passes."""
    out: list[Violation] = []
    for variable in system.inputs:
        out += _variable_violations(variable, is_input=True)
    for variable in system.outputs:
        out += _variable_violations(variable, is_input=False)
    if not any(t.shape == "gaussmf" for v in system.inputs + system.outputs for t in v.terms):
        out.append(Violation("family", system.name, "", "no gaussmf term anywhere"))
    wheels = [v for v in system.outputs if v.name in WHEELS]
    if len(wheels) == 2:
        left, right = wheels
        if left.range != right.range or left.terms != right.terms:
            out.append(
                Violation("wheels", "right", "", "the wheels' voltage terms or ranges differ")
            )
    return out
