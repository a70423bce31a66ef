"""fuzzynav's parts and how each is switched off (``assets/rules/fuzzynav_parts.toml``).

A part (the echo memory, the bearing planner, edge following, ...) is switched off by
setting one or more of fuzzynav's crisp parameters to a value that leaves it nothing to
do (``memory_s = 0``: echoes are forgotten at once). The viewer's checkboxes,
``fuzzynav run --off PART`` and the ablation study (``scripts/fuzzynav_ablation.py``: what
each part buys) all use this file, so that they switch the same things.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

from fuzzynav.controller.fuzzynav_params import CRISP_DEFAULTS, RULES_DIR

PARTS_PATH = RULES_DIR / "fuzzynav_parts.toml"
_KEYS = ("name", "what", "item", "off")


@dataclass(frozen=True)
class Part:
    """One part: its name, what switching it off does, the design item that describes it
    (docs/fuzzynav.md), and the crisp parameter values that switch it off."""

    name: str
    what: str
    item: int
    off: dict


def load_parts(path: str | Path = PARTS_PATH) -> tuple[Part, ...]:
    """The parts in ``path``, checked: known keys only, names unique and non-empty, every
    ``off`` key a crisp parameter with a finite number, no parameter in two parts (so
    that switching one part back on cannot switch another back on). A bad file raises
    ``ValueError`` naming the file, the key and the value."""
    path = Path(path)
    from fuzzynav.resources import loads_user_toml, read_user_text

    data = loads_user_toml(read_user_text(path, "parts file"), str(path))
    unknown = sorted(set(data) - {"part"})
    if unknown:
        raise ValueError(f"{path}: unknown key(s) {unknown} (allowed: part)")
    entries = data.get("part")
    if not isinstance(entries, list) or not entries:
        raise ValueError(f"{path}: needs at least one [[part]] table")
    parts: list = []
    owner: dict = {}
    for k, entry in enumerate(entries):
        where = f"{path}: part[{k}]"
        extra = sorted(set(entry) - set(_KEYS))
        if extra:
            raise ValueError(f"{where}: unknown key(s) {extra} (allowed: {', '.join(_KEYS)})")
        missing = [key for key in _KEYS if key not in entry]
        if missing:
            raise ValueError(f"{where}: missing key(s) {missing}")
        name, off = entry["name"], entry["off"]
        if not isinstance(name, str) or not name.strip() or any(p.name == name for p in parts):
            raise ValueError(f"{where}.name = {name!r}: must be a new, non-empty string")
        if not isinstance(entry["what"], str):
            raise ValueError(f"{where}.what = {entry['what']!r}: must be a string")
        if isinstance(entry["item"], bool) or not isinstance(entry["item"], int):
            raise ValueError(f"{where}.item = {entry['item']!r}: must be an integer")
        if not isinstance(off, dict) or not off:
            raise ValueError(f"{where}.off = {off!r}: must be a table of crisp parameters")
        for key, value in off.items():
            if key not in CRISP_DEFAULTS:
                raise ValueError(
                    f"{where}.off.{key} = {value!r}: not a crisp parameter of fuzzynav"
                )
            if (
                isinstance(value, bool)
                or not isinstance(value, (int, float))
                or not math.isfinite(value)
            ):
                raise ValueError(f"{where}.off.{key} = {value!r}: must be a finite number")
            if key in owner:
                raise ValueError(
                    f"{where}.off.{key} = {value!r}: already switched by part {owner[key]!r}"
                )
            owner[key] = name
        parts.append(
            Part(
                name,
                entry["what"],
                entry["item"],
                {key: float(value) for key, value in off.items()},
            )
        )
    return tuple(parts)
