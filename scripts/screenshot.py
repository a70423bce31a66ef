"""Make the viewer's screenshots: docs/img/viewer.png, and with ``--all`` the teacher's
guide's (docs/viewer.md): the inference view, the control surface and the editor, each
at 1280x800 and at 1920x1080, the inference view in presentation mode at 1280x800 (a
projector's), and the Editor with the starter driving (docs/img/viewer-<view>-<width>.png).

Starts the viewer in this process on a free port, opens it in headless Chromium
(Debian's ``chromium`` package; ``playwright install`` is not needed), presses Play,
lets the robot drive for a few simulated seconds and saves the page.

    .venv/bin/python scripts/screenshot.py [--scenario s1] [--seconds 14] [--speed 4]
    .venv/bin/python scripts/screenshot.py --all
"""

from __future__ import annotations

import argparse
import shutil
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


CHROMIUM_ARGS = [
    "--no-sandbox",
    "--disable-gpu",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
    "--no-first-run",
]


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--scenario", default="s1")
    parser.add_argument("--controller", default=None, help="default: paper if available")
    parser.add_argument("--seconds", type=float, default=13.0, help="simulated seconds to play")
    parser.add_argument("--tab", default="Inference", help="left panel tab to show")
    parser.add_argument("--speed", type=float, default=4.0, help="speed factor while playing")
    parser.add_argument("--width", type=int, default=1600)
    parser.add_argument("--height", type=int, default=900)
    parser.add_argument("--out", type=Path, default=ROOT / "docs" / "img" / "viewer.png")
    parser.add_argument("--presentation", action="store_true", help="presentation mode on")
    parser.add_argument(
        "--what-if", action="store_true", help="what-if mode on, phi_t set to -1.0 rad"
    )
    parser.add_argument(
        "--starter", action="store_true", help="the starter system drives (the first lesson)"
    )
    parser.add_argument(
        "--all", action="store_true", help="the guide's screenshots (three views, two sizes)"
    )
    args = parser.parse_args(argv)
    if args.all:
        shots = [
            ("inference", "Inference", 1280, 800, False),
            ("inference", "Inference", 1920, 1080, True),
            ("surface", "Surface", 1280, 800, False),
            ("surface", "Surface", 1920, 1080, False),
            ("editor", "Editor", 1280, 800, False),
            ("editor", "Editor", 1920, 1080, False),
            ("whatif", "Inference", 1280, 800, "what-if"),
            ("presentation", "Inference", 1280, 800, True),
            ("starter", "Editor", 1280, 800, "starter"),
        ]
        for view, tab, width, height, mode in shots:
            out = ROOT / "docs" / "img" / f"viewer-{view}-{width}.png"
            extra = {
                True: ["--presentation"],
                "what-if": ["--what-if"],
                "starter": ["--starter"],
            }.get(mode, [])
            code = main(
                [
                    "--tab",
                    tab,
                    "--width",
                    str(width),
                    "--height",
                    str(height),
                    "--out",
                    str(out),
                    "--seconds",
                    "9",
                    *extra,
                ]
            )
            if code:
                return code
        return 0

    chromium = shutil.which("chromium") or shutil.which("chromium-browser")
    if chromium is None:
        print("screenshot: chromium is not installed (apt-get install chromium)", file=sys.stderr)
        return 2
    from playwright.sync_api import sync_playwright

    from fuzzynav.app.viewer.model import ViewerApp
    from fuzzynav.app.viewer.server import ViewerServer

    app = ViewerApp(args.scenario, args.controller)
    server = ViewerServer(app, port=0)
    try:
        with sync_playwright() as pw:
            browser = pw.chromium.launch(
                executable_path=chromium, headless=True, args=CHROMIUM_ARGS
            )
            page = browser.new_page(
                viewport={"width": args.width, "height": args.height}, device_scale_factor=1
            )
            page.goto(server.url)
            page.wait_for_function(
                "() => { const m = window.__viserMutable; return !!(m && m.camera &&"
                " m.nodeRefFromName['/target'] && m.nodeRefFromName['/ground']); }",
                timeout=60_000,
            )
            page.wait_for_timeout(3000)  # the panels dock and the camera refits
            # Headless Chromium renders WebGL in software and viser says so: close that.
            for button in page.locator(".mantine-Notification-closeButton").all():
                button.click()
            if args.starter:
                from fuzzynav.app.viewer.starter import STARTER_LABEL

                app.set_controller(STARTER_LABEL)
            page.get_by_role("button", name="Play").click()
            app.set_speed(args.speed)
            app.wait_for(
                lambda a: a.sim.time_s >= args.seconds or a.sim.done,
                timeout=args.seconds / args.speed * 4 + 20,
            )
            app.set_speed(0.1)  # still running in the picture, barely moving (a Speed button)
            if args.presentation:
                page.get_by_text("View", exact=True).click()
                page.get_by_role("checkbox", name="Presentation mode (large type)").click()
                page.get_by_text("View", exact=True).click()  # closed: the status on top
                page.evaluate("() => document.querySelector('.fz-status')?.scrollIntoView()")
            if args.tab:
                page.get_by_role("tab", name=args.tab).click()
            if args.what_if:
                app.start_what_if()
                app.set_what_if_input(2, -1.0)
                page.get_by_text("What-if", exact=True).click()
            page.wait_for_timeout(1500)  # let the panels and the scene catch up
            args.out.parent.mkdir(parents=True, exist_ok=True)
            page.screenshot(path=str(args.out))
            app.pause()
            browser.close()
    finally:
        server.stop()
    print(
        f"screenshot: wrote {args.out} (t = {app.sim.time_s:.1f} s, "
        f"controller {app.controller_label})"
    )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
