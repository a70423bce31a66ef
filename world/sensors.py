"""Three US-100 ultrasonic range sensors, modelled as fans of pymunk ray casts.

Each sensor sits on the footprint's front edge with a mounting angle (left, front,
right). Its beam is a cone, modelled by ``rays_per_beam`` rays spread evenly across the
cone; the reading is the nearest echo of any ray, as an ultrasonic sensor reports the
first echo whatever part of its cone it came from. Rays ignore the robot's own shape.

A reading is ``inf`` when nothing echoes within ``max_range_m``; a surface closer than
``min_range_m`` reads as ``min_range_m`` (the US-100's blind zone). Optional Gaussian
noise comes from a seeded generator, and a reading is refreshed at ``update_rate_hz``
(held in between), so a run is reproducible.

Speed: the rays are cast only where they can hit, and the readings are exactly those
of casting them all. A cast first asks the arena which obstacles are within reach of
any ray (a distance test on the centres it keeps as floats); with none, every reading is
``inf``. Otherwise, per sensor, an obstacle counts only if it is within a ray's length
of the sensor and the disc's angular extent (its bearing +- asin(r / d)) overlaps the
beam's, and a ray is cast only if it passes within a radius of such an obstacle's
centre. Every test is conservative (1e-6 m and 1e-9 rad of slack), so a ray that could
hit is always cast; the casts are pymunk's ``Space.segment_query_first``. A
space holding shapes the arena does not know (added to ``arena.space`` directly) gets
the general path: pymunk's bounding-box query per beam, then every ray of the beam.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
import pymunk

from fuzzynav.world.arena import RAY_FILTER, Arena
from fuzzynav.world.robot import HUSKY, SensorMount

# Slack on the prefilter's distances and angles, far above the rounding of the centres
# and directions it compares: it may let a ray through that misses, never the reverse.
_PREFILTER_SLACK_M = 1e-6
#: A reading is due once the time is within this of its schedule (s; both engines).
SCHEDULE_SLACK_S = 1e-12
_ANGLE_SLACK_RAD = 1e-9
_cos, _sin, _hypot, _atan2, _asin = math.cos, math.sin, math.hypot, math.atan2, math.asin


#: The side sensors' mounting angle (left +, right -) from the front one: the robot's
#: (``[sonars]`` of husky.toml, :data:`fuzzynav.world.robot.HUSKY`).
SIDE_MOUNT_RAD = HUSKY.side_mount_rad
#: One beam width from the front one: no blind sector ahead (``--sonar-side`` of it).
GAPLESS_SIDE_MOUNT_RAD = HUSKY.gapless_side_mount_rad


def default_mounts(
    footprint_m: tuple[float, float] | None = None, side_angle_rad: float | None = None
) -> tuple[SensorMount, ...]:
    """The robot's sonars (husky.toml's ``[[sonars]]``), on another footprint or with
    the side ones at +-``side_angle_rad`` if given.

    The paper names three US-100s (15-degree cones) and not how they are mounted. At the
    robot's default angle (45 degrees) they leave gaps between the beams but make the
    sensor that sees the nearest echo say clearly where the obstacle is (left, ahead or
    right), which is what fuzzynav's navigator was designed on. One beam width apart
    (``GAPLESS_SIDE_MOUNT_RAD``, ``fuzzynav run --sonar-side 15``) they cover the sector
    ahead without a gap: the paper's memoryless controller then passes an obstacle it
    loses between the wider beams, while fuzzynav's navigator keeps its success rate but
    less often the safe distance (docs/paper-controller.md, "Sensing").

    Parameters
    ----------
    footprint_m : (float, float), optional
        The footprint that carries them (the robot's, :data:`HUSKY`, if omitted).
    side_angle_rad : float, optional
        The angle of every sonar that points off the heading, in (0, pi/2] (as
        :meth:`~fuzzynav.world.robot.RobotDescription.with_sonar_side`; the robot's if
        omitted).

    Returns
    -------
    tuple of SensorMount
    """
    robot = HUSKY if footprint_m is None else HUSKY.with_footprint(footprint_m)
    if side_angle_rad is not None:
        robot = robot.with_sonar_side(side_angle_rad)
    return robot.mounts


@dataclass(frozen=True)
class SensorConfig:
    """US-100 model parameters (datasheet: 2 cm to 4.5 m, about 15 degree beam)."""

    mounts: tuple[SensorMount, ...] = field(default_factory=default_mounts)
    beam_width_rad: float = HUSKY.beam_width_rad
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
            raise ValueError(
                f"SensorConfig.min_range_m = {self.min_range_m!r}: "
                f"must be below max_range_m = {self.max_range_m!r}"
            )

    def reach_m(self) -> float:
        """The farthest any ray reaches from the robot's centre (m), with the
        prefilter's slack: which obstacles a cast may hit, in both engines."""
        near = max((math.hypot(m.x_m, m.y_m) for m in self.mounts), default=0.0)
        return near + self.max_range_m + _PREFILTER_SLACK_M

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
        self._spread = max(abs(a) for a in self._offsets)  # rays' largest angle off centre
        self._constants_for: SensorConfig | None = None
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
        return [
            ((x + c * m.x_m - s * m.y_m, y + s * m.x_m + c * m.y_m), heading + m.angle_rad)
            for m in self.config.mounts
        ]

    def _constants(self) -> tuple:
        """Per-config constants: mounts as floats, the reach of any ray from the centre."""
        cfg = self.config
        if self._constants_for is not cfg:
            mounts = [(m.x_m, m.y_m, m.angle_rad) for m in cfg.mounts]
            self._consts = (mounts, cfg.reach_m())
            self._constants_for = cfg
        return self._consts

    def read(self, arena: Arena, time_s: float) -> np.ndarray:
        """Cast the rays if an update is due, and return the readings (m, inf = no echo)."""
        if time_s + SCHEDULE_SLACK_S < self._next_update_s:
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
        prefilter = getattr(arena, "_ray_candidates", None)
        candidates = prefilter(reach) if prefilter is not None else None
        if candidates is None:
            self._cast_all(arena)
            return
        n = len(mounts)
        if not candidates:
            # Nothing within reach of any ray: every cast would miss.
            self._store([math.inf] * n, None)
            return
        query = arena.space.segment_query_first
        max_range = cfg.max_range_m
        offsets = self._offsets
        spread = self._spread
        slack = _PREFILTER_SLACK_M
        x, y, heading = arena.pose
        c, s = _cos(heading), _sin(heading)
        ranges, hits = [], None
        for k, (mx, my, angle) in enumerate(mounts):
            ox, oy = x + c * mx - s * my, y + s * mx + c * my
            nearest, hit = math.inf, None
            direction = heading + angle
            cd, sd = _cos(direction), _sin(direction)
            near = []
            for cx, cy, radius in candidates:
                dx, dy = cx - ox, cy - oy
                margin = radius + slack
                distance = _hypot(dx, dy)
                if distance > max_range + margin:
                    continue  # beyond the end of every ray
                if distance > margin:
                    # Seen from the sensor the disc spans its bearing +- asin(r / d);
                    # a beam whose rays all point outside that misses it.
                    bearing = _atan2(dy * cd - dx * sd, dx * cd + dy * sd)
                    if abs(bearing) > spread + _asin(margin / distance) + _ANGLE_SLACK_RAD:
                        continue
                near.append((dx, dy, margin))
            if near:
                for offset in offsets:
                    ux, uy = _cos(direction + offset), _sin(direction + offset)
                    # Cast a ray only if it passes within a radius of an obstacle's
                    # centre: a segment farther from every circle cannot hit one.
                    for dx, dy, margin in near:
                        along = dx * ux + dy * uy
                        across = dx * uy - dy * ux
                        if -margin <= along <= max_range + margin and -margin <= across <= margin:
                            break
                    else:
                        continue
                    end = (ox + max_range * ux, oy + max_range * uy)
                    result = query((ox, oy), end, 0.0, RAY_FILTER)
                    if result is not None:
                        distance = result.alpha * max_range
                        if distance < nearest:
                            point = result.point
                            nearest, hit = distance, (point.x, point.y)
            if hit is not None:
                nearest = self._reading(nearest)
                if hits is None:
                    hits = [(math.nan, math.nan)] * n
                hits[k] = hit
            ranges.append(nearest)
        self._store(ranges, hits)

    def _reading(self, distance: float) -> float:
        """A finite echo distance as the sensor reports it: noise, then the limits."""
        cfg = self.config
        if cfg.noise_std_m > 0.0:
            distance += self._rng.normal(0.0, cfg.noise_std_m)
        return min(max(distance, cfg.min_range_m), cfg.max_range_m)

    def _store(self, ranges: list[float], hits) -> None:
        """Keep the readings (a fresh array per update) and the hit points (None: none)."""
        self._ranges_list = ranges
        self._ranges = np.array(ranges, dtype=float)
        if hits is not None:
            self.hit_points[...] = hits
            self._hits_nan = False
        elif not self._hits_nan:
            self.hit_points[...] = np.nan
            self._hits_nan = True

    def _cast_all(self, arena: Arena) -> None:
        """The casts with pymunk's public API and its bounding-box query as the
        prefilter: for arenas whose space holds shapes the arena does not know."""
        cfg = self.config
        space = arena.space
        max_range = cfg.max_range_m
        ranges, hits = [], None
        for k, (origin, direction) in enumerate(self.beam_geometry(arena.pose)):
            ends = [
                (
                    origin[0] + max_range * math.cos(direction + offset),
                    origin[1] + max_range * math.sin(direction + offset),
                )
                for offset in self._offsets
            ]
            nearest, hit = math.inf, None
            # The rays are segments, so the box around their ends and the origin holds
            # them all: when no shape touches it, no ray can hit and none is cast.
            xs = [origin[0]] + [e[0] for e in ends]
            ys = [origin[1]] + [e[1] for e in ends]
            if space.bb_query(pymunk.BB(min(xs), min(ys), max(xs), max(ys)), RAY_FILTER):
                for end in ends:
                    info = space.segment_query_first(origin, end, 0.0, RAY_FILTER)
                    if info is not None:
                        distance = info.alpha * max_range
                        if distance < nearest:
                            nearest, hit = distance, (info.point.x, info.point.y)
            if hit is not None:
                nearest = self._reading(nearest)
                if hits is None:
                    hits = [(math.nan, math.nan)] * len(cfg.mounts)
                hits[k] = hit
            ranges.append(nearest)
        self._store(ranges, hits)
