"""The scenario file's format: its keys, its bounds, how its values are read and written.

:data:`FORMAT` lists each table's keys in a file's order with the :class:`Scenario
<world.scenario.Scenario>` field each holds; :data:`OMITTED_DEFAULTS` the keys a file may
leave out. :func:`dumps_plain` writes a scenario's plain data as TOML
(:meth:`world.scenario.Scenario.to_toml`). The bounds (:data:`MAX_COORDINATE_M`, ...)
say what a file may hold, and ``_Reader`` reads its values, each checked, raising
:class:`ScenarioError` with the file, the key and the value. :mod:`world.scenario` builds
the scenario from them (the format is described in its docstring).
"""

from __future__ import annotations

import math
from dataclasses import fields
from typing import Any

import tomli_w

from fuzzynav.resources import escape_controls, shown


class ScenarioError(ValueError):
    """A scenario that cannot be used, with the file, key and value that make it so."""

    def __init__(self, source: str, key: str, value: Any, reason: str):
        self.source, self.key, self.value, self.reason = source, key, value, reason
        super().__init__(f"{escape_controls(str(source))}: {key} = {shown(value)}: {reason}")


class ScenarioNotFoundError(ScenarioError, FileNotFoundError):
    """A scenario name or file that does not exist: a :class:`ScenarioError` (so a
    ``ValueError``) and a ``FileNotFoundError``, as either is caught."""


#: The scenario file's format, written once: each table (None: the top level) and its
#: keys in the order a file has them, each with the :class:`Scenario` field it holds. The
#: ``[[obstacles]]`` and the ``[disturbance]`` tables hold the fields of
#: :class:`ObstacleSpec` and :class:`Disturbance` under their own names. The writer
#: walks it; the keys the reader allows come from it.
FORMAT: tuple[tuple[str | None, tuple[tuple[str, str], ...]], ...] = (
    (None, (("name", "name"), ("description", "description"), ("duration_s", "duration_s"))),
    (
        "robot",
        (
            ("start", "start"),
            ("heading_rad", "heading_rad"),
            ("field_of_view_deg", "field_of_view_deg"),
        ),
    ),
    ("target", (("position", "target"), ("tolerance_m", "tolerance_m"))),
)
#: Keys a file may leave out, with the value that means (the writer leaves them out too).
OMITTED_DEFAULTS: dict[str, Any] = {"description": "", "field_of_view_deg": 360.0}


def _plain(value):
    """A field's value as TOML's plain data: a pair (a tuple) as a list."""
    return list(value) if isinstance(value, tuple) else value


def _fields_of(item) -> dict:
    """A dataclass's fields as plain data, in their order, under their own names."""
    return {f.name: _plain(getattr(item, f.name)) for f in fields(item)}


def _toml_value(value) -> str:
    """One value as TOML: a list of numbers inline (``[x, y]``, each a float), anything
    else as tomli-w writes it."""
    if isinstance(value, list):
        return "[" + ", ".join(_toml_value(float(v)) for v in value) + "]"
    return tomli_w.dumps({"v": value})[len("v = ") : -1]


def dumps_plain(data: dict) -> str:
    """Plain data (tables of values, arrays of tables) as TOML, top-level values first,
    then each table in order, a blank line before each (what :meth:`Scenario.to_toml`
    writes).

    Parameters
    ----------
    data : dict
        Keys to numbers, strings, lists of numbers, tables (dicts) of those, or
        non-empty lists of such tables (written as ``[[key]]``).

    Returns
    -------
    str
        The TOML text, ending with a newline.
    """

    def is_tables(value) -> bool:
        return isinstance(value, list) and any(isinstance(v, dict) for v in value)

    lines = [
        f"{key} = {_toml_value(value)}"
        for key, value in data.items()
        if not isinstance(value, dict) and not is_tables(value)
    ]
    for key, value in data.items():
        if isinstance(value, dict):
            lines += ["", f"[{key}]"] + [f"{k} = {_toml_value(v)}" for k, v in value.items()]
        elif is_tables(value):
            for table in value:
                lines += ["", f"[[{key}]]"]
                lines += [f"{k} = {_toml_value(v)}" for k, v in table.items()]
    return "\n".join(lines) + "\n"


# ---------------------------------------------------------------------------------------
# Reading: the bounds of a value and the checked reader


#: Bounds on what a scenario file may hold, far beyond any sensible arena, but inside
#: what the physics and the controllers compute without overflow (a target 1e300 m away
#: overflowed in the controller; an obstacle of radius 1e300 m "collided" at a clearance
#: of 4e299 m).
MAX_COORDINATE_M = 10_000.0
MAX_RADIUS_M = 1_000.0
MAX_SPEED_MPS = 100.0
MAX_ACCELERATION_MPS2 = 100.0
MAX_DISTURBANCE = 1_000.0
#: The longest run a scenario file may ask for: a run's log grows with its length (an
#: hour at the default 20 ms period is 180,000 rows, about 52 MB, most of it spooled
#: to the disk: world.sim_log.LOG_BLOCK_BYTES).
MAX_DURATION_S = 3600.0
#: The most obstacles a scenario may hold: far more than any layout here (at most 20),
#: and few enough that validating (a k-d tree) and running stay quick.
MAX_OBSTACLES = 1000
#: The largest integer a number key takes as written (beyond it a float loses the
#: integer anyway; Python cannot even print an integer of more than 4300 digits).
_MAX_EXACT_INT = 2**63
_FORMAT_KEYS = {table: {key for key, _ in keys} for table, keys in FORMAT}
_TOP_KEYS = _FORMAT_KEYS[None] | {"robot", "target", "obstacles", "disturbance"}
_ROBOT_KEYS = _FORMAT_KEYS["robot"]
_TARGET_KEYS = _FORMAT_KEYS["target"]


class _Reader:
    """Reads typed values out of nested tables, raising ScenarioError with full key paths."""

    def __init__(self, source: str):
        self.source = source

    def fail(self, key: str, value: Any, reason: str):
        raise ScenarioError(self.source, key, value, reason)

    def table(self, data: Any, key: str, allowed: set[str], required: set[str]) -> dict:
        if not isinstance(data, dict):
            self.fail(key, data, "must be a table")
        for k in data:
            if k not in allowed:
                full = f"{key}.{k}" if key else k
                self.fail(full, data[k], f"unknown key (allowed: {', '.join(sorted(allowed))})")
        for k in sorted(required):
            if k not in data:
                full = f"{key}.{k}" if key else k
                self.fail(full, None, "missing required key")
        return data

    def number(
        self,
        value: Any,
        key: str,
        *,
        positive: bool = False,
        non_negative: bool = False,
        limit: float | None = None,
        unit: str = "",
    ) -> float:
        """A finite number; with ``limit``, at most that in magnitude."""
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            self.fail(key, value, "must be a number")
        if isinstance(value, int) and abs(value) > _MAX_EXACT_INT:
            self.fail(key, value, f"is too large (at most {_MAX_EXACT_INT:.3g} in magnitude)")
        value = float(value)
        if not math.isfinite(value):
            self.fail(key, value, "must be finite (NaN and inf are not allowed)")
        if positive and value <= 0:
            self.fail(key, value, "must be positive")
        if non_negative and value < 0:
            self.fail(key, value, "must not be negative")
        if limit is not None and abs(value) > limit:
            self.fail(key, value, f"must be within +-{limit:g}{unit}")
        return value

    def point(
        self, value: Any, key: str, limit: float = MAX_COORDINATE_M, unit: str = " m"
    ) -> tuple[float, float]:
        if not isinstance(value, list) or len(value) != 2:
            self.fail(key, value, "must be a list of two numbers [x, y]")
        return (
            self.number(value[0], f"{key}[0]", limit=limit, unit=unit),
            self.number(value[1], f"{key}[1]", limit=limit, unit=unit),
        )

    def string(self, value: Any, key: str, keep: str = "") -> str:
        """A string, with control characters (but those in ``keep``) written as visible
        escapes: a name is printed in tables and titles, and ESC or NUL must not drive
        the terminal."""
        if not isinstance(value, str):
            self.fail(key, value, "must be a string")
        return escape_controls(value, keep)
