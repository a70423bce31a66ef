"""The signal plots (the Signals tab): distances, bearings and wheel voltages over the
last seconds of the run, redrawn at ``PLOT_HZ`` while it plays (viser sends a plot's
whole window each time)."""

from __future__ import annotations

import math

import numpy as np

from fuzzynav.app.viewer.model import SAFE_DISTANCE_M

PLOT_POINTS = 120


class SignalPlots:
    """The Signals tab of one :class:`app.viewer.server.ViewerServer`."""

    def __init__(self, view):
        self.view = view
        self.app = view.app
        self.plot_distance = None
        self._distance_top = None
        self._drawn_key = None  # (rows, last time, range): what the plots show

    def build(self, tab) -> None:
        gui = self.view.server.gui
        self._signals_tab = tab
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
            self.plot_distance = self.view.server.gui.add_uplot(
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

    def draw(self) -> None:
        rows = self.app.signals()
        if len(rows) < 2:
            rows = np.full((2, 7), np.nan)
            rows[:, 0] = (0.0, 0.02)
        step = max(1, len(rows) // PLOT_POINTS)
        rows = rows[::step]
        t = rows[:, 0]
        top = self._distance_range()
        key = (len(rows), float(rows[-1, 0]), float(rows[0, 0]), top)
        if key == self._drawn_key and top == self._distance_top:
            return  # nothing new (a paused drag): the window is not sent again
        self._drawn_key = key
        if top != self._distance_top:
            self._make_distance_plot(top)
        self.plot_distance.data = (t, rows[:, 1], rows[:, 2], np.full(len(t), SAFE_DISTANCE_M))
        self.plot_angle.data = (t, rows[:, 3], rows[:, 4])
        self.plot_voltage.data = (t, rows[:, 5], rows[:, 6])
