"""The viewer's memory and disk against its budget (issue 37 items 4 and 5).

Each phase starts ``fuzzynav``'s viewer server in a child process (s1, paper), connects a
scripted websocket client (viser's own protocol, as ``tests/test_viewer_clients.py``
speaks it: no browser) and floods it as the issue's review did, while this process
samples the child's ``/proc/PID/status`` every 20 ms:

``short``     1,000 uploads of 512 KiB declared, each left one byte short
``kept``      400 uploads of distinct scenario files of 1,000 obstacles each
``adds``      1,500 presses of "Obstacle: Add"
``rrd``       150 presses of Step then Reset, with ``serve --rrd`` (bytes written counted)
``hour``      an hour-long run (3,600 s simulated, as fast as it steps) among 110 moving
              obstacles, a tab connected

For each: the child's resident memory when the client has connected (``base``), its
peak (``VmHWM``), the growth, the growth of its anonymous memory (``RssAnon``: what only
swap could free; the rest is pages of files, the run's log mapped back from its spool
among them), and what ``app/viewer/budget.py`` states for the part the phase fills.
``--code REV`` runs the same phases on the code at git revision REV (``git archive``, as
``bench/bench_viewer.py --baseline`` does) for a before / after.

Run: ``.venv/bin/python bench/bench_viewer_budget.py [--phases short,kept,adds,rrd,hour]
[--repeat 3] [--code HEAD]`` (a few minutes a repeat on 2 cores).
"""

from __future__ import annotations

import argparse
import asyncio
import json
import os
import signal
import statistics
import subprocess
import sys
import tempfile
import threading
import time
import uuid as uuids
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PHASES = ("short", "kept", "adds", "rrd", "hour")
UPLOAD_DECLARED = 512 * 1024


# -- the child: a viewer server --------------------------------------------------------


def _hour_scenario():
    import random

    from fuzzynav.world.scenario import ObstacleSpec, load_scenario

    rng = random.Random(1)
    obstacles = tuple(
        ObstacleSpec(
            (rng.uniform(-300, 300), rng.uniform(30, 300)),
            0.3,
            (rng.uniform(-0.5, 0.5), rng.uniform(-0.5, 0.5)),
        )
        for _ in range(110)
    )
    return load_scenario("s1").replace(obstacles=obstacles, duration_s=3600.0, target=(7000.0, 0.0))


def child(args) -> None:
    from fuzzynav.app.viewer.model import ViewerApp
    from fuzzynav.app.viewer.server import ViewerServer

    scenario = _hour_scenario() if args.child == "hour" else "s1"
    app = ViewerApp(scenario, "p", rrd_path=args.rrd)
    server = ViewerServer(app, port=0)
    c = server.controls
    info = {
        "port": server.port,
        "scenario_upload": c.scenario_upload._impl.uuid,
        "obstacle_buttons": c.obstacle_buttons._impl.uuid,
        "run_buttons": c.run_buttons._impl.uuid,
    }
    Path(args.info).write_text(json.dumps(info))
    stop = threading.Event()
    signal.signal(signal.SIGTERM, lambda *a: stop.set())
    if args.child == "hour":
        while not server.server.get_clients() and not stop.is_set():
            time.sleep(0.05)
        t0 = time.perf_counter()
        while not stop.is_set() and not app.sim.done and app.sim.time_s < 3600.0 - 1e-9:
            with app.lock:
                for _ in range(50):
                    app.driver._step_locked()
            time.sleep(0.0005)  # (the render thread draws meanwhile)
        history = app._history
        Path(args.info + ".done").write_text(
            json.dumps(
                {
                    "sim_s": app.sim.time_s,
                    "wall_s": time.perf_counter() - t0,
                    "history_steps": len(history),
                    "history_bytes": getattr(history, "bytes", None),
                    "stride": getattr(history, "stride", None),
                }
            )
        )
    stop.wait()
    account = getattr(app, "account", None)
    if account is not None:  # what the world's account was charged, by kind
        kinds = ("uploads", "scenarios", "obstacles", "history")
        held = {k: account.held(k) for k in kinds}
        Path(args.info + ".held").write_text(json.dumps(held))
    server.stop()


# -- the parent: a scripted client and the sampler --------------------------------------


class Sampler:
    """The child's resident memory, sampled every 20 ms."""

    def __init__(self, pid: int):
        self.pid = pid
        self.peak_rss = 0
        self.peak_anon = 0
        self.hwm = 0
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)
        self._thread.start()

    def read(self) -> dict:
        out = {}
        with open(f"/proc/{self.pid}/status") as f:
            for line in f:
                key, _, value = line.partition(":")
                if key in ("VmRSS", "VmHWM", "RssAnon"):
                    out[key] = int(value.split()[0]) * 1024
        return out

    def _run(self) -> None:
        while not self._stop.is_set():
            try:
                s = self.read()
            except (FileNotFoundError, ProcessLookupError):
                return
            self.peak_rss = max(self.peak_rss, s.get("VmRSS", 0))
            self.peak_anon = max(self.peak_anon, s.get("RssAnon", 0))
            self.hwm = max(self.hwm, s.get("VmHWM", 0))
            time.sleep(0.02)

    def stop(self) -> None:
        self._stop.set()
        self._thread.join(timeout=2)


def _encode(message) -> bytes:
    import msgspec

    return msgspec.msgpack.encode(message.as_serializable_dict())


async def _client(port: int):
    import viser
    import websockets
    from viser import _messages as m

    ws = await websockets.connect(
        f"ws://127.0.0.1:{port}",
        subprotocols=[f"viser-v{viser.__version__}"],
        max_size=None,
        open_timeout=60,
    )
    camera = m.ViewerCameraMessage(
        wxyz=(1.0, 0.0, 0.0, 0.0),
        position=(0.0, 0.0, 20.0),
        fov=0.78,
        near=0.01,
        far=1000.0,
        image_height=700,
        image_width=900,
        look_at=(0.0, 0.0, 0.0),
        up_direction=(0.0, 0.0, 1.0),
    )
    await ws.send(_encode(camera))

    async def drain():
        try:
            async for _ in ws:
                pass
        except websockets.ConnectionClosed:
            pass

    return ws, asyncio.ensure_future(drain())


def _scenario_toml(k: int, n: int = 1000) -> bytes:
    lines = [f'name = "flood {k}"', "duration_s = 60.0", "[robot]", "start = [0.0, 0.0]"]
    lines += ["[target]", f"position = [{8 + k % 50}.0, 8.0]"]
    for j in range(n):
        lines += ["[[obstacles]]", f"position = [{-500 + (j % 40) * 25}.0, {30 + j // 40 * 5}.0]"]
        lines += ["radius_m = 0.2"]
    return ("\n".join(lines) + "\n").encode()


async def _flood(phase: str, info: dict, ws) -> None:
    from viser import _messages as m

    def press(handle_uuid, value):
        return ws.send(_encode(m.GuiUpdateMessage(uuid=handle_uuid, updates={"value": value})))

    up = info["scenario_upload"]
    if phase == "short":
        for _ in range(1000):
            t = uuids.uuid4().hex
            start = m.FileTransferStartUpload(
                up, t, "a.toml", "text/plain", part_count=2, size_bytes=UPLOAD_DECLARED
            )
            await ws.send(_encode(start))
            await ws.send(_encode(m.FileTransferPart(up, t, 0, b"#" * (UPLOAD_DECLARED - 1))))
    elif phase == "kept":
        for k in range(400):
            body = _scenario_toml(k)
            t = uuids.uuid4().hex
            start = m.FileTransferStartUpload(
                up, t, f"flood{k}.toml", "text/plain", part_count=1, size_bytes=len(body)
            )
            await ws.send(_encode(start))
            await ws.send(_encode(m.FileTransferPart(up, t, 0, body)))
            await asyncio.sleep(0.02)
    elif phase == "adds":
        for _ in range(1500):
            await press(info["obstacle_buttons"], "Add")
            await asyncio.sleep(0.002)
    elif phase == "rrd":
        for _ in range(150):
            await press(info["run_buttons"], "Step")
            await press(info["run_buttons"], "Reset")
            await asyncio.sleep(0.05)


def _cpu_s(pid: int) -> float:
    with open(f"/proc/{pid}/stat") as f:
        fields = f.read().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def _wait_idle(pid: int, loop, limit_s: float = 180.0) -> None:
    """Until the server uses under a fifth of a core over 2 s (at most ``limit_s``)."""
    deadline = time.monotonic() + limit_s
    while time.monotonic() < deadline:
        before = _cpu_s(pid)
        loop.run_until_complete(asyncio.sleep(2.0))
        if _cpu_s(pid) - before < 0.4:
            return


def run_phase(phase: str, code: Path | None, settle_s: float = 3.0) -> dict:
    with tempfile.TemporaryDirectory(prefix="fuzzynav-budget-") as tmp:
        info_path = Path(tmp) / "info.json"
        rrd_dir = Path(tmp) / "rrd"
        rrd_dir.mkdir()
        cmd = [sys.executable, __file__, "--child", phase, "--info", str(info_path)]
        if phase == "rrd":
            cmd += ["--rrd", str(rrd_dir / "session.rrd")]
        env = dict(os.environ)
        if code is not None:
            env.update(PYTHONPATH=str(code), PYTHONDONTWRITEBYTECODE="1")
        proc = subprocess.Popen(cmd, env=env, cwd=tmp, stdout=subprocess.DEVNULL)
        try:
            while not info_path.exists():
                if proc.poll() is not None:
                    raise RuntimeError(f"{phase}: the server ended ({proc.returncode})")
                time.sleep(0.05)
            time.sleep(0.2)
            info = json.loads(info_path.read_text())
            sampler = Sampler(proc.pid)
            loop = asyncio.new_event_loop()
            ws, drain = loop.run_until_complete(_client(info["port"]))
            time.sleep(3.0)  # the page sent, the client settled
            first = sampler.read()
            base, base_anon = first["VmRSS"], first["RssAnon"]
            t0 = time.perf_counter()
            if phase == "hour":
                done = Path(str(info_path) + ".done")
                while not done.exists():
                    loop.run_until_complete(asyncio.sleep(0.2))
                    if proc.poll() is not None:
                        raise RuntimeError("hour: the server ended")
                extra = json.loads(done.read_text())
            else:
                loop.run_until_complete(_flood(phase, info, ws))
                extra = {}
            loop.run_until_complete(asyncio.sleep(settle_s))
            _wait_idle(proc.pid, loop)  # (what the flood queued is handled)
            flood_s = time.perf_counter() - t0
            now = sampler.read()
            sampler.stop()
            loop.run_until_complete(ws.close())
            drain.cancel()
            loop.close()
            written = sum(p.stat().st_size for p in rrd_dir.glob("*.rrd"))
            files = len(list(rrd_dir.glob("*.rrd")))
        finally:
            proc.send_signal(signal.SIGTERM)
            try:
                proc.wait(timeout=30)
            except subprocess.TimeoutExpired:
                proc.kill()
                proc.wait()
        held_path = Path(str(info_path) + ".held")
        held = json.loads(held_path.read_text()) if held_path.exists() else {}
    return {
        "phase": phase,
        "base_MB": base / 1e6,
        "peak_MB": max(sampler.peak_rss, now["VmHWM"]) / 1e6,
        "growth_MB": (max(sampler.peak_rss, now["VmHWM"]) - base) / 1e6,
        "end_MB": now["VmRSS"] / 1e6,
        "anon_base_MB": base_anon / 1e6,
        "anon_peak_MB": sampler.peak_anon / 1e6,
        "anon_growth_MB": (sampler.peak_anon - base_anon) / 1e6,
        "seconds": flood_s,
        "rrd_files": files,
        "rrd_MB": written / 1e6,
        "charged_MB": sum(held.values()) / 1e6 if held else None,
        "held": held,
        **extra,
    }


def stated_budget() -> dict:
    """What app/viewer/budget.py states for each phase (MB), from its constants."""
    try:
        from fuzzynav.app.viewer import budget as b
    except ImportError:
        return {}
    return {
        "short": b.MAX_UPLOADS_IN_FLIGHT * 512 * 1024 / 1e6,
        "kept": b.MAX_KEPT_SCENARIOS * (b.KEPT_SCENARIO_BYTES + 1000 * b.KEPT_OBSTACLE_BYTES) / 1e6,
        "adds": b.MAX_LAYOUT_OBSTACLES * b.ADDED_OBSTACLE_BYTES / 1e6,
        "hour": b.HISTORY_BYTES / 1e6,
        "rrd_minute_files": b.RRD_RUNS_PER_MINUTE,
        "server_total": b.SERVER_BUDGET_BYTES / 1e6,
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--phases", default=",".join(PHASES))
    parser.add_argument("--repeat", type=int, default=1)
    parser.add_argument("--code", default=None, help="git revision to measure instead")
    parser.add_argument("--json", default=None, help="write every run's numbers here")
    parser.add_argument("--child", default=None, help=argparse.SUPPRESS)
    parser.add_argument("--info", default=None, help=argparse.SUPPRESS)
    parser.add_argument("--rrd", default=None, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.child:
        child(args)
        return
    phases = [p for p in args.phases.split(",") if p]
    code_dir = None
    holder = None
    if args.code:
        sys.path.insert(0, str(ROOT / "bench"))
        from bench_viewer import baseline_tree

        holder = tempfile.TemporaryDirectory(prefix="fuzzynav-budget-code-")
        code_dir = baseline_tree(args.code, Path(holder.name))
    budget = stated_budget()
    runs = []
    for _ in range(args.repeat):
        for phase in phases:
            r = run_phase(phase, code_dir)
            runs.append(r)
            print(json.dumps(r), flush=True)
    print(f"\ncode: {args.code or 'this tree'}; load average {os.getloadavg()[0]:.1f}")
    print(
        f"{'phase':8} {'base MB':>8} {'peak MB':>8} {'growth MB':>10} {'rrd files':>9} "
        f"{'rrd MB':>7} {'stated MB':>9}"
    )
    for phase in phases:
        rs = [r for r in runs if r["phase"] == phase]

        def med(key, rs=rs):
            return statistics.median(r[key] for r in rs)

        stated = budget.get(phase)
        print(
            f"{phase:8} {med('base_MB'):8.1f} {med('peak_MB'):8.1f} {med('growth_MB'):10.1f} "
            f"{med('anon_growth_MB'):11.1f} {med('rrd_files'):9.0f} {med('rrd_MB'):7.1f} "
            f"{'' if stated is None else f'{stated:.1f}':>9}"
        )
    if args.json:
        Path(args.json).write_text(json.dumps({"budget": budget, "runs": runs}, indent=1))
    if holder is not None:
        holder.cleanup()


if __name__ == "__main__":
    main()
