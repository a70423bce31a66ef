"""The 2D world: a pymunk space with the Husky's footprint, circular obstacles and a target.

The arena does not compute dynamics of its own: the LG model gives the body's mean
forward speed ``v`` (m/s) and yaw rate ``w`` (rad/s) over each step, and the arena moves
the pymunk body with them, so the pose (x, y, heading) always comes from pymunk.

Obstacles follow the constant-acceleration law of the paper (Eq. 13-14),
``p(t) = p0 + v0 (t - t0) + a (t - t0)^2 / 2``. Moving an obstacle (a drag in the viewer)
restarts its law from where it is put, keeping its current velocity.

Contacts are reported by pymunk in the step they happen (the robot's shape is a sensor,
so pymunk reports the overlap without pushing anything) and kept as
:class:`Collision` events; nothing passes through anything silently.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass

import numpy as np
import pymunk

from world.geometry import rectangle_circle_clearance
from world.scenario import ObstacleSpec

ROBOT_COLLISION_TYPE = 1
OBSTACLE_COLLISION_TYPE = 2
ROBOT_CATEGORY = 0b1
# Rays ignore the robot's own shape: they see every category but the robot's.
RAY_FILTER = pymunk.ShapeFilter(mask=pymunk.ShapeFilter.ALL_MASKS() ^ ROBOT_CATEGORY)


@dataclass(frozen=True)
class Collision:
    time_s: float
    obstacle_id: int
    robot_xy: tuple[float, float]
    obstacle_xy: tuple[float, float]


class Obstacle:
    """A circle on its own kinematic pymunk body, moving by a constant-acceleration law."""

    def __init__(self, obstacle_id: int, spec: ObstacleSpec, time_s: float = 0.0):
        self.id = obstacle_id
        self.radius_m = spec.radius_m
        self.body = pymunk.Body(body_type=pymunk.Body.KINEMATIC)
        self.shape = pymunk.Circle(self.body, spec.radius_m)
        self.shape.collision_type = OBSTACLE_COLLISION_TYPE
        self.shape.obstacle_id = obstacle_id
        self.acceleration = np.asarray(spec.acceleration, dtype=float)
        self.restart_law(spec.position, spec.velocity, time_s)

    def restart_law(self, position, velocity, time_s: float) -> None:
        self.initial_position = np.asarray(position, dtype=float)
        self.initial_velocity = np.asarray(velocity, dtype=float)
        self.law_start_s = time_s
        self.is_static = not (self.initial_velocity.any() or self.acceleration.any())
        self.body.position = tuple(self.initial_position)

    def position_at(self, time_s: float) -> np.ndarray:
        tau = time_s - self.law_start_s
        return self.initial_position + self.initial_velocity * tau + 0.5 * self.acceleration * tau * tau

    def velocity_at(self, time_s: float) -> np.ndarray:
        return self.initial_velocity + self.acceleration * (time_s - self.law_start_s)

    def spec_at(self, time_s: float) -> ObstacleSpec:
        """The obstacle as a scenario entry, as if its law started at ``time_s``."""
        return ObstacleSpec(tuple(self.position_at(time_s)), self.radius_m,
                            tuple(self.velocity_at(time_s)), tuple(self.acceleration))


class Arena:
    """The pymunk world holding the robot, the obstacles and the target.

    Parameters
    ----------
    footprint_m : (length, width)
        The robot's collision rectangle, metres (real Husky A200: 0.99 x 0.67).
    mass_kg, inertia_kg_m2 : float
        Given to the pymunk body; they never matter for the motion, which is set from
        the LG model's velocities every step.
    """

    def __init__(self, footprint_m=(0.99, 0.67), mass_kg: float = 48.39,
                 inertia_kg_m2: float = 3.0556):
        self.footprint_m = (float(footprint_m[0]), float(footprint_m[1]))
        self.space = pymunk.Space()
        self.robot = pymunk.Body(mass_kg, inertia_kg_m2)
        self.robot_shape = pymunk.Poly.create_box(self.robot, self.footprint_m)
        self.robot_shape.sensor = True
        self.robot_shape.collision_type = ROBOT_COLLISION_TYPE
        self.robot_shape.filter = pymunk.ShapeFilter(categories=ROBOT_CATEGORY)
        self.space.add(self.robot, self.robot_shape)
        self._pose = (0.0, 0.0, 0.0)
        self.space.on_collision(ROBOT_COLLISION_TYPE, OBSTACLE_COLLISION_TYPE,
                                begin=self._on_contact)
        self.obstacles: dict[int, Obstacle] = {}
        self.target = np.zeros(2)
        self.time_s = 0.0
        self.collisions: list[Collision] = []
        self._ids = itertools.count()
        self._obstacle_cache: tuple[np.ndarray, np.ndarray, list[int]] | None = None
        self._clearance_cache: np.ndarray | None = None
        self._any_moving = False

    # -- set-up and edits (the viewer calls these while the simulation runs) ----------

    def reset(self, start, heading_rad: float, target, obstacles=()) -> None:
        for obstacle in list(self.obstacles.values()):
            self.space.remove(obstacle.body, obstacle.shape)
        self.obstacles.clear()
        self._changed()
        self._ids = itertools.count()
        self.time_s = 0.0
        self.collisions = []
        self.robot.position = (float(start[0]), float(start[1]))
        self.robot.angle = float(heading_rad)
        self.robot.velocity = (0.0, 0.0)
        self.robot.angular_velocity = 0.0
        self.space.reindex_shapes_for_body(self.robot)
        self._read_pose()
        self.target = np.array(target, dtype=float)
        for spec in obstacles:
            self.add_obstacle(spec)

    def _changed(self) -> None:
        self._obstacle_cache = None
        self._clearance_cache = None
        self._any_moving = any(not o.is_static for o in self.obstacles.values())

    def add_obstacle(self, spec: ObstacleSpec) -> int:
        """Add an obstacle whose law starts now; returns its id."""
        obstacle = Obstacle(next(self._ids), spec, self.time_s)
        self.obstacles[obstacle.id] = obstacle
        self.space.add(obstacle.body, obstacle.shape)
        self._changed()
        return obstacle.id

    def remove_obstacle(self, obstacle_id: int) -> None:
        obstacle = self.obstacles.pop(obstacle_id)
        self.space.remove(obstacle.body, obstacle.shape)
        self._changed()

    def move_obstacle(self, obstacle_id: int, position) -> None:
        """Put an obstacle somewhere else now; a moving one keeps its law from there."""
        obstacle = self.obstacles[obstacle_id]
        obstacle.restart_law(position, obstacle.velocity_at(self.time_s), self.time_s)
        self.space.reindex_shapes_for_body(obstacle.body)
        self._changed()

    def move_target(self, position) -> None:
        self.target = np.array(position, dtype=float)

    # -- state -------------------------------------------------------------------------

    @property
    def pose(self) -> tuple[float, float, float]:
        """(x m, y m, heading rad) as pymunk holds it (heading not wrapped)."""
        return self._pose

    def _read_pose(self) -> None:
        # Reading pymunk's Vec2d costs microseconds; the pose changes only in step/reset.
        p = self.robot.position
        self._pose = (p.x, p.y, self.robot.angle)

    def obstacle_arrays(self) -> tuple[np.ndarray, np.ndarray, list[int]]:
        """(centres (n, 2), radii (n,), ids) of the obstacles now."""
        if self._obstacle_cache is None:
            ids = list(self.obstacles)
            centres = np.array([self.obstacles[i].position_at(self.time_s) for i in ids],
                               dtype=float).reshape(-1, 2)
            radii = np.array([self.obstacles[i].radius_m for i in ids], dtype=float)
            self._obstacle_cache = (centres, radii, ids)
        return self._obstacle_cache

    def clearances(self) -> np.ndarray:
        """Footprint-to-surface distance of each obstacle (m, negative when overlapping)."""
        if self._clearance_cache is None:
            centres, radii, _ = self.obstacle_arrays()
            xy, heading = self._pose[:2], self._pose[2]
            length, width = self.footprint_m
            # A scalar loop beats numpy for the handful of obstacles a scene holds.
            self._clearance_cache = np.array(
                [rectangle_circle_clearance(xy, heading, length, width, c, r)
                 for c, r in zip(centres.tolist(), radii.tolist())])
        return self._clearance_cache

    # -- stepping ----------------------------------------------------------------------

    def step(self, forward_speed_m_s: float, yaw_rate_rad_s: float, dt_s: float) -> list[Collision]:
        """Advance the world by ``dt_s`` with the body's mean velocities over the step.

        With v and w constant over the step the body moves along an exact circular arc;
        the chord of that arc is ``v dt sinc(w dt / 2)`` long and points along the
        heading at mid-step, which is what the velocity given to pymunk encodes.
        Returns the contacts that began in this step.
        """
        half_turn = 0.5 * yaw_rate_rad_s * dt_s
        chord_scale = math.sin(half_turn) / half_turn if abs(half_turn) > 1e-9 else 1.0
        mid_heading = self.robot.angle + half_turn
        speed = forward_speed_m_s * chord_scale
        self.robot.velocity = (speed * math.cos(mid_heading), speed * math.sin(mid_heading))
        self.robot.angular_velocity = yaw_rate_rad_s

        t_next = self.time_s + dt_s
        for obstacle in self.obstacles.values() if self._any_moving else ():
            if not obstacle.is_static:
                # Kinematic bodies move by their velocity; give them the chord of the step
                # so the position at t_next matches the law exactly.
                chord = (obstacle.position_at(t_next) - obstacle.position_at(self.time_s)) / dt_s
                obstacle.body.velocity = (float(chord[0]), float(chord[1]))
        first_new = len(self.collisions)
        self.space.step(dt_s)
        self.time_s = t_next
        self._read_pose()
        self._clearance_cache = None
        if self._any_moving:
            self._obstacle_cache = None
            for obstacle in self.obstacles.values():
                if not obstacle.is_static:
                    obstacle.body.position = tuple(obstacle.position_at(t_next))
        return self.collisions[first_new:]

    def _on_contact(self, arbiter: pymunk.Arbiter, space: pymunk.Space, data) -> None:
        robot_shape, other = arbiter.shapes
        if other is self.robot_shape:
            robot_shape, other = other, robot_shape
        obstacle_id = getattr(other, "obstacle_id", -1)
        p = self.robot.position
        q = other.body.position
        self.collisions.append(Collision(self.time_s + space.current_time_step, obstacle_id,
                                         (p.x, p.y), (q.x, q.y)))
