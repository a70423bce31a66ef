"""Issue 19, input: every malformed or hostile file of the outside review is refused with
the file, key (or line) and value named, quickly, and nothing but the project's own error
escapes. Each test here failed on the code before the issue (a traceback, a hang of
seconds, or a silent acceptance)."""

from __future__ import annotations

import math
import os
import time
import warnings

import numpy as np
import pytest

from fuzzynav.controller.fis import FisFormatError, loads_fis, read_fis
from fuzzynav.controller.fuzzy import FuzzySystem, Rule, Term, Variable
from fuzzynav.controller.rulebase import MAX_RULES, MAX_TERMS, MAX_VARIABLES, loads_toml
from fuzzynav.world.husky import HuskyParameters
from fuzzynav.world.scenario import (
    MAX_OBSTACLES,
    ScenarioError,
    load_scenario,
    loads_scenario,
    scenario_from_dict,
)

SCENARIO = """name = "t"
duration_s = 10.0
[robot]
start = [0.0, 0.0]
[target]
position = [8.0, 8.0]
"""

FIS = """[System]
Name='t'
Type='mamdani'
Version=2.0
NumInputs=1
NumOutputs=1
NumRules=1
AndMethod='min'
OrMethod='max'
ImpMethod='min'
AggMethod='max'
DefuzzMethod='centroid'

[Input1]
Name='x'
Range=[0 1]
NumMFs=1
MF1='a':'MFSHAPE',[MFPARAMS]

[Output1]
Name='y'
Range=[0 1]
NumMFs=1
MF1='b':'trimf',[0 0.5 1]

[Rules]
1, 1 (1) : 1
"""


def fis_text(shape="trimf", params="0 0.5 1", **system) -> str:
    text = FIS.replace("MFSHAPE", shape).replace("MFPARAMS", params)
    for key, value in system.items():
        text = text.replace(f"{key}=1\n", f"{key}={value}\n", 1)
    return text


# ---------------------------------------------------------------------------------------
# .fis


@pytest.mark.parametrize(
    "shape, params",
    [
        ("gaussmf", "1e-200 0.5"),  # 2 sigma^2 underflows: ZeroDivisionError before
        ("gaussmf", "1e200 0.5"),  # ... overflows: NameError 'inf' before
        ("gauss2mf", "1e-200 0.2 1e200 0.7"),
        ("trimf", "-1e308 0 1e308"),  # c - a overflows
        ("trapmf", "-1e308 -1e308 1e308 1e308"),
    ],
)
def test_single_sample_code_agrees_with_the_batch_path_on_extreme_constants(shape, params):
    system = loads_fis(fis_text(shape, params), "x.fis")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # numpy's, on the batch path
        for x in (0.5, 0.2, 0.7, 0.0, 1e300, -1e308, math.nan, math.inf):
            one = system.evaluate_one([x])
            batch = system.evaluate(np.array([[x]]))[0]
            assert np.array_equal(one, batch, equal_nan=True), x


def test_the_number_pattern_is_linear():
    """20,000 digits then 'x' took 39 s (the pattern tried every split of the digits);
    200,000 would take an hour."""
    start = time.perf_counter()
    with pytest.raises(FisFormatError, match=r"x\.fis:\d+: MF1 parameter: not a number"):
        loads_fis(fis_text("trimf", "0 0.5 " + "1" * 200_000 + "x"), "x.fis")
    assert time.perf_counter() - start < 5.0


@pytest.mark.parametrize(
    "key, value, limit",
    [
        ("NumOutputs", "99999999999999999999", MAX_VARIABLES),  # OverflowError before
        ("NumInputs", "1000000000", MAX_VARIABLES),  # MemoryError / 36 GB before
        ("NumRules", "1" + "0" * 5000, MAX_RULES),  # ValueError without file or line before
    ],
)
def test_counts_are_bounded_with_the_limit_named(key, value, limit):
    with pytest.raises(FisFormatError) as info:
        loads_fis(fis_text(**{key: value}), "big.fis")
    message = str(info.value)
    assert "big.fis:" in message and key in message and f"at most {limit}" in message
    assert len(message) < 300  # the 5000 digits are cut


def test_too_many_terms_and_a_huge_term_index_are_refused():
    text = fis_text().replace("NumMFs=1\nMF1='a'", f"NumMFs={MAX_TERMS + 1}\nMF1='a'", 1)
    with pytest.raises(FisFormatError, match=f"NumMFs: too large \\(at most {MAX_TERMS}\\)"):
        loads_fis(text, "x.fis")
    text = fis_text().replace("1, 1 (1) : 1", "9" * 5000 + ", 1 (1) : 1")
    with pytest.raises(FisFormatError, match="antecedent index: too large"):
        loads_fis(text, "x.fis")


def test_control_characters_in_fis_names_are_escaped():
    system = loads_fis(fis_text().replace("Name='t'", "Name='a\x1b[31mb'"), "x.fis")
    assert "\x1b" not in system.name and "\\x1b" in system.name


def test_a_fis_directory_or_fifo_is_named(tmp_path):
    with pytest.raises(FisFormatError, match="is a directory"):
        read_fis(tmp_path)
    fifo = tmp_path / "pipe.fis"
    os.mkfifo(fifo)
    with pytest.raises(FisFormatError, match="is a FIFO"):
        read_fis(fifo)  # never opened: that would wait for a writer


# ---------------------------------------------------------------------------------------
# Scenario files


NESTED = {
    "arrays": "x = " + "[" * 5000 + "]" * 5000,
    "inline tables": "x = " + "{a = " * 5000 + "1" + "}" * 5000,
    "headers": "[" + ".".join(["a"] * 5000) + "]",
    "dotted keys": ".".join(["a"] * 5000) + " = 1",
}


@pytest.mark.parametrize("kind", NESTED)
def test_deep_nesting_is_refused_before_it_recurses(write_toml, kind):
    """A RecursionError traceback before (also in the viewer's upload)."""
    path = write_toml(SCENARIO + NESTED[kind] + "\n")
    with pytest.raises(ScenarioError, match="nested deeper than 32 levels") as info:
        load_scenario(path)
    assert str(path) in str(info.value)
    with pytest.raises(ScenarioError, match="nested deeper"):
        loads_scenario((SCENARIO + NESTED[kind]).encode(), "upload.toml")


def test_an_unreadable_scenario_is_named(write_toml, monkeypatch):
    path = write_toml(SCENARIO)

    def refuse(*args, **kwargs):
        raise PermissionError(13, "Permission denied", str(path))

    monkeypatch.setattr(os, "open", refuse)
    with pytest.raises(ScenarioError, match="cannot read: Permission denied"):
        load_scenario(path)


@pytest.mark.skipif(os.geteuid() == 0, reason="root reads any file")
def test_an_unreadable_scenario_is_named_for_real(write_toml):
    path = write_toml(SCENARIO)
    path.chmod(0)
    with pytest.raises(ScenarioError, match="cannot read"):
        load_scenario(path)


def test_a_directory_or_fifo_is_not_called_missing(tmp_path):
    with pytest.raises(ScenarioError, match="is a directory, not a scenario file"):
        load_scenario(tmp_path)
    fifo = tmp_path / "pipe.toml"
    os.mkfifo(fifo)
    with pytest.raises(ScenarioError, match="is a FIFO"):
        load_scenario(fifo)


def test_a_byte_order_mark_is_accepted(tmp_path):
    path = tmp_path / "bom.toml"
    path.write_bytes(b"\xef\xbb\xbf" + SCENARIO.encode())
    assert load_scenario(path).name == "t"
    assert loads_scenario(b"\xef\xbb\xbf" + SCENARIO.encode(), "up.toml").name == "t"


def _grid(n: int, pitch: float = 1.0) -> str:
    side = math.ceil(math.sqrt(n))
    rows = []
    for k in range(n):
        x, y = 20.0 + pitch * (k % side), 20.0 + pitch * (k // side)
        rows.append(f"[[obstacles]]\nposition = [{x}, {y}]\nradius_m = 0.2\n")
    return SCENARIO + "".join(rows)


def test_obstacles_are_counted_and_the_overlap_check_is_fast(write_toml):
    """10,000 obstacles took 31 s to validate (every pair): now refused at once, with the
    limit named; the limit's worth validates in well under a second."""
    start = time.perf_counter()
    with pytest.raises(ScenarioError, match=f"10000 obstacles: at most {MAX_OBSTACLES}"):
        load_scenario(write_toml(_grid(10_000)))
    scenario = load_scenario(write_toml(_grid(MAX_OBSTACLES)))
    assert len(scenario.obstacles) == MAX_OBSTACLES
    assert time.perf_counter() - start < 10.0


def test_the_overlap_check_finds_the_first_pair_as_before(write_toml):
    text = _grid(400) + "[[obstacles]]\nposition = [20.1, 20.0]\nradius_m = 0.2\n"
    with pytest.raises(ScenarioError) as info:
        load_scenario(write_toml(text))
    assert info.value.key == "obstacles[400].position" and "obstacles[0]" in str(info.value)


@pytest.mark.parametrize("value", ["1" + "0" * 5000, "1" + "0" * 400, "9" * 15000 + ".0"])
def test_huge_numbers_are_refused_and_cut_in_the_message(write_toml, value):
    """5000 digits: a ValueError traceback; 400: an OverflowError; 15,000 digits: the
    whole token echoed."""
    path = write_toml(SCENARIO.replace("duration_s = 10.0", f"duration_s = {value}"))
    with pytest.raises(ScenarioError) as info:
        load_scenario(path)
    message = str(info.value)
    assert str(path) in message and len(message) < 400


def test_control_characters_in_a_scenario_name_are_escaped(write_toml):
    path = write_toml(SCENARIO.replace('name = "t"', 'name = "a\\u001b[2Jb\\u0000c"'))
    name = load_scenario(path).name
    assert "\x1b" not in name and "\x00" not in name
    assert name == "a\\x1b[2Jb\\x00c"


# ---------------------------------------------------------------------------------------
# Rule bases (TOML)


RULEBASE = """[system]
name = "t"
POINTS
[[inputs]]
name = "x"
range = [0.0, 1.0]
terms = [{ name = "a", shape = "trimf", params = [0.0, 0.5, 1.0] }]
[[outputs]]
name = "y"
range = [0.0, 1.0]
terms = [{ name = "b", shape = "trimf", params = [0.0, 0.5, 1.0] }]
[rulebase]
rules = ["IF x IS a THEN y IS b"]
"""


@pytest.mark.parametrize(
    "points, needle",
    [
        ("points = 1000000000", "must be an integer from 2 to 10001"),
        ("points = 1e400", "system.points"),
    ],
)
def test_rule_base_points_are_bounded(points, needle):
    with pytest.raises(ValueError, match=needle):
        loads_toml(RULEBASE.replace("POINTS", points), "rb.toml")


def test_rule_base_nesting_and_counts_are_bounded():
    with pytest.raises(ValueError, match="rb.toml: arrays, inline tables or headers nested"):
        loads_toml(RULEBASE.replace("POINTS", NESTED["arrays"]), "rb.toml")
    many = ", ".join(
        f'{{ name = "t{k}", shape = "trimf", params = [0.0, 0.5, 1.0] }}'
        for k in range(MAX_TERMS + 1)
    )
    text = RULEBASE.replace("POINTS", "").replace(
        'terms = [{ name = "a", shape = "trimf", params = [0.0, 0.5, 1.0] }]',
        f"terms = [{many}]",
        1,
    )
    with pytest.raises(ValueError, match=f"at most {MAX_TERMS} allowed"):
        loads_toml(text, "rb.toml")
    rules = ", ".join(['"IF x IS a THEN y IS b"'] * (MAX_RULES + 1))
    text = RULEBASE.replace("POINTS", "").replace(
        'rules = ["IF x IS a THEN y IS b"]', f"rules = [{rules}]"
    )
    with pytest.raises(ValueError, match=f"{MAX_RULES + 1} rules: at most {MAX_RULES}"):
        loads_toml(text, "rb.toml")


# ---------------------------------------------------------------------------------------
# husky.toml


def _husky(tmp_path, **changes):
    from fuzzynav.world.husky import DEFAULT_PARAMETER_FILE

    text = DEFAULT_PARAMETER_FILE.read_text()
    for key, value in changes.items():
        lines = [
            f"{key} = {value}" if line.split("=")[0].strip() == key else line
            for line in text.splitlines()
        ]
        text = "\n".join(lines) + "\n"
    path = tmp_path / "husky.toml"
    path.write_text(text)
    return path


@pytest.mark.parametrize(
    "key, value",
    [
        ("hull_inertia_kg_m2", "1e-300"),  # NaN "non-finite voltages" in the run before
        ("hull_mass_kg", "1e30"),
        ("torque_constant_nm_per_a", "1e90"),
        ("wheel_radius_m", "1e-9"),
    ],
)
def test_husky_values_that_no_robot_has_are_named(tmp_path, key, value):
    path = _husky(tmp_path, **{key: value})
    with pytest.raises(ValueError) as info:
        HuskyParameters.from_toml(path)
    message = str(info.value)
    assert str(path) in message and key in message and "physically possible" in message


def test_husky_plant_that_drives_beyond_reason_is_refused(tmp_path):
    """Every value within its range, but together a 12 V top speed far beyond a ground
    robot's."""
    path = _husky(
        tmp_path,
        torque_constant_nm_per_a=1e-4,
        gear_ratio=0.01,
        wheel_damping_fl=1e-6,
        wheel_damping_rl=1e-6,
        wheel_damping_fr=1e-6,
        wheel_damping_rr=1e-6,
        wheel_radius_m=5,
    )
    with pytest.raises(ValueError, match="drive the robot at .* m/s at 12 V"):
        HuskyParameters.from_toml(path)


def test_the_shipped_husky_passes_and_a_nested_file_is_refused(tmp_path):
    from fuzzynav.world.husky import DEFAULT_PARAMETER_FILE

    HuskyParameters.from_toml(DEFAULT_PARAMETER_FILE)
    path = tmp_path / "deep.toml"
    path.write_text(NESTED["inline tables"])
    with pytest.raises(ValueError, match="nested deeper"):
        HuskyParameters.from_toml(path)


# ---------------------------------------------------------------------------------------
# In code: the same limits


def test_scenario_from_dict_with_a_huge_integer_names_it():
    data = {
        "name": "t",
        "duration_s": 10**400,
        "robot": {"start": [0, 0]},
        "target": {"position": [1, 1]},
    }
    with pytest.raises(ScenarioError, match="duration_s = <an integer of 1329 bits>: is too large"):
        scenario_from_dict(data)


def test_fuzzy_system_built_in_code_with_tiny_sigma_evaluates():
    x = Variable("x", (0.0, 1.0), (Term("a", "gaussmf", (1e-200, 0.5)),))
    y = Variable("y", (0.0, 1.0), (Term("b", "trimf", (0.0, 0.5, 1.0)),))
    system = FuzzySystem([x], [y], [Rule((0,), (0,))])
    assert system.evaluate_one([0.25]).tolist() == [0.5]  # no rule fires: mid-range
