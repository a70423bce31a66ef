"""Lesson files: a lesson saved from the page and opened again, from the page
(**Lesson → Open lesson**) or at start (``fuzzynav serve --lesson FILE``).

A lesson is a JSON file holding:

- the scenario as loaded (its TOML text) and the layout as edited on it (drags, added
  and removed obstacles, the target), so that *layout edited* and **Restore** hold;
- the controller by name, or its rule base (TOML text) when it was edited in the Editor
  (shapes, inference choices, rules) or uploaded;
- the Editor: each system it edited (the paper controller, the starter), its rule base
  and the layout's numbers its sliders showed;
- the settings: perception, geometry, disturbance, sensor noise, fuzzynav's parts,
  speed, seed;
- the view: presentation mode, *Firing rules only*;
- the time, and the run's timeline: what drove it from which control step (every switch
  of controller, every edit, every change of perception, disturbance, noise or parts);
- the inputs the controller read at that time, and what the run did that cannot be
  replayed (a drag during the run).

Opening replays the run from the start with the same seed, each change of the timeline
at its step, to the saved time, and leaves it paused; the inputs reached are compared
with the saved ones, and a difference (a drag during the run, a run without a seed) is
said in a warning. The replay runs on a thread of its own, a few hundred steps at a
time, so a server opening a long lesson serves at once (and every classroom tab replays
on its own thread); a press that changes the run meanwhile stops it.

Everything read from a lesson is checked before anything is applied: the size, the
scenario by :func:`world.scenario.loads_scenario`, each rule base by
:func:`controller.rulebase.loads_toml` and as a controller, each setting against what
the viewer's setters accept (names, ranges, the geometry and perception together, the
seed). A bad file raises :class:`ViewerError` naming the file, key and value, and the
world is left exactly as it was.
"""

from __future__ import annotations

import json
import math
import threading

from fuzzynav.app.viewer.state import MAX_UPLOAD_BYTES, NOISE_RANGE_M, SPEED_RANGE, ViewerError

LESSON_KEY = "fuzzynav_lesson"
LESSON_VERSION = 1
MAX_REPLAY_S = 3600.0
MAX_TIMELINE = 10_000  # changes of what drives, in one run
MAX_NOTE_CHARS = 1000  # the teacher's note
REPLAY_CHUNK_STEPS = 250  # steps replayed per hold of the world's lock
INPUTS_MATCH = 1e-6  # the replay reached the saved moment: d_t and phi_t within this
# What drives, as a lesson and each entry of its timeline hold it.
SETTING_KEYS = ("controller", "fis", "perception", "disturbance_on", "noise_std_m", "parts_off")
MAX_LABEL_CHARS = 200  # the scenario's label, as a rule base's name
MAX_UNREPLAYED = 20  # what the run did that a replay cannot make, as said when it opens
VIEW_KEYS = ("presentation", "firing_only")
# The keys a lesson file and each entry of its timeline may hold (``rule_base_toml``: an
# older lesson's rule base); any other is refused, naming it (a misspelt key was ignored).
ENTRY_KEYS = ("step", "controller", "rule_base", "rule_base_toml", "perception",
              "disturbance_on", "noise_std_m", "parts_off")  # fmt: skip
EDITOR_KEYS = ("rule_base", "rule_base_toml", "numbers")  # an entry of ``editors``
LESSON_KEYS = (LESSON_KEY, "scenario_label", "scenario_toml", "layout_toml", "controller",
               "rule_base", "rule_base_toml", "rule_bases", "perception", "geometry",
               "disturbance_on", "noise_std_m", "parts_off", "speed", "seed", "time_s",
               "view", "inputs", "unreplayed", "note", "timeline", "editors")  # fmt: skip


def dumps_lesson(app, view: dict | None = None) -> str:
    """The lesson of ``app`` as it is now (JSON text). Each rule base is written once
    (``rule_bases``) and named by its index; when the run's earlier rule bases would
    take the file past :data:`~.state.MAX_UPLOAD_BYTES`, the timeline is left out and
    the lesson says so (opened, it warns where its replay differs)."""
    with app.lock:
        s = app.settings()
        bases: list = []
        data = {
            LESSON_KEY: LESSON_VERSION,
            "scenario_label": s["scenario_label"],
            "scenario_toml": app.base_scenario.to_toml(),
            "layout_toml": s["scenario"].to_toml(),
            "controller": s["controller"],
            "rule_base": _base_index(bases, s["fis"]),
            "editors": _editors_json(app, bases),
            "perception": s["perception"],
            "geometry": s["geometry"],
            "disturbance_on": bool(s["disturbance_on"]),
            "noise_std_m": float(s["noise_std_m"]),
            "parts_off": list(s["parts_off"]),
            "speed": float(s["speed"]),
            "seed": app.seed,
            "time_s": round(float(app.sim.time_s), 6),
            "view": dict(view or {}),
            "inputs": [
                None if not math.isfinite(v) else float(v) for v in app.controller.last_inputs
            ],
            "unreplayed": list(app._unreplayed),
            "note": app.note,
        }
        final = list(bases)
        data["timeline"] = [_entry_json(entry, bases) for entry in app._timeline]
    data["rule_bases"] = [_toml(fis) for fis in bases]
    text = json.dumps(data, indent=2) + "\n"
    if len(text.encode()) > MAX_UPLOAD_BYTES and len(bases) > len(final):
        data["rule_bases"] = [_toml(fis) for fis in final]
        data["timeline"] = None
        data["unreplayed"].append("the run's earlier rule bases (too large to keep)")
        text = json.dumps(data, indent=2) + "\n"
    return text


def _editors_json(app, bases: list) -> dict:
    """Each system the Editor edited: its rule base (an index) and its sliders' numbers."""
    return {
        kind: {"rule_base": _base_index(bases, fis), "numbers": numbers}
        for kind, (fis, numbers) in editor_states(app).items()
    }


def editor_states(app) -> dict:
    """Each system ``app``'s Editor edited (``paper``, ``starter``): (its rule base, its
    sliders' numbers), as a lesson keeps them and a teacher pushes them."""
    return {
        kind: (editor.controller().fis, editor.numbers())
        for kind, editor in (("paper", app.paper_edit), ("starter", app.starter_edit))
        if editor is not None and editor.edited
    }


def fresh_editors(states: dict, geometry: str) -> dict:
    """An editor of its own for each system of ``states`` (:func:`editor_states`),
    holding exactly that edit: its rule base, and its sliders at the numbers (None: an
    older lesson's edit, the sliders at the shipped numbers). ValueError naming the
    system when an edit is not that system's or its numbers not the layout's."""
    from fuzzynav.app.viewer.editor import PaperEditor, StarterEditor

    makers = {"paper": PaperEditor, "starter": StarterEditor}
    out = {}
    for kind, (fis, numbers) in states.items():
        editor = makers[kind](geometry)
        try:
            if numbers is None:
                editor.adopt(fis)
            else:
                editor.restore(fis, numbers)
        except ValueError as exc:
            raise ValueError(f"editors.{kind}: {exc}") from None
        out[kind] = editor
    return out


def install_editors_locked(app, editors: dict) -> None:
    """The Editor holds ``editors`` (kind: editor, :func:`fresh_editors`); a system not
    among them starts afresh (the page's views follow the editors)."""
    app.paper_edit = editors.get("paper")
    app.starter_edit = editors.get("starter")


def _toml(fis) -> str:
    from fuzzynav.controller.rulebase import dumps_toml

    return dumps_toml(fis)


def _base_index(bases: list, fis) -> int | None:
    """``fis``'s index in ``bases`` (added when new); None for a named controller."""
    if fis is None:
        return None
    for k, known in enumerate(bases):
        if known is fis or known == fis:
            return k
    bases.append(fis)
    return len(bases) - 1


def _entry_json(entry: dict, bases: list) -> dict:
    return {
        "step": int(entry["step"]),
        "controller": entry["controller"],
        "rule_base": _base_index(bases, entry["fis"]),
        "perception": entry["perception"],
        "disturbance_on": bool(entry["disturbance_on"]),
        "noise_std_m": float(entry["noise_std_m"]),
        "parts_off": list(entry["parts_off"]),
    }


def _field(data: dict, key: str, kind, source: str):
    value = data.get(key)
    if not isinstance(value, kind) or isinstance(value, bool) and kind is not bool:
        raise ViewerError(f"{source}: {key} = {value!r}: not a {getattr(kind, '__name__', kind)}")
    return value


def _number(data: dict, key: str, source: str) -> float:
    """``data[key]``, a JSON number, as a float (an integer of 400 digits is refused by
    name, not left to overflow)."""
    value = _field(data, key, (int, float), source)
    try:
        return float(value)
    except OverflowError:
        raise ViewerError(
            f"{source}: {key} = <an integer of {value.bit_length()} bits>: too large"
        ) from None


def _known_keys(data: dict, known: tuple[str, ...], where: str) -> None:
    """ViewerError naming a key ``data`` may not hold (a misspelt one was ignored)."""
    from fuzzynav.resources import escape_controls, shorten

    unknown = [k for k in data if k not in known]
    if unknown:
        shown = ", ".join(escape_controls(shorten(repr(k), 60)) for k in unknown[:5])
        raise ViewerError(f"{where}: unknown key(s) {shown} (a lesson holds: {', '.join(known)})")


def _rule_bases(data: dict, source: str) -> list:
    """The lesson's rule bases (TOML texts), each read and built as a controller, so
    that one the engine cannot drive is refused before anything is applied."""
    from fuzzynav.controller.fis_controller import FisController
    from fuzzynav.controller.rulebase import loads_toml

    raw = data.get("rule_bases") or []
    if not isinstance(raw, list):
        raise ViewerError(f"{source}: rule_bases = {raw!r}: not a list of rule bases")
    out = []
    for k, text in enumerate(raw):
        key = f"rule_bases[{k}]"
        try:
            fis = loads_toml(_field({key: text}, key, str, source), f"{source}: {key}")
            FisController(fis)
        except ValueError as exc:
            raise ViewerError(f"{source}: {key}: {exc}") from None
        out.append(fis)
    return out


def _rule_base(data: dict, source: str, bases: list):
    """The rule base a lesson (or a timeline entry) drives with: ``rule_base``, an
    index into ``rule_bases``, or (an older lesson) its own ``rule_base_toml``; None
    for a named controller."""
    if data.get("rule_base_toml") is not None:
        return _rule_bases({"rule_bases": [data["rule_base_toml"]]}, source)[0]
    index = data.get("rule_base")
    if index is None:
        return None
    if isinstance(index, bool) or not isinstance(index, int) or not 0 <= index < len(bases):
        raise ViewerError(
            f"{source}: rule_base = {index!r}: not an index of rule_bases (0 to {len(bases) - 1})"
        )
    return bases[index]


def _settings_of(data: dict, source: str, geometry: str, bases: list) -> dict:
    """One set of what drives (the lesson's own, or a timeline entry's), checked."""
    from fuzzynav.app.viewer.starter import STARTER_LABEL
    from fuzzynav.controller.navigator.parts import load_parts
    from fuzzynav.controller.registry import controller_names
    from fuzzynav.world.perception import PERCEPTION_MODES

    fis = _rule_base(data, source, bases)
    controller = _field(data, "controller", str, source)
    known = set(controller_names()) | {STARTER_LABEL}
    if fis is None and controller not in known:
        raise ViewerError(
            f"{source}: controller = {controller!r}: not available here "
            f"(available: {', '.join(sorted(known))})"
        )
    perception = _field(data, "perception", str, source)
    if perception not in PERCEPTION_MODES:
        raise ViewerError(
            f"{source}: perception = {perception!r}: choose one of {', '.join(PERCEPTION_MODES)}"
        )
    if geometry == "paper" and perception != "ideal":
        raise ViewerError(
            f"{source}: perception = {perception!r} with geometry = 'paper': the paper's "
            "point robot takes ideal perception only"
        )
    noise = _number(data, "noise_std_m", source)
    if not (math.isfinite(noise) and NOISE_RANGE_M[0] <= noise <= NOISE_RANGE_M[1]):
        raise ViewerError(
            f"{source}: noise_std_m = {noise!r}: must be between {NOISE_RANGE_M[0]} and "
            f"{NOISE_RANGE_M[1]} m"
        )
    parts_off = _field(data, "parts_off", list, source)
    known_parts = [p.name for p in load_parts()]
    if not all(isinstance(p, str) and p in known_parts for p in parts_off):
        raise ViewerError(
            f"{source}: parts_off = {parts_off!r}: not a list of fuzzynav's parts "
            f"({', '.join(known_parts)})"
        )
    return {
        "controller": controller,
        "fis": fis,
        "perception": perception,
        "disturbance_on": _field(data, "disturbance_on", bool, source),
        "noise_std_m": noise,
        "parts_off": tuple(parts_off),
    }


def _timeline(data: dict, source: str, geometry: str, time_s: float, period_s: float, bases):
    """The run's timeline (a list of settings from a control step), checked; a lesson
    without one replays with its own settings from the start."""
    raw = data.get("timeline")
    if raw is None:
        return None
    if not isinstance(raw, list) or not raw or len(raw) > MAX_TIMELINE:
        raise ViewerError(
            f"{source}: timeline: not a list of 1 to {MAX_TIMELINE} entries ({type(raw).__name__})"
        )
    out, last = [], -1
    last_step = int(round(time_s / period_s))
    for k, entry in enumerate(raw):
        where = f"{source}: timeline[{k}]"
        if not isinstance(entry, dict):
            raise ViewerError(f"{where}: {entry!r}: not a table")
        _known_keys(entry, ENTRY_KEYS, where)
        step = _field(entry, "step", int, where)
        if not (last < step <= last_step) or (k == 0 and step != 0):
            raise ViewerError(
                f"{where}: step = {step!r}: must grow from 0 and stay within the run "
                f"(to step {last_step})"
            )
        last = step
        out.append({"step": step, **_settings_of(entry, where, geometry, bases)})
    return out


def _editors(data: dict, source: str, geometry: str, bases: list, entries: list) -> dict:
    """The Editor as the lesson left it (:func:`editor_states`' form): each system it
    edited (``paper``, ``starter``), its rule base and its sliders' numbers, checked by
    building its editor; a system not listed starts afresh. A lesson without
    ``editors`` (an older file) gives each editor the last edit of it that drove in
    ``entries`` (its sliders at the shipped numbers: that file kept no others)."""
    from fuzzynav.app.viewer.starter import STARTER_EDITED_LABEL
    from fuzzynav.app.viewer.state import EDITED_LABEL

    kinds = ("paper", "starter")
    raw = data.get("editors")
    if raw is None:
        by_label = {EDITED_LABEL: "paper", STARTER_EDITED_LABEL: "starter"}
        last = {by_label[e["controller"]]: e["fis"] for e in entries if e["controller"] in by_label}
        return {kind: (fis, None) for kind, fis in last.items() if fis is not None}
    if not isinstance(raw, dict) or not set(raw) <= set(kinds):
        raise ViewerError(
            f"{source}: editors = {sorted(raw) if isinstance(raw, dict) else raw!r}: not a "
            f"table of {' and '.join(kinds)}"
        )
    states = {}
    for kind, saved in raw.items():
        where = f"{source}: editors.{kind}"
        if not isinstance(saved, dict):
            raise ViewerError(f"{where}: {saved!r}: not a table")
        _known_keys(saved, EDITOR_KEYS, where)
        fis = _rule_base(saved, where, bases)
        if fis is None:
            raise ViewerError(f"{where}: rule_base = None: the edit's rule base is needed")
        numbers = saved.get("numbers")
        if not isinstance(numbers, dict):
            raise ViewerError(f"{where}: numbers = {numbers!r:.40}: not a table of numbers")
        states[kind] = (fis, numbers)
    try:
        fresh_editors(states, geometry)
    except ValueError as exc:
        raise ViewerError(f"{source}: {exc}") from None
    return states


def read_lesson(
    content: bytes | str, source: str = "lesson.json", control_period_s: float = 0.02
) -> dict:
    """The checked settings of a lesson file (nothing applied yet)."""
    from fuzzynav.resources import shorten
    from fuzzynav.world.perception import GEOMETRIES
    from fuzzynav.world.scenario import ScenarioError, loads_scenario
    from fuzzynav.world.simulation import check_run_size

    raw = content.encode() if isinstance(content, str) else bytes(content)
    if len(raw) > MAX_UPLOAD_BYTES:
        raise ViewerError(f"{source}: {len(raw)} bytes is too large for a lesson file")
    try:
        data = json.loads(raw.decode("utf-8"))
    except (UnicodeDecodeError, ValueError) as exc:
        raise ViewerError(f"{source}: not a lesson file (JSON): {exc}") from None
    except RecursionError:
        raise ViewerError(f"{source}: not a lesson file (JSON nested too deep)") from None
    if not isinstance(data, dict) or data.get(LESSON_KEY) != LESSON_VERSION:
        raise ViewerError(
            f"{source}: not a fuzzynav lesson (no {LESSON_KEY} = {LESSON_VERSION}); save one "
            "from the page's Lesson folder"
        )
    _known_keys(data, LESSON_KEYS, source)
    label = _label(data, source)
    try:
        base = loads_scenario(_field(data, "scenario_toml", str, source), f"{source}: scenario")
        layout = loads_scenario(_field(data, "layout_toml", str, source), f"{source}: layout")
        check_run_size(layout.duration_s, control_period_s, len(layout.obstacles))
    except ScenarioError as exc:
        raise ViewerError(str(exc)) from None
    except ValueError as exc:
        raise ViewerError(f"{source}: layout_toml: {exc}") from None
    geometry = _field(data, "geometry", str, source)
    if geometry not in GEOMETRIES:
        raise ViewerError(
            f"{source}: geometry = {geometry!r}: choose one of {', '.join(GEOMETRIES)}"
        )
    bases = _rule_bases(data, source)
    settings = _settings_of(data, source, geometry, bases)
    time_s = _number(data, "time_s", source)
    if not (math.isfinite(time_s) and 0.0 <= time_s <= min(MAX_REPLAY_S, layout.duration_s)):
        raise ViewerError(f"{source}: time_s = {time_s!r}: must be within the run")
    speed = _number(data, "speed", source)
    if not (math.isfinite(speed) and SPEED_RANGE[0] - 1e-9 <= speed <= SPEED_RANGE[1] + 1e-9):
        raise ViewerError(
            f"{source}: speed = {speed!r}: must be between {SPEED_RANGE[0]} and "
            f"{SPEED_RANGE[1]} times real time"
        )
    seed = data.get("seed")
    if seed is not None and (isinstance(seed, bool) or not isinstance(seed, int) or seed < 0):
        raise ViewerError(f"{source}: seed = {seed!r}: not an integer >= 0 (nor null)")
    note = data.get("note") or ""
    if not isinstance(note, str) or len(note) > MAX_NOTE_CHARS:
        raise ViewerError(
            f"{source}: note: not a text of at most {MAX_NOTE_CHARS} characters "
            f"({type(note).__name__}, {len(note) if isinstance(note, str) else '-'})"
        )
    view = data.get("view") or {}
    if not isinstance(view, dict) or not all(
        k in VIEW_KEYS and isinstance(v, bool) for k, v in view.items()
    ):
        raise ViewerError(
            f"{source}: view = {shorten(repr(view), 120)}: not a table of "
            f"{' and '.join(VIEW_KEYS)}, each true or false"
        )
    timeline = _timeline(data, source, geometry, time_s, control_period_s, bases)
    return {
        "scenario_label": label,
        "base_scenario": base,
        "scenario": layout,
        **settings,
        "geometry": geometry,
        "speed": speed,
        "seed": seed,
        "time_s": time_s,
        "timeline": timeline,
        "editors": _editors(data, source, geometry, bases, timeline or [settings]),
        "inputs": _saved_inputs(data, source),
        "unreplayed": _unreplayed(data, source),
        "note": note,
        "view": dict(view),
    }


def _label(data: dict, source: str) -> str:
    """The scenario's label as the page shows it: a text of at most
    :data:`MAX_LABEL_CHARS`, its control characters written as escapes."""
    from fuzzynav.resources import escape_controls

    label = _field(data, "scenario_label", str, source)
    if len(label) > MAX_LABEL_CHARS:
        raise ViewerError(
            f"{source}: scenario_label: a text of {len(label)} characters (at most "
            f"{MAX_LABEL_CHARS})"
        )
    return escape_controls(label)


def _unreplayed(data: dict, source: str) -> list[str]:
    """What the run did that a replay cannot make: a list of texts, the first
    :data:`MAX_UNREPLAYED` kept (said when the lesson opens)."""
    from fuzzynav.resources import escape_controls

    raw = data.get("unreplayed") or []
    if not isinstance(raw, list) or not all(
        isinstance(u, str) and len(u) <= MAX_NOTE_CHARS for u in raw
    ):
        raise ViewerError(
            f"{source}: unreplayed: not a list of texts of at most {MAX_NOTE_CHARS} "
            f"characters ({type(raw).__name__})"
        )
    return [escape_controls(u) for u in raw[:MAX_UNREPLAYED]]


def _saved_inputs(data: dict, source: str):
    """The inputs read at the saved time ([d_t, d_o, phi_t, phi_o], null: not sensed)."""
    raw = data.get("inputs")
    if raw is None:
        return None
    if not (isinstance(raw, list) and len(raw) == 4) or not all(
        v is None or isinstance(v, (int, float)) and not isinstance(v, bool) for v in raw
    ):
        raise ViewerError(f"{source}: inputs = {raw!r}: not four numbers (or null)")
    return [math.nan if v is None else float(v) for v in raw]


def open_lesson(app, content: bytes | str, source: str = "lesson.json", background=False):
    """Open a lesson in ``app``: its scenario, layout and settings, the run replayed to its
    time (each change of its timeline at its step) and paused. Everything is checked
    before anything is applied. With ``background`` the replay runs on a thread of its
    own and this returns at once. Returns the lesson's view (for the page to apply)."""
    lesson = read_lesson(content, source, app.sim.control_period_s)
    timeline = lesson["timeline"] or [{"step": 0, **{k: lesson[k] for k in SETTING_KEYS}}]
    app.driver.pause()
    with app.lock:
        app.seed = lesson["seed"]
        app.note = lesson["note"]
        # the scenario and layout, the Editor as the lesson left it (its edits, or
        # afresh, whatever this world had edited before) and what drove at the start
        app.apply_settings({**lesson, **timeline[0]})
        app.driver._reset_locked(app.editing._layout_scenario())  # the seed, from the start
        app._notice(f"Opening the lesson {source}: replaying to t = {lesson['time_s']:.2f} s…")
        run_id = app.run_id
    args = (app, lesson, list(timeline[1:]), source, run_id)
    if background:
        threading.Thread(target=_replay, args=args, name="fuzzynav-lesson", daemon=True).start()
    else:
        _replay(*args)
    return lesson["view"]


def apply_entry_locked(app, entry: dict) -> None:
    """Drive with what a timeline entry (or a teacher's push) says: fuzzynav's parts,
    the controller (an edit the Editor holds drives as the Editor's own), perception,
    disturbance and noise; only what differs is changed (a change of noise rebuilds the
    sensors, as it did in the run)."""
    from fuzzynav.app.viewer.starter import STARTER_EDITED_LABEL
    from fuzzynav.app.viewer.state import EDITED_LABEL
    from fuzzynav.controller.fis_controller import FisController

    setup = app.setup
    for name in [p.name for p in setup.part_options()]:
        if (name in entry["parts_off"]) != (name in app.parts_off):
            setup.set_part(name, name not in entry["parts_off"])
    label, fis = entry["controller"], entry["fis"]
    if fis is None:
        if label != app.controller_label:
            setup.set_controller(label)
    else:
        kind = {EDITED_LABEL: "paper", STARTER_EDITED_LABEL: "starter"}.get(label)
        editor = app.editor(kind) if kind is not None else None
        if editor is not None and editor.edited and editor.controller().fis == fis:
            controller = editor.controller()  # the edit the Editor holds (the lesson's last)
        else:  # uploaded, or an earlier edit (it drives; the Editor keeps the last)
            controller = FisController(fis, name=label)
            if kind is None:
                app.uploaded_controller, app.uploaded_label = controller, label
        setup._install_controller(controller, label, quiet=True)
    if entry["perception"] != app.sim.perception.mode:
        setup.set_perception(entry["perception"])
    if entry["disturbance_on"] != app.disturbance_on:
        setup.set_disturbance(entry["disturbance_on"])
    if entry["noise_std_m"] != app.noise_std_m:
        setup.set_noise(entry["noise_std_m"])


def _replay(app, lesson: dict, changes: list, source: str, run_id: int) -> None:
    """Step the run to the lesson's time, each change at its step, a chunk of steps per
    hold of the lock; a press that changes the run meanwhile (Play, a reset, a switch)
    stops the replay there, and it says so."""
    period = app.sim.control_period_s
    target = lesson["time_s"]
    entries = None  # the timeline's length after the last chunk: another change stops us
    while True:
        with app.lock:
            if (
                app.run_id != run_id
                or app.playing
                or entries is not None
                and len(app._timeline) != entries
            ):
                app._notice(
                    f"The lesson {source} was replayed to t = {app.sim.time_s:.2f} s only: the "
                    "run was changed meanwhile.",
                    "warning",
                )
                return
            for _ in range(REPLAY_CHUNK_STEPS):
                step = int(round(app.sim.time_s / period))
                while changes and changes[0]["step"] <= step:
                    apply_entry_locked(app, changes.pop(0))
                if app.sim.time_s + 0.5 * period >= target or app.sim.done:
                    break
                app.driver._step_locked()
            else:
                entries = len(app._timeline)
                continue
            app.playing = False
            _say_opened_locked(app, lesson, source)
            return


def _say_opened_locked(app, lesson: dict, source: str) -> None:
    """The lesson is open: said, with a warning when the moment reached is not the one
    saved (d_t and phi_t compared to :data:`INPUTS_MATCH`)."""
    text = f"Opened the lesson {source} at t = {app.sim.time_s:.2f} s."
    if lesson["note"]:
        text += f" Teacher's note: {lesson['note']}"
    saved = lesson["inputs"]
    now = app.controller.last_inputs
    differs = []
    if saved is not None:
        for k, name, unit in ((0, "d_t", "m"), (2, "phi_t", "rad")):
            if not (abs(float(now[k]) - saved[k]) <= INPUTS_MATCH):
                differs.append(f"{name} {float(now[k]):.2f} {unit} (saved: {saved[k]:.2f} {unit})")
    if not differs:
        app._notice(text, "info")
        return
    why = (
        "the run had changes a replay cannot make: " + "; ".join(lesson["unreplayed"])
        if lesson["unreplayed"]
        else "the run had no fixed seed"
        if lesson["seed"] is None
        else "the replay took another path"
    )
    app._notice(
        f"{text} The replay differs from the moment saved: {', '.join(differs)} ({why}).", "warning"
    )
