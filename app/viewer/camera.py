"""Each tab's camera: straight down at the arena, refitted when the canvas changes shape,
and put back above the arena when tilted (unless the 3D view is on)."""

from __future__ import annotations

import math
import time

import numpy as np
import viser

TOP_DOWN_TOLERANCE_RAD = math.radians(1.5)
FIT_WINDOW_S = 20.0  # a new tab's camera follows its canvas's shape for this long


class Camera:
    """The cameras of every tab of one :class:`app.viewer.server.ViewerServer`."""

    def __init__(self, view):
        self.view = view
        self._camera_fits: dict[int, float] = {}
        self._fitting_until: dict[int, float] = {}
        self._fit_window: dict[int, float] = {}

    def on_connect(self, client: viser.ClientHandle) -> None:
        """Frame the arena for this tab, and again whenever its canvas changes shape in
        its first seconds (it starts as wide as the window and narrows when the side
        panels dock, which takes a while on a slow machine).

        Nothing waits here: viser runs this on one of its 32 worker threads, which
        every button and dropdown of every tab shares; a tab that held one for its
        first seconds stalled a whole class joining at once. The canvas reports each
        change of shape as a camera message (:meth:`_on_camera`), which refits it.
        """
        self.open_fit_window(client, FIT_WINDOW_S)
        client.camera.on_update(lambda camera: self._on_camera(client))
        self.fit(client, force=False)

    def on_disconnect(self, client: viser.ClientHandle) -> None:
        for table in (self._camera_fits, self._fitting_until, self._fit_window):
            table.pop(client.client_id, None)

    def open_fit_window(self, client, seconds: float) -> None:
        """Refit this tab's camera whenever its canvas changes shape in the next
        ``seconds`` (a tab connecting, the panels widening in presentation mode)."""
        self._fit_window[client.client_id] = time.monotonic() + seconds

    def _on_camera(self, client) -> None:
        if time.monotonic() < self._fit_window.get(client.client_id, 0.0):
            self.fit(client, force=False)
        self._keep_top_down(client)

    def _keep_top_down(self, client) -> None:
        """Unless the 3D view is switched on, a camera tilted (a drag on the ground
        rotates it in viser) is put straight back above the point it looks at, at the
        same distance: panning and zooming stay, tilting does not."""
        if self.view.view_3d or time.monotonic() < self._fitting_until.get(client.client_id, 0.0):
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

    def fit(self, client, force: bool) -> None:
        """Point this tab's camera straight down at the arena, if its shape changed."""
        bounds = self.view.scene.bounds
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

    def fit_all(self) -> None:
        """Refit every tab's camera now."""
        for client in self.view.server.get_clients().values():
            self.fit(client, force=True)

    def frame(self, bounds) -> None:
        """The camera a new tab starts with, and every tab's camera refitted, for
        these bounds."""
        cam = self.view.server.initial_camera
        # A new tab's canvas aspect is not known yet ("Reset view" also comes here):
        # assume the canvas between the docked panels is a little taller than wide.
        position, look_at = self.camera_pose(bounds, 0.8)
        cam.fov = math.radians(45.0)
        cam.position = position
        cam.look_at = look_at
        self.fit_all()

    @staticmethod
    def camera_pose(bounds, aspect: float):
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
        position, look_at = self.camera_pose(bounds, aspect)
        camera.fov = math.radians(45.0)
        # Position first: setting it also shifts look_at; look_at then turns the camera.
        camera.position = position
        camera.look_at = look_at
