"""A small fuzzy system to start a lesson with: two inputs, d_t and phi_t, and
six rules, beside the paper's forty.

It only heads for the target: it reads no obstacle (d_o and phi_o take part in no rule),
so on s1 it drives straight into the first obstacle in its way, which is the lesson's
next step ("what rules would avoid it?"). The system has the robot's four inputs and two
outputs, as every controller here does; the rule grid shows only the columns its rules
use (d_t, phi_t, left, right). Offered in the viewer's Controller dropdown as
:data:`STARTER_LABEL`. Its shapes are built from the six numbers of
:class:`StarterLayout` (widths and centres that keep every term valid and in order), which
the Editor's sliders move while the starter drives; the edited starter drives as
:data:`STARTER_EDITED_LABEL`.
"""

from __future__ import annotations

import math

STARTER_LABEL = "starter (d_t, phi_t: 6 rules)"
STARTER_EDITED_LABEL = "starter (edited)"

# The layout's numbers: name, starting value, bounds. Each is a place or a width, so
# every slider position keeps the terms valid and in order.
STARTER_NUMBERS = (
    ("d_t.near", 0.5, (0.0, 10.0)),  # near holds 1 up to, far starts (m)
    ("d_t.ramp", 2.5, (0.1, 15.0)),  # far holds 1 after (m)
    ("phi_t.zero", 0.25, (0.02, 1.5)),  # Z half-width (rad)
    ("phi_t.full", 0.5, (0.05, 1.5)),  # N, P hold 1 from (rad)
    ("v.slow", 3.0, (0.5, 6.0)),  # slow centre (V)
    ("v.fast", 8.0, (6.5, 11.0)),  # fast centre (V)
)


class StarterLayout:
    """The starter's shapes from six numbers (the Editor's sliders while it drives)."""

    def parameter_names(self) -> list[str]:
        return [name for name, _, _ in STARTER_NUMBERS]

    def bounds(self) -> list[tuple[float, float]]:
        return [bounds for _, _, bounds in STARTER_NUMBERS]

    def initial_vector(self):
        import numpy as np

        return np.array([value for _, value, _ in STARTER_NUMBERS], dtype=float)

    def system(self, vector):
        """The starter system with these numbers; ValueError outside the bounds."""
        values = [float(v) for v in vector]
        for (name, _, (lo, hi)), value in zip(STARTER_NUMBERS, values):
            if not (math.isfinite(value) and lo <= value <= hi):
                raise ValueError(f"{name} = {value!r}: must be between {lo} and {hi}")
        return starter_system(values)


def starter_system(numbers=None):
    """The starter's :class:`FuzzySystem` (Mamdani, MATLAB's default choices), shaped
    by :class:`StarterLayout`'s numbers (its starting values by default)."""
    from fuzzynav.controller.fuzzy import FuzzySystem, Rule, Term, Variable

    if numbers is None:
        numbers = [value for _, value, _ in STARTER_NUMBERS]
    near, ramp, zero, full, slow, fast = (float(v) for v in numbers)
    pi = math.pi
    d_t = Variable(
        "d_t",
        (0.0, 30.0),
        (
            Term("near", "linzmf", (near, near + ramp)),
            Term("far", "linsmf", (near, near + ramp)),
        ),
        unit="m",
        description="distance to the target",
    )
    # d_o and phi_o are the robot's inputs too, but no rule reads them.
    d_o = Variable("d_o", (0.0, 3.0), (Term("near", "linzmf", (0.0, 3.0)),), unit="m")
    phi_t = Variable(
        "phi_t",
        (-pi, pi),
        (
            Term("N", "linzmf", (-full, 0.0)),
            Term("Z", "trimf", (-zero, 0.0, zero)),
            Term("P", "linsmf", (0.0, full)),
        ),
        unit="rad",
        description="bearing of the target (positive: to the left)",
    )
    phi_o = Variable("phi_o", (-pi, pi), (Term("Z", "trimf", (-pi, 0.0, pi)),), unit="rad")
    wheel_terms = (
        Term("stop", "trimf", (-2.0, 0.0, 2.0)),
        Term("slow", "trimf", (slow - 3.0, slow, slow + 3.0)),
        Term("fast", "trimf", (fast - 4.0, fast, fast + 4.0)),
    )
    left = Variable("left", (-0.28, 14.0), wheel_terms, unit="V")
    right = Variable("right", (-0.28, 14.0), wheel_terms, unit="V")
    N, Z, P = 0, 1, 2
    NEAR, FAR = 0, 1
    STOP, SLOW, FAST = 0, 1, 2

    def rule(dt, pt, wl, wr):
        return Rule((dt, None, pt, None), (wl, wr))

    rules = [
        rule(FAR, Z, FAST, FAST),  # far and straight ahead: full speed
        rule(NEAR, Z, SLOW, SLOW),  # near and ahead: slow down
        rule(None, P, STOP, FAST),  # target to the left: turn left
        rule(None, N, FAST, STOP),  # target to the right: turn right
        rule(NEAR, P, STOP, SLOW),  # near and to the left: turn on the spot
        rule(NEAR, N, SLOW, STOP),  # near and to the right
    ]
    return FuzzySystem(
        (d_t, d_o, phi_t, phi_o),
        (left, right),
        rules,
        name="starter",
        description="a lesson's first system: head for the target",
    )


def starter_controller():
    from fuzzynav.controller.fis_controller import FisController

    return FisController(starter_system(), name=STARTER_LABEL)
