"""The live recorder: a running simulation appended to a recording a chunk of steps at a
time (the viewer's recording, or any stream the caller opened)."""

from __future__ import annotations

import functools
import math
import time
from pathlib import Path

from fuzzynav.safe_files import check_writable_file

from . import blueprint as blueprints
from . import documents
from .blueprint import APPLICATION_ID, application_id
from .columns import ColumnWriter
from .events import send_events
from .files import RecordingError, SinkPipe, not_written, open_stream, write_file_chunks
from .internals import controller_fis, rule_system
from .plot_events import send_plot_events
from .scene import static_world

#: The longest :meth:`LiveRecorder.bytes_written` waits for rerun to flush.
FLUSH_TIMEOUT_S = 2.0


class LiveRecorder:
    """Append a running simulation to a recording, a chunk of steps at a time.

    ::

        recorder = LiveRecorder("run.rrd")        # or LiveRecorder(stream=rr.RecordingStream(...))
        while not sim.done:
            sim.step()
            recorder.update(sim)                  # sends the new rows every chunk_steps
        recorder.close(sim)                       # the rest, the metrics, the file's footer

    ``update`` may be called as often as one likes: rows are sent when ``chunk_steps``
    of them are waiting and ``min_interval_s`` of wall time has passed since the last
    send, or when the run has ended. A chunk costs a few tens of milliseconds whatever
    its size (one chunk per entity, ~75 entities for a fuzzy controller), so the interval
    keeps a fast-forwarded viewer from spending its time recording. The controller, sensors, robot
    parameters and voltage limit are read from the simulation. A simulation that is
    ``reset()`` starts a new log: close this recorder and open a new one
    (``update`` raises ValueError when the log has shrunk).

    Parameters
    ----------
    path : str or Path, optional
        The ``.rrd`` file; or pass ``stream``, an open ``rr.RecordingStream`` whose sinks
        the caller chose (a viewer, a gRPC server...).
    chunk_steps : int
        How many steps to collect before sending them (default 50: one second of
        simulated time at the default 20 ms period).
    min_interval_s : float
        Wall time between two sends at least (default 0.5 s; 0 for none).
    """

    def __init__(
        self,
        path=None,
        *,
        stream=None,
        chunk_steps: int = 50,
        min_interval_s: float = 0.5,
        extra_metadata: dict | None = None,
    ):
        if (path is None) == (stream is None):
            raise ValueError("LiveRecorder needs exactly one of path and stream")
        if int(chunk_steps) < 1:
            raise ValueError(f"chunk_steps = {chunk_steps!r}: must be >= 1")
        self.path = Path(path) if path is not None else None
        self._tmp: Path | None = None
        self.kept_partial: Path | None = None
        if self.path is not None:
            from fuzzynav.safe_files import temporary_beside

            check_writable_file(self.path)
            try:  # written beside the target, renamed over it by close()
                self._tmp = temporary_beside(self.path)
            except OSError as exc:
                raise not_written(self.path, exc.strerror or str(exc)) from None
        if not (math.isfinite(min_interval_s) and min_interval_s >= 0):
            raise ValueError(f"min_interval_s = {min_interval_s!r}: must be >= 0")
        self.chunk_steps = int(chunk_steps)
        self.min_interval_s = float(min_interval_s)
        self._last_send = -math.inf
        self.extra_metadata = dict(extra_metadata or {})
        # A file's stream opens with the first update, when its application id (the
        # scenario and controller) is known.
        self._rec = stream
        self._owns_stream = stream is None
        self._pipe: SinkPipe | None = None
        self._writer: ColumnWriter | None = None
        self._sim = None
        self.closed = False

    @property
    def rows_sent(self) -> int:
        return self._writer.sent if self._writer is not None else 0

    def _open(self, sim=None) -> None:
        if self._rec is None:
            app_id = (
                application_id(
                    sim.scenario,
                    sim.controller,
                    sim.geometry,
                    voltage_limit_v=sim.voltage_limit_v,
                    parameters=sim.model.parameters,
                    **_run_options(sim),
                )
                if sim
                else APPLICATION_ID
            )
            # rerun's file sink writes through a pipe that a thread copies into the
            # temporary file: given the file itself, rerun's flush at times never
            # returns after a failed write (a full disk): files.recording_sink
            self._pipe = SinkPipe(functools.partial(write_file_chunks, self._tmp))
            self._rec = open_stream(self._pipe.name, app_id)

    def _failed(self, exc: BaseException) -> RecordingError:
        """Close the file after a failed write (a full disk) and keep what was written
        under a name that says it is partial; the error to raise."""
        from fuzzynav.safe_files import discard

        self.closed = True
        try:
            if self._rec is not None and self._owns_stream:
                self._rec.disconnect()
        except Exception:  # the stream is broken already; what matters is the file
            pass
        if self._pipe is not None:
            self._pipe.close()  # what rerun wrote is in the file now
        reason = getattr(exc, "strerror", None) or str(exc) or type(exc).__name__
        if self._tmp is None:
            return RecordingError(f"recording stream failed ({reason})")
        self.kept_partial = discard(self._tmp, self.path, keep_partial=True)
        kept = f"; what was written is in {self.kept_partial}" if self.kept_partial else ""
        return RecordingError(str(not_written(self.path, reason)) + kept)

    def _start(self, sim) -> None:
        self._open(sim)
        params = sim.model.parameters
        self._writer = ColumnWriter(
            self._rec,
            footprint_m=(params.footprint_length_m, params.footprint_width_m),
            sensor_config=sim.sensors.config,
            voltage_limit_v=sim.voltage_limit_v,
            fis=controller_fis(sim.controller),
            tolerance_m=sim.scenario.tolerance_m,
            controller=sim.controller,
            perception=sim.perception.mode,
            geometry=sim.geometry,
            # the legends are placed from the simulation's log at the close: the rows
            # plotted are not kept (a long live run kept every one)
            legends_from_log=True,
        )
        self._rec.send_recording_name(
            blueprints.recording_name(
                sim.scenario, sim.controller, sim.geometry, **_run_options(sim)
            )
        )
        ids = sim.arena.obstacle_arrays()[2]
        n_rules = len(getattr(rule_system(sim.controller), "rules", ()))
        self._rec.send_blueprint(
            blueprints.blueprint(
                sim.scenario,
                ids,
                n_rules,
                internals=self._writer.internals,
                perception=sim.perception.mode,
            )
        )
        # Sent with the first chunk's styles.
        static_world(self._writer.static, sim.scenario)
        self._metadata(sim, self._writer.static)

    def _metadata(self, sim, static) -> None:
        extra = dict(self.extra_metadata)
        if self._writer is not None and self._writer.fis_error:
            extra["rule firing"] = f"not recorded ({self._writer.fis_error})"
        if self._writer is not None and self._writer.replica_error:
            extra["controller internals"] = f"not recorded ({self._writer.replica_error})"
        documents.metadata(
            static,
            scenario=sim.scenario,
            controller=sim.controller,
            fis=controller_fis(sim.controller),
            parameters=sim.model.parameters,
            sensor_config=sim.sensors.config,
            seed=sim.seed,
            perception=sim.perception.mode,
            control_period_s=sim.control_period_s,
            voltage_limit_v=sim.voltage_limit_v,
            extra_metadata=extra,
            geometry=sim.geometry,
        )

    def bytes_written(self) -> int:
        """Bytes of the file so far: rerun's pipeline flushed first (at most
        ``FLUSH_TIMEOUT_S``), so every row sent counts. 0 for a stream the caller
        opened, or before the first update."""
        if self._pipe is None or self._rec is None or self.closed:
            return 0
        try:
            self._rec.flush(timeout_sec=FLUSH_TIMEOUT_S)
        except Exception:  # noqa: BLE001 - a slow or failed sink: count what arrived
            pass
        return self._pipe.bytes_received()

    def update(self, sim, *, force: bool = False) -> int:
        """Send the rows logged since the last chunk if ``chunk_steps`` of them wait and
        ``min_interval_s`` has passed (or the run is over, or ``force``). Returns how
        many rows were sent."""
        if self.closed:
            raise ValueError("LiveRecorder.update after close()")
        if self._sim is not None and sim is not self._sim:
            raise ValueError("LiveRecorder records one simulation; open another for this one")
        try:
            sent = self._update(sim, force)
        except (OSError, RuntimeError) as exc:  # rerun's sink: "No space left on device"
            raise self._failed(exc) from None
        if self._pipe is not None and self._pipe.error is not None:  # the copier's write
            raise self._failed(self._pipe.error) from None
        return sent

    def _update(self, sim, force: bool) -> int:
        if self._writer is None:
            self._sim = sim
            self._start(sim)
        n = _log_length(sim)
        sent = self._writer.sent
        if n < sent:
            raise ValueError(
                f"the simulation's log shrank from {sent} to {n} rows (reset?): "
                f"close this recorder and open a new one"
            )
        if n == sent:
            return 0
        if not (force or sim.done):
            if n - sent < self.chunk_steps:
                return 0
            if time.monotonic() - self._last_send < self.min_interval_s:
                return 0
        # a view, not sim.log's copy: that copied the whole log at every send
        view = getattr(sim, "log_view", None)
        self._writer.send(view() if view is not None else sim.log, sent, n)
        self._last_send = time.monotonic()
        return n - sent

    def close(self, sim=None, *, extra_metadata: dict | None = None) -> None:
        """Send what is left, the metrics and the final layout; close the file and, for
        a path, rename it into place (a failure keeps the old file at the path and the
        partial one as ``<stem>.partial.rrd``: :class:`RecordingError`)."""
        if self.closed:
            return
        sim = sim if sim is not None else self._sim
        if sim is not None and self._writer is not None and _log_length(sim) < self._writer.sent:
            sim = None  # reset since: its log and metrics belong to another run
        try:
            self._close(sim, extra_metadata)
        except (OSError, RuntimeError) as exc:
            raise self._failed(exc) from None
        except BaseException:  # Ctrl-C: keep what there is, under a name that says so
            self._failed(KeyboardInterrupt("interrupted"))
            raise
        error = self._pipe.close() if self._pipe is not None else None
        if error is not None:  # a write failed (a full disk): keep the partial file
            raise self._failed(error) from None
        if self._tmp is not None:
            from fuzzynav.safe_files import commit

            try:
                commit(self._tmp, self.path)
            except OSError as exc:
                raise self._failed(exc) from None

    def _close(self, sim, extra_metadata) -> None:
        self._open(sim)
        try:
            if sim is not None:
                self.update(sim, force=True)
                if extra_metadata:
                    self.extra_metadata.update(extra_metadata)
                static = self._writer.static
                static.send(self._rec)  # what is pending (nothing sent yet if no rows)
                self._metadata(sim, static)
                result = sim.result() if _log_length(sim) else None  # no metrics of nothing
                if result is not None:
                    documents.metrics(static, result.metrics, result.outcome)
                    events = send_events(self._rec, static, result)
                    self._writer.legend_extra = send_plot_events(
                        self._rec, self._writer, result.log, events, static
                    )
                    documents.summary(static, result, sim.controller, events)
                self._writer.send_heatmap(static)
                static.send(self._rec)
                w = self._writer
                self._rec.send_blueprint(
                    blueprints.blueprint(
                        sim.scenario,
                        w.obstacle_ids,
                        w.n_rules,
                        result.log if result is not None else None,
                        internals=w.internals,
                        legend_corners=w.legend_corners(result.log if result is not None else None),
                        perception=sim.perception.mode,
                    )
                )
        finally:
            self.closed = True
            self._rec.flush()
            if self._owns_stream:
                self._rec.disconnect()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()
        return False


def _log_length(sim) -> int:
    """Rows in the simulation's log without copying it (the buffer's count if exposed)."""
    buffer = getattr(sim, "_log", None)
    n = getattr(buffer, "n", None)
    return int(n) if isinstance(n, int) else len(sim.log)


def _run_options(sim) -> dict:
    """What tells two runs of one scenario and controller apart (the layout's key and
    the recording's name: :mod:`.blueprint`)."""
    return dict(
        perception=sim.perception.mode,
        seed=sim.seed,
        noise_std_m=sim.sensors.config.noise_std_m,
        control_period_s=sim.control_period_s,
    )
