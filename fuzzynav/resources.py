"""Where fuzzynav's shipped data lies: the ``fuzzynav.assets`` package.

Read through :mod:`importlib.resources`, so the same code finds the files in a checkout
(editable install) and in an installed wheel. Nothing is ever written there: commands
that produce files write where the user says (``--out``) or into the current folder.
"""

from __future__ import annotations

from importlib.resources import files
from pathlib import Path
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from os import PathLike


def assets_dir() -> Path:
    """The folder of the shipped data (``husky.toml``, ``rules/``, ``scenarios/``)."""
    root = files("fuzzynav.assets")
    # A wheel installs unzipped and an editable install points at the checkout, so the
    # traversable is a real folder; say so plainly if someone zipped the package.
    if not isinstance(root, Path):
        raise RuntimeError(
            f"fuzzynav's assets are not a folder on disk ({root!r}); "
            "install fuzzynav unzipped (pip does)"
        )
    return root


def asset_path(*parts: str) -> Path:
    """A shipped file: ``asset_path("rules", "paper.toml")``."""
    return assets_dir().joinpath(*parts)


# ---------------------------------------------------------------------------------------
# Reading the user's files: shared by every parser (scenario, rule base, .fis, husky.toml)
# so that each refuses the same way what no parser should try to read.

#: The largest text file any fuzzynav parser reads (a scenario of 1000 obstacles is
#: about 100 KB; a rule base of 10,000 rules about 1 MB).
MAX_INPUT_BYTES = 4 * 1024 * 1024
#: The deepest nesting of arrays, inline tables and tables a TOML input may have;
#: fuzzynav's own files nest 3 deep. tomllib recurses once per level (a few thousand
#: levels overflow the stack), so this is checked before tomllib sees the text.
MAX_TOML_DEPTH = 32
#: How much of a value an error message shows (a 15,000-digit number is cut).
MAX_SHOWN_CHARS = 80


class InputError(ValueError):
    """A user's file that cannot be read or parsed: ``source`` (the file) and ``reason``;
    the message is ``"{source}: {reason}"``."""

    def __init__(self, source: str, reason: str):
        self.source, self.reason = str(source), reason
        super().__init__(f"{self.source}: {reason}")


def shorten(text: str, limit: int = MAX_SHOWN_CHARS) -> str:
    """``text`` with control characters escaped and, if longer than ``limit``, its middle
    cut out (the length said), so that an error message stays one readable line."""
    text = escape_controls(text)
    if len(text) <= limit:
        return text
    head = limit * 2 // 3
    tail = limit - head
    return f"{text[:head]}...[{len(text)} characters]...{text[-tail:]}"


def shown(value: object) -> str:
    """``repr(value)`` for an error message: cut to :data:`MAX_SHOWN_CHARS`, control
    characters escaped; huge integers are described, never converted to text (Python
    refuses more than 4300 digits), and nesting is never walked."""
    if isinstance(value, int) and not isinstance(value, bool) and value.bit_length() > 256:
        return f"<an integer of {value.bit_length()} bits>"
    import reprlib

    brief = reprlib.Repr()  # (keyword arguments only from Python 3.12)
    brief.maxlevel, brief.maxdict, brief.maxlist, brief.maxtuple = 3, 6, 8, 8
    brief.maxstring = brief.maxother = brief.maxlong = 60
    try:
        text = brief.repr(value)
    except (ValueError, RecursionError):  # an integer deep inside, or a cycle
        text = f"<a {type(value).__name__}>"
    return shorten(text)


#: The Unicode bidirectional controls (embeddings, overrides, isolates, marks): a name
#: holding U+202E prints the rest of the line reversed ("Trojan Source").
_BIDI_CONTROLS = frozenset((0x061C, 0x200E, 0x200F, *range(0x202A, 0x202F), *range(0x2066, 0x206A)))


def escape_controls(text: str, keep: str = "") -> str:
    r"""``text`` with every control character (C0, DEL, C1, the line/paragraph
    separators and the bidirectional controls) written as a visible escape (ESC as ``\x1b``), except those in
    ``keep``, so that a name from a file cannot drive the terminal."""
    out = []
    for ch in text:
        o = ord(ch)
        if ch not in keep and (
            o < 0x20 or 0x7F <= o < 0xA0 or o in (0x2028, 0x2029) or o in _BIDI_CONTROLS
        ):
            out.append(f"\\x{o:02x}" if o < 0x100 else f"\\u{o:04x}")
        else:
            out.append(ch)
    return "".join(out)


def read_user_text(
    path: str | PathLike[str], what: str = "file", max_bytes: int = MAX_INPUT_BYTES
) -> str:
    """The text of a user's file (:func:`read_user_bytes`, decoded): a UTF-8 byte-order
    mark is dropped; text that is not UTF-8 is refused."""
    return decode_user_bytes(read_user_bytes(path, what, max_bytes), str(path))


def read_user_bytes(
    path: str | PathLike[str], what: str = "file", max_bytes: int = MAX_INPUT_BYTES
) -> bytes:
    """The bytes of a user's file, or :class:`InputError` saying what the path is: the
    project's one reader of the files a user names.

    A directory, a FIFO, a device or a socket is named as such (a FIFO is never opened:
    that would wait for a writer; ``/dev/zero`` is never read: it never ends); a missing
    file, one that cannot be read (permission) or one over ``max_bytes`` is refused with
    the reason. The file is checked again once open (it may have been swapped), and
    never more than ``max_bytes + 1`` bytes are read.
    """
    import os

    path = Path(path)
    shown_path = escape_controls(str(path))
    try:
        info = path.stat()
    except FileNotFoundError:
        raise InputError(shown_path, f"cannot read: no such {what}") from None
    except OSError as exc:
        raise InputError(shown_path, f"cannot read: {exc.strerror or exc}") from None
    _refuse_irregular(shown_path, info.st_mode, what)
    if info.st_size > max_bytes:
        raise InputError(
            shown_path,
            f"{info.st_size} bytes is more than a {what} may be (at most {max_bytes} bytes)",
        )
    try:
        fd = os.open(path, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0))
        with os.fdopen(fd, "rb") as stream:
            _refuse_irregular(shown_path, os.fstat(stream.fileno()).st_mode, what)
            data = stream.read(max_bytes + 1)
    except OSError as exc:
        raise InputError(shown_path, f"cannot read: {exc.strerror or exc}") from None
    if len(data) > max_bytes:
        raise InputError(shown_path, f"more than a {what} may be (at most {max_bytes} bytes)")
    return data


def _refuse_irregular(source: str, mode: int, what: str) -> None:
    import stat

    if stat.S_ISDIR(mode):
        raise InputError(source, f"is a directory, not a {what}")
    if not stat.S_ISREG(mode):
        kind = (
            "a FIFO (named pipe)"
            if stat.S_ISFIFO(mode)
            else "a socket"
            if stat.S_ISSOCK(mode)
            else "a device"
            if stat.S_ISCHR(mode) or stat.S_ISBLK(mode)
            else "not a regular file"
        )
        raise InputError(source, f"is {kind}, not a {what}")


def decode_user_bytes(data: bytes, source: str) -> str:
    """UTF-8 text of uploaded or read bytes (a byte-order mark dropped), or InputError."""
    try:
        return bytes(data).decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        raise InputError(source, f"not UTF-8 text ({exc.reason} at byte {exc.start})") from None


def toml_nesting_depth(text: str, limit: int = MAX_TOML_DEPTH) -> int:
    """The deepest bracket nesting of TOML text (arrays, inline tables and table
    headers), scanned in one linear pass that skips strings and comments; stops early
    and returns ``limit + 1`` once the nesting passes ``limit``."""
    depth = deepest = 0
    i, n = 0, len(text)
    while i < n:
        ch = text[i]
        if ch == "#":
            j = text.find("\n", i)
            i = n if j < 0 else j + 1
            continue
        if ch == '"' or ch == "'":
            triple = text.startswith(ch * 3, i)
            if triple:
                if ch == '"':  # basic: a backslash escapes the next character
                    end = i + 3
                    while end < n and not text.startswith('"""', end):
                        end += 2 if text[end] == "\\" else 1
                    end = -1 if end >= n else end
                else:
                    end = text.find(ch * 3, i + 3)
                # A closing run may be longer than three quotes ("""a"""" ends in one).
                i = n if end < 0 else end + 3
                while i < n and text[i] == ch:
                    i += 1
                continue
            j = i + 1
            while j < n and text[j] != ch and text[j] != "\n":
                j += 2 if ch == '"' and text[j] == "\\" else 1
            i = j + 1
            continue
        if ch == "[" or ch == "{":
            depth += 1
            if depth > deepest:
                deepest = depth
                if deepest > limit:
                    return deepest
        elif ch == "]" or ch == "}":
            depth -= 1
        i += 1
    return deepest


def _structure_depth(data: object, limit: int) -> int:
    """The nesting depth of parsed TOML data, walked without recursion; stops past
    ``limit`` (dotted keys and headers like ``[a.a.a...]`` nest without brackets)."""
    deepest = 0
    stack: list[tuple[object, int]] = [(data, 1)]
    while stack:
        value, depth = stack.pop()
        if depth > deepest:
            deepest = depth
            if deepest > limit:
                return deepest
        if isinstance(value, dict):
            stack.extend((v, depth + 1) for v in value.values() if isinstance(v, (dict, list)))
        elif isinstance(value, list):
            stack.extend((v, depth + 1) for v in value if isinstance(v, (dict, list)))
    return deepest


def loads_user_toml(text: str, source: str, max_depth: int = MAX_TOML_DEPTH) -> dict[str, Any]:
    """Parse a user's TOML text with every limit checked, or raise :class:`InputError`
    naming ``source``: nesting deeper than ``max_depth`` (checked before tomllib
    recurses), invalid TOML, an integer too long for Python, and structures nested
    deeper than ``max_depth`` through dotted keys."""
    import tomllib

    if text.startswith("\ufeff"):
        text = text[1:]
    if toml_nesting_depth(text, max_depth) > max_depth:
        raise InputError(
            source,
            f"arrays, inline tables or headers nested deeper than {max_depth} levels (the limit)",
        )
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise InputError(source, f"not valid TOML: {shorten(str(exc), 200)}") from None
    except (ValueError, RecursionError, MemoryError) as exc:
        # An integer of more than 4300 digits (Python's limit for int()).
        raise InputError(source, f"not usable TOML: {shorten(str(exc), 200)}") from None
    if _structure_depth(data, max_depth) > max_depth:
        raise InputError(
            source,
            f"keys nested deeper than {max_depth} levels (the limit), e.g. through dotted keys",
        )
    return data
