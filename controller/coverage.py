"""Holes in a rule base: where does no rule fire clearly?

A *hole* is a region of an input pair where the strongest rule that reads it fires
below a floor. In a hole MATLAB's no-rule fallback (the output range's middle) drives the
robot, or, for the obstacle inputs, a sensed obstacle steers nothing. Table 1 has two
families of rules, the target rules (d_t, phi_t) and the obstacle rules (d_o, phi_o),
and each must cover its own pair over the variables' whole ranges:

* the target grid: (d_t, phi_t) over their ranges, nothing sensed (d_o, phi_o NaN);
* the obstacle grid: (d_o, phi_o) over their ranges, the target 5 m ahead.

:func:`strongest_rules` gives the strongest rule of each family on each grid point.

A grid can miss a hole narrower than its step: two steep triangles that cross at 0.099
read 0.13 on a 0.02 rad grid. Table 1 has a rule, weight 1, for every pair of terms of
each family (5 x 5 target rules, 3 x 5 obstacle rules), so there the strongest rule at
``(a, b)`` is exactly ``min(envelope_A(a), envelope_B(b))``, with ``envelope`` the
largest membership of any term of one input (:func:`envelope`). One input at a time,
that is cheap to evaluate on a fine grid, at every shape's breakpoints and 200 times
finer round every local minimum (1e-4 for the paper's slopes): :func:`weakest_cover` and
:func:`coverage_shortfall` (one number for a tuning cost, zero when every input is
covered at the floor) use it.
"""

from __future__ import annotations

import math

import numpy as np

from fuzzynav.controller.fuzzy import FuzzySystem

#: The floor the paper controller's rule bases are held to (issue: "the strongest rule
#: fires at >= 0.1").
MIN_STRONGEST = 0.1
FAMILIES = {"target": ("d_t", "phi_t"), "obstacle": ("d_o", "phi_o")}
_FILL = {"target": {"d_o": math.nan, "phi_o": math.nan}, "obstacle": {"d_t": 5.0, "phi_t": 0.0}}


def family_rules(system: FuzzySystem, family: str) -> np.ndarray:
    """Indices of the rules that read exactly the family's two inputs."""
    names = system.input_names
    wanted = {names.index(n) for n in FAMILIES[family]}
    return np.array(
        [
            i
            for i, rule in enumerate(system.rules)
            if {k for k, term in enumerate(rule.antecedent) if term is not None} == wanted
        ],
        dtype=int,
    )


def grid(
    system: FuzzySystem,
    family: str,
    n_distance: int = 301,
    n_angle: int = 601,
    max_angle_rad: float = math.inf,
):
    """The family's grid: an (n_distance * n_angle, 4) array of inputs, without the
    points whose angle exceeds ``max_angle_rad`` in magnitude."""
    distance_name, angle_name = FAMILIES[family]
    variables = {v.name: v for v in system.inputs}
    distances = np.linspace(*variables[distance_name].range, n_distance)
    angles = np.linspace(*variables[angle_name].range, n_angle)
    d, a = np.meshgrid(distances, angles, indexing="ij")
    columns = {distance_name: d.ravel(), angle_name: a.ravel()}
    columns.update({k: np.full(d.size, v) for k, v in _FILL[family].items()})
    points = np.column_stack([columns[n] for n in system.input_names])
    return points[np.abs(columns[angle_name]) <= max_angle_rad]


def strongest_rules(
    system: FuzzySystem,
    family: str,
    n_distance: int = 301,
    n_angle: int = 601,
    max_angle_rad: float = math.inf,
) -> tuple[np.ndarray, np.ndarray]:
    """(grid, strongest firing strength of the family's rules at each grid point)."""
    points = grid(system, family, n_distance, n_angle, max_angle_rad)
    rules = family_rules(system, family)
    if rules.size == 0:
        raise ValueError(f"{system.name}: no rule reads exactly {FAMILIES[family]}")
    return points, system.firing_strengths(points)[:, rules].max(axis=1)


def _complete(system: FuzzySystem, family: str) -> bool:
    """Whether the family has one weight-1 rule for every pair of its inputs' terms."""
    names = system.input_names
    index = [names.index(n) for n in FAMILIES[family]]
    sizes = [len(system.inputs[i].terms) for i in index]
    rules = [system.rules[i] for i in family_rules(system, family)]
    pairs = {tuple(r.antecedent[i] for i in index) for r in rules if r.weight == 1.0}
    return len(pairs) == sizes[0] * sizes[1]


def envelope(
    system: FuzzySystem, name: str, n_points: int = 20001, max_abs: float = math.inf
) -> tuple[np.ndarray, np.ndarray]:
    """(x, largest membership of any term of input ``name`` at x) over the input's range
    (within ``|x| <= max_abs``), on a fine grid plus every shape's parameters."""
    k = system.input_names.index(name)
    variable = system.inputs[k]
    lo, hi = variable.range
    lo, hi = max(lo, -max_abs), min(hi, max_abs)
    breaks = [p for t in variable.terms for p in t.params if lo <= p <= hi]
    x = np.unique(np.concatenate([np.linspace(lo, hi, n_points), breaks]))
    cover = _largest_membership(system, k, x)
    # A minimum between two samples (two slopes crossing) is found by sampling the
    # neighbourhood of every sampled local minimum 200 times finer.
    c, left, right = cover[1:-1], cover[:-2], cover[2:]
    dips = ((c < left) & (c <= right)) | ((c <= left) & (c < right))
    inner = np.flatnonzero(dips) + 1
    if inner.size:
        fine = np.concatenate([np.linspace(x[i - 1], x[i + 1], 401) for i in inner])
        x = np.unique(np.concatenate([x, fine]))
        cover = _largest_membership(system, k, x)
    return x, cover


def _largest_membership(system: FuzzySystem, k: int, x: np.ndarray) -> np.ndarray:
    X = np.full((len(x), len(system.inputs)), math.nan)
    X[:, k] = x
    return system.memberships(X)[k].max(axis=1)


def weakest_cover(system: FuzzySystem, family: str, max_angle_rad: float = math.inf) -> float:
    """The smallest strength at which the family's strongest rule fires anywhere in its
    inputs' ranges (the angle within ``max_angle_rad``); from the envelopes for a
    complete family (module doc), else the minimum on the default grid."""
    if not _complete(system, family):
        return float(strongest_rules(system, family, max_angle_rad=max_angle_rad)[1].min())
    distance_name, angle_name = FAMILIES[family]
    return float(
        min(
            envelope(system, distance_name)[1].min(),
            envelope(system, angle_name, max_abs=max_angle_rad)[1].min(),
        )
    )


def coverage_shortfall(
    system: FuzzySystem,
    floor: float = MIN_STRONGEST,
    obstacle_sector_rad: float = math.inf,
    n_distance: int = 201,
    n_angle: int = 401,
) -> float:
    """Sum over both families of (largest shortfall below ``floor`` + 10 x the mean
    shortfall), the obstacle angle within ``|phi_o| <= obstacle_sector_rad``. For a
    complete family (module doc) the shortfalls are those of each input's envelope;
    else those of the strongest rule on the (n_distance x n_angle) grid. The mean
    term grades a hole by its size, so that a search is led out of it even while the
    worst point stays at zero."""
    total = 0.0
    for family in FAMILIES:
        sector = obstacle_sector_rad if family == "obstacle" else math.inf
        if _complete(system, family):
            distance_name, angle_name = FAMILIES[family]
            covers = [
                envelope(system, distance_name)[1],
                envelope(system, angle_name, max_abs=sector)[1],
            ]
        else:
            covers = [strongest_rules(system, family, n_distance, n_angle, sector)[1]]
        for cover in covers:
            gap = np.maximum(0.0, floor - cover)
            total += float(gap.max()) + 10.0 * float(gap.mean())
    return total
