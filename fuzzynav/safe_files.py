"""Writing output files whole or not at all, and never over what must not be written.

The one writer of the project: every file fuzzynav writes (recordings,
traces, figures, rule bases, checkpoints, ``.fis`` exports, reports) goes through
:func:`write_bytes_atomically`, :func:`write_text_atomically` or :func:`atomic_output`.

A file is written to a temporary file beside its target (same folder, so the rename is
atomic on every local file system), flushed to disk and renamed over the target only
when complete. On a failure (a full disk, a read-only folder) or an interrupt, the old
file at the target stays as it was; the partial one is removed, or, when the caller
asks for it, kept under a name that says it is partial (``run.rrd`` ->
``run.partial.rrd``).

A symbolic link is followed: the file it points at is replaced, the link stays (a
rename over the link would replace the link itself, e.g. ``/dev/stdout``). A target
that is not a regular file is never renamed over: a pipe (FIFO) or a terminal is
written through a stream, anything else (a device, a socket, a directory) is refused.

A file whose name the command chose (in a folder it was given: a report's, a sweep's
failures, figures) is written inside an :class:`OutputScope`: while one is active, no
writer of this module replaces a file that exists and that this same scope did not write
(ValueError naming it), unless the scope was opened with ``overwrite`` (``--force``,
``overwrite=True``). A path the user named is asked for and written as before.
:func:`free_path` chooses a fresh name instead (a partial recording beside an old one).

This module sits at the package's root (beside :mod:`fuzzynav.resources`) so that the
controller's own savers use it too.
"""

from __future__ import annotations

import contextlib
import contextvars
import errno
import os
import stat
import tempfile
from collections.abc import Iterable, Iterator
from pathlib import Path
from typing import TypeAlias

#: A path as the writers take it: text or a path object (``os.PathLike``).
StrPath: TypeAlias = str | os.PathLike[str]

__all__ = [
    "OutputScope",
    "free_path",
    "check_replaceable",
    "partial_path",
    "temporary_beside",
    "commit",
    "discard",
    "write_bytes_atomically",
    "write_chunks_atomically",
    "write_text_atomically",
    "atomic_output",
    "check_writable_file",
    "check_output_path",
    "check_distinct_outputs",
    "installed_package_dir",
    "refuse_installed",
    "is_stream_target",
]


def partial_path(path: StrPath) -> Path:
    """Where a partial file for ``path`` is kept: ``run.rrd`` -> ``run.partial.rrd``."""
    path = Path(path)
    return path.with_name(f"{path.stem}.partial{path.suffix}")


def free_path(path: StrPath) -> Path:
    """``path`` if no file is there, else the first free ``<stem>-2<suffix>``,
    ``<stem>-3<suffix>``, ...: a fresh name, for the caller to say."""
    path = Path(path)
    candidate, number = path, 2
    while os.path.lexists(candidate):
        candidate = path.with_name(f"{path.stem}-{number}{path.suffix}")
        number += 1
    return candidate


class OutputScope:
    """The files one command (or one call of the Python interface) writes under names
    it chose: none of them replaces a file that exists and was not written within this
    scope, unless ``overwrite``.

    Active within a ``with`` block (in this thread): :func:`commit` and every writer of
    this module ask it before they write (:func:`check_replaceable`) and record what
    they wrote. Call :meth:`check` first with the names known in advance, so that a
    long command is refused before its work, not after.

    Parameters
    ----------
    option : the option or argument named in the message (``OUT_DIR``, ``--failures``)
    overwrite : replace existing files (``--force``, ``overwrite=True``)
    remedy : what the message offers (default: give --force, or another folder)
    """

    def __init__(
        self,
        option: str,
        *,
        overwrite: bool = False,
        remedy: str = "give --force to replace it, or another folder",
    ) -> None:
        if not isinstance(overwrite, bool):  # "no" is true, and would replace
            raise TypeError(f"{option}: overwrite = {overwrite!r}: must be True or False")
        self.option = option
        self.overwrite = bool(overwrite)
        self.remedy = remedy
        self._written: set[Path] = set()
        self._tokens: list[contextvars.Token[OutputScope | None]] = []

    def check(self, paths: Iterable[StrPath]) -> None:
        """ValueError naming the first of ``paths`` that exists and was not written in
        this scope (nothing when ``overwrite``)."""
        if self.overwrite:
            return
        from fuzzynav.resources import escape_controls

        for path in paths:
            if os.path.lexists(path) and _target(path) not in self._written:
                raise ValueError(
                    f"{self.option} {escape_controls(str(path))}: exists already, and was "
                    "not written by this command: a name the command chose never replaces "
                    f"a file unless asked ({self.remedy}); nothing was written over"
                )

    def claim(self, path: StrPath) -> Path:
        """:meth:`check` ``path``, then count it as written in this scope."""
        self.check([path])
        self._written.add(_target(path))
        return Path(path)

    def __enter__(self) -> OutputScope:
        self._tokens.append(_ACTIVE_SCOPE.set(self))
        return self

    def __exit__(self, *exc_info: object) -> None:
        _ACTIVE_SCOPE.reset(self._tokens.pop())


_ACTIVE_SCOPE: contextvars.ContextVar[OutputScope | None] = contextvars.ContextVar(
    "fuzzynav_output_scope", default=None
)


def check_replaceable(path: StrPath) -> None:
    """ValueError when an :class:`OutputScope` is active and ``path`` exists without
    having been written in it: asked by every writer before it starts."""
    scope = _ACTIVE_SCOPE.get()
    if scope is not None:
        scope.check([path])


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def _target(path: StrPath) -> Path:
    """The file a write to ``path`` lands in: symbolic links followed (the link stays)."""
    return Path(os.path.realpath(path))


def temporary_beside(path: StrPath) -> Path:
    """A new empty file in the folder of ``path`` (of the file a link points at),
    hidden, named after it (OSError if the folder cannot be written)."""
    path = _target(path)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".writing", dir=path.parent)
    os.close(fd)
    # mkstemp makes the file private (0600); the finished file gets the usual mode.
    os.chmod(tmp, 0o666 & ~_umask())
    return Path(tmp)


def _refuse_non_regular(path: Path) -> None:
    """OSError unless ``path`` (links followed) is a regular file or does not exist:
    a rename must never replace a device, a pipe or a folder."""
    try:
        mode = os.stat(path).st_mode
    except FileNotFoundError:
        return
    if not stat.S_ISREG(mode):
        raise OSError(errno.EINVAL, "not a regular file: nothing was renamed over it", str(path))


def commit(tmp: StrPath, path: StrPath) -> Path:
    """Flush ``tmp`` to disk and rename it over ``path`` (the file a link points at);
    OSError on failure, with ``tmp`` still there for the caller to discard."""
    fd = os.open(tmp, os.O_RDONLY)
    try:
        os.fsync(fd)  # a full disk shows here at the latest, before the old file goes
    finally:
        os.close(fd)
    target = _target(path)
    _refuse_non_regular(target)  # checked again: it may have changed since the start
    scope = _ACTIVE_SCOPE.get()
    if scope is not None:  # a name the command chose: never over a file it did not write
        scope.claim(path)
    os.replace(tmp, target)
    return Path(path)


def discard(tmp: StrPath, path: StrPath, keep_partial: bool = False) -> Path | None:
    """Remove a temporary file that will not be committed, or with ``keep_partial``
    rename it to :func:`partial_path` (``path``), or a :func:`free_path` beside it when
    that exists; returns where it is kept, or None."""
    try:
        if keep_partial and Path(tmp).exists() and Path(tmp).stat().st_size > 0:
            kept = free_path(partial_path(path))  # never over an earlier partial file
            os.replace(tmp, kept)
            return kept
        os.unlink(tmp)
    except OSError:
        pass
    return None


def is_stream_target(path: StrPath) -> bool:
    """Whether ``path`` (links followed) is a pipe or a terminal: written through a
    stream, as it comes, never replaced."""
    try:
        mode = os.stat(path).st_mode
    except OSError:
        return False
    if stat.S_ISFIFO(mode):
        return True
    if stat.S_ISCHR(mode):
        try:
            fd = os.open(path, os.O_WRONLY | os.O_NONBLOCK | getattr(os, "O_NOCTTY", 0))
        except OSError:
            return False
        try:
            return os.isatty(fd)
        finally:
            os.close(fd)
    return False


def _write_stream(path: StrPath, chunks: Iterable[bytes]) -> Path:
    # Non-blocking open: a FIFO nobody reads fails at once (ENXIO) instead of hanging.
    try:
        fd = os.open(path, os.O_WRONLY | os.O_NONBLOCK | getattr(os, "O_NOCTTY", 0))
    except OSError as exc:
        if exc.errno == errno.ENXIO:
            raise OSError(errno.ENXIO, "a pipe that nobody reads", str(path)) from None
        raise
    os.set_blocking(fd, True)
    with os.fdopen(fd, "wb") as stream:
        for chunk in chunks:
            stream.write(chunk)
    return Path(path)


def write_chunks_atomically(path: StrPath, chunks: Iterable[bytes]) -> Path:
    """Write the ``chunks`` to ``path`` one after the other (a long file is never whole
    in memory), whole or not at all: OSError on failure, naming ``path``, and the old
    file stays. A pipe or a terminal gets them through a stream."""
    try:
        if is_stream_target(path):
            return _write_stream(path, chunks)
        _refuse_non_regular(_target(path))
        tmp = temporary_beside(path)
        try:
            with open(tmp, "wb") as stream:
                for chunk in chunks:
                    stream.write(chunk)
            return commit(tmp, path)
        except BaseException:
            discard(tmp, path)
            raise
    except OSError as exc:
        if exc.filename is not None and Path(exc.filename) == Path(path):
            raise
        # a write error names no file (or the temporary one): name the user's
        raise OSError(exc.errno, exc.strerror or str(exc), str(path)) from None


def write_bytes_atomically(path: StrPath, data: bytes) -> Path:
    """Write ``data`` to ``path`` whole or not at all (OSError naming ``path`` on
    failure; the old file stays); a pipe or a terminal gets it through a stream."""
    return write_chunks_atomically(path, [data])


def write_text_atomically(path: StrPath, text: str) -> Path:
    """Write ``text`` (UTF-8) to ``path`` whole or not at all (OSError on failure; the
    old file stays)."""
    return write_bytes_atomically(path, text.encode("utf-8"))


@contextlib.contextmanager
def atomic_output(path: StrPath) -> Iterator[Path]:
    """Within: a temporary path beside ``path`` to write (e.g. by a library that takes
    a file name, or in pieces so that a long file never sits in memory); on a normal
    exit it is renamed over ``path``, on any exception removed and ``path`` left as it
    was.

    Examples
    --------
    >>> with atomic_output("out.png") as tmp:  # doctest: +SKIP
    ...     figure.savefig(tmp, format="png")
    """
    check_replaceable(path)
    _refuse_non_regular(_target(path))
    tmp = temporary_beside(path)
    try:
        yield tmp
        commit(tmp, path)
    except BaseException:
        discard(tmp, path)
        raise


def installed_package_dir() -> Path:
    """The folder of the installed ``fuzzynav`` package (its shipped rule bases and
    scenarios): no command writes there."""
    import fuzzynav

    return Path(os.path.realpath(Path(fuzzynav.__file__).parent))


def _assets_dir() -> Path | None:
    try:
        from fuzzynav.resources import assets_dir

        return Path(os.path.realpath(assets_dir()))
    except Exception:  # noqa: BLE001 - a zipped install has no folder to protect
        return None


def _installed_roots() -> set[Path]:
    """The folders of the package and its subpackages, links followed: in a wheel, the
    package's folder; in a checkout's editable install (a tree of links to the files, or
    an import hook), the checkout's ``fuzzynav/``, ``world/``, ``controller/``,
    ``app/`` and ``assets/``."""
    from importlib.util import find_spec

    roots = {installed_package_dir()}
    assets = _assets_dir()
    if assets is not None:
        roots.add(assets)
    for name in (
        "fuzzynav",
        "fuzzynav.world",
        "fuzzynav.controller",
        "fuzzynav.app",
        "fuzzynav.assets",
    ):
        spec = find_spec(name)
        if spec is not None and spec.origin and spec.origin not in ("built-in", "frozen"):
            roots.add(Path(os.path.realpath(spec.origin)).parent)
    return roots


def refuse_installed(path: StrPath, option: str) -> None:
    """ValueError when ``path`` (links followed) is inside the installed package: its
    shipped rule bases and scenarios are what every later run reads."""
    from fuzzynav.resources import escape_controls

    target = _target(path)
    for root in _installed_roots():
        if target == root or root in target.parents:
            raise ValueError(
                f"{option} {escape_controls(str(path))}: is inside the installed fuzzynav "
                f"package ({root}); its shipped files are never written over: give a path "
                "of your own"
            )


def as_path(path: object, option: str) -> Path:
    """``path`` (a str or path-like) as a Path; TypeError naming ``option`` for anything
    else (an int, None) or an empty text (which would be the current folder)."""
    if not isinstance(path, str | os.PathLike) or path == "":
        raise TypeError(f"{option} = {path!r}: must be a path (a str or a pathlib.Path)")
    return Path(path)


def check_output_path(
    path: StrPath,
    option: str,
    inputs: Iterable[StrPath | None] = (),
    *,
    stream_ok: bool = True,
    replace: bool = True,
    folder: bool = False,
) -> Path:
    """The one output guard: every writer of the command line and of
    the Python interface asks it before it writes. Raise ValueError (naming ``option``,
    the path and why) when ``path`` must not be written:

    - a file or folder inside the installed package (its rule bases and scenarios,
      which every later run reads): :func:`refuse_installed`;
    - one of the run's ``inputs`` (the same file, through links too);
    - with ``replace=False``, a file that exists already: a name the command chose
      itself (a default such as ``./paper.fis``, or a file beside the folder named) is
      never written over unless asked (``--force``); a path the user gave is asked for;
    - a target that is not a regular file (a pipe or terminal is accepted with
      ``stream_ok``), or a folder where no file can be made.

    With ``folder`` the path is a folder to write files into, or a file in a folder
    not made yet: whether it can be written is not probed here
    (``app.figures.style.check_writable_dir`` makes the folder and probes it)."""
    from fuzzynav.resources import escape_controls

    path = as_path(path, option)
    shown = escape_controls(str(path))
    target = _target(path)
    refuse_installed(path, option)
    for source in inputs:
        if source is None:
            continue
        try:
            same = os.path.exists(source) and (
                _target(source) == target or (target.exists() and os.path.samefile(source, target))
            )
        except OSError:
            same = False
        if same:
            raise ValueError(
                f"{option} {shown}: is one of this run's inputs "
                f"({escape_controls(str(source))}); it would be overwritten: give another path"
            )
    if not replace and os.path.lexists(path):
        raise ValueError(
            f"{option} {shown}: exists already, and a name the command chose is never "
            "written over unless asked: give --force to replace it, or another path"
        )
    if folder:
        return path
    if stream_ok and is_stream_target(path):
        return path
    return check_writable_file(path, option)


def _same_file(a: StrPath, b: StrPath) -> bool:
    """Whether paths ``a`` and ``b`` name one file (links followed; hard links too)."""
    if _target(a) == _target(b):
        return True
    try:
        return os.path.samefile(a, b)
    except OSError:
        return False


def check_distinct_outputs(outputs: Iterable[tuple[str, StrPath | None]]) -> None:
    """ValueError when two of one command's outputs, ``(option, path)`` pairs (a None
    path is skipped), name the same file (through links too): one would overwrite the
    other (``run --trace same.out --rrd same.out`` lost the recording)."""
    from fuzzynav.resources import escape_controls

    seen: list[tuple[str, StrPath]] = []
    for option, path in outputs:
        if path is None:
            continue
        for other_option, other in seen:
            if _same_file(path, other):
                raise ValueError(
                    f"{option} {escape_controls(str(path))}: is also {other_option}'s output "
                    f"({escape_controls(str(other))}); two outputs of one command on one file "
                    "would lose one of them: give each its own path"
                )
        seen.append((option, path))


def check_writable_file(path: StrPath, option: str = "--rrd") -> Path:
    """Raise ValueError (with ``option``, the path and the reason) unless a file can be
    written at ``path`` whole: a regular file or none (links followed), in a folder
    where a file can be made (files are written beside the target and renamed over
    it, as :func:`write_text_atomically` does). Creates nothing that stays."""
    from fuzzynav.resources import escape_controls

    path = Path(path)
    shown = escape_controls(str(path))
    if path.is_dir():
        raise ValueError(f"{option} {shown}: is a directory, not a file")
    if path.exists() and not stat.S_ISREG(path.stat().st_mode):
        raise ValueError(
            f"{option} {shown}: is not a regular file (a device or a pipe); "
            "the file is written whole, then renamed into place"
        )
    target = _target(path)
    parent = target.parent
    if not parent.exists():
        raise ValueError(
            f"{option} {shown}: directory {escape_controls(str(parent))} does not exist"
        )
    if not parent.is_dir():
        raise ValueError(f"{option} {shown}: {escape_controls(str(parent))} is not a directory")
    try:
        probe = temporary_beside(path)
    except OSError as exc:
        raise ValueError(f"{option} {shown}: cannot write there ({exc.strerror or exc})") from None
    discard(probe, path)
    return path
