"""Screenshots of a recording in rerun's web viewer, in headless Chromium (docs/recordings.md).

    python scripts/recording_screenshot.py run.rrd out.png [--click X,Y] [--wait S]

Serves the file with ``rerun --serve-web`` on free ports of 127.0.0.1, opens the web
viewer in Chromium (Debian's ``chromium`` through playwright, software WebGL), waits
``--wait`` seconds for the recording to load (75 s was enough on 2 busy cores), clicks
where ``--click`` says (a tab: at 1600 x 1000 "plant and inputs" is at 987,50, "fuzzy
logic" at 1296,50), and writes the screenshot at ``--size``.
The rerun processes it started (the ``rerun`` wrapper and its server, one process group)
are ended by that group's id, also after an error; a signal that kills this script
before then leaves them running (``ps``, then ``kill`` their ids).
"""

from __future__ import annotations

import argparse
import base64
import os
import shutil
import signal
import socket
import subprocess
import sys
import time
import urllib.parse
from pathlib import Path


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def wait_for(port: int, timeout_s: float = 30.0) -> None:
    end = time.monotonic() + timeout_s
    while time.monotonic() < end:
        with socket.socket() as s:
            if s.connect_ex(("127.0.0.1", port)) == 0:
                return
        time.sleep(0.2)
    raise RuntimeError(f"nothing listens on port {port} after {timeout_s:g} s")


def screenshot(rrd: Path, out: Path, *, width: int, height: int, tabs=(), wait_s: float = 12.0):
    from playwright.sync_api import sync_playwright

    rerun = Path(sys.executable).with_name("rerun")
    web, grpc = free_port(), free_port()
    server = subprocess.Popen(
        [
            str(rerun),
            "--serve-web",
            str(rrd),
            "--bind",
            "127.0.0.1",  # (rerun binds every interface by default)
            "--web-viewer-port",
            str(web),
            "--port",
            str(grpc),
        ],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
        # its own process group: ``rerun`` is a wrapper that starts the real server as
        # a child, which outlived a terminated wrapper; the group is ended as one
        start_new_session=True,
    )
    try:
        wait_for(web)
        wait_for(grpc)
        source = urllib.parse.quote(f"rerun+http://localhost:{grpc}/proxy", safe="")
        url = f"http://127.0.0.1:{web}?url={source}"
        with sync_playwright() as p:
            browser = p.chromium.launch(
                executable_path=shutil.which("chromium"),
                args=[
                    "--headless",
                    "--no-sandbox",
                    "--disable-gpu",
                    "--disable-background-networking",
                    "--disable-component-update",
                    "--disable-sync",
                    "--use-gl=swiftshader",
                    "--enable-unsafe-swiftshader",
                ],
            )
            page = browser.new_page(viewport={"width": width, "height": height})
            page.goto(url)
            page.wait_for_timeout(wait_s * 1000)
            for tab in tabs:
                x, y = (float(v) for v in tab.split(","))
                page.mouse.click(x, y)
                page.wait_for_timeout(2500)
            # (page.screenshot waits for a quiet frame, which a WebGL app never gives)
            cdp = page.context.new_cdp_session(page)
            shot = cdp.send("Page.captureScreenshot", {"format": "png"})
            out.write_bytes(base64.b64decode(shot["data"]))
            browser.close()
    finally:
        end_group(server)


def end_group(server: subprocess.Popen) -> None:
    """End the server's process group (the wrapper and the server it started)."""
    try:
        os.killpg(server.pid, signal.SIGTERM)
    except ProcessLookupError:
        return
    try:
        server.wait(timeout=10)
    except subprocess.TimeoutExpired:
        os.killpg(server.pid, signal.SIGKILL)
        server.wait(timeout=10)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("rrd", type=Path)
    parser.add_argument("out", type=Path)
    parser.add_argument("--size", default="1600x1000")
    parser.add_argument(
        "--click",
        action="append",
        default=[],
        metavar="X,Y",
        help="click here (a tab) before the screenshot; repeatable",
    )
    parser.add_argument("--wait", type=float, default=12.0, help="seconds to let it load")
    args = parser.parse_args(argv)
    width, height = (int(v) for v in args.size.split("x"))
    screenshot(args.rrd, args.out, width=width, height=height, tabs=args.click, wait_s=args.wait)
    print(f"screenshot written to {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
