"""Where a plot's legend goes: the corner of a stacked panel its curves leave emptiest,
and how far the value axis is stretched to make room (a legend must not hide curves).

:class:`LegendFit` is fed a run's rows a block at a time (a long run's log is never
whole in memory); :func:`legend_placement` does it for a whole array at once.
"""

from __future__ import annotations

import numpy as np

#: The plot area of a stacked panel at 1600 x 1000 (px) and a legend entry's height: a
#: legend of k entries covers about (k * LEGEND_ENTRY_PX + 12) / PLOT_PX of a panel.
PLOT_PX = 140.0
LEGEND_ENTRY_PX = 23.0
LEGEND_WIDTH = 0.24  # of the time axis
#: How far the value axis may be stretched to give the legend empty room (x its span).
MAX_HEADROOM = 2.6


def legend_placement(series: np.ndarray, n_entries: int):
    """(corner, value range or None) for a plot's legend, so that it covers no data
    (rerun draws the legend over the plot): the corner whose legend-sized box holds the
    fewest points of ``series`` (rows, k); if even that one holds some, the value axis
    is stretched away from the data on that side (by at most :data:`MAX_HEADROOM`), so
    the legend sits over empty room; else the data's range with a 5 % margin (always
    set: rerun's own range left curves that start with a gap off the panel). None
    without data. (:class:`LegendFit` does the arithmetic, also on data given in
    pieces.)"""
    values = np.asarray(series, dtype=float)
    if values.ndim != 2 or not values.size:
        return None
    finite = values[np.isfinite(values)]
    if not finite.size:
        return None
    fit = LegendFit(float(finite.min()), float(finite.max()), n_entries)
    fit.add(len(values), 0, values)
    return fit.placement()


def unit_times(n: int, start: int, stop: int) -> np.ndarray:
    """``np.linspace(0.0, 1.0, n)[start:stop]``, the same floats, without the others
    (numpy makes them as ``i * (1 / (n - 1))``, and the last exactly 1)."""
    if n == 1:
        return np.zeros(stop - start)
    t = np.arange(start, stop, dtype=float) * (1.0 / (n - 1))
    if stop == n and stop > start:
        t[-1] = 1.0
    return t


#: The largest magnitude the legend placement computes with (a controller may answer
#: 1e308 V; the span of two of them is no float).
_FINITE_LIMIT = 1e300


class LegendFit:
    """:func:`legend_placement` of data that come in pieces: made with the range of its
    finite values (``lo``, ``hi``), then given the rows (``add``), any number at a
    time; only the rows in the legend's two time spans (the first and the last
    :data:`LEGEND_WIDTH` of the plot, :meth:`window`) count, and what is kept of them is
    a count per corner and an extreme per side."""

    def __init__(self, lo: float, hi: float, n_entries: int):
        import rerun.blueprint as rrb

        # values past +-1e300 are placed as if there: a span of two 1e308s overflows
        lo, hi = max(lo, -_FINITE_LIMIT), min(hi, _FINITE_LIMIT)
        self.lo, self.hi = lo, hi
        span = hi - lo if hi > lo else max(abs(hi), 1.0)
        self.pad = 0.05 * span  # rerun's own margin, about
        self.lo_r, self.hi_r = lo - self.pad, hi + self.pad
        self.h = min(0.95, (n_entries * LEGEND_ENTRY_PX + 14.0) / PLOT_PX)
        corners = rrb.Corner2D
        self.corners = (corners.LeftTop, corners.RightTop, corners.LeftBottom, corners.RightBottom)
        self.counts = dict.fromkeys(self.corners, 0)
        self.top = {True: -np.inf, False: -np.inf}  # largest value in the left/right span
        self.bottom = {True: np.inf, False: np.inf}  # smallest
        self.seen = {True: False, False: False}  # any finite value there

    @staticmethod
    def window(n: int) -> tuple[int, int]:
        """(a, b): of ``n`` rows, those before ``a`` and from ``b`` on lie in the
        legend's time spans (the plot's time axis runs over the rows, 0 to 1)."""
        w = LEGEND_WIDTH

        def t(i):
            return unit_times(n, i, i + 1)[0]

        a = max(0, int(w * (n - 1)) - 2)  # (t rises with i: from just before the edge)
        while a < n and t(a) < w:
            a += 1
        b = max(0, int((1 - w) * (n - 1)) - 2)
        while b < n and t(b) <= 1 - w:
            b += 1
        return a, b

    def add(self, n: int, start: int, rows: np.ndarray) -> None:
        """Rows ``start``... of the ``n`` rows of the plot (rows, k), as many as come."""
        rows = np.asarray(rows, dtype=float)
        t = unit_times(n, start, start + len(rows))
        t = np.repeat(t[:, None], rows.shape[1], axis=1).reshape(-1)
        v = rows.reshape(-1)
        ok = np.isfinite(v)
        t, v = t[ok], np.clip(v[ok], -_FINITE_LIMIT, _FINITE_LIMIT)
        vn = (v - self.lo_r) / (self.hi_r - self.lo_r)
        h, w = self.h, LEGEND_WIDTH
        left, right = t < w, t > 1 - w
        top, bottom = vn > 1 - h, vn < h
        for corner, inside in zip(
            self.corners, (left & top, right & top, left & bottom, right & bottom)
        ):
            self.counts[corner] += int(np.count_nonzero(inside))
        for side, in_time in ((True, left), (False, right)):
            if in_time.any():
                self.seen[side] = True
                self.top[side] = max(self.top[side], float(v[in_time].max()))
                self.bottom[side] = min(self.bottom[side], float(v[in_time].min()))

    def placement(self):
        """(corner, value range), as :func:`legend_placement` says."""
        import rerun.blueprint as rrb

        counts = self.counts
        corner = min(counts, key=counts.get)
        lo_r, hi_r, pad, h = self.lo_r, self.hi_r, self.pad, self.h
        if counts[corner] == 0:  # the data's own range (rerun's auto range misjudged series
            return corner, (lo_r, hi_r)  # that start with a gap, e.g. d_o before any sighting)
        # Stretch the axis so that the data under the legend's box move out of it: on the
        # box's side, the data's extreme inside the box's time span sets the room needed.
        best = None
        for c_top in (True, False):
            for c_left in (True, False):
                if not self.seen[c_left]:
                    extreme = hi_r if c_top else lo_r
                else:
                    extreme = self.top[c_left] if c_top else self.bottom[c_left]
                # new range [a, b] with the legend box (h of it) beyond ``extreme``
                if c_top:
                    b = lo_r + (max(extreme + pad, lo_r) - lo_r) / (1.0 - h)
                    a, b = lo_r, max(b, hi_r)
                else:
                    a = hi_r - (hi_r - min(extreme - pad, hi_r)) / (1.0 - h)
                    a, b = min(a, lo_r), hi_r
                stretch = (b - a) / (hi_r - lo_r)
                if best is None or stretch < best[0]:
                    best = (stretch, c_top, c_left, (a, b))
        stretch, top, left, value_range = best
        corner = {
            (True, True): rrb.Corner2D.LeftTop,
            (True, False): rrb.Corner2D.RightTop,
            (False, True): rrb.Corner2D.LeftBottom,
            (False, False): rrb.Corner2D.RightBottom,
        }[(top, left)]
        if stretch > MAX_HEADROOM:  # rather some overlap than flattened curves
            return min(counts, key=counts.get), (lo_r, hi_r)
        return corner, (float(value_range[0]), float(value_range[1]))
