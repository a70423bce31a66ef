"""``--out PATH.jsonl``: the rows of a study, one JSON object a line, written as they arrive.

Each line is one finished run, written whole with its newline in one call and flushed,
so that a crash or Ctrl-C loses at most the run in progress. ``--resume`` reads the file
back: its rows are not run again and never written twice.

What ``--resume`` trusts: nothing. The file is read through the project's
safe reader (a regular file, at most :data:`MAX_RESULTS_BYTES`; a FIFO or ``/dev/zero``
is refused, never read). Every line must be a JSON object with ``\\n`` line ends
(carriage returns are refused) whose every field passes ``check_row`` (its type and
range), and whose fingerprint says it was made by this fuzzynav, rule base and robot;
otherwise the file and the line are named, exit status 2, and the file is left as it
was. A last line without its newline (cut by a crash) is an unfinished write and is
dropped (the file is cut back to the last whole line before anything is appended) only
when at least one whole row comes before it and the fragment is the start of a row:
anything else, e.g. a file holding one JSON object without a newline, is refused.

While a study writes its file, the file is locked (an OS advisory lock, ``flock``): a
second run on the same file refuses, naming the first one's process id.

JSON numbers are written with ``repr`` precision, so a row read back is equal, bit for
bit, to the row that was written; non-finite floats are written as ``null``.
"""

from __future__ import annotations

import contextlib
import json
import math
import os
from collections.abc import Callable, Iterable
from collections.abc import Set as AbstractSet
from pathlib import Path

__all__ = ["ResultLog", "ResultLogError", "finite_or_none", "MAX_RESULTS_BYTES"]

#: The largest results file ``--resume`` reads: about 300,000 rows of ~800 bytes (two
#: controllers' sweeps of the largest ``--n``, with room to spare).
MAX_RESULTS_BYTES = 256 * 1024 * 1024
#: The longest line of a results file: a row is under 1 kB; a line far longer is no row
#: (and is never handed to the JSON parser, whose recursion a deep array exhausts).
MAX_ROW_BYTES = 64 * 1024


class ResultLogError(ValueError):
    """A results file that cannot be used as asked (exit status 2 from the CLI)."""


def finite_or_none(value):
    """``value``, with a non-finite float replaced by None (recursively in lists/dicts)."""
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if isinstance(value, dict):
        return {k: finite_or_none(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [finite_or_none(v) for v in value]
    return value


def _lock_holder(fd: int) -> int | None:
    """The process id holding a ``flock`` on the file open as ``fd`` (Linux's
    ``/proc/locks``; None where that cannot be read)."""
    info = os.fstat(fd)
    inode = f"{os.major(info.st_dev):02x}:{os.minor(info.st_dev):02x}:{info.st_ino}"
    try:
        with open("/proc/locks", encoding="ascii", errors="replace") as locks:
            for line in locks:
                fields = line.split()
                # "1: FLOCK  ADVISORY  WRITE 4242 08:01:1234 0 EOF" (a "->" marks waiters)
                if "->" not in fields and "FLOCK" in fields and inode in fields:
                    return int(fields[fields.index(inode) - 1])
    except (OSError, ValueError, IndexError):
        return None
    return None


class ResultLog:
    """The JSON Lines file of a study.

    Parameters
    ----------
    path : path-like
        The file (``.jsonl`` by convention; any name is accepted).
    resume : bool
        False: the file must not exist. True: its rows are read (it may not exist yet).
    key : callable
        Row -> hashable identity of the run (which layout, controller, options...).
    check_row : callable, optional
        Row -> None, raising ValueError naming the field and value of a row that is
        not one of this study's (wrong type, out of range, another fingerprint).

    Raises
    ------
    ResultLogError
        The file exists without ``resume``; a line is not a valid row; the file is not
        a regular file, is too large, or is locked by another run; its folder does not
        exist or the path is a directory.
    """

    def __init__(
        self,
        path,
        *,
        resume: bool,
        key: Callable[[dict], object],
        check_row: Callable[[dict], None] | None = None,
    ):
        from fuzzynav.resources import escape_controls

        self.path = Path(path)
        self.shown = escape_controls(str(self.path))
        self.key = key
        self.check_row = check_row
        self.rows: dict[object, dict] = {}
        self._lines: dict[object, int] = {}
        self._file = None
        self._lock_fd: int | None = None
        self._created = False
        self._valid_bytes = 0
        self.dropped_partial_line = False
        if self.path.is_dir():
            raise ResultLogError(f"--out {self.shown}: is a directory, not a file")
        if not self.path.parent.is_dir():
            raise ResultLogError(
                f"--out {self.shown}: folder {escape_controls(str(self.path.parent))} "
                "does not exist"
            )
        if self.path.exists() or self.path.is_symlink():
            if not resume:
                raise ResultLogError(
                    f"--out {self.shown}: the file exists; give --resume to go on with it, "
                    f"or another --out (nothing was overwritten)"
                )
            self._read()

    # ----------------------------------------------------------------------- reading

    def _read(self) -> None:
        from fuzzynav.resources import InputError, read_user_bytes

        try:
            data = read_user_bytes(self.path, "results file", MAX_RESULTS_BYTES)
        except InputError as exc:
            raise ResultLogError(f"--out {exc}") from None
        if b"\r" in data:
            number = data[: data.index(b"\r")].count(b"\n") + 1
            raise ResultLogError(
                f"{self.shown} line {number}: a carriage return; a results file of fuzzynav "
                "has '\\n' line ends only (the file was left as it was)"
            )
        whole_end = data.rfind(b"\n") + 1  # a line after the last newline is unfinished
        number = 0
        for number, line in enumerate(data[:whole_end].split(b"\n")[:-1], start=1):
            if not line.strip():
                continue
            self._add(self._parse(line, number), number)
        fragment = data[whole_end:]
        if fragment:
            # Our writer puts each row and its newline in one call: only the last line
            # can be cut, and it starts like a row. Anything else is not our file.
            if not self.rows or not fragment.startswith(b'{"'):
                raise ResultLogError(
                    f"{self.shown} line {number + 1}: not a whole line (no newline at its end) "
                    "and not the cut end of a results file of this study; the file was left "
                    "as it was: give another --out"
                )
            self.dropped_partial_line = True
        self._valid_bytes = whole_end

    def _parse(self, line: bytes, number: int) -> dict:
        if len(line) > MAX_ROW_BYTES:
            raise ResultLogError(
                f"{self.shown} line {number}: {len(line)} bytes, longer than any row "
                f"(at most {MAX_ROW_BYTES})"
            )
        try:
            row = json.loads(line)
        except (json.JSONDecodeError, UnicodeDecodeError) as exc:
            raise ResultLogError(f"{self.shown} line {number}: not JSON ({exc})") from None
        except RecursionError:
            raise ResultLogError(f"{self.shown} line {number}: JSON nested too deep") from None
        if not isinstance(row, dict):
            raise ResultLogError(f"{self.shown} line {number}: not a JSON object")
        return row

    def _add(self, row: dict, number: int) -> None:
        try:
            if self.check_row is not None:
                self.check_row(row)
            k = self.key(row)
            hash(k)
        except (KeyError, TypeError, ValueError) as exc:
            from fuzzynav.resources import shorten

            reason = f"{exc.args[0]!r} missing" if isinstance(exc, KeyError) else str(exc)
            raise ResultLogError(
                f"{self.shown} line {number}: not a row of this study ({shorten(reason, 300)}); "
                "the file was left as it was"
            ) from None
        if k not in self.rows:  # never written twice by us; keep the first if so
            self.rows[k] = row
            self._lines[k] = number

    def check_belongs(self, keys: Iterable, describe: Callable[[dict], str] | None = None) -> None:
        """Refuse a file with rows of another study (another seed, family, controller,
        fuzzynav version, rule base...); ``describe(row)`` says what differs."""
        wanted = keys if isinstance(keys, AbstractSet) else set(keys)  # (a sweep's: lazy)
        for k, row in self.rows.items():
            if k not in wanted:
                if describe is not None:
                    what = describe(row)
                else:
                    what = ", ".join(
                        f"{name} {row.get(name)!r}"
                        for name in ("controller", "family", "seed", "perception", "index")
                        if name in row
                    )
                raise ResultLogError(
                    f"{self.shown} line {self._lines[k]}: a row of another study ({what}); "
                    f"give another --out, or the options it was written with"
                )

    # ----------------------------------------------------------------------- writing

    def lock(self) -> ResultLog:
        """Take the file's advisory lock (creating the file if needed), or refuse with
        the process id of the run that holds it. Released by :meth:`close`."""
        import fcntl

        if self._lock_fd is not None:
            return self
        existed = self.path.exists()
        fd = os.open(self.path, os.O_RDWR | os.O_CREAT | os.O_NONBLOCK, 0o666)
        self._created = not existed
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            holder = _lock_holder(fd)
            os.close(fd)
            who = f"process {holder}" if holder is not None else "another process"
            raise ResultLogError(
                f"--out {self.shown}: {who} is writing it (fuzzynav sweep or compare); two "
                "runs on one file would run and write every row twice: wait for it, or give "
                "another --out"
            ) from None
        self._lock_fd = fd
        return self

    def open(self) -> ResultLog:
        """Lock, then open for appending (cutting off an unfinished last line first)."""
        if self._file is None:
            self.lock()
            if self.dropped_partial_line:
                os.truncate(self.path, self._valid_bytes)
            self._file = open(self.path, "a", encoding="utf-8")  # noqa: SIM115 (closed in close())
        return self

    def write(self, row: dict) -> None:
        """Append one row (skipped if a row with its key is there already), flushed."""
        k = self.key(row)
        if k in self.rows:
            return
        if self._file is None:
            self.open()
        row = finite_or_none(row)
        line = json.dumps(row, allow_nan=False, separators=(",", ":"))
        try:
            self._file.write(line + "\n")
            self._file.flush()
            os.fsync(self._file.fileno())  # a machine that goes down keeps it too
        except OSError as exc:  # a full disk: say which file
            raise OSError(exc.errno, exc.strerror or str(exc), self.shown) from None
        self.rows[k] = row

    def close(self) -> None:
        if self._file is not None:
            with contextlib.suppress(OSError):
                self._file.close()
            self._file = None
        if self._lock_fd is not None:
            if self._created and os.fstat(self._lock_fd).st_size == 0:
                # made by this run, which ended before its first row: leave no empty
                # file that a later run without --resume would take for a study
                with contextlib.suppress(OSError):
                    os.unlink(self.path)
            os.close(self._lock_fd)  # releases the lock
            self._lock_fd = None

    def __enter__(self):
        return self.open()

    def __exit__(self, *exc):
        self.close()
        return False
