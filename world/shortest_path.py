"""The shortest collision-free path among circles: the reference of the benchmark metrics.

A point robot that must keep out of a set of (inflated) circles goes, at best, along
straight segments tangent to the circles and arcs of their boundaries (the tangent
graph, or "visibility graph" of circles). :func:`shortest_path` builds that graph exactly

* nodes: the start, the target and every tangent point: the two tangents from the start
  and from the target to each circle, the outer bitangents of every pair of circles and
  their inner bitangents when the pair does not overlap;
* segment edges: each tangent, when it enters no circle's interior (it may touch);
* arc edges: between consecutive nodes on a circle, along its boundary, when no other
  circle covers any part of the arc (overlapping circles make one wall);

and runs Dijkstra on it (:mod:`heapq`: the graphs are small, and scipy's csgraph would
read a zero-length arc between two coincident tangent points as "no edge"). The result
is exact up to floating point, with no grid.

The benchmark (:func:`robot_shortest_path_m`) inflates every static obstacle by the
clearance (0.25 m, the paper's safe distance) plus the robot's *inscribed* radius (half
its width, 0.335 m for the Husky): the centre of a footprint that keeps the clearance
sideways-on can pass no closer, so this length is a lower bound on the path of any run
that keeps the clearance (an optimistic optimum, as BARN's). It is also the passability
the layout generator guarantees (``world.layouts.PASSABLE_GAP_M`` = width + 2 x 0.25 m):
with the circumscribed radius (0.598 m) many generated gaps would be closed. Moving
obstacles are left out: the reference is the static map, as in BARN.

Pure functions of the geometry; nothing here knows a controller.
"""

from __future__ import annotations

import heapq
import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

__all__ = [
    "ShortestPath",
    "shortest_path",
    "shortest_path_m",
    "robot_shortest_path_m",
    "inflation_m",
    "CLEARANCE_M",
]

CLEARANCE_M = 0.25  # the paper's safe distance
TOLERANCE_M = 1e-7  # a tangent touching a circle is not inside it
_TWO_PI = 2.0 * math.pi


@dataclass(frozen=True)
class ShortestPath:
    """A shortest path: its length and the nodes it visits (start, tangent points on the
    circles, target; consecutive nodes on one circle are joined by an arc).

    ``length_m`` is ``inf`` and ``nodes`` empty when no collision-free path exists.
    """

    length_m: float
    nodes: tuple[tuple[float, float], ...]
    circles_visited: tuple[int, ...]  # per node: its circle's index, -1 for start/target


def inflation_m(width_m: float, clearance_m: float = CLEARANCE_M) -> float:
    """How far the benchmark inflates an obstacle: the clearance plus the robot's
    inscribed radius, half its width (module docstring)."""
    return clearance_m + 0.5 * width_m


def _segments_clear(a: np.ndarray, b: np.ndarray, centres: np.ndarray, radii: np.ndarray):
    """For (m, 2) segment ends a, b: True where the segment enters no circle's interior."""
    if len(centres) == 0:
        return np.ones(len(a), bool)
    ab = b - a  # (m, 2)
    length2 = np.einsum("ij,ij->i", ab, ab)  # (m,)
    ac = centres[None, :, :] - a[:, None, :]  # (m, k, 2)
    with np.errstate(invalid="ignore", divide="ignore"):
        t = np.einsum("mkj,mj->mk", ac, ab) / length2[:, None]
    t = np.where(length2[:, None] > 0.0, np.clip(t, 0.0, 1.0), 0.0)
    closest = a[:, None, :] + t[:, :, None] * ab[:, None, :]
    distance = np.hypot(
        closest[..., 0] - centres[None, :, 0], closest[..., 1] - centres[None, :, 1]
    )
    return np.all(distance >= radii[None, :] - TOLERANCE_M, axis=1)


def _arc_clear(i: int, start_rad: float, sweep_rad: float, centres, radii) -> bool:
    """True when no other circle covers part of circle i's arc from ``start_rad``,
    counter-clockwise by ``sweep_rad``."""
    cx, cy, r = centres[i, 0], centres[i, 1], radii[i]
    for j in range(len(radii)):
        if j == i:
            continue
        rj = radii[j]
        d = math.hypot(centres[j, 0] - cx, centres[j, 1] - cy)
        if d >= r + rj - TOLERANCE_M or d + rj <= r + TOLERANCE_M:
            continue  # apart, touching, or inside circle i: the boundary is free of it
        if d + r <= rj + TOLERANCE_M:
            return False  # circle i lies inside circle j
        toward = math.atan2(centres[j, 1] - cy, centres[j, 0] - cx)
        half = math.acos(max(-1.0, min(1.0, (r * r + d * d - rj * rj) / (2.0 * r * d))))
        # circle j covers the open angular interval (toward - half, toward + half) of i
        begin = (toward - half - start_rad) % _TWO_PI
        angular_tol = TOLERANCE_M / r
        if begin < sweep_rad - angular_tol or begin + 2.0 * half > _TWO_PI + angular_tol:
            return False
    return True


def _point_tangents(p, centre, radius):
    """Angles (seen from the centre) of the two tangent points from point p, or ()."""
    dx, dy = p[0] - centre[0], p[1] - centre[1]
    d = math.hypot(dx, dy)
    if d <= radius:
        return ()
    toward = math.atan2(dy, dx)
    alpha = math.acos(radius / d)
    return (toward + alpha, toward - alpha)


def _bitangents(c1, r1, c2, r2):
    """Pairs (angle on circle 1, angle on circle 2) of the tangent points of the common
    tangents: the outer two, and the inner two when the circles are apart."""
    dx, dy = c2[0] - c1[0], c2[1] - c1[1]
    d = math.hypot(dx, dy)
    toward = math.atan2(dy, dx)
    out = []
    if d > abs(r1 - r2):  # outer: the same normal at both tangent points
        alpha = math.acos((r1 - r2) / d)
        out += [(toward + alpha, toward + alpha), (toward - alpha, toward - alpha)]
    if d > r1 + r2:  # inner: opposite normals
        alpha = math.acos((r1 + r2) / d)
        out += [
            (toward + alpha, toward + alpha + math.pi),
            (toward - alpha, toward - alpha + math.pi),
        ]
    return out


def _tangent_graph(start, target, centres, radii):
    """The tangent graph (module docstring): ``(points, circle_of, edges)``, node 0 the
    start and node 1 the target, ``circle_of[n]`` the circle node ``n`` lies on (-1: an
    end point) and ``edges[n]`` its (length, neighbour) pairs."""
    points = [start, target]
    circle_of = [-1, -1]
    angle_of = [0.0, 0.0]

    def node(i: int, angle: float) -> int:
        x = float(centres[i, 0] + radii[i] * math.cos(angle))
        y = float(centres[i, 1] + radii[i] * math.sin(angle))
        points.append((x, y))
        circle_of.append(i)
        angle_of.append(angle % _TWO_PI)
        return len(points) - 1

    candidates = [(0, 1)]  # segment edges to check, as node pairs
    for i in range(len(radii)):
        for end in (0, 1):
            for angle in _point_tangents(points[end], centres[i], radii[i]):
                candidates.append((end, node(i, angle)))
        for j in range(i + 1, len(radii)):
            for a_i, a_j in _bitangents(centres[i], radii[i], centres[j], radii[j]):
                candidates.append((node(i, a_i), node(j, a_j)))

    xy = np.asarray(points)
    pairs = np.asarray(candidates, int)
    clear = _segments_clear(xy[pairs[:, 0]], xy[pairs[:, 1]], centres, radii)
    edges: list[list[tuple[float, int]]] = [[] for _ in points]
    used: set[int] = set()
    for (u, v), ok in zip(candidates, clear):
        if ok:
            length = math.dist(points[u], points[v])
            edges[u].append((length, v))
            edges[v].append((length, u))
            used.update((u, v))
    for i in range(len(radii)):
        on_circle = sorted((angle_of[n], n) for n in used if circle_of[n] == i)
        if len(on_circle) < 2:
            continue
        # each node to the next counter-clockwise (with two nodes: both ways round)
        for k, (angle, n) in enumerate(on_circle):
            next_angle, m = on_circle[(k + 1) % len(on_circle)]
            sweep = (next_angle - angle) % _TWO_PI
            if _arc_clear(i, angle, sweep, centres, radii):
                length = radii[i] * sweep
                edges[n].append((length, m))
                edges[m].append((length, n))
    return points, circle_of, edges


def _dijkstra(edges) -> tuple[float, list[int]]:
    """Dijkstra from node 0 to node 1: ``(length, route of nodes)``, ``(inf, [])`` when
    node 1 cannot be reached."""
    distance = [math.inf] * len(edges)
    previous = [-1] * len(edges)
    distance[0] = 0.0
    queue = [(0.0, 0)]
    while queue:
        d, u = heapq.heappop(queue)
        if d > distance[u]:
            continue
        if u == 1:
            break
        for length, v in edges[u]:
            if d + length < distance[v]:
                distance[v] = d + length
                previous[v] = u
                heapq.heappush(queue, (d + length, v))
    if not math.isfinite(distance[1]):
        return math.inf, []
    route = [1]
    while route[-1] != 0:
        route.append(previous[route[-1]])
    route.reverse()
    return float(distance[1]), route


def shortest_path(start, target, centres, radii) -> ShortestPath:
    """The shortest path from ``start`` to ``target`` that enters no circle.

    Parameters
    ----------
    start, target : (2,) floats
        End points [m].
    centres : (k, 2) array_like
        Circle centres [m]; ``k`` may be 0.
    radii : (k,) array_like
        Circle radii [m], > 0 (already inflated: this function knows no robot).

    Returns
    -------
    ShortestPath
        ``length_m = inf`` when no path exists: the start or the target lies inside a
        circle, or the circles wall one off from the other. A path may touch circles.
    """
    centres = np.asarray(centres, float).reshape(-1, 2)
    radii = np.asarray(radii, float).reshape(-1)
    if len(centres) != len(radii):
        raise ValueError(f"{len(centres)} centres but {len(radii)} radii")
    if np.any(~np.isfinite(radii)) or np.any(radii <= 0.0) or not np.all(np.isfinite(centres)):
        raise ValueError("circle centres must be finite and radii finite and > 0")
    start = (float(start[0]), float(start[1]))
    target = (float(target[0]), float(target[1]))
    for name, p in (("start", start), ("target", target)):
        if not all(math.isfinite(v) for v in p):
            raise ValueError(f"{name} = {p}: must be finite")
    none = ShortestPath(math.inf, (), ())
    for p in (start, target):
        if len(radii) and np.any(np.hypot(*(centres - p).T) < radii - TOLERANCE_M):
            return none
    points, circle_of, edges = _tangent_graph(start, target, centres, radii)
    length, route = _dijkstra(edges)
    if not route:
        return none
    return ShortestPath(length, tuple(points[n] for n in route), tuple(circle_of[n] for n in route))


def shortest_path_m(start, target, centres, radii) -> float:
    """Length [m] of :func:`shortest_path` (``inf`` when there is none)."""
    return shortest_path(start, target, centres, radii).length_m


def robot_shortest_path_m(
    start,
    target,
    obstacles: Sequence,
    width_m: float,
    clearance_m: float = CLEARANCE_M,
) -> float:
    """The benchmark's shortest path [m] for a robot of width ``width_m`` that keeps
    ``clearance_m`` from the static obstacles (module docstring).

    ``obstacles``: objects with ``position``, ``radius_m`` and ``is_static`` (a
    scenario's :class:`world.scenario.ObstacleSpec`); moving ones are left out.
    """
    statics = [o for o in obstacles if o.is_static]
    margin = inflation_m(width_m, clearance_m)
    centres = np.array([o.position for o in statics], float).reshape(-1, 2)
    radii = np.array([o.radius_m + margin for o in statics], float)
    return shortest_path_m(start, target, centres, radii)
