"""The viewer: how long a drag takes to reach the controller, and what the server costs.

1. Drag latency through the app (what a handle's callback calls): from
   ``ViewerApp.move_target`` to the first controller call that sees the new target,
   at 1x real time (a control step every 20 ms), median over many moves.
2. Drag latency through a real browser (headless Chromium; skipped without it), split
   in two: the server side, from the handle's update reaching the app (the drag
   callback) to the first controller call that sees it; and end to end, from the
   playwright mouse move on the target's handle to that controller call. The end-to-end
   number includes headless Chromium's software WebGL handling the pointer event, which
   dominates on a loaded machine.
3. CPU of the server process (``psutil``, this process: server, simulation thread and
   render thread): idle without a tab, idle with a tab, running at 1x and at 10x with a
   tab; and the scene update rate while running.
4. Bandwidth: the bytes each tab receives (every websocket frame, counted in the browser
   by playwright: viser sends uncompressed binary frames, so the frame sizes are the
   bytes on the wire less a few of framing) while the robot drives at 1x with the
   inference view open ("Fuzzy rules" on older code), with one tab and with two; and
   the scene update rate meanwhile. ``--baseline REV`` measures the same for the code
   at git revision REV (main, by default) in the same run, from a ``git archive`` of it
   imported in a subprocess, and prints the two side by side.

Run: ``.venv/bin/python bench/bench_viewer.py [--controller fuzzynav] [--baseline main]``
(about two minutes). Numbers swing with the machine's load; the load average is printed
with them.
"""

from __future__ import annotations

import json
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

import psutil

from fuzzynav.app.viewer.model import ViewerApp
from fuzzynav.app.viewer.server import ViewerServer

ROOT = Path(__file__).resolve().parents[1]

CHROMIUM_ARGS = [
    "--no-sandbox",
    "--disable-gpu",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
    "--no-first-run",
]
CPU_WINDOW_S = 5.0


class ControllerClock:
    """Wall-clock times of the controller's calls (the app's input watcher)."""

    def __init__(self, app: ViewerApp):
        self.times: list[float] = []
        self._lock = threading.Lock()
        app.add_input_watcher(self._seen)

    def _seen(self, inputs, wall_s) -> None:
        with self._lock:
            self.times.append(wall_s)

    def first_after(self, t: float, timeout: float = 2.0) -> float | None:
        deadline = time.perf_counter() + timeout
        while time.perf_counter() < deadline:
            with self._lock:
                later = [w for w in self.times[-50:] if w > t]
            if later:
                return later[0]
            time.sleep(0.0005)
        return None


def api_latency(n: int = 60, controller: str | None = None) -> list[float]:
    app = ViewerApp("s1", controller).start()
    clock = ControllerClock(app)
    try:
        app.play()
        app.wait_for(lambda a: a.sim.time_s > 0.5, timeout=10)
        latencies = []
        for k in range(n):
            time.sleep(0.013 * (k % 7) + 0.005)  # land at varied points of the 20 ms period
            started = time.perf_counter()
            app.move_target((8.0, 8.0 - 0.01 * k))
            # move_target holds the lock a step holds: every step that starts after it
            # returns reads the new target.
            done = time.perf_counter()
            seen = clock.first_after(done)
            if seen is not None:
                latencies.append(seen - started)
        return latencies
    finally:
        app.stop()


JS_HANDLE = """
() => {
  const m = window.__viserMutable, cam = m.camera, node = m.nodeRefFromName['/target'];
  const p = new cam.position.constructor(); node.getWorldPosition(p);
  const v = p.project(cam), r = m.canvas.getBoundingClientRect();
  return [r.left + (v.x + 1) / 2 * r.width, r.top + (1 - v.y) / 2 * r.height];
}
"""


def open_tab(pw, url, chromium):
    browser = pw.chromium.launch(executable_path=chromium, headless=True, args=CHROMIUM_ARGS)
    page = browser.new_context(viewport={"width": 1280, "height": 800}).new_page()
    page.goto(url)
    page.wait_for_function(
        "() => { const m = window.__viserMutable; return !!(m && m.camera &&"
        " m.nodeRefFromName['/target'] && m.nodeRefFromName['/ground']); }",
        timeout=60_000,
    )
    page.wait_for_timeout(3000)  # panels docked, camera refitted
    return browser, page


def cpu_percent(process: psutil.Process, seconds: float, during=None) -> float:
    process.cpu_percent(None)
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        if during is not None:
            during()
        time.sleep(0.1)
    return process.cpu_percent(None)


def browser_latency_and_cpu(chromium: str | None, controller: str | None = None) -> dict:
    out: dict = {}
    process = psutil.Process()
    app = ViewerApp("s1", controller)
    server = ViewerServer(app, port=0)
    clock = ControllerClock(app)
    received: list[float] = []
    move_target = app.move_target

    def timed_move_target(xy):
        received.append(time.perf_counter())  # the drag callback has the update
        move_target(xy)

    app.move_target = timed_move_target  # the handle's callback looks it up at call time
    try:
        time.sleep(1.0)
        out["cpu idle, no tab (%)"] = cpu_percent(process, CPU_WINDOW_S)
        if chromium is None:
            return out
        from playwright.sync_api import sync_playwright

        with sync_playwright() as pw:
            browser, page = open_tab(pw, server.url, chromium)
            out["cpu idle, one tab (%)"] = cpu_percent(process, CPU_WINDOW_S)

            app.play()
            app.wait_for(lambda a: a.sim.time_s > 0.5, timeout=10)
            x, y = page.evaluate(JS_HANDLE)
            page.mouse.move(x, y)
            page.mouse.down()
            server_side, end_to_end = [], []
            for k in range(1, 41):
                n_before = len(received)
                started = time.perf_counter()
                page.mouse.move(x + 4 * k, y + 2 * k)
                deadline = time.perf_counter() + 2.0
                while len(received) == n_before and time.perf_counter() < deadline:
                    time.sleep(0.0005)
                if len(received) == n_before:
                    continue
                arrived = received[n_before]
                seen = clock.first_after(arrived)
                if seen is not None:
                    server_side.append(seen - arrived)
                    end_to_end.append(seen - started)
                time.sleep(0.06)
            page.mouse.up()
            out["browser drag updates measured"] = len(end_to_end)
            if end_to_end:
                out["drag update -> controller input, server side, median (ms)"] = (
                    1e3 * statistics.median(server_side)
                )
                out["drag update -> controller input, server side, max (ms)"] = 1e3 * max(
                    server_side
                )
                out["mouse move -> controller input, end to end, median (ms)"] = (
                    1e3 * statistics.median(end_to_end)
                )

            def keep_running():
                if app.sim.done:
                    app.play()  # starts again from the layout

            app.restore_layout()
            app.play()
            out["cpu running 1x, one tab (%)"] = cpu_percent(process, CPU_WINDOW_S, keep_running)
            out["scene updates running 1x (Hz)"] = server.scene_hz()
            app.set_speed(10.0)
            out["cpu running 10x, one tab (%)"] = cpu_percent(process, CPU_WINDOW_S, keep_running)
            out["scene updates running 10x (Hz)"] = server.scene_hz()
            app.pause()
            browser.close()
    finally:
        server.stop()
    return out


BANDWIDTH_WINDOW_S = 10.0
# The inference view's tab, by the names it has had ("Fuzzy rules" before issue 18).
INFERENCE_TABS = ("Inference", "Fuzzy rules")


class SentBytes:
    """Bytes the server sends to each websocket connection (viser's frames are binary and
    uncompressed at the websocket level, so this is what goes on the wire less a few
    bytes of framing per message). Counted by wrapping ``ServerConnection.send`` (the
    page's socket lives in a web worker, out of playwright's sight)."""

    def __init__(self):
        from websockets.asyncio.server import ServerConnection

        self.by_connection: dict[int, int] = {}
        self._cls = ServerConnection
        self._original = ServerConnection.send
        counts = self.by_connection
        original = self._original

        async def send(conn, message, *args, **kwargs):
            counts[id(conn)] = counts.get(id(conn), 0) + len(message)
            return await original(conn, message, *args, **kwargs)

        ServerConnection.send = send

    def total(self) -> dict[int, int]:
        return dict(self.by_connection)

    def close(self) -> None:
        self._cls.send = self._original


def bandwidth(chromium: str, controller: str | None = None, tabs: int = 1) -> dict:
    """Bytes per second each tab receives while the robot drives at 1x with the inference
    view open, and the scene update rate meanwhile (``tabs`` tabs connected)."""
    from playwright.sync_api import sync_playwright

    sent = SentBytes()
    app = ViewerApp("s1", controller)
    server = ViewerServer(app, port=0)
    out: dict = {}
    try:
        with sync_playwright() as pw:
            browser = pw.chromium.launch(
                executable_path=chromium, headless=True, args=CHROMIUM_ARGS
            )
            pages = []
            for _ in range(tabs):
                page = browser.new_context(viewport={"width": 1280, "height": 800}).new_page()
                page.goto(server.url)
                page.wait_for_function(
                    "() => { const m = window.__viserMutable; return !!(m && m.camera &&"
                    " m.nodeRefFromName['/ground']); }",
                    timeout=60_000,
                )
                pages.append(page)
            time.sleep(3.0)
            for page in pages:
                for name in INFERENCE_TABS:
                    tab = page.get_by_role("tab", name=name)
                    if tab.count():
                        tab.first.click()
                        break
            app.play()
            app.wait_for(lambda a: a.sim.time_s > 1.0, timeout=20)
            before = sent.total()
            started = time.perf_counter()
            hz = []
            while time.perf_counter() - started < BANDWIDTH_WINDOW_S:
                if app.sim.done:
                    app.play()  # again from the layout
                time.sleep(0.5)
                hz.append(server.scene_hz())
            elapsed = time.perf_counter() - started
            after = sent.total()
            per_tab = [(after[k] - before.get(k, 0)) / elapsed / 1e3 for k in after]
            if len(per_tab) != tabs:
                raise RuntimeError(f"{len(per_tab)} connections seen, {tabs} tabs opened")
            out["kB/s per tab"] = statistics.median(per_tab)
            out["scene Hz"] = statistics.median(hz)
            app.pause()
            browser.close()
    finally:
        server.stop()
        sent.close()
    return out


def bandwidth_table(chromium: str, controller: str | None) -> dict:
    one = bandwidth(chromium, controller, tabs=1)
    two = bandwidth(chromium, controller, tabs=2)
    return {
        "1x, inference view open, one tab: kB/s per tab": one["kB/s per tab"],
        "1x, inference view open, one tab: scene updates (Hz)": one["scene Hz"],
        "1x, two tabs: kB/s per tab (bytes per client)": two["kB/s per tab"],
        "1x, two tabs: scene updates (Hz)": two["scene Hz"],
    }


def baseline_tree(revision: str, into: Path) -> Path:
    """The code at ``revision`` as an importable ``fuzzynav`` package under ``into``
    (``git archive``; the package-dir mapping rebuilt with symlinks). Returns the folder
    to put on PYTHONPATH."""
    src = into / "src"
    src.mkdir(parents=True)
    archive = subprocess.run(
        ["git", "-C", str(ROOT), "archive", revision], check=True, capture_output=True
    ).stdout
    subprocess.run(["tar", "-x", "-C", str(src)], input=archive, check=True)
    pkg = into / "path" / "fuzzynav"
    pkg.mkdir(parents=True)
    for f in (src / "fuzzynav").iterdir():
        (pkg / f.name).symlink_to(f)
    for sub, folder in (
        ("app", "app"),
        ("world", "world"),
        ("controller", "controller"),
        ("assets", "assets"),
    ):
        (pkg / sub).symlink_to(src / folder)
    return into / "path"


def baseline_numbers(revision: str, controller: str | None) -> dict:
    """Run this script's bandwidth measurement on the code at ``revision``."""
    with tempfile.TemporaryDirectory(prefix="fuzzynav-baseline-") as tmp:
        path = baseline_tree(revision, Path(tmp))
        env = dict(os.environ, PYTHONPATH=str(path), PYTHONDONTWRITEBYTECODE="1")
        args = [sys.executable, str(Path(__file__).resolve()), "--bandwidth-json"]
        if controller:
            args += ["--controller", controller]
        done = subprocess.run(args, env=env, capture_output=True, text=True, cwd=tmp)
        if done.returncode != 0:
            raise RuntimeError(f"baseline {revision} failed:\n{done.stderr[-2000:]}")
        return json.loads(done.stdout.strip().splitlines()[-1])


def main(argv=None) -> None:
    import argparse

    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument(
        "--controller", default=None, help="controller in the viewer (default: the viewer's, paper)"
    )
    parser.add_argument(
        "--baseline",
        default="main",
        help="git revision whose bandwidth is measured beside this tree's ('' to skip)",
    )
    parser.add_argument("--bandwidth-json", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    chromium = shutil.which("chromium") or shutil.which("chromium-browser")
    if args.bandwidth_json:  # the baseline's subprocess: its numbers as one JSON line
        import fuzzynav.app.viewer.model as viewer_module

        numbers = bandwidth_table(chromium, args.controller)
        numbers["code"] = str(Path(viewer_module.__file__).resolve().parent)
        print(json.dumps(numbers))
        return
    load = os.getloadavg()
    print(
        f"bench_viewer: load average {load[0]:.1f} on {os.cpu_count()} cores, "
        f"controller {args.controller or 'default'}"
    )
    latencies = api_latency(controller=args.controller)
    print(
        f"drag latency, app API -> controller input: median {1e3 * statistics.median(latencies):.1f} ms, "
        f"max {1e3 * max(latencies):.1f} ms over {len(latencies)} moves at 1x "
        f"(control period 20 ms)"
    )
    if chromium is None:
        print("chromium not installed: browser latency, CPU and bandwidth skipped")
    results = browser_latency_and_cpu(chromium, args.controller)
    for key, value in results.items():
        print(f"{key}: {value:.1f}" if isinstance(value, float) else f"{key}: {value}")
    if chromium is not None:
        ours = bandwidth_table(chromium, args.controller)
        theirs = baseline_numbers(args.baseline, args.controller) if args.baseline else {}
        print(f"bandwidth (this tree{f' | {args.baseline}' if theirs else ''}):")
        for key, value in ours.items():
            other = f" | {theirs[key]:.1f}" if key in theirs else ""
            print(f"  {key}: {value:.1f}{other}")
    load = os.getloadavg()
    print(f"bench_viewer: load average at the end {load[0]:.1f}")


if __name__ == "__main__":
    main()
