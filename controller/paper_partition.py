"""The paper controller's membership functions as fuzzy partitions: no holes by design.

The paper gives Table 1 (40 rules), the ranges, term names and shape kinds, but not the
membership parameters (its Figs. 6-11 are missing). This parametrisation lays every
input out as a *Ruspini partition*: ordered centres ``c_0 < c_1 < ... < c_n``, each
inner term a triangle whose feet are its neighbours' centres, the outer terms linear
shoulders (``linzmf`` below ``c_1``, ``linsmf`` above ``c_{n-1}``). At every input the
memberships sum to 1, so the strongest term holds at least 0.5 and, since Table 1 has a
rule for every pair of terms (25 target rules d_t x phi_t, 15 obstacle rules
d_o x phi_o), the strongest rule fires at >= 0.5 everywhere: MATLAB's no-rule fallback
can never act, and the crisp output is a continuous function of the inputs.

Parameters (:data:`PARTITION_PARAMETERS`, 22 numbers, each a positive width or an
origin, so every vector in the bounds is a valid, ordered system):

* ``d_t``: ``c0`` and four widths -> VS, S, M, L, VL at ``c0 .. c4`` (metres).
* ``d_o``: ``b0`` and two widths -> near, medium, far at ``b0 .. b2`` (metres; beyond
  3 m nothing is sensed and no obstacle rule fires).
* ``phi_t`` and ``phi_o``, mirror-symmetric (Table 1 is): ``p1`` and a width ->
  centres ``-p2, -p1, 0, p1, p2`` for VN, N, Z, P, VP (radians).
* outputs ``left`` and ``right`` (shared: the rules are mirror images): ``e0`` and four
  gaps -> triangle centres ``e0 .. e4`` (volts) for VS .. VL, and a half-width per term.
  Output sets need not cover anything; their centroids and areas set the voltages.

This layout made an earlier paper-geometry rule base (with a fitted start
heading); its output sets need not overlap and its triangles may be spikes, so it can
break the design rules of :mod:`fuzzynav.controller.design_rules`. Today's rule base is
drawn from :mod:`fuzzynav.controller.paper_design`; :class:`TableOneTunable`, the base
every layout shares, lives here.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from fuzzynav.controller.fis_controller import FisController
from fuzzynav.controller.fuzzy import FuzzySystem
from fuzzynav.controller.rulebase import dumps_toml, read_toml
from fuzzynav.resources import asset_path

TEMPLATE = asset_path("rules", "paper_first_design.toml")

# name, lower, upper, starting value (a hand layout: speeds of a few volts, turns at
# +-0.3 rad, obstacles felt from 1.5 m).
PARTITION_PARAMETERS: list[tuple[str, float, float, float]] = [
    ("d_t.c0", -1.13, 1.5, 0.3),  # the paper's d_t range starts at -1.13 m
    ("d_t.w1", 0.2, 4.0, 1.0),
    ("d_t.w2", 0.3, 6.0, 2.0),
    ("d_t.w3", 0.3, 8.0, 3.0),
    ("d_t.w4", 0.5, 12.0, 4.0),
    ("d_o.b0", 0.0, 1.5, 0.4),
    ("d_o.w1", 0.1, 2.0, 0.8),
    ("d_o.w2", 0.1, 2.5, 1.0),
    ("phi_t.p1", 0.03, 1.5, 0.3),
    ("phi_t.w", 0.05, 3.0, 0.6),
    ("phi_o.p1", 0.03, 1.5, 0.4),
    ("phi_o.w", 0.05, 2.5, 0.8),
    ("v.e0", -0.28, 3.0, 0.5),
    ("v.g1", 0.2, 5.0, 1.0),
    ("v.g2", 0.2, 5.0, 1.0),
    ("v.g3", 0.2, 5.0, 1.5),
    ("v.g4", 0.2, 6.0, 2.0),
    ("v.h0", 0.2, 4.0, 1.0),
    ("v.h1", 0.2, 4.0, 1.0),
    ("v.h2", 0.2, 4.0, 1.0),
    ("v.h3", 0.2, 4.0, 1.5),
    ("v.h4", 0.2, 6.0, 2.0),
]


def partition(centres) -> list[tuple[str, tuple[float, ...]]]:
    """Shapes of a Ruspini partition over ordered ``centres`` (at least two)."""
    c = [float(x) for x in centres]
    if len(c) < 2 or any(b <= a for a, b in zip(c, c[1:])):
        raise ValueError(f"partition centres must be increasing, got {c}")
    terms: list[tuple[str, tuple[float, ...]]] = [("linzmf", (c[0], c[1]))]
    terms += [("trimf", (c[k - 1], c[k], c[k + 1])) for k in range(1, len(c) - 1)]
    terms.append(("linsmf", (c[-2], c[-1])))
    return terms


def _mirrored(p1: float, width: float) -> list[float]:
    p2 = p1 + width
    return [-p2, -p1, 0.0, p1, p2]


class TableOneTunable:
    """What every parametrisation of Table 1's membership functions shares: a template
    rule base (rules, ranges, names) whose shapes :meth:`terms` fills in from a bounded
    vector. Subclasses give ``PARAMETERS`` ((name, low, high, start) rows), ``terms``
    and the header lines that say where the numbers come from."""

    name = "paper"
    #: ``fuzzynav tune`` adds a cost for holes (app/experiments/objective.py): Table 1's two rule
    #: families must each cover their inputs (controller/coverage.py).
    holes_penalised = True
    PARAMETERS: list[tuple[str, float, float, float]] = []
    DESCRIPTION = ""
    HEADER: tuple[str, ...] = ()

    def __init__(self, template: str | Path = TEMPLATE):
        self.template_path = Path(template)
        self._template = read_toml(self.template_path)
        self._shaped_template: FuzzySystem | None = None

    def parameter_names(self) -> list[str]:
        return [p[0] for p in self.PARAMETERS]

    def initial_vector(self) -> np.ndarray:
        return np.array([p[3] for p in self.PARAMETERS])

    def bounds(self) -> list[tuple[float, float]]:
        return [(p[1], p[2]) for p in self.PARAMETERS]

    def terms(self, vector) -> dict[str, list[tuple[str, tuple[float, ...]]]]:
        raise NotImplementedError

    def _vector(self, vector) -> np.ndarray:
        v = np.asarray(vector, dtype=float).ravel()
        if v.size != len(self.PARAMETERS):
            raise ValueError(
                f"{type(self).__name__}: vector must have {len(self.PARAMETERS)} entries, "
                f"got {v.size}"
            )
        return v

    def _shaped(self, terms) -> FuzzySystem:
        """The template with this parametrisation's shapes (built once, then reused)."""
        if getattr(self, "_shaped_template", None) is None:
            fis = self._template
            for var, shapes in terms.items():
                variable = next(x for x in fis.inputs + fis.outputs if x.name == var)
                for term, (shape, params) in zip(variable.term_names, shapes):
                    fis = fis.with_term_params(var, term, [float(p) for p in params], shape=shape)
            self._shaped_template = fis
        return fis if self._shaped_template is None else self._shaped_template

    def system(self, vector) -> FuzzySystem:
        terms = self.terms(vector)
        template = self._shaped(terms)
        flat = [
            float(p)
            for var in template.inputs + template.outputs
            for _, params in terms[var.name]
            for p in params
        ]
        return template.with_parameter_vector(flat)

    def __getstate__(self):
        state = dict(self.__dict__)
        state["_shaped_template"] = None
        return state

    def build(self, vector) -> FisController:
        return FisController(self.system(vector), name="paper")

    def save(
        self, vector, path: str | Path, header: str = "", unsensed_none: bool = False
    ) -> list[Path]:
        """Write the rule base with a header saying what is tuned and how to redo it;
        ``unsensed_none``: Table 1's NONE for d_o read as the paper's text has it."""
        path = Path(path)
        fis = self.system(vector).replace(
            description=self.DESCRIPTION, unsensed_none=("d_o",) if unsensed_none else ()
        )
        names = ", ".join(f"{n}={x:.6g}" for n, x in zip(self.parameter_names(), np.ravel(vector)))
        lines = list(self.HEADER)
        lines += [f"# {line}" if line else "#" for line in header.splitlines()]
        lines += [f"# tuned vector: {names}", ""]
        path.parent.mkdir(parents=True, exist_ok=True)
        from fuzzynav.safe_files import write_text_atomically

        write_text_atomically(path, "\n".join(lines) + "\n" + dumps_toml(fis))
        return [path]


class PaperPartitionTunable(TableOneTunable):
    """The paper controller (Table 1) with partition membership functions (module doc)."""

    PARAMETERS = PARTITION_PARAMETERS
    DESCRIPTION = (
        "Pahlavan & Khankalantary fuzzy navigator, Table 1 rules; "
        "partition membership functions fitted by fuzzynav (not from the paper)"
    )
    HEADER = (
        "# The fuzzy navigator of Pahlavan & Khankalantary (paper section 3, Table 1).",
        "#",
        "# From the paper: inputs, outputs, ranges, term names, Mamdani min/max/centroid",
        "# and the 40 rules of Table 1 (weight 1), unchanged.",
        "# NOT from the paper: the membership parameters (Ruspini partitions on every",
        "# input: no holes; controller/paper_partition.py), fitted as the header says.",
        "# Sign convention: phi > 0 = target/obstacle on the LEFT. d_o NaN = nothing sensed.",
        "#",
    )

    def terms(self, vector) -> dict[str, list[tuple[str, tuple[float, ...]]]]:
        v = self._vector(vector)
        centres = np.cumsum(v[12:17])
        outputs: list[tuple[str, tuple[float, ...]]] = [
            ("trimf", (c - h, c, c + h)) for c, h in zip(centres.tolist(), v[17:22].tolist())
        ]
        return {
            "d_t": partition(np.cumsum(v[0:5])),
            "d_o": partition(np.cumsum(v[5:8])),
            "phi_t": partition(_mirrored(v[8], v[9])),
            "phi_o": partition(_mirrored(v[10], v[11])),
            "left": outputs,
            "right": outputs,
        }
