"""Perception: from what the robot senses to the controller's four inputs.

The inputs are in the paper's order ``(d_t, d_o, phi_t, phi_o)``:

``d_t`` (m)
    Distance from the robot's centre to the target (the paper's radar, Eq. 7).
``d_o`` (m)
    Distance from the robot's body to the nearest obstacle's surface, or NaN ("nothing
    detected") beyond the paper's 3 m cutoff, so that the obstacle rules do not fire.
``phi_t`` (rad)
    Bearing of the target relative to the heading, wrapped to (-pi, pi] (Eq. 10);
    positive means the target is to the left.
``phi_o`` (rad)
    Bearing of the nearest obstacle relative to the heading, (-pi, pi]; NaN with d_o.

Two geometries (``geometry``):

``husky``
    The real Husky's footprint (``world.robot.HUSKY``, husky.toml): ``d_o`` is
    footprint to surface.
``paper``
    The paper's point robot: ``d_t``, ``d_o``, ``phi_t``, ``phi_o`` exactly by Eqs. 7-12
    from the robot's centre to the target's and the obstacles' centres (the nearest
    obstacle by centre distance). Only ``ideal`` perception: the paper computes its inputs
    from positions, and a range sensor cannot see a centre.

Two modes:

``ideal``
    The exact footprint-to-surface distance of the nearest obstacle and the bearing of
    its centre, among the obstacles whose centre bears within the field of view
    (``field_of_view_rad``, centred on the heading; default all around the robot).
    The paper's scenarios s1-s3 set the front half-plane (``robot.field_of_view_deg =
    180`` in their files): its robot senses obstacles with three front-mounted US-100s,
    which see nothing behind the axle line (docs/paper-controller.md).
``ultrasonic``
    From the range sensors (any number): ``d_o`` is the smallest reading and ``phi_o`` is the
    mounting angle of the sensor that reads it (an ultrasonic sensor cannot say where in
    its cone the echo came from). Obstacles outside the beams are not seen.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from fuzzynav.world.arena import Arena
from fuzzynav.world.geometry import FULL_CIRCLE_RAD
from fuzzynav.world.kernels import nearest_obstacle, sonar_obstacle_input, target_input
from fuzzynav.world.sensors import RangeSensorArray

OBSTACLE_CUTOFF_M = 3.0
PERCEPTION_MODES = ("ideal", "ultrasonic")
GEOMETRIES = ("husky", "paper")
INPUT_NAMES = ("d_t", "d_o", "phi_t", "phi_o")


def check_geometry(geometry: str, perception: str = "ideal") -> None:
    """Refuse an unknown geometry, and the paper's point robot with range sensors."""
    if geometry not in GEOMETRIES:
        raise ValueError(f"geometry = {geometry!r}: must be one of {', '.join(GEOMETRIES)}")
    if geometry == "paper" and perception != "ideal":
        raise ValueError(
            f"perception = {perception!r} with geometry = 'paper': the paper's robot is a "
            "point whose inputs are Eqs. 7-12 from positions; use perception 'ideal' "
            "(or geometry 'husky' for the range sensors)"
        )


def check_controller(controller) -> None:
    """ValueError, with a sentence, unless ``controller`` is what the loop drives with
    these inputs: an object with ``reset()`` (called at every start) and
    ``__call__(inputs) -> voltages``. The simulation checks it before anything starts
    (one without ``reset()`` is refused here, not deep inside with an AttributeError)."""
    missing = [
        what
        for what, present in (
            ("reset() method", callable(getattr(controller, "reset", None))),
            ("__call__(inputs)", callable(controller)),
        )
        if not present
    ]
    if missing:
        from fuzzynav.resources import shown

        raise ValueError(
            f"controller = {shown(controller)}: has no {' and no '.join(missing)}; a "
            "controller is an object with reset() (called at every start) and "
            "__call__(inputs) -> (left, right) voltages"
        )


@dataclass(frozen=True)
class ControlContext:
    """What a controller that declares ``needs_context = True`` is given besides its
    inputs, as ``controller(inputs, context=ControlContext(...))``: the
    world as the simulation knows it at the decision. A controller meant to reproduce the
    paper should not need it; one that plans, learns or is judged against the truth may.

    Attributes
    ----------
    time_s : float
        Simulated time of the decision, s.
    period_s : float
        The control period, s.
    pose : tuple of float
        The robot's (x m, y m, heading rad).
    target : tuple of float
        The target's (x m, y m).
    obstacles : tuple of tuple of float
        Every obstacle as ``(x m, y m, radius m)`` at ``time_s``, whether sensed or not.
    ranges_m : tuple of float
        The sonar readings (left, front, right; m, inf = nothing in range).
    """

    time_s: float
    period_s: float
    pose: tuple[float, float, float]
    target: tuple[float, float]
    obstacles: tuple[tuple[float, float, float], ...]
    ranges_m: tuple[float, ...]


def control_context(arena: Arena, period_s: float, ranges) -> ControlContext:
    """The :class:`ControlContext` of ``arena`` now.

    Parameters
    ----------
    arena : Arena
        The world.
    period_s : float
        The control period, s.
    ranges : sequence of float
        The sonar readings this period.
    """
    centres, radii, _ = arena.obstacle_arrays()
    return ControlContext(
        time_s=float(arena.time_s),
        period_s=float(period_s),
        pose=tuple(float(v) for v in arena.pose),  # type: ignore[arg-type]
        target=(float(arena.target[0]), float(arena.target[1])),
        obstacles=tuple(
            (float(x), float(y), float(r)) for (x, y), r in zip(centres.tolist(), radii.tolist())
        ),
        ranges_m=tuple(float(v) for v in np.asarray(ranges, dtype=float).tolist()),
    )


def ideal_obstacle_inputs(
    arena: Arena, cutoff_m: float = OBSTACLE_CUTOFF_M
) -> tuple[float, float, int]:
    """(d_o, phi_o, obstacle id) of the nearest obstacle by exact geometry; NaN, NaN, -1
    when none is within ``cutoff_m`` (:func:`world.kernels.nearest_obstacle`)."""
    scene = arena._scene()
    d_o, phi_o, k = nearest_obstacle(scene, arena.pose, cutoff_m)
    return d_o, phi_o, scene.ids[k] if k >= 0 else -1


class Perception:
    """Turns the arena (and the sensors' readings) into the controller's four inputs."""

    def __init__(
        self,
        mode: str,
        sensors: RangeSensorArray,
        cutoff_m: float = OBSTACLE_CUTOFF_M,
        geometry: str = "husky",
        field_of_view_rad: float = FULL_CIRCLE_RAD,
    ):
        if mode not in PERCEPTION_MODES:
            raise ValueError(f"perception = {mode!r}: must be one of {', '.join(PERCEPTION_MODES)}")
        check_geometry(geometry, mode)
        self.mode = mode
        self.geometry = geometry
        self._centre_to_centre = geometry == "paper"
        self.sensors = sensors
        self.cutoff_m = cutoff_m
        self.set_field_of_view(field_of_view_rad)
        self._mount_angles = [float(m.angle_rad) for m in sensors.config.mounts]
        self._no_ranges = np.full(len(self._mount_angles), math.inf)
        self._no_ranges.flags.writeable = False
        self._no_ranges_list = self._no_ranges.tolist()

    def set_field_of_view(self, field_of_view_rad: float) -> None:
        """Sense (ideal mode) only obstacles whose centre bears within +- half of it."""
        if not (math.isfinite(field_of_view_rad) and 0.0 < field_of_view_rad <= FULL_CIRCLE_RAD):
            raise ValueError(f"field_of_view_rad = {field_of_view_rad!r}: must be in (0, 2 pi]")
        self.field_of_view_rad = float(field_of_view_rad)
        # None: all around (the plain nearest obstacle, no bearing needed)
        self._half_field = (
            None if field_of_view_rad >= FULL_CIRCLE_RAD else 0.5 * float(field_of_view_rad)
        )

    def inputs(self, arena: Arena, time_s: float) -> tuple[np.ndarray, np.ndarray]:
        """(inputs (4,), sensor ranges (3,)); the sensors are read in both modes so that
        their readings are always logged (in the paper's geometry the point robot has
        none: the ranges are inf)."""
        d_t, d_o, phi_t, phi_o, ranges, _ = self._sense(arena, time_s)
        return np.array((d_t, d_o, phi_t, phi_o)), ranges

    def _sense(self, arena: Arena, time_s: float, target_xy=None):
        """The inputs as floats: ``(d_t, d_o, phi_t, phi_o, ranges, ranges as a list)``.

        The float forms of the batch engine's stages: :func:`world.kernels.target_input`,
        :func:`~world.kernels.nearest_obstacle` and, with the sonars, the nearest
        reading at its mount's angle (:func:`~world.kernels.sonar_obstacle_input`).
        ``target_xy`` (two floats) saves reading ``arena.target`` when the caller has it.
        """
        sensors = self.sensors
        if self._centre_to_centre:  # the paper's point robot senses exactly, no sonars
            ranges = self._no_ranges
            ranges_list = self._no_ranges_list
        else:
            ranges = sensors.read(arena, time_s)
            cached = getattr(sensors, "_ranges_list", None)
            if cached is None or len(cached) != len(ranges):
                cached = np.asarray(ranges, dtype=float).tolist()
            ranges_list = cached
        if target_xy is None:
            target_xy = arena.target
        d_t, phi_t = target_input(arena._pose, target_xy)
        if self.mode == "ideal":
            d_o, phi_o, _ = nearest_obstacle(
                arena._scene(), arena._pose, self.cutoff_m, self._centre_to_centre,
                self._half_field,
            )  # fmt: skip
        else:
            d_o, phi_o = sonar_obstacle_input(ranges_list, self._mount_angles, self.cutoff_m)
        return d_t, d_o, phi_t, phi_o, ranges, ranges_list
