"""Three US-100 ultrasonic range sensors, modelled as fans of pymunk ray casts.

Each sensor sits on the footprint's front edge with a mounting angle (left, front,
right). Its beam is a cone, modelled by ``rays_per_beam`` rays spread evenly across the
cone; the reading is the nearest echo of any ray, as an ultrasonic sensor reports the
first echo whatever part of its cone it came from. Rays ignore the robot's own shape.

A reading is ``inf`` when nothing echoes within ``max_range_m``; a surface closer than
``min_range_m`` reads as ``min_range_m`` (the US-100's blind zone). Optional Gaussian
noise comes from a seeded generator, and a reading is refreshed at ``update_rate_hz``
(held in between), so a run is reproducible.

Speed: a cast first asks the arena which obstacles could be within reach of any ray
(a distance test on floats it has anyway); with none, nothing is cast and every reading
is ``inf``, as the casts would have said. Otherwise each sensor whose beam's bounding box
touches an obstacle's casts its rays with Chipmunk's segment query, called through
pymunk's cffi binding (the call ``Space.segment_query_first`` makes, without building
a ``SegmentQueryInfo``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
import pymunk

from world.arena import RAY_FILTER, Arena, _cp, _ffi

# Slack (m) on the prefilter's reach and boxes, far above the rounding of the centres.
_PREFILTER_SLACK_M = 1e-6
_cos, _sin = math.cos, math.sin


@dataclass(frozen=True)
class SensorMount:
    """Where a sensor sits on the robot (robot frame: x forward, y left)."""

    name: str
    x_m: float
    y_m: float
    angle_rad: float


def default_mounts(footprint_m=(0.99, 0.67)) -> tuple[SensorMount, ...]:
    """Left, front and right sensors on the front edge, 45 degrees apart.

    45 degrees apart with 15-degree cones leaves gaps between the beams but makes the
    sensor that sees the nearest echo say clearly where the obstacle is (left, ahead or
    right), which is what the controller's obstacle-angle input needs.
    """
    half_length, half_width = 0.5 * footprint_m[0], 0.5 * footprint_m[1]
    corner_y = 0.75 * half_width
    return (
        SensorMount("left", half_length, corner_y, math.radians(45.0)),
        SensorMount("front", half_length, 0.0, 0.0),
        SensorMount("right", half_length, -corner_y, math.radians(-45.0)),
    )


@dataclass(frozen=True)
class SensorConfig:
    """US-100 model parameters (datasheet: 2 cm to 4.5 m, about 15 degree beam)."""

    mounts: tuple[SensorMount, ...] = field(default_factory=default_mounts)
    beam_width_rad: float = math.radians(15.0)
    rays_per_beam: int = 5
    min_range_m: float = 0.02
    max_range_m: float = 4.5
    noise_std_m: float = 0.0
    update_rate_hz: float = 25.0

    def __post_init__(self):
        for name in ("beam_width_rad", "min_range_m", "max_range_m", "update_rate_hz"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0):
                raise ValueError(f"SensorConfig.{name} = {value!r}: must be positive and finite")
        if not (math.isfinite(self.noise_std_m) and self.noise_std_m >= 0):
            raise ValueError(f"SensorConfig.noise_std_m = {self.noise_std_m!r}: must be >= 0")
        if self.rays_per_beam < 1:
            raise ValueError(f"SensorConfig.rays_per_beam = {self.rays_per_beam!r}: must be >= 1")
        if self.min_range_m >= self.max_range_m:
            raise ValueError(f"SensorConfig.min_range_m = {self.min_range_m!r}: "
                             f"must be below max_range_m = {self.max_range_m!r}")

    def ray_offsets_rad(self) -> np.ndarray:
        if self.rays_per_beam == 1:
            return np.zeros(1)
        half = 0.5 * self.beam_width_rad
        return np.linspace(-half, half, self.rays_per_beam)


class RangeSensorArray:
    """The three sensors together: ``read(arena)`` returns their ranges in metres."""

    def __init__(self, config: SensorConfig | None = None, seed: int | None = None):
        self.config = config or SensorConfig()
        self._offsets = [float(a) for a in self.config.ray_offsets_rad()]
        self._constants_for = None
        self._info = _ffi.new("cpSegmentQueryInfo *") if _ffi is not None else None
        self._filter = _ffi.new("cpShapeFilter *", RAY_FILTER)[0] if _ffi is not None else None
        self.reset(seed)

    def reset(self, seed: int | None = None) -> None:
        self._rng = np.random.default_rng(seed)
        self._next_update_s = -math.inf
        self._ranges = np.full(len(self.config.mounts), math.inf)
        self._ranges_list = self._ranges.tolist()
        self.hit_points = np.full((len(self.config.mounts), 2), np.nan)
        self._hits_nan = True

    @property
    def ranges_m(self) -> np.ndarray:
        """The latest readings (held between updates)."""
        return self._ranges

    def beam_geometry(self, pose) -> list[tuple[tuple[float, float], float]]:
        """(origin in the world, centre direction in the world) of each sensor."""
        x, y, heading = pose
        c, s = math.cos(heading), math.sin(heading)
        return [((x + c * m.x_m - s * m.y_m, y + s * m.x_m + c * m.y_m), heading + m.angle_rad)
                for m in self.config.mounts]

    def _constants(self) -> tuple:
        """Per-config constants: mounts as floats, the reach of any ray from the centre."""
        cfg = self.config
        if self._constants_for is not cfg:
            mounts = [(m.x_m, m.y_m, m.angle_rad) for m in cfg.mounts]
            reach = max((math.hypot(mx, my) for mx, my, _ in mounts), default=0.0) + cfg.max_range_m
            self._consts = (mounts, reach + _PREFILTER_SLACK_M)
            self._constants_for = cfg
        return self._consts

    def read(self, arena: Arena, time_s: float) -> np.ndarray:
        """Cast the rays if an update is due, and return the readings (m, inf = no echo)."""
        if time_s + 1e-12 < self._next_update_s:
            return self._ranges
        period = 1.0 / self.config.update_rate_hz
        # Keep a steady cadence, but never schedule the next update in the past.
        following = self._next_update_s + period
        self._next_update_s = following if following > time_s else time_s + period
        self._cast(arena)
        return self._ranges

    def _cast(self, arena: Arena) -> None:
        cfg = self.config
        mounts, reach = self._constants()
        n = len(mounts)
        prefilter = getattr(arena, "_ray_candidates", None)
        candidates = prefilter(reach) if prefilter is not None else None
        if candidates is not None and not candidates:
            # Nothing within reach of any ray: every cast would miss.
            self._ranges_list = [math.inf] * n
            self._ranges = np.full(n, math.inf)
            if not self._hits_nan:
                self.hit_points[...] = np.nan
                self._hits_nan = True
            return
        space = arena.space
        space_ptr = getattr(arena, "_space_ptr", None)
        info, shape_filter = self._info, self._filter
        fast = space_ptr is not None and info is not None
        max_range = cfg.max_range_m
        offsets = self._offsets
        slack = _PREFILTER_SLACK_M
        x, y, heading = arena.pose
        c, s = _cos(heading), _sin(heading)
        ranges, hits, any_hit = [], [], False
        for mx, my, angle in mounts:
            ox, oy = x + c * mx - s * my, y + s * mx + c * my
            nearest, hit = math.inf, (math.nan, math.nan)
            if candidates is None:
                near = None
            else:
                # Only obstacles within a ray's length of this sensor can echo.
                near = []
                for candidate in candidates:
                    cx, cy, radius = candidate
                    limit = max_range + radius + slack
                    if (cx - ox) * (cx - ox) + (cy - oy) * (cy - oy) <= limit * limit:
                        near.append(candidate)
                if not near:
                    ranges.append(nearest)
                    hits.append(hit)
                    continue
            direction = heading + angle
            ends = [(ox + max_range * _cos(direction + offset),
                     oy + max_range * _sin(direction + offset))
                    for offset in offsets]
            # The rays are segments, so the box around their ends and the origin holds
            # them all: when no shape touches it, no ray can hit and none is cast.
            xs = [ox] + [e[0] for e in ends]
            ys = [oy] + [e[1] for e in ends]
            x_lo, y_lo, x_hi, y_hi = min(xs), min(ys), max(xs), max(ys)
            if near is None:
                touched = bool(space.bb_query(pymunk.BB(x_lo, y_lo, x_hi, y_hi), RAY_FILTER))
            else:
                x_lo -= slack
                y_lo -= slack
                x_hi += slack
                y_hi += slack
                touched = False
                for cx, cy, radius in near:
                    if (cx + radius >= x_lo and cx - radius <= x_hi
                            and cy + radius >= y_lo and cy - radius <= y_hi):
                        touched = True
                        break
            if touched:
                origin = (ox, oy)
                for end in ends:
                    if fast:
                        if _cp.cpSpaceSegmentQueryFirst(space_ptr, origin, end, 0.0,
                                                        shape_filter, info):
                            distance = info.alpha * max_range
                            if distance < nearest:
                                point = info.point
                                nearest, hit = distance, (point.x, point.y)
                    else:
                        result = space.segment_query_first(origin, end, 0.0, RAY_FILTER)
                        if result is not None:
                            distance = result.alpha * max_range
                            if distance < nearest:
                                nearest, hit = distance, (result.point.x, result.point.y)
            if math.isfinite(nearest):
                any_hit = True
                if cfg.noise_std_m > 0.0:
                    nearest += self._rng.normal(0.0, cfg.noise_std_m)
                nearest = min(max(nearest, cfg.min_range_m), cfg.max_range_m)
            ranges.append(nearest)
            hits.append(hit)
        self._ranges_list = ranges
        self._ranges = np.array(ranges, dtype=float)
        if any_hit:
            self.hit_points[...] = hits
            self._hits_nan = False
        elif not self._hits_nan:
            self.hit_points[...] = np.nan
            self._hits_nan = True
