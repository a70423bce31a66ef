"""Scenario files: where the robot starts, where the target is, what is in the way.

A scenario is a TOML file in ``assets/scenarios/`` (or anywhere, given by path)::

    name = "Scenario 1: three static obstacles"
    duration_s = 150.0                 # the run times out after this
    [robot]
    start = [0.0, 0.0]                 # m
    heading_rad = 0.0
    field_of_view_deg = 360.0          # optional: the obstacle sensors' field (below)
    [target]
    position = [8.0, 8.0]              # m
    tolerance_m = 0.15                 # arrival when the centre is this close
    [[obstacles]]
    position = [4.0, 4.0]              # m, at t = 0
    radius_m = 0.2
    velocity = [0.0, 0.0]              # optional, m/s at t = 0
    acceleration = [0.0, 0.0]          # optional, m/s^2 (paper Eq. 13-14)
    [disturbance]                      # optional: A sin(w t) on the controller inputs
    amplitude = 1.0
    angular_frequency_rad_s = 2.0
    start_s = 25.0
    stop_s = 35.0

``robot.field_of_view_deg`` is the field, centred on the heading, in which ideal
perception senses obstacles (by the bearing of an obstacle's centre; 0 < value <= 360,
default 360: all around). s1-s3 set 180, the front half-plane of the paper's three
front-mounted US-100 sensors (docs/paper-controller.md). Ultrasonic perception senses
what the beams hit, whatever this says.

Optional top-level key: ``description``. Every other key is rejected, and every error
names the file, the key and the value, so a typo never silently changes a run.
Files are parsed with :mod:`tomllib`, never evaluated.

The format's keys and bounds, the checked reading of its values and its writer are
:mod:`world.scenario_format`'s; their public names are imported here too, so that
``fuzzynav.world.scenario`` still offers them.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass, field, fields, replace
from pathlib import Path
from typing import Any

from fuzzynav.resources import (
    InputError,
    assets_dir,
    loads_user_toml,
    read_user_text,
)
from fuzzynav.world.geometry import rectangle_circle_clearance
from fuzzynav.world.kernels import CONTACT_CLEARANCE_M
from fuzzynav.world.robot import HUSKY
from fuzzynav.world.scenario_format import (
    _ROBOT_KEYS,
    _TARGET_KEYS,
    _TOP_KEYS,
    FORMAT,
    MAX_ACCELERATION_MPS2,
    MAX_DISTURBANCE,
    MAX_DURATION_S,
    MAX_OBSTACLES,
    MAX_RADIUS_M,
    MAX_SPEED_MPS,
    OMITTED_DEFAULTS,
    ScenarioError,
    ScenarioNotFoundError,
    _fields_of,
    _plain,
    _Reader,
    dumps_plain,
)
from fuzzynav.world.scenario_format import MAX_COORDINATE_M as MAX_COORDINATE_M

ASSETS_DIR = assets_dir()
SCENARIO_DIR = ASSETS_DIR / "scenarios"

# The robot's footprint (assets/husky.toml, world/robot.py), against which a scenario's
# start is checked unless another is given (the paper's point robot: (0, 0)).
DEFAULT_FOOTPRINT_M = HUSKY.footprint_m


@dataclass(frozen=True)
class ObstacleSpec:
    """A circular obstacle; it follows p(t) = p0 + v0 t + a t^2 / 2 (paper Eq. 13-14)."""

    position: tuple[float, float]
    radius_m: float
    velocity: tuple[float, float] = (0.0, 0.0)
    acceleration: tuple[float, float] = (0.0, 0.0)

    @property
    def is_static(self) -> bool:
        return self.velocity == (0.0, 0.0) and self.acceleration == (0.0, 0.0)


@dataclass(frozen=True)
class Disturbance:
    """``amplitude * sin(angular_frequency_rad_s * t)`` added to every controller input
    while ``start_s <= t < stop_s`` (paper scenario 3: sin(2t) for 25-35 s)."""

    amplitude: float
    angular_frequency_rad_s: float
    start_s: float
    stop_s: float

    def value(self, t_s: float) -> float:
        if self.start_s <= t_s < self.stop_s:
            return self.amplitude * math.sin(self.angular_frequency_rad_s * t_s)
        return 0.0


@dataclass(frozen=True)
class Scenario:
    name: str
    duration_s: float
    start: tuple[float, float]
    heading_rad: float
    target: tuple[float, float]
    tolerance_m: float
    obstacles: tuple[ObstacleSpec, ...] = ()
    disturbance: Disturbance | None = None
    description: str = ""
    source: str = field(default="<memory>", compare=False)
    #: ideal perception senses obstacles whose centre bears within +- half of it
    field_of_view_deg: float = 360.0

    def __post_init__(self):
        # A scenario made or replaced in code is held to the file's rule for its
        # duration, a positive finite number of seconds (NaN failed deep inside
        # with "cannot convert float NaN to integer", a negative one ran one step); only
        # the file's hour-long cap is left to files (the log spools a longer run).
        _Reader(self.source).number(self.duration_s, "duration_s", positive=True)

    def replace(self, **changes) -> Scenario:
        return replace(self, **changes)

    @property
    def field_of_view_rad(self) -> float:
        return math.radians(self.field_of_view_deg)

    def to_dict(self) -> dict:
        """The scenario as the plain data of its TOML file (:func:`scenario_from_dict`
        reads it back), laid out by :data:`FORMAT`; a key holding its default
        (:data:`OMITTED_DEFAULTS`) is left out, as a file may leave it out."""
        data: dict[str, Any] = {}
        for table, keys in FORMAT:
            holder = data if table is None else data.setdefault(table, {})
            for key, attribute in keys:
                value = getattr(self, attribute)
                if key in OMITTED_DEFAULTS and value == OMITTED_DEFAULTS[key]:
                    continue
                holder[key] = _plain(value)
        if self.obstacles:  # a file without any leaves the array out
            data["obstacles"] = [_fields_of(o) for o in self.obstacles]
        if self.disturbance is not None:
            data["disturbance"] = _fields_of(self.disturbance)
        return data

    def to_toml(self) -> str:
        """TOML text that :func:`load_scenario` reads back to an equal scenario: the plain
        data of :meth:`to_dict`, each value written by tomli-w, each ``[x, y]`` pair on one
        line (tomli-w writes an array over several lines; scenario files are read and
        edited by people). Its bytes are what a run's scenario digest is taken of
        (app/runs.py): they are those of the hand-written layout this replaced."""
        return dumps_plain(self.to_dict())


_OBSTACLE_KEYS = {f.name for f in fields(ObstacleSpec)}
_DISTURBANCE_KEYS = {f.name for f in fields(Disturbance)}


def _read_obstacles(r: _Reader, data: dict) -> list[ObstacleSpec]:
    """The ``[[obstacles]]`` of a scenario's data, each checked."""
    raw_obstacles = data.get("obstacles", [])
    if not isinstance(raw_obstacles, list):
        r.fail("obstacles", raw_obstacles, "must be an array of tables ([[obstacles]])")
    if len(raw_obstacles) > MAX_OBSTACLES:
        r.fail(
            "obstacles",
            raw_obstacles,
            f"{len(raw_obstacles)} obstacles: at most {MAX_OBSTACLES} are allowed",
        )
    obstacles = []
    for i, raw in enumerate(raw_obstacles):
        key = f"obstacles[{i}]"
        o = r.table(raw, key, _OBSTACLE_KEYS, {"position", "radius_m"})
        obstacles.append(
            ObstacleSpec(
                position=r.point(o["position"], f"{key}.position"),
                radius_m=r.number(
                    o["radius_m"], f"{key}.radius_m", positive=True, limit=MAX_RADIUS_M, unit=" m"
                ),
                velocity=r.point(
                    o.get("velocity", [0.0, 0.0]), f"{key}.velocity", MAX_SPEED_MPS, " m/s"
                ),
                acceleration=r.point(
                    o.get("acceleration", [0.0, 0.0]),
                    f"{key}.acceleration",
                    MAX_ACCELERATION_MPS2,
                    " m/s^2",
                ),
            )
        )
    return obstacles


def _read_disturbance(r: _Reader, data: dict) -> Disturbance | None:
    """The ``[disturbance]`` of a scenario's data, checked; None without one."""
    if "disturbance" not in data:
        return None
    d = r.table(data["disturbance"], "disturbance", _DISTURBANCE_KEYS, _DISTURBANCE_KEYS)
    disturbance = Disturbance(
        amplitude=r.number(d["amplitude"], "disturbance.amplitude", limit=MAX_DISTURBANCE),
        angular_frequency_rad_s=r.number(
            d["angular_frequency_rad_s"],
            "disturbance.angular_frequency_rad_s",
            limit=1e4,
            unit=" rad/s",
        ),
        start_s=r.number(
            d["start_s"],
            "disturbance.start_s",
            non_negative=True,
            limit=MAX_DURATION_S,
            unit=" s",
        ),
        stop_s=r.number(
            d["stop_s"],
            "disturbance.stop_s",
            non_negative=True,
            limit=MAX_DURATION_S,
            unit=" s",
        ),
    )
    if disturbance.stop_s < disturbance.start_s:
        r.fail("disturbance.stop_s", disturbance.stop_s, "must not be before start_s")
    return disturbance


def scenario_from_dict(
    data: dict,
    source: str = "<memory>",
    footprint_m: tuple[float, float] = DEFAULT_FOOTPRINT_M,
) -> Scenario:
    """Validate plain data (as from a TOML file) and build a :class:`Scenario`.

    Raises
    ------
    ScenarioError
        For an unknown or missing key, a value of the wrong type, NaN or inf, a
        non-positive radius, tolerance or duration, a duration over :data:`MAX_DURATION_S`, a start pose whose footprint overlaps
        an obstacle, a target inside a static obstacle or too near one to reach
        (:func:`target_blocker`), or overlapping static obstacles.
    """
    r = _Reader(source)
    r.table(data, "", _TOP_KEYS, {"name", "duration_s", "robot", "target"})
    name = r.string(data["name"], "name")
    description = r.string(data.get("description", ""), "description", keep="\n\t")
    duration_s = r.number(data["duration_s"], "duration_s", positive=True)
    if duration_s > MAX_DURATION_S:
        r.fail(
            "duration_s",
            duration_s,
            f"must be at most {MAX_DURATION_S:g} s (an hour of simulated time)",
        )

    robot = r.table(data["robot"], "robot", _ROBOT_KEYS, {"start"})
    start = r.point(robot["start"], "robot.start")
    heading = r.number(
        robot.get("heading_rad", 0.0), "robot.heading_rad", limit=1000.0, unit=" rad"
    )

    field_of_view_deg = r.number(
        robot.get("field_of_view_deg", 360.0),
        "robot.field_of_view_deg",
        positive=True,
        limit=360.0,
        unit=" degrees",
    )

    target_t = r.table(data["target"], "target", _TARGET_KEYS, {"position"})
    target = r.point(target_t["position"], "target.position")
    tolerance = r.number(
        target_t.get("tolerance_m", 0.15),
        "target.tolerance_m",
        positive=True,
        limit=MAX_RADIUS_M,
        unit=" m",
    )

    obstacles = _read_obstacles(r, data)
    disturbance = _read_disturbance(r, data)
    scenario = Scenario(
        name=name,
        duration_s=duration_s,
        start=start,
        heading_rad=heading,
        target=target,
        tolerance_m=tolerance,
        obstacles=tuple(obstacles),
        disturbance=disturbance,
        description=description,
        source=source,
        field_of_view_deg=field_of_view_deg,
    )
    check_layout(scenario, footprint_m)
    return scenario


def target_blocker(
    target, tolerance_m: float, obstacles, half_width_m: float
) -> tuple[int, str] | None:
    """The first static obstacle that keeps the robot from the target, as
    ``(index, reason)``, or None.

    The robot arrives when its centre is within ``tolerance_m`` of the target, and its
    centre never comes nearer an obstacle's surface than its half-width (side-on). So a
    target less than ``half_width_m - tolerance_m`` from a static obstacle's surface (or
    inside it) cannot be reached. Moving obstacles pass: scenario 2 starts one on the
    target.
    """
    for i, o in enumerate(obstacles):
        if not o.is_static:
            continue
        gap_m = math.dist(o.position, target) - o.radius_m
        if gap_m < 0.0:
            return i, (
                f"lies inside static obstacle obstacles[{i}] at {list(o.position)} "
                f"(radius {o.radius_m} m)"
            )
        if gap_m + tolerance_m < half_width_m:
            return i, (
                f"cannot be reached: it is {gap_m:.3f} m from static obstacle "
                f"obstacles[{i}] at {list(o.position)} (radius {o.radius_m} m), and "
                f"the robot's centre, which must come within {tolerance_m} m of it, "
                f"stays at least its half-width {half_width_m} m from any obstacle"
            )
    return None


def check_scenario(
    scenario: Scenario, footprint_m: tuple[float, float] = DEFAULT_FOOTPRINT_M
) -> None:
    """Check a :class:`Scenario` built in code as a file is checked (every key, limit and
    layout rule): it is written out and read back. Raises :class:`ScenarioError`.

    Parameters
    ----------
    scenario : Scenario
        The scenario (a shipped one, an edited one, one made in code).
    footprint_m : tuple of float
        The robot's (length, width) its start is checked against; (0, 0): a point.
    """
    loads_scenario(scenario.to_toml(), scenario.source or scenario.name, footprint_m)


def check_layout(scenario: Scenario, footprint_m: tuple[float, float] = DEFAULT_FOOTPRINT_M):
    """Reject layouts no run could start from, or whose target no run could reach
    (raises :class:`ScenarioError`)."""
    r = _Reader(scenario.source)
    length, width = footprint_m
    for i, o in enumerate(scenario.obstacles):
        clearance = rectangle_circle_clearance(
            scenario.start, scenario.heading_rad, length, width, o.position, o.radius_m
        )
        if clearance <= CONTACT_CLEARANCE_M:
            r.fail(
                f"obstacles[{i}].position",
                list(o.position),
                f"overlaps the robot's footprint at its start {list(scenario.start)}",
            )
    blocked = target_blocker(scenario.target, scenario.tolerance_m, scenario.obstacles, 0.5 * width)
    if blocked is not None:
        r.fail("target.position", list(scenario.target), blocked[1])
    overlap = first_overlap([o for o in scenario.obstacles if o.is_static])
    if overlap is not None:
        statics = [i for i, o in enumerate(scenario.obstacles) if o.is_static]
        i, j = statics[overlap[0]], statics[overlap[1]]
        r.fail(
            f"obstacles[{j}].position",
            list(scenario.obstacles[j].position),
            f"overlaps static obstacle obstacles[{i}] at {list(scenario.obstacles[i].position)}",
        )


#: Up to this many obstacles :func:`first_overlap` checks every pair: quicker than loading
#: scipy.spatial for its k-d tree, which a first run would wait for.
ALL_PAIRS_UP_TO = 64


def first_overlap(obstacles) -> tuple[int, int] | None:
    """The first pair ``(i, j)``, ``i < j``, of circles that overlap (centres nearer than
    the sum of the radii), in the order of ``j`` then ``i``; None if none do.

    Up to :data:`ALL_PAIRS_UP_TO` obstacles every pair is checked; beyond, a k-d tree of
    the centres gives the candidate pairs (centres within twice the largest radius), so
    a layout of well-spread obstacles costs O(n log n), not the O(n^2) of every pair;
    :data:`MAX_OBSTACLES` bounds the worst case.
    """
    if len(obstacles) < 2:
        return None
    import numpy as np

    centres = np.array([o.position for o in obstacles], dtype=float)
    radii = np.array([o.radius_m for o in obstacles], dtype=float)
    if len(obstacles) <= ALL_PAIRS_UP_TO:
        i, j = np.triu_indices(len(obstacles), k=1)
    else:
        from scipy.spatial import cKDTree

        pairs = cKDTree(centres).query_pairs(2.0 * float(radii.max()), output_type="ndarray")
        if not len(pairs):
            return None
        i, j = pairs[:, 0], pairs[:, 1]
    gap = np.hypot(*(centres[i] - centres[j]).T)
    hit = gap < radii[i] + radii[j]
    if not hit.any():
        return None
    i, j = i[hit], j[hit]
    first = np.lexsort((i, j))[0]  # the smallest j, then the smallest i
    return int(i[first]), int(j[first])


def scenario_names() -> list[str]:
    """Names of the scenario files shipped in ``assets/scenarios`` (s1, s2, s3, ...)."""
    return sorted(p.stem for p in SCENARIO_DIR.glob("*.toml"))


def resolve_scenario_path(name_or_path: str | Path) -> Path:
    """``s1`` -> ``assets/scenarios/s1.toml``; anything else is taken as a path."""
    text = str(name_or_path)
    candidate = SCENARIO_DIR / f"{text}.toml"
    if "/" not in text and "\\" not in text and not text.endswith(".toml") and candidate.exists():
        return candidate
    return Path(text)


def load_scenario(
    name_or_path: str | Path, footprint_m: tuple[float, float] = DEFAULT_FOOTPRINT_M
) -> Scenario:
    """Load and validate a scenario by shipped name (``s1``) or by path.

    Raises
    ------
    ScenarioError
        The file is not valid TOML or fails validation; a missing file is a
        :class:`ScenarioNotFoundError`, also a ``FileNotFoundError``.
    """
    if not isinstance(name_or_path, str | os.PathLike) or name_or_path == "":
        raise TypeError(
            f"scenario = {name_or_path!r}: a shipped scenario's name (such as 's1'), a "
            "scenario file's path or a Scenario"
        )
    path = resolve_scenario_path(name_or_path)
    source = str(path)
    if not path.exists() and not path.is_symlink():
        known = ", ".join(scenario_names())
        raise ScenarioNotFoundError(
            source, "file", str(name_or_path), f"no such scenario file (shipped scenarios: {known})"
        )
    try:
        data = loads_scenario_data(read_user_text(path, "scenario file"), source)
    except InputError as exc:
        raise ScenarioError(source, "file", path.name, exc.reason) from None
    return scenario_from_dict(data, source=source, footprint_m=footprint_m)


def loads_scenario_data(text: str, source: str) -> dict:
    """The plain data of a scenario's TOML text, every limit checked
    (:func:`fuzzynav.resources.loads_user_toml`); raises InputError."""
    return loads_user_toml(text, source)


def loads_scenario(
    content: str | bytes, source: str, footprint_m: tuple[float, float] = DEFAULT_FOOTPRINT_M
) -> Scenario:
    """Parse and validate a scenario from its TOML text or bytes (an upload);
    ``source`` names it in errors. Raises :class:`ScenarioError`."""
    from fuzzynav.resources import decode_user_bytes

    try:
        text = decode_user_bytes(content, source) if isinstance(content, bytes) else content
        data = loads_scenario_data(text, source)
    except InputError as exc:
        reason = exc.reason.replace("not valid TOML:", "not a valid TOML scenario:", 1)
        raise ScenarioError(source, "file", "upload", reason) from None
    return scenario_from_dict(data, source=source, footprint_m=footprint_m)
