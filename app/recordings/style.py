"""How a recording looks: the colours, the draw orders and the sizes of what it draws.

Red, orange, purple... are obstacles 0, 1, 2 in every plot, in the world view and in the
figures (:data:`OBSTACLE_PALETTE` by the obstacle's column); rerun takes a colour packed
as 0xRRGGBBAA (:func:`rgba`).
"""

from __future__ import annotations

SAFE_DISTANCE_M = 0.25
HEADING_ARROW_M = 0.7
#: Draw orders in the world view (higher on top): beams under everything the robot is.
BEAM_ORDER, OBSTACLE_ORDER, TRAIL_ORDER, ROBOT_ORDER, HEADING_ORDER = 10, 20, 30, 40, 50
RING_SEGMENTS = 48

# Colours (RGB).
ROBOT = (40, 110, 220)
TRAIL = (40, 110, 220)
HEADING = (0, 140, 120)  # teal: neither the trail's blue nor a sensor's or an obstacle's
SENSED = (240, 180, 0)  # the line to the obstacle the controller reacts to
EVENT = (20, 20, 20)
# Red, orange, purple... are obstacles 0, 1, 2 in every plot and figure: the right wheel
# is drawn black-ish, the limits light grey.
RIGHT = (40, 40, 40)
LIMIT = (185, 185, 185)
TARGET = (30, 160, 60)
OBSTACLE = (200, 60, 50)
SAFE_RING = (140, 140, 140)
START = (235, 235, 235)
SCALE = (200, 200, 200)
OBSTACLE_PATH = (150, 60, 160)
SENSOR_COLORS = {"left": (0, 170, 200), "front": (120, 120, 120), "right": (200, 0, 170)}
SERIES_PALETTE = [
    (31, 119, 180),
    (214, 39, 40),
    (44, 160, 44),
    (255, 127, 14),
    (148, 103, 189),
    (140, 86, 75),
    (227, 119, 194),
    (127, 127, 127),
    (188, 189, 34),
    (23, 190, 207),
]
# Obstacle series: no green (the target's) and no blue (the robot's).
OBSTACLE_PALETTE = [
    (214, 39, 40),
    (255, 127, 14),
    (148, 103, 189),
    (140, 86, 75),
    (227, 119, 194),
    (188, 189, 34),
    (23, 190, 207),
    (127, 127, 127),
]


def rgba(color) -> int:
    """(r, g, b) or (r, g, b, a) packed as 0xRRGGBBAA, rerun's colour component."""
    r, g, b, a = (tuple(color) + (255,))[:4]
    return (int(r) << 24) | (int(g) << 16) | (int(b) << 8) | int(a)
