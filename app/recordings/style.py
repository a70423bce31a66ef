"""How a recording looks: the draw orders and the sizes of what it draws, and its
colours, as (r, g, b) tuples of :mod:`app.palette`'s (one palette for the recordings,
the figures and the viewer); rerun takes a colour packed as 0xRRGGBBAA (:func:`rgba`).
"""

from __future__ import annotations

from fuzzynav.app import palette
from fuzzynav.app.palette import rgb

SAFE_DISTANCE_M = 0.25
HEADING_ARROW_M = 0.7
#: Draw orders in the world view (higher on top): beams under everything the robot is.
BEAM_ORDER, OBSTACLE_ORDER, TRAIL_ORDER, ROBOT_ORDER, HEADING_ORDER = 10, 20, 30, 40, 50
RING_SEGMENTS = 48

# Colours (RGB), app.palette's.
ROBOT = rgb(palette.ROBOT)
TRAIL = rgb(palette.TRAIL)
HEADING = rgb(palette.HEADING)
SENSED = rgb(palette.SENSED)
EVENT = rgb(palette.EVENT)
RIGHT = rgb(palette.WHEEL_RIGHT)
LIMIT = rgb(palette.LIMIT)
TARGET = rgb(palette.TARGET)
SAFE_RING = rgb(palette.SAFE)
SAFE = rgb(palette.SAFE)
BREACH = rgb(palette.BREACH)
START = rgb(palette.START)
SCALE = rgb(palette.SCALE)
COLLISION = rgb(palette.COLLISION)
SENSOR_COLORS = {name: rgb(c) for name, c in palette.SENSORS.items()}
SERIES_PALETTE = [rgb(c) for c in palette.SERIES]
TERM_PALETTE = [rgb(c) for c in palette.TERMS]
AGGREGATED = rgb(palette.AGGREGATED)
VALUE = rgb(palette.VALUE)
INPUT_COLORS = {name: rgb(c) for name, c in palette.INPUTS.items()}
DISTURBANCE = rgb(palette.DISTURBANCE)
#: Obstacle k's colour by its column (no green: the target's; no blue: the robot's).
OBSTACLE_PALETTE = [rgb(c) for c in palette.OBSTACLES]
#: What app.palette's obstacle colours are called, in its order (a panel without a
#: legend names them).
OBSTACLE_NAMES = ("red", "orange", "purple", "brown", "pink", "olive", "cyan", "grey")
assert len(OBSTACLE_NAMES) == len(palette.OBSTACLES)


def obstacle_color(col: int) -> tuple[int, int, int]:
    """The colour of the obstacle in column ``col`` of the run's log."""
    return OBSTACLE_PALETTE[col % len(OBSTACLE_PALETTE)]


def time_text(time_s: float, digits: int = 2) -> str:
    """A time as the recordings write it: seconds, and past a minute also as rerun's
    time axis writes it (``100.52 s = +1m 40.52s``), so that a time in a text is
    found on the axis.

    Parameters
    ----------
    time_s : float
        Simulated time (s).
    digits : int
        Digits after the point.
    """
    text = f"{time_s:.{digits}f} s"
    if time_s >= 60.0:
        minutes, seconds = divmod(float(time_s), 60.0)
        text += f" = +{int(minutes)}m {seconds:.{digits}f}s"
    return text


def rgba(color) -> int:
    """(r, g, b) or (r, g, b, a) packed as 0xRRGGBBAA, rerun's colour component."""
    r, g, b, a = (tuple(color) + (255,))[:4]
    return (int(r) << 24) | (int(g) << 16) | (int(b) << 8) | int(a)
