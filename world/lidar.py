"""A ring of range rays (a planar lidar) as the robot's range sensors.

:func:`lidar_config` gives a :class:`~fuzzynav.world.sensors.SensorConfig` of ``n_rays``
single-ray sensors evenly spaced all around, each on the footprint's edge where its
direction leaves the footprint, so a reading is the free distance from the robot's
body along that ray. Both engines take it as they take the sonars
(``Simulation(sensor_config=...)``, ``run_batch(sensor_config=...)``): with
``perception="ultrasonic"`` the controller sees the nearest reading at its ray's angle,
and a controller that takes the ranges gets all of them, in ray order (ray 0 straight
ahead, then counter-clockwise; angles wrapped to (-pi, pi]).
"""

from __future__ import annotations

import math

from fuzzynav.world.robot import HUSKY, RobotDescription, SensorMount
from fuzzynav.world.sensors import SensorConfig

__all__ = ["lidar_config", "ring_mounts"]


def ring_mounts(n_rays: int, robot: RobotDescription = HUSKY) -> tuple[SensorMount, ...]:
    """``n_rays`` mounts evenly spaced all around, on the footprint's edge.

    Parameters
    ----------
    n_rays : int
        How many rays, >= 1.
    robot : RobotDescription
        The robot whose footprint carries them (the Husky if omitted).

    Returns
    -------
    tuple of SensorMount
        ``ray0`` (straight ahead), ``ray1``, ... counter-clockwise.
    """
    if isinstance(n_rays, bool) or not isinstance(n_rays, int) or n_rays < 1:
        raise ValueError(f"n_rays = {n_rays!r}: must be a whole number >= 1")
    half_length, half_width = robot.half_length_m, robot.half_width_m
    mounts = []
    for k in range(n_rays):
        angle = 2.0 * math.pi * k / n_rays
        if angle > math.pi:
            angle -= 2.0 * math.pi
        c, s = math.cos(angle), math.sin(angle)
        # where the ray from the centre leaves the footprint's rectangle
        exit_m = min(
            half_length / abs(c) if abs(c) > 1e-12 else math.inf,
            half_width / abs(s) if abs(s) > 1e-12 else math.inf,
        )
        mounts.append(SensorMount(f"ray{k}", exit_m * c, exit_m * s, angle))
    return tuple(mounts)


def lidar_config(
    n_rays: int = 16,
    robot: RobotDescription = HUSKY,
    max_range_m: float = 10.0,
    update_rate_hz: float = 25.0,
    noise_std_m: float = 0.0,
) -> SensorConfig:
    """A ring of ``n_rays`` single rays (:func:`ring_mounts`) as a sensor configuration.

    Parameters
    ----------
    n_rays : int
        How many rays, >= 1.
    robot : RobotDescription
        The robot that carries it (the Husky if omitted).
    max_range_m : float
        The rays' reach, m.
    update_rate_hz : float
        How often the ring is read, Hz.
    noise_std_m : float
        Gaussian noise on each echo, m (seeded per run).

    Returns
    -------
    SensorConfig
    """
    return SensorConfig(
        mounts=ring_mounts(n_rays, robot),
        beam_width_rad=2.0 * math.pi / n_rays,
        rays_per_beam=1,
        max_range_m=max_range_m,
        update_rate_hz=update_rate_hz,
        noise_std_m=noise_std_m,
    )
