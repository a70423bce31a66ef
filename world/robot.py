"""The robot as everything but its dynamics knows it: one description, read once.

``assets/husky.toml`` holds the Husky's linear-graph dynamics (:mod:`world.husky`) and,
beside them, what the rest of the code knows of the robot: its collision footprint
(``[footprint]``), its three sonars (``[sonars]``: the side ones' mounting angle, how far
off the centre line they sit, the beam's width) and the drive's voltage limit
(``[drive]``). :data:`HUSKY` is that file read once. The arena, the sensors, the scenario
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

from fuzzynav.resources import InputError, loads_user_toml, read_user_text, shown
from fuzzynav.world.husky_params import DEFAULT_PARAMETER_FILE, HuskyParameters

__all__ = [
    "HUSKY",
    "DESCRIPTION_TABLES",
    "RobotDescription",
    "SensorMount",
    "brief",
    "sonar_mounts",
]


@dataclass(frozen=True)
class SensorMount:
    """Where a sensor sits on the robot (robot frame: x forward, y left)."""

    name: str
    x_m: float
    y_m: float
    angle_rad: float


#: The tables of husky.toml read here, not by :class:`~fuzzynav.world.husky.HuskyParameters`:
#: ``{table: {key: (unit, upper bound)}}``; every value a finite number > 0.
DESCRIPTION_TABLES: dict[str, dict[str, tuple[str, float]]] = {
    "sonars": {
        "side_angle_deg": ("degrees", 90.0),
        "lateral_fraction": ("-", 1.0),
        "beam_width_deg": ("degrees", 180.0),
    },
    "drive": {"voltage_limit_v": ("V", 1e4)},
}


def sonar_mounts(
    footprint_m: tuple[float, float], side_angle_rad: float, lateral_fraction: float
) -> tuple[SensorMount, ...]:
    """Left, front and right sonars on the footprint's front edge.

    Parameters
    ----------
    footprint_m : (float, float)
        The footprint's length and width, m.
    side_angle_rad : float
        The side sonars' angle from the front one (left +, right -), in (0, pi/2].
    lateral_fraction : float
        How far off the centre line the side sonars sit, as a fraction of the half-width.

    Returns
    -------
    tuple of SensorMount
        ``left``, ``front``, ``right``.

    Raises
    ------
    ValueError
        For a side angle outside (0, pi/2].
    """
    if not (math.isfinite(side_angle_rad) and 0.0 < side_angle_rad <= math.pi / 2):
        raise ValueError(f"side_angle_rad = {side_angle_rad!r}: must be in (0, pi/2]")
    half_length, half_width = 0.5 * footprint_m[0], 0.5 * footprint_m[1]
    corner_y = lateral_fraction * half_width
    return (
        SensorMount("left", half_length, corner_y, side_angle_rad),
        SensorMount("front", half_length, 0.0, 0.0),
        SensorMount("right", half_length, -corner_y, -side_angle_rad),
    )


@dataclass(frozen=True)
class RobotDescription:
    """The robot's footprint, sonars, voltage limit and the pymunk body's mass.

    Parameters
    ----------
    footprint_m : (float, float)
        Length along the heading and width across it, m (collisions and clearances).
    side_mount_rad : float
        The side sonars' mounting angle (left +, right -) from the front one.
    lateral_fraction : float
        The side sonars' distance off the centre line, as a fraction of the half-width.
    beam_width_rad : float
        One sonar's cone; side sonars one beam width from the front one leave no gap.
    voltage_limit_v : float
        The saturation after the controller, V.
    mass_kg, inertia_kg_m2 : float
        The hull's mass and yaw inertia (the pymunk body's; the motion is the LG model's).
    mounts : tuple of SensorMount, optional
        The sonars; by default the three of :func:`sonar_mounts` for the fields above.
    """

    footprint_m: tuple[float, float]
    side_mount_rad: float
    lateral_fraction: float
    beam_width_rad: float
    voltage_limit_v: float
    mass_kg: float
    inertia_kg_m2: float
    mounts: tuple[SensorMount, ...] = ()

    def __post_init__(self) -> None:
        object.__setattr__(
            self, "footprint_m", (float(self.footprint_m[0]), float(self.footprint_m[1]))
        )
        if not self.mounts:
            object.__setattr__(
                self,
                "mounts",
                sonar_mounts(self.footprint_m, self.side_mount_rad, self.lateral_fraction),
            )
        else:
            object.__setattr__(self, "mounts", tuple(self.mounts))

    @property
    def half_length_m(self) -> float:
        """Half the footprint's length, m (centre to front edge)."""
        return 0.5 * self.footprint_m[0]

    @property
    def half_width_m(self) -> float:
        """Half the footprint's width, m (centre to either side)."""
        return 0.5 * self.footprint_m[1]

    @property
    def gapless_side_mount_rad(self) -> float:
        """The side sonars' angle that leaves no blind sector ahead: one beam width."""
        return self.beam_width_rad

    def with_sonar_side(self, side_angle_rad: float) -> RobotDescription:
        """The same robot with its side sonars at +-``side_angle_rad`` (``--sonar-side``).

        Parameters
        ----------
        side_angle_rad : float
            The side sonars' new angle from the front one, in (0, pi/2].

        Returns
        -------
        RobotDescription
        """
        mounts = sonar_mounts(self.footprint_m, side_angle_rad, self.lateral_fraction)
        return replace(self, side_mount_rad=float(side_angle_rad), mounts=mounts)

    def with_footprint(self, footprint_m: tuple[float, float]) -> RobotDescription:
        """The same robot with another footprint, its sonars moved onto the new front edge.

        Parameters
        ----------
        footprint_m : (float, float)
            The new length and width, m.

        Returns
        -------
        RobotDescription
        """
        length, width = float(footprint_m[0]), float(footprint_m[1])
        mounts = sonar_mounts((length, width), self.side_mount_rad, self.lateral_fraction)
        return replace(self, footprint_m=(length, width), mounts=mounts)

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
        return replace(self, mounts=tuple(mounts))

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
        return replace(
            self,
            footprint_m=(parameters.footprint_length_m, parameters.footprint_width_m),
            mass_kg=parameters.hull_mass_kg,
            inertia_kg_m2=parameters.hull_inertia_kg_m2,
            mounts=self.mounts if mounts is None else tuple(mounts),
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
            mass and inertia are read from them) and the tables of
            :data:`DESCRIPTION_TABLES`.

        Returns
        -------
        RobotDescription

        Raises
        ------
        ValueError
            As :meth:`HuskyParameters.from_toml`, and for a missing or unknown key of a
            description table or a value that is not a number in its range (the file,
            key and value named).
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
                if (
                    isinstance(value, bool)
                    or not isinstance(value, (int, float))
                    or not (0.0 < value <= upper)
                ):
                    raise ValueError(
                        f"{path}: key {table}.{key} = {shown(value)}: must be a number "
                        f"> 0 and <= {upper:g} {unit}"
                    )
                values[key] = float(value)
        return cls(
            footprint_m=(parameters.footprint_length_m, parameters.footprint_width_m),
            side_mount_rad=math.radians(values["side_angle_deg"]),
            lateral_fraction=values["lateral_fraction"],
            beam_width_rad=math.radians(values["beam_width_deg"]),
            voltage_limit_v=values["voltage_limit_v"],
            mass_kg=parameters.hull_mass_kg,
            inertia_kg_m2=parameters.hull_inertia_kg_m2,
        )


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
