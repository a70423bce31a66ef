"""Running scenarios headless: one place that builds a simulation from user choices."""

from __future__ import annotations

import dataclasses
import functools
import math
from pathlib import Path

from fuzzynav.controller.registry import make_controller
from fuzzynav.world.perception import check_geometry
from fuzzynav.world.robot import sonar_side_refusal
from fuzzynav.world.scenario import DEFAULT_FOOTPRINT_M, Scenario, check_scenario, load_scenario
from fuzzynav.world.sensors import SensorConfig, default_mounts
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


def check_run_options(
    control_period_s,
    sensor_noise_std_m,
    field_of_view_deg=None,
    sonar_side_deg=None,
) -> tuple[float, float, float | None, float | None]:
    """The run options, checked (ValueError naming the argument and its range) and as
    floats; None (the scenario's field of view, the default mounting) stays None.
    :func:`build_simulation` calls it, for the command line (whose options argparse
    has checked against the same ranges) and the Python interface alike (Python once took
    ``sensor_noise_std_m=1e300`` and ``control_period_s=True``)."""
    from fuzzynav.app.args import (
        FIELD_OF_VIEW_LIMITS_DEG,
        SENSOR_NOISE_LIMITS_M,
        SONAR_SIDE_LIMITS_DEG,
        number_value,
    )
    from fuzzynav.world.run_limits import MAX_CONTROL_PERIOD_S, MIN_CONTROL_PERIOD_S

    def optional(value, name, limits, unit):
        return None if value is None else number_value(value, name, *limits, unit)

    return (
        number_value(
            control_period_s, "control_period_s", MIN_CONTROL_PERIOD_S, MAX_CONTROL_PERIOD_S, " s"
        ),
        number_value(sensor_noise_std_m, "sensor_noise_std_m", *SENSOR_NOISE_LIMITS_M, " m"),
        optional(field_of_view_deg, "field_of_view_deg", FIELD_OF_VIEW_LIMITS_DEG, " degrees"),
        optional(sonar_side_deg, "sonar_side_deg", SONAR_SIDE_LIMITS_DEG, " degrees"),
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
    field_of_view_deg: float | None = None,
    sonar_side_deg: float | None = None,
) -> Simulation:
    """A simulation from user choices; both geometries start from the scenario's own
    pose. ``field_of_view_deg`` replaces the scenario's field of view (ideal perception
    senses obstacles whose centre bears within half of it; None keeps the scenario's).
    ``sonar_side_deg`` mounts the side sonars at +- that angle (None: the default 45)."""
    check_geometry(geometry, perception)
    control_period_s, sensor_noise_std_m, field_of_view_deg, sonar_side_deg = check_run_options(
        control_period_s, sensor_noise_std_m, field_of_view_deg, sonar_side_deg
    )
    # the start is checked against the robot that drives: the paper's geometry is a
    # point robot, so a layout valid for it is not refused for the Husky's footprint
    footprint = (0.0, 0.0) if geometry == "paper" else DEFAULT_FOOTPRINT_M
    if isinstance(scenario, Scenario):
        check_scenario(scenario, footprint)  # one made in code is checked as a file is
    else:
        scenario = load_scenario(scenario, footprint_m=footprint)
    if field_of_view_deg is not None:
        scenario = scenario.replace(field_of_view_deg=field_of_view_deg)
    if sonar_side_deg is not None:  # the robot's sensors must have side sonars to turn
        why = sonar_side_refusal(default_mounts(), geometry)
        if why is not None:
            raise ValueError(f"sonar_side_deg = {sonar_side_deg:g} (--sonar-side): {why}")
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
        sensor_config=SensorConfig(
            noise_std_m=sensor_noise_std_m,
            **(
                {}
                if sonar_side_deg is None
                else {"mounts": default_mounts(side_angle_rad=math.radians(sonar_side_deg))}
            ),
        ),
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


# ---------------------------------------------------------------------------------------
# The command that reproduces a run (stored in every recording's /meta/run)

SCENARIO_DIGEST_OPTION = "--scenario-sha256"
FIS_DIGEST_OPTION = "--fis-sha256"


def scenario_digest(scenario: Scenario) -> str:
    """sha256 of the scenario a run drives, as its TOML (``Scenario.to_toml``, what a
    recording's ``/meta/scenario`` holds): the same for the file it came from and for
    that document saved as a file."""
    import hashlib

    return hashlib.sha256(scenario.to_toml().encode("utf-8")).hexdigest()


def _shipped_name(scenario: Scenario) -> str | None:
    from fuzzynav.world.scenario import SCENARIO_DIR

    source = getattr(scenario, "source", "") or ""
    if not source or source == "<memory>":
        return None
    path = Path(source)
    try:
        shipped = path.resolve().parent == SCENARIO_DIR.resolve() and path.suffix == ".toml"
    except OSError:
        return None
    return path.stem if shipped else None


def _file_signature(path) -> tuple | None:
    """What tells a file's versions apart without reading it (None: cannot stat it)."""
    try:
        stat = Path(path).stat()
    except OSError:
        return None
    return (stat.st_ino, stat.st_size, stat.st_mtime_ns, stat.st_ctime_ns)


@functools.lru_cache(maxsize=64)
def _file_scenario_digest(source: str, signature: tuple | None) -> str | None:
    """:func:`scenario_digest` of the scenario file ``source`` as it is now, read once
    per version of the file (``signature``); None when it cannot be read."""
    from fuzzynav.world.scenario import ScenarioError, load_scenario

    if signature is None:
        return None
    try:
        return scenario_digest(load_scenario(source))
    except (ScenarioError, OSError):
        return None


@functools.lru_cache(maxsize=4)
def _default_parameters(signature: tuple | None):
    """The robot's parameters in husky.toml, read once per version of the file."""
    from fuzzynav.world.husky_params import DEFAULT_PARAMETER_FILE, HuskyParameters

    return HuskyParameters.from_toml(DEFAULT_PARAMETER_FILE)


def _scenario_part(scenario: Scenario) -> tuple[list[str], list[str]]:
    """(arguments, notes): the scenario as ``run`` takes it. A shipped scenario by its
    name when the run drove it unchanged; a file by its path with its digest (``run``
    refuses a file that changed since); a scenario made in memory (the viewer's, an
    edited one) as ``scenario.toml``, the recording's ``/meta/scenario`` saved."""
    digest = scenario_digest(scenario)
    source = getattr(scenario, "source", "") or ""
    if source and source != "<memory>":
        if _file_scenario_digest(source, _file_signature(source)) == digest:
            name = _shipped_name(scenario)
            if name is not None:
                return [name], []
            return [source, SCENARIO_DIGEST_OPTION, digest], []
    return (  # (the digest goes last: see reproduce)
        ["scenario.toml", SCENARIO_DIGEST_OPTION, digest],
        [
            "scenario.toml: the recording's /meta/scenario saved as a file (the run's "
            "scenario was not read unchanged from a file)"
        ],
    )


def rules_text(controller) -> str | None:
    """What a controller drives with, as text: its class, its rule base(s) as TOML and
    its crisp parameters (plain attributes for a controller with no rule base); None
    when they cannot be written out (a fuzzy system the TOML writer refuses)."""
    import json

    from fuzzynav.controller.interface import (
        FuzzyController,
        ParamsController,
        RuleBlocksController,
        unwrapped,
    )
    from fuzzynav.controller.rulebase import dumps_toml

    inner = unwrapped(controller)  # the viewer wraps its controller
    parts = [type(inner).__name__]
    systems = []
    if isinstance(inner, FuzzyController) and inner.fis is not None:
        systems.append(inner.fis)
    if isinstance(inner, RuleBlocksController):
        systems += list(inner.rule_blocks().values())
    try:
        parts += [dumps_toml(system) for system in systems]
    except Exception:  # not a FuzzySystem the writer knows: nothing to compare
        return None
    if isinstance(inner, ParamsController):
        parts.append(inner.params_toml())
    if len(parts) == 1:  # not fuzzy: its plain parameters
        plain = {
            k: v
            for k, v in vars(inner).items()
            if not k.startswith("_") and isinstance(v, (int, float, str, bool))
        }
        parts.append(json.dumps(plain, sort_keys=True, default=repr))
    return "\n".join(parts)


def rules_digest(rules) -> str | None:
    """The one digest of rules: sha256 (hex) of a fuzzy system's TOML (what
    ``--fis-sha256`` pins), or of what a controller drives with (:func:`rules_text`:
    ``--rules-sha256``, a recording's layout key, a study's fingerprint); None when
    they cannot be written out."""
    import hashlib

    from fuzzynav.controller.fuzzy import FuzzySystem
    from fuzzynav.controller.rulebase import dumps_toml

    if rules is None:
        return None
    text = dumps_toml(rules) if isinstance(rules, FuzzySystem) else rules_text(rules)
    return None if text is None else hashlib.sha256(text.encode("utf-8")).hexdigest()


def _controller_part(controller, geometry: str) -> tuple[list[str], list[str]]:
    """(arguments, notes): ``--controller NAME [--off ...]`` when a fresh controller of
    that name (the same parts off) drives with exactly this one's rules and parameters;
    ``--fis PATH --fis-sha256 HEX`` for one read from a .fis file; else a note that the
    controller cannot be named on the command line (edited in the viewer, say)."""
    from fuzzynav.controller.interface import FuzzyController, PartsController, unwrapped
    from fuzzynav.controller.registry import controller_names

    inner = unwrapped(controller)
    name = getattr(inner, "name", None)  # a label, if it has one
    parts_off = tuple(inner.parts_off) if isinstance(inner, PartsController) else ()
    mine = rules_text(controller)
    if mine is not None and isinstance(name, str) and name in controller_names():
        if _fresh_fingerprint(name, geometry, parts_off, _controller_files_signature()) == mine:
            args = ["--controller", name]
            if parts_off:
                args += ["--off", ",".join(parts_off)]
            return args, []
    source = str(getattr(inner, "source", "") or "")
    fis = inner.fis if isinstance(inner, FuzzyController) else None
    if source.endswith(".fis") and fis is not None and mine is not None:
        return ["--fis", source, FIS_DIGEST_OPTION, rules_digest(fis)], []
    label = name if isinstance(name, str) and name else type(inner).__name__
    return (
        ["--controller", label],
        [
            f"the controller ({label}) is not one 'run' builds: its rules or parameters "
            "differ from the shipped ones (they are in /meta/rules)"
        ],
    )


def _controller_files_signature() -> tuple:
    """(name, signature) of every shipped rule file and of husky.toml: what a fresh
    controller is built from, so that a file changed on disk (an editable install) is
    read again."""
    from fuzzynav.resources import asset_path
    from fuzzynav.world.husky_params import DEFAULT_PARAMETER_FILE

    files = [*sorted(asset_path("rules").glob("*.toml")), Path(DEFAULT_PARAMETER_FILE)]
    return tuple((p.name, _file_signature(p)) for p in files)


@functools.lru_cache(maxsize=16)
def _fresh_fingerprint(name: str, geometry: str, parts_off: tuple, signature: tuple):
    """The fingerprint of a fresh controller of that name (those parts off), built once
    per version of the files it is built from: reading and writing out the paper's rule base took about a
    sixth of a recording's time, the same every run."""
    del signature  # the cache's key only
    from fuzzynav.controller.interface import PartsController

    fresh = make_controller(name, geometry=geometry)
    if parts_off and isinstance(fresh, PartsController):
        fresh.set_parts_off(list(parts_off))
    return rules_text(fresh)


@dataclasses.dataclass(frozen=True)
class Reproduction:
    """The ``fuzzynav run`` command of a run; ``complete`` when it reproduces the run by
    itself, else ``notes`` say what it needs besides (or cannot carry)."""

    command: str
    notes: tuple[str, ...] = ()

    @property
    def complete(self) -> bool:
        return not self.notes


def reproduce(
    scenario: Scenario,
    controller,
    *,
    perception: str = "ideal",
    seed: int | None = 0,
    control_period_s: float = 0.02,
    geometry: str = "husky",
    noise_std_m: float = 0.0,
    voltage_limit_v: float = 12.0,
    parameters=None,
) -> Reproduction:
    """The command that repeats a run: every option that changes it (scenario and its
    digest when it is not a shipped one, controller or .fis with its digest, parts off,
    perception, geometry, seed, noise, control period). ``scenario`` is the one the run
    drove (in the paper's geometry, after its paper start)."""
    import shlex

    argv, notes = _scenario_part(scenario)
    digest = argv[1:]  # the scenario's digest option, if any, goes last
    argv = argv[:1]
    more, why = _controller_part(controller, geometry)
    argv += more
    notes += why
    argv += ["--perception", perception, "--geometry", geometry]
    if seed is None:
        notes.append("the run had no seed (seed None): its noise cannot be repeated")
    else:
        argv += ["--seed", str(int(seed))]
    argv += ["--noise", repr(float(noise_std_m)), "--dt", repr(float(control_period_s))]
    argv += digest
    if float(voltage_limit_v) != 12.0:
        notes.append(f"voltage limit {voltage_limit_v:g} V ('run' drives with 12 V)")
    if parameters is not None:
        from fuzzynav.world.husky_params import DEFAULT_PARAMETER_FILE

        if parameters != _default_parameters(_file_signature(DEFAULT_PARAMETER_FILE)):
            notes.append("the robot's parameters differ from husky.toml (see /meta/robot)")
    return Reproduction("fuzzynav run " + " ".join(shlex.quote(a) for a in argv), tuple(notes))


def check_digests(args, sim) -> None:
    """``run --scenario-sha256 / --fis-sha256``: refuse to run a scenario or a rule base
    other than the one a recording's reproduce command names (ValueError, said why)."""
    want = getattr(args, "scenario_sha256", None)
    if want:
        have = scenario_digest(sim.scenario)
        if have != want.lower():
            raise ValueError(
                f"{SCENARIO_DIGEST_OPTION} {want}: the scenario {args.scenario!r} is not the "
                f"one recorded (its sha256 is {have}): the file changed since"
            )
    want = getattr(args, "fis_sha256", None)
    if want:
        fis = getattr(sim.controller, "fis", None)
        have = rules_digest(fis) if fis is not None else "(no rule base)"
        if have != want.lower():
            raise ValueError(
                f"{FIS_DIGEST_OPTION} {want}: the rule base read from --fis is not the one "
                f"recorded (its sha256 is {have}): the file changed since"
            )


def add_digest_options(parser) -> None:
    parser.add_argument(
        SCENARIO_DIGEST_OPTION,
        metavar="HEX",
        help="refuse to run unless the scenario's sha256 (as its TOML; a recording's "
        "reproduce command gives it) is this",
    )
    parser.add_argument(
        FIS_DIGEST_OPTION,
        metavar="HEX",
        help="refuse to run unless the --fis rule base's sha256 (as its TOML) is this",
    )
