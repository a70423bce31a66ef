"""One palette: the colours every recording, figure and the viewer draw a quantity with.

A quantity has one colour wherever it is drawn:

- the robot and its trail blue, the target green, the heading teal;
- obstacle ``k`` (by its column in the run's log) ``OBSTACLES[k]``: red, orange, purple...
  in every plot, lane, world view and figure; a moving obstacle's path in its own colour;
- the target's inputs: d_t green (the target's), phi_t blue; the obstacle's inputs d_o
  and phi_o magenta (the nearest obstacle as sensed: no one obstacle's colour);
- a fuzzy variable's terms ``TERMS[j]`` by the term's order (S, M, L... of an output:
  the same in the recording's fuzzy-logic tab and in the membership figures), the
  aggregated output ``AGGREGATED``, a colour no term has;
- the left wheel blue, the right dark grey, the limits light grey.

Colours are ``#rrggbb`` strings (matplotlib's and the viewer's form); :func:`rgb` gives
the (r, g, b) tuple rerun and viser take.
"""

from __future__ import annotations

ROBOT = "#1f77b4"
TRAIL = ROBOT
TARGET = "#2ca02c"
HEADING = "#008c78"  # teal: neither the trail's blue nor an obstacle's colour
#: Obstacle k's colour: no green (the target's), no blue (the robot's).
OBSTACLES = (
    "#d62728",
    "#ff7f0e",
    "#9467bd",
    "#8c564b",
    "#e377c2",
    "#bcbd22",
    "#17becf",
    "#7f7f7f",
)
#: The controller's inputs, as plotted: d_t is the target's distance (the target's
#: green), phi_t its bearing (blue, as the paper's Fig. 14), d_o and phi_o the nearest
#: obstacle's as sensed.
D_T = TARGET
PHI_T = ROBOT
OBSTACLE_INPUT = "#c026d3"
D_O = PHI_O = OBSTACLE_INPUT
#: The viewer's arena draws the target's inputs on the robot in teal (the target's
#: green is its marker's there).
TARGET_INPUT = "#0d9488"
INPUTS = {"d_t": D_T, "phi_t": PHI_T, "d_o": D_O, "phi_o": PHI_O}

WHEEL_LEFT = ROBOT
WHEEL_RIGHT = "#282828"
LIMIT = "#b9b9b9"
SAFE = "#555555"  # the 0.25 m safe distance: its line and the obstacles' rings
#: Inside the safe distance: the breach's band on the time axes and its lane.
BREACH = "#e4572e"
EVENT = "#141414"
DISTURBANCE = "#f2a900"
SENSED = "#f0b400"  # the line to the obstacle the controller reacts to
START = "#5a5a5a"  # dark: readable on rerun's light and dark backgrounds
SCALE = "#5a5a5a"
COLLISION = "#000000"
#: The range sensors.
SENSORS = {"left": "#00aac8", "front": "#787878", "right": "#c800aa"}
#: A fuzzy variable's terms by their order (matplotlib's tab10 without its grey).
TERMS = (
    "#1f77b4",
    "#ff7f0e",
    "#2ca02c",
    "#d62728",
    "#9467bd",
    "#8c564b",
    "#e377c2",
    "#bcbd22",
    "#17becf",
)
AGGREGATED = "#3c3c3c"  # the aggregated output: no term's colour
VALUE = "#000000"  # an input's value, an output's centroid
#: Further series of no fixed meaning (velocity, the disturbance...).
SERIES = (
    "#1f77b4",
    "#d62728",
    "#2ca02c",
    "#ff7f0e",
    "#9467bd",
    "#8c564b",
    "#e377c2",
    "#7f7f7f",
    "#bcbd22",
    "#17becf",
)
#: The viewer's plot series (its inference view's terms and its time plots).
VIEWER_SERIES = ("#7c3aed", "#0891b2", "#16a34a", "#ea580c", "#db2777", "#475569", "#65a30d")


def obstacle(col: int) -> str:
    """The colour of the obstacle in column ``col`` of a run's log."""
    return OBSTACLES[col % len(OBSTACLES)]


def term(j: int) -> str:
    """The colour of a fuzzy variable's ``j``-th term."""
    return TERMS[j % len(TERMS)]


def rgb(colour: str) -> tuple[int, int, int]:
    """``#rrggbb`` as (r, g, b), 0-255."""
    h = colour.lstrip("#")
    return (int(h[0:2], 16), int(h[2:4], 16), int(h[4:6], 16))
