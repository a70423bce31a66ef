"""The drag handles: the target and each obstacle follow the pointer when dragged by
the body (or, with "Show drag handles", by viser's arrows), and are drawn back where
the world has them when a drag is refused. Drags run on viser's event loop, in order."""

from __future__ import annotations

import math

import numpy as np

from fuzzynav.app.figures.style import obstacle_label
from fuzzynav.app.viewer.compat_viser import is_removed
from fuzzynav.app.viewer.model import Snapshot, ViewerError
from fuzzynav.resources import shorten

# Low posts: seen from above in perspective, a tall one away from the middle showed its
# side beside its top, a double circle (in trap).
OBSTACLE_HEIGHT_M = 0.2
CROWDED_M = 1.5  # an obstacle this near another is labelled by its number, on its top
# The target is drawn (and picked) above the obstacles: dropped on one, it is still
# the target that a press on it grabs.
TARGET_HEIGHT_M = OBSTACLE_HEIGHT_M + 0.08
STATIC_COLOUR = (96, 112, 136)
MOVING_COLOUR = (234, 88, 12)
TARGET_RED = (220, 38, 38)
HINT_CLEAR_M = 3.5  # the arena's hint goes once the robot is this near the target


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


# An obstacle's label, on its right, needs about this much room before the arena's edge;
# and it would lie on the target's label this near the target.
LABEL_ROOM_M = 3.0
TARGET_LABEL_ROOM_M = 1.2


class DragHandles:
    """The target's and the obstacles' nodes of one :class:`app.viewer.server.ViewerServer`
    and what a drag on them does."""

    def __init__(self, view):
        self.view = view
        self.app = view.app
        self.dragging: set[str] = set()
        self.obstacle_nodes: dict[tuple[int, int], dict] = {}

    def build_target(self, scene) -> None:
        tx, ty = self.app.sim.arena.target
        self.target = scene.add_transform_controls(
            "/target",
            scale=1.0,
            line_width=2.5,
            active_axes=(True, True, False),
            disable_rotations=True,
            disable_axes=not self.view.show_handles,
            disable_sliders=not self.view.show_handles,
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
            font_screen_scale=self.view.label_scale(0.9),
        )
        # A first hint on the arena itself, gone after the first drag (in any tab).
        self.drag_hint = scene.add_label(
            "/target/hint",
            "drag the target or an obstacle",
            position=(-0.4, -0.45, 0.0),
            anchor="top-right",
            font_screen_scale=self.view.label_scale(0.85),
        )
        self.target.on_update(self._make_drag_callback("/target", None))

    def place_target(self, target) -> None:
        """The target's handle where the world has it (unless a tab is dragging it)."""
        if "/target" not in self.dragging:
            self.target.position = (target[0], target[1], TARGET_HEIGHT_M)

    def hint_follow(self, snap: Snapshot) -> None:
        """The arena's drag hint goes once the robot nears the target (kept, it
        would cover the robot at the end of the run)."""
        if self.drag_hint.visible and not snap.history:
            x, y, _ = snap.pose
            if math.hypot(snap.target[0] - x, snap.target[1] - y) < HINT_CLEAR_M:
                self.drag_hint.visible = False

    def show(self, on: bool) -> None:
        """viser's arrows on the target and the obstacles, or none."""
        gizmos = [self.target] + [node["handle"] for node in self.obstacle_nodes.values()]
        for gizmo in gizmos:
            gizmo.disable_axes = not on
            gizmo.disable_sliders = not on

    def rescale_labels(self) -> None:
        """The labels at the type size of the mode (presentation mode: larger)."""
        self.target_label.font_screen_scale = self.view.label_scale(0.9)
        self.drag_hint.font_screen_scale = self.view.label_scale(0.85)
        for node in self.obstacle_nodes.values():
            node["label"].font_screen_scale = self.view.label_scale(0.8)

    def draw_obstacles(self, snap: Snapshot) -> None:
        scene = self.view.server.scene
        wanted = {(snap.run_id, o.id): o for o in snap.obstacles}
        for key in [k for k in self.obstacle_nodes if k not in wanted]:
            node = self.obstacle_nodes.pop(key)
            node["handle"].remove()
            self.dragging.discard(node["name"])
        for key, ob in wanted.items():
            node = self.obstacle_nodes.get(key)
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
                    disable_axes=not self.view.show_handles,
                    disable_sliders=not self.view.show_handles,
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
                    font_screen_scale=self.view.label_scale(0.8),
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
                self.obstacle_nodes[key] = node
            number = snap.obstacle_numbers.get(ob.id, ob.id + 1)
            if node["number"] != number:  # an obstacle before it was removed
                node["number"] = number
                node["crowded"] = None  # (its label is written again below)
            elif node["xy"] != ob.xy and node["name"] not in self.dragging:
                node["handle"].position = (ob.xy[0], ob.xy[1], OBSTACLE_HEIGHT_M + 0.01)
                node["xy"] = ob.xy
        self._label_crowded(wanted, snap)

    def _label_left(self, ob, snap: Snapshot) -> bool:
        """An obstacle's label goes on its left when, on its right, it would be cut at
        the arena's right edge or lie on the target's label (s2's moving obstacle starts
        on the target)."""
        bounds = self.view.scene.bounds
        near_edge = bounds is not None and ob.xy[0] > bounds[1] - LABEL_ROOM_M
        return near_edge or math.dist(ob.xy, snap.target) < TARGET_LABEL_ROOM_M

    def _label_crowded(self, wanted: dict, snap: Snapshot) -> None:
        """Obstacles close together (trap's posts) are labelled by their number on their
        top, not "obstacle k" beside them (the labels overlapped); the others in full,
        on their right, or on their left where the right has no room."""
        for key, node in self.obstacle_nodes.items():
            ob = wanted.get(key)
            if ob is None:
                continue
            crowded = any(
                math.dist(ob.xy, other.xy) < CROWDED_M for k, other in wanted.items() if k != key
            )
            place = "top" if crowded else "left" if self._label_left(ob, snap) else "right"
            if node.get("crowded") == place:
                continue
            node["crowded"] = place
            label = node["label"]
            if crowded:
                label.text = str(node["number"])
                label.anchor = "center-center"
                label.position = (0.0, 0.0, 0.02)
            else:
                label.text = self._obstacle_label(node["number"], ob.is_static)
                side = -1.0 if place == "left" else 1.0
                label.anchor = "center-right" if place == "left" else "center-left"
                label.position = (side * (ob.radius_m + 0.08), 0.0, 0.0)

    @staticmethod
    def _obstacle_label(number: int, static: bool) -> str:
        """What the arena calls an obstacle: the number the messages use (its place in
        the layout from 1), in :func:`obstacle_label`'s words, as the recordings and the
        figures say it."""
        return obstacle_label(number - 1) + ("" if static else " (moving)")

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
            if self.view.locked:  # a classroom's teacher locked the controls
                if event.phase == "start":
                    self.view.tell(event.client, self.view.LOCKED_TEXT, "warning")
                return
            try:
                self._first_drag()
                if event.phase == "start" or "xy" not in grab:
                    self.dragging.add(name)
                    grab["from"] = _xy(event.start_position)  # copies
                    grab["xy"] = np.array(gizmo.position[:2], dtype=float)
                x, y = grab["xy"] + _xy(event.end_position) - grab["from"]
                if obstacle_id is None:
                    app.move_target((x, y))
                else:
                    app.move_obstacle(obstacle_id, (x, y))
                # Another tab may have reset the run meanwhile: this node is then gone
                # (the new run's node follows the world), and the drag goes on.
                if not is_removed(gizmo):
                    gizmo.position = (x, y, float(gizmo.position[2]))
            except ViewerError as exc:  # a malformed or refused position
                app._notice(str(exc), "warning")
                if not is_removed(gizmo):
                    self._snap_back(gizmo, obstacle_id)
                grab.clear()
                self.dragging.discard(name)  # or its drawing stays frozen
            finally:
                if event.phase == "end":  # whatever happened above, the drag ends here
                    grab.clear()
                    self.dragging.discard(name)
                    app.check_target()

        return on_drag

    def _make_drag_callback(self, name: str, obstacle_id: int | None):
        app = self.app

        async def on_update(event) -> None:
            if event.client is None:
                return
            if self.view.locked:  # drawn back where the world has it
                self._snap_back(event.target, obstacle_id)
                return
            if event.phase == "start":
                self.dragging.add(name)
                self._first_drag()
            try:
                x, y = _xy(event.target.position)
                if obstacle_id is None:
                    app.move_target((x, y))
                else:
                    app.move_obstacle(obstacle_id, (x, y))
            except ViewerError as exc:
                # refused (1e300, NaN, no position): drawn back where it is, and no
                # longer held as dragged, or its drawing stays frozen
                app._notice(str(exc), "warning")
                self._snap_back(event.target, obstacle_id)
                self.dragging.discard(name)
                return
            if event.phase == "end":
                self.dragging.discard(name)
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
