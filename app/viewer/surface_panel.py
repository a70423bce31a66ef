"""The Surface tab: the controller's crisp outputs over a plane of two inputs (MATLAB's
Surface Viewer: both axes and the held inputs chosen), as heatmaps sent once, with the
operating point as a dot that moves (a few bytes of CSS, :func:`surface_view.marker_style`)."""

from __future__ import annotations

import html
import math

import numpy as np

from fuzzynav.app.viewer import surface_view
from fuzzynav.app.viewer.model import Snapshot, ViewerError
from fuzzynav.app.viewer.status import set_html
from fuzzynav.app.viewer.teaching import Teaching

# The (d_o, phi_o) plane holds the target this far straight ahead: near enough that the
# obstacle rules show (paper: the speed spans 4.7 V and the turn 2.1 V over the plane;
# with the target 5 m ahead, 2.9 V and 0.7 V, a map that showed nearly nothing).
OBSTACLE_PLANE_D_T_M = 2.0
SURFACE_INPUTS = ("d_t", "d_o", "phi_t", "phi_o")
SURFACE_RANGES = ((0.0, 12.0), (0.0, 4.0), (-math.pi, math.pi), (-math.pi / 2, math.pi / 2))


class SurfacePanel:
    """The Surface tab of one :class:`app.viewer.server.ViewerServer`."""

    def __init__(self, view):
        self.view = view
        self.app = view.app
        self._surface_key = None
        self._surface_planes: list = []

    def build(self) -> None:
        gui = self.view.server.gui
        self._build_surface_choice()
        # The first plane as a 3-D surface in the scene, beside the arena:
        # with View → 3D view the class turns it; the operating point moves on it.
        self.surface_3d_cb = gui.add_checkbox(
            "3D surface beside the arena",
            False,
            hint="The first map's speed as a surface in the scene, the robot's operating "
            "point on it; turn it with the mouse (this also ticks View → 3D view)",
            order=0.5,
        )
        self.surface_3d_cb.on_update(self.view.guarded(self._on_surface_3d))
        self._nodes_3d = None  # (key, {name: handle}) while the surface is drawn
        self.surface_html = gui.add_html("", order=1.0)
        self.marker_html = gui.add_html("", order=2.0)

    def _build_surface_choice(self) -> None:
        """The first surface's two axes and the values the other inputs are held at
        (MATLAB's Surface Viewer); the second plane stays (d_o, phi_o)."""
        gui = self.view.server.gui
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
                box.on_update(self.view.guarded(lambda e: self._on_surface_choice()))
                self.surface_held_boxes.append(box)
            self.surface_no_obstacle_cb = gui.add_checkbox(
                "no obstacle sensed",
                True,
                hint="d_o and phi_o held as 'none sensed' (when neither is an axis)",
            )
            for handle in (self.surface_x_dd, self.surface_y_dd, self.surface_no_obstacle_cb):
                handle.on_update(self.view.guarded(lambda e: self._on_surface_choice()))

    def _on_surface_choice(self) -> None:
        x = SURFACE_INPUTS.index(self.surface_x_dd.value)
        y = SURFACE_INPUTS.index(self.surface_y_dd.value)
        if x == y:
            raise ViewerError("choose two different inputs for the axes")
        self.surface_axes = (x, y)
        self.surface_held = [float(b.value) for b in self.surface_held_boxes]
        self._surface_key = None  # recompute
        self.app._bump()

    def _custom_plane(self, fis, read=(0, 1, 2, 3)):
        """The chosen plane; over the two inputs the system reads when it reads only two
        (the starter: d_t, phi_t), whatever the axes chosen."""
        xi, yi = self.surface_axes
        if len(read) == 2 and {xi, yi} != set(read):
            xi, yi = read
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

    def _surface_planes_for(self, inner):
        """(title, fis, x index, y index, x range, y range, held inputs, outputs) per
        plane; outputs are ('speed', 'turn') from (left, right) or the block's own."""
        fis = getattr(inner, "fis", None)
        if fis is not None and fis.n_inputs == 4 and not hasattr(inner, "teaching_view"):
            names = fis.input_names
            ranges = [tuple(v.range) for v in fis.inputs]
            held = np.array([OBSTACLE_PLANE_D_T_M, np.nan, 0.0, np.nan])
            d_o_range = (max(ranges[1][0], 0.0), min(ranges[1][1], 4.0))
            read = Teaching.read_inputs(fis)
            if not {1, 3} <= set(read):  # no (d_o, phi_o) plane for a system blind to them
                return [self._custom_plane(fis, read)]
            return [
                self._custom_plane(fis, read),
                (
                    f"{names[1]}, {names[3]} with the target {OBSTACLE_PLANE_D_T_M:g} m ahead",
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

    def _on_surface_3d(self, event) -> None:
        on = bool(event.value)
        if on and not self.view.view_3d:  # a surface is for turning
            self.view.view_3d = True
            self.view.controls.view_3d_cb.value = True
        bounds = self.view.scene.bounds
        if on and bounds is not None:
            # every tab looks at the arena and the surface beside it, from the south
            x0, x1, y0, y1 = bounds
            size = y1 - y0
            cx, cy = 0.5 * (x0 + x1 + 1.0 + size), 0.5 * (y0 + y1)
            width = (x1 - x0) + 1.0 + size
            for client in self.view.server.get_clients().values():
                try:
                    client.camera.position = (cx, cy - 1.5 * width, 1.2 * width)
                    client.camera.look_at = (cx, cy, 0.0)
                except Exception:  # the tab went away meanwhile
                    pass
        elif not on:
            self.view.view_3d = False
            self.view.controls.view_3d_cb.value = False
            self.view.camera.fit_all()
        self.app._bump()

    def _draw_3d(self, snap: Snapshot) -> None:
        """The first plane's speed (or first output) as a surface beside the arena, and
        the operating point on it; drawn by the render thread, with the panels."""
        scene = self.view.server.scene
        wanted = bool(self.surface_3d_cb.value) and bool(self._surface_planes)
        bounds = self.view.scene.bounds
        if not wanted or bounds is None:
            if self._nodes_3d is not None:
                for node in self._nodes_3d[1].values():
                    node.remove()
                self._nodes_3d = None
            return
        title, fis, xi, yi, x_range, y_range, held, kind = self._surface_planes[0]
        key = (id(fis), xi, yi, x_range, y_range, tuple(np.nan_to_num(held, nan=-9e9)), bounds)
        x0, x1, y0, y1 = bounds
        size = float(y1 - y0)
        ox, oy = x1 + 1.0, y0  # beside the arena, to its right
        if self._nodes_3d is None or self._nodes_3d[0] != key:
            if self._nodes_3d is not None:
                for node in self._nodes_3d[1].values():
                    node.remove()
            xs, ys, out = surface_view.surface_grid(fis, xi, yi, x_range, y_range, held, n=31)
            values = 0.5 * (out[..., 0] + out[..., 1]) if kind == "wheels" else out[..., 0]
            limit = float(np.nanmax(np.abs(values))) or 1.0
            gx = ox + (xs - x_range[0]) / (x_range[1] - x_range[0]) * size
            gy = oy + (ys - y_range[0]) / (y_range[1] - y_range[0]) * size
            gz = np.nan_to_num(values) / limit * 0.35 * size
            pts = np.stack(np.broadcast_arrays(gx[None, :], gy[:, None], gz), axis=-1)
            segs = np.concatenate(
                [
                    np.stack([pts[:, :-1], pts[:, 1:]], axis=2).reshape(-1, 2, 3),
                    np.stack([pts[:-1, :], pts[1:, :]], axis=2).reshape(-1, 2, 3),
                ]
            ).astype(np.float32)
            mid = 0.5 * (segs[:, 0, 2] + segs[:, 1, 2]) / (0.35 * size) * limit
            rgb = surface_view.diverging_rgb(mid, limit)
            colours = np.repeat(rgb[:, None, :], 2, axis=1)
            nodes = {
                "lines": scene.add_line_segments(
                    "/surface3d/lines", segs, colours, thickness=2.5, thickness_units="screen"
                ),
                "label": scene.add_label(
                    "/surface3d/label",
                    f"{title}: speed (V) over {fis.input_names[xi]} → , {fis.input_names[yi]} ↑",
                    position=(ox, oy + size + 0.4, 0.0),
                    anchor="bottom-left",
                    font_screen_scale=self.view.label_scale(0.8),
                ),
                "point": scene.add_icosphere(
                    "/surface3d/point", radius=0.18, color=(250, 204, 21), position=(ox, oy, 0)
                ),
            }
            self._nodes_3d = (key, nodes, (xs, ys, values, limit, ox, oy, size))
        xs, ys, values, limit, ox, oy, size = self._nodes_3d[2]
        d_t, d_o, phi_t, phi_o = snap.inputs if snap.what_if is None else snap.what_if
        vx, vy = ((d_t, d_o, phi_t, phi_o)[xi], (d_t, d_o, phi_t, phi_o)[yi])
        point = self._nodes_3d[1]["point"]
        inside = (
            math.isfinite(vx)
            and math.isfinite(vy)
            and x_range[0] <= vx <= x_range[1]
            and y_range[0] <= vy <= y_range[1]
        )
        if inside:
            x = held.copy()
            x[xi], x[yi] = vx, vy
            out = np.asarray(fis.evaluate_one(x), dtype=float)
            value = 0.5 * (out[0] + out[1]) if kind == "wheels" else out[0]
            where = (
                ox + (vx - x_range[0]) / (x_range[1] - x_range[0]) * size,
                oy + (vy - y_range[0]) / (y_range[1] - y_range[0]) * size,
                float(np.nan_to_num(value)) / limit * 0.35 * size,
            )
            point.position = where
        if point.visible != inside:
            point.visible = inside

    def draw(self, snap: Snapshot) -> None:
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
            where = surface_view.marker_fraction(vx, vy, x_range, y_range)
            for k in range(2):
                markers[f"fz-op{p}{k}"] = where
        set_html(self.marker_html, surface_view.marker_style(markers))
        with self.view.server.atomic():
            self._draw_3d(snap)

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
            xs, ys, out = surface_view.surface_grid(fis, xi, yi, x_range, y_range, held)
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
                png = base64.b64encode(surface_view.surface_png(values, limit)).decode()
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
