"""The robot as everything but its dynamics knows it: one description, read once.

``assets/husky.toml`` holds the Husky's linear-graph dynamics (:mod:`world.husky`) and,
beside them, what the rest of the code knows of the robot: its collision footprint
(``[footprint]``), its range sensors (any number of ``[[sonars]]``, each a name, a
position in footprint units and an angle; ``[sonar_beam]``, the beam's width) and the
drive's voltage limit (``[drive]``). :data:`HUSKY` is that file read once. The arena, the sensors, the scenario
checks, the layout generator, both engines (through the sensors and the plant's
parameters), the figures, the viewer and fuzzynav's navigator take the footprint and the
sonar mounts from it, or from a description derived from it
(:meth:`RobotDescription.with_sonar_side`, :meth:`RobotDescription.with_footprint`:
``--sonar-side`` is one), so that each number is written once
(``tests/test_one_robot.py`` looks for the literals in the code).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from pathlib import Path
from typing import TypeGuard

from fuzzynav.resources import InputError, loads_user_toml, read_user_text, shown
from fuzzynav.world.husky_params import DEFAULT_PARAMETER_FILE, HuskyParameters

__all__ = [
    "HUSKY",
    "DESCRIPTION_TABLES",
    "RobotDescription",
    "SONAR_KEYS",
    "SensorMount",
    "SonarPlacement",
    "brief",
    "sonar_side_refusal",
]


@dataclass(frozen=True)
class SensorMount:
    """Where a sensor sits on the robot (robot frame: x forward, y left)."""

    name: str
    x_m: float
    y_m: float
    angle_rad: float


#: The tables of husky.toml read here, not by :class:`~fuzzynav.world.husky.HuskyParameters`:
#: ``{table: {key: (unit, upper bound)}}``; every value a finite number > 0. The sonars
#: themselves are the array of tables ``[[sonars]]`` (:data:`SONAR_KEYS`).
DESCRIPTION_TABLES: dict[str, dict[str, tuple[str, float]]] = {
    "sonar_beam": {"width_deg": ("degrees", 180.0)},
    "drive": {"voltage_limit_v": ("V", 1e4)},
}
#: The numbers of one ``[[sonars]]`` entry (besides its ``name``): ``{key: (unit, low,
#: high)}``, each a finite number in ``[low, high]``.
SONAR_KEYS: dict[str, tuple[str, float, float]] = {
    "x_half_lengths": ("half-lengths", -1.0, 1.0),
    "y_half_widths": ("half-widths", -1.0, 1.0),
    "angle_deg": ("degrees", -180.0, 180.0),
}


@dataclass(frozen=True)
class SonarPlacement:
    """Where a sensor sits in footprint units, so that it follows a changed footprint:
    ``x_half_lengths`` ahead of the centre (1 = the front edge), ``y_half_widths`` left
    of the centre line (right negative), pointing ``angle_rad`` from the heading."""

    name: str
    x_half_lengths: float
    y_half_widths: float
    angle_rad: float

    def mount(self, footprint_m: tuple[float, float]) -> SensorMount:
        """The :class:`SensorMount` on a footprint of this length and width (m)."""
        half_length, half_width = 0.5 * footprint_m[0], 0.5 * footprint_m[1]
        return SensorMount(
            self.name,
            self.x_half_lengths * half_length,
            self.y_half_widths * half_width,
            self.angle_rad,
        )


def _placements_of(mounts, footprint_m: tuple[float, float]) -> tuple[SonarPlacement, ...]:
    """The placements of ``mounts`` on a footprint of this length and width (m)."""
    half_length, half_width = 0.5 * footprint_m[0], 0.5 * footprint_m[1]
    return tuple(
        SonarPlacement(
            m.name,
            m.x_m / half_length if half_length else 0.0,
            m.y_m / half_width if half_width else 0.0,
            m.angle_rad,
        )
        for m in mounts
    )


def _check_side_angle(side_angle_rad: float) -> None:
    if not (math.isfinite(side_angle_rad) and 0.0 < side_angle_rad <= math.pi / 2):
        raise ValueError(f"side_angle_rad = {side_angle_rad!r}: must be in (0, pi/2]")


def sonar_side_refusal(sensors, geometry: str = "husky") -> str | None:
    """Why a side angle (``--sonar-side``) cannot mean anything for these sensors, or
    None when it can. It turns the side sonars: those that point off the heading, within
    90 degrees of it. A set without one has nothing to turn; a set with a sensor that
    looks further back (a ring of rays all around, ``world/lidar.py``) has no side
    sonars: turned, its rays would collapse onto two directions and its rear ones look
    forward across the body. In the paper's geometry the robot is a point without
    sonars (its inputs exact, its ranges none): the angle would change nothing.

    Parameters
    ----------
    sensors : sequence of SensorMount or SonarPlacement
        The robot's range sensors (a name and an ``angle_rad`` each).
    geometry : {"husky", "paper"}
        The robot's geometry (``world/perception.py``).

    Returns
    -------
    str or None
    """
    if geometry == "paper":
        return (
            "with geometry = 'paper' the robot is the paper's point, which has no sonars "
            "(its inputs are exact): a side angle would change nothing (geometry 'husky' "
            "has the sonars)"
        )
    behind = [p for p in sensors if abs(p.angle_rad) > math.pi / 2 + 1e-9]
    if behind:
        names = ", ".join(f"{p.name} at {math.degrees(p.angle_rad):g}" for p in behind[:3])
        more = f" and {len(behind) - 3} more" if len(behind) > 3 else ""
        return (
            f"the robot's sensors look behind the side ({names} degrees{more}): a sensor "
            "set all around, such as a ring of rays, has no side sonars to turn"
        )
    if all(p.angle_rad == 0.0 for p in sensors):
        return "none of the robot's sensors points off the heading: no side sonar to turn"
    return None


def _sided(placements, side_angle_rad: float) -> tuple[SonarPlacement, ...]:
    """The placements with every one that points off the heading at +-``side_angle_rad``
    (its own side kept); ValueError when that cannot mean anything for them
    (:func:`sonar_side_refusal`)."""
    _check_side_angle(side_angle_rad)
    why = sonar_side_refusal(placements)
    if why is not None:
        raise ValueError(f"side_angle_rad = {side_angle_rad!r}: {why}")
    return tuple(
        p
        if p.angle_rad == 0.0
        else replace(p, angle_rad=math.copysign(side_angle_rad, p.angle_rad))
        for p in placements
    )


@dataclass(frozen=True)
class RobotDescription:
    """The robot's footprint, sonars, voltage limit and the pymunk body's mass.

    Parameters
    ----------
    footprint_m : (float, float)
        Length along the heading and width across it, m (collisions and clearances).
    sonars : tuple of SonarPlacement
        The range sensors, in footprint units (any number, at least one).
    beam_width_rad : float
        One sonar's cone; side sonars one beam width from the front one leave no gap.
    voltage_limit_v : float
        The saturation after the controller, V.
    mass_kg, inertia_kg_m2 : float
        The hull's mass and yaw inertia (the pymunk body's; the motion is the LG model's).
    mounts : tuple of SensorMount, optional
        The sonars in metres; by default ``sonars`` on the footprint.
    """

    footprint_m: tuple[float, float]
    sonars: tuple[SonarPlacement, ...]
    beam_width_rad: float
    voltage_limit_v: float
    mass_kg: float
    inertia_kg_m2: float
    mounts: tuple[SensorMount, ...] = ()

    def __post_init__(self) -> None:
        footprint = (float(self.footprint_m[0]), float(self.footprint_m[1]))
        object.__setattr__(self, "footprint_m", footprint)
        object.__setattr__(self, "sonars", tuple(self.sonars))
        mounts = tuple(self.mounts) or tuple(p.mount(footprint) for p in self.sonars)
        object.__setattr__(self, "mounts", mounts)

    @property
    def half_length_m(self) -> float:
        """Half the footprint's length, m (centre to front edge)."""
        return 0.5 * self.footprint_m[0]

    @property
    def half_width_m(self) -> float:
        """Half the footprint's width, m (centre to either side)."""
        return 0.5 * self.footprint_m[1]

    @property
    def side_mount_rad(self) -> float:
        """The widest mount's angle off the heading, rad (the Husky's side sonars')."""
        return max(abs(m.angle_rad) for m in self.mounts)

    @property
    def gapless_side_mount_rad(self) -> float:
        """The side sonars' angle that leaves no blind sector ahead: one beam width."""
        return self.beam_width_rad

    def with_sonar_side(self, side_angle_rad: float) -> RobotDescription:
        """The same robot with every sonar that points off the heading at
        +-``side_angle_rad``, on its side (``--sonar-side``).

        Parameters
        ----------
        side_angle_rad : float
            The new angle from the heading, in (0, pi/2].

        Returns
        -------
        RobotDescription

        Raises
        ------
        ValueError
            The angle is out of range, or the robot has no side sonars to turn
            (:func:`sonar_side_refusal`: none off the heading, or a ring all around).
        """
        sonars = _sided(self.sonars, side_angle_rad)
        return replace(self, sonars=sonars, mounts=())

    def with_footprint(self, footprint_m: tuple[float, float]) -> RobotDescription:
        """The same robot with another footprint, its sonars carried with it.

        Parameters
        ----------
        footprint_m : (float, float)
            The new length and width, m.

        Returns
        -------
        RobotDescription
        """
        length, width = float(footprint_m[0]), float(footprint_m[1])
        return replace(self, footprint_m=(length, width), mounts=())

    def with_mounts(self, mounts) -> RobotDescription:
        """The same robot with these sonars (a sensor configuration's own).

        Parameters
        ----------
        mounts : sequence of SensorMount
            The sonars.

        Returns
        -------
        RobotDescription
        """
        mounts = tuple(mounts)
        return replace(self, sonars=_placements_of(mounts, self.footprint_m), mounts=mounts)

    def with_parameters(
        self, parameters: HuskyParameters, mounts=None, voltage_limit_v: float | None = None
    ) -> RobotDescription:
        """The footprint, mass and inertia of a plant's parameters, the rest this one's
        unless given (the sonars stay where they are: the simulation's robot, whose
        sensors may be configured apart).

        Parameters
        ----------
        parameters : HuskyParameters
            The plant's parameters.
        mounts : sequence of SensorMount, optional
            The sonars (this description's if omitted).
        voltage_limit_v : float, optional
            The saturation after the controller (this description's if omitted).

        Returns
        -------
        RobotDescription
        """
        footprint = (parameters.footprint_length_m, parameters.footprint_width_m)
        mounts = self.mounts if mounts is None else tuple(mounts)
        return replace(
            self,
            footprint_m=footprint,
            mass_kg=parameters.hull_mass_kg,
            inertia_kg_m2=parameters.hull_inertia_kg_m2,
            sonars=_placements_of(mounts, footprint),
            mounts=mounts,
            voltage_limit_v=(
                self.voltage_limit_v if voltage_limit_v is None else float(voltage_limit_v)
            ),
        )

    @classmethod
    def from_toml(cls, path: str | Path) -> RobotDescription:
        """Read the description from a parameter file such as ``assets/husky.toml``.

        Parameters
        ----------
        path : str or Path
            The file: :class:`~fuzzynav.world.husky.HuskyParameters`' keys (the footprint,
            mass and inertia are read from them), the tables of
            :data:`DESCRIPTION_TABLES` and the ``[[sonars]]`` (:data:`SONAR_KEYS`).

        Returns
        -------
        RobotDescription

        Raises
        ------
        ValueError
            As :meth:`HuskyParameters.from_toml`, and for a missing or unknown key of a
            description table or a sonar, a value that is not a number in its range, or a
            sonar's name missing or repeated (the file, key and value named).
        """
        path = Path(path)
        parameters = HuskyParameters.from_toml(path)
        try:
            document = loads_user_toml(read_user_text(path, "husky parameter file"), str(path))
        except InputError as error:  # (read once already: only a file changed meanwhile)
            raise ValueError(str(error)) from None
        values = {}
        for table, keys in DESCRIPTION_TABLES.items():
            data = document.get(table)
            if not isinstance(data, dict):
                raise ValueError(f"{path}: table [{table}] = {shown(data)}: missing or not a table")
            for key in data:
                if key not in keys:
                    raise ValueError(f"{path}: unknown key {table}.{key} = {shown(data[key])}")
            for key, (unit, upper) in keys.items():
                value = data.get(key)
                if not _is_number(value) or not (0.0 < value <= upper):
                    raise ValueError(
                        f"{path}: key {table}.{key} = {shown(value)}: must be a number "
                        f"> 0 and <= {upper:g} {unit}"
                    )
                values[key] = float(value)
        return cls(
            footprint_m=(parameters.footprint_length_m, parameters.footprint_width_m),
            sonars=_read_sonars(document.get("sonars"), path),
            beam_width_rad=math.radians(values["width_deg"]),
            voltage_limit_v=values["voltage_limit_v"],
            mass_kg=parameters.hull_mass_kg,
            inertia_kg_m2=parameters.hull_inertia_kg_m2,
        )


def _is_number(value: object) -> TypeGuard[float]:
    return not isinstance(value, bool) and isinstance(value, (int, float))


def _read_sonars(entries, path: Path) -> tuple[SonarPlacement, ...]:
    """The ``[[sonars]]`` of a parameter file, checked (:data:`SONAR_KEYS`)."""
    if not isinstance(entries, list) or not entries:
        raise ValueError(
            f"{path}: [[sonars]] = {shown(entries)}: missing; give at least one "
            f"[[sonars]] table (name, {', '.join(SONAR_KEYS)})"
        )
    sonars: list[SonarPlacement] = []
    for i, entry in enumerate(entries):
        where = f"sonars[{i}]"
        if not isinstance(entry, dict):
            raise ValueError(f"{path}: {where} = {shown(entry)}: must be a table")
        for key in entry:
            if key != "name" and key not in SONAR_KEYS:
                raise ValueError(f"{path}: unknown key {where}.{key} = {shown(entry[key])}")
        name = entry.get("name")
        if not isinstance(name, str) or not name.strip():
            raise ValueError(f"{path}: key {where}.name = {shown(name)}: must be a name")
        if any(s.name == name for s in sonars):
            raise ValueError(f"{path}: key {where}.name = {shown(name)}: named twice")
        numbers = {}
        for key, (unit, low, high) in SONAR_KEYS.items():
            value = entry.get(key)
            if not _is_number(value) or not (low <= value <= high):
                raise ValueError(
                    f"{path}: key {where}.{key} = {shown(value)}: must be a number "
                    f"in [{low:g}, {high:g}] {unit}"
                )
            numbers[key] = float(value)
        sonars.append(
            SonarPlacement(
                name,
                numbers["x_half_lengths"],
                numbers["y_half_widths"],
                math.radians(numbers["angle_deg"]),
            )
        )
    return tuple(sonars)


def brief(controller, robot: RobotDescription) -> None:
    """Tell a controller the robot it drives, as far as it declares it wants to know:
    ``needs_robot = True``: ``controller.set_robot(robot)`` (the whole description, the
    footprint included); ``needs_sensor_mounts = True``: then
    ``controller.set_sensor_mounts(robot.mounts)`` (``--sonar-side`` moves them). The
    simulation calls it before each start.

    Parameters
    ----------
    controller : object
        The controller (any object; one that declares neither is left alone).
    robot : RobotDescription
        The robot that drives.
    """
    if getattr(controller, "needs_robot", False):
        controller.set_robot(robot)
    if getattr(controller, "needs_sensor_mounts", False):
        controller.set_sensor_mounts(robot.mounts)


#: The Husky A200 as ``assets/husky.toml`` describes it, read once.
HUSKY = RobotDescription.from_toml(DEFAULT_PARAMETER_FILE)
