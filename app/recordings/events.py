"""A run's events in a recording: closest approaches, the disturbance window and the
end (issue 28), as a text log, state lanes on the timeline and markers in the world."""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from fuzzynav.world.geometry import circle_points

from .arrow import StaticBatch, time_column
from .style import EVENT, HEADING_ORDER, OBSTACLE_ORDER, OBSTACLE_PALETTE, RING_SEGMENTS

EVENTS_LOG_PATH = "/events/log"  # TextLog at each event's time
EVENTS_LANES = "/events/lanes"  # StateChange lanes: closest, disturbance, outcome
EVENTS_WORLD = "/world/events"  # static: where the robot was at each event


@dataclasses.dataclass(frozen=True)
class Event:
    """One event of a run: its time (s), what ("closest", "disturbance on/off",
    "reached", "collided", "timeout"), the obstacle (closest only) and its text."""

    time_s: float
    kind: str
    text: str
    obstacle: int | None = None
    distance_m: float | None = None


def run_events(result) -> list[Event]:
    """The run's events in time order: each obstacle's closest approach (centre to
    centre, as the paper's section 4 gives them, with the footprint clearance then),
    the disturbance window's start and end, and the outcome at the run's end."""
    log = result.log
    events: list[Event] = []
    if not len(log):
        return events
    t = log.time_s
    for col, oid in enumerate(log.obstacle_ids):
        d = np.where(
            np.isfinite(log.center_distance_m[:, col]), log.center_distance_m[:, col], np.inf
        )
        k = int(np.argmin(d))
        if not math.isfinite(d[k]):
            continue
        clearance = float(log.clearance_m[k, col])
        surface = (
            ""
            if getattr(result, "geometry", "husky") == "paper"
            else (f", footprint clearance {clearance:.2f} m")
        )
        events.append(
            Event(
                float(t[k]),
                "closest",
                f"closest to obstacle {oid}: {d[k]:.2f} m centre to centre{surface}",
                oid,
                float(d[k]),
            )
        )
    window = getattr(result.scenario, "disturbance", None)
    if window is not None:
        for when, what in ((window.start_s, "on"), (window.stop_s, "off")):
            if t[0] <= when <= t[-1]:
                events.append(
                    Event(
                        float(when),
                        f"disturbance {what}",
                        f"disturbance {what} ({window.amplitude:g} sin({window.angular_frequency_rad_s:g} t) "
                        f"on the inputs from {window.start_s:g} s to {window.stop_s:g} s)",
                    )
                )
    outcome = getattr(result, "outcome", None) or "running"
    end = float(t[-1])
    m = result.metrics or {}
    if outcome == "reached":
        text = f"reached the target at {m.get('time_to_target_s', end):.2f} s"
    elif outcome == "collided":
        text = f"collided at {end:.2f} s"
    else:
        text = f"{outcome} at {end:.2f} s"
    events.append(Event(end, outcome, text))
    return sorted(events, key=lambda e: e.time_s)


def send_events(rec, static: StaticBatch, result) -> list[Event]:
    """The events as a text log and state lanes on the timeline, and, in the world,
    a marker where the robot was at each closest approach and each moving obstacle
    drawn where it was then, with its whole track."""
    import rerun as rr

    events = run_events(result)
    if not events:
        return events
    log = result.log
    times = np.array([e.time_s for e in events])
    rec.send_columns(
        EVENTS_LOG_PATH,
        indexes=[time_column(times)],
        columns=rr.TextLog.columns(
            text=[f"{e.time_s:7.2f} s  {e.text}" for e in events],
            level=["WARN" if e.kind in ("collided", "timeout") else "INFO" for e in events],
        ),
        strict=True,
    )
    t0 = float(log.time_s[0])
    lanes = {
        "closest approach": [(t0, "-")]
        + [
            (e.time_s, f"obstacle {e.obstacle}: {e.distance_m:.2f} m")
            for e in events
            if e.kind == "closest"
        ],
        # (the end is an instant: the lane says from the start how the run ends)
        "outcome": [(t0, f"driving, then {events[-1].text}")],
    }
    if any(e.kind.startswith("disturbance") for e in events):
        lanes["disturbance"] = [(t0, "off")] + [
            (e.time_s, "on" if e.kind.endswith("on") else "off")
            for e in events
            if e.kind.startswith("disturbance")
        ]
    for lane, changes in lanes.items():
        changes = sorted(changes, key=lambda c: c[0])
        rec.send_columns(
            f"{EVENTS_LANES}/{lane.replace(' ', '_')}",
            indexes=[time_column(np.array([c[0] for c in changes]))],
            columns=rr.StateChange.columns(state=[c[1] for c in changes]),
            strict=True,
        )
    # where the robot and the obstacle were at each closest approach
    closest = [e for e in events if e.kind == "closest"]
    if closest:
        rows = [int(np.searchsorted(log.time_s, e.time_s)) for e in closest]
        static.add_archetype(
            f"{EVENTS_WORLD}/closest",
            rr.Points2D(
                positions=[log.pose[k, :2] for k in rows],
                radii=0.07,
                colors=[EVENT] * len(rows),
                labels=[f"{e.distance_m:.2f} m at {e.time_s:.1f} s" for e in closest],
                draw_order=float(HEADING_ORDER + 1),
            ),
        )
        for e, k in zip(closest, rows):
            col = list(log.obstacle_ids).index(e.obstacle)
            xy = log.obstacle_xy[:, col]
            present = np.all(np.isfinite(xy), axis=1)
            if not present.any() or np.ptp(xy[present], axis=0).max() <= 1e-9:
                continue  # a static obstacle is drawn where it is
            color = OBSTACLE_PALETTE[col % len(OBSTACLE_PALETTE)]
            radius = float(log.obstacle_radii_m[col])
            static.add_archetype(
                f"{EVENTS_WORLD}/moving_{e.obstacle}/track",
                rr.LineStrips2D(
                    strips=[xy[present]],
                    colors=[(*color, 140)],
                    radii=0.012,
                    draw_order=float(OBSTACLE_ORDER - 1),
                ),
            )
            static.add_archetype(
                f"{EVENTS_WORLD}/moving_{e.obstacle}/at_closest",
                rr.LineStrips2D(
                    strips=[circle_points(radius, RING_SEGMENTS) + xy[k]],
                    colors=[color],
                    radii=0.015,
                    labels=[f"obstacle {e.obstacle} at {e.time_s:.1f} s"],
                    draw_order=float(OBSTACLE_ORDER),
                ),
            )
    return events
