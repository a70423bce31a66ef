"""Issue 37 item 13, the figures' part: a controller answering +-1e308 V is drawn
without numpy's or matplotlib's RuntimeWarnings (its output before saturation is drawn
within ten times the limit, and the legend says so). Failed before: 62 overflow
warnings from matplotlib's tick and transform arithmetic."""

from __future__ import annotations

import warnings

import numpy as np

import fuzzynav


class _Huge:
    def reset(self) -> None:
        pass

    def __call__(self, inputs, **kwargs):
        return np.array([1e308, -1e308])


def test_figures_of_a_controller_answering_1e308_warn_nothing(tmp_path):
    run = fuzzynav.simulate("s1", controller=_Huge())
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)
        written = run.figures(tmp_path)
    assert written
    from fuzzynav.app.figures.run_figures import _drawable_output

    drawn, label = _drawable_output(np.array([1e308, -1e308, 3.0]), 12.0)
    assert drawn.tolist() == [120.0, -120.0, 3.0] and "within ±120 V" in label
    assert _drawable_output(np.array([13.0, -2.0]), 12.0)[1] == "before saturation"


def test_a_recording_of_a_controller_answering_1e308_warns_nothing(tmp_path):
    """The recording's part: the legend placement's arithmetic over a plot whose values
    reach 1e308 overflowed (numpy's RuntimeWarning from app/recordings/blueprint.py)."""
    run = fuzzynav.simulate("s1", controller=_Huge())
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)
        path = run.save_rrd(tmp_path / "huge.rrd")
    assert path.stat().st_size > 10_000
