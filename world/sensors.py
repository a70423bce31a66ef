"""Three US-100 ultrasonic range sensors, modelled as fans of pymunk ray casts.

Each sensor sits on the footprint's front edge with a mounting angle (left, front,
right). Its beam is a cone, modelled by ``rays_per_beam`` rays spread evenly across the
cone; the reading is the nearest echo of any ray, as an ultrasonic sensor reports the
first echo whatever part of its cone it came from. Rays ignore the robot's own shape.

A reading is ``inf`` when nothing echoes within ``max_range_m``; a surface closer than
``min_range_m`` reads as ``min_range_m`` (the US-100's blind zone). Optional Gaussian
noise comes from a seeded generator, and a reading is refreshed at ``update_rate_hz``
(held in between), so a run is reproducible.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
import pymunk

from world.arena import RAY_FILTER, Arena


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
        self.reset(seed)

    def reset(self, seed: int | None = None) -> None:
        self._rng = np.random.default_rng(seed)
        self._next_update_s = -math.inf
        self._ranges = np.full(len(self.config.mounts), math.inf)
        self.hit_points = np.full((len(self.config.mounts), 2), np.nan)

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

    def read(self, arena: Arena, time_s: float) -> np.ndarray:
        """Cast the rays if an update is due, and return the readings (m, inf = no echo)."""
        if time_s + 1e-12 < self._next_update_s:
            return self._ranges
        period = 1.0 / self.config.update_rate_hz
        # Keep a steady cadence, but never schedule the next update in the past.
        following = self._next_update_s + period
        self._next_update_s = following if following > time_s else time_s + period
        cfg = self.config
        space = arena.space
        ranges = np.empty(len(cfg.mounts))
        for k, (origin, direction) in enumerate(self.beam_geometry(arena.pose)):
            ends = [(origin[0] + cfg.max_range_m * math.cos(direction + offset),
                     origin[1] + cfg.max_range_m * math.sin(direction + offset))
                    for offset in self._offsets]
            nearest, hit = math.inf, (math.nan, math.nan)
            # The rays are segments, so the box around their ends and the origin holds
            # them all: when no shape touches it, no ray can hit and none is cast.
            xs = [origin[0]] + [e[0] for e in ends]
            ys = [origin[1]] + [e[1] for e in ends]
            if space.bb_query(pymunk.BB(min(xs), min(ys), max(xs), max(ys)), RAY_FILTER):
                for end in ends:
                    info = space.segment_query_first(origin, end, 0.0, RAY_FILTER)
                    if info is not None:
                        distance = info.alpha * cfg.max_range_m
                        if distance < nearest:
                            nearest, hit = distance, (info.point.x, info.point.y)
            if math.isfinite(nearest):
                if cfg.noise_std_m > 0.0:
                    nearest += self._rng.normal(0.0, cfg.noise_std_m)
                nearest = min(max(nearest, cfg.min_range_m), cfg.max_range_m)
            ranges[k] = nearest
            self.hit_points[k] = hit
        self._ranges = ranges
        return ranges
