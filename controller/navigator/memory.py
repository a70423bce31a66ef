"""fuzzynav's perception memory (items 1, 2 and 7 of docs/fuzzynav.md's
design): what it makes of its readings over time.

- **Odometry**: the pose dead-reckoned from the voltages the controller commanded, with
  the plant's gains and a first-order lag (``odo_lag``), in which echoes are stored.
- **Echo memory**: every ``store_s`` the echoes nearer than ``store_range_m`` as short
  arcs, and a sonar's nearest echo as a point, merged within ``merge_m`` and forgotten
  after ``memory_s``; at the sensors' rate, the remembered footprint distance per sector
  and the points not behind the robot (which the bearing planner reads).
- **Sectors**: the readings folded by their mounts' angles (:meth:`PerceptionMemory.fold`), the remembered sectors and (ideal perception) the
  nearest obstacle all around folded into left, front and right; each remembered
  sector distance grows back only at ``memory_grow_mps``; the front and the nearest
  obstacle count as nearer when they close faster than the robot's own motion explains
  (time to contact).
"""

from __future__ import annotations

import math

from fuzzynav.controller.navigator.robot import (
    _AXES,
    _HX,
    _HY,
    _MOUNTS,
    _V_PER_VOLT,
    _W_PER_VOLT,
    range_at_clearance,
)

# The nearest obstacle counts as coming at the robot when it closes faster than this,
# beyond what the robot's own motion explains (below it: measurement noise).
_CLOSING_MPS = 0.05


class PerceptionMemory:
    """The memory's state, cleared by :meth:`reset`: ``pose`` and ``vel`` (odometry
    frame), ``points`` (remembered echoes: x, y, time stored), ``mem_sectors`` (their
    footprint distance per sector: left, front, right), ``mem`` (the sector distances
    last fed, growing back), and the closing speeds of the front reading and the
    nearest obstacle. Reads the controller's crisp parameters (``params``, shared)."""

    def __init__(self, params: dict):
        self.params = params
        #: the sonars (x, y, angle) and their axes: the robot's (set_sensor_mounts)
        self.mounts, self.axes = _MOUNTS, _AXES
        #: the footprint's half-sizes (m): the robot's (set_robot)
        self.hx, self.hy = _HX, _HY
        self.reset()

    @property
    def mounts(self) -> tuple[tuple[float, float, float], ...]:
        """The sonars as ``(x, y, angle)`` (robot frame), any number: the front one is
        the one pointing nearest straight ahead (the first of a tie), the others fold
        into the left sector (angle > 0) or the right (angle <= 0)."""
        return self._mounts

    @mounts.setter
    def mounts(self, mounts) -> None:
        self._mounts = mounts = tuple(mounts)
        angles = [abs(m[2]) for m in mounts]
        front = angles.index(min(angles))
        others = [k for k in range(len(mounts)) if k != front]
        #: the front sonar's index and the left and right sectors' indices
        self.front_index = front
        self.left_indices = tuple(k for k in others if mounts[k][2] > 0.0)
        self.right_indices = tuple(k for k in others if mounts[k][2] <= 0.0)
        # the three-sonar Husky's left, front, right: unpacked as they come
        self._in_order = (self.left_indices, front, self.right_indices) == ((0,), 1, (2,))

    def fold(self, ranges) -> tuple[float, float, float]:
        """The readings as ``(left, front, right)`` (m): the front sonar's, and the
        nearest of each side's (inf for a side without a sonar or a reading)."""
        if self._in_order and len(ranges) == 3:
            left, front, right = ranges
            return left, front, right
        count = len(ranges)
        front = ranges[self.front_index] if self.front_index < count else math.inf
        left = min((ranges[k] for k in self.left_indices if k < count), default=math.inf)
        right = min((ranges[k] for k in self.right_indices if k < count), default=math.inf)
        return left, front, right

    def reset(self) -> None:
        self.mem = [math.inf, math.inf, math.inf]  # remembered left, front, right (m)
        self.prev_front = math.inf
        self.closing_f = 0.0  # front closing speed beyond our own (m/s), per store_s
        self.closing_o = 0.0  # nearest obstacle's closing speed beyond our own (m/s)
        self.prev_obstacle = (math.nan, math.nan)
        # Short memory of echoes: points in an odometry frame (dead reckoning from the
        # voltages this controller commanded), forgotten after memory_s seconds.
        self.pose = [0.0, 0.0, 0.0]
        self.vel = [0.0, 0.0]
        self.points: list[tuple[float, float, float]] = []  # (x, y, time stored)
        self.mem_sectors = (math.inf, math.inf, math.inf)

    def advance(self, cl: float, cr: float, dt: float) -> None:
        """Dead reckoning over the last period from the last command ``(cl, cr)`` (V):
        the speed and turn rate follow it with a first-order lag, then the pose moves."""
        p = self.params
        pose, vel = self.pose, self.vel
        lag = p["odo_lag"]
        vel[0] += (_V_PER_VOLT * 0.5 * (cl + cr) - vel[0]) * lag
        vel[1] += (_W_PER_VOLT * 0.5 * (cr - cl) - vel[1]) * lag
        th = pose[2] + 0.5 * vel[1] * dt
        pose[0] += vel[0] * dt * math.cos(th)
        pose[1] += vel[0] * dt * math.sin(th)
        pose[2] += vel[1] * dt

    def remember(self, x: float, y: float, t: float) -> None:
        """Store an echo point (odometry frame) at time ``t``; one near a remembered
        point replaces it, so a static obstacle costs a few points however long it is seen."""
        merge2 = self.params["merge_m"] ** 2
        points = self.points
        for i in range(len(points) - 1, -1, -1):
            px, py, _ = points[i]
            if (px - x) ** 2 + (py - y) ** 2 < merge2:
                del points[i]
                break
        points.append((x, y, t))

    def update(self, ranges, d_o: float, phi_o: float, t: float, store_tick: bool) -> list:
        """At the sensors' rate: store the echoes (every ``store_s``: ``store_tick``),
        forget points older than ``memory_s`` and recompute the remembered footprint
        distance per sector (``mem_sectors``, held between updates). Returns the points
        not behind the robot's rear edge, in its frame (x ahead, y left), for the planner."""
        p = self.params
        x0, y0, th = self.pose
        c, s_ = math.cos(th), math.sin(th)
        store_range = p["store_range_m"]
        points = self.points
        if store_tick:
            # An ultrasonic echo may come from anywhere across the beam: it is
            # remembered as an arc (the axis and both edges), or a point placed on
            # the axis would follow the robot as it turns away.
            spread = math.radians(p["echo_spread_deg"])
            for (mx, my, ma), r in zip(self.mounts, ranges):
                if r < store_range:
                    for a in (ma - spread, ma, ma + spread):
                        bx, by = mx + r * math.cos(a), my + r * math.sin(a)
                        self.remember(x0 + c * bx - s_ * by, y0 + s_ * bx + c * by, t)
            if d_o == d_o and phi_o in self.axes:
                # A sonar's nearest echo also as the point on its axis that is d_o
                # from the footprint. Only sonar sightings (bearing on a beam axis)
                # are remembered: the all-around nearest obstacle of ideal
                # perception acts in the moment only, because one disturbed sample
                # (s3) would otherwise stay as a phantom obstacle for memory_s.
                rr = range_at_clearance(phi_o, d_o, self.hx, self.hy)
                bx, by = rr * math.cos(phi_o), rr * math.sin(phi_o)
                self.remember(x0 + c * bx - s_ * by, y0 + s_ * bx + c * by, t)
            points = self.points
        oldest = t - p["memory_s"]
        if points and points[0][2] < oldest:
            points = self.points = [q for q in points if q[2] >= oldest]
        m_l = m_f = m_r = math.inf
        corridor = p["front_corridor_m"]
        creep = p["memory_creep_mps"]
        now = t
        hx, hy = self.hx, self.hy
        ahead = []
        for px, py, pt in points:
            dx, dy = px - x0, py - y0
            bx = c * dx + s_ * dy
            by = c * dy - s_ * dx
            if bx < -hx:  # behind the robot: irrelevant going forward
                continue
            ahead.append((bx, by))
            ex = bx - hx if bx > hx else 0.0
            ey = abs(by) - hy
            if ey < 0.0:
                ey = 0.0
            # A remembered echo may have moved since (a moving obstacle): it counts
            # as nearer by memory_creep_mps x its age.
            d = math.sqrt(ex * ex + ey * ey) - creep * (now - pt)
            if bx > 0.0 and abs(by) < hy + corridor:
                if d < m_f:
                    m_f = d
            elif by > 0.0:
                if d < m_l:
                    m_l = d
            elif d < m_r:
                m_r = d
        self.mem_sectors = (m_l, m_f, m_r)
        return ahead

    def sectors(
        self,
        ranges,
        d_o: float,
        d_o_raw: float,
        phi_o: float,
        store_tick: bool,
        dt: float,
        store_dt: float,
    ) -> tuple[float, float, float, float]:
        """The distances fed to the avoidance block: ``(left, front_eff, right, hint)``,
        the readings ``ranges`` (:meth:`fold`) with the remembered sectors and (ideal
        perception) the nearest obstacle ``d_o``, ``phi_o`` folded in and held by the
        memory; ``front_eff`` is the front, shortened by its closing speed (time to
        contact) and ``hint`` the nearest obstacle's bearing when it is ahead (else 0).
        Closing speeds are measured every ``store_s`` (``store_tick``, ``store_dt``
        apart)."""
        p = self.params
        vel = self.vel
        left, front, right = self.fold(ranges)
        raw_front = front
        fold = math.radians(p["side_fold_deg"])
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
                    self.closing_o = (prev_d - d_o) / store_dt - vel[0] * math.cos(phi_o)
                self.prev_obstacle = (d_o_raw, phi_o)
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
            self.closing_f = 0.0
            if raw_front < 4.5 and self.prev_front < 4.5 and abs(vel[1]) < 0.2:
                change = self.prev_front - raw_front
                if abs(change) < 0.3:
                    self.closing_f = change / store_dt - 0.65
            self.prev_front = raw_front
        if self.closing_f > 0.0:
            front_eff = max(0.0, front_mem - p["ttc_gain_s"] * min(self.closing_f, 1.0))

        return left, front_eff, right, hint
