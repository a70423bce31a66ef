"""Lesson files: a lesson saved from the page and opened again, from the page
(**Lesson → Open lesson**) or at start (``fuzzynav serve --lesson FILE``).

A lesson is a JSON file holding:

- the scenario as loaded (its TOML text) and the layout as edited on it (drags, added
  and removed obstacles, the target), so that *layout edited* and **Restore** hold;
- the controller by name, or its rule base (TOML text) when it was edited in the Editor
  (shapes and inference choices) or uploaded;
- the settings: perception, geometry, disturbance, sensor noise, fuzzynav's parts,
  speed, seed;
- the view: presentation mode, *Firing rules only*;
- the time: the run is replayed from the start to that time with the same seed (drags
  made during the run are not replayed: the layout is the one saved), and left paused.

Everything read from a lesson is checked as an upload is: the size, the scenario by
:func:`world.scenario.loads_scenario`, the rule base by
:func:`controller.rulebase.loads_toml`, each setting by the viewer's own setter. A bad
file raises :class:`ViewerError` naming what is wrong, and the world is left as it was
whenever the file is refused before anything is applied.
"""

from __future__ import annotations

import json
import math

from fuzzynav.app.viewer.state import MAX_UPLOAD_BYTES, ViewerError

LESSON_KEY = "fuzzynav_lesson"
LESSON_VERSION = 1
MAX_REPLAY_S = 3600.0


def dumps_lesson(app, view: dict | None = None) -> str:
    """The lesson of ``app`` as it is now (JSON text)."""
    from fuzzynav.controller.rulebase import dumps_toml

    with app.lock:
        s = app.settings()
        data = {
            LESSON_KEY: LESSON_VERSION,
            "scenario_label": s["scenario_label"],
            "scenario_toml": app.base_scenario.to_toml(),
            "layout_toml": s["scenario"].to_toml(),
            "controller": s["controller"],
            "rule_base_toml": dumps_toml(s["fis"]) if s["fis"] is not None else None,
            "perception": s["perception"],
            "geometry": s["geometry"],
            "disturbance_on": bool(s["disturbance_on"]),
            "noise_std_m": float(s["noise_std_m"]),
            "parts_off": list(s["parts_off"]),
            "speed": float(s["speed"]),
            "seed": app.seed,
            "time_s": round(float(app.sim.time_s), 6),
            "view": dict(view or {}),
        }
    return json.dumps(data, indent=2) + "\n"


def _field(data: dict, key: str, kind, source: str):
    value = data.get(key)
    if not isinstance(value, kind) or isinstance(value, bool) and kind is not bool:
        raise ViewerError(f"{source}: {key} = {value!r}: not a {getattr(kind, '__name__', kind)}")
    return value


def read_lesson(content: bytes | str, source: str = "lesson.json") -> dict:
    """The checked settings of a lesson file (nothing applied yet)."""
    from fuzzynav.controller.rulebase import loads_toml
    from fuzzynav.world.scenario import ScenarioError, loads_scenario

    raw = content.encode() if isinstance(content, str) else bytes(content)
    if len(raw) > MAX_UPLOAD_BYTES:
        raise ViewerError(f"{source}: {len(raw)} bytes is too large for a lesson file")
    try:
        data = json.loads(raw.decode("utf-8"))
    except (UnicodeDecodeError, ValueError) as exc:
        raise ViewerError(f"{source}: not a lesson file (JSON): {exc}") from None
    if not isinstance(data, dict) or data.get(LESSON_KEY) != LESSON_VERSION:
        raise ViewerError(
            f"{source}: not a fuzzynav lesson (no {LESSON_KEY} = {LESSON_VERSION}); save one "
            "from the page's Lesson folder"
        )
    label = _field(data, "scenario_label", str, source)
    try:
        base = loads_scenario(_field(data, "scenario_toml", str, source), f"{source}: scenario")
        layout = loads_scenario(_field(data, "layout_toml", str, source), f"{source}: layout")
    except ScenarioError as exc:
        raise ViewerError(str(exc)) from None
    fis_text = data.get("rule_base_toml")
    fis = None
    if fis_text is not None:
        try:
            fis = loads_toml(_field(data, "rule_base_toml", str, source), f"{source}: rule base")
        except ValueError as exc:
            raise ViewerError(str(exc)) from None
    parts_off = _field(data, "parts_off", list, source)
    if not all(isinstance(p, str) for p in parts_off):
        raise ViewerError(f"{source}: parts_off = {parts_off!r}: not a list of part names")
    time_s = float(_field(data, "time_s", (int, float), source))
    if not (math.isfinite(time_s) and 0.0 <= time_s <= min(MAX_REPLAY_S, layout.duration_s)):
        raise ViewerError(f"{source}: time_s = {time_s!r}: must be within the run")
    seed = data.get("seed")
    if seed is not None and (isinstance(seed, bool) or not isinstance(seed, int)):
        raise ViewerError(f"{source}: seed = {seed!r}: not an integer")
    view = data.get("view") or {}
    if not isinstance(view, dict):
        raise ViewerError(f"{source}: view = {view!r}: not a table")
    return {
        "scenario_label": label,
        "base_scenario": base,
        "scenario": layout,
        "controller": _field(data, "controller", str, source),
        "fis": fis,
        "perception": _field(data, "perception", str, source),
        "geometry": _field(data, "geometry", str, source),
        "disturbance_on": _field(data, "disturbance_on", bool, source),
        "noise_std_m": float(_field(data, "noise_std_m", (int, float), source)),
        "parts_off": tuple(parts_off),
        "speed": float(_field(data, "speed", (int, float), source)),
        "seed": seed,
        "time_s": time_s,
        "view": {k: bool(view[k]) for k in ("presentation", "firing_only") if k in view},
    }


def open_lesson(app, content: bytes | str, source: str = "lesson.json") -> dict:
    """Open a lesson in ``app``: its scenario, layout, controller and settings, the run
    replayed to its time and paused. Returns its view (for the page to apply)."""
    lesson = read_lesson(content, source)
    from fuzzynav.app.viewer.starter import STARTER_LABEL
    from fuzzynav.controller.registry import controller_names

    known = set(controller_names()) | {STARTER_LABEL}
    if lesson["fis"] is None and lesson["controller"] not in known:
        raise ViewerError(
            f"{source}: controller {lesson['controller']!r} is not available here "
            f"(available: {', '.join(sorted(known))})"
        )
    app.seed = lesson["seed"]
    app.apply_settings(lesson)
    with app.lock:
        app.driver._reset_locked(app.editing._layout_scenario())  # the seed, from the start
        while app.sim.time_s + 0.5 * app.sim.control_period_s < lesson["time_s"]:
            if app.sim.done:
                break
            app.driver._step_locked()
        app.playing = False
        app._notice(f"Opened the lesson {source} at t = {app.sim.time_s:.2f} s.", "info")
    return lesson["view"]
