"""Issue 38 in a real headless Chromium: the lesson a teacher gives with the viewer
(paused, the page answers every drag at once; the rules readable; the classroom's
Teacher folder). The helpers are tests/test_viewer_browser.py's."""

from __future__ import annotations

import os
import time

import numpy as np
import pytest
from test_viewer_browser import (  # noqa: F401  (browser: a fixture)
    JS_NODE_SCREEN,
    VIEWPORT,
    browser,
    obstacle_node,
    open_page,
    open_tab,
)

from fuzzynav.app.viewer import compat_viser
from fuzzynav.app.viewer.model import ViewerApp
from fuzzynav.controller.registry import controller_names

pytestmark = [
    pytest.mark.browser,
    pytest.mark.timeout(150),
    pytest.mark.skipif("paper" not in controller_names(), reason="no paper controller"),
]

# A signature of the beams as drawn: the sum of the line nodes' vertex coordinates.
JS_BEAMS = """
() => {
  const m = window.__viserMutable; let total = 0, count = 0;
  for (const name of ['/robot/beams', '/robot/free_beams']) {
    const n = m.nodeRefFromName[name];
    if (!n) continue;
    n.traverse((o) => {
      const g = o.geometry; if (!g || !g.attributes) return;
      for (const key of ['instanceStart', 'position']) {
        const a = g.attributes[key]; if (!a) continue;
        const arr = a.data ? a.data.array : a.array;
        for (let i = 0; i < arr.length; i++) total += arr[i] * ((i % 7) + 1);
        count += arr.length;
      }
    });
  }
  return [count, Math.round(total * 1000)];
}
"""

JS_SHOWN = """
() => {
  const status = document.querySelector('.fz-status');
  const firing = [...document.querySelectorAll('.fz-inference .fz-firing')]
    .map((e) => +(e.dataset.rule || e.closest('[data-rule]')?.dataset.rule || -1));
  return {status: status ? status.innerText : '', firing: firing.sort((a, b) => a - b)};
}
"""

# From the pointer's next move on, the time (page clock) when the page has answered:
# d_o sensed, the beams and the firing rules changed.
JS_WATCH = (
    "([before, beams]) => { window.__fzMoved = undefined; window.__fzAnswered = undefined;"
    " window.addEventListener('pointermove', () => { window.__fzMoved = performance.now(); },"
    " {capture: true, once: true});"
    " const check = () => { const shown = ("
    + JS_SHOWN.strip()
    + ")(); const now = ("
    + JS_BEAMS.strip()
    + ")(); if (window.__fzMoved !== undefined"
    " && !/d\\s*o\\s*none/.test(shown.status.replace(/\\n/g, ' '))"
    " && JSON.stringify(now) !== JSON.stringify(beams) && shown.firing.length > 0"
    " && JSON.stringify(shown.firing) !== JSON.stringify(before)) {"
    " window.__fzAnswered = performance.now(); } else { setTimeout(check, 2); } };"
    " check(); }"
)


@pytest.fixture(scope="module")
def lesson(browser):  # noqa: F811
    from fuzzynav.app.viewer.server import ViewerServer

    app = ViewerApp("s1", "paper")
    server = ViewerServer(app, port=0)
    page = open_page(browser, server.url)
    yield server, page
    page.context.close()
    server.stop()


def test_paused_an_obstacle_dragged_ahead_changes_d_o_beams_and_rules_within_200_ms(lesson):
    """Issue 38's main moment: paused at t = 0, obstacle 1 dragged a metre and a half
    ahead of the robot; the status's d_o, the beams and the firing rules change at
    once, without a Step (they stayed "d_o none" until Step)."""
    server, page = lesson
    app = server.app
    app.pause()
    app.load_scenario("s1")
    open_tab(page, "Inference")
    page.wait_for_function("() => document.querySelectorAll('.fz-hit [data-rule]').length == 40")
    page.wait_for_timeout(500)
    before = page.evaluate(JS_SHOWN)
    assert "none" in before["status"]  # d_o: nothing sensed at s1's start
    ob = next(iter(app.sim.arena.obstacles))
    ox, oy = app.sim.arena.obstacles[ob].position_at(0.0)
    x, y, heading = app.sim.arena.pose
    goal = (x + 1.5 * np.cos(heading), y + 1.5 * np.sin(heading))
    points = None
    for _ in range(40):  # the node stands still on screen
        now = page.evaluate(
            JS_NODE_SCREEN, {"name": obstacle_node(app, ob), "dx": goal[0] - ox, "dy": goal[1] - oy}
        )
        if now is not None and now == points:
            break
        points = now
        page.wait_for_timeout(250)
    (x0, y0), (x1, y1) = points["from"], points["to"]
    page.mouse.move(x0, y0)
    page.mouse.down()
    for k in range(1, 6):  # a start of a drag that keeps the obstacle far
        page.mouse.move(x0 + (x1 - x0) * 0.02 * k, y0 + (y1 - y0) * 0.02 * k)
        page.wait_for_timeout(30)
    far_point = (x0 + (x1 - x0) * 0.1, y0 + (y1 - y0) * 0.1)
    # Timed in the page's own clock, from the pointer's move to the page showing its
    # answer (a round trip of the test's to the browser can take longer than the
    # answer itself). The best of three jumps: the machine may be busy with others.
    times = []
    for attempt in range(3):
        if attempt:
            page.mouse.move(*far_point)  # back where nothing is sensed, and again
        page.wait_for_function(
            "() => /d\\s*o\\s*none/.test(document.querySelector('.fz-status')"
            ".innerText.replace(/\\n/g, ' '))",
            timeout=5_000,
        )
        page.wait_for_timeout(400)
        far = page.evaluate(JS_SHOWN)
        page.evaluate(JS_WATCH, [far["firing"], page.evaluate(JS_BEAMS)])
        page.mouse.move(x1, y1)  # in front of the robot
        page.wait_for_function("() => window.__fzAnswered !== undefined", timeout=5_000)
        moved, answered = page.evaluate("() => [window.__fzMoved, window.__fzAnswered]")
        times.append((answered - moved) / 1000.0)
        if times[-1] < 0.2:
            break
    elapsed = min(times)
    print(f"paused drag answered in {', '.join(f'{t * 1000:.0f}' for t in times)} ms")
    page.mouse.up()
    assert app.snapshot().time_s == 0.0 and not app.playing  # no step was taken
    d_o = app.snapshot().inputs[1]
    assert np.isfinite(d_o) and d_o < 1.5
    page.wait_for_timeout(400)
    shown = page.evaluate(JS_SHOWN)
    expected = sorted(int(r) + 1 for r in np.flatnonzero(app.teaching()["strengths"] > 0))
    assert shown["firing"] == expected
    assert f"{d_o:.2f} m" in shown["status"]
    # 200 ms on a machine that is not oversubscribed; on one that runs more than a job
    # per core (a parallel test suite beside this one) the limit scales with the load.
    busy = max(1.0, os.getloadavg()[0] / (os.cpu_count() or 1))
    limit = min(0.2 * busy, 2.0)
    assert elapsed < limit, (
        f"the page took {times} s to answer the drag (limit {limit:.2f} s, load x{busy:.1f})"
    )


# The rule rows a reader sees in the Inference tab without scrolling: each row's hit area
# wholly inside the tab's scrolled area, below the sticky headers and above the pinned
# aggregate, and at least 12 px tall.
JS_READABLE_ROWS = """
() => {
  const view = document.querySelector('.fz-inference');
  if (!view) return {rows: 0, height: 0};
  let box = view.parentElement;
  while (box && !(box.scrollHeight > box.clientHeight + 2
                  && /(auto|scroll)/.test(getComputedStyle(box).overflowY))) box = box.parentElement;
  const area = box ? box.getBoundingClientRect()
                   : {top: 0, bottom: window.innerHeight, left: 0, right: window.innerWidth};
  const head = view.querySelector('.fz-rule-head').getBoundingClientRect();
  const agg = view.querySelector('.fz-rule-agg').getBoundingClientRect();
  const top = Math.max(area.top, head.bottom), bottom = Math.min(area.bottom, agg.top, window.innerHeight);
  let rows = 0, height = 0;
  for (const r of view.querySelectorAll('.fz-hit rect[data-rule]')) {
    const b = r.getBoundingClientRect();
    height = Math.max(height, b.height);
    if (b.top >= top - 0.5 && b.bottom <= bottom + 0.5 && b.height >= 12) rows += 1;
  }
  return {rows, height};
}
"""


def _state_clipped(page) -> float:
    """How far (px) the status line's state reaches past what its panel shows."""
    return page.evaluate(
        """() => { const s = [...document.querySelectorAll('.fz-status span')]
            .find((e) => e.innerText.startsWith('●'));
          let box = s.parentElement;
          while (box && !(/(auto|scroll|hidden)/.test(getComputedStyle(box).overflowX)
                 || /(auto|scroll)/.test(getComputedStyle(box).overflowY))) box = box.parentElement;
          const right = box.getBoundingClientRect().left + box.clientWidth;
          return Math.max(s.getBoundingClientRect().right - right,
                          s.getBoundingClientRect().right - window.innerWidth); }"""
    )


@pytest.mark.parametrize("mode", ["what-if", "presentation", "presentation-1920"])
def test_the_rule_grid_keeps_eight_readable_rows(lesson, mode):
    """Defect 3: with What-if open at 1280x800, or in presentation mode, the rule grid
    showed its header and its aggregate and no row at all (the term plots and the rule
    strip above it took the height)."""
    server, page = lesson
    app = server.app
    app.pause()
    app.load_scenario("s1")
    for _ in range(40):
        app.step_once()
    size = {"width": 1920, "height": 1080} if mode == "presentation-1920" else VIEWPORT
    page.set_viewport_size(size)
    open_tab(page, "Inference")
    try:
        if mode == "what-if":
            page.get_by_text("What-if", exact=True).click()
            page.get_by_role("checkbox", name="What-if mode").click()
            assert app.wait_for(lambda a: a.what_if is not None, timeout=10)
        else:
            server.set_presentation(True)
            app._bump()
        page.wait_for_timeout(1500)
        page.evaluate(  # the tab scrolled to its top, as a tab opened for the lesson
            "() => { let b = document.querySelector('.fz-inference');"
            " while (b) { b.scrollTop = 0; b = b.parentElement; } }"
        )
        page.wait_for_timeout(300)
        seen = page.evaluate(JS_READABLE_ROWS)
        page.screenshot(path=f"/tmp/fz-rules-{mode}.png")
        assert seen["rows"] >= 8, seen
        assert _state_clipped(page) <= 0.5  # defect 5: the status's state is not cut
    finally:
        if mode == "what-if":
            app.stop_what_if()
            page.get_by_text("What-if", exact=True).click()
        else:
            server.set_presentation(False)
        page.set_viewport_size(VIEWPORT)
        page.wait_for_timeout(500)


@pytest.mark.parametrize("state", ["looking back", "reached"])
def test_the_status_lines_state_is_never_cut_at_the_panels_edge(lesson, state):
    """Defect 5: "t = 98.54 s● reached the target" and "looking back (paused" were cut
    at the control panel's edge (in presentation mode worst)."""
    server, page = lesson
    app = server.app
    app.pause()
    app.load_scenario("s1")
    for _ in range(60):
        app.step_once()
    if state == "reached":
        x, y, heading = app.sim.arena.pose
        app.move_target((x + 1.0 * np.cos(heading), y + 1.0 * np.sin(heading)))
        app.set_speed(10.0)
        app.play()
        assert app.wait_for(lambda a: a.sim.done, timeout=30)
        expected = "reached the target"
    else:
        app.view_history(0.4)
        expected = "looking back (paused)"
    try:
        for presentation in (False, True):
            server.set_presentation(presentation)
            app._bump()
            page.wait_for_function(
                "(t) => [...document.querySelectorAll('.fz-status span')]"
                ".some((e) => e.innerText.startsWith('●') && e.innerText.includes(t))",
                arg=expected,
                timeout=10_000,
            )
            page.wait_for_timeout(800)
            assert _state_clipped(page) <= 0.5, (presentation, _state_clipped(page))
    finally:
        server.set_presentation(False)
        app.set_speed(1.0)
        app.leave_history()


def test_a_click_on_a_rule_opens_it_large_and_it_follows_the_world(lesson):
    """Issue 38: a rule you can zoom into: a click on its row opens it large (its
    antecedents with today's degrees, its clipped consequents, its share of the firing
    strength); paused, a drag that changes it changes the open rule; Escape closes it."""
    server, page = lesson
    app = server.app
    app.pause()
    app.load_scenario("s1")
    for _ in range(40):
        app.step_once()
    open_tab(page, "Inference")
    page.wait_for_function("() => document.querySelectorAll('.fz-firing').length > 0")
    page.wait_for_timeout(500)
    info = app.teaching()
    best = int(np.argmax(info["strengths"])) + 1
    row = page.locator(f".fz-hit rect[data-rule='{best}']")
    row.scroll_into_view_if_needed()
    small = row.bounding_box()
    row.click()
    zoom = page.locator("#fz-zoom")
    zoom.wait_for(state="visible", timeout=5_000)
    text = zoom.inner_text()
    assert f"Rule {best}" in text
    from fuzzynav.app.viewer.drawing import rule_sentence

    fis = info["fis"]
    assert rule_sentence(fis, best - 1, info["input_names"], info["output_names"]) in text
    share = 100 * info["strengths"][best - 1] / info["strengths"].sum()
    page.wait_for_function(
        "(t) => document.querySelector('#fz-zoom').innerText.includes(t)",
        arg=f"{share:.0f} % of the firing strength",
        timeout=5_000,
    )
    big = page.locator("#fz-zoom .fz-zoom-row").bounding_box()
    assert big["height"] >= 2.5 * small["height"] and big["width"] >= 2 * small["width"] * 0.9
    page.screenshot(path="/tmp/fz-rule-zoom.png")
    # paused, the world changes: the open rule follows (its share, read again)
    before = zoom.inner_text()
    ob = next(iter(app.sim.arena.obstacles))
    x, y, heading = app.sim.arena.pose
    app.move_obstacle(ob, (x + 1.2 * np.cos(heading), y + 1.2 * np.sin(heading)))
    page.wait_for_function(
        "(t) => document.querySelector('#fz-zoom').innerText !== t", arg=before, timeout=5_000
    )
    page.keyboard.press("Escape")
    zoom.wait_for(state="detached", timeout=5_000)


JS_FOLLOWS = """
([first, second]) => {
  const find = (t) => [...document.querySelectorAll('body *')]
    .filter((e) => e.textContent.trim() === t).pop();
  const a = t => (t.startsWith('.') ? document.querySelector(t) : find(t));
  const x = a(first), y = a(second);
  if (!x || !y) return null;
  return !!(x.compareDocumentPosition(y) & Node.DOCUMENT_POSITION_FOLLOWING);
}
"""


def test_classroom_teacher_folder_stays_last_token_masked_and_push_says_layout_edited(browser):  # noqa: F811
    """Defect 4: the Teacher folder (order 1000) jumped above the clock once viser's
    server-wide order counter passed 1000 (later tabs, a scenario change); the token
    stayed readable on the projected teacher's tab; after a push of an edited layout
    the students' status did not say "layout edited"."""
    from fuzzynav.app.viewer.classroom import ClassroomServer

    # a server that has served many tabs: viser's counter is far past 1000
    compat_viser.raise_order_counter(5000)
    classroom = ClassroomServer(lambda: ViewerApp("s1", "paper"), port=0, token="teach-me")
    pages = []
    try:
        teacher = open_page(browser, classroom.url)
        pages.append(teacher)
        student = open_page(browser, classroom.url)
        pages.append(student)
        assert len(classroom.sessions) == 2
        first, second = sorted(classroom.sessions)
        for page in pages:
            page.wait_for_function(
                f"() => ({JS_FOLLOWS})(['.fz-status', 'Teacher']) !== null", timeout=30_000
            )
            assert page.evaluate(JS_FOLLOWS, [".fz-status", "Teacher"]) is True
            assert page.evaluate(JS_FOLLOWS, ["Result", "Teacher"]) is True
        # after a scenario change, still last
        classroom.sessions[first].app.load_scenario("s2")
        teacher.wait_for_timeout(1500)
        assert teacher.evaluate(JS_FOLLOWS, ["Result", "Teacher"]) is True
        classroom.sessions[first].app.load_scenario("s1")
        # the token is typed as discs, and gone from the page once taken
        teacher.get_by_text("Teacher", exact=True).click()
        uuid = compat_viser.handle_uuid(classroom.sessions[first].teacher_token_box)
        box = teacher.locator(f"div:has(> div > p > label[for='{uuid}']) input")
        box.scroll_into_view_if_needed()
        box.fill("teach")  # (the whole token is taken as soon as it is typed)
        teacher.wait_for_timeout(300)
        masked = box.evaluate(
            "(e) => getComputedStyle(e).getPropertyValue('-webkit-text-security')"
        )
        teacher.screenshot(path="/tmp/fz-teacher-token.png")
        assert masked == "disc"
        box.press("End")
        box.type("-me")
        teacher.get_by_role("button", name="Push my world's setup to the class").wait_for(
            state="visible", timeout=10_000
        )
        assert "teach-me" not in teacher.evaluate(
            "() => [...document.querySelectorAll('input')].map((e) => e.value).join(' ')"
        )
        # the teacher edits the layout and pushes: the student's status says so
        app = classroom.sessions[first].app
        ob = next(iter(app.sim.arena.obstacles))
        app.move_obstacle(ob, (2.0, 3.5))
        assert app.layout_edited
        teacher.get_by_role("button", name="Push my world's setup to the class").click()
        student_app = classroom.sessions[second].app
        assert student_app.wait_for(lambda a: a.layout_edited, timeout=10)
        student.wait_for_function(
            "() => document.querySelector('.fz-status').innerText.includes('layout edited')",
            timeout=10_000,
        )
        # and Restore in the student's tab goes back to the scenario as loaded
        student_app.restore_layout()
        assert not student_app.layout_edited
    finally:
        for page in pages:
            page.context.close()
        classroom.stop()


def test_what_ifs_boxes_take_every_value_their_sliders_offer_and_the_refusal_goes(lesson):
    """Defect 5: What-if's d_t box refused 50 with "must be between -1.13 and 30" while
    its slider ran 0-20 (and 25, inside the rule base's range, could not be set); the
    red message stayed after What-if was left."""
    server, page = lesson
    app = server.app
    app.pause()
    app.load_scenario("s1")
    for _ in range(10):
        app.step_once()
    fis = app.what_if_system()
    lo, hi = fis.inputs[0].range
    open_tab(page, "Inference")
    page.get_by_text("What-if", exact=True).click()
    page.get_by_role("checkbox", name="What-if mode").click()
    try:
        assert app.wait_for(lambda a: a.what_if is not None, timeout=10)
        box = server.inference.what_if_boxes[0]
        assert (box.min, box.max) == (round(lo, 2), round(hi, 2))
        # the page's slider shows the same range
        page.wait_for_function(
            "(hi) => [...document.querySelectorAll('.mantine-Slider-markLabel')]"
            ".some((e) => e.innerText.trim() === hi)",
            arg=f"{hi:g}",
            timeout=10_000,
        )
        value = round(0.5 * (20.0 + hi), 2)  # beyond the old slider, inside the rules
        boxes = page.locator(".fz-inference >> xpath=ancestor::*[.//input][1]").locator(
            "input[inputmode='decimal']:visible"
        )
        # the box shows the moment's d_t first (else the server's first value for it can
        # land after the typing and overwrite it: CI's stop 44 failed so)
        shown = round(float(app.what_if[0]), 2)
        deadline = time.monotonic() + 10.0
        while time.monotonic() < deadline:
            text = boxes.nth(0).input_value() if boxes.nth(0).is_enabled() else ""
            if text and abs(float(text) - shown) < 5e-3:
                break
            page.wait_for_timeout(50)
        else:
            raise AssertionError(f"the d_t box never showed {shown}")
        boxes.nth(0).fill(str(value))
        boxes.nth(0).press("Enter")
        assert app.wait_for(lambda a: a.what_if[0] == value, timeout=10), (
            app.what_if,
            boxes.nth(0).input_value(),
            app.snapshot().message,
        )
        assert app.snapshot().message_level not in ("error", "warning")
        # a refusal while trying inputs goes when What-if is left
        app._notice("d_t = 99: must be between -1.13 and 30", "error")
        page.wait_for_function("() => !!document.querySelector('.fz-message')", timeout=10_000)
    finally:
        page.get_by_role("checkbox", name="What-if mode").click()
        page.get_by_text("What-if", exact=True).click()
    assert app.wait_for(lambda a: a.what_if is None, timeout=10)
    page.wait_for_function("() => !document.querySelector('.fz-message')", timeout=10_000)


def test_what_ifs_box_of_an_input_not_sensed_holds_no_number_and_takes_one(lesson):
    """Paused at a moment with no obstacle in view, the What-if boxes of d_o and phi_o
    (not sensed) show no number, not the last moment's, and their labels say *none
    sensed*; in What-if mode a number typed into the empty d_o box is tried."""
    server, page = lesson
    app = server.app
    app.pause()
    app.load_scenario("s1")
    x, y, heading = app.sim.arena.pose
    app.add_obstacle((x + 2.0 * np.cos(heading), y + 2.0 * np.sin(heading)))
    open_tab(page, "Inference")
    page.get_by_text("What-if", exact=True).click()
    boxes = page.locator(".fz-inference >> xpath=ancestor::*[.//input][1]").locator(
        "input[inputmode='decimal']:visible"
    )
    try:
        d_o = round(float(app.controller.last_inputs[1]), 2)
        page.wait_for_function(
            "([b, v]) => b.length > 1 && Math.abs(+b[1].value - v) < 5e-3 && b[1].value !== ''",
            arg=[boxes.element_handles(), d_o],
            timeout=10_000,
        )
        for obstacle_id in list(app.sim.arena.obstacles):
            app.remove_obstacle(obstacle_id)
        assert np.isnan(app.controller.last_inputs[[1, 3]]).all()
        for label in ("d_o (m): none sensed", "phi_o (rad): none sensed"):
            page.get_by_text(label, exact=True).wait_for(timeout=10_000)
        assert boxes.nth(1).input_value() == "" and boxes.nth(3).input_value() == ""
        assert boxes.nth(0).input_value() != ""
        page.get_by_role("checkbox", name="What-if mode").click()
        assert app.wait_for(lambda a: a.what_if is not None, timeout=10)
        page.wait_for_function(
            "(b) => !b.disabled", arg=boxes.nth(1).element_handle(), timeout=10_000
        )
        boxes.nth(1).fill("1.5")
        boxes.nth(1).press("Enter")
        assert app.wait_for(lambda a: a.what_if[1] == 1.5, timeout=10), app.message
        page.get_by_text("d_o (m)", exact=True).wait_for(timeout=10_000)
        page.get_by_role("checkbox", name="What-if mode").click()
        assert app.wait_for(lambda a: a.what_if is None, timeout=10)
    finally:
        page.get_by_text("What-if", exact=True).click()
        app.load_scenario("s1")


def test_keyboard_space_plays_and_pauses_right_arrow_steps_r_resets(lesson):
    """Issue 38: keyboard control, as a teacher at the projector expects it: space plays
    and pauses, the right arrow steps one control period, R resets; not while typing in
    a box."""
    server, page = lesson
    app = server.app
    app.pause()
    app.load_scenario("s1")
    page.wait_for_timeout(500)
    page.mouse.click(5, 795)  # the page has the focus, no box does
    page.keyboard.press("ArrowRight")
    assert app.wait_for(lambda a: a.sim.time_s > 0.0, timeout=10)
    assert abs(app.sim.time_s - app.sim.control_period_s) < 1e-9 and not app.playing
    page.keyboard.press(" ")
    assert app.wait_for(lambda a: a.playing, timeout=10)
    page.wait_for_function(
        "() => document.querySelector('.fz-status').innerText.includes('running')",
        timeout=10_000,
    )
    page.keyboard.press(" ")
    assert app.wait_for(lambda a: not a.playing, timeout=10)
    assert app.sim.time_s > app.sim.control_period_s
    page.keyboard.press("r")
    assert app.wait_for(lambda a: a.sim.time_s == 0.0, timeout=10)
    # typing in a box is typing, not a key of the run
    open_tab(page, "Inference")
    page.get_by_text("What-if", exact=True).click()
    try:
        box = page.locator(".fz-inference >> xpath=ancestor::*[.//input][1]").locator(
            "input[inputmode='decimal']:visible"
        )
        box.nth(0).focus()
        page.keyboard.press("ArrowRight")
        page.keyboard.press(" ")
        page.wait_for_timeout(800)
        assert app.sim.time_s == 0.0 and not app.playing
    finally:
        page.get_by_text("What-if", exact=True).click()


def test_the_starter_system_is_chosen_in_the_page_and_its_grid_has_two_inputs(lesson):
    """Issue 38: the small two-input system, selectable beside the paper's; its rule
    grid shows only the columns its six rules use."""
    from fuzzynav.app.viewer.starter import STARTER_LABEL

    server, page = lesson
    app = server.app
    app.pause()
    app.load_scenario("s1")
    open_tab(page, "Inference")
    try:
        page.get_by_role("combobox", name="Controller").click()
        page.get_by_role("option", name=STARTER_LABEL, exact=True).click()
        assert app.wait_for(lambda a: a.controller_label == STARTER_LABEL, timeout=10)
        page.wait_for_function(
            "() => document.querySelector('.fz-inference')?.innerText.includes('of 6 rules fire')",
            timeout=10_000,
        )
        heads = page.evaluate(
            "() => [...document.querySelectorAll('.fz-rule-head .fz-col-name')]"
            ".map((e) => e.textContent.trim())"
        )
        assert heads[:2] == ["d_t", "phi_t"] and "d_o" not in heads and "phi_o" not in heads
        assert page.locator(".fz-hit [data-rule]").count() == 6
    finally:
        app.set_controller("paper")


def test_a_lesson_is_saved_from_the_page_and_opened_again_from_it(lesson, tmp_path):
    """Issue 38: Lesson → Save lesson downloads the world as a file; Lesson → Open
    lesson brings it back (layout, controller, view, time) after the world changed."""
    server, page = lesson
    app = server.app
    app.pause()
    app.load_scenario("s1")
    ob = next(iter(app.sim.arena.obstacles))
    app.move_obstacle(ob, (2.5, 1.0))
    for _ in range(100):
        app.step_once()
    saved_pose = np.array(app.sim.arena.pose)
    page.get_by_text("Lesson", exact=True).click()
    try:
        with page.expect_download(timeout=15_000) as download:
            page.get_by_role("button", name="Save lesson (.json)").click()
        path = tmp_path / "lesson.json"
        download.value.save_as(path)
        assert '"fuzzynav_lesson": 1' in path.read_text(encoding="utf-8")
        # the world moves on elsewhere
        app.load_scenario("s2")
        app.set_controller("p")
        with page.expect_file_chooser(timeout=15_000) as chooser:
            page.get_by_role("button", name="Open lesson (.json)").click()
        chooser.value.set_files(path)
        assert app.wait_for(lambda a: a.message.startswith("Opened the lesson"), timeout=20), (
            app.message
        )
        assert app.scenario_label == "s1" and app.controller_label == "paper"
        assert app.layout_edited and not app.playing
        np.testing.assert_allclose(app.sim.arena.pose, saved_pose, atol=1e-9)
        page.wait_for_function(
            "() => document.querySelector('.fz-status').innerText.includes('layout edited')"
            " && document.querySelector('.fz-status').innerText.includes('t = 2.00 s')",
            timeout=10_000,
        )
    finally:
        page.get_by_text("Lesson", exact=True).click()


def test_a_lesson_opened_from_the_page_shows_its_editor_numbers(lesson, tmp_path):
    """A lesson saved with an Editor edit and opened from the page after the Editor was
    moved again: the page's Editor shows the lesson's number (it kept the one moved)."""
    server, page = lesson
    app = server.app
    app.pause()
    app.load_scenario("s1")
    app.set_controller("paper")
    name = "d_t.top"
    lo, hi = app.editor().bounds[name]
    saved, moved = (round(lo + f * (hi - lo), 2) for f in (0.3, 0.7))
    app.set_membership_parameter(name, saved)
    for _ in range(20):
        app.step_once()
    path = tmp_path / "edited.json"
    path.write_text(app.lesson_text(), encoding="utf-8")
    app.set_membership_parameter(name, moved)
    open_tab(page, "Editor")
    boxes = page.locator("input[inputmode='decimal']")

    def box_of(value):
        for k in range(boxes.count()):
            if abs(float(boxes.nth(k).input_value() or "nan") - value) < 1e-6:
                return k
        return None

    deadline = time.monotonic() + 10
    while box_of(moved) is None and time.monotonic() < deadline:
        page.wait_for_timeout(100)
    k = box_of(moved)
    assert k is not None, f"no number box holds {name} = {moved}"
    page.get_by_text("Lesson", exact=True).click()
    try:
        with page.expect_file_chooser(timeout=15_000) as chooser:
            page.get_by_role("button", name="Open lesson (.json)").click()
        chooser.value.set_files(path)
        assert app.wait_for(lambda a: a.message.startswith("Opened the lesson"), timeout=20)
        assert app.editor().value(name) == pytest.approx(saved)
        page.wait_for_function(
            "([k, v]) => Math.abs(+document.querySelectorAll(\"input[inputmode='decimal']\")[k]"
            ".value - v) < 1e-6",
            arg=[k, saved],
            timeout=10_000,
        )
    finally:
        page.get_by_text("Lesson", exact=True).click()
        app.reset_membership_editor()


def test_one_inference_is_walked_step_by_step_in_the_page(lesson):
    """Issue 38: Step by step → Next walks the moment through the five stages, each
    drawn and said with its numbers; Back goes back; Off leaves; the run pauses."""
    server, page = lesson
    app = server.app
    app.pause()
    app.load_scenario("s1")
    for _ in range(30):
        app.step_once()
    open_tab(page, "Inference")
    page.get_by_text("Step by step", exact=True).click()
    try:
        titles = []
        for stage in range(1, 6):
            page.get_by_role("button", name="Next ▶").click()
            page.wait_for_function(
                "(k) => document.querySelector('.fz-stepwise')?.dataset.stage == k",
                arg=str(stage),
                timeout=10_000,
            )
            titles.append(page.locator(".fz-step-title").inner_text())
        assert titles == [
            "Step 1 of 5: Fuzzification",
            "Step 2 of 5: The rules' AND",
            "Step 3 of 5: Implication",
            "Step 4 of 5: Aggregation",
            "Step 5 of 5: Defuzzification",
        ]
        # the last stage: the crisp outputs drawn and said, the voltages of the status
        v = app.snapshot().voltages_v
        text = page.locator(".fz-stepwise").inner_text()
        assert f"{v[0]:.2f}" in text and f"{v[1]:.2f}" in text
        assert page.locator(".fz-stepwise .fz-step-crisp").count() == 2
        page.screenshot(path="/tmp/fz-stepwise.png")
        page.get_by_role("button", name="◀ Back").click()
        page.wait_for_function(
            "() => document.querySelector('.fz-stepwise')?.dataset.stage == '4'", timeout=10_000
        )
        assert not app.playing
        page.get_by_role("button", name="Off").click()
        page.wait_for_function("() => !document.querySelector('.fz-stepwise')", timeout=10_000)
    finally:
        server.inference.stage = 0
        page.get_by_text("Step by step", exact=True).click()


@pytest.mark.parametrize("controller", ["paper", "fuzzynav"])
def test_the_inference_shows_at_once_after_a_scenario_switch_and_the_hint_goes(lesson, controller):
    """Defect 5: the inference was blank after a scenario switch (until Play or Step);
    the arena's drag hint stayed until someone dragged, and covered the robot near the
    end of the run."""
    server, page = lesson
    app = server.app
    app.pause()
    app.set_controller(controller)
    open_tab(page, "Inference")
    try:
        page.get_by_role("combobox", name="Scenario").click()
        page.get_by_role("option", name="s2", exact=True).click()
        assert app.wait_for(lambda a: a.scenario_label == "s2", timeout=10)
        page.wait_for_function(
            "() => document.querySelectorAll('.fz-inference .fz-firing').length > 0",
            timeout=10_000,
        )
        assert app.sim.time_s == 0.0
        # the hint: on the arena at the start, gone once the robot nears the target
        server.handles.drag_hint.visible = True  # as on a fresh server
        app._bump()
        page.wait_for_timeout(500)
        assert server.handles.drag_hint.visible  # far from the target: it stays
        x, y, heading = app.sim.arena.pose
        app.move_target((x + 2.0 * np.cos(heading), y + 2.0 * np.sin(heading)))
        assert app.wait_for(lambda a: not server.handles.drag_hint.visible, timeout=10)
    finally:
        app.set_controller("paper")
        app.load_scenario("s1")


def test_the_panels_scrollbar_hides_no_part_of_the_plots(lesson):
    """Defect 5: the Inference panel's scrollbar hid the right 6 px of the term plots
    and of the rule grid."""
    server, page = lesson
    app = server.app
    app.pause()
    app.load_scenario("s1")
    for _ in range(20):
        app.step_once()
    open_tab(page, "Inference")
    page.wait_for_function("() => document.querySelectorAll('.fz-inference svg').length > 3")
    page.wait_for_timeout(500)
    overlap = page.evaluate(
        """() => { const view = document.querySelector('.fz-inference');
          let box = view.parentElement;
          while (box && !(box.scrollHeight > box.clientHeight + 2
                 && /(auto|scroll)/.test(getComputedStyle(box).overflowY))) box = box.parentElement;
          let right = box.getBoundingClientRect().left + box.clientLeft + box.clientWidth;
          // an overlay scrollbar (Mantine's ScrollArea) covers the content without
          // narrowing it: its left edge is the limit
          let el = view;
          while (el) {
            const bar = el.querySelector && el.querySelector(
              ':scope > .mantine-ScrollArea-scrollbar[data-orientation="vertical"]');
            if (bar && bar.getBoundingClientRect().width > 0) {
              right = Math.min(right, bar.getBoundingClientRect().left); break; }
            el = el.parentElement;
          }
          let worst = -1e9;
          for (const s of view.querySelectorAll('svg')) {
            const r = s.getBoundingClientRect();
            if (r.width > 0) worst = Math.max(worst, r.right - right);
          }
          return worst; }"""
    )
    assert overlap <= 0.5, f"the plots reach {overlap:.1f} px under the scrollbar"


def test_the_teacher_sees_the_class_and_locks_the_students_controls(browser):  # noqa: F811
    """Issue 38: the teacher's tab lists every student's world (scenario, controller,
    time, state, edits) and can lock and unlock the students' controls: a locked tab's
    Play and drags are refused with a word; unlocked, they work again."""
    from fuzzynav.app.viewer.classroom import ClassroomServer

    classroom = ClassroomServer(lambda: ViewerApp("s1", "paper"), port=0, token="teach-me")
    pages = []
    try:
        teacher = open_page(browser, classroom.url)
        pages.append(teacher)
        student = open_page(browser, classroom.url)
        pages.append(student)
        first, second = sorted(classroom.sessions)
        t_view, s_view = classroom.sessions[first], classroom.sessions[second]
        teacher.wait_for_function(
            f"() => ({JS_FOLLOWS})(['.fz-status', 'Teacher']) !== null", timeout=30_000
        )
        teacher.get_by_text("Teacher", exact=True).click()
        uuid = compat_viser.handle_uuid(t_view.teacher_token_box)
        box = teacher.locator(f"div:has(> div > p > label[for='{uuid}']) input")
        box.scroll_into_view_if_needed()
        box.fill("teach-me")
        lock = teacher.get_by_role("checkbox", name="Lock the students' controls")
        lock.wait_for(state="visible", timeout=10_000)
        # the overview lists the student's world, and follows it
        s_view.app.move_obstacle(next(iter(s_view.app.sim.arena.obstacles)), (2.0, 3.0))
        for _ in range(25):
            s_view.app.step_once()
        teacher.wait_for_function(
            "() => { const r = document.querySelector('.fz-class-row');"
            " return r && r.innerText.includes('0.5 s') && r.innerText.includes('layout'); }",
            timeout=15_000,
        )
        teacher.locator(".fz-class").scroll_into_view_if_needed()
        teacher.screenshot(path="/tmp/fz-class.png")
        row = teacher.locator(".fz-class-row").inner_text()
        assert "s1" in row and "paper" in row and "paused" in row
        # locked: the student's Play is refused, and said
        lock.click()  # the press reaches the server over its websocket: wait for it
        assert _eventually(lambda: s_view.locked), "the lock never reached the student's world"
        assert not t_view.locked
        student.get_by_role("button", name="Play", exact=True).click()
        student.wait_for_timeout(1000)
        assert not s_view.app.playing
        student.wait_for_function(
            "() => document.body.innerText.includes('locked the controls')", timeout=10_000
        )
        # the teacher's own tab still plays
        t_view.app.play()
        assert t_view.app.wait_for(lambda a: a.sim.time_s > 0.1, timeout=10)
        t_view.app.pause()
        # unlocked: the student's Play works
        lock.click()
        assert _eventually(lambda: not s_view.locked), "the unlock never reached it"
        student.get_by_role("button", name="Play", exact=True).click()
        assert s_view.app.wait_for(lambda a: a.playing, timeout=10)
        s_view.app.pause()
    finally:
        for page in pages:
            page.context.close()
        classroom.stop()


def _eventually(predicate, timeout_s: float = 10.0) -> bool:
    """``predicate()`` true within ``timeout_s`` (a press is handled on the server's
    threads after the browser's click returns)."""
    import time

    deadline = time.monotonic() + timeout_s
    while not predicate():
        if time.monotonic() > deadline:
            return False
        time.sleep(0.02)
    return True


def test_a_rule_is_edited_added_and_undone_in_the_page(lesson):
    """Issue 38: Editor → Rules: pick a rule, change its sentence and Apply (the robot's
    controller and the Inference tab take it at once), Add as new, Undo."""
    server, page = lesson
    app = server.app
    app.pause()
    app.load_scenario("s1")
    open_tab(page, "Editor")
    page.get_by_text("Rules (add, change, remove)", exact=True).click()
    try:
        n = len(app.fuzzy_system().rules)
        uuid = compat_viser.handle_uuid(server.editor.rule_number)
        number = page.locator(f"div:has(> div > p > label[for='{uuid}']) input")
        number.fill("3")
        number.press("Enter")
        uuid = compat_viser.handle_uuid(server.editor.rule_text)
        box = page.locator(f"div:has(> div > p > label[for='{uuid}']) input")
        # the box shows rule 1's sentence first: wait for rule 3's (a value merely
        # starting with IF raced the server's update of the box)
        want = app.editor().rule_text(3)
        page.wait_for_function(
            "([e, want]) => e.value === want", arg=[box.element_handle(), want], timeout=10_000
        )
        assert box.input_value() == want
        box.fill("if d_t is VS then left is VS and right is VS")
        page.get_by_role("button", name="Add as new").click()
        assert app.wait_for(lambda a: len(a.fuzzy_system().rules) == n + 1, timeout=10)
        assert app.controller_label == "paper (edited)"
        open_tab(page, "Inference")
        page.wait_for_function(
            "(n) => document.querySelectorAll('.fz-hit [data-rule]').length == n",
            arg=n + 1,
            timeout=10_000,
        )
        open_tab(page, "Editor")
        page.get_by_role("button", name="Undo").click()
        assert app.wait_for(lambda a: len(a.fuzzy_system().rules) == n, timeout=10)
        # the page shows the rule picked after the undo (the last) before we type: the
        # server sends it just after the rules change, and it overwrote a sentence typed
        # meanwhile (the suite under load did it, and Apply then applied a valid rule)
        page.wait_for_function(
            "([e, t]) => e.value === t",
            arg=[box.element_handle(), app.editor().rule_text(n)],
            timeout=10_000,
        )
        # a sentence with a wrong term is refused with its reason
        box.fill("if d_t is HUGE then left is VS")
        page.get_by_role("button", name="Apply").click()
        page.wait_for_function(
            "() => document.body.innerText.includes('unknown term')", timeout=10_000
        )
        assert len(app.fuzzy_system().rules) == n
    finally:
        app.reset_membership_editor()
        page.get_by_text("Rules (add, change, remove)", exact=True).click()


def test_a_3d_surface_beside_the_arena_with_the_operating_point_on_it(lesson):
    """Issue 38: the Surface tab's first map as a 3-D surface in the scene, which the
    class turns (it ticks View → 3D view); the robot's operating point moves on it."""
    server, page = lesson
    app = server.app
    app.pause()
    app.load_scenario("s1")
    open_tab(page, "Surface")
    box = page.get_by_role("checkbox", name="3D surface beside the arena")
    box.click()
    try:
        page.wait_for_function(
            "() => !!window.__viserMutable.nodeRefFromName['/surface3d/lines']", timeout=15_000
        )
        assert server.view_3d  # the camera may turn
        js_point = (
            "() => { const n = window.__viserMutable.nodeRefFromName['/surface3d/point'];"
            " return n ? n.position.toArray().map((v) => +v.toFixed(3)) : null; }"
        )
        page.wait_for_function(f"() => ({js_point})() !== null", timeout=10_000)
        first = page.evaluate(js_point)
        for _ in range(200):
            app.step_once()
        page.wait_for_function(
            f"(p) => JSON.stringify(({js_point})()) !== JSON.stringify(p)",
            arg=first,
            timeout=10_000,
        )
        # the point stands on the surface: its height is the map's value there
        x, y, z = server.surface._nodes_3d[1]["point"].position
        assert abs(z) > 1e-3
        page.wait_for_timeout(1000)
        page.screenshot(path="/tmp/fz-surface3d.png")
    finally:
        box.click()
        page.wait_for_function(
            "() => !window.__viserMutable.nodeRefFromName['/surface3d/lines']", timeout=15_000
        )
        assert not server.view_3d  # back to the top-down arena


def test_a_membership_functions_corner_is_dragged_on_its_plot(lesson):
    """Issue 38: membership functions shaped by dragging: each Editor folder's plot has a
    handle on every corner a slider moves; dragging one moves that slider (as its own,
    checked update) and the robot drives with the edited system at once."""
    from fuzzynav.app.viewer.term_drag import corner_sliders

    server, page = lesson
    app = server.app
    app.pause()
    app.load_scenario("s1")
    app.reset_membership_editor()
    open_tab(page, "Editor")
    editor = app.editor()
    names = [n for n in editor.names if n.startswith("d_t.")]
    corners = corner_sliders(editor, "d_t", names)
    x, name, rate = next(c for c in corners if abs(c[2] - 1.0) < 1e-6)  # moves 1:1
    before = editor.value(name)
    handle = page.locator(f".fz-term-drag[data-group='d_t'] .fz-corner[data-slider='{name}']")
    handle.scroll_into_view_if_needed()
    page.wait_for_timeout(300)
    box = handle.bounding_box()
    plot = page.locator(".fz-term-drag[data-group='d_t'] .fz-term-area").bounding_box()
    lo, hi = editor.controller().fis.inputs[0].range
    s_lo, s_hi = editor.bounds[name]
    shift_m = 0.5 if s_hi - before > before - s_lo else -0.5  # toward the room it has
    dx = shift_m / (hi - lo) * plot["width"]
    cx, cy = box["x"] + box["width"] / 2, box["y"] + box["height"] / 2
    page.mouse.move(cx, cy)
    page.mouse.down()
    for k in range(1, 6):
        page.mouse.move(cx + dx * k / 5, cy)
        page.wait_for_timeout(30)
    page.mouse.up()
    try:
        assert app.wait_for(lambda a: a.controller_label == "paper (edited)", timeout=10)
        page.wait_for_timeout(500)
        moved = app.editor().value(name) - before
        page.screenshot(path="/tmp/fz-terms.png")
        assert moved == pytest.approx(shift_m / rate, abs=0.15), (moved, name)
    finally:
        app.reset_membership_editor()
        app.set_controller("paper")
