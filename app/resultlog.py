"""``--out PATH.jsonl``: the rows of a study, one JSON object a line, written as they arrive.

Each line is one finished run, written whole with its newline in one call and flushed,
so that a crash or Ctrl-C loses at most the run in progress. ``--resume`` reads the file
back: its rows are not run again and never written twice; a last line without its
newline (cut by a crash) is an unfinished write and is dropped (the file is cut back to
the last whole line before anything is appended). Any other line that is not a JSON
object, or a row that belongs to another study, is refused with the file and line
named; so is an existing file without ``--resume`` (nothing is overwritten).

JSON numbers are written with ``repr`` precision, so a row read back is equal, bit for
bit, to the row that was written; non-finite floats are written as ``null``.
"""

from __future__ import annotations

import json
import math
import os
from collections.abc import Callable, Iterable
from pathlib import Path

__all__ = ["ResultLog", "ResultLogError", "finite_or_none"]


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

    Raises
    ------
    ResultLogError
        The file exists without ``resume``; a line is not a JSON object; its folder
        does not exist or the path is a directory.
    """

    def __init__(self, path, *, resume: bool, key: Callable[[dict], object]):
        self.path = Path(path)
        self.key = key
        self.rows: dict[object, dict] = {}
        self._lines: dict[object, int] = {}
        self._file = None
        self.dropped_partial_line = False
        if self.path.is_dir():
            raise ResultLogError(f"--out {self.path}: is a directory, not a file")
        if not self.path.parent.is_dir():
            raise ResultLogError(f"--out {self.path}: folder {self.path.parent} does not exist")
        if self.path.exists():
            if not resume:
                raise ResultLogError(
                    f"--out {self.path}: the file exists; give --resume to go on with it, "
                    f"or another --out (nothing was overwritten)"
                )
            self._read()

    def _read(self) -> None:
        data = self.path.read_bytes()
        whole_end = data.rfind(b"\n") + 1  # a line after the last newline is unfinished
        self.dropped_partial_line = whole_end < len(data)
        self._valid_bytes = whole_end
        for number, line in enumerate(data[:whole_end].splitlines(), start=1):
            if not line.strip():
                continue
            try:
                row = json.loads(line)
            except (json.JSONDecodeError, UnicodeDecodeError) as exc:
                raise ResultLogError(f"{self.path} line {number}: not JSON ({exc})") from None
            if not isinstance(row, dict):
                raise ResultLogError(f"{self.path} line {number}: not a JSON object")
            try:
                k = self.key(row)
            except (KeyError, TypeError, ValueError) as exc:
                raise ResultLogError(
                    f"{self.path} line {number}: not a row of a study ({exc!r} missing or wrong)"
                ) from None
            if k not in self.rows:  # never written twice by us; keep the first if so
                self.rows[k] = row
                self._lines[k] = number

    def check_belongs(self, keys: Iterable) -> None:
        """Refuse a file with rows of another study (another seed, family, controller...)."""
        wanted = set(keys)
        for k, row in self.rows.items():
            if k not in wanted:
                what = ", ".join(
                    f"{name} {row.get(name)!r}"
                    for name in ("controller", "family", "seed", "perception", "index")
                    if name in row
                )
                raise ResultLogError(
                    f"{self.path} line {self._lines[k]}: a row of another study ({what}); "
                    f"give another --out, or the options it was written with"
                )

    def open(self) -> ResultLog:
        """Open for appending (cutting off an unfinished last line first)."""
        if self._file is None:
            if self.dropped_partial_line:
                with open(self.path, "r+b") as f:
                    f.truncate(self._valid_bytes)
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
        self._file.write(line + "\n")
        self._file.flush()
        os.fsync(self._file.fileno())  # a machine that goes down keeps it too
        self.rows[k] = row

    def close(self) -> None:
        if self._file is not None:
            self._file.close()
            self._file = None

    def __enter__(self):
        return self.open()

    def __exit__(self, *exc):
        self.close()
        return False
