"""The stages of fuzzynav's control step, as :meth:`FuzzyNavController.__call__
<fuzzynav.controller.fuzzynav.FuzzyNavController.__call__>` takes them.

Item numbers are those of docs/fuzzynav.md's design, parameter by parameter.
The readings as floats, the dead reckoning and the check of the target reading (item 10),
the memory, planner and tracker updated and the sector distances (items 1, 2, 7); then
the crisp decisions: the side chooser and its latch (item 5), the progress watch that
starts and ends boundary following (item 8), the arbitration weight ``alpha`` (item 6),
the evaluation of the block(s) that take part, the guard that keeps the goal block from
turning back into an obstacle being passed (item 5), the deadlock's turn on the spot and
the limit on reversing (item 9), and the mixing's saturation (:func:`_saturated`, item
9). :class:`ControlSteps` holds them as methods of the controller (it is mixed into
``FuzzyNavController``, whose state they read and change).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from fuzzynav.controller.fuzzynav_memory import _CLOSING_MPS, PerceptionMemory
from fuzzynav.controller.fuzzynav_planner import BearingPlanner
from fuzzynav.controller.fuzzynav_robot import VOLTAGE_LIMIT_V
from fuzzynav.controller.fuzzynav_tracker import Tracker


def _linz(x: float, lo: float, hi: float) -> float:
    if x <= lo:
        return 1.0
    if x >= hi:
        return 0.0
    return (hi - x) / (hi - lo)


def _saturated(speed: float, turn: float) -> tuple[float, float]:
    """Mixing (item 9): past the voltage limit the speed is reduced, never the turn (the
    loop's saturation would otherwise eat the turn)."""
    limit = VOLTAGE_LIMIT_V
    if abs(turn) > limit:
        turn = math.copysign(limit, turn)
    room = limit - abs(turn)
    if abs(speed) > room:
        speed = math.copysign(room, speed)
    return speed, turn


class ControlSteps:
    """The stages of the step (module doc); mixed into ``FuzzyNavController``, which
    sets the state they use (``__init__`` and ``reset``)."""

    params: dict
    memory: PerceptionMemory
    planner: BearingPlanner
    tracker: Tracker
    axes: Any
    t: float
    cmd: tuple[float, float]
    calls: int
    store_every: int
    sector_every: int
    side: float
    follow: bool
    best_d_t: float
    best_t: float
    follow_d_t: float
    follow_t: float
    creep_s: float
    unstick_s: float
    reverse_s: float
    _eval: Any
    _eval_goal: Any
    _eval_avoid: Any

    @staticmethod
    def _readings(inputs, ranges_m):
        """``(d_t, d_o, phi_t, phi_o, ranges)`` as Python floats (the sonar ranges
        infinite when there are none)."""
        d_t, d_o, phi_t, phi_o = (
            inputs.tolist() if type(inputs) is np.ndarray else [float(v) for v in inputs]
        )
        if ranges_m is None:
            ranges = [math.inf, math.inf, math.inf]
        elif type(ranges_m) is np.ndarray:
            ranges = ranges_m.tolist()
        else:
            ranges = [float(v) for v in ranges_m]
        return d_t, d_o, phi_t, phi_o, ranges

    def _dead_reckon(self, d_t, d_o, phi_t, phi_o, dt):
        """Advance the clock and the dead reckoning, and check the target reading (item
        10); ``(d_t, phi_t, d_o, phi_o, d_o_raw)`` as the rest of the step takes them."""
        d_o_raw = d_o
        # Dead reckoning over the last period from the last command (first-order lag):
        # the memory's odometry, and the tracker's own frame (the turn's real lag).
        self.t += dt
        memory, tracker = self.memory, self.tracker
        cl, cr = self.cmd
        memory.advance(cl, cr, dt)
        vel = memory.vel
        tracker.advance(cl, cr, vel[0], dt)
        if self.params["target_gate_m"] > 0.0 and d_t == d_t and phi_t == phi_t:
            d_t, phi_t = tracker.check_target(d_t, phi_t)
            if tracker.target_doubted:
                # The four inputs arrive together: when the target's are provably
                # disturbed, the nearest obstacle's are not trusted either (the sonar
                # ranges, read apart, still guard the robot).
                d_o = phi_o = d_o_raw = math.nan
        return d_t, phi_t, d_o, phi_o, d_o_raw

    def _sense(self, ranges, d_t, phi_t, d_o, d_o_raw, phi_o, dt):
        """The memory, the planner and the tracker updated (items 1, 2, 7); the sector
        distances ``(left, front, right)`` and the nearest obstacle's side ``hint``."""
        memory, tracker = self.memory, self.tracker
        # At the sensors' rate (sector_s): store the echoes every store_s (and, in ideal
        # perception, the nearest obstacle), forget points older than memory_s,
        # recompute the remembered footprint distance per sector (held between updates)
        # and plan the bearing past the remembered points.
        self.calls += 1
        store_tick = self.calls % self.store_every == 0
        if self.calls % self.sector_every == 0:
            ahead = memory.update(ranges, d_o, phi_o, self.t, store_tick)
            self.planner.update(ahead, d_t, phi_t, phi_o, self.t, self.best_t)
        # The sectors: readings, memory and (ideal perception) the nearest obstacle all
        # around, with time to contact; the tracker follows that obstacle every store_s.
        store_dt = dt * self.store_every
        left, front_eff, right, hint = memory.sectors(
            ranges, d_o, d_o_raw, phi_o, store_tick, dt, store_dt
        )
        if not (d_o == d_o and phi_o == phi_o):
            tracker.lose()
        elif store_tick:
            tracker.track(d_o_raw, phi_o, store_dt)
        return left, front_eff, right, hint

    def _latch_side(self, phi_t, left, front_eff, right, hint) -> float:
        """The side chooser (item 5); the side the avoidance block turns to (+1 left)."""
        p = self.params
        # Side chooser with a latch: the planner's side when it has one (the avoidance
        # block must turn the way the planner steers), else chosen from the readings.
        if self.planner.side != 0.0 and not self.follow:
            self.side = self.planner.side
        elif front_eff < p["latch_front_m"]:
            if self.side == 0.0:
                self.side = self._choose_side(phi_t, left, right, hint)
        elif front_eff > p["release_front_m"] and not self.follow:
            self.side = 0.0
        return self.side if self.side != 0.0 else (1.0 if phi_t >= 0 else -1.0)

    def _watch_progress(self, d_t, left, front_eff, right, side) -> None:
        """Progress watch -> boundary following (item 8): starts after ``stall_s``
        without progress, ends past ``leave_margin_m`` of progress or without a boundary."""
        p = self.params
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

    def _alpha(self, d_t, left, front_eff, right) -> float:
        """Arbitration weight (item 6): the strength of "near" over the sectors."""
        p = self.params
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
        return max(a_front, a_side)

    def _blocks(self, alpha, phi, d_t, avoid_in):
        """``(goal speed, goal turn, avoid speed, avoid turn)``: only the block(s) that
        take part are evaluated (both: one merged call; same numbers)."""
        if alpha <= 0.0:
            g_speed, g_turn = self._eval_goal((phi, d_t))
            return g_speed, g_turn, 0.0, 0.0
        if alpha >= 1.0:
            a_speed, a_turn = self._eval_avoid(avoid_in)
            return 0.0, 0.0, a_speed, a_turn
        return self._eval((phi, d_t) + avoid_in)

    def _guard(self, g_speed, g_turn, d_t, left, right):
        """The goal block's ``(speed, turn)``, kept from turning back into an obstacle
        being passed (item 5)."""
        p = self.params
        # While passing on the latched side, the goal block may not turn back towards the
        # obstacle being passed while it is still remembered within guard_m.
        # It drives on instead (the goal block alone would turn in place).
        # Not when the target is nearer than the obstacle being passed.
        guarding = (self.side > 0 and g_turn < 0.0 and right < p["guard_m"]) or (
            self.side < 0 and g_turn > 0.0 and left < p["guard_m"]
        )
        if (
            guarding
            and not self.follow
            and self.planner.side == 0.0
            and d_t > min(left, right) + 0.5
        ):
            g_turn = 0.0
            g_speed = max(g_speed, p["guard_speed_v"])
        return g_speed, g_turn

    def _unstick(self, speed, turn, side, dt):
        """The command ``(speed, turn)`` out of a deadlock (item 9)."""
        # Deadlock: blended rules that cancel (near on both sides, the goal pulling
        # ahead) leave the robot creeping on the spot; after deadlock_s of that it turns
        # on the spot towards its side for deadlock_s, which gives the planner a new view.
        if self.unstick_s > 0.0:
            self.unstick_s -= dt
            speed, turn = 0.0, 7.0 * side
        elif abs(speed) < 1.5 and abs(turn) < 1.5:
            self.creep_s += dt
            if self.creep_s > self.params["deadlock_s"]:
                self.creep_s = 0.0
                self.unstick_s = self.params["deadlock_s"]
        else:
            self.creep_s = 0.0
        return speed, turn

    def _limit_reverse(self, speed, turn, side, d_o_raw, phi_o, dt):
        """The command ``(speed, turn)`` with reversing limited to ``back_max_s`` at a
        time (item 9)."""
        # The sensors look forward only: backing off is allowed for back_max_s at a
        # time, then the robot turns on the spot until it may drive forward again.
        # Except in ideal perception when the nearest obstacle all around is ahead and
        # coming at the robot by itself: nothing is nearer behind, so it backs away on.
        if speed < 0.0:
            self.reverse_s += dt
            backing_away = (
                d_o_raw == d_o_raw
                and phi_o == phi_o
                and phi_o not in self.axes
                and abs(phi_o) < 0.5 * math.pi
                and self.memory.closing_o > _CLOSING_MPS
            )
            if self.reverse_s > self.params["back_max_s"] and not backing_away:
                speed = 0.0
                if abs(turn) < 4.0:
                    turn = math.copysign(6.0, turn if turn else side)
        else:
            self.reverse_s = 0.0
        return speed, turn

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
