"""fuzzynav's own navigator: two small Mamdani blocks, arbitration by "near", a short memory.

Design (the README's figure is ``docs/img/fuzzynav_design.png``)::

    ranges (left, front, right) --+--> echo memory ----> L, F, R --+--> AVOID block --+
    d_o, phi_o (ideal only) ------+         |                       |   (L, F, R, side)|
                                            v        side chooser --+                  |--> blend --> mix --> (left, right) V
    d_t, phi_t --> bearing planner / escape: phi --> GOAL block (phi, d_t) ------------+
                                                    alpha = strength of "near" (L, F, R)

1. **Sectors.** The three ultrasonic readings give the distance seen to the left (+45 deg),
   ahead and to the right (-45 deg). The same readings exist in both perception modes, so
   the design works in both. In ``ideal`` perception the nearest obstacle all around
   (``d_o``, ``phi_o``) is folded into its sector (ahead within ``side_fold_deg``, else left
   or right), which covers the gaps between the beams and the robot's flanks; in
   ``ultrasonic`` mode ``d_o``/``phi_o`` come from the beams anyway.
2. **Echo memory** (state, cleared by :meth:`reset`). Every ``store_s`` the echoes nearer
   than ``store_range_m`` are stored as points in an odometry frame (dead reckoning from
   the voltages this controller commanded, with the plant's gains and lag), each as a short
   arc (the axis +- ``echo_spread_deg``: an echo may come from anywhere across the 15 deg
   beam), and the nearest echo as the point on its axis d_o from the footprint. Only
   sonar sightings are remembered (in ideal perception too): the all-around nearest
   obstacle of ideal perception is used in the moment only, because a disturbed sample
   (s3's disturbance) remembered for ``memory_s`` was a phantom obstacle. A new
   point within ``merge_m`` of an old one replaces it; points are forgotten after
   ``memory_s``. At the sensors' 25 Hz the remembered footprint distance per sector (ahead
   = within the flanks + ``front_corridor_m``) is recomputed, so an obstacle that has left
   the beams while beside the robot still holds it off; a remembered sector distance
   grows back only at ``memory_grow_mps``.
   **Bearing planner** (:func:`blocked_cones`, :func:`free_bearing`): each remembered point
   between ``plan_nearest_m`` and ``plan_horizon_m`` ahead (and not beyond the target)
   blocks the cone of bearings whose ray passes it nearer than the half-width +
   ``plan_margin_m``; the goal block is fed the free bearing nearest the target's instead
   of the target's own. Its side is latched while points are within ``plan_latch_m``, and
   changes farther out only for a detour shorter by ``plan_switch_rad`` (near, only when
   the latched detour exceeds ``plan_flip_rad``, and then only to a detour under
   ``plan_flip_rad``, at most once per ``plan_flip_min_s``, while the robot makes
   progress). Once the robot has made no progress for ``plan_stuck_s``, a side it changed
   to is kept for ``plan_flip_hold_s``: at the mouth of a U both detours are near 90
   degrees and the side would otherwise flip every second or so, the robot turning on
   the spot until it times out. Points beside the robot (back to its rear edge) block
   bearings too, so that a detour past 90 degrees sees the trap's arm it would turn into.
   With points near and all-around sensing (ideal perception), a change of side also
   charges each detour the turn to its bearing from the heading (``plan_turn_weight`` x
   that bearing): a robot turning on the spot towards one side no longer sees the other
   side come out shorter at each new echo and turn back.
3. **Goal block** (8 rules): target bearing (NB NS Z PS PB) x distance (near far) ->
   speed and turn. A target off to the side is turned to *in place* (speed "stop"), so the
   robot never orbits its target (the paper's trap: its outputs cannot go negative).
4. **Avoidance block** (13 rules): left / front / right distance (near medium far) and the
   chosen side -> speed and turn. Close ahead it backs off and turns hard to the chosen
   side; close beside, it turns away; passing at a medium distance it holds its heading.
5. **Side chooser** (crisp, with memory): the planner's side when it has one; otherwise,
   when something appears ahead (``latch_front_m``), the robot picks the side to pass on
   (away from the obstacle's bearing when known, else the target's side unless that side is
   the more obstructed) and *latches* it until the front is clear again, so it never
   dithers between two sides. While an obstacle is being passed (within ``guard_m`` on the
   far side) and the planner is idle, the goal block may not turn back into it.
6. **Arbitration**: ``alpha`` = the strength of "near" over the sectors (a linear-Z of
   the front distance, and one of the side distances); the command is
   ``alpha * avoid + (1 - alpha) * goal``: avoidance takes precedence as obstacles get near.
   Within ``arrive_m`` of the target, obstacles beside (or beyond the target) yield.
7. **Moving obstacles**: the front reading's rate of change, and in ideal perception the
   nearest obstacle's, are watched; an obstacle closing faster than the robot's own motion
   explains counts as nearer by ``ttc_gain_s`` x the excess speed (time to contact), so the
   robot turns away and slows earlier. **Yield or pass first** (ideal perception): every
   ``store_s`` the nearest obstacle's centre is estimated (``dodge_radius_m`` beyond its
   surface along its bearing) and its velocity followed; once it has been seen
   ``dodge_sightings`` times in a row moving faster than ``dodge_min_speed_mps``, the
   closest approach of robot and obstacle over the next ``dodge_horizon_s`` is predicted
   (both at constant velocity, :func:`closest_approach_m`); if it is under
   ``dodge_safe_m``, the robot stops or goes on at full speed, whichever keeps the
   obstacle farther (:func:`dodge_speed`): it lets a crossing obstacle pass, or clears
   its path first. The tracker dead-reckons its own heading with the turn's real lag
   (``turn_lag``, fitted on logged runs: the plant's turn settles in a few periods, its
   speed in about fifteen); the echo memory keeps the slower ``odo_lag`` for both, which
   smears echoes stored while turning by up to about 10 degrees, and the planner was
   designed with that smear (correcting it made U-trap escapes worse, 56 -> 42 % on the
   design seeds, so it is kept and stated here). An ultrasonic sighting's bearing is the
   sensor's axis, which says nothing of motion across the beam: the tracker ignores it,
   so in ultrasonic perception only the time-to-contact rule acts.
8. **Escape from local minima** (memory): if the target distance has not improved for
   ``stall_s`` seconds, the robot follows the obstacle boundary on its latched side (the
   goal block is fed a virtual bearing ``follow_bias_rad`` towards it) until it is
   ``leave_margin_m`` closer to the target than where it got stuck (the Bug-2 idea), or
   loses the boundary. The virtual bearing sits at the goal block's PS peak, so that block
   drives on at speed on an arc towards the boundary while the avoidance block holds the
   distance; at 0.6 rad (fully PB) it turned on the spot towards the boundary, the
   avoidance block turned it back, and the robot crept along the edge at about 0.13 m/s.
9. **Mixing**: left = speed - turn, right = speed + turn; if that exceeds 12 V the speed is
   reduced, never the turn (the loop's saturation would otherwise eat the turn). A command
   near zero for ``deadlock_s`` (the two blocks cancelling) turns the robot on the spot
   towards its side for ``deadlock_s``; reversing lasts at most ``back_max_s`` at a time
   (nothing looks backwards), then it turns on the spot; except in ideal perception while
   the nearest obstacle all around is ahead and closing by itself (a moving obstacle
   coming at the robot): nothing is nearer behind, and turning on the spot in its way
   was how a robot that had yielded got hit.
10. **Doubted inputs** (:meth:`FuzzyNavController._check_target`): the target stands
   still, so a reading of it that places it (dead reckoned) more than ``target_gate_m``
   from where the agreeing readings put it is doubted; the robot steers by the tracked
   target instead, and ignores the nearest-obstacle reading of the same moment (the four
   inputs arrive together; the sonar ranges, read apart, still guard it). s3's
   disturbance, ``sin(2 t)`` on every input for 10 s, swings the target by up to a metre
   and a radian; it cost fuzzynav 0.6 m of path in ideal perception and is now ignored.
   A doubted reading that keeps still for ``target_settle_s`` is the target moved, and
   is taken: a disturbance does not keep still. A move that is meant (the viewer's
   drag) is announced with :meth:`FuzzyNavController.new_target`.

Each part above can be switched off by its crisp parameters
(``assets/rules/fuzzynav_parts.toml``, :meth:`FuzzyNavController.set_parts_off`): the
viewer's "fuzzynav's parts" checkboxes, ``fuzzynav run --off PART`` and the ablation study
``scripts/fuzzynav_ablation.py`` (what each part buys) use it.

Both blocks live in ``assets/rules/fuzzynav_goal.toml`` and ``fuzzynav_avoid.toml``
(readable rules; ``.fis`` export one file per block: :func:`export_fis`); the crisp
parameters are in ``assets/rules/fuzzynav_params.toml``. For speed the two blocks are
evaluated as one merged system (same rules, disjoint variables: exactly the same outputs).
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np

from fuzzynav.controller.fis import write_fis
from fuzzynav.controller.fuzzy import FuzzySystem, Rule
from fuzzynav.controller.fuzzynav_params import (
    AVOID_PATH,
    CRISP_BOUNDS,
    CRISP_DEFAULTS,
    GOAL_PATH,
    PARAMS_PATH,
    load_params,
)
from fuzzynav.controller.fuzzynav_parts import load_parts
from fuzzynav.controller.rulebase import read_toml, write_toml

VOLTAGE_LIMIT_V = 12.0
# Plant constants for dead reckoning (notes section 1): 12 V both -> 0.617 m/s,
# (-12, +12) -> 0.62 rad/s; and the sensor mounts (x, y, angle) on the front edge.
_V_PER_VOLT = 0.617 / 12.0
_W_PER_VOLT = 0.62 / 12.0
_HX, _HY = 0.495, 0.335
_MOUNTS = (
    (0.495, 0.75 * 0.335, math.radians(45.0)),
    (0.495, 0.0, 0.0),
    (0.495, -0.75 * 0.335, math.radians(-45.0)),
)

_AXES = frozenset(m[2] for m in _MOUNTS)
# The nearest obstacle counts as coming at the robot when it closes faster than this,
# beyond what the robot's own motion explains (below it: measurement noise).
_CLOSING_MPS = 0.05


def _linz(x: float, lo: float, hi: float) -> float:
    if x <= lo:
        return 1.0
    if x >= hi:
        return 0.0
    return (hi - x) / (hi - lo)


def blocked_cones(
    points_robot,
    radius_m: float,
    horizon_m: float,
    beyond_m: float,
    nearest_m: float = 0.0,
    rearmost_m: float = 0.0,
) -> list[tuple[float, float]]:
    """Bearings (rad, > 0 left) the robot's centre line may not take, one interval per point.

    A point at distance ``rho`` and bearing ``beta`` (robot frame) is passed at a lateral
    distance of at least ``radius_m`` by every heading outside
    ``beta -+ asin(radius_m / rho)``; a point nearer than ``radius_m`` blocks a half plane.
    Points farther than ``horizon_m``, farther than ``beyond_m`` (the target: what lies
    beyond it does not matter), nearer than ``nearest_m`` or behind ``x = rearmost_m``
    (robot frame, x ahead) are ignored. With ``rearmost_m < 0`` points beside the robot
    block bearings beyond 90 degrees, which a detour round a trap has to take.
    """
    cones = []
    limit = min(horizon_m, beyond_m)
    for bx, by in points_robot:
        rho = math.hypot(bx, by)
        if rho > limit or rho < nearest_m or bx < rearmost_m:
            continue
        beta = math.atan2(by, bx)
        half = math.asin(radius_m / rho) if rho > radius_m else 0.5 * math.pi
        cones.append((beta - half, beta + half))
    return cones


def range_at_clearance(bearing_rad: float, clearance_m: float) -> float:
    """How far from the robot's centre, along ``bearing_rad``, a point is
    ``clearance_m`` from the footprint (half-sizes _HX, _HY).

    With ``u = (|cos|, |sin|)``, the point ``r u`` is ``sqrt(max(r ux - HX, 0)^2 +
    max(r uy - HY, 0)^2)`` from the rectangle: off a side, ``r = (H + d) / u``; off a
    corner, the larger root of ``r^2 - 2 r (ux HX + uy HY) + HX^2 + HY^2 - d^2 = 0``.
    (Placing it at d_o beyond the footprint's extent along the bearing puts it too near
    off a corner: the footprint's nearest point is the corner, not the ray's exit.)
    """
    ux, uy = abs(math.cos(bearing_rad)), abs(math.sin(bearing_rad))
    d = clearance_m
    if ux > 0.0:
        r = (_HX + d) / ux
        if r * uy <= _HY:
            return r
    if uy > 0.0:
        r = (_HY + d) / uy
        if r * ux <= _HX:
            return r
    b = ux * _HX + uy * _HY
    return b + math.sqrt(b * b - (_HX * _HX + _HY * _HY - d * d))


def free_bearing(
    cones: list[tuple[float, float]], phi_t: float, side: float
) -> tuple[float, float]:
    """The bearing nearest the target's that no cone blocks, and the side it passes on.

    Overlapping cones merge into one blocked interval. If ``phi_t`` is free it is
    returned with side 0; otherwise the interval's edge on ``side`` (+1: pass with the
    obstacles on the right, i.e. the left edge) is returned, or, with ``side`` 0, the
    nearer edge (the shorter detour).
    """
    lo = hi = phi_t
    blocked = False
    grown = True
    while grown:
        grown = False
        for a, b in cones:
            if a <= hi and b >= lo and (a < lo or b > hi or not blocked):
                if a < lo:
                    lo = a
                if b > hi:
                    hi = b
                blocked = grown = True
    if not blocked:
        return phi_t, 0.0
    if side == 0.0:
        side = 1.0 if hi - phi_t <= phi_t - lo else -1.0
    return (hi if side > 0 else lo), side


def closest_approach_m(rel, obstacle_vel, robot_vel, horizon_s: float) -> float:
    """Smallest distance between an obstacle (``rel`` from the robot, moving at
    ``obstacle_vel``) and the robot (moving at ``robot_vel``) over ``[0, horizon_s]``,
    both at constant velocity: ``|rel + r t*|`` with ``r`` the relative velocity and
    ``t* = clip(-rel . r / |r|^2, 0, horizon_s)``."""
    rx, ry = obstacle_vel[0] - robot_vel[0], obstacle_vel[1] - robot_vel[1]
    r2 = rx * rx + ry * ry
    # Only an exactly zero relative velocity has no closest time: a tiny one (1e-8 m/s)
    # still moves the obstacle by its speed times the horizon.
    t = 0.0 if r2 == 0.0 else min(max(-(rel[0] * rx + rel[1] * ry) / r2, 0.0), horizon_s)
    return math.hypot(rel[0] + rx * t, rel[1] + ry * t)


def dodge_speed(
    speed_v: float, rel, obstacle_vel, heading_rad: float, horizon_s: float, safe_m: float
) -> float:
    """The speed command (V) against a moving obstacle: ``speed_v`` if the predicted
    closest approach along the heading stays at least ``safe_m``, else whichever of
    stopping or full speed keeps the obstacle farther (by more than 5 cm), else
    ``speed_v``. Reversing is not a candidate: nothing looks backwards."""
    c, s = math.cos(heading_rad), math.sin(heading_rad)

    def approach(v):
        mps = _V_PER_VOLT * v
        return closest_approach_m(rel, obstacle_vel, (mps * c, mps * s), horizon_s)

    best_v, best_m = speed_v, approach(speed_v)
    if best_m >= safe_m:
        return speed_v
    for candidate in (0.0, VOLTAGE_LIMIT_V):
        m = approach(candidate)
        if m > best_m + 0.05:
            best_v, best_m = candidate, m
    return best_v


def merge_blocks(goal: FuzzySystem, avoid: FuzzySystem) -> FuzzySystem:
    """One system evaluating both blocks: inputs goal's then avoid's, outputs
    goal_speed, goal_turn, avoid_speed, avoid_turn. Each rule keeps its own block's
    variables, so every output is exactly what its block alone would give."""
    gi, go = len(goal.inputs), len(goal.outputs)
    ai, ao = len(avoid.inputs), len(avoid.outputs)
    inputs = list(goal.inputs) + list(avoid.inputs)
    outputs = [dataclasses.replace(v, name=f"goal_{v.name}") for v in goal.outputs] + [
        dataclasses.replace(v, name=f"avoid_{v.name}") for v in avoid.outputs
    ]
    rules = [
        Rule(r.antecedent + (None,) * ai, r.consequent + (None,) * ao, r.weight) for r in goal.rules
    ]
    rules += [
        Rule((None,) * gi + r.antecedent, (None,) * go + r.consequent, r.weight)
        for r in avoid.rules
    ]
    return FuzzySystem(
        inputs, outputs, rules, name="fuzzynav-merged", n_points=max(goal.n_points, avoid.n_points)
    )


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


class FuzzyNavController:
    """The navigator; state (memory) is cleared by :meth:`reset`.

    Attributes for teaching and recording: ``goal``, ``avoid`` (the two blocks),
    ``last`` (a dict: sectors, side, alpha, mode and both blocks' outputs of the last call),
    ``decisions`` (one tuple per call since :meth:`reset`, :data:`DECISION_FIELDS`: the
    voltages returned, the inner state and the blocks' inputs behind them, so that a
    recording plots that state and the rules' firing without deciding the run again).
    """

    needs_ranges = True
    name = "fuzzynav"

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
        self.reset()

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
        self.mem = [math.inf, math.inf, math.inf]  # remembered left, front, right (m)
        self.side = 0.0  # latched side (+1 left, -1 right), 0 = none
        self.prev_front = math.inf
        self.reverse_s = 0.0  # how long the robot has been backing off
        self.creep_s = 0.0  # how long the command has been near zero
        self.unstick_s = 0.0  # time left turning on the spot out of a deadlock
        self.closing_f = 0.0  # front closing speed beyond our own (m/s), per store_s
        self.closing_o = 0.0  # nearest obstacle's closing speed beyond our own (m/s)
        self.prev_obstacle = (math.nan, math.nan)
        self.best_d_t = math.inf  # best target distance during the progress window
        self.best_t = 0.0
        self.follow = False  # boundary following (escape) active
        self.follow_d_t = math.inf
        self.follow_t = 0.0
        self.last: dict = {}
        self.decisions: list[tuple] = []
        # Short memory of echoes: points in an odometry frame (dead reckoning from the
        # voltages this controller commanded), forgotten after memory_s seconds.
        self.pose = [0.0, 0.0, 0.0]
        self.vel = [0.0, 0.0]
        self.cmd = (0.0, 0.0)
        self.points: list[tuple[float, float, float]] = []  # (x, y, time stored)
        self.calls = -1
        self.mem_sectors = (math.inf, math.inf, math.inf)
        self.plan_side = 0.0  # side the bearing planner passes on (+1 left), 0 = free
        self.plan_offset = 0.0  # planned bearing minus the target's (rad)
        self.plan_flip_t = -math.inf
        # Tracker of the nearest obstacle (ideal perception), in its own dead-reckoned
        # frame whose heading uses the turn's real lag (see the module docstring, 7).
        self.track_pose = [0.0, 0.0, 0.0]
        self.track_w = 0.0
        self.obs_centre = None  # (x, y): estimated centre of the nearest obstacle
        self.obs_vel = (0.0, 0.0)  # its estimated velocity (m/s)
        self.obs_sightings = 0  # consecutive consistent sightings
        # The target as placed by its readings (tracker frame), and a doubted reading
        # that keeps still (the target moved?) and for how long.
        self.target_est = None
        self.target_candidate = None
        self.target_candidate_s = 0.0
        self.target_doubted = False

    def _remember(self, x: float, y: float) -> None:
        """Store an echo point (odometry frame); one near a remembered point replaces it,
        so a static obstacle costs a few points however long it is seen."""
        merge2 = self.params["merge_m"] ** 2
        points = self.points
        for i in range(len(points) - 1, -1, -1):
            px, py, _ = points[i]
            if (px - x) ** 2 + (py - y) ** 2 < merge2:
                del points[i]
                break
        points.append((x, y, self.t))

    def state(self) -> dict:
        return {
            "t": self.t,
            "mem": list(self.mem),
            "side": self.side,
            "prev_front": self.prev_front,
            "prev_obstacle": self.prev_obstacle,
            "best_d_t": self.best_d_t,
            "best_t": self.best_t,
            "follow": self.follow,
            "follow_d_t": self.follow_d_t,
            "follow_t": self.follow_t,
            "pose": list(self.pose),
            "vel": list(self.vel),
            "cmd": self.cmd,
            "points": list(self.points),
            "target_est": self.target_est,
            "target_candidate": self.target_candidate,
            "target_candidate_s": self.target_candidate_s,
            "target_doubted": self.target_doubted,
        }

    # -- decision ----------------------------------------------------------------------
    def __call__(self, inputs, ranges_m=None):
        p = self.params
        dt = p["control_period_s"]
        d_t, d_o, phi_t, phi_o = (
            inputs.tolist() if type(inputs) is np.ndarray else [float(v) for v in inputs]
        )
        d_o_raw = d_o
        if ranges_m is None:
            ranges = [math.inf, math.inf, math.inf]
        elif type(ranges_m) is np.ndarray:
            ranges = ranges_m.tolist()
        else:
            ranges = [float(v) for v in ranges_m]
        left, front, right = ranges
        # Dead reckoning over the last period from the last command (first-order lag).
        self.t += dt
        pose, vel = self.pose, self.vel
        cl, cr = self.cmd
        lag = p["odo_lag"]
        vel[0] += (_V_PER_VOLT * 0.5 * (cl + cr) - vel[0]) * lag
        vel[1] += (_W_PER_VOLT * 0.5 * (cr - cl) - vel[1]) * lag
        self.track_w += (_W_PER_VOLT * 0.5 * (cr - cl) - self.track_w) * p["turn_lag"]
        tp = self.track_pose
        tp[0] += vel[0] * dt * math.cos(tp[2])
        tp[1] += vel[0] * dt * math.sin(tp[2])
        tp[2] += self.track_w * dt
        if p["target_gate_m"] > 0.0 and d_t == d_t and phi_t == phi_t:
            d_t, phi_t = self._check_target(d_t, phi_t)
            if self.target_doubted:
                # The four inputs arrive together: when the target's are provably
                # disturbed, the nearest obstacle's are not trusted either (the sonar
                # ranges, read apart, still guard the robot).
                d_o = phi_o = d_o_raw = math.nan
        th = pose[2] + 0.5 * vel[1] * dt
        pose[0] += vel[0] * dt * math.cos(th)
        pose[1] += vel[0] * dt * math.sin(th)
        pose[2] += vel[1] * dt
        x0, y0, th = pose
        c, s_ = math.cos(th), math.sin(th)
        fold = math.radians(p["side_fold_deg"])
        store_range = p["store_range_m"]
        # At the sensors' rate (store_s): store the echoes (and, in ideal perception, the
        # nearest obstacle), forget points older than memory_s, and recompute the
        # remembered footprint distance per sector (held between updates).
        self.calls += 1
        store_tick = self.calls % self.store_every == 0
        if self.calls % self.sector_every == 0:
            points = self.points
            if store_tick:
                # An ultrasonic echo may come from anywhere across the beam: it is
                # remembered as an arc (the axis and both edges), or a point placed on
                # the axis would follow the robot as it turns away.
                spread = math.radians(p["echo_spread_deg"])
                for (mx, my, ma), r in zip(_MOUNTS, ranges):
                    if r < store_range:
                        for a in (ma - spread, ma, ma + spread):
                            bx, by = mx + r * math.cos(a), my + r * math.sin(a)
                            self._remember(x0 + c * bx - s_ * by, y0 + s_ * bx + c * by)
                if d_o == d_o and phi_o in _AXES:
                    # A sonar's nearest echo also as the point on its axis that is d_o
                    # from the footprint. Only sonar sightings (bearing on a beam axis)
                    # are remembered: the all-around nearest obstacle of ideal
                    # perception acts in the moment only, because one disturbed sample
                    # (s3) would otherwise stay as a phantom obstacle for memory_s.
                    rr = range_at_clearance(phi_o, d_o)
                    bx, by = rr * math.cos(phi_o), rr * math.sin(phi_o)
                    self._remember(x0 + c * bx - s_ * by, y0 + s_ * bx + c * by)
                points = self.points
            oldest = self.t - p["memory_s"]
            if points and points[0][2] < oldest:
                points = self.points = [q for q in points if q[2] >= oldest]
            m_l = m_f = m_r = math.inf
            corridor = p["front_corridor_m"]
            creep = p["memory_creep_mps"]
            now = self.t
            ahead = []
            for px, py, pt in points:
                dx, dy = px - x0, py - y0
                bx = c * dx + s_ * dy
                by = c * dy - s_ * dx
                if bx < -_HX:  # behind the robot: irrelevant going forward
                    continue
                ahead.append((bx, by))
                ex = bx - _HX if bx > _HX else 0.0
                ey = abs(by) - _HY
                if ey < 0.0:
                    ey = 0.0
                # A remembered echo may have moved since (a moving obstacle): it counts
                # as nearer by memory_creep_mps x its age.
                d = math.sqrt(ex * ex + ey * ey) - creep * (now - pt)
                if bx > 0.0 and abs(by) < _HY + corridor:
                    if d < m_f:
                        m_f = d
                elif by > 0.0:
                    if d < m_l:
                        m_l = d
                elif d < m_r:
                    m_r = d
            self.mem_sectors = (m_l, m_f, m_r)
            # Bearing planner: the free bearing nearest the target's, passing every
            # remembered point at plan_margin_m off the flank; held between updates as
            # an offset from the target's bearing.
            # Points beside the robot (back to its rear edge) count as well: they bound
            # the detours of more than 90 degrees that lead out of a trap; without them
            # the side turned away from looked free and the robot turned back and forth.
            cones = blocked_cones(
                ahead,
                _HY + p["plan_margin_m"],
                p["plan_horizon_m"],
                d_t + 0.3,
                p["plan_nearest_m"],
                -_HX,
            )
            # The side is latched while remembered points are near (plan_latch_m), even
            # when the target's bearing is momentarily free, so that the planner and the
            # avoidance block never dither between two sides. Farther away it changes
            # side only for a detour shorter by plan_switch_rad.
            near_block = any(bx * bx + by * by < p["plan_latch_m"] ** 2 for bx, by in ahead)
            latched = self.plan_side
            psi, side_now = free_bearing(cones, phi_t, latched)
            if side_now != 0.0 and latched == 0.0:
                latched = side_now
            elif side_now != 0.0 and (not near_block or abs(psi - phi_t) > p["plan_flip_rad"]):
                # near points hold the side, unless its detour has grown past
                # plan_flip_rad (the robot would turn back): then the other side, if it
                # is a real shortcut (a detour under plan_flip_rad) and the robot is
                # making progress, at most once per plan_flip_min_s; in any case once
                # the side has been held plan_flip_hold_s
                other, _ = free_bearing(cones, phi_t, -latched)
                held_s = self.t - self.plan_flip_t
                # With points near, a detour is also charged the turn to its bearing
                # from the heading (both are bearings relative to it), so that a robot
                # turning on the spot towards one side does not see the other come out
                # shorter at each new echo and turn back (clutter, U-traps). Only with
                # all-around sensing (a nearest obstacle off the beam axes, ideal
                # perception): with the beams alone the flank of the side kept is
                # unseen, and runs came nearer obstacles (docs/fuzzynav-log.md).
                turn_w = (
                    p["plan_turn_weight"]
                    if near_block and phi_o == phi_o and phi_o not in _AXES
                    else 0.0
                )
                if abs(other - phi_t) + turn_w * abs(other) + p["plan_switch_rad"] < abs(
                    psi - phi_t
                ) + turn_w * abs(psi) and (
                    not near_block
                    or held_s > p["plan_flip_hold_s"]
                    or (
                        held_s > p["plan_flip_min_s"]
                        and abs(other - phi_t) < p["plan_flip_rad"]
                        and self.t - self.best_t < p["plan_stuck_s"]
                    )
                ):
                    psi, latched = other, -latched
                    self.plan_flip_t = self.t
            elif side_now == 0.0 and not near_block:
                latched = 0.0
            self.plan_side = latched
            self.plan_offset = psi - phi_t
        m_l, m_f, m_r = self.mem_sectors
        if m_l < left:
            left = m_l
        if m_f < front:
            front = m_f
        if m_r < right:
            right = m_r
        # Ideal perception: the nearest obstacle all around, folded into its sector (the
        # beams are blind between them and beside the robot).
        hint = 0.0
        if not (d_o == d_o and phi_o == phi_o):
            self.prev_obstacle = (math.nan, math.nan)
            self.obs_centre = None
            self.obs_vel = (0.0, 0.0)
            self.obs_sightings = 0
        else:
            # An obstacle closing faster than our own motion explains is moving towards
            # us: it counts as nearer by ttc_gain_s x that excess speed.
            # The rate is measured over store_s and only while the robot hardly turns:
            # a beam sweeping over a surface, or a footprint corner swinging round,
            # changes the distance as fast as motion does.
            if store_tick:
                prev_d, prev_phi = self.prev_obstacle
                self.closing_o = 0.0
                if (
                    prev_d == prev_d
                    and abs(phi_o - prev_phi) < 0.3
                    and abs(prev_d - d_o) < 0.3
                    and abs(vel[1]) < 0.2
                ):
                    self.closing_o = (prev_d - d_o) / (dt * self.store_every) - vel[0] * math.cos(
                        phi_o
                    )
                self.prev_obstacle = (d_o_raw, phi_o)
                self._track(d_o_raw, phi_o)
            if self.closing_o > _CLOSING_MPS:
                d_o = max(0.0, d_o - p["ttc_gain_s"] * min(self.closing_o, 0.5))
            a = abs(phi_o)
            if a < fold:
                front = min(front, d_o)
                hint = phi_o
            elif a <= 2.0:
                if phi_o > 0:
                    left = min(left, d_o)
                else:
                    right = min(right, d_o)
        # Memory: a remembered distance grows back at memory_grow_mps.
        grow = p["memory_grow_mps"] * dt
        mem = self.mem
        left = mem[0] = min(left, mem[0] + grow)
        front_mem = mem[1] = min(front, mem[1] + grow)
        right = mem[2] = min(right, mem[2] + grow)
        # Time-to-contact: closing faster than the robot could drive -> treat as nearer.
        # Measured on the front sensor's own reading: the remembered sector jumps when a
        # point is stored or forgotten, which is not motion. A jump of more than
        # 0.1 m in one period is a new echo, not motion either.
        front_eff = front_mem
        if store_tick:
            raw_front = ranges[1]
            self.closing_f = 0.0
            if raw_front < 4.5 and self.prev_front < 4.5 and abs(vel[1]) < 0.2:
                change = self.prev_front - raw_front
                if abs(change) < 0.3:
                    self.closing_f = change / (dt * self.store_every) - 0.65
            self.prev_front = raw_front
        if self.closing_f > 0.0:
            front_eff = max(0.0, front_mem - p["ttc_gain_s"] * min(self.closing_f, 1.0))

        # Side chooser with a latch: the planner's side when it has one (the avoidance
        # block must turn the way the planner steers), else chosen from the readings.
        if self.plan_side != 0.0 and not self.follow:
            self.side = self.plan_side
        elif front_eff < p["latch_front_m"]:
            if self.side == 0.0:
                self.side = self._choose_side(phi_t, left, right, hint)
        elif front_eff > p["release_front_m"] and not self.follow:
            self.side = 0.0
        side = self.side if self.side != 0.0 else (1.0 if phi_t >= 0 else -1.0)

        # Progress watch -> boundary following.
        if d_t < self.best_d_t - p["stall_progress_m"]:
            self.best_d_t, self.best_t = d_t, self.t
        if self.follow:
            if (
                d_t < self.follow_d_t - p["leave_margin_m"]
                or self.t - self.follow_t > p["follow_max_s"]
                or min(left, front_eff, right) > p["follow_lost_m"]
            ):
                self.follow = False
                self.best_d_t, self.best_t = d_t, self.t
        elif self.t - self.best_t > p["stall_s"]:
            self.follow = True
            self.follow_d_t = min(d_t, self.best_d_t)
            self.follow_t = self.t
            if self.side == 0.0:
                self.side = side
        phi = phi_t + self.plan_offset
        if self.follow:
            # Keep the boundary on the side opposite to the latched turn: pull towards it.
            side = self.side
            phi = -side * p["follow_bias_rad"]

        # Arbitration weight: the strength of "near" over the sectors.
        a_front = _linz(front_eff, p["alpha_front_lo_m"], p["alpha_front_hi_m"])
        a_side = p["alpha_side_max"] * max(
            _linz(left, p["alpha_side_lo_m"], p["alpha_side_hi_m"]),
            _linz(right, p["alpha_side_lo_m"], p["alpha_side_hi_m"]),
        )
        # Arriving: an obstacle beside the robot, or ahead but beyond the target, yields
        # to the goal block as the target gets within arrive_m.
        if d_t < p["arrive_m"]:
            k = d_t / p["arrive_m"]
            a_side *= k
            if front_eff > d_t:
                a_front *= k
        alpha = max(a_front, a_side)
        # Evaluate only the block(s) that take part (both: one merged call; same numbers).
        avoid_in = (min(left, 4.5), min(front_eff, 4.5), min(right, 4.5), side)
        if alpha <= 0.0:
            g_speed, g_turn = self._eval_goal((phi, d_t))
            a_speed = a_turn = 0.0
        elif alpha >= 1.0:
            g_speed = g_turn = 0.0
            a_speed, a_turn = self._eval_avoid(avoid_in)
        else:
            g_speed, g_turn, a_speed, a_turn = self._eval((phi, d_t) + avoid_in)

        # While passing on the latched side, the goal block may not turn back towards the
        # obstacle being passed while it is still remembered within guard_m.
        # It drives on instead (the goal block alone would turn in place).
        # Not when the target is nearer than the obstacle being passed.
        guarding = (self.side > 0 and g_turn < 0.0 and right < p["guard_m"]) or (
            self.side < 0 and g_turn > 0.0 and left < p["guard_m"]
        )
        if guarding and not self.follow and self.plan_side == 0.0 and d_t > min(left, right) + 0.5:
            g_turn = 0.0
            g_speed = max(g_speed, p["guard_speed_v"])
        speed = alpha * a_speed + (1.0 - alpha) * g_speed
        turn = alpha * a_turn + (1.0 - alpha) * g_turn
        # Deadlock: blended rules that cancel (near on both sides, the goal pulling
        # ahead) leave the robot creeping on the spot; after deadlock_s of that it turns
        # on the spot towards its side for deadlock_s, which gives the planner a new view.
        if self.unstick_s > 0.0:
            self.unstick_s -= dt
            speed, turn = 0.0, 7.0 * side
        elif abs(speed) < 1.5 and abs(turn) < 1.5:
            self.creep_s += dt
            if self.creep_s > p["deadlock_s"]:
                self.creep_s = 0.0
                self.unstick_s = p["deadlock_s"]
        else:
            self.creep_s = 0.0
        # A moving obstacle on a collision course: stop, or go on at full speed, when
        # that keeps its predicted closest approach farther (yield or pass first).
        dodge = ""
        if p["dodge_horizon_s"] > 0.0 and self.obs_sightings >= p["dodge_sightings"]:
            vx, vy = self.obs_vel
            if vx * vx + vy * vy > p["dodge_min_speed_mps"] ** 2:
                tp = self.track_pose
                rel = (self.obs_centre[0] - tp[0], self.obs_centre[1] - tp[1])
                commanded = speed
                speed = dodge_speed(
                    speed, rel, (vx, vy), tp[2], p["dodge_horizon_s"], p["dodge_safe_m"]
                )
                if speed != commanded:
                    dodge = "yield" if speed == 0.0 else "pass first"
        # The sensors look forward only: backing off is allowed for back_max_s at a
        # time, then the robot turns on the spot until it may drive forward again.
        # Except in ideal perception when the nearest obstacle all around is ahead and
        # coming at the robot by itself: nothing is nearer behind, so it backs away on.
        if speed < 0.0:
            self.reverse_s += dt
            backing_away = (
                d_o_raw == d_o_raw
                and phi_o == phi_o
                and phi_o not in _AXES
                and abs(phi_o) < 0.5 * math.pi
                and self.closing_o > _CLOSING_MPS
            )
            if self.reverse_s > p["back_max_s"] and not backing_away:
                speed = 0.0
                if abs(turn) < 4.0:
                    turn = math.copysign(6.0, turn if turn else side)
        else:
            self.reverse_s = 0.0
        limit = VOLTAGE_LIMIT_V
        if abs(turn) > limit:
            turn = math.copysign(limit, turn)
        room = limit - abs(turn)
        if abs(speed) > room:
            speed = math.copysign(room, speed)
        self.last = {
            "sectors": (left, front_eff, right),
            "side": side,
            "alpha": alpha,
            "follow": self.follow,
            "goal": (g_speed, g_turn),
            "avoid": (a_speed, a_turn),
            "block_inputs": (phi, d_t) + avoid_in,
            "plan_offset": self.plan_offset,
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
                self.plan_offset,
                _DODGE_CODE.get(dodge, 0.0),
                float(self.follow),
                float(self.target_doubted),
                phi,
                d_t,
                *avoid_in,
            )
        )
        return np.array(self.cmd)

    def new_target(self) -> None:
        """The target was moved on purpose (a user dragged it in the viewer): take the
        next reading as it is instead of doubting it until it settles."""
        self.target_est = None
        self.target_candidate = None
        self.target_doubted = False

    def _check_target(self, d_t: float, phi_t: float) -> tuple[float, float]:
        """The target's distance and bearing to steer by: the reading, unless it is
        provably disturbed, else where the target was tracked.

        The target stands still, so a reading that places it (in the tracker's
        dead-reckoned frame) more than ``target_gate_m`` from where the agreeing readings
        put it is doubted, and the tracked position is steered by instead (s3 adds
        ``sin(2 t)`` to every input for 10 s: the target would seem to swing by a metre
        and a radian). A doubted reading that stays put for ``target_settle_s`` (within
        ``target_still_m`` of where it was first) is the target moved, and is taken: a
        disturbance does not keep still, a target that was moved does (one moved on
        purpose, as the viewer's drag, is announced with :meth:`new_target`).
        """
        p = self.params
        tp = self.track_pose
        mx = tp[0] + d_t * math.cos(tp[2] + phi_t)
        my = tp[1] + d_t * math.sin(tp[2] + phi_t)
        est = self.target_est
        self.target_doubted = False
        if est is None:
            self.target_est = (mx, my)
            return d_t, phi_t
        if (mx - est[0]) ** 2 + (my - est[1]) ** 2 < p["target_gate_m"] ** 2:
            k = p["target_filter"]
            self.target_est = (est[0] + k * (mx - est[0]), est[1] + k * (my - est[1]))
            self.target_candidate = None
            return d_t, phi_t
        cand = self.target_candidate
        if (
            cand is not None
            and (mx - cand[0]) ** 2 + (my - cand[1]) ** 2 < p["target_still_m"] ** 2
        ):
            self.target_candidate_s += p["control_period_s"]
        else:
            self.target_candidate = (mx, my)
            self.target_candidate_s = 0.0
        if self.target_candidate_s >= p["target_settle_s"]:
            self.target_est = (mx, my)
            self.target_candidate = None
            return d_t, phi_t
        self.target_doubted = True
        ex, ey = est[0] - tp[0], est[1] - tp[1]
        bearing = math.atan2(ey, ex) - tp[2]
        return math.hypot(ex, ey), math.atan2(math.sin(bearing), math.cos(bearing))

    def _track(self, d_o: float, phi_o: float) -> None:
        """Update the nearest obstacle's estimated centre and velocity (every store_s).

        The centre is placed at ``dodge_radius_m`` beyond the surface along the bearing
        (:func:`range_at_clearance` of ``d_o + radius``): for a static obstacle of another
        radius it then hardly slides as the robot passes. A jump of more than 0.3 m is
        another obstacle (or a disturbed input): the track restarts. An ultrasonic
        sighting's bearing is the sensor's axis, which says nothing of motion across the
        beam: it restarts the track too, so the dodge acts in ideal perception only.
        """
        p = self.params
        x, y, heading = self.track_pose
        rho = range_at_clearance(phi_o, d_o + p["dodge_radius_m"])
        cx, cy = x + rho * math.cos(heading + phi_o), y + rho * math.sin(heading + phi_o)
        prev = self.obs_centre
        if (
            prev is not None
            and phi_o not in _AXES
            and (cx - prev[0]) ** 2 + (cy - prev[1]) ** 2 < 0.3**2
        ):
            h = p["control_period_s"] * self.store_every
            vx, vy = self.obs_vel
            self.obs_vel = (
                0.5 * vx + 0.5 * (cx - prev[0]) / h,
                0.5 * vy + 0.5 * (cy - prev[1]) / h,
            )
            self.obs_sightings += 1
        else:
            self.obs_vel = (0.0, 0.0)
            self.obs_sightings = 0
        self.obs_centre = (cx, cy)

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

    @staticmethod
    def _choose_side(phi_t: float, left: float, right: float, hint: float = 0.0) -> float:
        """Pass on the side away from the obstacle when its bearing is known (ideal
        perception), else on the target's side unless that side is the more obstructed."""
        if abs(hint) > 0.12:
            return -1.0 if hint > 0 else 1.0
        pref = 1.0 if phi_t >= 0 else -1.0
        if pref > 0 and left < right - 0.3 and left < 2.0:
            return -1.0
        if pref < 0 and right < left - 0.3 and right < 2.0:
            return 1.0
        return pref


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


def export_fis(directory: str | Path) -> list[Path]:
    """Write the two blocks as MATLAB .fis files (one per block)."""
    directory = Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    paths = []
    for name, path in (("goal", GOAL_PATH), ("avoid", AVOID_PATH)):
        out = directory / f"fuzzynav_{name}.fis"
        write_fis(read_toml(path), out)
        paths.append(out)
    return paths


# ----------------------------------------------------------------------------- tuning


class FuzzyNavTunable:
    """The tuning protocol of ``controller.tuning`` (duck-typed): a vector of the crisp
    parameters in CRISP_BOUNDS followed by the membership parameters of both blocks.
    Picklable (holds only plain data and FuzzySystems, which pickle)."""

    name = "fuzzynav"

    def __init__(
        self,
        goal_path=GOAL_PATH,
        avoid_path=AVOID_PATH,
        params_path=PARAMS_PATH,
        tune_memberships: bool = False,
    ):
        self.goal = read_toml(goal_path)
        self.avoid = read_toml(avoid_path)
        # The search starts from the hand design in this file (CRISP_DEFAULTS), never
        # from the shipped file (which a tuning run overwrites), so that the tuning
        # command is reproducible.
        self.params = dict(CRISP_DEFAULTS)
        self.control_period_s = self.params["control_period_s"]
        # tuning stops a run that makes no progress; not before the escape had its chance
        self.stall_cutoff_s = self.params["stall_s"] + 20.0
        self.params_path = Path(params_path)
        self.goal_path, self.avoid_path = Path(goal_path), Path(avoid_path)
        self.tune_memberships = tune_memberships
        self._crisp = list(CRISP_BOUNDS)

    def _mf_names(self) -> list[str]:
        if not self.tune_memberships:
            return []
        return [f"goal.{n}" for n in self.goal.parameter_names()] + [
            f"avoid.{n}" for n in self.avoid.parameter_names()
        ]

    def parameter_names(self) -> list[str]:
        return [f"crisp.{k}" for k in self._crisp] + self._mf_names()

    def initial_vector(self) -> np.ndarray:
        v = [self.params[k] for k in self._crisp]
        if self.tune_memberships:
            v += self.goal.parameter_vector().tolist() + self.avoid.parameter_vector().tolist()
        return np.array(v, dtype=float)

    def bounds(self) -> list[tuple[float, float]]:
        b = [CRISP_BOUNDS[k] for k in self._crisp]
        if self.tune_memberships:
            for value in np.concatenate(
                [self.goal.parameter_vector(), self.avoid.parameter_vector()]
            ):
                span = max(0.3, 0.3 * abs(value))
                b.append((value - span, value + span))
        return b

    def _split(self, vector):
        vector = np.asarray(vector, dtype=float).ravel()
        n = len(self._crisp)
        params = dict(self.params)
        params.update({k: float(x) for k, x in zip(self._crisp, vector[:n])})
        goal, avoid = self.goal, self.avoid
        if self.tune_memberships:
            ng = len(goal.parameter_vector())
            goal = goal.with_parameter_vector(vector[n : n + ng])
            avoid = avoid.with_parameter_vector(vector[n + ng :])
        return goal, avoid, params

    def build(self, vector) -> FuzzyNavController:
        goal, avoid, params = self._split(vector)
        return FuzzyNavController(goal, avoid, params)

    def save(self, vector, path) -> list[Path]:
        """Write the tuned parameters to ``path`` (and, when memberships are tuned, the two
        rule bases beside it); never into the installed package unless asked to."""
        goal, avoid, params = self._split(vector)
        params_path = Path(path)
        written = [write_params(params, params_path)]
        if self.tune_memberships:
            base = params_path.parent
            write_toml(goal, base / "fuzzynav_goal.toml")
            write_toml(avoid, base / "fuzzynav_avoid.toml")
            written += [base / "fuzzynav_goal.toml", base / "fuzzynav_avoid.toml"]
        return written


def params_toml(params: dict) -> str:
    """The crisp parameters as the ``[crisp]`` table of ``fuzzynav_params.toml``: plain
    data, written by tomli-w (in :data:`CRISP_DEFAULTS` order) under two comment lines."""
    import tomli_w

    header = (
        "# fuzzynav's crisp parameters (arbitration, memory, escape); see\n"
        "# controller/fuzzynav.py. Written by FuzzyNavTunable.save.\n\n"
    )
    return header + tomli_w.dumps({"crisp": {k: float(params[k]) for k in CRISP_DEFAULTS}})


def write_params(params: dict, path: str | Path = PARAMS_PATH) -> Path:
    path = Path(path)
    from fuzzynav.safe_files import write_text_atomically

    write_text_atomically(path, params_toml(params))
    return path


def tunable(**kwargs) -> FuzzyNavTunable:
    return FuzzyNavTunable(**kwargs)
