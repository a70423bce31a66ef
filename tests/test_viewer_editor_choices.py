"""Issue 27, "inference choices as a lesson": the Editor's AND, implication, aggregation
and defuzzification dropdowns; a choice rebuilds the driving controller live, the
inference view follows, the downloaded .fis carries the choice and reads back.

The engine's side (each choice against simpful / scikit-fuzzy) is
tests/test_fuzzy_inference.py; the browser fixtures are test_viewer_browser.py's.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from test_viewer_browser import browser, open_tab, page, served, shared, step  # noqa: F401

from fuzzynav.app.viewer.editor import PaperEditor
from fuzzynav.app.viewer.model import ViewerApp, ViewerError
from fuzzynav.controller.inference import Inference
from fuzzynav.controller.rulebase import loads_toml


def test_the_editor_keeps_its_choices_through_slider_moves_and_resets():
    editor = PaperEditor()
    assert editor.choice("defuzz_method") == "centroid" and not editor.edited
    controller = editor.set_choice("agg_method", "probor")
    assert controller.fis.inference == Inference(agg_method="probor") and editor.edited
    # a slider move rebuilds the shapes and keeps the choice
    name = editor.names[0]
    lo, hi = editor.bounds[name]
    moved = editor.set(name, (lo + hi) / 2)
    assert moved.fis.inference.agg_method == "probor"
    # the downloaded rule base carries it (its rules read NONE as the text does: a .fis
    # cannot say that, and its TOML is the download)
    assert 'aggregation = "probor"' in editor.toml_text()
    assert loads_toml(editor.toml_text()).inference.agg_method == "probor"
    with pytest.raises(ValueError, match="a .fis cannot say"):
        editor.fis_text()
    with pytest.raises(ValueError, match="must be one of"):
        editor.set_choice("defuzz_method", "median")
    assert editor.reset().fis.inference == Inference()
    assert editor.choice("agg_method") == "max"


def test_the_viewer_drives_with_a_choice_at_once_and_refuses_an_unknown_one():
    app = ViewerApp("s1", "paper")  # not started: stepped by hand
    for _ in range(20):
        app.step_once()
    before = app.controller.last_output.copy()
    app.set_inference_choice("defuzz_method", "lom")
    assert app.controller_label == "paper (edited)"
    fis = app.controller.inner.fis
    assert fis.inference.defuzz_method == "lom"
    # the panels show the new controller's answer at the last inputs, at once
    assert np.array_equal(app.controller.last_output, fis.evaluate_one(app.controller.last_inputs))
    assert not np.allclose(app.controller.last_output, before)
    with pytest.raises(ViewerError, match="imp_method = 'max'"):
        app.set_inference_choice("imp_method", "max")
    assert loads_toml(app.editor().toml_text()).inference.defuzz_method == "lom"
    with pytest.raises(ViewerError, match=r"Download \.fis: .*a \.fis cannot say.*Download \.toml"):
        app.edited_fis_text()  # the download's sentence, in the page


@pytest.mark.browser
@pytest.mark.timeout(150)
def test_editor_choices_change_the_inference_view_and_the_downloaded_fis(served, page):  # noqa: F811
    app = served.app
    app.set_controller("paper")
    step(app, 40)
    open_tab(page, "Inference")
    page.wait_for_function(
        "() => document.querySelectorAll('.fz-rules').length > 0", timeout=15_000
    )
    view = page.locator(".fz-inference")
    assert "Outputs (centroid)" in view.inner_text()
    assert view.locator("g[transform*='scale(1,']").count() == 0  # clipped, not scaled
    before = app.controller.last_output.copy()

    open_tab(page, "Editor")
    for label, value in (("Defuzzification", "mom"), ("Implication", "prod")):
        page.get_by_role("combobox", name=label).click()
        page.get_by_role("option", name=value, exact=True).click()
    assert app.wait_for(
        lambda a: (
            a.controller.inner.fis.inference == Inference(imp_method="prod", defuzz_method="mom")
        ),
        timeout=10,
    ), app.controller.inner.fis.inference
    assert app.controller_label == "paper (edited)"
    after = app.controller.last_output.copy()
    assert not np.allclose(after, before)

    # the inference view names the method, draws the scaled consequents and shows the
    # new outputs
    open_tab(page, "Inference")
    page.wait_for_function(
        "() => document.querySelector('.fz-inference') &&"
        " document.querySelector('.fz-inference').innerText.includes('Outputs (MOM)')",
        timeout=15_000,
    )
    text = view.inner_text()
    assert "scaled by the rule's strength" in text
    assert view.locator("g[transform*='scale(1,']").count() > 0
    for value in after:
        assert f"{value:.2f}" in text

    # the downloaded rule base carries the choices and reads back to the driving system;
    # its rules read NONE as the text does, which a .fis cannot say: the page says so
    open_tab(page, "Editor")
    page.get_by_role("button", name="Download .fis").click()
    page.get_by_text("a .fis cannot say").first.wait_for(timeout=10_000)
    with page.expect_download(timeout=15_000) as download:
        page.get_by_role("button", name="Download .toml").click()
    text = Path(download.value.path()).read_text()
    assert 'implication = "prod"' in text and 'defuzzification = "mom"' in text
    back = loads_toml(text)
    assert back == app.controller.inner.fis
    x = app.controller.last_inputs
    assert np.array_equal(back.evaluate_one(x), app.controller.inner.fis.evaluate_one(x))

    # Reset: the shipped controller and its choices, in the dropdowns too
    page.get_by_role("button", name="Reset to shipped").click()
    assert app.wait_for(lambda a: a.controller_label == "paper", timeout=10)
    assert app.controller.inner.fis.inference == Inference()
    page.wait_for_function(
        "() => [...document.querySelectorAll('input')].some(e => e.value === 'centroid')",
        timeout=10_000,
    )
    assert page.get_by_role("combobox", name="Implication").input_value() == "min"
