"""The viser side of the viewer: the 3D scene, the control panel, the plots and the
teaching panel (see :mod:`app.viewer.model` for what the page shows and why).

:class:`ViewerServer` owns the viser server and one render thread. GUI callbacks only
call :class:`app.viewer.model.ViewerApp` methods; the render thread alone writes the scene,
from :meth:`ViewerApp.snapshot`, at up to ``FRAME_HZ`` while something changes and not
at all while nothing does. The plots, the status line and the teaching panel are redrawn
at ``PANEL_HZ``.
"""

from __future__ import annotations

import html
import math
import threading
import time
from collections import deque

import numpy as np
import viser

from fuzzynav.app.viewer import views
from fuzzynav.app.viewer.model import (
    NOISE_RANGE_M,
    SAFE_DISTANCE_M,
    Snapshot,
    ViewerApp,
    ViewerError,
)
from fuzzynav.app.viewer.origin_guard import guarded_server_start
from fuzzynav.resources import shorten
from fuzzynav.world.perception import GEOMETRIES, PERCEPTION_MODES

FRAME_HZ = 30.0
HUSKY_FOOTPRINT_M = (0.99, 0.67)  # drawn; the world's own footprint is the arena's
PANEL_HZ = 4.0  # the status line and the inference view
PLOT_HZ = 2.0  # the signal plots (viser sends their whole window as float64 each time)
PLOT_POINTS = 120
TRAIL_CHUNK = 8  # trail points per scene node: a frame re-sends at most this many
BEAM_STEP_M = 0.02  # beams are drawn to 2 cm
SPEED_CHOICES = ("0.1", "0.25", "0.5", "1", "3", "10")
TOP_DOWN_TOLERANCE_RAD = math.radians(1.5)
NORMAL_WIDTHS = (400, 330)  # the left and right panels (px)
PRESENTATION_WIDTHS = (720, 420)  # ... in presentation mode
FIT_WINDOW_S = 20.0
HISTORY_STEP_S = 0.02  # the time slider's step: one control period
TIMELINE_PERIOD_S = 2.0  # the rule-firing strip is redrawn at most this often while playing
SURFACE_INPUTS = ("d_t", "d_o", "phi_t", "phi_o")
SURFACE_RANGES = ((0.0, 12.0), (0.0, 4.0), (-math.pi, math.pi), (-math.pi / 2, math.pi / 2))
EDITOR_STEP = 0.01  # the editor's sliders (two decimals: the number boxes show them whole)
# The Editor's inference choices (issue 27): field of controller.inference.Inference,
# label, and what the choice does, in words (MATLAB's names are the options).
EDITOR_CHOICES = (
    ("and_method", "AND", "how a rule joins its clauses: min, or prod (their product)"),
    (
        "imp_method",
        "Implication",
        "a rule's output set: min (its term clipped at the rule's strength) or prod (scaled by it)",
    ),
    (
        "agg_method",
        "Aggregation",
        "how the rules' sets combine: max, sum (may pass 1), probor (a + b - ab)",
    ),
    (
        "defuzz_method",
        "Defuzzification",
        "centroid, bisector (half the area each side), mom / som / lom: mean, smallest or "
        "largest (in magnitude) of the points where the set is highest",
    ),
)
# What the editor's numbers do, in words (the Husky's 27-number layout, controller/paper.py,
# and the paper geometry's partition layout, controller/paper_partition.py).
EDITOR_LABELS = {
    "d_t.a0": "VS full to, S starts (m)",
    "d_t.w1": "S peak after that (m)",
    "d_t.w2": "M centre after S (m)",
    "d_t.w3": "L peak after M (m)",
    "d_t.w4": "VL full after L (m)",
    "d_t.c0": "first centre (m)",
    "d_o.b0": "near full to (m)",
    "d_o.w1": "medium centre after (m)",
    "d_o.w2": "far full after that (m)",
    "phi_t.peak": "P, N peak (rad)",
    "phi_t.width": "VP, VN full after (rad)",
    "phi_t.zero": "Z half-width (rad)",
    "phi_t.foot": "P starts at (× peak)",
    "phi_o.peak": "P, N peak (rad)",
    "phi_o.width": "VP, VN peak after (rad)",
    "phi_o.zero": "Z half-width (rad)",
    "phi_o.foot": "P starts at (× peak)",
    "phi_o.tail": "VP, VN end after (rad)",
    "v.vs_end": "VS full to (V)",
    "v.vs_ramp": "VS falls over (V)",
    "v.s_offset": "S centre after VS (V)",
    "v.m_offset": "M centre after S (V)",
    "v.l_offset": "L centre after M (V)",
    "v.s_half": "S half-width (V)",
    "v.m_half": "M half-width (V)",
    "v.l_half": "L half-width (V)",
    "v.vl_offset": "VL starts after L (V)",
    "v.vl_ramp": "VL rises over (V)",
}  # a new tab's camera follows its canvas's shape for this long
GHOST_GREY = (148, 163, 184)

# Colours (RGB 0-255).
HUSKY_YELLOW = (250, 190, 20)
HUSKY_DARK = (40, 40, 40)
STATIC_COLOUR = (96, 112, 136)
MOVING_COLOUR = (234, 88, 12)
TARGET_RED = (220, 38, 38)
TRAIL_BLUE = (37, 99, 235)
RING_OK = (217, 119, 6)
RING_ALERT = (220, 38, 38)
NO_ECHO = (175, 175, 175)
MEMORY_PURPLE = (147, 51, 234)  # fuzzynav's remembered echoes
STEER_GREEN = (22, 163, 74)  # the bearing its planner steers to
GROUND = (255, 255, 255)
TARGET_INPUT = (13, 148, 136)  # d_t, phi_t on the robot (views.TARGET_INPUT)
OBSTACLE_INPUT = (192, 38, 211)  # d_o, phi_o (views.OBSTACLE_INPUT)
ARC_SEGMENTS = 8
INPUT_SEGMENTS = ARC_SEGMENTS + 2  # a distance, a radius along the heading, an arc

OBSTACLE_HEIGHT_M = 0.5
# The target is drawn (and picked) above the obstacles: dropped on one, it is still
# the target that a press on it grabs.
TARGET_HEIGHT_M = OBSTACLE_HEIGHT_M + 0.08

COLOUR_KEY = [
    ("#dc2626", "beam: echo within 0.25 m (the safe distance)"),
    ("#f59e0b", "beam: echo at about 1 m"),
    ("#16a34a", "beam: echo at 3 m or more"),
    ("#afafaf", "beam: no echo (thin, full range)"),
    ("#2563eb", "trail of this run"),
    ("#94a3b8", "ghost: the previous run's trail"),
    ("#9333ea", "fuzzynav's echo memory (points it remembers)"),
    ("#16a34a", "fuzzynav's planned bearing (thick green line)"),
    ("#d97706", "safe-distance ring (red: an obstacle inside)"),
    ("#0d9488", "d_t (line to the target) and phi_t (arc from the heading)"),
    ("#c026d3", "d_o (from the footprint's edge) and phi_o (arc from the heading)"),
    ("#606f88", "static obstacle"),
    ("#ea580c", "moving obstacle"),
    ("#dc2626", "target (drag it)"),
]


def colour_key_html() -> str:
    rows = "".join(
        f"<div style='display:flex;align-items:center;gap:6px'><span style='display:inline-block;"
        f"width:22px;height:5px;border-radius:2px;background:{c}'></span>{html.escape(t)}</div>"
        for c, t in COLOUR_KEY
    )
    return f"<div class='fz-colour-key' style='font-size:0.8em;padding:0 6px'>{rows}</div>"


# Paper Table 4, proposed method (S1, S2, S3): shown beside our numbers for the shipped
# scenarios when their layout has not been edited.
PAPER_TABLE4 = {
    "s1": {
        "path_length_m": 11.8332,
        "mad_m": 0.3653,
        "rmse_m": 0.4825,
        "min_center_distance_m": 0.2557,
    },
    "s2": {
        "path_length_m": 11.8672,
        "mad_m": 0.5727,
        "rmse_m": 0.7449,
        "min_center_distance_m": 0.3834,
    },
    "s3": {
        "path_length_m": 11.8263,
        "mad_m": 0.6298,
        "rmse_m": 0.7474,
        "min_center_distance_m": 0.6398,
    },
}


def yaw_wxyz(theta: float) -> tuple[float, float, float, float]:
    return (math.cos(0.5 * theta), 0.0, 0.0, math.sin(0.5 * theta))


def reading_colour(distance_m: float) -> tuple[int, int, int]:
    """Red within the safe distance, through amber, to green at 3 m; grey = no echo."""
    if not math.isfinite(distance_m):
        return NO_ECHO
    stops = [
        (0.0, (220, 38, 38)),
        (SAFE_DISTANCE_M, (220, 38, 38)),
        (1.0, (245, 158, 11)),
        (3.0, (22, 163, 74)),
    ]
    if distance_m >= stops[-1][0]:
        return stops[-1][1]
    for (d0, c0), (d1, c1) in zip(stops, stops[1:]):
        if distance_m <= d1:
            f = 0.0 if d1 == d0 else (distance_m - d0) / (d1 - d0)
            return tuple(int(round(a + f * (b - a))) for a, b in zip(c0, c1))
    return stops[-1][1]


def rounded_rectangle(length: float, width: float, offset: float, n_arc: int = 8) -> np.ndarray:
    """Closed outline (N, 2) of a rectangle grown by ``offset`` (round corners)."""
    hx, hy = 0.5 * length, 0.5 * width
    points = []
    for cx, cy, a0 in (
        (hx, hy, 0.0),
        (-hx, hy, 0.5 * math.pi),
        (-hx, -hy, math.pi),
        (hx, -hy, 1.5 * math.pi),
    ):
        for k in range(n_arc + 1):
            a = a0 + 0.5 * math.pi * k / n_arc
            points.append((cx + offset * math.cos(a), cy + offset * math.sin(a)))
    points.append(points[0])
    return np.array(points)


def polyline_segments(points_xy: np.ndarray, z: float) -> np.ndarray:
    """(N, 2) polyline -> (N - 1, 2, 3) line segments at height z."""
    p = np.asarray(points_xy, dtype=np.float32)
    seg = np.zeros((max(len(p) - 1, 0), 2, 3), dtype=np.float32)
    seg[:, 0, :2] = p[:-1]
    seg[:, 1, :2] = p[1:]
    seg[:, :, 2] = z
    return seg


def arena_bounds(snap: Snapshot, start) -> tuple[int, int, int, int]:
    """Even-sized integer bounds holding start, target and obstacles, with a margin."""
    xs = [start[0], snap.target[0], snap.pose[0]] + [o.xy[0] for o in snap.obstacles]
    ys = [start[1], snap.target[1], snap.pose[1]] + [o.xy[1] for o in snap.obstacles]
    x0, x1 = math.floor(min(xs) - 2.0), math.ceil(max(xs) + 2.0)
    y0, y1 = math.floor(min(ys) - 2.0), math.ceil(max(ys) + 2.0)
    size = max(x1 - x0, y1 - y0, 10)
    size += size % 2
    cx, cy = round(0.5 * (x0 + x1)), round(0.5 * (y0 + y1))
    half = size // 2
    return cx - half, cx + half, cy - half, cy + half


def _fmt(value, unit: str = "", digits: int = 2) -> str:
    if value is None or (isinstance(value, float) and not math.isfinite(value)):
        return "—"
    if isinstance(value, bool):
        return "yes" if value else "no"
    if isinstance(value, (int, float)):
        return f"{value:.{digits}f}{(' ' + unit) if unit else ''}"
    return str(value)


def _xy(position) -> np.ndarray:
    """The first two numbers of a position a client sent, or ViewerError (an empty or
    malformed position froze the dragged thing's drawing)."""
    try:
        xy = np.array([float(v) for v in list(position)[:2]], dtype=float)
    except (TypeError, ValueError):
        xy = np.zeros(0)
    if xy.shape != (2,):
        raise ViewerError(f"position {shorten(repr(position), 60)}: must be two numbers")
    return xy


class ClientSurface:
    """One tab's own scene and GUI (viser's client-scoped API), in the shape of the
    server that :class:`ViewerServer` draws on: classroom mode gives every tab a world
    of its own (:mod:`app.viewer.classroom`)."""

    def __init__(self, server, client):
        import types

        self._server, self._client = server, client
        self.scene, self.gui = client.scene, client.gui
        self.initial_camera = types.SimpleNamespace()  # the tab's own camera is fitted

    def get_clients(self) -> dict:
        cid = self._client.client_id
        return {cid: self._client} if cid in self._server.get_clients() else {}

    def atomic(self):
        return self._client.atomic()

    def get_port(self) -> int:
        return self._server.get_port()

    def on_client_connect(self, callback) -> None:
        callback(self._client)

    def on_client_disconnect(self, callback) -> None:
        pass  # the classroom server ends the tab's world

    def stop(self) -> None:
        pass  # the server is the classroom's


class ViewerServer:
    """The viser server showing a :class:`ViewerApp` (which it starts and stops)."""

    _RESULT_PENDING = (
        "<div style='color:#64748b;font-size:0.85em'>The outcome and the "
        "paper's Table 4 metrics appear here when a run ends.</div>"
    )

    def __init__(self, app: ViewerApp, host: str = "127.0.0.1", port: int = 8080, *, surface=None):
        self.app = app
        self.host = host
        if surface is None:
            with guarded_server_start(host):  # only its own page may connect (origin_guard)
                self.server = viser.ViserServer(
                    host=host, port=port, label="fuzzynav", verbose=False
                )
        else:  # one tab's own world (classroom mode): its scene and GUI only
            self.server = surface
        self.port = self.server.get_port()
        from fuzzynav.app.viewer.guards import install_message_guards
        from fuzzynav.app.viewer.model import MAX_UPLOAD_BYTES

        # only a component's value, finite numbers, uploads refused at their declared size
        install_message_guards(
            self.server, MAX_UPLOAD_BYTES, lambda text: app._notice(text, "warning")
        )
        self._stop = threading.Event()
        self._camera_fits: dict[int, float] = {}
        self._dragging: set[str] = set()
        self._frame_times: deque[float] = deque(maxlen=120)
        self._obstacle_nodes: dict[tuple[int, int], dict] = {}
        self._trail_nodes: list = []
        self._current_trail = None
        self._trail_points = np.zeros((0, 2))
        self._trail_index = 0
        self._drawn_run = -1
        self._bounds = None
        self._last_target = None
        self._last_ranges = None
        self._ring_alert = None
        self._last_panel_version = -1
        self._last_metrics_run = -1
        self._distance_top = None
        self._start_xy = tuple(app.sim.scenario.start)
        self.view_3d = False
        self._fitting_until: dict[int, float] = {}
        self._fit_window: dict[int, float] = {}
        self.show_handles = False
        self.presentation = False
        self._ghost_drawn = -1
        self.ghost_node = None
        self._system_key = None
        self._system_count = 0
        self._uid = "fz0"
        self._surface_key = None
        self._surface_planes: list = []
        self._last_inference = None
        self._next_plot = 0.0
        self._timeline_key = None
        self._next_timeline = 0.0

        self.server.scene.set_up_direction("+z")
        self._build_gui()
        self._build_static_scene()
        self.server.on_client_connect(self._on_connect)
        self.server.on_client_disconnect(self._on_disconnect)
        app.start()
        self._thread = threading.Thread(
            target=self._render_loop, name="fuzzynav-render", daemon=True
        )
        self._thread.start()

    # -- lifecycle ---------------------------------------------------------------------

    @property
    def url(self) -> str:
        host = "127.0.0.1" if self.host in ("", "0.0.0.0") else self.host
        if ":" in host:
            host = f"[{host}]"
        return f"http://{host}:{self.port}"

    def stop(self) -> None:
        """Stop rendering, the simulation thread and the server; the port is freed."""
        self._stop.set()
        self._thread.join(timeout=5.0)
        self.app.stop()
        self.server.stop()

    def scene_hz(self) -> float:
        """Scene updates per second over the last frames (0 when idle)."""
        times = list(self._frame_times)
        if len(times) < 2 or time.perf_counter() - times[-1] > 0.5:
            return 0.0
        return (len(times) - 1) / (times[-1] - times[0])

    def _on_connect(self, client: viser.ClientHandle) -> None:
        """Frame the arena for this tab, and again whenever its canvas changes shape in
        its first seconds (it starts as wide as the window and narrows when the side
        panels dock, which takes a while on a slow machine).

        Nothing waits here: viser runs this on one of its 32 worker threads, which
        every button and dropdown of every tab shares; a tab that held one for its
        first seconds stalled a whole class joining at once. The canvas reports each
        change of shape as a camera message (:meth:`_on_camera`), which refits it.
        """
        self._open_fit_window(client, FIT_WINDOW_S)
        client.camera.on_update(lambda camera: self._on_camera(client))
        self._fit_camera(client, force=False)

    def _on_disconnect(self, client: viser.ClientHandle) -> None:
        for table in (self._camera_fits, self._fitting_until, self._fit_window):
            table.pop(client.client_id, None)

    def _open_fit_window(self, client, seconds: float) -> None:
        """Refit this tab's camera whenever its canvas changes shape in the next
        ``seconds`` (a tab connecting, the panels widening in presentation mode)."""
        self._fit_window[client.client_id] = time.monotonic() + seconds

    def _on_camera(self, client) -> None:
        if time.monotonic() < self._fit_window.get(client.client_id, 0.0):
            self._fit_camera(client, force=False)
        self._keep_top_down(client)

    def _keep_top_down(self, client) -> None:
        """Unless the 3D view is switched on, a camera tilted (a drag on the ground
        rotates it in viser) is put straight back above the point it looks at, at the
        same distance: panning and zooming stay, tilting does not."""
        if self.view_3d or time.monotonic() < self._fitting_until.get(client.client_id, 0.0):
            return  # (our own fit moves position, then look_at: not a user's tilt)
        try:
            camera = client.camera
            position = np.asarray(camera.position, dtype=float)
            look_at = np.asarray(camera.look_at, dtype=float)
        except Exception:
            return
        view = look_at - position
        distance = float(np.linalg.norm(view))
        if distance <= 0:
            return
        tilt = math.acos(max(-1.0, min(1.0, -view[2] / distance)))
        if tilt <= TOP_DOWN_TOLERANCE_RAD:
            return
        camera.position = (look_at[0], look_at[1] - 1e-3 * distance, look_at[2] + distance)
        camera.look_at = tuple(look_at)

    def _fit_camera(self, client, force: bool) -> None:
        """Point this tab's camera straight down at the arena, if its shape changed."""
        bounds = self._bounds
        if bounds is None:
            return
        try:
            camera = client.camera
            if camera.update_timestamp == 0.0:
                return
            aspect = float(camera.aspect or 1.0)
            fitted = self._camera_fits.get(client.client_id)
            if not force and fitted is not None and abs(aspect - fitted) <= 0.02 * fitted:
                return
            self._camera_fits[client.client_id] = aspect
            self._fitting_until[client.client_id] = time.monotonic() + 1.0
            self._point_camera(camera, bounds, aspect)
        except Exception:  # the tab went away meanwhile
            self._camera_fits.pop(client.client_id, None)

    # -- static parts ------------------------------------------------------------------

    def _build_static_scene(self) -> None:
        scene = self.server.scene
        # No HDRI environment map: viser fetches it from the internet and keeps the canvas
        # dimmed until it arrives, which offline (a classroom) is never.
        scene.configure_environment_map(hdri=None)
        scene.configure_default_lights(enabled=True, cast_shadow=False)
        # ... so light the scene ourselves: soft all round, plus a sun from above.
        scene.add_light_ambient("/lights/ambient", intensity=1.6)
        scene.add_light_directional("/lights/sun", intensity=1.2, position=(2.0, -3.0, 10.0))
        L, W = HUSKY_FOOTPRINT_M
        self.robot = scene.add_frame("/robot", show_axes=False)
        # The paper's geometry draws the robot as the point it is (a small disc), the
        # Husky's as its body; both exist, one is shown (``_show_geometry``).
        self.point_robot = scene.add_cylinder(
            "/robot/point",
            radius=0.06,
            height=0.04,
            color=HUSKY_YELLOW,
            wxyz=(math.cos(math.pi / 4), math.sin(math.pi / 4), 0.0, 0.0),
            position=(0.0, 0.0, 0.05),
            visible=False,
        )
        self._husky_nodes = []
        self._husky_nodes.append(
            scene.add_box(
                "/robot/body",
                color=HUSKY_YELLOW,
                dimensions=(L, W * 0.78, 0.26),
                position=(0.0, 0.0, 0.25),
            )
        )
        self._husky_nodes.append(
            scene.add_box(
                "/robot/deck",
                color=HUSKY_DARK,
                dimensions=(0.62 * L, 0.62 * W, 0.03),
                position=(-0.06 * L, 0.0, 0.39),
            )
        )
        self._husky_nodes.append(
            scene.add_box(
                "/robot/bumper",
                color=HUSKY_DARK,
                dimensions=(0.06, W * 0.78, 0.12),
                position=(0.5 * L - 0.03, 0.0, 0.2),
            )
        )
        wheel_q = (math.cos(math.pi / 4), math.sin(math.pi / 4), 0.0, 0.0)
        for i, (sx, sy) in enumerate(((1, 1), (1, -1), (-1, 1), (-1, -1))):
            self._husky_nodes.append(
                scene.add_cylinder(
                    f"/robot/wheel{i}",
                    radius=0.165,
                    height=0.11,
                    color=(25, 25, 25),
                    wxyz=wheel_q,
                    position=(sx * 0.256, sy * (0.5 * W - 0.055), 0.165),
                )
            )
        # Heading arrow on the deck.
        arrow = np.array(
            [
                [[-0.25, 0, 0.43], [0.42, 0, 0.43]],
                [[0.42, 0, 0.43], [0.27, 0.12, 0.43]],
                [[0.42, 0, 0.43], [0.27, -0.12, 0.43]],
            ],
            dtype=np.float32,
        )
        scene.add_line_segments("/robot/heading", arrow, (255, 255, 255), thickness=0.05)
        self._ring_points = {
            "husky": polyline_segments(rounded_rectangle(L, W, SAFE_DISTANCE_M), 0.03),
            # the paper's 25 cm, centre to centre: an obstacle's centre must stay outside
            "paper": polyline_segments(rounded_rectangle(0.0, 0.0, SAFE_DISTANCE_M), 0.03),
        }
        self.ring = scene.add_line_segments(
            "/robot/safe_ring", self._ring_points["husky"], RING_OK, thickness=0.035
        )
        self._shown_geometry = "husky"
        # Beams that echo: thick, coloured by the reading; beams that do not: thin grey.
        self.beams = scene.add_line_segments(
            "/robot/beams", np.zeros((1, 2, 3), np.float32), NO_ECHO, thickness=0.07
        )
        self.free_beams = scene.add_line_segments(
            "/robot/free_beams", np.zeros((1, 2, 3), np.float32), NO_ECHO, thickness=0.025
        )
        self._show_geometry(self.app.geometry)
        # Target: a bullseye with a handle that slides on the ground.
        tx, ty = self.app.sim.arena.target
        self.target = scene.add_transform_controls(
            "/target",
            scale=1.0,
            line_width=2.5,
            active_axes=(True, True, False),
            disable_rotations=True,
            disable_axes=not self.show_handles,
            disable_sliders=not self.show_handles,
            depth_test=False,
            position=(tx, ty, TARGET_HEIGHT_M),
        )
        for k, (radius, colour) in enumerate(
            ((0.36, TARGET_RED), (0.25, (255, 255, 255)), (0.13, TARGET_RED))
        ):
            ring = scene.add_cylinder(
                f"/target/ring{k}",
                radius=radius,
                height=0.02,
                color=colour,
                position=(0.0, 0.0, -0.05 + 0.006 * k),
                cast_shadow=False,
            )
            ring.on_drag("left")(self._make_body_drag("/target", None, self.target))
        self.target_label = scene.add_label(
            "/target/label",
            "target",
            position=(0.45, 0.45, 0.0),
            anchor="bottom-left",
            font_screen_scale=self._label_scale(0.9),
        )
        # A first hint on the arena itself, gone after the first drag (in any tab).
        self.drag_hint = scene.add_label(
            "/target/hint",
            "drag the target or an obstacle",
            position=(-0.4, -0.45, 0.0),
            anchor="top-right",
            font_screen_scale=self._label_scale(0.85),
        )
        self.target.on_update(self._make_drag_callback("/target", None))
        self.ideal = scene.add_line_segments(
            "/ideal_line", np.zeros((1, 2, 3), np.float32), (150, 150, 150), thickness=0.02
        )
        self.start_marker = scene.add_line_segments(
            "/start", np.zeros((1, 2, 3), np.float32), (90, 90, 90), thickness=0.04
        )
        # fuzzynav's memory: the echoes it remembers, and the bearing its planner steers to.
        self.memory = scene.add_point_cloud(
            "/memory/echoes",
            np.zeros((1, 3), np.float32),
            MEMORY_PURPLE,
            point_size=0.07,
            point_shape="circle",
            visible=False,
        )
        self.steer = scene.add_line_segments(
            "/memory/steer",
            np.zeros((1, 2, 3), np.float32),
            STEER_GREEN,
            thickness=0.06,
            visible=False,
        )
        # The controller's inputs drawn on the robot, in the term plots' colours: d_t as
        # the line to the target, phi_t as the arc from the heading to it; d_o as the gap
        # from the footprint's edge along phi_o, phi_o as its arc. A fixed number of
        # segments each: an update sends only their points, at the panels' rate.
        self.input_nodes = {
            kind: scene.add_line_segments(
                f"/inputs/{kind}",
                np.zeros((INPUT_SEGMENTS, 2, 3), np.float32),
                colour,
                thickness=0.04,
                visible=False,
            )
            for kind, colour in (("target", TARGET_INPUT), ("obstacle", OBSTACLE_INPUT))
        }
        self._inputs_drawn = None
        self.ghost_node = scene.add_line_segments(
            "/ghost/trail",
            np.zeros((1, 2, 3), np.float32),
            GHOST_GREY,
            thickness=0.035,
            visible=False,
        )

    def _frame_arena(self, bounds) -> None:
        """Ground grid, metre marks and the top-down camera for these bounds."""
        scene = self.server.scene
        x0, x1, y0, y1 = bounds
        cx, cy = 0.5 * (x0 + x1), 0.5 * (y0 + y1)
        size = x1 - x0
        scene.add_grid(
            "/ground",
            width=size,
            height=size,
            plane="xy",
            cell_size=0.5,
            section_size=1.0,
            cell_color=(222, 222, 218),
            section_color=(165, 165, 160),
            cell_thickness=0.8,
            section_thickness=1.3,
            plane_opacity=0.0,
            shadow_opacity=0.0,
            position=(cx, cy, 0.0),
        )
        scene.add_box(
            "/ground_slab",
            color=GROUND,
            dimensions=(size, size, 0.02),
            position=(cx, cy, -0.012),
            cast_shadow=False,
            receive_shadow=0.25,
        )
        scene.remove_by_name("/marks")
        step = 1 if size <= 16 else 2
        for x in range(x0, x1 + 1, step):
            scene.add_label(
                f"/marks/x{x}",
                f"{x}" + (" m" if x == x1 else ""),
                position=(x, y0 - 0.25, 0.0),
                anchor="top-center",
                font_screen_scale=self._label_scale(0.75),
            )
        for y in range(y0, y1 + 1, step):
            scene.add_label(
                f"/marks/y{y}",
                f"{y}" + (" m" if y == y1 else ""),
                position=(x0 - 0.25, y, 0.0),
                anchor="center-right",
                font_screen_scale=self._label_scale(0.75),
            )
        cam = self.server.initial_camera
        # A new tab's canvas aspect is not known yet ("Reset view" also comes here):
        # assume the canvas between the docked panels is a little taller than wide.
        position, look_at = self._camera_pose(bounds, 0.8)
        cam.fov = math.radians(45.0)
        cam.position = position
        cam.look_at = look_at
        for client in self.server.get_clients().values():
            self._fit_camera(client, force=True)

    @staticmethod
    def _camera_pose(bounds, aspect: float):
        """Straight above the arena's centre, high enough for all of it at this aspect."""
        x0, x1, y0, y1 = bounds
        cx, cy = 0.5 * (x0 + x1), 0.5 * (y0 + y1)
        half = 0.5 * (x1 - x0) + 0.9  # room for the metre marks
        tan = math.tan(0.5 * math.radians(45.0))
        aspect = max(min(aspect, 4.0), 0.25)
        height = max(half / tan, half / (tan * aspect))
        # A hair south of straight above, so that +y is "up" on the screen.
        return (cx, cy - 1e-3 * height, height), (cx, cy, 0.0)

    def _point_camera(self, camera, bounds, aspect: float) -> None:
        position, look_at = self._camera_pose(bounds, aspect)
        camera.fov = math.radians(45.0)
        # Position first: setting it also shifts look_at; look_at then turns the camera.
        camera.position = position
        camera.look_at = look_at

    # -- GUI ---------------------------------------------------------------------------

    def _build_gui(self) -> None:
        gui = self.server.gui
        app = self.app
        gui.configure_theme(
            dark_mode=False,
            show_logo=False,
            show_share_button=False,
            brand_color=(37, 99, 235),
            control_width="large",
        )
        gui.set_panel_label("fuzzynav · fuzzy Husky navigator")

        self.status = gui.add_html(self._status_html(app.snapshot()))
        self.run_buttons = gui.add_button_group("Run", ("Play", "Pause", "Step", "Reset"))
        self.run_buttons.on_click(self._guarded(self._on_run_button))
        # Speeds as choices: a linear slider gave 0.1-1x a tenth of its track.
        self.speed = gui.add_button_group("Speed ×", SPEED_CHOICES)
        self.speed.on_click(self._guarded(lambda e: app.set_speed(float(self.speed.value))))
        # Back through the run: the scene, the inputs and the inference of any step.
        self.history_slider = gui.add_slider(
            "Run so far (s)",
            0.0,
            HISTORY_STEP_S,
            HISTORY_STEP_S,
            0.0,
            hint="Drag back through this run: the robot, its inputs and the rules as they "
            "were then (the run pauses; Live, Play or Step go back)",
        )
        self.history_slider.on_update(
            self._guarded(lambda e: self.app.view_history(self.history_slider.value))
        )
        self.history_live = gui.add_button("Live", hint="Back to where the run is now")
        self.history_live.on_click(self._guarded(lambda e: self.app.leave_history()))
        # Messages below the buttons, so that one appearing never moves them.
        self.message_html = gui.add_html("")
        # Above the fold at 1280 x 800 (it was the last thing in the panel).
        gui.add_html(
            "<div class='fz-drag-hint' style='font-size:0.8em;color:#475569;padding:0 8px'>"
            "Drag the <b>target</b> or an <b>obstacle</b> by its body; the robot reacts at "
            "once. Scroll to zoom, right-drag to pan.</div>"
        )

        with gui.add_folder("Scenario"):
            self.scenario_dd = gui.add_dropdown(
                "Scenario", app.scenario_options(), initial_value=app.scenario_label
            )
            self.scenario_dd.on_update(
                self._guarded(lambda e: app.load_scenario(self.scenario_dd.value))
            )
            self.obstacle_buttons = gui.add_button_group("Obstacle", ("Add", "Remove newest"))
            self.obstacle_buttons.on_click(self._guarded(self._on_obstacle_button))
            self.restore = gui.add_button(
                "Restore scenario layout",
                icon=viser.Icon.RESTORE,
                hint="Undo drags, additions and removals",
            )
            self.restore.on_click(self._guarded(lambda e: app.restore_layout()))
            self.scenario_upload = gui.add_upload_button(
                "Upload scenario (.toml)", icon=viser.Icon.UPLOAD, mime_type=".toml"
            )
            self.scenario_upload.on_upload(self._guarded(self._on_scenario_upload))

        with gui.add_folder("Controller and sensing"):
            self.controller_dd = gui.add_dropdown(
                "Controller", app.controller_options(), initial_value=app.controller_label
            )
            self.controller_dd.on_update(
                self._guarded(lambda e: app.set_controller(self.controller_dd.value))
            )
            self.fis_upload = gui.add_upload_button(
                "Upload a .fis controller", icon=viser.Icon.UPLOAD, mime_type=".fis"
            )
            self.fis_upload.on_upload(self._guarded(self._on_fis_upload))
            self.perception_dd = gui.add_dropdown(
                "Perception",
                PERCEPTION_MODES,
                initial_value=app.sim.perception.mode,
                hint="ideal: exact nearest obstacle; ultrasonic: the three beams",
            )
            self.perception_dd.on_update(
                self._guarded(lambda e: app.set_perception(self.perception_dd.value))
            )
            self.geometry_dd = gui.add_dropdown(
                "Geometry",
                GEOMETRIES,
                initial_value=app.geometry,
                hint="husky: the real 0.99 x 0.67 m footprint; paper: the paper's point robot, "
                "inputs and distances centre to centre (ideal perception)",
            )
            self.geometry_dd.on_update(
                self._guarded(lambda e: app.set_geometry(self.geometry_dd.value))
            )
            self.disturbance_cb = gui.add_checkbox(
                "Disturbance",
                app.disturbance_on,
                hint="A sin(2t) added to every controller input (scenario 3: 25-35 s)",
            )
            self.disturbance_cb.on_update(
                self._guarded(lambda e: app.set_disturbance(self.disturbance_cb.value))
            )
            self.noise = gui.add_slider(
                "Sensor noise σ (m)", NOISE_RANGE_M[0], NOISE_RANGE_M[1], 0.01, app.noise_std_m
            )
            self.noise.on_update(self._guarded(self._on_noise))
            # What each part of fuzzynav does, shown by switching it off while it drives
            # (shown while fuzzynav drives; assets/rules/fuzzynav_parts.toml).
            self.parts_folder = gui.add_folder(
                "fuzzynav's parts (untick: off)",
                expand_by_default=False,
                visible=app.snapshot().has_parts,
            )
            self.part_boxes = {}
            with self.parts_folder:
                for part in app.part_options():
                    box = gui.add_checkbox(
                        part.name, part.name not in app.parts_off, hint=f"Off: {part.what}"
                    )
                    box.on_update(
                        self._guarded(lambda e, name=part.name: app.set_part(name, e.target.value))
                    )
                    self.part_boxes[part.name] = box

        with gui.add_folder("View", expand_by_default=False):
            self.handles_cb = gui.add_checkbox(
                "Show drag handles",
                self.show_handles,
                hint="Arrows on the target and the obstacles (they also drag by their body)",
            )
            self.handles_cb.on_update(self._guarded(self._on_handles))
            self.view_3d_cb = gui.add_checkbox(
                "3D view (tilt with the mouse)",
                self.view_3d,
                hint="Off: the camera stays straight above the arena",
            )
            self.view_3d_cb.on_update(self._guarded(self._on_view_3d))
            self.presentation_cb = gui.add_checkbox(
                "Presentation mode (large type)",
                self.presentation,
                hint="A wide inference panel and large type, for a projector",
            )
            self.presentation_cb.on_update(self._guarded(self._on_presentation))
        with gui.add_folder("Colour key"):
            gui.add_html(colour_key_html())
        with gui.add_folder("Result"):
            self.result = gui.add_html(self._RESULT_PENDING)

        panel = gui.add_panel()
        self.left_panel = panel
        self._inference_tab = panel.add_tab("Inference", viser.Icon.BRAIN)
        with self._inference_tab:
            self.defs_html = gui.add_html("", order=0.0)
            self.firing_only_cb = gui.add_checkbox(
                "Firing rules only",
                False,
                hint="Show only the rules whose strength is above zero",
                order=0.5,
            )
            self.firing_only_cb.on_update(self._guarded(lambda e: self._redraw_inference()))
            self._build_what_if()
            self.timeline_html = gui.add_html("", order=0.8)
            self.inference_html = gui.add_html("", order=1.0)
        self._surface_tab = panel.add_tab("Surface", viser.Icon.GRID_DOTS)
        with self._surface_tab:
            self._build_surface_choice()
            self.surface_html = gui.add_html("", order=1.0)
            self.marker_html = gui.add_html("", order=2.0)
        self._editor_tab = panel.add_tab("Editor", viser.Icon.ADJUSTMENTS)
        with self._editor_tab:
            self._build_editor()
        self._signals_tab = panel.add_tab("Signals", viser.Icon.CHART_LINE)
        self.plot_distance = None
        self._make_distance_plot(self._distance_range())
        with self._signals_tab:
            axes_x = {"time": False, "auto": True}
            self.plot_angle = gui.add_uplot(
                data=(np.zeros(2), np.full(2, np.nan), np.full(2, np.nan)),
                series=(
                    {"label": "t (s)"},
                    {"label": "φ_t target", "stroke": "#2563eb", "width": 2},
                    {"label": "φ_o obstacle", "stroke": "#dc2626", "width": 2},
                ),
                title="Bearings (rad, + = to the left)",
                scales={"x": axes_x, "y": {"range": [-3.2, 3.2]}},
                legend={"show": True, "live": False},
                aspect=1.9,
                order=1.0,
            )
            self.plot_voltage = gui.add_uplot(
                data=(np.zeros(2), np.full(2, np.nan), np.full(2, np.nan)),
                series=(
                    {"label": "t (s)"},
                    {"label": "left", "stroke": "#7c3aed", "width": 2},
                    {"label": "right", "stroke": "#059669", "width": 2},
                ),
                title="Wheel voltages (V, after the 12 V limit)",
                scales={"x": axes_x, "y": {"range": [-12.5, 12.5]}},
                legend={"show": True, "live": False},
                aspect=1.9,
                order=2.0,
            )
        panel.dock_left()
        panel.set_width(NORMAL_WIDTHS[0])
        main = gui.main_panel
        main.dock_right()
        main.set_width(NORMAL_WIDTHS[1])

    def _build_editor(self) -> None:
        """Sliders for the paper controller's membership parameters (the tuner's
        parametrisation: ordered terms stay valid), a download and a reset."""
        gui = self.server.gui
        app = self.app
        editor = app.editor()
        note = (
            "The sliders start from the shipped rule base's own numbers."
            if editor.exact
            else "The shipped rule base does not record its parameters: the sliders start "
            "from the tuner's starting point (Reset drives with the shipped one)."
        )
        gui.add_html(
            "<div style='font-size:0.85em;padding:0 6px'>Move a slider or change an inference "
            "choice and the robot drives with the edited <b>paper</b> controller at once (the "
            "run goes on). Each number "
            "places a term (where it starts, peaks or ends) or a gap after the term before "
            f"it, so the terms stay in order whatever you do. {note}</div>"
        )
        self.editor_buttons = gui.add_button_group(
            "Edited system", ("Download .fis", "Reset to shipped")
        )
        self.editor_buttons.on_click(self._guarded(self._on_editor_button))
        from fuzzynav.controller.inference import CHOICES

        self.editor_choices = {}
        with gui.add_folder("Inference (MATLAB's choices)", expand_by_default=True):
            for field, label, hint in EDITOR_CHOICES:
                dropdown = gui.add_dropdown(
                    label, CHOICES[field], initial_value=editor.choice(field), hint=hint
                )
                dropdown.on_update(
                    self._guarded(
                        lambda e, field=field: app.set_inference_choice(field, e.target.value)
                    )
                )
                self.editor_choices[field] = dropdown
        self.editor_sliders = {}
        groups: dict[str, list[str]] = {}
        for name in editor.names:
            groups.setdefault(name.split(".")[0], []).append(name)
        titles = {"v": "outputs left, right (V)"}
        for group, names in groups.items():
            with gui.add_folder(titles.get(group, group), expand_by_default=group == "d_t"):
                for name in names:
                    lo, hi = editor.bounds[name]
                    slider = gui.add_slider(
                        EDITOR_LABELS.get(name, name.split(".", 1)[1]),
                        lo,
                        hi,
                        step=EDITOR_STEP,
                        initial_value=round(editor.value(name), 2),
                        hint=f"{name} in the tuner's terms; {lo:g} to {hi:g}",
                    )
                    slider.on_update(
                        self._guarded(
                            lambda e, name=name: app.set_membership_parameter(name, e.target.value)
                        )
                    )
                    self.editor_sliders[name] = slider

    def _distance_range(self) -> float:
        """Top of the distance plot: the start-target distance, rounded up, at least 4 m."""
        sc = self.app.sim.scenario
        span = math.dist(sc.start, sc.target)
        return float(max(4.0, math.ceil(span + 0.5)))

    def _make_distance_plot(self, top: float) -> None:
        """(Re)build the distance plot with a fixed y range.

        The range is fixed because uPlot's auto range fails on NaN (no obstacle sensed),
        and the plot is rebuilt rather than rescaled because viser's uPlot keeps the
        x range it had when its scales change.
        """
        if self.plot_distance is not None:
            self.plot_distance.remove()
        with self._signals_tab:
            self.plot_distance = self.server.gui.add_uplot(
                data=(
                    np.array([0.0, 0.02]),
                    np.full(2, np.nan),
                    np.full(2, np.nan),
                    np.full(2, SAFE_DISTANCE_M),
                ),
                series=(
                    {"label": "t (s)"},
                    {"label": "d_t target", "stroke": "#2563eb", "width": 2},
                    {"label": "d_o obstacle", "stroke": "#dc2626", "width": 2},
                    {"label": "safe 0.25", "stroke": "#f59e0b", "width": 1, "dash": [5, 4]},
                ),
                title="Distances (m)",
                scales={"x": {"time": False, "auto": True}, "y": {"range": [0.0, top]}},
                legend={"show": True, "live": False},
                aspect=1.9,
                order=0.0,
            )
        self._distance_top = top

    def _on_noise(self, event) -> None:
        try:
            self.app.set_noise(self.noise.value)
        except ViewerError:
            self.noise.value = self.app.noise_std_m  # never leave the box blank or wrong
            raise

    def _on_handles(self, event) -> None:
        self.show_handles = bool(self.handles_cb.value)
        gizmos = [self.target] + [node["handle"] for node in self._obstacle_nodes.values()]
        for gizmo in gizmos:
            gizmo.disable_axes = not self.show_handles
            gizmo.disable_sliders = not self.show_handles

    def _on_view_3d(self, event) -> None:
        self.view_3d = bool(self.view_3d_cb.value)
        if not self.view_3d:
            for client in self.server.get_clients().values():
                self._fit_camera(client, force=True)

    def _build_surface_choice(self) -> None:
        """The first surface's two axes and the values the other inputs are held at
        (MATLAB's Surface Viewer); the second plane stays (d_o, phi_o)."""
        gui = self.server.gui
        self.surface_axes = (0, 2)
        self.surface_held = [5.0, 1.0, 0.0, 0.0]
        with gui.add_folder("Axes and held inputs", expand_by_default=False, order=0.0):
            self.surface_x_dd = gui.add_dropdown("x axis", SURFACE_INPUTS, initial_value="d_t")
            self.surface_y_dd = gui.add_dropdown("y axis", SURFACE_INPUTS, initial_value="phi_t")
            self.surface_held_boxes = []
            for k, name in enumerate(SURFACE_INPUTS):
                lo, hi = SURFACE_RANGES[k]
                box = gui.add_number(
                    f"held {name}",
                    initial_value=self.surface_held[k],
                    min=round(lo, 2),
                    max=round(hi, 2),
                    step=0.05,
                    hint="the value this input is held at when it is not an axis",
                )
                box.on_update(self._guarded(lambda e: self._on_surface_choice()))
                self.surface_held_boxes.append(box)
            self.surface_no_obstacle_cb = gui.add_checkbox(
                "no obstacle sensed",
                True,
                hint="d_o and phi_o held as 'none sensed' (when neither is an axis)",
            )
            for handle in (self.surface_x_dd, self.surface_y_dd, self.surface_no_obstacle_cb):
                handle.on_update(self._guarded(lambda e: self._on_surface_choice()))

    def _on_surface_choice(self) -> None:
        x = SURFACE_INPUTS.index(self.surface_x_dd.value)
        y = SURFACE_INPUTS.index(self.surface_y_dd.value)
        if x == y:
            raise ViewerError("choose two different inputs for the axes")
        self.surface_axes = (x, y)
        self.surface_held = [float(b.value) for b in self.surface_held_boxes]
        self._surface_key = None  # recompute
        self.app._bump()

    def _custom_plane(self, fis):
        xi, yi = self.surface_axes
        held = np.array(self.surface_held, dtype=float)
        no_obstacle = self.surface_no_obstacle_cb.value and not ({xi, yi} & {1, 3})
        if no_obstacle:
            held[1] = held[3] = np.nan
        names = fis.input_names
        others = [k for k in range(4) if k not in (xi, yi)]
        said = []
        for k in others:
            if np.isnan(held[k]):
                if "no obstacle sensed" not in said:
                    said.append("no obstacle sensed")
            else:
                said.append(f"{names[k]} = {held[k]:g}")
        ranges = [self._surface_range(fis, k) for k in range(4)]
        return (
            f"{names[xi]}, {names[yi]} with {', '.join(said)}",
            fis,
            xi,
            yi,
            ranges[xi],
            ranges[yi],
            held,
            "wheels",
        )

    @staticmethod
    def _surface_range(fis, k: int) -> tuple[float, float]:
        lo, hi = fis.inputs[k].range
        return (
            max(SURFACE_RANGES[k][0], lo) if k in (0, 1) else SURFACE_RANGES[k][0],
            min(SURFACE_RANGES[k][1], hi) if k in (0, 1) else SURFACE_RANGES[k][1],
        )

    def _build_what_if(self) -> None:
        """What-if mode: pause, type an input's value, and the whole inference (rules,
        clipped sets, aggregate, centroids, the surface's dot) follows; the robot stays."""
        gui = self.server.gui
        with gui.add_folder("What-if", expand_by_default=False, order=0.6):
            self.what_if_cb = gui.add_checkbox(
                "What-if mode",
                False,
                hint="Pause and try inputs by hand; untick to go on where the run was",
            )
            self.what_if_cb.on_update(self._guarded(self._on_what_if))
            self.what_if_boxes = []
            for k, (name, lo, hi, unit) in enumerate(
                (
                    ("d_t", 0.0, 20.0, "m"),
                    ("d_o", 0.0, 10.0, "m"),
                    ("phi_t", -math.pi, math.pi, "rad"),
                    ("phi_o", -math.pi, math.pi, "rad"),
                )
            ):
                box = gui.add_number(
                    f"{name} ({unit})",
                    initial_value=0.0,
                    min=round(lo, 2),
                    max=round(hi, 2),
                    step=0.01,
                    disabled=True,
                    hint="type a value (d_o, phi_o: none sensed until you do)",
                )
                box.on_update(
                    self._guarded(lambda e, k=k: self.app.set_what_if_input(k, e.target.value))
                )
                self.what_if_boxes.append(box)

    def _on_what_if(self, event) -> None:
        if self.what_if_cb.value:
            try:
                self.app.start_what_if()
            except ViewerError:
                self.what_if_cb.value = False
                raise
        else:
            self.app.stop_what_if()

    def _redraw_inference(self) -> None:
        self._last_inference = None
        self.app._bump()

    def _on_presentation(self, event) -> None:
        """Large type for a projector: a wide inference panel, a wider control panel,
        the status line and the arena's labels larger, and every tab's camera refitted
        to its narrower canvas (the new shape arrives as a camera message)."""
        self.presentation = bool(self.presentation_cb.value)
        for client in self.server.get_clients().values():  # before the canvases change
            self._open_fit_window(client, 10.0)
        left, right = PRESENTATION_WIDTHS if self.presentation else NORMAL_WIDTHS
        self.left_panel.set_width(left)
        self.server.gui.main_panel.set_width(right)
        with self.server.atomic():
            if self._bounds is not None:
                self._frame_arena(self._bounds)  # the metre marks, at the new size
            self.target_label.font_screen_scale = self._label_scale(0.9)
            self.drag_hint.font_screen_scale = self._label_scale(0.85)
            for node in self._obstacle_nodes.values():
                node["label"].font_screen_scale = self._label_scale(0.8)
        self._last_inference = None  # redraw with the new type size
        self._last_metrics_run = -1
        self.app._bump()

    def _on_editor_button(self, event) -> None:
        if self.editor_buttons.value == "Download .fis":
            text = self.app.edited_fis_text()
            event.client.send_file_download(
                "paper_edited.fis", text.encode("utf-8"), save_immediately=True
            )
            return
        self.app.reset_membership_editor()
        editor = self.app.editor()
        for name, slider in self.editor_sliders.items():
            slider.value = round(editor.value(name), 2)
        for field, dropdown in self.editor_choices.items():
            dropdown.value = editor.choice(field)

    def _guarded(self, func):
        """Run a GUI callback; a refused action becomes a message in the page."""

        def callback(event):
            if event.client is None:  # a value the server itself set (sync), not a user
                return
            try:
                func(event)
            except ViewerError as exc:
                self._tell(event.client, str(exc), "error")
            except Exception as exc:  # never let a callback kill the viewer quietly
                self._tell(event.client, f"unexpected error: {type(exc).__name__}: {exc}", "error")

        return callback

    def _tell(self, client, text: str, level: str) -> None:
        self.app._notice(text, level)
        if client is not None:
            colour = {"error": "red", "warning": "yellow", "success": "green"}.get(level, "blue")
            client.add_notification(
                "Refused" if level == "error" else "fuzzynav",
                text,
                color=colour,
                auto_close_seconds=8.0,
            )

    def _on_run_button(self, event) -> None:
        choice = self.run_buttons.value
        {
            "Play": self.app.play,
            "Pause": self.app.pause,
            "Step": self.app.step_once,
            "Reset": self.app.reset,
        }[choice]()

    def _on_obstacle_button(self, event) -> None:
        if self.obstacle_buttons.value == "Add":
            self.app.add_obstacle()
        else:
            self.app.remove_obstacle()

    def _on_fis_upload(self, event) -> None:
        uploaded = self.fis_upload.value
        label = self.app.upload_fis(uploaded.content, uploaded.name)
        self.controller_dd.options = self.app.controller_options()
        self.controller_dd.value = label
        self._tell(event.client, f"Driving with {label}.", "success")

    def _on_scenario_upload(self, event) -> None:
        uploaded = self.scenario_upload.value
        label = self.app.upload_scenario(uploaded.content, uploaded.name)
        self.scenario_dd.options = self.app.scenario_options()
        self.scenario_dd.value = label

    def _first_drag(self) -> None:
        """The arena's drag hint has done its job."""
        if self.drag_hint.visible:
            self.drag_hint.visible = False

    def _make_body_drag(self, name: str, obstacle_id: int | None, gizmo):
        """Drag the target or an obstacle by its body: it follows the pointer on the
        horizontal plane through the point grabbed."""
        app = self.app
        grab: dict = {}

        # async: run on the event loop, in order (a thread pool could take "start" after
        # an "update" and measure the drag from a point that has moved).
        async def on_drag(event) -> None:
            if event.client is None:
                return
            try:
                self._first_drag()
                if event.phase == "start" or "xy" not in grab:
                    self._dragging.add(name)
                    grab["from"] = _xy(event.start_position)  # copies
                    grab["xy"] = np.array(gizmo.position[:2], dtype=float)
                x, y = grab["xy"] + _xy(event.end_position) - grab["from"]
                if obstacle_id is None:
                    app.move_target((x, y))
                else:
                    app.move_obstacle(obstacle_id, (x, y))
                # Another tab may have reset the run meanwhile: this node is then gone
                # (the new run's node follows the world), and the drag goes on.
                if not gizmo._impl.removed:
                    gizmo.position = (x, y, float(gizmo.position[2]))
            except ViewerError as exc:  # a malformed or refused position (issue 26)
                app._notice(str(exc), "warning")
                if not gizmo._impl.removed:
                    self._snap_back(gizmo, obstacle_id)
                grab.clear()
                self._dragging.discard(name)  # or its drawing stays frozen
            finally:
                if event.phase == "end":  # whatever happened above, the drag ends here
                    grab.clear()
                    self._dragging.discard(name)
                    app.check_target()

        return on_drag

    def _make_drag_callback(self, name: str, obstacle_id: int | None):
        app = self.app

        async def on_update(event) -> None:
            if event.client is None:
                return
            if event.phase == "start":
                self._dragging.add(name)
                self._first_drag()
            try:
                x, y = _xy(event.target.position)
                if obstacle_id is None:
                    app.move_target((x, y))
                else:
                    app.move_obstacle(obstacle_id, (x, y))
            except ViewerError as exc:
                # refused (1e300, NaN, no position): drawn back where it is, and no
                # longer held as dragged, or its drawing stays frozen (issue 26)
                app._notice(str(exc), "warning")
                self._snap_back(event.target, obstacle_id)
                self._dragging.discard(name)
                return
            if event.phase == "end":
                self._dragging.discard(name)
                app.check_target()

        return on_update

    def _snap_back(self, gizmo, obstacle_id: int | None) -> None:
        """Draw a handle where its target or obstacle is (after a refused drag)."""
        snap = self.app.snapshot()
        if obstacle_id is None:
            xy = snap.target
        else:
            xy = next((o.xy for o in snap.obstacles if o.id == obstacle_id), None)
        if xy is not None:
            z = float(gizmo.position[2]) if len(gizmo.position) > 2 else 0.0
            gizmo.position = (float(xy[0]), float(xy[1]), z if math.isfinite(z) else 0.0)

    # -- the render loop ---------------------------------------------------------------

    def _render_loop(self) -> None:
        period = 1.0 / FRAME_HZ
        drawn_version = -1
        next_panels = 0.0
        while not self._stop.is_set():
            started = time.perf_counter()
            snap = self.app.snapshot()
            if snap.version != drawn_version:
                try:
                    with self.server.atomic():
                        self._draw_scene(snap)
                except Exception as exc:  # keep rendering whatever one frame did
                    self.app._notice(f"scene update failed: {type(exc).__name__}: {exc}", "warning")
                drawn_version = snap.version
                self._frame_times.append(started)
            if snap.version != self._last_panel_version and (
                started >= next_panels or not snap.playing
            ):
                try:
                    self._draw_panels(snap)
                except Exception as exc:
                    self.app._notice(f"panel update failed: {type(exc).__name__}: {exc}", "warning")
                self._last_panel_version = snap.version
                next_panels = started + 1.0 / PANEL_HZ
            if self._last_panel_version == drawn_version == snap.version and not snap.playing:
                # All drawn and nothing runs: sleep until the app changes.
                with self.app._changed:
                    if self.app.version == snap.version and not self._stop.is_set():
                        self.app._changed.wait(0.25)
                continue
            self._stop.wait(max(0.0, period - (time.perf_counter() - started)))

    def _show_geometry(self, geometry: str) -> None:
        """The Husky's body for its footprint; a small disc for the paper's point robot."""
        if geometry == self._shown_geometry:
            return
        self._shown_geometry = geometry
        for node in self._husky_nodes:
            node.visible = geometry == "husky"
        self.point_robot.visible = geometry == "paper"
        # The point robot senses exactly, not with the sonars: no beams are drawn.
        self.beams.visible = self.free_beams.visible = geometry == "husky"
        self.ring.points = self._ring_points[geometry]
        self._ring_alert = None  # recolour the new ring

    def _draw_scene(self, snap: Snapshot) -> None:
        self._show_geometry(snap.geometry)
        if snap.run_id != self._drawn_run:
            self._drawn_run = snap.run_id
            for node in self._trail_nodes + [self._current_trail]:
                if node is not None:
                    node.remove()
            self._trail_nodes = []
            self._current_trail = None
            self._trail_points = np.zeros((0, 2))
            self._trail_index = 0
            self._start_xy = tuple(self.app.sim.scenario.start)
            bounds = arena_bounds(snap, self._start_xy)
            if bounds != self._bounds:
                self._bounds = bounds
                self._frame_arena(bounds)
            sx, sy = self._start_xy
            cross = np.array(
                [
                    [[sx - 0.2, sy, 0.01], [sx + 0.2, sy, 0.01]],
                    [[sx, sy - 0.2, 0.01], [sx, sy + 0.2, 0.01]],
                ],
                dtype=np.float32,
            )
            self.start_marker.points = cross
            self._last_target = None
        self._draw_obstacles(snap)

        x, y, heading = snap.pose
        self.robot.position = (x, y, 0.0)
        self.robot.wxyz = yaw_wxyz(heading)

        # Drawn to BEAM_STEP_M (a pixel or two at the arena's scale): a beam is re-sent
        # when its reading moves by that much, not at every millimetre.
        ranges = tuple(np.round(snap.ranges_m / BEAM_STEP_M) * BEAM_STEP_M)
        if ranges != self._last_ranges:
            self._last_ranges = ranges
            for handle, echo in ((self.beams, True), (self.free_beams, False)):
                points, colours = self._beam_segments(snap, echo, ranges)
                handle.points = points
                handle.colors = colours
        alert = snap.nearest_clearance_m < SAFE_DISTANCE_M
        if alert != self._ring_alert:
            self._ring_alert = alert
            colour = RING_ALERT if alert else RING_OK
            self.ring.colors = np.broadcast_to(
                np.array(colour, np.uint8), self.ring.points.shape
            ).copy()

        if snap.target != self._last_target:
            self._last_target = snap.target
            if "/target" not in self._dragging:
                self.target.position = (snap.target[0], snap.target[1], TARGET_HEIGHT_M)
            sx, sy = self._start_xy
            self.ideal.points = np.array(
                [[[sx, sy, 0.008], [snap.target[0], snap.target[1], 0.008]]], dtype=np.float32
            )
        self._draw_memory(snap)
        self._draw_trail()
        self._draw_ghost(snap)

    @staticmethod
    def input_segments(pose, distance, bearing, radius, start=0.0) -> np.ndarray:
        """(INPUT_SEGMENTS, 2, 3): a distance along ``bearing`` (from ``start`` m off the
        centre), the heading's radius and the arc from the heading to ``bearing``."""
        x, y, heading = pose
        z = 0.5
        a = heading + bearing
        seg = np.zeros((INPUT_SEGMENTS, 2, 3), np.float32)
        seg[:, :, 2] = z
        seg[0, 0, :2] = (x + start * math.cos(a), y + start * math.sin(a))
        seg[0, 1, :2] = (x + (start + distance) * math.cos(a), y + (start + distance) * math.sin(a))
        seg[1, 0, :2] = (x, y)
        seg[1, 1, :2] = (x + radius * math.cos(heading), y + radius * math.sin(heading))
        angles = heading + np.linspace(0.0, bearing, ARC_SEGMENTS + 1)
        arc = np.column_stack([x + radius * np.cos(angles), y + radius * np.sin(angles)])
        seg[2:, 0, :2] = arc[:-1]
        seg[2:, 1, :2] = arc[1:]
        return seg

    @staticmethod
    def footprint_exit(footprint_m, bearing: float) -> float:
        """How far from the centre a ray at ``bearing`` (robot frame) leaves the
        footprint (0 for the paper's point robot)."""
        half_l, half_w = 0.5 * footprint_m[0], 0.5 * footprint_m[1]
        c, s = abs(math.cos(bearing)), abs(math.sin(bearing))
        return min(half_l / c if c > 1e-9 else math.inf, half_w / s if s > 1e-9 else math.inf)

    def _draw_inputs(self, snap: Snapshot) -> None:
        """The inputs the controller was given, on the robot (at the panels' rate, from
        the same snapshot as the term plots: the same numbers)."""
        d_t, d_o, phi_t, phi_o = snap.inputs if snap.what_if is None else snap.what_if
        pose = snap.input_pose or snap.pose  # where they were read (a step ago)
        key = (tuple(np.round(pose, 3)), tuple(np.round((d_t, d_o, phi_t, phi_o), 3)))
        if key == self._inputs_drawn:
            return
        self._inputs_drawn = key
        shown = {
            "target": math.isfinite(d_t) and math.isfinite(phi_t),
            "obstacle": math.isfinite(d_o) and math.isfinite(phi_o),
        }
        if shown["target"]:
            self.input_nodes["target"].points = self.input_segments(pose, d_t, phi_t, 1.1)
        if shown["obstacle"]:
            start = self.footprint_exit(snap.footprint_m, phi_o)
            self.input_nodes["obstacle"].points = self.input_segments(
                pose, max(d_o, 0.0), phi_o, 0.8, start
            )
        for kind, node in self.input_nodes.items():
            if node.visible != shown[kind]:
                node.visible = shown[kind]

    def _draw_ghost(self, snap: Snapshot) -> None:
        if snap.ghost_id == self._ghost_drawn:
            return
        self._ghost_drawn = snap.ghost_id
        ghost = snap.ghost
        if ghost is None or len(ghost.trail) < 2:
            self.ghost_node.visible = False
            return
        segs = polyline_segments(ghost.trail, 0.012)
        self.ghost_node.points = segs
        self.ghost_node.colors = np.broadcast_to(np.array(GHOST_GREY, np.uint8), segs.shape).copy()
        self.ghost_node.visible = True

    def _draw_memory(self, snap: Snapshot) -> None:
        """fuzzynav's remembered echoes (where the robot believes they are) and the
        bearing it steers to; hidden for controllers without a memory."""
        shown = snap.memory_xy is not None
        if self.memory.visible != shown:
            self.memory.visible = shown
        # The planned bearing only while there is one (none before the first step of a
        # run: a line left from the last run would lie).
        steering = shown and math.isfinite(snap.steer_heading_rad)
        if self.steer.visible != steering:
            self.steer.visible = steering
        if not shown:
            return
        pts = snap.memory_xy
        if len(pts):
            cloud = np.column_stack([pts, np.full(len(pts), 0.08)]).astype(np.float32)
        else:
            cloud = np.zeros((1, 3), np.float32)  # one point under the ground
            cloud[0, 2] = -1.0
        self.memory.points = cloud
        self.memory.colors = np.broadcast_to(np.array(MEMORY_PURPLE, np.uint8), cloud.shape).copy()
        x, y, _ = snap.pose
        a = snap.steer_heading_rad
        if math.isfinite(a):
            self.steer.points = np.array(
                [[[x, y, 0.5], [x + 1.6 * math.cos(a), y + 1.6 * math.sin(a), 0.5]]],
                dtype=np.float32,
            )

    def _beam_segments(self, snap: Snapshot, echo: bool, ranges=None):
        """The cone outlines (robot frame) of the beams that echo, or of those that do not."""
        mounts = self.app.sim.sensors.config.mounts
        half = 0.5 * snap.beam_width_rad
        segments, colours = [], []
        for mount, reading in zip(mounts, snap.ranges_m if ranges is None else ranges):
            if math.isfinite(reading) != echo:
                continue
            reach = float(reading) if math.isfinite(reading) else snap.max_range_m
            colour = reading_colour(float(reading))
            ox, oy, a = mount.x_m, mount.y_m, mount.angle_rad
            arc = [
                (ox + reach * math.cos(a + s), oy + reach * math.sin(a + s))
                for s in np.linspace(-half, half, 5)
            ]
            outline = [(ox, oy)] + arc + [(ox, oy)]
            for p, q in zip(outline, outline[1:]):
                segments.append([[p[0], p[1], 0.06], [q[0], q[1], 0.06]])
                colours.append([colour, colour])
        if not segments:  # nothing of this kind: a zero-length segment under the robot
            return np.zeros((1, 2, 3), np.float32), np.full((1, 2, 3), 255, np.uint8)
        return np.array(segments, dtype=np.float32), np.array(colours, dtype=np.uint8)

    def _draw_obstacles(self, snap: Snapshot) -> None:
        scene = self.server.scene
        wanted = {(snap.run_id, o.id): o for o in snap.obstacles}
        for key in [k for k in self._obstacle_nodes if k not in wanted]:
            node = self._obstacle_nodes.pop(key)
            node["handle"].remove()
            self._dragging.discard(node["name"])
        for key, ob in wanted.items():
            node = self._obstacle_nodes.get(key)
            if node is None or node["static"] != ob.is_static:
                if node is not None:
                    node["handle"].remove()
                name = f"/obstacles/r{key[0]}_o{key[1]}"
                handle = scene.add_transform_controls(
                    name,
                    scale=max(0.6, 2.2 * ob.radius_m),
                    line_width=2.5,
                    active_axes=(True, True, False),
                    disable_rotations=True,
                    disable_axes=not self.show_handles,
                    disable_sliders=not self.show_handles,
                    depth_test=False,
                    position=(ob.xy[0], ob.xy[1], OBSTACLE_HEIGHT_M + 0.01),
                )
                body = scene.add_cylinder(
                    f"{name}/body",
                    radius=ob.radius_m,
                    height=OBSTACLE_HEIGHT_M,
                    color=STATIC_COLOUR if ob.is_static else MOVING_COLOUR,
                    position=(0.0, 0.0, -0.5 * OBSTACLE_HEIGHT_M - 0.01),
                )
                body.on_drag("left")(self._make_body_drag(name, ob.id, handle))
                number = snap.obstacle_numbers.get(ob.id, ob.id + 1)
                label = scene.add_label(
                    f"{name}/label",
                    self._obstacle_label(number, ob.is_static),
                    position=(ob.radius_m + 0.08, 0.0, 0.0),
                    anchor="center-left",
                    font_screen_scale=self._label_scale(0.8),
                )
                handle.on_update(self._make_drag_callback(name, ob.id))
                node = {
                    "handle": handle,
                    "name": name,
                    "static": ob.is_static,
                    "xy": ob.xy,
                    "label": label,
                    "number": number,
                }
                self._obstacle_nodes[key] = node
            number = snap.obstacle_numbers.get(ob.id, ob.id + 1)
            if node["number"] != number:  # an obstacle before it was removed
                node["number"] = number
                node["label"].text = self._obstacle_label(number, ob.is_static)
            elif node["xy"] != ob.xy and node["name"] not in self._dragging:
                node["handle"].position = (ob.xy[0], ob.xy[1], OBSTACLE_HEIGHT_M + 0.01)
                node["xy"] = ob.xy

    @staticmethod
    def _obstacle_label(number: int, static: bool) -> str:
        """What the arena calls an obstacle: the number the messages use."""
        return f"obstacle {number}" + ("" if static else " (moving)")

    def _label_scale(self, scale: float) -> float:
        """Arena labels are larger in presentation mode."""
        return scale * (1.6 if self.presentation else 1.0)

    def _draw_trail(self) -> None:
        run_id, new = self.app.trail_since(self._trail_index)
        if run_id != self._drawn_run or len(new) == 0:
            return
        self._trail_index += len(new)
        scene = self.server.scene
        points = np.concatenate([self._trail_points, new])
        chunk = TRAIL_CHUNK
        while len(points) > chunk:
            # A full chunk is frozen as a node of its own; the next starts at its end.
            name = f"/trail/r{run_id}_{len(self._trail_nodes)}"
            self._trail_nodes.append(
                scene.add_line_segments(
                    name, polyline_segments(points[:chunk], 0.015), TRAIL_BLUE, thickness=0.045
                )
            )
            self._current_trail = None
            points = points[chunk - 1 :]
        if len(points) >= 2:
            segs = polyline_segments(points, 0.015)
            if self._current_trail is None:
                name = f"/trail/r{run_id}_{len(self._trail_nodes)}"
                self._current_trail = scene.add_line_segments(
                    name, segs, TRAIL_BLUE, thickness=0.045
                )
            else:
                self._current_trail.points = segs
        self._trail_points = points

    # -- panels ------------------------------------------------------------------------

    def _draw_panels(self, snap: Snapshot) -> None:
        self._set_html(self.status, self._status_html(snap))
        self._set_html(self.message_html, self._message_html(snap))
        self._sync_controls(snap)
        now = time.perf_counter()
        if now >= self._next_plot or not snap.playing:
            self._next_plot = now + 1.0 / PLOT_HZ
            self._draw_plots()
        self._draw_inference(snap)
        self._draw_timeline(snap)
        self._draw_surface(snap)
        with self.server.atomic():
            self._draw_inputs(snap)
        key = (snap.run_id, snap.metrics is not None, snap.ghost_id)
        if self._last_metrics_run != key:
            self._last_metrics_run = key
            self.result.content = self._metrics_html(snap)

    @staticmethod
    def _set_html(element, content: str) -> None:
        """Send an HTML element only when its text changes."""
        if element.content != content:
            element.content = content

    @staticmethod
    def _message_html(snap: Snapshot) -> str:
        if not snap.message:
            return ""
        colour = {"error": "#b91c1c", "warning": "#b45309", "success": "#15803d"}.get(
            snap.message_level, "#334155"
        )
        return (
            f"<div class='fz-message' style='margin:0 6px;padding:4px 6px;border-radius:4px;"
            f"background:{colour}14;color:{colour};font-size:0.85em'>"
            f"{html.escape(snap.message)}</div>"
        )

    def _sync_controls(self, snap: Snapshot) -> None:
        """Show in every tab what the world is (another tab may have changed it)."""
        app = self.app
        options = tuple(app.scenario_options())
        if tuple(self.scenario_dd.options) != options:
            self.scenario_dd.options = options
        if self.scenario_dd.value != snap.scenario_label:
            self.scenario_dd.value = snap.scenario_label
        options = tuple(app.controller_options())
        if tuple(self.controller_dd.options) != options:
            self.controller_dd.options = options
        if self.controller_dd.value != snap.controller_label and snap.controller_label in options:
            self.controller_dd.value = snap.controller_label
        if self.perception_dd.value != snap.perception:
            self.perception_dd.value = snap.perception
        if self.geometry_dd.value != snap.geometry:
            self.geometry_dd.value = snap.geometry
        if self.disturbance_cb.value != snap.disturbance_on:
            self.disturbance_cb.value = snap.disturbance_on
        if abs(self.noise.value - snap.noise_std_m) > 1e-9:
            self.noise.value = snap.noise_std_m
        if self.parts_folder.visible != snap.has_parts:
            self.parts_folder.visible = snap.has_parts
        for name, box in self.part_boxes.items():
            if box.value != (name not in snap.parts_off):
                box.value = name not in snap.parts_off
        top = max(round(snap.history_span[1], 2), HISTORY_STEP_S)
        if abs(self.history_slider.max - top) > 1e-9:
            self.history_slider.max = top
        shown = min(round(snap.time_s, 2), top)
        if abs(self.history_slider.value - shown) > 0.5 * HISTORY_STEP_S:
            self.history_slider.value = shown
        if self.history_live.disabled == snap.history:
            self.history_live.disabled = not snap.history
        on = snap.what_if is not None
        if self.what_if_cb.value != on:
            self.what_if_cb.value = on
        for k, box in enumerate(self.what_if_boxes):
            if box.disabled == on:
                box.disabled = not on
            if on and math.isfinite(snap.what_if[k]) and abs(box.value - snap.what_if[k]) > 5e-3:
                box.value = round(float(snap.what_if[k]), 2)
        if self.app.paper_edit is not None:
            editor = self.app.paper_edit
            for name, slider in self.editor_sliders.items():
                value = round(editor.value(name), 2)  # as the slider shows it
                if abs(slider.value - value) > 1e-9:
                    slider.value = value
            for field, dropdown in self.editor_choices.items():
                if dropdown.value != editor.choice(field):
                    dropdown.value = editor.choice(field)

    def _status_html(self, snap: Snapshot) -> str:
        state = (
            "what-if (paused)"
            if snap.what_if is not None
            else "looking back (paused)"
            if snap.history
            else "running"
            if snap.playing
            else {
                "reached": "reached the target",
                "collided": "collided",
                "timeout": "timed out",
            }.get(snap.outcome, "paused")
        )
        colour = {
            "running": "#16a34a",
            "reached the target": "#16a34a",
            "collided": "#dc2626",
            "timed out": "#d97706",
        }.get(state, "#64748b")
        d_t, d_o, phi_t, phi_o = snap.inputs
        v_l, v_r = snap.voltages_v
        # A disturbed input is marked (the disturbance is added to every input).
        mark = (
            "<sup title='includes the disturbance' style='color:#b45309'>~</sup>"
            if snap.inputs_disturbed
            else ""
        )
        extras = ""
        if snap.disturbance_text:
            extras += f" · <span style='color:#b45309'>{html.escape(snap.disturbance_text)}</span>"
        if snap.noise_std_m > 0:
            extras += f" · noise σ {snap.noise_std_m:.2f} m"
        if snap.layout_edited:
            extras += " · layout edited"
        big = self.presentation
        return (
            "<div class='fz-status' style='font-family:system-ui,sans-serif;line-height:1.35;"
            f"padding:0 8px;font-size:{'1.3em' if big else '1em'}'>"
            f"<div style='display:flex;justify-content:space-between;align-items:baseline'>"
            f"<span class='fz-time' style='font-size:1.6em;font-weight:600;"
            "font-variant-numeric:tabular-nums;white-space:nowrap'>"
            f"t = {snap.time_s:.2f} s</span>"
            f"<span style='font-weight:600;color:{colour};white-space:nowrap'>● {state}</span></div>"
            f"<div style='font-size:0.85em;color:#475569'>{html.escape(snap.scenario_label)} · "
            f"{html.escape(snap.controller_label)}{self._parts_note(snap)} · {snap.perception}"
            f" · ×{snap.speed:g}{extras}</div>"
            "<table style='width:100%;font-size:0.85em;margin-top:4px;"
            "font-variant-numeric:tabular-nums;white-space:nowrap'><tr>"
            f"<td>d<sub>t</sub> {_fmt(d_t, 'm')}{mark}</td><td>d<sub>o</sub> "
            f"{_fmt(d_o, 'm') + mark if math.isfinite(d_o) else 'none'}</td>"
            f"<td>V<sub>L</sub> {_fmt(v_l, 'V', 1)}</td></tr><tr>"
            f"<td>φ<sub>t</sub> {_fmt(phi_t, 'rad')}{mark}</td><td>φ<sub>o</sub> "
            f"{_fmt(phi_o, 'rad') + mark if math.isfinite(phi_o) else 'none'}</td>"
            f"<td>V<sub>R</sub> {_fmt(v_r, 'V', 1)}</td></tr></table></div>"
        )

    @staticmethod
    def _parts_note(snap: Snapshot) -> str:
        if not (snap.has_parts and snap.parts_off):
            return ""
        off = snap.parts_off
        return html.escape(
            f" (without {' and '.join(off)})" if len(off) <= 2 else f" ({len(off)} parts off)"
        )

    def _metrics_html(self, snap: Snapshot) -> str:
        if snap.metrics is None and snap.ghost is None:
            return self._RESULT_PENDING
        m = snap.metrics or {"outcome": "running" if snap.playing else "not finished"}
        ghost = snap.ghost.metrics if snap.ghost is not None else None
        paper = PAPER_TABLE4.get(snap.scenario_label) if not snap.layout_edited else None
        colour = "#15803d" if m.get("outcome") == "reached" else "#b91c1c"
        rows = [
            ("Outcome", m.get("outcome"), None, ""),
            ("Time to target", m.get("time_to_target_s"), None, "s"),
            ("Path length", m.get("path_length_m"), "path_length_m", "m"),
            ("MAD from the line", m.get("mad_m"), "mad_m", "m"),
            ("RMSE from the line", m.get("rmse_m"), "rmse_m", "m"),
            ("Min centre distance", m.get("min_center_distance_m"), "min_center_distance_m", "m"),
            ("Min clearance (footprint)", m.get("min_clearance_m"), None, "m"),
            ("Max |voltage|", m.get("max_abs_voltage_v"), None, "V"),
        ]
        head = (
            "<tr><th style='text-align:left'>metric</th><th style='text-align:right'>this run</th>"
            + ("<th style='text-align:right;color:#64748b'>previous</th>" if ghost else "")
            + ("<th style='text-align:right'>paper</th>" if paper else "")
            + "</tr>"
        )
        body = []
        for label, value, key, unit in rows:
            shown = (
                f"<b style='color:{colour}'>{html.escape(str(value))}</b>"
                if label == "Outcome"
                else _fmt(value, unit, 3)
            )
            paper_cell = (
                (
                    f"<td style='text-align:right;color:#64748b;white-space:nowrap'>"
                    f"{_fmt(paper.get(key), unit, 3) if key else ''}</td>"
                )
                if paper
                else ""
            )
            ghost_cell = ""
            if ghost:
                g = ghost.get(
                    key
                    or {
                        "Outcome": "outcome",
                        "Time to target": "time_to_target_s",
                        "Min clearance (footprint)": "min_clearance_m",
                        "Max |voltage|": "max_abs_voltage_v",
                    }.get(label, "")
                )
                ghost_cell = (
                    "<td style='text-align:right;color:#64748b;white-space:nowrap'>"
                    f"{html.escape(str(g)) if label == 'Outcome' and g else _fmt(g, unit, 3)}</td>"
                )
            body.append(
                f"<tr><td>{label}</td><td style='text-align:right;white-space:nowrap'>{shown}</td>"
                f"{ghost_cell}"
                f"{paper_cell}</tr>"
            )
        note = (
            "<div style='color:#64748b;font-size:0.8em'>"
            + (
                f"Previous run (grey trail): {html.escape(snap.ghost.label)}. "
                if snap.ghost is not None
                else ""
            )
            + f"This run: {html.escape(snap.run_label)}. "
            "Paper: Table 4, proposed method. "
            "MAD and RMSE are distances from the straight start–target line.</div>"
        )
        return (
            "<table style='width:100%;font-size:"
            f"{'1.1em' if self.presentation else '0.85em'};font-variant-numeric:tabular-nums'>"
            + head
            + "".join(body)
            + "</table>"
            + note
        )

    def _draw_plots(self) -> None:
        rows = self.app.signals()
        if len(rows) < 2:
            rows = np.full((2, 7), np.nan)
            rows[:, 0] = (0.0, 0.02)
        step = max(1, len(rows) // PLOT_POINTS)
        rows = rows[::step]
        t = rows[:, 0]
        top = self._distance_range()
        if top != self._distance_top:
            self._make_distance_plot(top)
        self.plot_distance.data = (t, rows[:, 1], rows[:, 2], np.full(len(t), SAFE_DISTANCE_M))
        self.plot_angle.data = (t, rows[:, 3], rows[:, 4])
        self.plot_voltage.data = (t, rows[:, 5], rows[:, 6])

    def _system_uid(self, fis, labels, output_labels) -> str:
        """An id prefix for this system's SVG definitions (new when the system changes)."""
        key = id(fis)
        if key != self._system_key:
            self._system_key = key
            self._system_count += 1
            self._uid = f"fz{self._system_count}"
            self.defs_html.content = views.defs_html(fis, self._uid, labels, output_labels)
        return self._uid

    @staticmethod
    def _output_weights(info) -> dict | None:
        """fuzzynav's blocks: the weight its arbitration gives each output now (alpha to
        the avoidance block, 1 - alpha to the goal block); None for a plain system."""
        state = info.get("state") or {}
        try:
            alpha = float(state["avoidance weight alpha"])
        except (KeyError, TypeError, ValueError):
            return None
        return {
            name: (alpha if name.startswith("avoid") else 1.0 - alpha)
            for name in info["output_names"]
        }

    def _draw_timeline(self, snap: Snapshot) -> None:
        """The rule-firing strip of this run, with a cursor at the time shown (the live
        end, or the time slider's step). Redrawn every TIMELINE_PERIOD_S while playing."""
        import base64

        now = time.perf_counter()
        key = (snap.run_id, snap.controller_label, round(snap.time_s, 2))
        if key == self._timeline_key or (snap.playing and now < self._next_timeline):
            return
        self._timeline_key = key
        self._next_timeline = now + TIMELINE_PERIOD_S
        line = self.app.firing_timeline()
        if line is None:
            self._set_html(self.timeline_html, "")
            return
        times, strengths = line
        png = base64.b64encode(views.timeline_png(times, strengths)).decode()
        t0, t1 = float(times[0]), float(times[-1])
        where = 100.0 * (snap.time_s - t0) / (t1 - t0) if t1 > t0 else 100.0
        self._set_html(
            self.timeline_html,
            "<div class='fz-timeline' style='font-family:system-ui,sans-serif;font-size:0.8em;"
            "padding:0 6px'><b>Rules over this run</b> (a row per rule, rule 1 at the top; "
            "orange: firing)<div style='position:relative'>"
            f"<img src='data:image/png;base64,{png}' style='width:100%;height:60px;"
            "display:block;image-rendering:pixelated;border:1px solid #cbd5e1'/>"
            f"<div class='fz-timeline-cursor' style='position:absolute;top:0;bottom:0;"
            f"left:{min(max(where, 0.0), 100.0):.1f}%;width:2px;background:#0f172a'></div></div>"
            "<div style='display:flex;justify-content:space-between;color:#475569'>"
            f"<span>{t0:.1f} s</span><span>{t1:.1f} s</span></div></div>",
        )

    def _draw_inference(self, snap: Snapshot) -> None:
        info = self.app.teaching()
        if info is None:
            fis = self.app.fuzzy_system()
            if fis is None:
                text = (
                    f"The controller <b>{html.escape(snap.controller_label)}</b> has no "
                    "fuzzy rules to show. Choose a fuzzy controller (paper, fuzzynav) or "
                    "upload a .fis file."
                )
            else:
                text = "Press <b>Play</b> or <b>Step</b>: the rules that fire appear here."
            self._set_html(
                self.inference_html,
                f"<div style='font-size:0.9em;color:#475569;padding:0 6px'>{text}</div>",
            )
            return
        fis = info["fis"]
        only_firing = bool(self.firing_only_cb.value)
        key = (id(fis), tuple(np.round(info["inputs"], 6)), self.presentation, only_firing)
        if key == self._last_inference:
            return
        self._last_inference = key
        labels = list(info["input_names"])
        notes = {}
        if info.get("state") is not None and "phi_t" in labels:
            # fuzzynav's goal block is fed the planner's bearing, not the target's.
            labels[labels.index("phi_t")] = "phi_plan"
            notes["phi_plan"] = (
                "the bearing fuzzynav's planner steers to, fed to its goal block "
                "(not the target bearing φ_t of the status line)"
            )
        uid = self._system_uid(fis, labels, info["output_names"])
        inf = views.infer(fis, info["inputs"], labels, info["output_names"])
        self._set_html(
            self.inference_html,
            views.inference_html(
                inf,
                uid=uid,
                large=self.presentation,
                crisp=info["state"],
                only_firing=only_firing,
                weights=self._output_weights(info),
                notes=notes,
            ),
        )

    # -- control surfaces ---------------------------------------------------------------

    def _surface_planes_for(self, inner):
        """(title, fis, x index, y index, x range, y range, held inputs, outputs) per
        plane; outputs are ('speed', 'turn') from (left, right) or the block's own."""
        fis = getattr(inner, "fis", None)
        if fis is not None and fis.n_inputs == 4 and not hasattr(inner, "teaching_view"):
            names = fis.input_names
            ranges = [tuple(v.range) for v in fis.inputs]
            held = np.array([5.0, np.nan, 0.0, np.nan])
            d_o_range = (max(ranges[1][0], 0.0), min(ranges[1][1], 4.0))
            return [
                self._custom_plane(fis),
                (
                    f"{names[1]}, {names[3]} with the target 5 m ahead",
                    fis,
                    1,
                    3,
                    d_o_range,
                    (-math.pi / 2, math.pi / 2),
                    held,
                    "wheels",
                ),
            ]
        goal = getattr(inner, "goal", None)
        if goal is not None and hasattr(inner, "teaching_view"):
            held = np.zeros(goal.n_inputs)
            held[:] = [5.0 if n == "d_t" else 0.0 for n in goal.input_names]
            xi = goal.input_names.index("d_t")
            yi = 1 - xi
            return [
                (
                    "fuzzynav's goal block over (d_t, phi_plan); its avoidance block reads "
                    "three sector distances, not (d_o, phi_o)",
                    goal,
                    xi,
                    yi,
                    (0.0, min(goal.inputs[xi].range[1], 12.0)),
                    (-math.pi, math.pi),
                    held,
                    "block",
                )
            ]
        return []

    def _draw_surface(self, snap: Snapshot) -> None:
        inner = self.app.controller.inner
        key = (id(getattr(inner, "fis", None)), id(inner))
        if self._surface_key is None or key != self._surface_key:
            self._surface_key = key
            self._surface_planes = self._surface_planes_for(inner)
            self.surface_html.content = self._surface_html(snap)
        markers = {}
        d_t, d_o, phi_t, phi_o = snap.inputs if snap.what_if is None else snap.what_if
        for p, plane in enumerate(self._surface_planes):
            title, fis, xi, yi, x_range, y_range, held, kind = plane
            if kind == "block":
                info = self.app.teaching()
                x = info["inputs"] if info is not None else np.full(2, np.nan)
                vx, vy = float(x[xi]), float(x[yi])
            else:
                values = (d_t, d_o, phi_t, phi_o)
                vx, vy = values[xi], values[yi]
            where = views.marker_fraction(vx, vy, x_range, y_range)
            for k in range(2):
                markers[f"fz-op{p}{k}"] = where
        self._set_html(self.marker_html, views.marker_style(markers))

    def _surface_html(self, snap: Snapshot) -> str:
        if not self._surface_planes:
            return (
                "<div style='font-size:0.9em;color:#475569;padding:0 6px'>The controller "
                f"<b>{html.escape(snap.controller_label)}</b> has no fuzzy surface to show.</div>"
            )
        import base64

        blocks = []
        for p, (title, fis, xi, yi, x_range, y_range, held, kind) in enumerate(
            self._surface_planes
        ):
            xs, ys, out = views.surface_grid(fis, xi, yi, x_range, y_range, held)
            if kind == "wheels":
                left, right = out[..., 0], out[..., 1]
                fields = [
                    ("speed = (left + right) / 2 (V)", 0.5 * (left + right)),
                    # as fuzzynav's command has it: left = speed - turn, right = speed + turn
                    ("turn = (right − left) / 2 (V)", 0.5 * (right - left)),
                ]
            else:
                fields = [(f"{fis.output_names[k]}", out[..., k]) for k in range(2)]
            cells = []
            for k, (label, values) in enumerate(fields):
                limit = float(np.nanmax(np.abs(values))) or 1.0
                png = base64.b64encode(views.surface_png(values, limit)).decode()
                x_ticks = "".join(
                    f"<span class='fz-xtick'>{v:.3g}</span>" for v in np.linspace(*x_range, 5)
                )
                y_ticks = "".join(
                    f"<span class='fz-ytick'>{v:.2g}</span>"
                    for v in np.linspace(y_range[1], y_range[0], 5)
                )
                cells.append(
                    "<div style='flex:1;min-width:0'>"
                    f"<div style='font-size:0.8em;font-weight:600'>{html.escape(label)}</div>"
                    "<div style='display:flex;gap:2px'>"
                    "<div style='display:flex;flex-direction:column;justify-content:space-between;"
                    f"font-size:0.65em;color:#475569;text-align:right'>{y_ticks}</div>"
                    "<div style='position:relative;flex:1;min-width:0'>"
                    f"<img src='data:image/png;base64,{png}' style='width:100%;display:block;"
                    "image-rendering:pixelated;border:1px solid #cbd5e1'/>"
                    f"<div id='fz-op{p}{k}' class='fz-op' style='position:absolute;display:none;"
                    "width:12px;height:12px;margin:-6px 0 0 -6px;border-radius:50%;"
                    "border:2px solid #111;background:#facc15'></div>"
                    "<div style='font-size:0.65em;color:#475569;display:flex;"
                    f"justify-content:space-between'>{x_ticks}</div></div></div>"
                    f"<div style='font-size:0.7em;color:#475569;text-align:center'>"
                    f"{html.escape(fis.input_names[xi])} → ; ↑ {html.escape(fis.input_names[yi])}"
                    "</div>"
                    "<div class='fz-colour-bar' style='height:8px;margin-top:2px;border:1px solid "
                    "#cbd5e1;background:linear-gradient(to right,#2563eb,#ffffff,#dc2626)'></div>"
                    "<div style='font-size:0.65em;color:#475569;display:flex;"
                    f"justify-content:space-between'><span>−{limit:.1f}</span><span>0</span>"
                    f"<span>+{limit:.1f} V</span></div></div>"
                )
            blocks.append(
                f"<div style='font-weight:600;margin-top:6px'>{html.escape(title)}</div>"
                f"<div style='display:flex;gap:8px'>{''.join(cells)}</div>"
            )
        return (
            "<div class='fz-surface' style='font-family:system-ui,sans-serif;font-size:0.9em;"
            "padding:0 6px'>The crisp outputs over two inputs, the others held; the yellow "
            "dot is where the robot is now. A positive turn turns to the left."
            + "".join(blocks)
            + "</div>"
        )
