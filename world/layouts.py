"""Seeded random layouts for sweeps: does a controller generalise beyond three scenarios?

Families
--------
``standard``
    The standard sweep: 1-4 static obstacles of radius 0.15-0.35 m near the straight
    start-target line, every gap between two obstacles passable (wider than the robot
    plus both safe distances), a moving obstacle in a quarter of the layouts, a random
    start heading, the target 6-12 m away in a random direction.
``clutter``
    Denser: 5-9 static obstacles in a corridor around the line, gaps still passable.
``u_trap``
    A U-shaped cup of obstacles across the line, open away from the robot, so that
    driving straight at the target ends in a dead end (a local minimum).
``two_moving``
    1-2 static obstacles and two moving ones crossing the line.
``paper_jitter``
    The paper's scenarios s1, s2, s3 in turn (layout ``i`` is s``i % 3 + 1``), each
    jittered by less than the paper's figures can be read: every static obstacle moved
    by up to +-5 cm in x and y, every moving obstacle's acceleration (and velocity)
    scaled by 0.95-1.05 per axis, the start heading turned by up to +-0.03 rad; the
    disturbance of s3 kept. A result on s1-s3 that does not survive this is luck.

Layout ``i`` of a sweep with seed ``s`` comes from ``numpy.random.default_rng([s, i])``,
so the first ``n`` layouts of a seed are the same whatever the sweep's size. Every
layout is checked by :func:`world.scenario.check_layout`, like a scenario file.
"""

from __future__ import annotations

import dataclasses
import functools
import math

import numpy as np

from fuzzynav.world.robot import HUSKY, RobotDescription
from fuzzynav.world.scenario import (
    ObstacleSpec,
    Scenario,
    ScenarioError,
    check_layout,
    load_scenario,
)

FAMILIES = ("standard", "clutter", "u_trap", "two_moving", "paper_jitter")
JITTER_POSITION_M = 0.05
JITTER_MOTION_SCALE = 0.05
JITTER_HEADING_RAD = 0.03

SAFE_DISTANCE_M = 0.25


def passable_gap_m(robot: RobotDescription = HUSKY) -> float:
    """The narrowest gap a layout leaves between two obstacles: the robot fits with its
    safe distance on both sides.

    Parameters
    ----------
    robot : RobotDescription
        The robot the layouts are drawn for (its footprint's width).

    Returns
    -------
    float
        Metres.
    """
    return robot.footprint_m[1] + 2 * SAFE_DISTANCE_M


#: The passable gap for the Husky (:func:`passable_gap_m`).
PASSABLE_GAP_M = passable_gap_m(HUSKY)
START_CLEAR_M = 1.2  # no obstacle surface this close to the start centre
TARGET_CLEAR_M = 1.0  # nor to the target, so that it can be reached safely


def _duration_s(distance_m: float) -> float:
    # Generous: a slow, careful controller at 0.15 m/s still arrives.
    return 30.0 + distance_m / 0.15


def _frame(rng: np.random.Generator):
    """Start at the origin, the target 6-12 m away in a random direction."""
    distance = rng.uniform(6.0, 12.0)
    bearing = rng.uniform(-math.pi, math.pi)
    target = np.array((distance * math.cos(bearing), distance * math.sin(bearing)))
    along = target / distance
    across = np.array((-along[1], along[0]))
    return np.zeros(2), target, along, across, distance


def _fits(centre, radius, placed, start, target, gap_m) -> bool:
    if np.linalg.norm(centre - start) - radius < START_CLEAR_M:
        return False
    if np.linalg.norm(centre - target) - radius < TARGET_CLEAR_M:
        return False
    return all(np.linalg.norm(centre - c) - radius - r >= gap_m for c, r in placed)


def _scatter(
    rng,
    count,
    start,
    target,
    along,
    across,
    distance,
    *,
    lateral_m,
    gap_m,
    placed=None,
    radius_range=(0.15, 0.35),
    tries=200,
):
    placed = list(placed or [])
    for _ in range(count):
        for _ in range(tries):
            radius = rng.uniform(*radius_range)
            centre = (
                start
                + along * rng.uniform(0.15, 0.85) * distance
                + across * rng.uniform(-lateral_m, lateral_m)
            )
            if _fits(centre, radius, placed, start, target, gap_m):
                placed.append((centre, radius))
                break
    return placed


def _moving(rng, start, target, along, across, distance):
    """A moving obstacle that crosses the line somewhere in its middle part.

    Constant velocity or the paper's constant acceleration from rest, half and half.
    """
    radius = rng.uniform(0.2, 0.35)
    crossing = start + along * rng.uniform(0.3, 0.8) * distance
    side = rng.choice((-1.0, 1.0))
    offset = rng.uniform(2.0, 4.0)
    origin = crossing + side * across * offset
    if np.linalg.norm(origin - start) - radius < START_CLEAR_M:
        origin = crossing + side * across * (offset + 2.0)
    arrival_s = rng.uniform(10.0, 40.0)  # when it would reach the line
    towards = -side * across
    if rng.random() < 0.5:
        velocity = towards * offset / arrival_s
        acceleration = np.zeros(2)
    else:
        velocity = np.zeros(2)
        acceleration = towards * 2.0 * offset / arrival_s**2
    return ObstacleSpec(tuple(origin), radius, tuple(velocity), tuple(acceleration))


def _u_trap(rng, start, target, along, across, distance):
    """Circles on a U: the bottom across the line, the arms reaching back to the robot."""
    radius = 0.25
    depth = rng.uniform(0.4, 0.6) * distance
    half_width = rng.uniform(1.2, 1.8)
    arm = rng.uniform(1.2, 2.0)
    pitch = 2 * radius + 0.1  # closer than the robot is wide: no way through the walls
    bottom = start + along * depth
    points = []
    for s in np.arange(-half_width, half_width + 1e-9, pitch):
        points.append(bottom + across * s)
    for side in (-1.0, 1.0):
        for b in np.arange(pitch, arm + 1e-9, pitch):
            points.append(bottom + across * side * half_width - along * b)
    return [(p, radius) for p in points]


def generate_layout(
    family: str, seed: int, index: int, robot: RobotDescription = HUSKY
) -> Scenario:
    """Layout ``index`` of family ``family`` for sweep seed ``seed``.

    Parameters
    ----------
    family : str
        One of :data:`FAMILIES`.
    seed : int
        The sweep's seed.
    index : int
        The layout's number in the sweep.
    robot : RobotDescription
        The robot it is drawn for: gaps it passes (:func:`passable_gap_m`), a start its
        footprint clears.

    Returns
    -------
    Scenario
    """
    if family not in FAMILIES:
        raise ValueError(f"family = {family!r}: must be one of {', '.join(FAMILIES)}")
    for attempt in range(50):
        rng = np.random.default_rng([seed, index, FAMILIES.index(family), attempt])
        try:
            return _draw(family, rng, seed, index, robot)
        except ScenarioError:
            continue  # e.g. a trap arm under the start footprint: draw again
    raise RuntimeError(f"no valid {family} layout for seed {seed}, index {index} in 50 draws")


@functools.cache
def _paper_scenario(name: str) -> Scenario:
    return load_scenario(name)  # frozen: safe to share between layouts


def _jitter(rng: np.random.Generator, seed: int, index: int, robot: RobotDescription) -> Scenario:
    name = f"s{index % 3 + 1}"
    base = _paper_scenario(name)
    obstacles = []
    for o in base.obstacles:
        if o.is_static:
            shift = rng.uniform(-JITTER_POSITION_M, JITTER_POSITION_M, 2)
            obstacles.append(
                dataclasses.replace(
                    o, position=(o.position[0] + float(shift[0]), o.position[1] + float(shift[1]))
                )
            )
        else:
            scale = rng.uniform(1 - JITTER_MOTION_SCALE, 1 + JITTER_MOTION_SCALE, 2)
            obstacles.append(
                dataclasses.replace(
                    o,
                    velocity=(o.velocity[0] * float(scale[0]), o.velocity[1] * float(scale[1])),
                    acceleration=(
                        o.acceleration[0] * float(scale[0]),
                        o.acceleration[1] * float(scale[1]),
                    ),
                )
            )
    scenario = base.replace(
        name=f"paper_jitter #{index}: {name} jittered (seed {seed})",
        heading_rad=base.heading_rad + float(rng.uniform(-JITTER_HEADING_RAD, JITTER_HEADING_RAD)),
        obstacles=tuple(obstacles),
        source=f"<layout paper_jitter seed={seed} index={index}>",
    )
    check_layout(scenario, robot.footprint_m)
    return scenario


def _draw(
    family: str, rng: np.random.Generator, seed: int, index: int, robot: RobotDescription
) -> Scenario:
    if family == "paper_jitter":
        return _jitter(rng, seed, index, robot)
    start, target, along, across, distance = _frame(rng)
    gap_m = passable_gap_m(robot)
    moving: list[ObstacleSpec] = []
    if family == "standard":
        placed = _scatter(
            rng,
            int(rng.integers(1, 5)),
            start,
            target,
            along,
            across,
            distance,
            lateral_m=1.0,
            gap_m=gap_m,
        )
        if rng.random() < 0.25:
            moving.append(_moving(rng, start, target, along, across, distance))
    elif family == "clutter":
        placed = _scatter(
            rng,
            int(rng.integers(5, 10)),
            start,
            target,
            along,
            across,
            distance,
            lateral_m=2.5,
            gap_m=gap_m,
        )
    elif family == "u_trap":
        placed = _u_trap(rng, start, target, along, across, distance)
    else:
        placed = _scatter(
            rng,
            int(rng.integers(1, 3)),
            start,
            target,
            along,
            across,
            distance,
            lateral_m=1.0,
            gap_m=gap_m,
        )
        moving = [_moving(rng, start, target, along, across, distance) for _ in range(2)]
    statics = [ObstacleSpec((float(c[0]), float(c[1])), float(r)) for c, r in placed]
    scenario = Scenario(
        name=f"{family} #{index} (seed {seed})",
        duration_s=_duration_s(distance),
        start=(0.0, 0.0),
        heading_rad=float(rng.uniform(-math.pi, math.pi)),
        target=(float(target[0]), float(target[1])),
        tolerance_m=0.15,
        obstacles=tuple(statics + moving),
        source=f"<layout {family} seed={seed} index={index}>",
    )
    check_layout(scenario, robot.footprint_m)
    return scenario


def generate_layouts(
    family: str, n: int, seed: int, robot: RobotDescription = HUSKY
) -> list[Scenario]:
    """The first ``n`` layouts of a family for a seed.

    Parameters
    ----------
    family : str
        One of :data:`FAMILIES`.
    n : int
        How many.
    seed : int
        The sweep's seed.
    robot : RobotDescription
        The robot they are drawn for (:func:`generate_layout`).

    Returns
    -------
    list of Scenario
    """
    return [generate_layout(family, seed, i, robot) for i in range(n)]


#: How far past tangency a tangent layout's obstacle may sit (m, + outside the robot's
#: swept band, - inside it): 0 and a few last bits either side.
TANGENT_OFFSETS_M = (0.0, 1e-16, 5e-16, 1e-15, 2e-15, -1e-16)


def tangent_layout(seed: int, index: int, robot: RobotDescription = HUSKY) -> Scenario:
    """A layout whose one obstacle's path is tangent to the robot's straight path: the
    obstacle (static, or moving along the robot's line, either way) sits half the
    robot's width plus its radius off the start-target line, plus one of
    :data:`TANGENT_OFFSETS_M`. A robot driven straight at the target grazes it; which
    side of the contact rule a graze falls on is decided by a nanometre
    (:data:`world.kernels.CONTACT_CLEARANCE_M`), not by the last bits of either engine
    (``bench/bench_batch.py --tangent N``, ``tests/test_tangent.py``).

    Parameters
    ----------
    seed, index : int
        Layout ``index`` of the search with this seed (``default_rng([seed, index])``).
    robot : RobotDescription
        The robot whose width sets the tangent (the Husky if omitted).

    Returns
    -------
    Scenario
    """
    rng = np.random.default_rng([seed, index])
    heading = float(rng.uniform(-math.pi, math.pi))
    distance = float(rng.uniform(6.0, 12.0))
    radius = float(rng.uniform(0.1, 0.6))
    ux, uy = math.cos(heading), math.sin(heading)
    side = float(rng.choice([-1.0, 1.0]))
    offset = float(TANGENT_OFFSETS_M[int(rng.integers(len(TANGENT_OFFSETS_M)))])
    across = side * (robot.half_width_m + radius + offset)
    along = float(rng.uniform(2.0, distance - 1.0))
    speed = float(rng.uniform(-0.8, 0.8)) if index % 2 else 0.0
    obstacle = ObstacleSpec(
        (along * ux - across * uy, along * uy + across * ux),
        radius,
        velocity=(speed * ux, speed * uy),
    )
    scenario = Scenario(
        name=f"tangent #{index} (seed {seed})",
        duration_s=_duration_s(distance),
        start=(0.0, 0.0),
        heading_rad=heading,
        target=(distance * ux, distance * uy),
        tolerance_m=0.15,
        obstacles=(obstacle,),
    )
    check_layout(scenario, robot.footprint_m)
    return scenario
