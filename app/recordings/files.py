"""A recording as a file: written whole beside its target and renamed into place, or
refused with a :class:`RecordingError` that says why and that the old file is unchanged
(docs/robustness.md)."""

from __future__ import annotations

import contextlib
import os
import sys
import threading
from collections.abc import Iterator
from pathlib import Path

from .blueprint import APPLICATION_ID

#: The most bytes the copier reads from rerun's pipe at once.
COPY_BYTES = 1 << 20
#: How long, once the recording stream is disconnected, its end may take to arrive.
SINK_END_TIMEOUT_S = 60.0


class RecordingError(ValueError):
    """A recording that could not be written (the message says which file, why, and
    that any old file at the path is unchanged)."""


def open_stream(path, application_id: str = APPLICATION_ID):
    """A recording stream saving to ``path`` (rerun's file sink)."""
    import rerun as rr

    rec = rr.RecordingStream(application_id)
    rec.save(str(path))
    return rec


def not_written(path: Path, reason: str) -> RecordingError:
    old = "the file there before is unchanged" if path.exists() else "nothing was written there"
    return RecordingError(f"--rrd {path}: the recording was not written ({reason}); {old}")


class _Copier(threading.Thread):
    """Copies what rerun's file sink writes into a pipe to the recording's file (or a
    pipe or terminal) as it comes. A failed write (a full disk) is kept in ``error``
    and the rest is read and dropped, so that rerun's writer never waits on a full
    pipe."""

    def __init__(self, read_fd: int, write):
        super().__init__(name="fuzzynav-recording-copier", daemon=True)
        self.read_fd = read_fd
        self.write = write  # write(chunks): writes an iterable of bytes, or raises
        self.error: BaseException | None = None
        self.bytes_read = 0

    def _chunks(self):
        while True:
            data = os.read(self.read_fd, COPY_BYTES)
            if not data:
                return
            self.bytes_read += len(data)
            yield data

    def run(self) -> None:
        chunks = self._chunks()
        try:
            self.write(chunks)
        except BaseException as exc:  # noqa: BLE001 - reported by the thread that waits
            self.error = exc
        try:
            for _ in chunks:  # what is left after a failed write: read and dropped
                pass
        except OSError as exc:
            self.error = self.error or exc
        finally:
            os.close(self.read_fd)


def write_file_chunks(tmp: Path, chunks) -> None:
    with open(tmp, "wb") as stream:
        for chunk in chunks:
            stream.write(chunk)


class SinkPipe:
    """A name for rerun's file sink (``rec.save(pipe.name)``) whose bytes a thread
    copies, as rerun encodes them, into ``write(chunks)`` (e.g. a temporary file): a
    failed write is kept in :attr:`error` instead of leaving rerun's writer stuck.
    :meth:`close` once the recording stream is disconnected (that closes rerun's end)."""

    def __init__(self, write):
        read_fd, self._write_fd = os.pipe()
        self.name = f"/dev/fd/{self._write_fd}"  # rerun opens its own descriptor of it
        self._copier = _Copier(read_fd, write)
        self._copier.start()

    @property
    def error(self) -> BaseException | None:
        """The copier's first failure (a full disk), or None."""
        return self._copier.error

    def bytes_received(self) -> int:
        """Bytes rerun has written into the pipe so far: those the copier has read and
        those still waiting in the pipe."""
        waiting = 0
        with contextlib.suppress(ImportError, OSError):  # (no FIONREAD, or the pipe ended)
            import fcntl
            import termios

            buffer = bytearray(4)
            fcntl.ioctl(self._copier.read_fd, termios.FIONREAD, buffer)
            waiting = int.from_bytes(buffer, sys.byteorder)
        return self._copier.bytes_read + waiting

    def close(self) -> BaseException | None:
        """Close this end, wait for the copier to write the rest; its error, or None."""
        if self._write_fd is not None:
            os.close(self._write_fd)  # with rerun's closed, the copier sees the end
            self._write_fd = None
        self._copier.join(SINK_END_TIMEOUT_S)
        if self._copier.is_alive() and self._copier.error is None:
            self._copier.error = OSError("the recording stream did not end")
        return self._copier.error


@contextlib.contextmanager
def recording_sink(path) -> Iterator[str]:
    """A file name for rerun's file sink (``rec.save(name)``, inside the block) whose
    bytes are copied, as rerun encodes them, to a temporary file beside ``path``, which
    is flushed to disk and renamed over ``path`` when the block ends normally
    (:mod:`fuzzynav.safe_files`): a long run's recording is never held in memory, and
    never half written. A pipe or a terminal gets the bytes as a stream. The block must
    disconnect its recording stream (that closes the file) before it ends.

    A full disk or an unwritable folder raises :class:`RecordingError` and leaves
    ``path`` as it was; an exception in the block (Ctrl-C) removes the temporary file
    and propagates. (rerun's own file sink, given the temporary file's name, cannot be
    used: after a failed write its flush at times never returns (3 of 6 tries with a
    file-size limit; the others raise "File-writer thread shut down prematurely"); its
    binary stream, read a block at a time, makes a file of several
    streams that rerun's reader refuses.)"""
    from fuzzynav.safe_files import (
        check_replaceable,
        commit,
        discard,
        is_stream_target,
        temporary_beside,
        write_chunks_atomically,
    )

    path = Path(path)
    check_replaceable(path)  # a name the command chose: before the recording is made
    tmp = None
    if is_stream_target(path):  # never renamed over: written as it goes

        def write(chunks):
            write_chunks_atomically(path, chunks)

    else:
        try:
            tmp = temporary_beside(path)
        except OSError as exc:
            raise not_written(path, f"cannot write in its folder: {exc.strerror or exc}") from None

        def write(chunks):
            write_file_chunks(tmp, chunks)

    pipe = SinkPipe(write)
    done = False
    try:
        yield pipe.name
        done = True
    finally:
        error = pipe.close()
        if (not done or error is not None) and tmp is not None:
            discard(tmp, path)
    if error is not None:
        raise not_written(path, getattr(error, "strerror", None) or str(error)) from None
    if tmp is not None:
        try:
            commit(tmp, path)
        except OSError as exc:
            discard(tmp, path)
            raise not_written(path, exc.strerror or str(exc)) from None
        except BaseException:
            discard(tmp, path)
            raise
