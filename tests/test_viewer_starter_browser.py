"""The guide's first lesson, given with the starter system in a real headless Chromium:
every view follows the system that drives (the Editor's sliders and rules, What-if,
step by step), and the controller stays the starter throughout. The helpers are
tests/test_viewer_browser.py's."""

from __future__ import annotations

import pytest
from test_viewer_browser import browser, open_tab, served_page  # noqa: F401  (a fixture)

from fuzzynav.app.viewer import compat_viser
from fuzzynav.app.viewer.starter import STARTER_EDITED_LABEL, STARTER_LABEL
from fuzzynav.controller.registry import controller_names

pytestmark = [
    pytest.mark.browser,
    pytest.mark.timeout(150),
    pytest.mark.skipif("paper" not in controller_names(), reason="no paper controller"),
]


@pytest.fixture(scope="module")
def starter(browser):  # noqa: F811
    with served_page(browser) as served:
        yield served


def box_of(page, handle):
    """The number box of a viser slider or the input of a text/number handle."""
    uuid = compat_viser.handle_uuid(handle)
    return page.locator(f"div:has(> div > p > label[for='{uuid}']) input").last


def wait_box(page, box, text: str) -> None:
    try:
        page.wait_for_function(
            "([e, t]) => e.value === t", arg=[box.element_handle(), text], timeout=10_000
        )
    except Exception:
        raise AssertionError(f"the box shows {box.input_value()!r}, not {text!r}") from None


# d_t and phi_t's what-if sliders shown, d_o and phi_o's not (not in the page at all, or
# hidden)
JS_SHOWN_LABELS = """(ids) => ids.map((id) => {
  const e = document.querySelector(`label[for='${id}']`);
  return !!e && e.checkVisibility();
}).join() === 'true,false,true,false'"""


def is_starter(app) -> bool:
    return app.controller_label in (STARTER_LABEL, STARTER_EDITED_LABEL)


def test_the_first_lesson_with_the_starter_in_every_view(starter):
    """Controller = starter; the Editor shows the starter's sliders (not the paper's)
    and a slider edits the starter (it stays the starter, and the message says so); the
    starter's own rule applies unchanged and edited (checked against the starter's
    terms); step by step and What-if show only d_t and phi_t."""
    server, page, _ = starter
    app = server.app
    app.pause()
    app.load_scenario("s1")
    for _ in range(20):
        app.step_once()
    page.get_by_role("combobox", name="Controller").click()
    page.get_by_role("option", name=STARTER_LABEL, exact=True).click()
    assert app.wait_for(lambda a: a.controller_label == STARTER_LABEL, timeout=10)

    # -- the Editor: the starter's sliders, the paper's hidden ----------------------------
    open_tab(page, "Editor")
    sliders = server.editor.sections["starter"]["sliders"]
    near = box_of(page, sliders["d_t.near"])
    near.wait_for(state="visible", timeout=10_000)
    paper_first = server.editor.sections["paper"]["sliders"]
    assert not box_of(page, next(iter(paper_first.values()))).is_visible()
    page.wait_for_function(
        "() => document.querySelector('.fz-editor-intro')?.innerText.includes('starter')",
        timeout=10_000,
    )
    wait_box(page, near, "0.5")
    near.fill("1.2")
    near.press("Enter")
    assert app.wait_for(lambda a: a.controller_label == STARTER_EDITED_LABEL, timeout=10), (
        app.controller_label,
        app.message,
    )
    fis = app.fuzzy_system()
    assert len(fis.rules) == 6 and fis.inputs[0].terms[0].params == pytest.approx((1.2, 3.7))
    page.wait_for_function(
        "() => document.querySelector('.fz-message')?.innerText.includes('starter (edited)')",
        timeout=10_000,
    )

    # -- the rule editor checks against the starter's rule base ---------------------------
    page.get_by_text("Rules (add, change, remove)", exact=True).click()
    try:
        text_box = box_of(page, server.editor.rule_text)
        first = app.editor().rule_text(1)
        assert "far" in first  # the starter's own term, which the paper's d_t lacks
        wait_box(page, text_box, first)
        before = app.fuzzy_system().rules
        page.get_by_role("button", name="Apply").click()  # unchanged
        assert app.wait_for(lambda a: "rule edit: set" in a.message, timeout=10), app.message
        assert app.message_level == "info" and app.fuzzy_system().rules == before
        edited = "IF d_t IS far AND phi_t IS Z THEN left IS fast AND right IS slow"
        text_box.fill(edited)
        assert app.wait_for(lambda a: server.editor.rule_text.value == edited, timeout=10), (
            server.editor.rule_text.value
        )
        page.get_by_role("button", name="Apply").click()
        assert app.wait_for(lambda a: a.fuzzy_system().rules[0] != before[0], timeout=10), (
            app.message
        )
        assert app.editor().rule_text(1) == edited and len(app.fuzzy_system().rules) == 6
        assert is_starter(app)
    finally:
        page.get_by_text("Rules (add, change, remove)", exact=True).click()

    # -- step by step: the starter's two inputs ------------------------------------------
    open_tab(page, "Inference")
    page.get_by_text("Step by step", exact=True).click()
    try:
        page.get_by_role("button", name="Next ▶").click()
        page.wait_for_function(
            "() => document.querySelector('.fz-stepwise')?.dataset.stage == '1'",
            timeout=10_000,
        )
        said = page.locator(".fz-stepwise").inner_text()
        assert "d_t" in said and "phi_t" in said
        assert "d_o" not in said and "phi_o" not in said
        assert " near " in said or "far" in said  # the starter's terms
        page.get_by_role("button", name="Off").click()
        page.wait_for_function("() => !document.querySelector('.fz-stepwise')", timeout=10_000)
    finally:
        server.inference.stage = 0
        page.get_by_text("Step by step", exact=True).click()
    assert is_starter(app)

    # -- What-if: only the inputs the starter reads --------------------------------------
    page.get_by_text("What-if", exact=True).click()
    page.get_by_role("checkbox", name="What-if mode").click()
    try:
        assert app.wait_for(lambda a: a.what_if is not None, timeout=10)
        boxes = [box_of(page, b) for b in server.inference.what_if_boxes]
        uuids = [compat_viser.handle_uuid(b) for b in server.inference.what_if_boxes]
        page.wait_for_function(JS_SHOWN_LABELS, arg=uuids, timeout=10_000)
        page.wait_for_function("(e) => !e.disabled", arg=boxes[2].element_handle())
        boxes[2].fill("0.3")
        boxes[2].press("Enter")
        assert app.wait_for(lambda a: a.what_if is not None and a.what_if[2] == 0.3, timeout=10)
        page.wait_for_function(
            "() => /phi_t\\s*=?\\s*0\\.30/.test(document.querySelector('.fz-inference')"
            "?.innerText || '')",
            timeout=10_000,
        )
        assert is_starter(app) and app.message_level not in ("error", "warning")
    finally:
        page.get_by_role("checkbox", name="What-if mode").click()
        page.get_by_text("What-if", exact=True).click()
    assert app.wait_for(lambda a: a.what_if is None, timeout=10)
    assert is_starter(app)
    # the surface follows the starter: one map, over (d_t, phi_t)
    assert [p[2:4] for p in server.surface._surface_planes] == [(0, 2)]


def test_a_starter_rule_is_written_from_the_term_pickers_and_added(starter):
    """Rules → Pick the terms: a list per variable, of the driving system's terms (the
    starter's near and far for d_t); a pick writes the sentence, Add as new adds it."""
    server, page, _ = starter
    app = server.app
    app.pause()
    app.load_scenario("s1")
    app.set_controller(STARTER_LABEL)
    app.reset_membership_editor()  # the starter as shipped (an earlier test edited it)
    open_tab(page, "Editor")
    page.get_by_text("Rules (add, change, remove)", exact=True).click()
    uuid = compat_viser.handle_uuid(server.editor.rule_pickers[0])  # d_t's
    picker = page.locator(f"[id='{uuid}']")
    if not picker.is_visible():  # the folder opens on a click (an earlier test may leave it open)
        page.get_by_text("Pick the terms", exact=True).click()
    try:
        picker.wait_for(state="visible", timeout=30_000)
        text_box = box_of(page, server.editor.rule_text)
        wait_box(page, text_box, app.editor().rule_text(1))
        picker.click()
        options = page.get_by_role("option").all_inner_texts()
        assert [o.strip() for o in options] == ["—", "near", "far"], options
        page.get_by_role("option", name="near", exact=True).click()
        want = "IF d_t IS near AND phi_t IS Z THEN left IS fast AND right IS fast"
        wait_box(page, text_box, want)
        page.get_by_role("button", name="Add as new").click()
        assert app.wait_for(lambda a: len(a.fuzzy_system().rules) == 7, timeout=10)
        assert app.editor().rule_text(7) == want and is_starter(app)
    finally:
        if picker.is_visible():
            page.get_by_text("Pick the terms", exact=True).click()
        page.get_by_text("Rules (add, change, remove)", exact=True).click()
        app.set_controller("paper")
