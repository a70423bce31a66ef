"""The viewer on a projector (1280 x 800, presentation mode) and a lesson's clicks without
a console error, in a real headless Chromium. The helpers are tests/test_viewer_browser.py's."""

from __future__ import annotations

import time

import pytest
from test_viewer_browser import (  # noqa: F401  (browser: a fixture)
    browser,
    drag_node,
    obstacle_node,
    open_tab,
    served_page,
)

from fuzzynav.controller.registry import controller_names

pytestmark = [
    pytest.mark.browser,
    pytest.mark.timeout(150),
    pytest.mark.skipif("paper" not in controller_names(), reason="no paper controller"),
]

# Every visible piece of text on screen: its rendered size in px (an SVG's text scaled by
# its viewBox), the smallest first.
JS_TEXT_SIZES = """
() => {
  const out = [];
  const walker = document.createTreeWalker(document.body, NodeFilter.SHOW_TEXT);
  let n;
  while ((n = walker.nextNode())) {
    const text = n.textContent.trim();
    const el = n.parentElement;
    if (!text || !el || !el.checkVisibility({opacityProperty: true, visibilityProperty: true}))
      continue;
    const range = document.createRange();
    range.selectNodeContents(n);
    const onScreen = [...range.getClientRects()].some((r) => r.width > 0 && r.height > 0
      && r.right > 0 && r.bottom > 0 && r.left < innerWidth && r.top < innerHeight);
    if (!onScreen) continue;
    let px = parseFloat(getComputedStyle(el).fontSize);
    if (el instanceof SVGElement) {
      const m = el.getScreenCTM();
      px *= m ? Math.hypot(m.a, m.b) : 1;
    }
    out.push([Math.round(px * 10) / 10, text.slice(0, 30)]);
  }
  return out.sort((a, b) => a[0] - b[0]);
}
"""

# The arena's canvas and the widest other block on screen (the two docked panels).
JS_AREAS = """
() => {
  const c = window.__viserMutable.canvas.getBoundingClientRect();
  const vis = (r) => Math.max(0, Math.min(r.right, innerWidth) - Math.max(r.left, 0))
    * Math.max(0, Math.min(r.bottom, innerHeight) - Math.max(r.top, 0));
  const canvas = vis(c);
  const tab = document.querySelector('[role=tab]');
  const left = tab ? tab.closest('.mantine-Paper-root') : null;
  const right = document.querySelector('.fz-status')?.closest('.mantine-Paper-root');
  return {canvas, left: left ? vis(left.getBoundingClientRect()) : null,
          right: right ? vis(right.getBoundingClientRect()) : null, width: c.width};
}
"""


@pytest.fixture(scope="module")
def projector(browser):  # noqa: F811
    with served_page(browser, ("error", "warning")) as served:
        yield served


def test_presentation_mode_at_1280_reads_from_the_back_and_the_arena_is_largest(projector):
    """At 1280 x 800 in presentation mode, no text on screen is under 12 px (the rule
    grid's numbers were 7-8 px) in the Inference tab (step by step and What-if open),
    the Surface and the Editor; and the arena is the largest thing on screen (it was
    about 470 px wide, and 132 px with presentation mode's wide panels)."""
    server, page, _ = projector
    app = server.app
    app.pause()
    app.load_scenario("s1")
    for _ in range(300):
        app.step_once()
    page.get_by_text("View", exact=True).click()
    # a click, not check(): the box's state comes back from the server, later under load
    page.get_by_role("checkbox", name="Presentation mode").click()
    try:
        page.wait_for_function(
            "() => !!document.querySelector('style') && [...document.querySelectorAll('style')]"
            ".some((s) => s.textContent.includes('.mantine-Slider-markLabel'))",
            timeout=30_000,  # the server's push of the mode's style, late under load
        )
        areas = None
        for _ in range(40):  # the panels widen, the canvas narrows: until it settles
            now = page.evaluate(JS_AREAS)
            if now == areas:
                break
            areas = now
            page.wait_for_timeout(250)
        assert areas["canvas"] > areas["left"] and areas["canvas"] > areas["right"], areas
        open_tab(page, "Inference")
        page.get_by_text("Step by step", exact=True).click()
        # a stage shown (a click on a button the page is still drawing can be lost: again)
        staged = "() => Number(document.querySelector('.fz-stepwise')?.dataset.stage) >= 1"
        for _ in range(3):
            if server.inference.stage == 0:
                page.get_by_role("button", name="Next ▶").click()
            try:
                page.wait_for_function(staged, timeout=10_000)
                break
            except Exception:
                pass
        else:
            raise AssertionError(f"step by step shows no stage (server: {server.inference.stage})")
        for tab in ("Inference", "Surface", "Editor"):
            open_tab(page, tab)
            page.wait_for_timeout(700)
            sizes = page.evaluate(JS_TEXT_SIZES)
            assert sizes and sizes[0][0] >= 12.0, (tab, sizes[:8])
    finally:
        server.inference.stage = 0
        open_tab(page, "Inference")
        page.get_by_text("Step by step", exact=True).click()
        page.get_by_role("checkbox", name="Presentation mode").uncheck()
        page.get_by_text("View", exact=True).click()
        assert app.wait_for(lambda a: not server.presentation, timeout=10)


# Logged by viser's own client at a drag of a scene node (SceneTree.tsx calls
# preventDefault on the pointerdown that react-three-fiber dispatches from a passive
# listener): not fuzzynav's to fix; held by the strict xfail below.
VISER_PASSIVE = "Unable to preventDefault inside passive event listener"


def _drags_switches_and_edits(server, page, errors) -> list[str]:
    """An obstacle dragged, the controller switched in the page and back, a term plot's
    corner dragged in the Editor; what the console logged as an error or a warning."""
    from fuzzynav.app.viewer.starter import STARTER_LABEL

    app = server.app
    app.pause()
    app.load_scenario("s1")
    page.wait_for_timeout(500)
    errors.clear()
    ob = next(iter(app.sim.arena.obstacles))
    before = app.sim.arena.obstacles[ob].position_at(0.0)
    drag_node(page, obstacle_node(app, ob), 0.0, 1.0, 8)
    assert app.wait_for(
        lambda a: a.sim.arena.obstacles[ob].position_at(0.0)[1] > before[1] + 0.5, timeout=10
    )
    for name in (STARTER_LABEL, "fuzzynav", "paper"):
        page.get_by_role("combobox", name="Controller").click()
        page.get_by_role("option", name=name, exact=True).click()
        assert app.wait_for(lambda a, name=name: a.controller_label == name, timeout=10)
        page.wait_for_timeout(400)
    open_tab(page, "Editor")
    handle = page.locator(".fz-term-drag[data-group='d_t'] .fz-corner").first
    handle.scroll_into_view_if_needed()
    page.wait_for_timeout(300)
    box = handle.bounding_box()
    cx, cy = box["x"] + box["width"] / 2, box["y"] + box["height"] / 2
    page.mouse.move(cx, cy)
    page.mouse.down()
    for k in range(1, 6):
        page.mouse.move(cx + 4 * k, cy)
    page.mouse.up()
    try:
        assert app.wait_for(lambda a: a.controller_label == "paper (edited)", timeout=10)
        page.wait_for_timeout(500)
        return list(errors)
    finally:
        app.reset_membership_editor()
        app.set_controller("paper")


def test_a_lesson_of_drags_switches_and_edits_logs_no_console_error(projector):
    """Nothing of fuzzynav's logged as an error or a warning in the browser's console
    while a lesson drags, switches and edits (a switch logged "Tried to update
    non-existent component")."""
    logged = _drags_switches_and_edits(*projector)
    assert [e for e in logged if VISER_PASSIVE not in e] == []


@pytest.mark.xfail(
    strict=True,
    reason="viser 1.1's client logs 'Unable to preventDefault inside passive event "
    "listener invocation.' at every drag of a scene node (its SceneTree.tsx, not ours)",
)
def test_a_drag_of_an_obstacle_logs_nothing_at_all(projector):
    logged = _drags_switches_and_edits(*projector)
    assert logged == []


JS_CAMERA_TILT = """
() => {
  const m = window.__viserMutable, cam = m.camera, root = m.nodeRefFromName[''];
  const V = cam.position.constructor;
  const d = new V(); cam.getWorldDirection(d);
  const down = root.localToWorld(new V(0, 0, -1)).sub(root.localToWorld(new V(0, 0, 0))).normalize();
  return Math.acos(Math.max(-1, Math.min(1, d.dot(down))));
}
"""


def test_keyboard_nudges_of_an_editor_slider_leave_the_arena_seen_from_above(projector):
    """An Editor slider nudged with the arrow keys while the robot drives: the slider
    moves (the robot drives with the edit) and the camera keeps looking straight down
    (viser's camera took the arrows too, and the arena turned to a tilted view)."""
    server, page, _ = projector
    app = server.app
    app.pause()
    app.load_scenario("s1")
    app.set_speed(1.0)
    app.play()
    open_tab(page, "Editor")
    try:
        tilt = page.evaluate(JS_CAMERA_TILT)
        assert tilt < 0.05, tilt
        thumb = page.locator(".mantine-Slider-thumb:visible").first
        thumb.scroll_into_view_if_needed()
        thumb.focus()
        tilts = []  # the camera after each press (the server's camera guard, which
        # turns a tilted view back, must not be what keeps it flat)
        for key in ("ArrowUp", "ArrowLeft", "ArrowLeft", "ArrowDown", "ArrowRight") * 4:
            page.keyboard.down(key)
            page.wait_for_timeout(60)
            page.keyboard.up(key)
            tilts.append(page.evaluate(JS_CAMERA_TILT))
        assert app.wait_for(lambda a: a.controller_label == "paper (edited)", timeout=10)
        assert max(tilts) < 0.05, tilts
    finally:
        app.pause()
        app.reset_membership_editor()
        app.set_controller("paper")


def test_the_editor_plots_show_the_current_input_as_a_line(projector):
    """The Editor's term plots carry the input's value now as a red line, which follows
    the robot (sent as a few bytes of CSS, not the plot again)."""
    server, page, _ = projector
    app = server.app
    app.pause()
    app.load_scenario("s1")
    for _ in range(100):
        app.step_once()
    open_tab(page, "Editor")
    js = (
        "() => { const l = document.querySelector(\".fz-term-now[data-group='d_t']\");"
        " const a = l && l.ownerSVGElement.querySelector('.fz-term-area');"
        " if (!l || !a || getComputedStyle(l).display === 'none') return null;"
        " const r = l.getBoundingClientRect(), q = a.getBoundingClientRect();"
        " return (r.left + r.width / 2 - q.left) / q.width; }"
    )

    def at_value() -> bool:
        lo, hi = app.fuzzy_system().inputs[0].range
        want = (app.controller.last_inputs[0] - lo) / (hi - lo)
        shown = page.evaluate(js)
        return shown is not None and abs(shown - want) < 0.01

    page.wait_for_function(f"() => ({js})() !== null", timeout=10_000)
    deadline = time.monotonic() + 10
    while not at_value() and time.monotonic() < deadline:
        page.wait_for_timeout(100)
    assert at_value()
    before = page.evaluate(js)
    for _ in range(200):
        app.step_once()
    deadline = time.monotonic() + 10
    while not at_value() and time.monotonic() < deadline:
        page.wait_for_timeout(100)
    assert at_value() and page.evaluate(js) != before
