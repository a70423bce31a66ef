"""A study's rows: the identity of a row, and the check of a row read back.

Every row a study writes (:func:`.studies.run_layout_row`) is keyed by :func:`row_key`,
the key of the job that made it (:meth:`.studies.LayoutJob.key`). A row read back from a
results file (``--resume``, :class:`.resultlog.ResultLog`) is checked by :func:`check_row`
before it is trusted, and a row of another study is refused naming it
(:func:`describe_row`).
"""

from __future__ import annotations

import json
import math

#: The largest number of layouts one sweep (or compare's sweep, per controller) runs:
#: 100,000 runs are hours on a machine and a few hundred MB of rows; past it a typing
#: slip (``--n 100000000``) would build gigabytes of jobs before the first run.
MAX_LAYOUTS = 100_000


def row_key(row: dict) -> tuple:
    """The identity of a row (:meth:`.studies.LayoutJob.key` of the job that made it)."""
    return (
        row["controller"],
        tuple(row["parts_off"]),
        row["family"],
        row["seed"],
        row["perception"],
        json.dumps(row.get("options", {}), sort_keys=True),
        row["fingerprint"],
        row["index"],
    )


_ROW_NUMBERS = (
    "path_length_m",
    "straight_line_m",
    "straight_ratio",
    "min_clearance_m",
    "min_safety_distance_m",
    "time_to_target_s",
    "shortest_path_m",
    "path_ratio",
    "optimal_time_s",
    "time_ratio",
    "score",
)


def check_row(row: dict) -> None:
    """Raise ValueError naming the field and its value unless ``row`` is a row as
    :func:`.studies.run_layout_row` writes it: every field there, of its type and in its range,
    and consistent (success = reached without collision). What ``--resume`` reads
    back is checked with it before it is trusted."""
    from fuzzynav.resources import shown
    from fuzzynav.world.run_limits import OUTCOMES
    from fuzzynav.world.scenario_format import MAX_OBSTACLES

    def bad(name, why):
        return ValueError(f"{name} = {shown(row.get(name))}: {why}")

    def integer(name, low, high):
        value = row[name]
        if isinstance(value, bool) or not isinstance(value, int) or not low <= value <= high:
            raise bad(name, f"must be an integer from {low} to {high}")

    def text(name):
        value = row[name]
        if not isinstance(value, str) or not 0 < len(value) <= 200:
            raise bad(name, "must be a name (a string of 1 to 200 characters)")

    for name in ("index", "controller", "parts_off", "family", "seed", "perception"):
        if name not in row:
            raise ValueError(f"{name} missing")
    integer("index", 0, MAX_LAYOUTS - 1)
    integer("seed", 0, 2**63 - 1)
    for name in ("controller", "family", "perception"):
        text(name)
    if "scenario" in row:  # rows before the scenario's name was written have none
        text("scenario")
    parts = row["parts_off"]
    if not isinstance(parts, list) or not all(isinstance(p, str) for p in parts):
        raise bad("parts_off", "must be a list of part names")
    if "options" in row and not (
        isinstance(row["options"], dict)
        and all(isinstance(v, str | int | float | bool) for v in row["options"].values())
    ):
        raise bad("options", "must be an object of option names and plain values")
    fingerprint = row.get("fingerprint")
    if not (isinstance(fingerprint, str) and len(fingerprint) == 16):
        raise bad(
            "fingerprint",
            "missing or malformed: written by another fuzzynav version",
        )
    for name in ("outcome", "reached", "collided", "success", "n_obstacles", *_ROW_NUMBERS):
        if name not in row:
            raise ValueError(f"{name} missing")
    if row["outcome"] not in OUTCOMES:
        raise bad("outcome", f"must be one of {', '.join(OUTCOMES)}")
    for name in ("reached", "collided", "success"):
        if not isinstance(row[name], bool):
            raise bad(name, "must be true or false")
    if row["success"] != (row["reached"] and not row["collided"]):
        raise bad("success", "must be reached and not collided")
    if (row["outcome"] == "reached") != row["reached"]:
        raise bad("reached", f"does not match outcome {row['outcome']!r}")
    if row["outcome"] == "collided" and not row["collided"]:
        raise bad("collided", "does not match outcome 'collided'")
    integer("n_obstacles", 0, MAX_OBSTACLES)
    for name in _ROW_NUMBERS:
        value = row[name]
        if value is None:
            continue
        if (
            isinstance(value, bool)
            or not isinstance(value, int | float)
            or not math.isfinite(value)
        ):
            raise bad(name, "must be a finite number or null")
    if row["straight_line_m"] is None or row["straight_line_m"] <= 0:
        raise bad("straight_line_m", "must be a distance > 0")
    for name in ("path_length_m", "shortest_path_m", "optimal_time_s", "time_to_target_s"):
        if row[name] is not None and row[name] < 0:
            raise bad(name, "must be >= 0")
    if row["score"] is not None and not 0 <= row["score"] <= 1:
        raise bad("score", "must be from 0 to 1")


def describe_row(row: dict) -> str:
    """What a row of a results file is, for a refusal: its study's options, and whether
    it is the fingerprint alone that differs."""
    return ", ".join(
        f"{name} {row.get(name)!r}"
        for name in ("controller", "family", "seed", "perception", "index", "fingerprint")
        if name in row
    )
