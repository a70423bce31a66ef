"""The signal plots (the Signals tab): distances, bearings and wheel voltages over the
last seconds of the run, redrawn at ``PLOT_HZ`` while it plays (viser sends a plot's
whole window each time).

Which plots, their lines and value ranges are the ``live`` parts of the recordings'
table of plots (:func:`fuzzynav.app.recordings.series.live_plots`); their lines are
columns of the live signal rows (:data:`.driver.SIGNAL_COLUMNS`) or constants."""

from __future__ import annotations

import numpy as np

from fuzzynav.app.recordings.series import Live, live_plots
from fuzzynav.app.viewer import driver

PLOT_POINTS = 120


def live_columns(live: Live) -> list[int | None]:
    """The column of the live signal rows each line of ``live`` draws (None: a
    constant).

    Parameters
    ----------
    live : Live
        A plot's ``live`` part (:class:`fuzzynav.app.recordings.series.Live`).
    """
    return [
        None if line.column is None else driver.SIGNAL_COLUMNS.index(line.column)
        for line in live.lines
    ]


def live_series(live: Live) -> tuple[dict, ...]:
    """uPlot's series of ``live``: the time axis, then one per line.

    Parameters
    ----------
    live : Live
        A plot's ``live`` part.
    """
    series: list[dict] = [{"label": "t (s)"}]
    for line in live.lines:
        entry = {"label": line.label, "stroke": line.stroke, "width": line.width}
        if line.dash is not None:
            entry["dash"] = list(line.dash)
        series.append(entry)
    return tuple(series)


def live_data(live: Live, rows: np.ndarray) -> tuple[np.ndarray, ...]:
    """uPlot's data of ``live`` from live signal rows (the time first).

    Parameters
    ----------
    live : Live
        A plot's ``live`` part.
    rows : numpy.ndarray
        Live signal rows, (n, len(driver.SIGNAL_COLUMNS)).
    """
    t = rows[:, 0]
    columns = [
        np.full(len(t), line.value, dtype=float) if k is None else rows[:, k]
        for line, k in zip(live.lines, live_columns(live))
    ]
    return (t, *columns)


class SignalPlots:
    """The Signals tab of one :class:`app.viewer.server.ViewerServer`: one uPlot per
    entry of :func:`~fuzzynav.app.recordings.series.live_plots`, by its entity's path."""

    def __init__(self, view):
        self.view = view
        self.app = view.app
        self.plots: dict[str, object] = {}  # entity path: its uPlot
        self._ranges: dict[str, tuple[float, float]] = {}  # the value range each shows
        self._drawn_key = None  # (rows, last time, ranges): what the plots show

    def build(self, tab) -> None:
        self._signals_tab = tab
        self._lives = {plot.path: plot.live for plot in live_plots()}
        for path in self._lives:
            self._make_plot(path, self._range(path))

    def _range(self, path: str) -> tuple[float, float]:
        """The value range of ``path``'s live plot: fixed, or from the scenario (the
        distance plot: up to the start-target distance)."""
        y_range = self._lives[path].y_range
        return tuple(y_range(self.app.sim.scenario) if callable(y_range) else y_range)

    def _make_plot(self, path: str, y_range) -> None:
        """(Re)build ``path``'s plot with a fixed y range.

        The range is fixed because uPlot's auto range fails on NaN (no obstacle sensed),
        and the plot is rebuilt rather than rescaled because viser's uPlot keeps the
        x range it had when its scales change.
        """
        live = self._lives[path]
        old = self.plots.get(path)
        if old is not None:
            old.remove()
        empty = np.full((2, len(driver.SIGNAL_COLUMNS)), np.nan)
        empty[:, 0] = (0.0, 0.02)
        with self._signals_tab:
            self.plots[path] = self.view.server.gui.add_uplot(
                data=live_data(live, empty),
                series=live_series(live),
                title=live.title,
                scales={"x": {"time": False, "auto": True}, "y": {"range": list(y_range)}},
                legend={"show": True, "live": False},
                aspect=1.9,
                order=live.order,
            )
        self._ranges[path] = y_range

    def draw(self) -> None:
        rows = self.app.signals()
        if len(rows) < 2:
            rows = np.full((2, len(driver.SIGNAL_COLUMNS)), np.nan)
            rows[:, 0] = (0.0, 0.02)
        step = max(1, len(rows) // PLOT_POINTS)
        rows = rows[::step]
        ranges = {path: self._range(path) for path in self._lives}
        key = (len(rows), float(rows[-1, 0]), float(rows[0, 0]), tuple(ranges.values()))
        if key == self._drawn_key and ranges == self._ranges:
            return  # nothing new (a paused drag): the window is not sent again
        self._drawn_key = key
        for path, live in self._lives.items():
            if ranges[path] != self._ranges.get(path):
                self._make_plot(path, ranges[path])
            self.plots[path].data = live_data(live, rows)
