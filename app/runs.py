"""Running scenarios headless: one place that builds a simulation from user choices."""

from __future__ import annotations

from pathlib import Path

from fuzzynav.controller.registry import make_controller
from fuzzynav.world.perception import check_geometry
from fuzzynav.world.scenario import DEFAULT_FOOTPRINT_M, Scenario, load_scenario
from fuzzynav.world.sensors import SensorConfig
from fuzzynav.world.simulation import Simulation, SimulationResult

SUMMARY_KEYS = (
    "scenario",
    "controller",
    "perception",
    "outcome",
    "reached",
    "collided",
    "time_to_target_s",
    "path_length_m",
    "mad_m",
    "rmse_m",
    "min_center_distance_m",
    "min_clearance_m",
    "max_abs_voltage_v",
    "sim_time_s",
    "steps",
    "wall_time_s",
    "voltage_jumps",
    "geometry",
    "min_safety_distance_m",
)


def build_simulation(
    scenario: Scenario | str | Path,
    controller: str = "paper",
    *,
    perception: str = "ideal",
    seed: int | None = 0,
    fis_path: str | Path | None = None,
    control_period_s: float = 0.02,
    sensor_noise_std_m: float = 0.0,
    controller_object=None,
    stop_on_collision: bool = True,
    geometry: str = "husky",
) -> Simulation:
    """A simulation from user choices; both geometries start from the scenario's own
    pose."""
    check_geometry(geometry, perception)
    if not isinstance(scenario, Scenario):
        # the start is checked against the robot that drives: the paper's geometry is a
        # point robot, so a layout valid for it is not refused for the Husky's footprint
        footprint = (0.0, 0.0) if geometry == "paper" else DEFAULT_FOOTPRINT_M
        scenario = load_scenario(scenario, footprint_m=footprint)
    ctrl = (
        controller_object
        if controller_object is not None
        else make_controller(controller, fis_path, geometry=geometry)
    )
    return Simulation(
        scenario,
        ctrl,
        perception=perception,
        control_period_s=control_period_s,
        seed=seed,
        sensor_config=SensorConfig(noise_std_m=sensor_noise_std_m),
        stop_on_collision=stop_on_collision,
        geometry=geometry,
    )


def run_scenario(scenario, controller: str = "paper", **options) -> SimulationResult:
    """Build and run one simulation to its end (see :func:`build_simulation`)."""
    return build_simulation(scenario, controller, **options).run()


def summary(
    result: SimulationResult, controller_label: str, scenario_label: str | None = None
) -> dict:
    """The run as the flat JSON object ``fuzzynav run --json`` prints."""
    out = {
        "scenario": scenario_label or result.scenario.name,
        "controller": controller_label,
        "perception": result.perception,
    }
    out.update(result.metrics)
    return {k: out[k] for k in SUMMARY_KEYS}
