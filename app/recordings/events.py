"""A run's events in a recording: closest approaches, the disturbance window and the
end, as a text log, state lanes on the timeline and markers in the world."""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from fuzzynav.app.figures.style import obstacle_label
from fuzzynav.world.geometry import circle_points

from .arrow import StaticBatch, time_column
from .style import (
    BREACH,
    COLLISION,
    DISTURBANCE,
    EVENT,
    HEADING_ORDER,
    OBSTACLE_ORDER,
    RING_SEGMENTS,
    SAFE_DISTANCE_M,
    TARGET,
    obstacle_color,
)

EVENTS_LOG_PATH = "/events/log"  # TextLog at each event's time
EVENTS_LANES = "/events/lanes"  # StateChange lanes: closest, disturbance, outcome
EVENTS_WORLD = "/world/events"  # static: where the robot was at each event


@dataclasses.dataclass(frozen=True)
class Event:
    """One event of a run: its time (s), what ("closest", "approaching at the end",
    "safe distance", "disturbance on/off", "reached", "collided", "timeout"), the
    obstacle (closest, safe distance), the distance, its end (safe distance) and its
    text."""

    time_s: float
    kind: str
    text: str
    obstacle: int | None = None
    distance_m: float | None = None
    end_s: float | None = None
    row: int | None = None


def safe_distance_breaches(log, safe_m: float = SAFE_DISTANCE_M) -> list[tuple]:
    """(column, first row, last row, closest row) of every stretch of rows in which an
    obstacle's clearance (the footprint's, or in the paper's geometry the centre's, to
    its surface: ``log.clearance_m``, the clearance panel's) is below ``safe_m``."""
    found = []
    for col in range(len(log.obstacle_ids)):
        c = np.asarray(log.clearance_m[:, col], dtype=float)
        inside = np.isfinite(c) & (c < safe_m)
        if not inside.any():
            continue
        edges = np.flatnonzero(np.diff(np.concatenate([[0], inside.astype(np.int8), [0]])))
        for a, b in zip(edges[::2], edges[1::2]):
            k = a + int(np.argmin(c[a:b]))
            found.append((col, int(a), int(b - 1), int(k)))
    return found


def run_events(result) -> list[Event]:
    """The run's events in time order: each obstacle's closest approach (centre to
    centre, as the paper's section 4 gives them, with the footprint clearance then), a
    nearest distance at the run's last row said as what it is (the run ended while the
    robot was still approaching: no closest approach), every stretch inside the 0.25 m
    safe distance (from when to when, and how close), the disturbance window's start
    and end, and the outcome at the run's end."""
    log = result.log
    events: list[Event] = []
    if not len(log):
        return events
    t = log.time_s
    last = len(log) - 1
    outcome = getattr(result, "outcome", None) or "running"
    collided_with = None
    if outcome == "collided" and len(log.obstacle_ids):
        clear = np.where(np.isfinite(log.clearance_m[last]), log.clearance_m[last], np.inf)
        collided_with = int(np.argmin(clear))
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
        if k == last and col != collided_with and last > 0:
            # Still approaching when the run ended: a nearest distance, not a closest
            # approach (a collided run stopped the robot on its way).
            events.append(
                Event(
                    float(t[k]),
                    "approaching at the end",
                    f"{obstacle_label(oid)}: {d[k]:.2f} m centre to centre when the run ended "
                    "(still approaching: no closest approach)",
                    oid,
                    float(d[k]),
                    row=k,
                )
            )
            continue
        events.append(
            Event(
                float(t[k]),
                "closest",
                f"closest to {obstacle_label(oid)}: {d[k]:.2f} m centre to centre{surface}",
                oid,
                float(d[k]),
                row=k,
            )
        )
    for col, a, b, k in safe_distance_breaches(log):
        oid = log.obstacle_ids[col]
        closest = float(log.clearance_m[k, col])
        events.append(
            Event(
                float(t[a]),
                "safe distance",
                f"inside the {SAFE_DISTANCE_M:g} m safe distance of {obstacle_label(oid)} from "
                f"{t[a]:.2f} s to {t[b]:.2f} s, closest {closest:.2f} m at {t[k]:.2f} s",
                oid,
                closest,
                end_s=float(t[b]),
                row=k,
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
    end = float(t[-1])
    m = result.metrics or {}
    if outcome == "reached":
        text = f"reached the target at {m.get('time_to_target_s', end):.2f} s"
    elif outcome == "collided":
        who = (
            f" with {obstacle_label(log.obstacle_ids[collided_with])}"
            if collided_with is not None
            else ""
        )
        text = f"collided{who} at {end:.2f} s"
    else:
        text = f"{outcome} at {end:.2f} s"
    events.append(Event(end, outcome, text, row=last))
    return sorted(events, key=lambda e: e.time_s)


#: The lanes' states that are no obstacle's: their colours (app.palette's).
LANE_COLORS = {
    "-": (200, 200, 200),
    "clear": (205, 225, 205),
    "off": (200, 200, 200),
    "on": DISTURBANCE,
    "reached": TARGET,
    "collided": BREACH,
}


def _lane_colour(state: str):
    """A lane state's colour: an obstacle's for its closest approach, the breach's for
    a stretch inside the safe distance, the outcome's, grey for nothing."""
    if state in LANE_COLORS:
        return LANE_COLORS[state]
    if state.startswith("inside"):
        return BREACH
    if state.startswith("driving, then reached"):
        return TARGET
    if state.startswith("driving, then collided"):
        return BREACH
    return (170, 170, 170)


def _send_lane_styles(static: StaticBatch, path: str, states: list[str], colours: dict) -> None:
    """Each state's colour in its lane (rerun >= 0.41's StateConfiguration; rerun picks
    its own colours by the state's text before, which made obstacle 1 purple in one
    recording and green in another), with the recording's other static parts (one
    record batch, not a ``log`` call a lane)."""
    import rerun as rr

    configuration = getattr(rr, "StateConfiguration", None)
    if configuration is None:
        return
    values = list(dict.fromkeys(states))
    static.add_archetype(
        path,
        configuration(
            values=values,
            colors=[colours.get(v) or _lane_colour(v) for v in values],
        ),
    )


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
    colours: dict[str, tuple] = {}
    closest_states = []
    for e in events:
        if e.kind == "closest":
            state = f"{obstacle_label(e.obstacle)}: {e.distance_m:.2f} m"
            col = list(log.obstacle_ids).index(e.obstacle)
            colours[state] = obstacle_color(col)  # the obstacle's colour in every lane
            closest_states.append((e.time_s, state))
    safe = [(t0, "clear")]
    for e in events:
        if e.kind == "safe distance":
            state = f"inside: {obstacle_label(e.obstacle)}, closest {e.distance_m:.2f} m"
            safe.append((e.time_s, state))
            after = int(np.searchsorted(log.time_s, e.end_s, side="right"))
            if after < len(log):
                safe.append((float(log.time_s[after]), "clear"))
    lanes = {
        "closest approach": [(t0, "-")] + closest_states,
        "safe distance": safe,
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
        path = f"{EVENTS_LANES}/{lane.replace(' ', '_')}"
        rec.send_columns(
            path,
            indexes=[time_column(np.array([c[0] for c in changes]))],
            columns=rr.StateChange.columns(state=[c[1] for c in changes]),
            strict=True,
        )
        _send_lane_styles(static, path, [c[1] for c in changes], colours)
    _world_marks(static, log, events)
    return events


#: How far a closest approach's label sits from the robot, away from the obstacle (m):
#: beyond the safe ring (the robot is just outside it at a closest approach).
LABEL_OFFSET_M = 0.55


def _world_marks(static: StaticBatch, log, events) -> None:
    """In the world: a marker where the robot was at each closest approach (its label
    set off from the robot, away from the obstacle, so that it crosses no safety ring),
    a moving obstacle where it was then with its whole track, and a collision's place."""
    import rerun as rr

    ids = list(log.obstacle_ids)
    outcome = events[-1] if events else None
    if outcome is not None and outcome.kind == "collided":
        k = len(log) - 1
        static.add_archetype(
            f"{EVENTS_WORLD}/collision",
            rr.Points2D(
                positions=[log.pose[k, :2]],
                radii=0.11,
                colors=[COLLISION],
                labels=[outcome.text],
                draw_order=float(HEADING_ORDER + 2),
            ),
        )
    # a closest approach at the collision is the collision's (one mark, one label)
    closest = [
        e
        for e in events
        if e.kind == "closest" and not (outcome.kind == "collided" and e.row == len(log) - 1)
    ]
    if closest:
        rows = [e.row for e in closest]
        where = np.array([log.pose[k, :2] for k in rows], dtype=float)
        labels = []
        for e, k, xy in zip(closest, rows, where):
            centre = log.obstacle_xy[k, ids.index(e.obstacle)]
            away = xy - centre
            norm = float(np.hypot(*away))
            away = away / norm if norm > 1e-9 else np.array([0.0, 1.0])
            labels.append(xy + LABEL_OFFSET_M * away)
        static.add_archetype(
            f"{EVENTS_WORLD}/closest",
            rr.Points2D(
                positions=where,
                radii=0.07,
                colors=[EVENT] * len(rows),
                draw_order=float(HEADING_ORDER + 1),
            ),
        )
        static.add_archetype(
            f"{EVENTS_WORLD}/closest_labels",
            rr.Points2D(
                positions=np.array(labels),
                radii=0.001,
                colors=[EVENT] * len(rows),
                labels=[f"{e.distance_m:.2f} m at {e.time_s:.1f} s" for e in closest],
                draw_order=float(HEADING_ORDER + 1),
            ),
        )
        for e, k in zip(closest, rows):
            col = ids.index(e.obstacle)
            xy = log.obstacle_xy[:, col]
            present = np.all(np.isfinite(xy), axis=1)
            if not present.any() or np.ptp(xy[present], axis=0).max() <= 1e-9:
                continue  # a static obstacle is drawn where it is
            color = obstacle_color(col)
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
                    labels=[f"{obstacle_label(e.obstacle)} at {e.time_s:.1f} s"],
                    show_labels=False,  # (the closest approach's label says when)
                    draw_order=float(OBSTACLE_ORDER),
                ),
            )
