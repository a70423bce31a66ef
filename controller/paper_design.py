"""The paper controller's membership functions as a designer would draw them: 12 numbers.

Every variable is a fuzzy partition of the paper's shapes laid out by a few numbers, each
a centre, a spacing or a growth ratio that can be read off the figure; any vector within
the bounds passes the design rules of :mod:`fuzzynav.controller.design_rules` by
construction (``tests/test_paper_design.py`` draws vectors to show it), so an optimiser
cannot trade a rule away.

A partition over ordered centres ``c_0 < ... < c_n``: the first term a linear Z whose
ramp runs from ``c_0`` to ``c_1``, the last a linear S from ``c_{n-1}`` to ``c_n``, each
inner term a triangle with its feet on its neighbours' centres, except the middle one
of the inputs, a Gaussian (the paper's blend has Gaussians) whose width puts it at 0.5
half-way to its neighbours' centres (sigma = mean spacing / (2 sqrt(2 ln 2))). Then
neighbours cross at 0.5 (overlap >= 0.2), hold 0 (a Gaussian: 1/16 or less) at each
other's centres (distinct), and some term holds >= 0.5 everywhere (no hole).

Parameters (:data:`DESIGN_PARAMETERS`; metres, radians, volts):

* ``d_t`` (3): ``c0``, where VS stops holding 1; ``top``, where VL starts holding 1;
  ``r``, the growth of each spacing over the one before (far distances need less
  resolution). Centres ``c0, c0 + h, c0 + h (1 + r), ..., top`` with ``h`` set so that
  the last is ``top``.
* ``d_o`` (2): ``near``, where "near" stops holding 1; ``far``, where "far" holds 1
  (<= 3 m, the sensing limit); "medium" half-way.
* ``phi_t`` (2) and ``phi_o`` (2), mirrored (Table 1 is): ``vp``, where VP holds 1 (VN
  at ``-vp``), in the upper half of the positive half-universe (the ``span`` rule on a
  mirrored input); ``q``, how much further out than P's centre, as a multiple of it
  (P at ``vp / (1 + q)``, N mirrored). Z is a Gaussian at 0.
* the outputs (3), one set for both wheels: ``e0``, where VS holds 1 (the slow wheel of a
  turn); ``top``, where VL holds 1; ``r``, the growth of the spacing from one term to the
  next (centres ``e0 + g (1 + r + ... )`` with ``g`` set so that the last is ``top``).
  Output terms are triangles and shoulders (no Gaussian: a Gaussian never vanishes, so
  a rule firing at 0.01 clips it into a thin slab over the whole range that drags the
  centroid).

The bounds keep every width at or above 2 % of its universe and every centre inside it.
"""

from __future__ import annotations

import math

import numpy as np

from fuzzynav.controller.paper_partition import TableOneTunable

_SIGMA_PER_SPACING = 1.0 / (2.0 * math.sqrt(2.0 * math.log(2.0)))

# name, lower, upper, start (a hand layout: turns from +-0.9 rad, obstacles felt from
# 2.4 m at +-0.6 rad, a slow wheel near 0 V and a top speed near 10 V). The bounds keep the design
# rules by construction, ``span`` and ``rates`` included: ``span`` (d_t's VL and the
# wheels' VL in the upper half of their universes: ``d_t.top`` >= 14.5 m of [-1.13, 30],
# ``v.top`` >= 7 V of [-0.28, 14]; an angle's VP in the upper half of [0, max], ``phi_*.vp``)
# and ``rates`` (an angle's outer ramp from once to 8 times its inner spacing, ``phi_*.q``; d_t's and the wheels' growth ratios keep each
# term's graded part within 4x of its neighbours'); every ramp stays >= 2 % of its
# universe (``width``: hence q >= 1 and d_t.r <= 2.2).
DESIGN_PARAMETERS: list[tuple[str, float, float, float]] = [
    ("d_t.c0", -0.8, 1.5, 0.3),
    ("d_t.top", 14.5, 30.0, 20.0),
    ("d_t.r", 1.0, 2.2, 1.5),
    ("d_o.near", 0.0, 1.4, 0.5),
    ("d_o.far", 1.6, 3.0, 2.4),
    ("phi_t.vp", math.pi, 2.0 * math.pi, 3.5),
    ("phi_t.q", 1.0, 8.0, 3.0),
    ("phi_o.vp", 0.5 * math.pi, math.pi, 1.8),
    ("phi_o.q", 1.0, 8.0, 2.0),
    ("v.e0", -0.15, 1.0, 0.3),
    ("v.top", 7.0, 14.0, 10.0),
    ("v.r", 0.6, 2.0, 1.0),
]


def _spaced(start: float, first: float, ratio: float, n: int) -> list[float]:
    """``n`` centres from ``start``: spacings ``first, first r, first r^2, ...``."""
    out = [start]
    for k in range(n - 1):
        out.append(out[-1] + first * ratio**k)
    return out


def design_partition(centres, gaussian_middle: bool) -> list[tuple[str, tuple[float, ...]]]:
    """Shapes of a partition over increasing ``centres`` (module doc)."""
    c = [float(x) for x in centres]
    if len(c) < 3 or any(b <= a for a, b in zip(c, c[1:])):
        raise ValueError(f"centres must be at least three and increasing, got {c}")
    middle = len(c) // 2
    terms: list[tuple[str, tuple[float, ...]]] = [("linzmf", (c[0], c[1]))]
    for k in range(1, len(c) - 1):
        if gaussian_middle and k == middle:
            sigma = (c[k + 1] - c[k - 1]) / 2.0 * _SIGMA_PER_SPACING
            terms.append(("gaussmf", (sigma, c[k])))
        else:
            terms.append(("trimf", (c[k - 1], c[k], c[k + 1])))
    terms.append(("linsmf", (c[-2], c[-1])))
    return terms


def _mirrored(vp: float, q: float) -> list[float]:
    """VP at ``vp``, P at ``vp / (1 + q)``; N and VN mirrored."""
    p = vp / (1.0 + q)
    return [-vp, -p, 0.0, p, vp]


def output_centres(e0: float, top: float, ratio: float) -> list[float]:
    """Five centres from ``e0`` to ``top``, spacings growing by ``ratio`` (the wheels'
    VS .. VL, and d_t's)."""
    first = (top - e0) / sum(ratio**k for k in range(4))
    return _spaced(e0, first, ratio, 5)


class PaperDesignTunable(TableOneTunable):
    """Table 1 with designer-drawn partitions (module doc): 12 numbers."""

    PARAMETERS = DESIGN_PARAMETERS
    #: the bounds keep it inside the design rules: no cost for holes is needed
    holes_penalised = False
    DESCRIPTION = (
        "Pahlavan & Khankalantary fuzzy navigator, Table 1 rules; "
        "membership functions drawn by design rules, 12 numbers fitted by fuzzynav "
        "(not from the paper)"
    )
    HEADER = (
        "# The fuzzy navigator of Pahlavan & Khankalantary (paper section 3, Table 1).",
        "#",
        "# From the paper: inputs, outputs, ranges, term names, shape families, Mamdani",
        "# min/max/centroid and the 40 rules of Table 1 (weight 1), unchanged.",
        "# NOT from the paper: the membership parameters. Each input and the wheels' voltage",
        "# are partitions drawn from 12 numbers (controller/paper_design.py) that keep the",
        "# design rules of controller/design_rules.py; the numbers were fitted as below.",
        "# Sign convention: phi > 0 = target/obstacle on the LEFT. d_o NaN = nothing sensed.",
        "#",
    )

    def terms(self, vector) -> dict[str, list[tuple[str, tuple[float, ...]]]]:
        return design_terms(self._vector(vector))


def design_terms(v) -> dict[str, list[tuple[str, tuple[float, ...]]]]:
    """Every variable's shapes from the 12 numbers of :data:`DESIGN_PARAMETERS`."""
    outputs = design_partition(output_centres(v[9], v[10], v[11]), gaussian_middle=False)
    return {
        "d_t": design_partition(output_centres(v[0], v[1], v[2]), gaussian_middle=True),
        "d_o": design_partition([v[3], (v[3] + v[4]) / 2.0, v[4]], gaussian_middle=True),
        "phi_t": design_partition(_mirrored(v[5], v[6]), gaussian_middle=True),
        "phi_o": design_partition(_mirrored(v[7], v[8]), gaussian_middle=True),
        "left": outputs,
        "right": outputs,
    }


def corners(tunable: PaperDesignTunable | None = None) -> np.ndarray:
    """Every corner of the bounds box (2^12 vectors): where the rules are tightest."""
    t = tunable or PaperDesignTunable()
    lo, hi = np.array(t.bounds()).T
    n = len(lo)
    bits = (np.arange(2**n)[:, None] >> np.arange(n)) & 1
    return np.where(bits == 1, hi, lo)


#: The range clues' layout drops the two first centres it fixes (below).
CLUE_PARAMETERS: list[tuple[str, float, float, float]] = [
    p for p in DESIGN_PARAMETERS if p[0] not in ("d_t.c0", "v.e0")
]


def _from_edge(edge: float, top: float, ratio: float) -> list[float]:
    """0, then four centres from ``edge`` to ``top``, spacings growing by ``ratio``."""
    first = (top - edge) / sum(ratio**k for k in range(3))
    return [0.0, *_spaced(edge, first, ratio, 4)]


class PaperCluesTunable(PaperDesignTunable):
    """The layout the printed ranges hint at: d_t's universe starts at -1.13 m and the
    wheels' at -0.28 V, the lower foot of a first term centred on 0, as a designer's
    tool leaves it. d_t's VS and the wheels' VS are triangles on 0 with their feet on
    the printed lower edge and its mirror (so S sits at 1.13 m and 0.28 V); the other
    centres as in :class:`PaperDesignTunable`, which this shares everything else with:
    10 numbers. Its output VS's 0.28 V ramps sit under the ``width`` rule's 2 % of the
    universe (0.2856 V): the clue and that design rule cannot both hold."""

    PARAMETERS = CLUE_PARAMETERS

    def terms(self, vector) -> dict[str, list[tuple[str, tuple[float, ...]]]]:
        v = dict(zip(self.parameter_names(), self._vector(vector)))
        full = [v.get(name, 0.0) for name, *_ in DESIGN_PARAMETERS]
        out = design_terms(full)
        for name, top, ratio in (("d_t", "d_t.top", "d_t.r"), ("left", "v.top", "v.r")):
            edge = -self._range(name)[0]
            shapes = design_partition(_from_edge(edge, v[top], v[ratio]), name == "d_t")
            shapes[0] = ("trimf", (-edge, 0.0, edge))
            out[name] = shapes
        out["right"] = out["left"]
        return out

    def _range(self, name: str) -> tuple[float, float]:
        system = self._template
        return next(x for x in system.inputs + system.outputs if x.name == name).range
