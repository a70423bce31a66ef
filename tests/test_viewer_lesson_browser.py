"""Issue 38 in a real headless Chromium: the lesson a teacher gives with the viewer
(paused, the page answers every drag at once; the rules readable; the classroom's
Teacher folder). The helpers are tests/test_viewer_browser.py's."""

from __future__ import annotations

import os

import numpy as np
import pytest
from test_viewer_browser import (  # noqa: F401  (browser: a fixture)
    JS_NODE_SCREEN,
    browser,
    obstacle_node,
    open_page,
    open_tab,
)

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
