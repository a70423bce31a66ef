"""A recording as a file: written whole beside its target and renamed into place, or
refused with a :class:`RecordingError` that says why and that the old file is unchanged
(docs/robustness.md)."""

from __future__ import annotations

from pathlib import Path

from .blueprint import APPLICATION_ID


class RecordingError(ValueError):
    """A recording that could not be written (the message says which file, why, and
    that any old file at the path is unchanged)."""


def open_stream(path, application_id: str = APPLICATION_ID, recording_name: str | None = None):
    """A recording stream saving to ``path`` (rerun's file sink)."""
    import rerun as rr

    rec = rr.RecordingStream(application_id)
    rec.save(str(path))
    if recording_name:
        rec.send_recording_name(recording_name)
    return rec


def not_written(path: Path, reason: str) -> RecordingError:
    old = "the file there before is unchanged" if path.exists() else "nothing was written there"
    return RecordingError(f"--rrd {path}: the recording was not written ({reason}); {old}")


def write_recording_bytes(path, data: bytes) -> Path:
    """Write a finished recording: to a temporary file beside ``path``, flushed to disk,
    renamed over ``path`` only when complete (:mod:`fuzzynav.safe_files`). A full disk or an
    unwritable folder raises :class:`RecordingError` and leaves ``path`` as it was; an
    interrupt (Ctrl-C) removes the temporary file and propagates."""
    from fuzzynav.safe_files import commit, discard, is_stream_target, temporary_beside

    path = Path(path)
    if is_stream_target(path):  # never renamed over: written as it goes (issue 26)
        from fuzzynav.safe_files import write_bytes_atomically

        try:
            return write_bytes_atomically(path, data)
        except OSError as exc:
            raise not_written(path, exc.strerror or str(exc)) from None
    try:
        tmp = temporary_beside(path)
    except OSError as exc:
        raise not_written(path, f"cannot write in its folder: {exc.strerror or exc}") from None
    try:
        with open(tmp, "wb") as stream:
            stream.write(data)
        return commit(tmp, path)
    except OSError as exc:
        discard(tmp, path)
        raise not_written(path, exc.strerror or str(exc)) from None
    except BaseException:
        discard(tmp, path)
        raise
