"""The viewer in a real headless Chromium (Debian's ``chromium`` + the playwright package).

Skipped when Chromium is not installed, except when the environment variable CI is set:
CI installs it, so there a missing browser is a failure, not a skip.
"""

from __future__ import annotations

import io
import math
import os
import shutil

import numpy as np
import pytest
from net_helpers import port_is_free

from fuzzynav.app.viewer import ViewerApp

pytestmark = [pytest.mark.browser, pytest.mark.timeout(120)]

CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
CHROMIUM_ARGS = [
    "--no-sandbox",
    "--disable-gpu",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
    "--no-first-run",
]
VIEWPORT = {"width": 1280, "height": 800}

# Screen position of the target handle's ground-plane square (the gizmo's plane slider),
# and of the same point moved by (dx, dy) metres in the world.
JS_TARGET_HANDLE = """
(args) => {
  const m = window.__viserMutable;
  const cam = m.camera, root = m.nodeRefFromName[''], handle = m.nodeRefFromName['/target'];
  let plane = null;
  handle.traverse((c) => {
    if (!plane && c.isMesh && c.geometry && c.geometry.type === 'PlaneGeometry') plane = c;
  });
  if (plane === null) return null;
  const V = cam.position.constructor;
  const rect = m.canvas.getBoundingClientRect();
  const screen = (w) => {
    const v = w.clone().project(cam);
    return [rect.left + (v.x + 1) / 2 * rect.width, rect.top + (1 - v.y) / 2 * rect.height];
  };
  cam.updateMatrixWorld(); root.updateMatrixWorld(true);
  const p = new V(); plane.getWorldPosition(p);
  const offset = root.localToWorld(new V(args.dx, args.dy, 0)).sub(root.localToWorld(new V(0, 0, 0)));
  return {from: screen(p), to: screen(p.clone().add(offset))};
}
"""

JS_SCENE_READY = """
() => {
  const m = window.__viserMutable;
  return !!(m && m.camera && m.canvas && m.nodeRefFromName['/target'] && m.nodeRefFromName['/robot/body']
            && m.nodeRefFromName['/ground']);
}
"""


@pytest.fixture(scope="module")
def browser():
    if CHROMIUM is None:
        if os.environ.get("CI"):
            pytest.fail("CI is set but chromium is not installed: the browser tests must run")
        pytest.skip("chromium is not installed (apt-get install chromium)")
    try:
        from playwright.sync_api import sync_playwright
    except ImportError:
        if os.environ.get("CI"):
            raise
        pytest.skip("the playwright package is not installed")
    with sync_playwright() as pw:
        b = pw.chromium.launch(executable_path=CHROMIUM, headless=True, args=CHROMIUM_ARGS)
        yield b
        b.close()


@pytest.fixture(scope="module")
def shared(browser):
    """One server and one connected tab for the module (a page load costs seconds of
    software WebGL); each test starts from scenario s1 at t = 0, paused."""
    from fuzzynav.app.viewer_ui import ViewerServer

    app = ViewerApp("s1", "p")
    server = ViewerServer(app, port=0)
    page = open_page(browser, server.url)
    yield server, page
    page.context.close()
    server.stop()


@pytest.fixture
def served(shared):
    server, page = shared
    app = server.app
    app.pause()
    app.set_speed(1.0)
    app.load_scenario("s1")  # back to the file's layout, t = 0
    page.wait_for_timeout(300)
    return server


@pytest.fixture
def page(shared, served):
    return shared[1]


def open_page(browser, url):
    page = browser.new_context(viewport=VIEWPORT).new_page()
    page.goto(url)
    page.wait_for_function(JS_SCENE_READY, timeout=30_000)
    # The side panels dock, the canvas narrows, the server refits the camera to it.
    page.wait_for_function(
        "() => { const m = window.__viserMutable; const r = m.canvas.getBoundingClientRect();"
        " return r.width < window.innerWidth * 0.7 && Math.abs(m.camera.aspect - r.width / r.height) < 0.01; }",
        timeout=30_000,
    )
    page.wait_for_timeout(500)
    return page


def canvas_pixels(page) -> np.ndarray:
    from PIL import Image

    rect = page.evaluate(
        "() => { const r = window.__viserMutable.canvas.getBoundingClientRect();"
        " return {x: r.left, y: r.top, width: r.width, height: r.height}; }"
    )
    png = page.screenshot(clip=rect)
    return np.asarray(Image.open(io.BytesIO(png)).convert("RGB"), dtype=float)


def drag_target(page, dx_m: float, dy_m: float, steps: int) -> None:
    """Drag the target's plane handle by (dx_m, dy_m) in the world, as a user would: the
    mouse pressed on the handle, moved in ``steps`` steps, released."""
    points = page.evaluate(JS_TARGET_HANDLE, {"dx": dx_m, "dy": dy_m})
    assert points is not None, "no plane handle found on the target's gizmo"
    (x0, y0), (x1, y1) = points["from"], points["to"]
    page.mouse.move(x0, y0)
    page.mouse.down()
    for k in range(1, steps + 1):
        page.mouse.move(x0 + (x1 - x0) * k / steps, y0 + (y1 - y0) * k / steps)
        page.wait_for_timeout(15)
    page.mouse.up()


def test_page_connects_and_draws_the_arena(served, page):
    assert len(served.server.get_clients()) == 1
    pixels = canvas_pixels(page)
    assert pixels.shape[0] > 300 and pixels.shape[1] > 300
    # Not blank: the grid, the robot, the obstacles and the target give contrast and colour.
    assert pixels.std() > 15, pixels.std()
    colours = np.unique((pixels // 8).reshape(-1, 3), axis=0)
    assert len(colours) > 50, len(colours)
    # The Husky yellow and the target red are on screen.
    r, g, b = pixels[..., 0], pixels[..., 1], pixels[..., 2]
    assert np.sum((r > 200) & (g > 140) & (g < 215) & (b < 90)) > 50
    assert np.sum((r > 170) & (g < 90) & (b < 90)) > 50


def test_pressing_play_advances_simulation_time(served, page):
    app = served.app
    assert app.sim.time_s == 0.0
    page.get_by_role("button", name="Play").click()
    assert app.wait_for(lambda a: a.sim.time_s > 0.5, timeout=15), app.message
    page.wait_for_function(
        "() => { const m = document.body.innerText.match(/t = +([0-9.]+) s/); "
        "return m && parseFloat(m[1]) > 0.3; }",
        timeout=15_000,
    )
    page.get_by_role("button", name="Pause").click()
    assert app.wait_for(lambda a: not a.playing, timeout=10)


def test_dragging_the_target_handle_changes_where_the_robot_goes(served, page):
    app = served.app
    drag_target(page, 0.0, -6.0, steps=20)
    assert app.wait_for(lambda a: a.sim.arena.target[1] < 4.0, timeout=10), app.sim.arena.target
    tx, ty = app.sim.arena.target
    # Moved straight down by about 6 m, in the ground plane.
    assert abs(tx - 8.0) < 0.5 and abs(ty - 2.0) < 0.8, (tx, ty)

    page.get_by_role("button", name="Play").click()
    app.set_speed(5.0)
    assert app.wait_for(lambda a: a.sim.time_s >= 5.0, timeout=30), app.message
    app.pause()
    driven = np.array(app.sim.arena.pose[:2])
    # The same robot, same controller, the target left where it was.
    reference = ViewerApp("s1", "p")
    while reference.sim.time_s < app.sim.time_s - 1e-9:
        reference.step_once()
    untouched = np.array(reference.sim.arena.pose[:2])
    assert np.linalg.norm(driven - untouched) > 0.5, (driven, untouched)
    # It turned less to the left, and it heads for where the target is now.
    assert driven[1] < untouched[1] - 0.3, (driven, untouched)

    def heading_error(pose):
        x, y, heading = pose
        error = math.atan2(ty - y, tx - x) - heading
        return abs(math.atan2(math.sin(error), math.cos(error)))

    assert heading_error(app.sim.arena.pose) < heading_error(reference.sim.arena.pose) - 0.1


def test_a_target_dropped_on_an_obstacle_is_flagged_in_the_page(served, page):
    # s1's third obstacle is at (7.5, 6.4): drag the target (8, 8) onto it.
    app = served.app
    drag_target(page, -0.5, -1.6, steps=10)
    assert app.wait_for(lambda a: "cannot get there" in a.message, timeout=10), (
        app.sim.arena.target,
        app.message,
    )
    page.wait_for_function(
        "() => document.body.innerText.includes('cannot get there')", timeout=10_000
    )


def test_two_clients_share_one_world_and_closing_one_does_not_stop_it(browser, served, page):
    app = served.app
    first, second = open_page(browser, served.url), page
    assert len(served.server.get_clients()) == 2
    first.get_by_role("button", name="Play").click()
    assert app.wait_for(lambda a: a.sim.time_s > 0.5, timeout=15)
    # The other tab sees the same clock.
    second.wait_for_function(
        "() => { const m = document.body.innerText.match(/t = +([0-9.]+) s/); "
        "return m && parseFloat(m[1]) > 0.3; }",
        timeout=15_000,
    )
    first.context.close()  # the tab that pressed Play goes away
    t = app.sim.time_s
    assert app.wait_for(lambda a: a.sim.time_s > t + 0.5, timeout=15)
    assert app.playing
    assert app.wait_for(lambda a: len(served.server.get_clients()) == 1, timeout=10)
    # ... and the remaining tab keeps showing the clock going on.
    second.wait_for_function(
        "(t) => { const m = document.body.innerText.match(/t = +([0-9.]+) s/); "
        "return m && parseFloat(m[1]) > t; }",
        arg=t,
        timeout=15_000,
    )


def test_the_server_stops_and_frees_its_port(browser):
    from fuzzynav.app.viewer_ui import ViewerServer

    app = ViewerApp("s1", "p")
    server = ViewerServer(app, port=0)
    port = server.port
    try:
        page = browser.new_context(viewport=VIEWPORT).new_page()
        page.goto(server.url)
        page.wait_for_function(
            "() => !!(window.__viserMutable && window.__viserMutable.camera)", timeout=30_000
        )
        assert app.wait_for(lambda a: len(server.server.get_clients()) == 1, timeout=10)
        assert not port_is_free(port)
    finally:
        server.stop()
    assert port_is_free(port)
    # The tab notices: the green "connected" cloud of the title bar fades away.
    page.wait_for_function(
        "() => { const ok = document.querySelector('svg.tabler-icon-cloud-check');"
        " return !ok || getComputedStyle(ok).opacity === '0'; }",
        timeout=30_000,
        polling=200,
    )
    # A new viewer gets the very same port (viser would silently take the next one).
    again = ViewerServer(ViewerApp("s1", "p"), port=port)
    try:
        assert again.port == port
    finally:
        again.stop()
    page.context.close()


def test_unticking_a_fuzzynav_part_in_the_page_switches_it_off(served, page):
    """A teacher switches fuzzynav's edge following off in the panel: the running
    controller has it off at once, and ticking it again switches it back on."""
    app = served.app
    app.set_controller("fuzzynav")
    try:
        folder = page.get_by_text("fuzzynav's parts (untick: off)")
        folder.wait_for(timeout=15_000)
        folder.click()
        box = page.get_by_role("checkbox", name="edge following")
        box.wait_for(timeout=15_000)
        assert box.is_checked()
        box.click()
        assert app.wait_for(lambda a: a.parts_off == ("edge following",), timeout=10)
        assert app.controller.inner.parts_off == ("edge following",)
        page.wait_for_function(
            "() => document.body.innerText.includes('fuzzynav (without edge following)')",
            timeout=15_000,
        )
        box.click()
        assert app.wait_for(lambda a: a.parts_off == (), timeout=10)
    finally:
        app.set_part("edge following", True)
        app.set_controller("p")
