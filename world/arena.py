"""The 2D world: a pymunk space with the Husky's footprint, circular obstacles and a target.

The arena does not compute dynamics of its own: the LG model gives the body's mean
forward speed ``v`` (m/s) and yaw rate ``w`` (rad/s) over each step, and the arena moves
the pymunk body with them, so the pose (x, y, heading) always comes from pymunk.
Obstacles follow the constant-acceleration law of the paper (Eq. 13-14),
``p(t) = p0 + v0 (t - t0) + a (t - t0)^2 / 2``; moving one (a drag in the viewer)
restarts its law from where it is put, keeping its current velocity.

Contacts are kept as :class:`Collision` events. The robot touches an obstacle when its
footprint-to-surface clearance is at most :data:`~world.kernels.CONTACT_CLEARANCE_M` (a
nanometre: a path tangent to an obstacle is judged alike by both engines whatever the
last bits), as the batch engine (:mod:`world.batch`) judges it; Chipmunk's own contacts
count only where that clearance confirms them. Every step is also judged as a sweep
(:meth:`Arena._sweep`), so nothing passes through anything between two steps and
:attr:`Arena.min_clearance_m` is the true minimum clearance (to within
:data:`SWEEP_SPACING_M`). The arena talks to pymunk through its public API only. How
and why: docs/robustness.md, "How collisions are judged".
"""

from __future__ import annotations

import dataclasses
import itertools
import math
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
import pymunk

from fuzzynav.world import kernels
from fuzzynav.world.geometry import rectangle_clearance
from fuzzynav.world.kernels import (
    CONTACT_CLEARANCE_M,
    arc_poses,
    law_centre,
    law_path_bound,
    law_velocity,
    swept_clearances,
)
from fuzzynav.world.kernels import SWEEP_SPACING_M as SWEEP_SPACING_M
from fuzzynav.world.robot import HUSKY
from fuzzynav.world.scenario import ObstacleSpec

ROBOT_COLLISION_TYPE = 1
OBSTACLE_COLLISION_TYPE = 2
ROBOT_CATEGORY = 0b1
# Rays ignore the robot's own shape: they see every category but the robot's.
RAY_FILTER = pymunk.ShapeFilter(mask=pymunk.ShapeFilter.ALL_MASKS() ^ ROBOT_CATEGORY)

_cos, _sin = math.cos, math.sin

#: A step is swept when the ends could misjudge the minimum clearance by more than
#: this (m) and the clearance could come below :data:`SWEEP_RELEVANT_M` in it.
SWEEP_TOLERANCE_M = 0.01
SWEEP_RELEVANT_M = 1.0
_new_tuple = tuple.__new__


@dataclass(frozen=True)
class Collision:
    time_s: float
    obstacle_id: int
    robot_xy: tuple[float, float]
    obstacle_xy: tuple[float, float]


class Obstacle:
    """A circle on its own kinematic pymunk body, moving by its law
    (:func:`world.kernels.obstacle_law`: the paper's constant acceleration)."""

    def __init__(self, obstacle_id: int, spec: ObstacleSpec, time_s: float = 0.0):
        self.id = obstacle_id
        self.radius_m = spec.radius_m
        self.body = pymunk.Body(body_type=pymunk.Body.KINEMATIC)
        self.shape = pymunk.Circle(self.body, spec.radius_m)
        self.shape.collision_type = OBSTACLE_COLLISION_TYPE
        self.shape.obstacle_id = obstacle_id
        self.spec = spec
        self.restart_law(spec.position, spec.velocity, time_s)

    def restart_law(self, position, velocity, time_s: float) -> None:
        """Start the law again at ``time_s`` from this position and velocity (a drag in
        the viewer); the scenario entry's other keys are kept."""
        self.spec = dataclasses.replace(
            self.spec,
            position=(float(position[0]), float(position[1])),
            velocity=(float(velocity[0]), float(velocity[1])),
        )
        self.law_start_s = float(time_s)
        self.is_static = self.spec.is_static
        self._law = kernels.obstacle_law(self.spec)  # plain floats, for the hot path
        self.body.position = self.spec.position

    def position_at(self, time_s: float) -> np.ndarray:
        """The centre at ``time_s``, (2,) m (:meth:`_xy_at`)."""
        return np.array(self._xy_at(time_s))

    def _xy_at(self, time_s: float) -> tuple[float, float]:
        """The centre by the law (:func:`world.kernels.law_centre`, the batch engine's
        formula on floats)."""
        return law_centre(self._law, time_s - self.law_start_s)

    def velocity_at(self, time_s: float) -> np.ndarray:
        """The velocity at ``time_s``, (2,) m/s (:func:`world.kernels.law_velocity`)."""
        return np.array(law_velocity(self._law, time_s - self.law_start_s))


class _Scene(NamedTuple):
    """The obstacles at one instant as plain floats (the arena's per-step cache).

    ``ids``, ``radii``: per obstacle in the arena's order (the same list objects until
    the obstacles are edited); ``xy``: ``(x, y)`` centres by the obstacles' laws;
    ``clearances``: footprint-to-surface distances from the current pose; ``xy_flat``:
    the centres as one flat list (for the log).
    Built with ``tuple.__new__`` in the hot path (a NamedTuple's ``__new__`` is Python).
    """

    ids: list
    radii: list
    xy: list
    clearances: list
    xy_flat: list


#: The contact shape of a point robot (paper geometry), metres.
POINT_ROBOT_RADIUS_M = 1e-4


class Arena:
    """The pymunk world holding the robot, the obstacles and the target.

    Parameters
    ----------
    footprint_m : (length, width), optional
        The robot's collision rectangle, metres (the robot's, :data:`HUSKY`, if
        omitted); ``(0, 0)`` makes the robot a point (the paper's geometry): it touches
        an obstacle when its centre enters the obstacle's disc.
    mass_kg, inertia_kg_m2 : float, optional
        Given to the pymunk body (the robot's if omitted); they never matter for the
        motion, which is set from the LG model's velocities every step.
    """

    def __init__(
        self,
        footprint_m: tuple[float, float] | None = None,
        mass_kg: float | None = None,
        inertia_kg_m2: float | None = None,
    ):
        if footprint_m is None:
            footprint_m = HUSKY.footprint_m
        mass_kg = HUSKY.mass_kg if mass_kg is None else mass_kg
        inertia_kg_m2 = HUSKY.inertia_kg_m2 if inertia_kg_m2 is None else inertia_kg_m2
        self.footprint_m = (float(footprint_m[0]), float(footprint_m[1]))
        self.space = pymunk.Space()
        self.robot = pymunk.Body(mass_kg, inertia_kg_m2)
        self.robot_shape: pymunk.Shape
        if self.footprint_m == (0.0, 0.0):
            # A point has no pymunk shape; a circle far below any obstacle's size reports
            # the moment the centre reaches a disc (to within its 0.1 mm radius).
            self.robot_shape = pymunk.Circle(self.robot, POINT_ROBOT_RADIUS_M)
        elif min(self.footprint_m) > 0.0:
            self.robot_shape = pymunk.Poly.create_box(self.robot, self.footprint_m)
        else:
            raise ValueError(
                f"footprint_m = {footprint_m!r}: both sides > 0, or (0, 0) for a point"
            )
        self.robot_shape.sensor = True
        self.robot_shape.collision_type = ROBOT_COLLISION_TYPE
        self.robot_shape.filter = pymunk.ShapeFilter(categories=ROBOT_CATEGORY)
        self.space.add(self.robot, self.robot_shape)
        self._pose = (0.0, 0.0, 0.0)
        self.space.on_collision(
            ROBOT_COLLISION_TYPE, OBSTACLE_COLLISION_TYPE, begin=self._on_contact
        )
        self.obstacles: dict[int, Obstacle] = {}
        self.target = np.zeros(2)
        self.time_s = 0.0
        self.collisions: list[Collision] = []
        #: obstacles touching (the contact rule) at the last step's end
        self._touching: set[int] = set()
        self._ids = itertools.count()
        self._obstacle_cache: tuple[np.ndarray, np.ndarray, list[int]] | None = None
        self._clearance_cache: np.ndarray | None = None
        self._scene_cache: _Scene | None = None
        self._scene_obstacles: list[Obstacle] = []
        self._scene_ids: list[int] = []
        self._scene_radii: list[float] = []
        self._static_xy: tuple[list, list] | None = None
        # Moving obstacles: (index in the scene, obstacle, Chipmunk body), and
        # (time, their centres then) from the last step, which the next one reuses.
        self._moving: list[tuple[int, Obstacle, pymunk.Body]] = []
        self._moving_xy: tuple[float, list] | None = None
        self._any_moving = False
        self.min_clearance_m = math.inf  # the true minimum over every step (swept)
        self.swept_steps = 0  # steps the sweep had to sample (for tests and benches)
        self._half_diagonal_m = 0.5 * math.hypot(*self.footprint_m)

    # -- set-up and edits (the viewer calls these while the simulation runs) ----------

    def reset(self, start, heading_rad: float, target, obstacles=()) -> None:
        for obstacle in list(self.obstacles.values()):
            self.space.remove(obstacle.body, obstacle.shape)
        self._forget_removed_shapes()
        self.obstacles.clear()
        self._changed()
        self._ids = itertools.count()
        self.time_s = 0.0
        self.collisions = []
        self._touching = set()
        self.min_clearance_m = math.inf
        self.swept_steps = 0
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
        self._scene_cache = None
        self._static_xy = None
        # New lists (never mutated): the log tells an edit by their identity.
        self._scene_obstacles = list(self.obstacles.values())
        self._scene_ids = [o.id for o in self._scene_obstacles]
        self._scene_radii = [o.radius_m for o in self._scene_obstacles]
        self._moving = [
            (i, o, o.body) for i, o in enumerate(self._scene_obstacles) if not o.is_static
        ]
        self._moving_xy = None
        self._any_moving = bool(self._moving)

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
        self._forget_removed_shapes()
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
        # Read once per step or reset, and kept as floats.
        robot = self.robot
        x, y = robot.position
        self._pose = (x, y, robot.angle)

    def _scene(self) -> _Scene:
        """The obstacles now as plain floats, cached until the next step or edit.

        The clearances are :func:`world.geometry.rectangle_clearance`, the float form of
        the batch engine's :func:`~world.geometry.rectangle_clearances`.
        """
        scene = self._scene_cache
        if scene is None:
            time_s = self.time_s
            if self._static_xy is None:
                # The static obstacles' centres never change (the law at any time is
                # p0 + 0 + 0): computed once per edit, as the old array cache did.
                xy = [obstacle._xy_at(time_s) for obstacle in self._scene_obstacles]
                self._static_xy = (xy, [v for point in xy for v in point])
            xy, xy_flat = self._static_xy
            if self._any_moving:
                moved = self._moving_xy
                cached = moved[1] if moved is not None and moved[0] == time_s else None
                xy, xy_flat = list(xy), list(xy_flat)
                for j, (i, obstacle, _) in enumerate(self._moving):
                    point = cached[j] if cached is not None else obstacle._xy_at(time_s)
                    xy[i] = point
                    xy_flat[2 * i], xy_flat[2 * i + 1] = point
            x, y, heading = self._pose
            c, s = _cos(heading), _sin(heading)
            length, width = self.footprint_m
            hx, hy = 0.5 * length, 0.5 * width
            clearances = [
                rectangle_clearance(c, s, cx - x, cy - y, radius, hx, hy)
                for (cx, cy), radius in zip(xy, self._scene_radii)
            ]
            scene = self._scene_cache = _new_tuple(
                _Scene, (self._scene_ids, self._scene_radii, xy, clearances, xy_flat)
            )
        return scene

    def _ray_candidates(self, reach_m: float):
        """Obstacles a ray from within ``reach_m`` of the robot's centre might hit.

        Returns a list of ``(x, y, radius)`` (empty when nothing is in reach), or None
        when the space holds shapes the arena does not know (then ask pymunk).
        """
        if len(self.space.shapes) != len(self.obstacles) + 1:
            return None
        scene = self._scene()
        x, y, _ = self._pose
        found = []
        for (cx, cy), radius in zip(scene.xy, scene.radii):
            limit = reach_m + radius
            dx, dy = cx - x, cy - y
            if dx * dx + dy * dy <= limit * limit:
                found.append((cx, cy, radius))
        return found

    def obstacle_arrays(self) -> tuple[np.ndarray, np.ndarray, list[int]]:
        """(centres (n, 2), radii (n,), ids) of the obstacles now."""
        if self._obstacle_cache is None:
            scene = self._scene()
            centres = np.array(scene.xy, dtype=float).reshape(-1, 2)
            radii = np.array(scene.radii, dtype=float)
            self._obstacle_cache = (centres, radii, list(scene.ids))
        return self._obstacle_cache

    def clearances(self) -> np.ndarray:
        """Footprint-to-surface distance of each obstacle (m, negative when overlapping)."""
        if self._clearance_cache is None:
            self._clearance_cache = np.array(self._scene().clearances, dtype=float)
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
        speed = forward_speed_m_s * chord_scale
        robot = self.robot
        mid_heading = self._pose[2] + half_turn
        robot.velocity = (speed * _cos(mid_heading), speed * _sin(mid_heading))
        robot.angular_velocity = yaw_rate_rad_s

        t_now = self.time_s
        t_next = t_now + dt_s
        before = self._scene() if self._scene_obstacles else None
        pose_before = self._pose
        moving = self._moving
        if moving:
            # Kinematic bodies move by their velocity; give them the chord of the step
            # so the position at t_next matches the law exactly.
            # (Plain loops: a comprehension costs a function call in Python 3.11.)
            moved = self._moving_xy
            cached = moved[1] if moved is not None and moved[0] == t_now else None
            after = []
            for j, (_, obstacle, body) in enumerate(moving):
                x0, y0 = cached[j] if cached is not None else obstacle._xy_at(t_now)
                x1, y1 = obstacle._xy_at(t_next)
                after.append((x1, y1))
                body.velocity = ((x1 - x0) / dt_s, (y1 - y0) / dt_s)
        first_new = len(self.collisions)
        self.space.step(dt_s)
        self.time_s = t_next
        x, y = robot.position
        self._pose = (x, y, robot.angle)
        self._clearance_cache = None
        self._scene_cache = None
        if moving:
            self._obstacle_cache = None
            for j, (_, _, body) in enumerate(moving):
                body.position = after[j]
            self._moving_xy = (t_next, after)
        if len(self.collisions) > first_new:
            self._confirm_contacts(first_new)
        if before is not None:
            self._sweep(
                before, pose_before, forward_speed_m_s, yaw_rate_rad_s, t_now, dt_s, first_new
            )
        return self.collisions[first_new:] if len(self.collisions) > first_new else []

    def _confirm_contacts(self, first_new: int) -> None:
        """Keep of the contacts Chipmunk began in this step only those the one contact
        rule confirms: a footprint-to-surface clearance at most
        :data:`~world.kernels.CONTACT_CLEARANCE_M` at the step's end (:meth:`_scene`,
        the batch engine's formula). Chipmunk's own overlap test differs from the formula
        by a few 1e-16 m at a tangent touch, where it saw contacts the batch engine did
        not. The paper's point robot keeps Chipmunk's judgement."""
        if self.footprint_m == (0.0, 0.0):
            return
        scene = self._scene()
        clearance_of = dict(zip(scene.ids, scene.clearances))
        self.collisions[first_new:] = [
            event
            for event in self.collisions[first_new:]
            if clearance_of.get(event.obstacle_id, 0.0) <= CONTACT_CLEARANCE_M
        ]

    # -- the swept test ----------------------------------------------------------------

    def _sweep(
        self, before: _Scene, pose0, v: float, w: float, t0: float, dt: float, first_new: int
    ):
        """Judge the step [t0, t0 + dt] as a sweep, not only at its ends.

        The clearance c(t) of an obstacle changes at most as fast as the robot's
        footprint and the obstacle move relative to each other, so over the step it
        stays above ``(c0 + c1 - D) / 2`` (c0, c1 at the ends, D a bound on the
        relative path length: ``|v| dt + |w| dt * half-diagonal`` plus the obstacle's
        path). Only where that bound is lower than the ends by more than
        :data:`SWEEP_TOLERANCE_M` (a fast obstacle, a fast turn next to one) are the
        exact motions sampled every :data:`SWEEP_SPACING_M` of relative motion: the
        smallest sample updates :attr:`min_clearance_m`, and a contact that began and
        ended inside the step, which pymunk never saw, is logged as a
        :class:`Collision` at its first sampled instant.
        """
        after = self._scene()
        if after.ids is not before.ids:  # edited meanwhile: nothing to compare
            return
        robot_path = (abs(v) + abs(w) * self._half_diagonal_m) * dt
        smallest = self.min_clearance_m
        reported = {c.obstacle_id for c in self.collisions[first_new:]}
        touch_rule = self.footprint_m != (0.0, 0.0)
        touch = CONTACT_CLEARANCE_M if touch_rule else 0.0
        touching = set()
        touched: dict[int, int] = {}  # obstacle id -> its event's index, by the rule
        for j, (c0, c1) in enumerate(zip(before.clearances, after.clearances)):
            low = min(c0, c1)
            if low < smallest:
                smallest = low
            obstacle = self._scene_obstacles[j]
            if touch_rule and c1 <= touch:
                touching.add(obstacle.id)
                if c0 > touch and obstacle.id not in reported:
                    # the one contact rule: clearance <= CONTACT_CLEARANCE_M (the
                    # sweep below may still place its start earlier in the step)
                    touched[obstacle.id] = len(self.collisions)
                    x, y, _ = self._pose
                    ox, oy = after.xy[j]
                    self.collisions.append(Collision(t0 + dt, obstacle.id, (x, y), (ox, oy)))
                    reported.add(obstacle.id)
            path = robot_path
            if not obstacle.is_static:
                path += law_path_bound(obstacle._law, t0 - obstacle.law_start_s, dt)
            bound = 0.5 * (c0 + c1 - path)
            if bound >= low - SWEEP_TOLERANCE_M or bound >= SWEEP_RELEVANT_M:
                continue
            self.swept_steps += 1
            length, width = self.footprint_m
            clearance, tau = swept_clearances(
                pose0, v, w, dt, obstacle._law, obstacle.radius_m,
                t0 - obstacle.law_start_s, 0.5 * length, 0.5 * width, path,
            )  # fmt: skip
            k = int(np.argmin(clearance))
            if clearance[k] < smallest:
                smallest = float(clearance[k])
            if (
                c0 > touch
                and clearance[k] <= touch
                and (obstacle.id not in reported or obstacle.id in touched)
            ):
                first = int(np.argmax(clearance <= touch))
                x, y, _ = (float(p) for p in arc_poses(pose0, v, w, tau[first]))
                ox, oy = obstacle._xy_at(t0 + float(tau[first]))
                event = Collision(t0 + float(tau[first]), obstacle.id, (x, y), (ox, oy))
                if obstacle.id in touched:  # the sweep found its start: earlier
                    self.collisions[touched.pop(obstacle.id)] = event
                else:
                    self.collisions.append(event)
        self.min_clearance_m = smallest
        self._touching = touching

    def _forget_removed_shapes(self) -> None:
        """Let pymunk let go of the shapes just removed: it keeps them until its next
        step (for a step's callbacks), and resets without a step kept them all (300
        viewer Resets among 200 obstacles: 58 MB). A step of 0 s does it and moves
        nothing (Chipmunk returns at once on a zero step)."""
        self.space.step(0.0)

    def _on_contact(self, arbiter: pymunk.Arbiter, space: pymunk.Space, data) -> None:
        robot_shape, other = arbiter.shapes
        if other is self.robot_shape:
            robot_shape, other = other, robot_shape
        obstacle_id = getattr(other, "obstacle_id", -1)
        if obstacle_id in self._touching:
            return  # a touch the contact rule counted at the last step's end, deepening
        p = self.robot.position
        q = other.body.position  # type: ignore[union-attr]  # an obstacle's shape has a body
        self.collisions.append(
            Collision(self.time_s + space.current_time_step, obstacle_id, (p.x, p.y), (q.x, q.y))
        )
