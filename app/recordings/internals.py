"""What a controller did inside, in a recording: which controller it is, its fuzzy
system, the firing of its rules (a bar chart per decision, a heatmap of the run, the
rules in words) and fuzzynav's inner state (from the decisions it logged while it drove,
or replayed through a copy).

:class:`ControllerColumns` is the part of the column writer
(:class:`~fuzzynav.app.recordings.columns.ColumnWriter`) that sends them.
"""

from __future__ import annotations

import copy

import numpy as np

from .arrow import StaticBatch, tensor_rows, time_column
from .style import SERIES_PALETTE


def controller_fis(controller, *, merged: bool = False):
    """The controller's ``FuzzySystem`` (its ``fis`` attribute), or None. With ``merged``
    (the membership figures), a controller of fuzzy blocks (fuzzynav, the baseline: its
    ``rule_blocks``) without a ``fis`` gives its blocks merged into one (``merged``: every
    block's inputs and outputs, under names unique across them)."""
    if controller is None:
        return None
    inner = getattr(controller, "inner", controller)  # the viewer wraps its controller
    fis = getattr(inner, "fis", None)
    if fis is None and merged and callable(getattr(inner, "rule_blocks", None)):
        fis = getattr(inner, "merged", None)
    return fis if hasattr(fis, "firing_strengths") else None


def has_internals(controller) -> bool:
    """Whether the controller logs its inner state (fuzzynav's ``decisions``: per call,
    the two voltages and the :data:`INTERNALS`); that state is then recorded, from the
    log of the controller that drove or, failing that, replayed through a copy."""
    inner = getattr(controller, "inner", controller)  # the viewer wraps its controller
    return controller is not None and isinstance(getattr(inner, "decisions", None), list)


def rule_system(controller):
    """The fuzzy system whose rules' firing a recording plots: the controller's ``fis``
    (fed the four logged inputs), else for a controller that logs its decisions its
    ``merged`` blocks (fed the blocks' inputs it logged); None if neither."""
    fis = controller_fis(controller)
    if fis is not None:
        return fis
    inner = getattr(controller, "inner", controller)
    merged = getattr(inner, "merged", None) if has_internals(controller) else None
    return merged if hasattr(merged, "firing_strengths") else None


def controller_replica(controller):
    """A fresh copy of a controller that explains itself, through which the logged inputs
    are replayed to record its inner state when it did not log its decisions; else None."""
    if not has_internals(controller):
        return None
    inner = getattr(controller, "inner", controller)
    replica = copy.deepcopy(inner)
    replica.reset()
    return replica


INTERNALS_PATH = "/plots/internals"
INTERNALS = (
    "avoidance weight alpha",
    "planner offset (rad)",
    "yield (1) / pass first (-1)",
    "following an edge (1)",
    "target reading doubted (1)",
)


def controller_label(controller, unknown: str | None = "unknown") -> str | None:
    """The controller's name (its ``name``, else its class's); ``unknown`` for None."""
    if controller is None:
        return unknown
    name = getattr(controller, "name", None)
    if isinstance(name, str) and name:
        return name
    return type(controller).__name__


RULES_PATH = "/rules/firing"  # BarChart per step: every rule's firing strength (float32)
RULES_HEATMAP_PATH = "/rules/heatmap"  # static Tensor, rules x time bins (max per bin)
RULES_TEXT_PATH = "/rules/texts"  # static TextDocument: R1 ... Rn in words
RULES_STRONGEST_PATH = "/rules/strongest"  # StateChange: the strongest rule where it changes
#: A static bar of height 1 at abscissa 0, in the bar chart's view: rerun's bar chart
#: fits its axis to the bars it draws (0.41 has no axis range for it), so without it
#: the axis followed the strongest rule of the moment.
RULES_SCALE_PATH = f"{RULES_PATH}/scale"
#: The heatmap drawn with its rows named (a rerun tensor view names no row): the same
#: values as a colour-mapped image, R1 ... Rn beside its rows, seconds under its columns.
HEATMAP_IMAGE_PATH = f"{RULES_HEATMAP_PATH}/image"
HEATMAP_ROWS_PATH = f"{RULES_HEATMAP_PATH}/rows"
HEATMAP_TIMES_PATH = f"{RULES_HEATMAP_PATH}/times"
#: The heatmap image is drawn this many rows wide (its columns scaled to it), so that
#: it fills a panel about three times as wide as high, whatever the number of bins.
HEATMAP_ASPECT = 3.0
#: Where the row names stand, left of the image (in rows).
HEATMAP_LABEL_X = -2.5
#: The most time bins of the rule heatmap (a long run is binned: the max per bin).
HEATMAP_MAX_BINS = 1500


def rule_heatmap(strengths: np.ndarray, max_bins: int) -> np.ndarray:
    """(rules, bins) float32: the firing strengths (rows, rules) binned over time, each
    bin the largest strength of its rows; one column per row if there are few."""
    strengths = np.asarray(strengths, dtype=np.float32)
    n = len(strengths)
    if n <= max_bins:
        return np.ascontiguousarray(strengths.T)
    edges = np.linspace(0, n, max_bins + 1).astype(int)
    return np.ascontiguousarray(np.maximum.reduceat(strengths, edges[:-1], axis=0).T)


#: Rule strengths a live recording's heatmap keeps in memory (float32) before it writes
#: them to an unnamed temporary file: how long a live run will be is not known while it
#: runs, and the heatmap's bins are fractions of it.
HEAT_MEMORY_BYTES = 8 * 1024**2


class RuleHeat:
    """The run's rule firing as it comes, a chunk of decisions at a time: what the
    heatmap (:func:`rule_heatmap` of all of them) and its caption need, without keeping
    every decision. When their number is known in advance (``expected``, as
    ``record_run`` knows it) and above ``max_bins``, each bin's running maximum is kept,
    which is the same float32 maximum ``rule_heatmap`` takes over the whole run (a
    maximum does not depend on the order). Otherwise (a live recording, whose length
    nobody knows yet) the decisions are kept, beyond :data:`HEAT_MEMORY_BYTES` in an
    unnamed temporary file, and binned a block at a time at the end."""

    def __init__(self, expected: int | None = None, max_bins: int | None = None):
        self.max_bins = int(HEATMAP_MAX_BINS if max_bins is None else max_bins)
        self.count = 0  # decisions seen
        self.first_s: float | None = None
        self.last_s: float | None = None
        self.last_state: int | None = None  # the strongest rule at the last decision
        self.rules = 0
        self.calls = 0
        self._parts: list[np.ndarray] = []
        self._kept_bytes = 0
        self._spool = None  # the decisions that left memory (float32 rows), in order
        self._spooled = 0
        self._bins: np.ndarray | None = None
        self._starts: np.ndarray | None = None
        self.expected = None if expected is None else int(expected)
        if self.expected is not None and self.expected > self.max_bins:
            self._starts = _bin_starts(self.expected, self.max_bins)

    def add(self, times: np.ndarray, strengths: np.ndarray) -> np.ndarray:
        """Take the decisions at ``times`` (their ``strengths``, float32, NaN for a rule
        not evaluated); returns them with NaN as 0, as the heatmap has them."""
        strengths = np.nan_to_num(np.asarray(strengths, dtype=np.float32), nan=0.0)
        self.calls += 1
        if len(times):
            self.first_s = float(times[0]) if self.first_s is None else self.first_s
            self.last_s = float(times[-1])
        m, self.rules = strengths.shape
        if self._starts is None:
            self._keep(strengths)
        elif m:
            if self.count + m > self.expected:
                raise ValueError(f"{self.count + m} decisions, {self.expected} announced")
            if self._bins is None:
                self._bins = np.full((self.max_bins, self.rules), -np.inf, np.float32)
            _bin_maxima(self._bins, self._starts, self.count, strengths)
        self.count += m
        return strengths

    def _keep(self, strengths: np.ndarray) -> None:
        self._parts.append(strengths)
        self._kept_bytes += strengths.nbytes
        if self._kept_bytes > HEAT_MEMORY_BYTES:
            if self._spool is None:
                import tempfile

                self._spool = tempfile.TemporaryFile(prefix="fuzzynav-heat-")
            for part in self._parts:
                if part.size:
                    self._spool.write(np.ascontiguousarray(part).data)
                    self._spooled += len(part)
            self._parts, self._kept_bytes = [], 0

    def heatmap(self) -> np.ndarray:
        """(rules, bins) float32, as :func:`rule_heatmap` of every decision taken."""
        if self._starts is None and self._spool is None:
            return rule_heatmap(np.concatenate(self._parts), self.max_bins)
        if self._starts is None and self.count <= self.max_bins:  # (a bin a row)
            return rule_heatmap(np.concatenate(list(self._kept_blocks())), self.max_bins)
        if self._starts is None:  # spooled: bin a block at a time
            starts = _bin_starts(self.count, self.max_bins)
            bins = np.full((self.max_bins, self.rules), -np.inf, np.float32)
            done = 0
            for rows in self._kept_blocks():
                _bin_maxima(bins, starts, done, rows)
                done += len(rows)
            return np.ascontiguousarray(bins.T)
        if self._bins is None:  # no decision came (the firing could not be evaluated)
            return np.zeros((self.rules, 0), np.float32)
        filled = self._bins
        if self.count < self.expected:  # the firing stopped being recorded mid-run
            filled = filled[: int(np.searchsorted(self._starts, self.count, side="left"))]
        return np.ascontiguousarray(filled.T)

    def _kept_blocks(self):
        """The kept decisions in order, a block at a time: the spool's, then memory's."""
        self._spool.flush()
        self._spool.seek(0)
        block = max(1, HEAT_MEMORY_BYTES // (4 * max(1, self.rules)))
        done = 0
        while done < self._spooled:
            m = min(block, self._spooled - done)
            raw = self._spool.read(m * self.rules * 4)
            yield np.frombuffer(raw, dtype=np.float32).reshape(m, self.rules)
            done += m
        yield from (part for part in self._parts if len(part))


def _bin_starts(n: int, max_bins: int) -> np.ndarray:
    """The first row of each of :func:`rule_heatmap`'s bins of ``n`` rows (n > max_bins:
    strictly increasing, every bin has rows)."""
    return np.linspace(0, n, max_bins + 1).astype(int)[:-1]


def _bin_maxima(bins: np.ndarray, starts: np.ndarray, first_row: int, rows: np.ndarray) -> None:
    """Fold ``rows`` (rows ``first_row`` on) into the running maximum of their bins."""
    index = np.arange(first_row, first_row + len(rows))
    which = np.searchsorted(starts, index, side="right") - 1
    first = np.flatnonzero(np.r_[True, which[1:] != which[:-1]])
    maxima = np.maximum.reduceat(rows, first, axis=0)
    bins[which[first]] = np.maximum(bins[which[first]], maxima)


def heatmap_row_labels(n_rules: int) -> list[int]:
    """The rules (1 to n) named beside the heatmap's rows: every one up to 15, else R1,
    every fifth and the last (rerun writes a label about 16 px high: one a row would
    overlap at 40 rules in a panel 300 px high)."""
    if n_rules <= 15:
        return list(range(1, n_rules + 1))
    rows = [1] + list(range(5, n_rules + 1, 5))
    if n_rules - rows[-1] >= 3:
        rows.append(n_rules)
    return rows


#: The heatmap panel's size at 1600 x 1000 (px, about: the rules tab's third view) and
#: how far below its anchor point rerun writes a label's middle (5 px, then half its
#: height): the row names are anchored this much above their rows.
HEATMAP_PANEL_PX = (780.0, 330.0)
LABEL_DROP_PX = 14.0


def heatmap_bounds(n_rules: int) -> tuple[list[float], list[float]]:
    """(x range, y range) of the heatmap's view: the image (``HEATMAP_ASPECT * n``
    wide, ``n`` high, y down), the row names on its left, the seconds under it."""
    n = max(int(n_rules), 1)
    width = HEATMAP_ASPECT * n
    return [HEATMAP_LABEL_X - 2.5, width + 1.0], [-1.0, n + 0.12 * n + 3.0]


def _label_drop(n_rules: int) -> float:
    """:data:`LABEL_DROP_PX` in the heatmap view's units (rows), at its panel's size."""
    (x0, x1), (y0, y1) = heatmap_bounds(n_rules)
    px_per_unit = min(HEATMAP_PANEL_PX[0] / (x1 - x0), HEATMAP_PANEL_PX[1] / (y1 - y0))
    return LABEL_DROP_PX / px_per_unit


def time_ticks(first_s: float, last_s: float, most: int = 8) -> list[float]:
    """Round seconds between ``first_s`` and ``last_s`` (at most ``most`` of them)."""
    span = max(float(last_s) - float(first_s), 0.0)
    step = next(
        (s for s in (0.1, 0.2, 0.5, 1, 2, 5, 10, 20, 30, 60, 120, 300, 600) if span / s < most),
        10 ** np.ceil(np.log10(max(span, 1.0))),
    )
    start = np.ceil(first_s / step - 1e-9) * step
    return [float(t) for t in np.arange(start, last_s + 1e-9, step)]


def send_heatmap_image(static: StaticBatch, heatmap: np.ndarray, first_s, per_bin_s) -> None:
    """The heatmap as rerun draws an image, with its rows named: a colour-mapped depth
    image of the same values (viridis, 0 to 1) scaled to :data:`HEATMAP_ASPECT` times
    as wide as high, ``R1`` ... ``Rn`` left of its rows (:func:`heatmap_row_labels`,
    each with a tick on the image's edge) and seconds under its columns."""
    import rerun as rr

    n_rules, bins = heatmap.shape
    scale_x = HEATMAP_ASPECT * n_rules / bins
    static.add_archetype(
        HEATMAP_IMAGE_PATH,
        rr.DepthImage(
            np.ascontiguousarray(heatmap, dtype=np.float32),
            meter=1.0,
            colormap="viridis",
            depth_range=[0.0, 1.0],
        ),
    )
    static.add_archetype(HEATMAP_IMAGE_PATH, rr.Transform3D(scale=[scale_x, 1.0, 1.0]))
    rows = heatmap_row_labels(n_rules)
    drop = _label_drop(n_rules)
    grey = (90, 90, 90)
    static.add_archetype(
        HEATMAP_ROWS_PATH,
        rr.Points2D(
            positions=[(HEATMAP_LABEL_X, k - 0.5 - drop) for k in rows],
            radii=0.01,
            colors=[grey] * len(rows),
            labels=[f"R{k}" for k in rows],
            show_labels=True,
        ),
    )
    ticks = [[(-0.9, k - 0.5), (0.0, k - 0.5)] for k in rows]
    first = float(first_s or 0.0)
    last = first + per_bin_s * (bins - 1)
    times = time_ticks(first, last) if bins > 1 and per_bin_s > 0 else [first]
    xs = [
        ((t - first) / per_bin_s + 0.5) * scale_x if per_bin_s > 0 else 0.5 * scale_x for t in times
    ]
    ticks += [[(x, n_rules), (x, n_rules + 0.6)] for x in xs]
    static.add_archetype(
        f"{RULES_HEATMAP_PATH}/ticks",
        rr.LineStrips2D(ticks, radii=0.08, colors=[grey] * len(ticks)),
    )
    static.add_archetype(
        HEATMAP_TIMES_PATH,
        rr.Points2D(
            positions=[(x, n_rules + 0.6) for x in xs],
            radii=0.01,
            colors=[grey] * len(xs),
            labels=[f"{t + 0.0:g} s" for t in times],
            show_labels=True,
        ),
    )


class ControllerColumns:
    """The controller's inside, rows [start, end) at a time: every rule's firing and
    fuzzynav's inner state (:data:`INTERNALS`). A part of
    :class:`~fuzzynav.app.recordings.columns.ColumnWriter`, whose state it uses: the
    stream, the styles and the plots (``_style``, ``_plot``, ``_rows``), the controller,
    its ``fis`` or ``blocks``, and what earlier chunks chose (``internals_source``,
    ``replica``)."""

    def _plot_rules(self, strengths: np.ndarray, decided: np.ndarray) -> None:
        """Every rule's firing strength at every row with a decision as one bar chart
        (bar k-1 is rule Rk, its abscissa k; float32), taken into the run's heatmap
        (:class:`RuleHeat`, :meth:`send_heatmap`) and the strongest rule's lane. A row without a decision (the last) has no strengths:
        nothing is logged there, so the chart at the end shows the last decision's. One
        bar chart, not 40 lines in a 10-colour palette that made R1, R11 and R21 alike."""
        strengths = np.ascontiguousarray(strengths, dtype=np.float32)
        decided = np.asarray(decided, bool)
        self.n_rules = strengths.shape[1]
        if RULES_PATH not in self._styled:  # rule Rk at abscissa k (1 to n)
            self._style(RULES_PATH, "BarChart", color=(230, 160, 40))
            numbers = np.arange(1, self.n_rules + 1, dtype=np.float32)[None, :]
            self._static.add_array(RULES_PATH, "BarChart", "abscissa", tensor_rows(numbers))
            import rerun as rr

            self._static.add_archetype(  # the chart's axis from 0 to 1, whatever fires
                RULES_SCALE_PATH,
                rr.BarChart(
                    np.array([1.0], dtype=np.float32),
                    abscissa=np.array([0.0], dtype=np.float32),
                    widths=np.array([0.35], dtype=np.float32),
                    color=(200, 200, 200),
                ),
            )
        self._rows.add(
            RULES_PATH,
            "BarChart",
            "values",
            tensor_rows(strengths[decided]),
            lengths=decided.astype(np.int32),
            absent=~decided,  # the chart at the final instant shows the last decision
        )
        times = np.asarray(self._rows_time, dtype=float)[decided]
        self._send_strongest(times, self.rule_heat.add(times, strengths[decided]))

    def _send_strongest(self, times: np.ndarray, strengths: np.ndarray) -> None:
        """The strongest rule at each decision, where it changes (from the chunk before
        too): a labelled lane, sent a chunk at a time."""
        if not len(times):
            return
        import rerun as rr

        heat = self.rule_heat
        top = np.argmax(strengths, axis=1)
        fired = strengths[np.arange(len(top)), top] > 0
        state = np.where(fired, top, -1)
        change = np.ones(len(state), bool)
        change[1:] = state[1:] != state[:-1]
        change[0] = heat.last_state is None or state[0] != heat.last_state
        heat.last_state = int(state[-1])
        if not change.any():
            return
        labels = [f"R{k + 1}" if k >= 0 else "none fires" for k in state[change]]
        self.rec.send_columns(
            RULES_STRONGEST_PATH,
            indexes=[time_column(times[change])],
            columns=rr.StateChange.columns(state=labels),
            strict=True,
        )

    def send_heatmap(self, static: StaticBatch) -> None:
        """The rule firing of the whole run as a heatmap: rules down, time across (at
        most :data:`HEATMAP_MAX_BINS` bins, each the max over its rows, so a brief
        firing stays visible), with the rules in words beside it (:class:`RuleHeat`
        collected it; the lane of the strongest rule went with the chunks)."""
        heat = self.rule_heat
        if not heat.calls:
            return
        import rerun as rr

        heatmap = heat.heatmap()
        bins = heatmap.shape[1]
        first, last = heat.first_s, heat.last_s
        span = f"{first:.2f} s to {last:.2f} s" if heat.count else "no rows"
        per_bin = (last - first) / max(bins - 1, 1) if heat.count > 1 else 0.0
        static.add_archetype(
            RULES_HEATMAP_PATH,
            rr.Tensor(
                heatmap,
                dim_names=[
                    f"rule R1-R{heatmap.shape[0]}",
                    f"time {span}, {per_bin:.3g} s a column",
                ],
                value_range=[0.0, 1.0],
            ),
        )
        if bins:
            send_heatmap_image(static, heatmap, first, per_bin)
        lines = [
            f"# Rule firing, {span}",
            "",
            f"Heatmap: row k, counted from 1 at the top, is rule Rk; {bins} columns over "
            f"the run ({heat.count} steps, the largest strength in each column).",
            "Bar chart: the bar at k (1 to n on its axis) is rule Rk, at the time cursor.",
            "",
        ]
        lines += [f"- **R{k + 1}**: {text}" for k, text in enumerate(self.rule_texts())]
        static.add_archetype(
            RULES_TEXT_PATH, rr.TextDocument("\n".join(lines), media_type=rr.MediaType.MARKDOWN)
        )

    def rule_texts(self) -> list[str]:
        system = self.fis if self.fis is not None else self.blocks
        if system is None or not hasattr(system, "rule_text"):
            return [f"(rule {k + 1})" for k in range(self.n_rules)]
        return [system.rule_text(k) for k in range(min(self.n_rules, len(system.rules)))]

    def _internals(self, log, start: int, end: int) -> None:
        """Plot the controller's inner state on rows [start, end): from the decisions it
        logged while it drove (``decisions``), when they line up with the run (the same
        voltages, row for row), else by replaying the rows through the replica. Either
        way the state must come with exactly the voltages the run logged; if not (the
        controller was changed mid-run, say), nothing more is plotted and the metadata
        says why."""
        decided_v = log.controller_output_v[start:end]
        decided = np.all(np.isfinite(decided_v), axis=1)  # the last row has no decision
        out = np.full((end - start, len(INTERNALS)), np.nan)
        try:
            logged = self._logged_decisions(start, decided)
            decisions = logged if logged is not None else self._replay(log, start, decided)
        except ValueError as exc:  # decisions of another shape than this writer expects
            self.replica_error = f"its decisions do not fit ({exc})"
            return
        voltages, state = decisions[:, :2], decisions[:, 2 : 2 + len(INTERNALS)]
        # NaN (no decision to compare) counts as differing.
        differs = np.flatnonzero(~np.all(np.abs(voltages - decided_v[decided]) <= 1e-9, axis=1))
        if len(differs):
            k = start + np.flatnonzero(decided)[differs[0]]
            how = "logged decisions differ" if logged is not None else "replay differs"
            self.replica_error = f"its {how} from the run at t = {log.time_s[k]:.2f} s"
            return
        out[decided] = state
        self._plot(
            INTERNALS_PATH,
            list(INTERNALS),
            [SERIES_PALETTE[k % len(SERIES_PALETTE)] for k in range(len(INTERNALS))],
            [1.5] * len(INTERNALS),
            out,
        )
        if self.blocks is not None:
            strengths = np.full((end - start, len(self.blocks.rules)), np.nan)
            if decided.any():
                strengths[decided] = self.blocks.firing_strengths(
                    decisions[:, 2 + len(INTERNALS) :]
                )
            self._plot_rules(strengths, decided)

    def _logged_state(self, log, start: int, end: int) -> np.ndarray:
        """The inner state plotted on rows [start, end), read again from the driving
        controller's own decisions (as :meth:`_internals` plotted it from them; NaN at a
        row without a decision): for the legend of a run recorded whole."""
        decided = np.all(np.isfinite(log.controller_output_v[start:end]), axis=1)
        out = np.full((end - start, len(INTERNALS)), np.nan)
        out[decided] = self._logged_decisions(start, decided)[:, 2 : 2 + len(INTERNALS)]
        return out

    def _logged_decisions(self, start: int, decided: np.ndarray):
        """The driving controller's own decisions for the decided rows of [start, end)
        as an array (voltages, then the state); None to replay the rows instead (the
        first chunk chooses: a controller that did not log its decisions from the run's
        start is replayed throughout)."""
        inner = getattr(self.controller, "inner", self.controller)  # the viewer's wrapper
        decisions = getattr(inner, "decisions", None)
        rows = np.flatnonzero(decided) + start
        covered = isinstance(decisions, list) and (not len(rows) or rows[-1] < len(decisions))
        if self.internals_source is None:
            self.internals_source = "decisions" if covered and start == 0 else "replay"
        if self.internals_source == "replay":
            return None
        if not covered:  # swapped for another controller mid-run: nothing to line up
            return np.full((len(rows), self.decision_width), np.nan)
        return np.array([decisions[k] for k in rows], dtype=float).reshape(
            len(rows), self.decision_width
        )

    def _replay(self, log, start: int, decided: np.ndarray):
        """The decisions of the decided rows of [start, end), replayed through a copy
        of the controller (made at the first chunk); a replay that departs from the run
        stops there (its later rows are NaN)."""
        if self.replica is None:
            self.replica = controller_replica(self.controller)
        replica = self.replica
        rows = np.flatnonzero(decided) + start
        result = np.full((len(rows), self.decision_width), np.nan)
        for j, k in enumerate(rows):
            replica(log.inputs[k], ranges_m=log.ranges_m[k])
            result[j] = replica.decisions[-1]
            if np.any(np.abs(result[j, :2] - log.controller_output_v[k]) > 1e-9):
                break
        return result
