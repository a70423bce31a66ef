"""fuzzynav's own navigator: two small Mamdani blocks, arbitration by "near", a short memory.

:func:`fuzzynav_controller` builds :class:`FuzzyNavController` from the shipped files:
the two blocks (``assets/rules/fuzzynav_goal.toml``, ``fuzzynav_avoid.toml``), evaluated
as one merged system, and the crisp parameters (``assets/rules/fuzzynav_params.toml``).
It is called as every controller is, ``controller(inputs) -> (left, right)`` volts, and
keeps a memory that :meth:`~FuzzyNavController.reset` clears;
:meth:`~FuzzyNavController.set_parts_off` switches parts off
(``assets/rules/fuzzynav_parts.toml``) and :meth:`~FuzzyNavController.new_target`
announces a target moved on purpose.

This module holds the decision (the step in order and the state it keeps) and the
factory; the step's stages are ``fuzzynav_steps.py``'s, the merged blocks
``fuzzynav_blocks.py``'s, and the parts with state of their own ``fuzzynav_memory.py``,
``fuzzynav_planner.py`` and ``fuzzynav_tracker.py``. The design, item by item with its
parameters: docs/fuzzynav.md, "The design, parameter by parameter".
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from fuzzynav.controller.fuzzy import FuzzySystem
from fuzzynav.controller.fuzzynav_blocks import export_fis as export_fis
from fuzzynav.controller.fuzzynav_blocks import merge_blocks
from fuzzynav.controller.fuzzynav_memory import PerceptionMemory
from fuzzynav.controller.fuzzynav_params import (
    AVOID_PATH,
    CRISP_DEFAULTS,
    GOAL_PATH,
    PARAMS_PATH,
    load_params,
    params_toml,
)
from fuzzynav.controller.fuzzynav_parts import load_parts
from fuzzynav.controller.fuzzynav_planner import BearingPlanner
from fuzzynav.controller.fuzzynav_robot import _AXES, mounts_of
from fuzzynav.controller.fuzzynav_steps import ControlSteps, _saturated
from fuzzynav.controller.fuzzynav_tracker import Tracker
from fuzzynav.controller.rulebase import read_toml

#: What each of :attr:`FuzzyNavController.decisions` holds, in order: the voltages, the
#: inner state (dodge: 1 yield, -1 pass first, 0 neither), then the inputs of
#: :attr:`FuzzyNavController.merged` (both blocks' inputs: the bearing steered by, the
#: target distance, the sector distances and the side), from which a recording computes
#: every rule's firing strength.
DECISION_FIELDS = (
    "left_v",
    "right_v",
    "alpha",
    "plan_offset_rad",
    "dodge",
    "follow",
    "target_doubted",
    "phi_t",
    "d_t",
    "left",
    "front",
    "right",
    "side",
)
_DODGE_CODE = {"yield": 1.0, "pass first": -1.0}


def _forward(part: str, name: str, doc: str) -> property:
    """A read-only attribute of the controller that is one of its parts' own."""
    return property(lambda self: getattr(getattr(self, part), name), doc=doc)


class FuzzyNavController(ControlSteps):
    """The navigator; state (memory) is cleared by :meth:`reset`.

    Attributes for teaching and recording: ``goal``, ``avoid`` (the two blocks),
    ``last`` (a dict: sectors, side, alpha, mode and both blocks' outputs of the last call),
    ``decisions`` (one tuple per call since :meth:`reset`, :data:`DECISION_FIELDS`: the
    voltages returned, the inner state and the blocks' inputs behind them, so that a
    recording plots that state and the rules' firing without deciding the run again).
    """

    needs_ranges = True
    #: the simulation gives it the robot's sonar mounts (set_sensor_mounts) before each
    #: start: its memory places echoes on their axes (``--sonar-side`` moves them)
    needs_sensor_mounts = True
    #: and the robot's description (set_robot) before that: its footprint, so that the
    #: memory, the planner and the tracker know the robot that drives
    needs_robot = True
    name = "fuzzynav"

    # The parts' state that teaching, recording and tests read (see the parts' modules).
    points = _forward("memory", "points", "remembered echoes (x, y, time), odometry frame")
    pose = _forward("memory", "pose", "the dead-reckoned pose (x, y, heading) echoes are in")
    vel = _forward("memory", "vel", "the dead-reckoned speed and turn rate")
    plan_side = _forward("planner", "side", "the planner's side (+1 left, -1 right, 0 free)")
    plan_offset = _forward("planner", "offset", "the planner's bearing minus the target's")
    obs_vel = _forward("tracker", "obs_vel", "the nearest obstacle's tracked velocity")
    obs_sightings = _forward("tracker", "obs_sightings", "its consistent sightings in a row")
    target_doubted = _forward("tracker", "target_doubted", "the last target reading doubted")

    def __init__(self, goal: FuzzySystem, avoid: FuzzySystem, params: dict | None = None):
        if goal.input_names != ["phi_t", "d_t"] or goal.output_names != ["speed", "turn"]:
            raise ValueError(
                f"goal block must map (phi_t, d_t) -> (speed, turn), got "
                f"{goal.input_names} -> {goal.output_names}"
            )
        if avoid.input_names != ["left", "front", "right", "side"] or avoid.output_names != [
            "speed",
            "turn",
        ]:
            raise ValueError(
                f"avoid block must map (left, front, right, side) -> (speed, turn),"
                f" got {avoid.input_names} -> {avoid.output_names}"
            )
        self.goal = goal
        self.avoid = avoid
        self.params = dict(CRISP_DEFAULTS)
        self.params.update(params or {})
        self._merged = merge_blocks(goal, avoid)
        self._eval = self._merged.evaluate_one_list
        self._eval_goal = goal.evaluate_one_list
        self._eval_avoid = avoid.evaluate_one_list
        dt = self.params["control_period_s"]
        self.store_every = max(1, round(self.params["store_s"] / dt))
        self.sector_every = max(1, round(self.params["sector_s"] / dt))
        self.parts_off: tuple[str, ...] = ()
        self._params_on: dict[str, float] = {}  # values a switched-off part had
        # Its parts, sharing the parameters: the perception memory, the bearing planner
        # and the tracker (their modules say what each does).
        self.memory = PerceptionMemory(self.params)
        self.planner = BearingPlanner(self.params)
        self.tracker = Tracker(self.params)
        self.axes = _AXES  # the sonars' axes (set_sensor_mounts)
        self.reset()

    def set_robot(self, robot) -> None:
        """The robot that drives (:class:`~fuzzynav.world.robot.RobotDescription`): its
        footprint's half-sizes for the memory, the planner and the tracker, and its sonars
        (:meth:`set_sensor_mounts`). The mixing keeps the default robot's voltage limit,
        as the batch form does (the world clips to the simulation's own after it).

        Parameters
        ----------
        robot : RobotDescription
            The robot, as :attr:`fuzzynav.world.simulation.Simulation.robot` has it.
        """
        hx, hy = float(robot.half_length_m), float(robot.half_width_m)
        for part in (self.memory, self.planner, self.tracker):
            part.hx, part.hy = hx, hy
        self.set_sensor_mounts(robot.mounts)

    def set_sensor_mounts(self, sensor_mounts) -> None:
        """The robot's sonars (:class:`~fuzzynav.world.sensors.SensorMount` s, left, front,
        right): the memory, the planner and the tracker read their axes from these."""
        mounts = mounts_of(sensor_mounts)
        axes = frozenset(m[2] for m in mounts)
        self.axes = axes
        self.memory.mounts, self.memory.axes = mounts, axes
        self.planner.axes = axes
        self.tracker.axes = axes

    def set_parts_off(self, names=()) -> None:
        """Switch the named parts off and every other part on again
        (``assets/rules/fuzzynav_parts.toml``: a part is off while its crisp parameters
        hold the file's values; switched on, they get back the values they had). Takes
        effect at the next call, without :meth:`reset`. An unknown name raises
        ``ValueError`` and changes nothing."""
        parts = load_parts()
        known = [p.name for p in parts]
        names = set(names)
        unknown = sorted(names - set(known))
        if unknown:
            raise ValueError(f"unknown fuzzynav part(s) {unknown}: choose from {', '.join(known)}")
        for part in parts:
            for key, value in part.off.items():
                if part.name in names:
                    self._params_on.setdefault(key, self.params[key])
                    self.params[key] = value
                elif key in self._params_on:
                    self.params[key] = self._params_on.pop(key)
        self.parts_off = tuple(name for name in known if name in names)

    # -- state -------------------------------------------------------------------------
    def reset(self) -> None:
        self.t = 0.0
        self.side = 0.0  # latched side (+1 left, -1 right), 0 = none
        self.reverse_s = 0.0  # how long the robot has been backing off
        self.creep_s = 0.0  # how long the command has been near zero
        self.unstick_s = 0.0  # time left turning on the spot out of a deadlock
        self.best_d_t = math.inf  # best target distance during the progress window
        self.best_t = 0.0
        self.follow = False  # boundary following (escape) active
        self.follow_d_t = math.inf
        self.follow_t = 0.0
        self.last: dict = {}
        self.decisions: list[tuple] = []
        self.cmd = (0.0, 0.0)  # the last command (V), which dead reckoning follows
        self.calls = -1
        self.memory.reset()
        self.planner.reset()
        self.tracker.reset()

    def state(self) -> dict:
        memory, tracker = self.memory, self.tracker
        return {
            "t": self.t,
            "mem": list(memory.mem),
            "side": self.side,
            "prev_front": memory.prev_front,
            "prev_obstacle": memory.prev_obstacle,
            "best_d_t": self.best_d_t,
            "best_t": self.best_t,
            "follow": self.follow,
            "follow_d_t": self.follow_d_t,
            "follow_t": self.follow_t,
            "pose": list(memory.pose),
            "vel": list(memory.vel),
            "cmd": self.cmd,
            "points": list(memory.points),
            "target_est": tracker.target_est,
            "target_candidate": tracker.target_candidate,
            "target_candidate_s": tracker.target_candidate_s,
            "target_doubted": tracker.target_doubted,
        }

    # -- decision ----------------------------------------------------------------------
    def __call__(self, inputs, ranges_m=None):
        """One control step: the voltages (left, right) for ``inputs`` (d_t, d_o, phi_t,
        phi_o) and the sonar ranges (left, front, right; none: nothing seen).

        Parameters
        ----------
        inputs : sequence of 4 floats
            Target distance [m], nearest obstacle distance [m], target bearing [rad],
            nearest obstacle bearing [rad] (NaN: not sensed).
        ranges_m : sequence of 3 floats, optional
            The sonars' ranges [m], left, front, right.

        Returns
        -------
        numpy.ndarray
            The wheel voltages (left, right) [V].
        """
        dt = self.params["control_period_s"]
        d_t, d_o, phi_t, phi_o, ranges = self._readings(inputs, ranges_m)
        d_t, phi_t, d_o, phi_o, d_o_raw = self._dead_reckon(d_t, d_o, phi_t, phi_o, dt)
        left, front_eff, right, hint = self._sense(ranges, d_t, phi_t, d_o, d_o_raw, phi_o, dt)
        side = self._latch_side(phi_t, left, front_eff, right, hint)
        self._watch_progress(d_t, left, front_eff, right, side)
        phi = phi_t + self.planner.offset
        if self.follow:
            # Keep the boundary on the side opposite to the latched turn: pull towards it.
            side = self.side
            phi = -side * self.params["follow_bias_rad"]
        alpha = self._alpha(d_t, left, front_eff, right)
        avoid_in = (min(left, 4.5), min(front_eff, 4.5), min(right, 4.5), side)
        g_speed, g_turn, a_speed, a_turn = self._blocks(alpha, phi, d_t, avoid_in)
        g_speed, g_turn = self._guard(g_speed, g_turn, d_t, left, right)
        speed = alpha * a_speed + (1.0 - alpha) * g_speed
        turn = alpha * a_turn + (1.0 - alpha) * g_turn
        speed, turn = self._unstick(speed, turn, side, dt)
        # A moving obstacle on a collision course: stop, or go on at full speed, when
        # that keeps its predicted closest approach farther (yield or pass first).
        speed, dodge = self.tracker.dodge(speed)
        speed, turn = self._limit_reverse(speed, turn, side, d_o_raw, phi_o, dt)
        speed, turn = _saturated(speed, turn)
        self.last = {
            "sectors": (left, front_eff, right),
            "side": side,
            "alpha": alpha,
            "follow": self.follow,
            "goal": (g_speed, g_turn),
            "avoid": (a_speed, a_turn),
            "block_inputs": (phi, d_t) + avoid_in,
            "plan_offset": self.planner.offset,
            "dodge": dodge,
            "command": (speed, turn),
        }
        self.cmd = (speed - turn, speed + turn)
        # A few floats per call beside the simulation's own log row, so it grows as that does.
        self.decisions.append(
            (
                speed - turn,
                speed + turn,
                alpha,
                self.planner.offset,
                _DODGE_CODE.get(dodge, 0.0),
                float(self.follow),
                float(self.tracker.target_doubted),
                phi,
                d_t,
                *avoid_in,
            )
        )
        return np.array(self.cmd)

    def new_target(self) -> None:
        """The target was moved on purpose (a user dragged it in the viewer): take the
        next reading as it is instead of doubting it until it settles."""
        self.tracker.new_target()

    def rule_blocks(self) -> dict[str, FuzzySystem]:
        """The fuzzy blocks by name, for a recording's rule base."""
        return {"goal": self.goal, "avoid": self.avoid}

    def params_toml(self) -> str:
        """The crisp parameters in use, as ``fuzzynav_params.toml`` holds them."""
        return params_toml(self.params)

    @property
    def merged(self) -> FuzzySystem:
        """Both blocks as one system (:func:`merge_blocks`), as the loop evaluates them."""
        return self._merged

    def teaching_view(self):
        """For a teaching display: ``(system, inputs, state)`` of the last call, or None
        before the first. ``system`` is both blocks as one (:func:`merge_blocks`: inputs
        phi, d_t, left, front, right, side; outputs goal and avoid speed and turn),
        ``inputs`` what the blocks were fed, ``state`` the crisp parts in words."""
        last = self.last
        if not last:
            return None
        if last["follow"]:
            mode = "following an edge (no progress: Bug-2 escape)"
        elif last["dodge"]:
            mode = f"moving obstacle: {last['dodge']}"
        elif last["plan_offset"]:
            mode = f"planner steers {math.degrees(last['plan_offset']):+.0f} deg off the target"
        else:
            mode = "heading for the target"
        state = {
            "avoidance weight alpha": f"{last['alpha']:.2f}",
            "side": "left" if last["side"] > 0 else "right",
            "mode": mode,
            "target reading": (
                "doubted (it moves the target: a disturbance?); steering by the tracked target"
                if self.target_doubted
                else "taken as it is"
            ),
            "command": "speed {:.1f} V, turn {:.1f} V (left = speed - turn, "
            "right = speed + turn)".format(*last["command"]),
        }
        return self._merged, np.array(last["block_inputs"], dtype=float), state

    def teaching_points(self):
        """For a teaching display: ``(points, bearing_rad)``, the remembered echo points
        in the robot's frame (x ahead, y left; (n, 2) m, as dead reckoning places them)
        and the bearing the goal block was last fed (the planner's, rad, > 0 left)."""
        x0, y0, th = self.pose
        c, s = math.cos(th), math.sin(th)
        pts = np.array(
            [
                (c * (px - x0) + s * (py - y0), c * (py - y0) - s * (px - x0))
                for px, py, _ in self.points
            ],
            dtype=float,
        ).reshape(-1, 2)
        bearing = self.last["block_inputs"][0] if self.last else math.nan
        return pts, bearing


# ----------------------------------------------------------------------------- factory


def fuzzynav_controller(
    goal_path: str | Path = GOAL_PATH,
    avoid_path: str | Path = AVOID_PATH,
    params_path: str | Path = PARAMS_PATH,
) -> FuzzyNavController:
    return FuzzyNavController(
        read_toml(goal_path),
        read_toml(avoid_path),
        load_params(params_path),
    )
