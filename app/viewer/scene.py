"""The 3D scene: the robot (the Husky's body or the paper's point), its beams and safe
ring, the controller's inputs drawn on it, fuzzynav's memory, the trail and the previous
run's ghost, the start, the straight line to the target, and the ground with its metre
marks. The target's and obstacles' drag handles are :mod:`.handles`'. The shapes (the
safe ring, the beam cones, the inputs' lines and arcs, the Husky's body) are
:mod:`world.geometry`'s, as the recordings and the figures draw them; here they are only
placed in the scene.

Only the render thread draws here (:mod:`.render`), from :meth:`ViewerApp.snapshot`.
"""

from __future__ import annotations

import math

import numpy as np

from fuzzynav.app import palette
from fuzzynav.app.viewer.model import SAFE_DISTANCE_M, Snapshot
from fuzzynav.world.geometry import (
    HUSKY_WHEEL_RADIUS_M,
    HUSKY_WHEEL_WIDTH_M,
    beam_cone_outlines,
    beam_geometries,
    bearing_segments,
    footprint_exit_m,
    husky_body_boxes,
    husky_wheel_centres,
    rounded_rectangle,
)

TRAIL_CHUNK = 8  # trail points per scene node: a frame re-sends at most this many
TRAIL_MERGE = 64  # frozen chunks drawn again as one node (an hour's trail: 350 nodes)
BEAM_STEP_M = 0.02  # beams are drawn to 2 cm

# Colours (RGB 0-255).
GHOST_GREY = (148, 163, 184)
HUSKY_YELLOW = (250, 190, 20)
HUSKY_DARK = (40, 40, 40)
TRAIL_BLUE = (37, 99, 235)
RING_OK = (217, 119, 6)
RING_ALERT = (220, 38, 38)
NO_ECHO = (175, 175, 175)
MEMORY_PURPLE = (147, 51, 234)  # fuzzynav's remembered echoes
STEER_GREEN = (22, 163, 74)  # the bearing its planner steers to
GROUND = (255, 255, 255)
TARGET_INPUT = palette.rgb(palette.TARGET_INPUT)  # d_t, phi_t on the robot (app.palette)
OBSTACLE_INPUT = palette.rgb(palette.OBSTACLE_INPUT)  # d_o, phi_o (app.palette)
FIELD_OF_VIEW = (100, 116, 139)  # the edges of ideal perception's field of view
#: How far the field of view's edges are drawn from the robot's centre (m), and its arc.
FIELD_OF_VIEW_DRAWN_M = 2.5
ARC_SEGMENTS = 8
INPUT_SEGMENTS = ARC_SEGMENTS + 2  # a distance, a radius along the heading, an arc


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


def field_of_view_segments(field_of_view_rad: float, reach_m: float, z: float) -> np.ndarray:
    """Line segments in the robot's frame: the two edges of a field of view centred on
    the heading (x forward), ``reach_m`` long, and the arc between them."""
    half = 0.5 * field_of_view_rad
    arc = np.linspace(-half, half, max(8, int(math.degrees(field_of_view_rad) / 6)))
    points = np.column_stack([reach_m * np.cos(arc), reach_m * np.sin(arc)])
    edges = np.array([[[0.0, 0.0], points[0]], [[0.0, 0.0], points[-1]]])
    segments = np.concatenate([edges, np.stack([points[:-1], points[1:]], axis=1)])
    return np.concatenate([segments, np.full((*segments.shape[:2], 1), z)], axis=2).astype(
        np.float32
    )


def input_segments(pose, distance, bearing, radius, start=0.0) -> np.ndarray:
    """(INPUT_SEGMENTS, 2, 3): :func:`world.geometry.bearing_segments` at the inputs'
    height (a distance along ``bearing`` from ``start`` m off the centre, the heading's
    radius and the arc from the heading to ``bearing``)."""
    seg = np.zeros((INPUT_SEGMENTS, 2, 3), np.float32)
    seg[:, :, :2] = bearing_segments(pose, distance, bearing, radius, start, ARC_SEGMENTS)
    seg[:, :, 2] = 0.5
    return seg


def empty_lines(scene, path: str, colour, thickness: float, visible: bool = True):
    """A line-segments node with nothing to draw yet (its points are set later)."""
    return scene.add_line_segments(
        path, np.zeros((1, 2, 3), np.float32), colour, thickness=thickness, visible=visible
    )


class Scene:
    """The scene nodes of one :class:`app.viewer.server.ViewerServer`, and how a
    snapshot moves them."""

    def __init__(self, view):
        self.view = view
        self.app = view.app
        self.bounds = None
        self._trail_nodes: list = []
        self._trail_frozen: list = []  # the points of the chunks frozen since the last merge
        self._trail_count = 0  # chunks frozen: names the trail's nodes
        self._current_trail = None
        self._trail_points = np.zeros((0, 2))
        self._trail_index = 0
        self._drawn_run = -1
        self._last_target = None
        self._last_ranges = None
        self._ring_alert = None
        self._start_xy = tuple(view.app.sim.scenario.start)
        self._ghost_drawn = -1
        self.ghost_node = None

    # -- built once ----------------------------------------------------------------------

    def build(self) -> None:
        scene = self.view.server.scene
        # No HDRI environment map: viser fetches it from the internet and keeps the canvas
        # dimmed until it arrives, which offline (a classroom) is never.
        scene.configure_environment_map(hdri=None)
        scene.configure_default_lights(enabled=True, cast_shadow=False)
        # ... so light the scene ourselves: soft all round, plus a sun from above.
        scene.add_light_ambient("/lights/ambient", intensity=1.6)
        scene.add_light_directional("/lights/sun", intensity=1.2, position=(2.0, -3.0, 10.0))
        # The Husky's footprint is the world's (husky.toml), whatever the geometry shown.
        params = self.app.sim.model.parameters
        L, W = params.footprint_length_m, params.footprint_width_m
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
        colours = {"body": HUSKY_YELLOW, "deck": HUSKY_DARK, "bumper": HUSKY_DARK}
        self._husky_nodes = [
            scene.add_box(f"/robot/{name}", color=colours[name], dimensions=size, position=centre)
            for name, (size, centre) in husky_body_boxes(L, W).items()
        ]
        wheel_q = (math.cos(math.pi / 4), math.sin(math.pi / 4), 0.0, 0.0)
        for i, centre in enumerate(husky_wheel_centres(W).tolist()):
            self._husky_nodes.append(
                scene.add_cylinder(
                    f"/robot/wheel{i}",
                    radius=HUSKY_WHEEL_RADIUS_M,
                    height=HUSKY_WHEEL_WIDTH_M,
                    color=(25, 25, 25),
                    wxyz=wheel_q,
                    position=tuple(centre),
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
        self.beams = empty_lines(scene, "/robot/beams", NO_ECHO, 0.07)
        self.free_beams = empty_lines(scene, "/robot/free_beams", NO_ECHO, 0.025)
        self.show_geometry(self.app.geometry)
        # Ideal perception's field of view (s1-s3: the front half-plane of the paper's
        # three front sonars): an obstacle outside it is not sensed, so it is drawn.
        self.field_of_view = empty_lines(
            scene, "/robot/field_of_view", FIELD_OF_VIEW, 0.02, visible=False
        )
        self._field_drawn = None
        # Target: a bullseye with a handle that slides on the ground.
        self.view.handles.build_target(scene)
        self.ideal = empty_lines(scene, "/ideal_line", (150, 150, 150), 0.02)
        self.start_marker = empty_lines(scene, "/start", (90, 90, 90), 0.04)
        # fuzzynav's memory: the echoes it remembers, and the bearing its planner steers to.
        self.memory = scene.add_point_cloud(
            "/memory/echoes",
            np.zeros((1, 3), np.float32),
            MEMORY_PURPLE,
            point_size=0.07,
            point_shape="circle",
            visible=False,
        )
        self.steer = empty_lines(scene, "/memory/steer", STEER_GREEN, 0.06, visible=False)
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
        self.ghost_node = empty_lines(scene, "/ghost/trail", GHOST_GREY, 0.035, visible=False)

    def frame_arena(self, bounds) -> None:
        """Ground grid, metre marks and the top-down camera for these bounds."""
        scene = self.view.server.scene
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
        step = mark_step_m(size)
        for x in range(x0, x1 + 1, step):
            scene.add_label(
                f"/marks/x{x}",
                f"{x}" + (" m" if x == x1 else ""),
                position=(x, y0 - 0.25, 0.0),
                anchor="top-center",
                font_screen_scale=self.view.label_scale(0.75),
            )
        for y in range(y0, y1 + 1, step):
            scene.add_label(
                f"/marks/y{y}",
                f"{y}" + (" m" if y == y1 else ""),
                position=(x0 - 0.25, y, 0.0),
                anchor="center-right",
                font_screen_scale=self.view.label_scale(0.75),
            )
        self.view.camera.frame(bounds)

    # -- drawn from each snapshot ------------------------------------------------------

    def show_geometry(self, geometry: str) -> None:
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

    def draw(self, snap: Snapshot) -> None:
        self.show_geometry(snap.geometry)
        if snap.run_id != self._drawn_run:
            self._drawn_run = snap.run_id
            for node in self._trail_nodes + [self._current_trail]:
                if node is not None:
                    node.remove()
            self._trail_nodes = []
            self._trail_frozen = []
            self._current_trail = None
            self._trail_points = np.zeros((0, 2))
            self._trail_index = 0
            self._start_xy = tuple(self.app.sim.scenario.start)
            bounds = arena_bounds(snap, self._start_xy)
            if bounds != self.bounds:
                self.bounds = bounds
                self.frame_arena(bounds)
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
        self.view.handles.draw_obstacles(snap)

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

        self.view.handles.hint_follow(snap)
        if snap.target != self._last_target:
            self._last_target = snap.target
            self.view.handles.place_target(snap.target)
            sx, sy = self._start_xy
            self.ideal.points = np.array(
                [[[sx, sy, 0.008], [snap.target[0], snap.target[1], 0.008]]], dtype=np.float32
            )
        self._draw_field_of_view(snap)
        self._draw_memory(snap)
        self._draw_trail()
        self._draw_ghost(snap)

    def _draw_field_of_view(self, snap: Snapshot) -> None:
        field = snap.field_of_view_rad
        shown = snap.perception == "ideal" and field < 2.0 * math.pi
        key = (shown, field)
        if key == self._field_drawn:
            return
        self._field_drawn = key
        if shown:
            self.field_of_view.points = field_of_view_segments(field, FIELD_OF_VIEW_DRAWN_M, 0.02)
        self.field_of_view.visible = shown

    def draw_inputs(self, snap: Snapshot) -> None:
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
            self.input_nodes["target"].points = input_segments(pose, d_t, phi_t, 1.1)
        if shown["obstacle"]:
            start = footprint_exit_m(*snap.footprint_m, phi_o)
            self.input_nodes["obstacle"].points = input_segments(
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
        readings = np.asarray(snap.ranges_m if ranges is None else ranges, dtype=float)
        keep = np.isfinite(readings) == echo
        if not keep.any():  # nothing of this kind: a zero-length segment under the robot
            return np.zeros((1, 2, 3), np.float32), np.full((1, 2, 3), 255, np.uint8)
        # The mounts' origins and axes in the robot frame: the world's beams at pose 0.
        origins, directions = beam_geometries(np.zeros((1, 3)), self.app.sim.sensors.config.mounts)
        reach = np.where(np.isfinite(readings), readings, snap.max_range_m)[keep]
        outlines = beam_cone_outlines(
            origins[0][keep], directions[0][keep], reach, 0.5 * snap.beam_width_rad
        )
        segments = np.zeros((outlines.shape[0], outlines.shape[1] - 1, 2, 3), np.float32)
        segments[:, :, 0, :2] = outlines[:, :-1]
        segments[:, :, 1, :2] = outlines[:, 1:]
        segments[:, :, :, 2] = 0.06
        colours = np.repeat(
            np.array([reading_colour(float(r)) for r in readings[keep]], np.uint8),
            outlines.shape[1] - 1,
            axis=0,
        )
        colours = np.repeat(colours[:, None, :], 2, axis=1)
        return segments.reshape(-1, 2, 3), colours

    def _draw_trail(self) -> None:
        run_id, new = self.app.trail_since(self._trail_index)
        if run_id != self._drawn_run or len(new) == 0:
            return
        self._trail_index += len(new)
        scene = self.view.server.scene
        points = np.concatenate([self._trail_points, new])
        chunk = TRAIL_CHUNK
        while len(points) > chunk:
            # A full chunk is frozen as a node of its own; the next starts at its end.
            name = f"/trail/r{run_id}_{self._trail_count}"
            self._trail_nodes.append(
                scene.add_line_segments(
                    name, polyline_segments(points[:chunk], 0.015), TRAIL_BLUE, thickness=0.045
                )
            )
            self._trail_frozen.append(points[:chunk])
            self._trail_count += 1
            self._current_trail = None
            points = points[chunk - 1 :]
            if len(self._trail_frozen) == TRAIL_MERGE:
                self._merge_trail(run_id)
        if len(points) >= 2:
            segs = polyline_segments(points, 0.015)
            if self._current_trail is None:
                name = f"/trail/r{run_id}_{self._trail_count}"
                self._current_trail = scene.add_line_segments(
                    name, segs, TRAIL_BLUE, thickness=0.045
                )
            else:
                self._current_trail.points = segs
        self._trail_points = points

    def _merge_trail(self, run_id: int) -> None:
        """The last :data:`TRAIL_MERGE` frozen chunks drawn again as one node (an hour's
        trail was 22,500 nodes: 97 MB on the server, as many objects in every tab)."""
        frozen, self._trail_frozen = self._trail_frozen, []
        merged = np.concatenate([frozen[0]] + [f[1:] for f in frozen[1:]])
        node = self.view.server.scene.add_line_segments(
            f"/trail/r{run_id}_m{self._trail_count}",  # (after the chunks it replaces)
            polyline_segments(merged, 0.015),
            TRAIL_BLUE,
            thickness=0.045,
        )
        for old in self._trail_nodes[-len(frozen) :]:
            old.remove()
        del self._trail_nodes[-len(frozen) :]
        self._trail_nodes.append(node)

    # -- panels ------------------------------------------------------------------------


#: At most this many metre marks along each side of the arena (a legal scenario
#: 20 km wide sent 20,007 labels to every tab).
MAX_MARKS_PER_SIDE = 24


def mark_step_m(size_m: float) -> int:
    """Metres between the arena's marks: 1 up to 16 m, then 2, 5, 10, 20, 50, ... so that
    a side never carries more than :data:`MAX_MARKS_PER_SIDE` marks."""
    if size_m <= 16:
        return 1
    step, decade = 2, 1
    while size_m / (step * decade) > MAX_MARKS_PER_SIDE:
        step = {2: 5, 5: 10}.get(step, 2)
        if step == 2:
            decade *= 10
    return step * decade
