"""The static parts of the world in a recording: the y-up mirror of ``/world``, the
start, the straight start-target line and a 1 m scale. The robot, the target, the
obstacles and the sensors go with the run's rows
(:class:`~fuzzynav.app.recordings.columns.ColumnWriter`).
"""

from __future__ import annotations

from .sending import Statics
from .style import (
    SCALE,
    START,
)

#: The trail's segments inside the disturbance window, under the trail.
TRAIL_DISTURBED_PATH = "/world/robot/trail_disturbed"


def static_world(static: Statics, scenario) -> None:
    """The y-up mirror of /world, the start and the straight start-target line."""
    import rerun as rr

    static.add_archetype("/world", rr.Transform3D(scale=[1.0, -1.0, 1.0]))
    # Light, with a dark rim: visible on rerun's dark theme and on a light one.
    static.add_archetype(
        "/world/start",
        rr.Points2D(
            positions=[scenario.start, scenario.start],
            radii=[0.12, 0.08],
            colors=[(20, 20, 20), START],
            labels=["", "start"],
        ),
    )
    # A scale: a 1 m bar with 10 cm ticks, just below and left of the start (the view's
    # bounds always hold the start with a 1 m margin).
    x0, bar_y = scenario.start[0] - 0.8, scenario.start[1] - 0.75
    strips = [[(x0 + 0.3, bar_y), (x0 + 1.3, bar_y)]]
    strips += [
        [(x0 + 0.3 + 0.1 * k, bar_y), (x0 + 0.3 + 0.1 * k, bar_y + (0.1 if k % 5 == 0 else 0.05))]
        for k in range(11)
    ]
    static.add_archetype(
        "/world/scale",
        rr.LineStrips2D(
            strips=strips, colors=[SCALE] * len(strips), radii=0.012, labels=["1 m"] + [""] * 10
        ),
    )
    static.add_archetype(
        "/world/ideal_line",
        rr.LineStrips2D(
            strips=[[scenario.start, scenario.target]], colors=[(170, 170, 170)], radii=0.01
        ),
    )
