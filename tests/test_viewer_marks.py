"""The arena's metre marks stay few however wide the scenario (issue 37 item 12: a legal
scenario with start and target at +-9,999 m sent 20,007 labels to every tab)."""

from __future__ import annotations

import types

import pytest

from fuzzynav.app.viewer.scene import MAX_MARKS_PER_SIDE, Scene, mark_step_m


@pytest.mark.parametrize("size", [4, 16, 17, 48, 49, 100, 999, 20_000, 2_000_000])
def test_the_mark_step_keeps_each_side_under_the_cap(size):
    step = mark_step_m(size)
    assert size // step + 1 <= MAX_MARKS_PER_SIDE + 1
    assert step == 1 if size <= 16 else step >= 2


def test_a_20_km_arena_draws_a_few_dozen_marks():
    labels = []

    class FakeScene:
        def add_label(self, name, text, **kwargs):
            labels.append(name)

        def __getattr__(self, name):  # grid, box, removal, camera: not counted
            return lambda *args, **kwargs: None

    view = types.SimpleNamespace(
        server=types.SimpleNamespace(scene=FakeScene()),
        label_scale=lambda s: s,
        camera=types.SimpleNamespace(frame=lambda bounds: None),
    )
    scene = Scene.__new__(Scene)  # only frame_arena's drawing, on a scene that counts
    scene.view = view
    scene.frame_arena((-10_000, 10_000, -10_000, 10_000))
    marks = [n for n in labels if n.startswith("/marks/")]
    assert 0 < len(marks) <= 2 * (MAX_MARKS_PER_SIDE + 1), len(marks)
