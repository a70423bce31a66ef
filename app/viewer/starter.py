"""A small fuzzy system to start a lesson with: two inputs, d_t and phi_t, and
six rules, beside the paper's forty.

It only heads for the target: it reads no obstacle (d_o and phi_o take part in no rule),
so on s1 it drives straight into the first obstacle in its way, which is the lesson's
next step ("what rules would avoid it?"). The system has the robot's four inputs and two
outputs, as every controller here does; the rule grid shows only the columns its rules
use (d_t, phi_t, left, right). Offered in the viewer's Controller dropdown as
:data:`STARTER_LABEL`; the Editor's Download .fis is the paper's, so the starter is
exported from Python with :func:`fuzzynav.controller.fis.write_fis` if need be.
"""

from __future__ import annotations

import math

STARTER_LABEL = "starter (d_t, phi_t: 6 rules)"


def starter_system():
    """The starter's :class:`FuzzySystem` (Mamdani, MATLAB's default choices)."""
    from fuzzynav.controller.fuzzy import FuzzySystem, Rule, Term, Variable

    pi = math.pi
    d_t = Variable(
        "d_t",
        (0.0, 30.0),
        (Term("near", "linzmf", (0.5, 3.0)), Term("far", "linsmf", (0.5, 3.0))),
        unit="m",
        description="distance to the target",
    )
    # d_o and phi_o are the robot's inputs too, but no rule reads them.
    d_o = Variable("d_o", (0.0, 3.0), (Term("near", "linzmf", (0.0, 3.0)),), unit="m")
    phi_t = Variable(
        "phi_t",
        (-pi, pi),
        (
            Term("N", "linzmf", (-0.5, 0.0)),
            Term("Z", "trimf", (-0.25, 0.0, 0.25)),
            Term("P", "linsmf", (0.0, 0.5)),
        ),
        unit="rad",
        description="bearing of the target (positive: to the left)",
    )
    phi_o = Variable("phi_o", (-pi, pi), (Term("Z", "trimf", (-pi, 0.0, pi)),), unit="rad")
    wheel_terms = (
        Term("stop", "trimf", (-2.0, 0.0, 2.0)),
        Term("slow", "trimf", (0.0, 3.0, 6.0)),
        Term("fast", "trimf", (4.0, 8.0, 12.0)),
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
