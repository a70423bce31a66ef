"""The Editor tab: sliders for the membership parameters of the system that drives (the
starter's while it drives, else the paper controller's: :mod:`.editor`), its inference
choices, its rules, a download of the edited system and a reset. Both systems' sliders
are built once; only the driving one's are shown.
All of the Editor panel's code is here: its layout, its callbacks and its sync."""

from __future__ import annotations

from fuzzynav.app.viewer.compat_viser import handle_uuid
from fuzzynav.controller.inference import CHOICES

EDITOR_STEP = 0.01  # the editor's sliders (two decimals: the number boxes show them whole)
# The Editor's inference choices: field of controller.inference.Inference,
# label, and what the choice does, in words (MATLAB's names are the options).
EDITOR_CHOICES = (
    ("and_method", "AND", "how a rule joins its clauses: min, or prod (their product)"),
    (
        "imp_method",
        "Implication",
        "a rule's output set: min (its term clipped at the rule's strength) or prod (scaled by it)",
    ),
    (
        "agg_method",
        "Aggregation",
        "how the rules' sets combine: max, sum (may pass 1), probor (a + b - ab)",
    ),
    (
        "defuzz_method",
        "Defuzzification",
        "centroid, bisector (half the area each side), mom / som / lom: mean, smallest or "
        "largest (in magnitude) of the points where the set is highest",
    ),
)
# What the editor's numbers do, in words: the shipped paper controller's design layout
# (controller/paper_design.py), then the older 27-number (controller/paper.py) and
# partition (controller/paper_partition.py) layouts.
EDITOR_LABELS = {
    "d_t.c0": "VS holds 1 up to (m)",
    "d_t.top": "VL holds 1 from (m)",
    "d_t.r": "each next spacing grows (×)",
    "d_o.near": "near holds 1 up to (m)",
    "d_o.far": "far holds 1 from (m)",
    "phi_t.vp": "VP, VN hold 1 from (rad)",
    "phi_t.q": "P, N centre at vp / (1 + q)",
    "phi_o.vp": "VP, VN hold 1 from (rad)",
    "phi_o.q": "P, N centre at vp / (1 + q)",
    "v.e0": "VS holds 1 at (V)",
    "v.top": "VL holds 1 at (V)",
    "v.r": "each next spacing grows (×)",
    "d_t.a0": "VS full to, S starts (m)",
    "d_t.w1": "S peak after that (m)",
    "d_t.w2": "M centre after S (m)",
    "d_t.w3": "L peak after M (m)",
    "d_t.w4": "VL full after L (m)",
    "d_o.b0": "near full to (m)",
    "d_o.w1": "medium centre after (m)",
    "d_o.w2": "far full after that (m)",
    "phi_t.peak": "P, N peak (rad)",
    "phi_t.width": "VP, VN full after (rad)",
    "phi_t.zero": "Z half-width (rad)",
    "phi_t.foot": "P starts at (× peak)",
    "phi_o.peak": "P, N peak (rad)",
    "phi_o.width": "VP, VN peak after (rad)",
    "phi_o.zero": "Z half-width (rad)",
    "phi_o.foot": "P starts at (× peak)",
    "phi_o.tail": "VP, VN end after (rad)",
    "v.vs_end": "VS full to (V)",
    "v.vs_ramp": "VS falls over (V)",
    "v.s_offset": "S centre after VS (V)",
    "v.m_offset": "M centre after S (V)",
    "v.l_offset": "L centre after M (V)",
    "v.s_half": "S half-width (V)",
    "v.m_half": "M half-width (V)",
    "v.l_half": "L half-width (V)",
    "v.vl_offset": "VL starts after L (V)",
    "v.vl_ramp": "VL rises over (V)",
    # the starter's layout (app/viewer/starter.py)
    "d_t.near": "near holds 1 up to, far starts (m)",
    "d_t.ramp": "far holds 1 after (m)",
    "phi_t.full": "N, P hold 1 from (rad)",
    "v.slow": "slow centre (V)",
    "v.fast": "fast centre (V)",
}
EDITOR_KINDS = ("paper", "starter")
NO_TERM = "—"  # a rule picker's "this variable takes no part"


class EditorPanel:
    """The Editor tab of one :class:`app.viewer.server.ViewerServer`."""

    def __init__(self, view):
        self.view = view
        self.app = view.app
        self.editor_choices: dict = {}
        #: kind -> {"folders": [...], "sliders": {name: slider}, "term_plots": {...}}
        self.sections: dict = {}
        self._shown_kind = None

    @property
    def editor_sliders(self) -> dict:
        """The sliders of the system the Editor edits now."""
        section = self.sections.get(self.app.editor_kind())
        return section["sliders"] if section else {}

    @property
    def term_plots(self) -> dict:
        section = self.sections.get(self.app.editor_kind())
        return section["term_plots"] if section else {}

    def build(self) -> None:
        """Sliders for the membership parameters of each system the Editor edits (its
        layout's numbers: ordered terms stay valid), its rules and inference choices, a
        download and a reset."""
        gui = self.view.server.gui
        app = self.app
        editor = app.editor()
        self.intro_html = gui.add_html(self._intro(editor))
        self.now_html = gui.add_html("")  # the inputs' values on the plots (CSS)
        self.editor_buttons = gui.add_button_group(
            "Edited system", ("Download .fis", "Download .toml", "Reset to shipped")
        )
        self.editor_buttons.on_click(self.view.guarded(self._on_editor_button))
        self._build_rules(gui, editor)
        self.editor_choices = {}
        with gui.add_folder("Inference (MATLAB's choices)", expand_by_default=True):
            for field, label, hint in EDITOR_CHOICES:
                dropdown = gui.add_dropdown(
                    label, CHOICES[field], initial_value=editor.choice(field), hint=hint
                )
                dropdown.on_update(
                    self.view.guarded(
                        lambda e, field=field: app.set_inference_choice(field, e.value)
                    )
                )
                self.editor_choices[field] = dropdown
        for kind in EDITOR_KINDS:
            self.sections[kind] = self._build_sliders(gui, app.editor(kind), kind)
        self._shown_kind = app.editor_kind()
        self._show_rule(1)  # (the pickers at rule 1's terms)

    def _intro(self, editor) -> str:
        note = (
            "The sliders start from the shipped system's own numbers."
            if editor.exact
            else "The shipped rule base does not record its parameters: the sliders start "
            "from the tuner's starting point (Reset drives with the shipped one)."
        )
        return (
            "<div class='fz-editor-intro' style='font-size:0.85em;padding:0 6px'>Editing "
            f"<b>{editor.label}</b>, the system that drives. Move a slider or change an "
            "inference choice and the robot drives with the edited system at once (the run "
            "goes on). Each number places a term (where it holds 1 or is centred) or sets a "
            f"spacing between terms, so the terms stay in order whatever you do. {note}</div>"
        )

    def _build_sliders(self, gui, editor, kind: str) -> dict:
        """One folder of sliders per variable of ``editor``'s layout, each with its
        terms drawn to drag; shown while ``kind`` is the system the Editor edits."""
        groups: dict[str, list[str]] = {}
        for name in editor.names:
            groups.setdefault(name.split(".")[0], []).append(name)
        titles = {"v": "outputs left, right (V)"}
        shown = kind == self.app.editor_kind()
        section = {"folders": [], "sliders": {}, "term_plots": {}}
        for group, names in groups.items():
            folder = gui.add_folder(
                titles.get(group, group), expand_by_default=group == "d_t", visible=shown
            )
            section["folders"].append(folder)
            with folder:
                section["term_plots"][group] = (gui.add_html(""), names)
                for name in names:
                    lo, hi = editor.bounds[name]
                    slider = gui.add_slider(
                        EDITOR_LABELS.get(name, name.split(".", 1)[1]),
                        lo,
                        hi,
                        step=EDITOR_STEP,
                        # rounded to the step, kept inside the bounds (pi is a bound)
                        initial_value=min(max(round(editor.value(name), 2), lo), hi),
                        hint=f"{name} in the layout's terms; {lo:g} to {hi:g}",
                    )
                    slider.on_update(
                        self.view.guarded(
                            lambda e, name=name: self.app.set_membership_parameter(name, e.value)
                        )
                    )
                    section["sliders"][name] = slider
        return section

    def _draw_inputs_now(self, editor) -> None:
        """The current inputs (those tried in What-if, while it is on) as red lines on
        the Editor's plots."""
        import math

        from fuzzynav.app.viewer.term_drag import now_css

        app = self.app
        x = app.what_if if app.what_if is not None else app.controller.last_inputs
        values = [round(float(v), 2) if math.isfinite(float(v)) else None for v in list(x)[:4]]
        content = now_css(editor.controller().fis, values)
        if self.now_html.content != content:
            self.now_html.content = content

    def _draw_term_plots(self) -> None:
        """Each slider group's terms with a handle on every corner a slider moves
        (shaped by dragging, beside the sliders); drawn again when the
        edited system changes."""
        from fuzzynav.app.viewer.term_drag import terms_drag_svg

        editor = self.app.editor()
        fis = editor.controller().fis
        if fis is getattr(self, "_term_plots_for", None):  # (held: its id is never reused)
            return
        self._term_plots_for = fis
        ids = {name: handle_uuid(slider) for name, slider in self.editor_sliders.items()}
        ranges = {name: (s.min, s.max) for name, s in self.editor_sliders.items()}
        for group, (element, names) in self.term_plots.items():
            try:
                content = terms_drag_svg(editor, group, names, ids, ranges)
            except Exception:  # a layout without positions: the sliders alone
                content = ""
            if element.content != content:
                element.content = content

    def _build_rules(self, gui, editor) -> None:
        """The rules, edited like a designer's: pick a rule by its number, its
        sentence in the box; change it and Apply, or Add it as a new rule, Remove the
        rule picked, Undo the last rule edit. Every sentence is read by the rule base's
        own parser (terms and variables checked); the robot drives with it at once."""
        n = editor.rule_count()
        with gui.add_folder("Rules (add, change, remove)", expand_by_default=False):
            self.rule_number = gui.add_number(
                "Rule", 1, min=1, max=n, step=1, hint="the rule to read, change or remove"
            )
            self.rule_text = gui.add_text(
                "Sentence",
                editor.rule_text(1),
                hint="if <input> is <term> and ... then <output> is <term> and ... [weight w]",
            )
            self._written_sentence = editor.rule_text(1)  # the box's text as this panel set it
            self.rule_buttons = gui.add_button_group(
                "Rule edit", ("Apply", "Add as new", "Remove", "Undo")
            )
            # Or pick the terms from lists: the sentence is written from them.
            self.rule_pickers = []
            fis = editor.controller().fis
            with gui.add_folder("Pick the terms", expand_by_default=False):
                for k, var in enumerate(fis.inputs + fis.outputs):
                    picker = gui.add_dropdown(
                        var.name,
                        self._picker_options(var),
                        initial_value=NO_TERM,
                        hint=f"the rule's term of {var.name} ({NO_TERM}: it takes no part)",
                    )
                    picker.on_update(self.view.guarded(lambda e, k=k: self._on_picker(k, e.value)))
                    self.rule_pickers.append(picker)
        self.rule_number.on_update(self.view.guarded(self._on_rule_number))
        self.rule_buttons.on_click(self.view.guarded(self._on_rule_button))

    def _show_rule(self, number: int, keep_typed: bool = False) -> None:
        """Show rule ``number`` in the box and the pickers; with ``keep_typed``, a
        sentence the user has typed since the panel last wrote the box stays (a refresh
        after an edit built elsewhere must not take away what is being typed)."""
        editor = self.app.editor()
        n = editor.rule_count()
        number = min(max(int(number), 1), n)
        if self.rule_number.max != n:
            self.rule_number.max = n
        if self.rule_number.value != number:
            self.rule_number.value = number
        if not (keep_typed and self.rule_text.value != self._written_sentence):
            self._write_sentence(editor.rule_text(number))
        fis = editor.controller().fis
        rule = editor.rule(number)
        picks = list(rule.antecedent) + list(rule.consequent)
        for picker, var, k in zip(self.rule_pickers, fis.inputs + fis.outputs, picks):
            options = self._picker_options(var)
            if tuple(picker.options) != options:
                picker.options = options
            value = NO_TERM if k is None else var.terms[k].name
            if picker.value != value:
                picker.value = value

    @staticmethod
    def _picker_options(var) -> tuple[str, ...]:
        return (NO_TERM, *(t.name for t in var.terms))

    def _on_picker(self, index: int, value: str) -> None:
        """A term picked: the sentence in the box is written from the pickers (Apply or
        Add as new then reads it as a typed one)."""
        fis = self.app.editor().controller().fis
        picks = [p.value for p in self.rule_pickers]
        picks[index] = value
        names = [v.name for v in fis.inputs + fis.outputs]
        n_in = len(fis.inputs)

        def clauses(part):
            return " AND ".join(f"{n} IS {t}" for n, t in part if t != NO_TERM)

        pairs = list(zip(names, picks))
        self._write_sentence(f"IF {clauses(pairs[:n_in])} THEN {clauses(pairs[n_in:])}")

    def _write_sentence(self, text: str) -> None:
        self._written_sentence = text
        self.rule_text.value = text

    def _on_rule_number(self, event) -> None:
        self._show_rule(int(event.value))

    def _on_rule_button(self, event) -> None:
        number = int(self.rule_number.value)
        text = str(self.rule_text.value)
        action = {"Apply": "set", "Add as new": "add", "Remove": "remove", "Undo": "undo"}[
            event.value
        ]
        self.app.edit_rules(action, number, text, wait=False)  # built off this thread
        n = self.app.editor().rule_count()
        self._show_rule(n if action == "add" else number)

    def _on_editor_button(self, event) -> None:
        editor = self.app.editor()
        if event.value == "Download .toml":
            text = editor.toml_text()
            event.client.send_file_download(
                f"{editor.file_stem}.toml", text.encode("utf-8"), save_immediately=True
            )
            return
        if event.value == "Download .fis":
            text = self.app.edited_fis_text()  # a sentence if a .fis cannot hold it
            event.client.send_file_download(
                f"{editor.file_stem}.fis", text.encode("utf-8"), save_immediately=True
            )
            return
        self.app.reset_membership_editor()
        editor = self.app.editor()
        for name, slider in self.editor_sliders.items():
            slider.value = round(editor.value(name), 2)
        for field, dropdown in self.editor_choices.items():
            dropdown.value = editor.choice(field)
        self._show_rule(1)

    def sync(self) -> None:
        """The Editor as the system that drives has it: its sliders shown (and at its
        numbers: another tab may have moved them, a lesson opened brings its own), its
        rules, its choices."""
        kind = self.app.editor_kind()
        editor = self.app.editor(kind)
        if kind != self._shown_kind:
            self._shown_kind = kind
            for other, section in self.sections.items():
                for folder in section["folders"]:
                    if folder.visible != (other == kind):
                        folder.visible = other == kind
            self.intro_html.content = self._intro(editor)
            self._show_rule(1)
        shown = getattr(self, "_shown_rules", (None, None))
        # edited here or elsewhere (what is being typed stays), or another editor (a
        # lesson opened brings its own: its rule shown whatever was typed)
        if shown[0] is not editor or shown[1] != editor.rule_version():
            self._shown_rules = (editor, editor.rule_version())
            self._show_rule(int(self.rule_number.value), keep_typed=shown[0] is editor)
        if self.sections:
            self._draw_term_plots()
            self._draw_inputs_now(editor)
        for name, slider in self.editor_sliders.items():
            value = round(editor.value(name), 2)  # as the slider shows it
            if abs(slider.value - value) > 1e-9:
                slider.value = value
        for field, dropdown in self.editor_choices.items():
            if dropdown.value != editor.choice(field):
                dropdown.value = editor.choice(field)
