"""Writing output files whole or not at all.

A file is written to a temporary file beside its target (same folder, so the rename is
atomic on every local file system), flushed to disk and renamed over the target only
when complete. On a failure (a full disk, a read-only folder) or an interrupt, the old
file at the target stays as it was; the partial one is removed, or, when the caller
asks for it, kept under a name that says it is partial (``run.rrd`` ->
``run.partial.rrd``).
"""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

__all__ = ["partial_path", "temporary_beside", "commit", "discard", "write_text_atomically"]


def partial_path(path: Path) -> Path:
    """Where a partial file for ``path`` is kept: ``run.rrd`` -> ``run.partial.rrd``."""
    path = Path(path)
    return path.with_name(f"{path.stem}.partial{path.suffix}")


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def temporary_beside(path: Path) -> Path:
    """A new empty file in ``path``'s folder, hidden, named after it (OSError if the
    folder cannot be written)."""
    path = Path(path)
    fd, tmp = tempfile.mkstemp(
        prefix=f".{path.name}.", suffix=".writing", dir=path.parent if str(path.parent) else "."
    )
    os.close(fd)
    # mkstemp makes the file private (0600); the finished file gets the usual mode.
    os.chmod(tmp, 0o666 & ~_umask())
    return Path(tmp)


def commit(tmp: Path, path: Path) -> Path:
    """Flush ``tmp`` to disk and rename it over ``path`` (OSError on failure, with
    ``tmp`` still there for the caller to discard)."""
    fd = os.open(tmp, os.O_RDONLY)
    try:
        os.fsync(fd)  # a full disk shows here at the latest, before the old file goes
    finally:
        os.close(fd)
    os.replace(tmp, path)
    return Path(path)


def discard(tmp: Path, path: Path, keep_partial: bool = False) -> Path | None:
    """Remove a temporary file that will not be committed, or with ``keep_partial``
    rename it to :func:`partial_path` (``path``); returns where it is kept, or None."""
    try:
        if keep_partial and Path(tmp).exists() and Path(tmp).stat().st_size > 0:
            kept = partial_path(path)
            os.replace(tmp, kept)
            return kept
        os.unlink(tmp)
    except OSError:
        pass
    return None


def write_text_atomically(path, text: str) -> Path:
    """Write ``text`` (UTF-8) to ``path`` whole or not at all (OSError on failure; the
    old file stays)."""
    path = Path(path)
    tmp = temporary_beside(path)
    try:
        with open(tmp, "w", encoding="utf-8") as stream:
            stream.write(text)
        return commit(tmp, path)
    except BaseException:
        discard(tmp, path)
        raise


def check_writable_file(path, option: str = "--rrd") -> Path:
    """Raise ValueError (with ``option``, the path and the reason) unless a file can be
    written at ``path`` whole: a regular file or none, in a folder where a file can be
    made (files are written beside the target and renamed over it, as
    :func:`write_text_atomically` does). Creates nothing that stays."""
    import stat

    path = Path(path)
    if path.is_dir():
        raise ValueError(f"{option} {path}: is a directory, not a file")
    if path.exists() and not stat.S_ISREG(path.stat().st_mode):
        raise ValueError(
            f"{option} {path}: is not a regular file (a device or a pipe); "
            "the file is written whole, then renamed into place"
        )
    parent = path.parent if str(path.parent) else Path(".")
    if not parent.exists():
        raise ValueError(f"{option} {path}: directory {parent} does not exist")
    if not parent.is_dir():
        raise ValueError(f"{option} {path}: {parent} is not a directory")
    try:
        probe = temporary_beside(path)
    except OSError as exc:
        raise ValueError(f"{option} {path}: cannot write there ({exc.strerror or exc})") from None
    discard(probe, path)
    return path
