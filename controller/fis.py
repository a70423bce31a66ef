"""MATLAB Fuzzy Logic Toolbox ``.fis`` files: a strict reader and a writer.

Supported: what the engine in :mod:`controller.fuzzy` computes -- a Mamdani system with
AndMethod 'min' or 'prod', OrMethod 'max' or 'probor', ImpMethod 'min' or 'prod',
AggMethod 'max', 'sum' or 'probor', DefuzzMethod 'centroid', 'bisector', 'mom', 'som' or
'lom' (MATLAB's meanings: :mod:`controller.inference`), the membership functions of
:data:`controller.membership.SHAPES` by their MATLAB names (trimf, trapmf, linsmf, linzmf,
gaussmf, gauss2mf), AND and OR rules (connection 1 and 2) and NOT in an antecedent (a
negative term index: 1 - the term's membership). Everything else (Sugeno, custom methods,
other membership functions, NOT in a consequent) is rejected with an error that names the
file, the line and the value. The file is parsed, never evaluated.

The format::

    [System]
    Name='fuzzy-husky-paper'
    Type='mamdani'
    Version=2.0
    NumInputs=4
    NumOutputs=2
    NumRules=40
    AndMethod='min'
    OrMethod='max'
    ImpMethod='min'
    AggMethod='max'
    DefuzzMethod='centroid'

    [Input1]
    Name='d_t'
    Range=[-1.13 30]
    NumMFs=5
    MF1='VS':'linzmf',[0.2 1]
    ...

    [Output1]
    ...

    [Rules]
    5 0 1 0, 4 1 (1) : 1

A rule line lists, per input, the 1-based term index (0 = the input takes no part; -k =
NOT term k), a comma, per output the 1-based term index (0 = none), the weight in parentheses, a colon
and the connection (1 = AND, 2 = OR).

Not stored in a .fis file: the defuzzification grid size (MATLAB passes it to evalfis;
we read 101, MATLAB's default), units and descriptions.
"""

from __future__ import annotations

import math
import re
from pathlib import Path

from fuzzynav.resources import InputError, escape_controls, read_user_text, shorten

from . import membership as mf
from .fuzzy import DEFAULT_POINTS, FuzzySystem, Rule, Term, Variable
from .inference import CHOICES, FIS_KEYS, Inference
from .rulebase import MAX_RULES, MAX_TERMS, MAX_VARIABLES

__all__ = ["read_fis", "write_fis", "loads_fis", "dumps_fis", "FisFormatError"]


class FisFormatError(ValueError):
    """A .fis file we cannot read (malformed or unsupported)."""


# Each alternative starts with a different character class and nothing repeats a
# repeat, so matching is linear in the token's length (the former \d+\.?\d* tried
# every split of a run of digits: 20,000 digits and an 'x' took 39 s).
_NUM = r"[+-]?(?:\d+(?:\.\d*)?|\.\d+)(?:[eE][+-]?\d+)?"
_INT_RE = re.compile(r"[+-]?\d+")
#: The most digits an integer field (a count, an index) may have before it is refused.
_MAX_INT_DIGITS = 9
_NUM_RE = re.compile(rf"^{_NUM}$")
_SECTION_RE = re.compile(r"^\[(System|Input(\d{1,9})|Output(\d{1,9})|Rules)\]$")
_KV_RE = re.compile(r"^([A-Za-z][A-Za-z0-9]*)\s*=\s*(.*)$")
_STR_RE = re.compile(r"^'([^']*)'$")
_VEC_RE = re.compile(r"^\[([^\]]*)\]$")
_MF_RE = re.compile(r"^'([^']*)'\s*:\s*'([^']*)'\s*,\s*\[([^\]]*)\]$")
_RULE_RE = re.compile(r"^([^,]*),([^(]*)\(([^)]*)\)\s*:\s*(\S+)$")

_SYSTEM_KEYS = {"Name", "Type", "Version", "NumInputs", "NumOutputs", "NumRules"} | set(
    FIS_KEYS.values()
)
_VAR_KEYS = {"Name", "Range", "NumMFs"}


class _Reader:
    def __init__(self, source: str):
        self.source = source

    def err(self, lineno: int | None, what: str, value=None) -> FisFormatError:
        where = f"{self.source}:{lineno}" if lineno else self.source
        tail = f" (got {shorten(repr(value))})" if value is not None else ""
        return FisFormatError(f"{escape_controls(where)}: {what}{tail}")

    def num(self, lineno: int, text: str, what: str) -> float:
        t = text.strip()
        if not _NUM_RE.match(t):
            raise self.err(lineno, f"{what}: not a number", t)
        v = float(t)
        if not math.isfinite(v):
            raise self.err(lineno, f"{what}: not a finite number", t)
        return v

    def int_(self, lineno: int, text: str, what: str, limit: int) -> int:
        """An integer of at most ``limit`` in magnitude (the limit is named)."""
        t = text.strip()
        if not _INT_RE.fullmatch(t):
            raise self.err(lineno, f"{what}: not an integer", t)
        digits = t.lstrip("+-").lstrip("0") or "0"  # never int() of thousands of digits
        if len(digits) > _MAX_INT_DIGITS or int(digits) > limit:
            raise self.err(lineno, f"{what}: too large (at most {limit})", t)
        return -int(digits) if t.startswith("-") else int(digits)

    def count(self, lineno: int, text: str, what: str, limit: int) -> int:
        """A count of sections or terms: an integer from 1 to ``limit`` (``NumInputs=-2``
        was read, then reported as sections ``[Input1]..[Input-2]`` missing)."""
        value = self.int_(lineno, text, what, limit)
        if value < 1:
            raise self.err(lineno, f"{what}: must be at least 1", text.strip())
        return value

    def string(self, lineno: int, text: str, what: str) -> str:
        m = _STR_RE.match(text.strip())
        if not m:
            raise self.err(lineno, f"{what}: expected a quoted string like 'name'", text.strip())
        return escape_controls(m.group(1))

    def vector(self, lineno: int, text: str, what: str) -> list[float]:
        m = _VEC_RE.match(text.strip())
        if not m:
            raise self.err(lineno, f"{what}: expected a vector like [1 2 3]", text.strip())
        body = m.group(1).replace(",", " ").split()
        return [self.num(lineno, t, what) for t in body]


#: A section of a .fis file: (kind, index, its line, its (line number, text) lines).
_Section = tuple[str, int, int, list[tuple[int, str]]]


def _sections(rd: _Reader, text: str) -> list[_Section]:
    """The file's sections in order, comments and blank lines dropped."""
    sections: list[_Section] = []
    current: _Section | None = None
    for lineno, raw in enumerate(text.splitlines(), start=1):
        line = raw.strip()
        if not line or line.startswith("%") or line.startswith("#"):
            continue
        if line.startswith("["):
            m = _SECTION_RE.match(line)
            if not m:
                raise rd.err(lineno, "unknown section", line)
            if m.group(2):
                kind, idx = "Input", int(m.group(2))
            elif m.group(3):
                kind, idx = "Output", int(m.group(3))
            else:
                kind, idx = m.group(1), 0
            current = (kind, idx, lineno, [])
            sections.append(current)
            continue
        if current is None:
            raise rd.err(lineno, "text before the first [section]", line)
        current[3].append((lineno, line))
    return sections


def _system_keys(rd: _Reader, sys_sec: _Section) -> dict[str, tuple[int, str]]:
    """[System]'s keys, each with its line and value; every required one present."""
    sysd: dict[str, tuple[int, str]] = {}
    for lineno, line in sys_sec[3]:
        m = _KV_RE.match(line)
        if not m:
            raise rd.err(lineno, "expected Key=Value in [System]", line)
        key, val = m.group(1), m.group(2).strip()
        if key not in _SYSTEM_KEYS:
            raise rd.err(lineno, f"unknown [System] key {shorten(repr(key))}", line)
        if key in sysd:
            raise rd.err(lineno, f"duplicate [System] key {shorten(repr(key))}", line)
        sysd[key] = (lineno, val)
    for key in ("Name", "Type", "NumInputs", "NumOutputs", "NumRules"):
        if key not in sysd:
            raise rd.err(sys_sec[2], f"[System] lacks {key}=")
    return sysd


def _system_choices(rd: _Reader, sysd: dict[str, tuple[int, str]], sys_line: int) -> dict[str, str]:
    """The system's type (Mamdani only), its inference methods and its version."""
    lineno, val = sysd["Type"]
    got = rd.string(lineno, val, "Type")
    if got.lower() != "mamdani":
        raise rd.err(
            lineno,
            f"unsupported system type {shorten(repr(got))}: only Mamdani systems are supported (no Sugeno)",
            val,
        )
    choices = {}
    for field, key in FIS_KEYS.items():
        allowed = ", ".join(map(repr, CHOICES[field]))
        if key not in sysd:
            raise rd.err(sys_line, f"[System] lacks {key}= (one of {allowed})")
        lineno, val = sysd[key]
        got = rd.string(lineno, val, key)
        if got.lower() not in CHOICES[field]:
            raise rd.err(
                lineno, f"unsupported {key} {shorten(repr(got))}: supported are {allowed}", val
            )
        choices[field] = got.lower()
    if "Version" in sysd:
        lineno, val = sysd["Version"]
        if rd.num(lineno, val, "Version") != 2.0:
            raise rd.err(lineno, "unsupported Version (only 2.0)", val)
    return choices


def _variables(
    rd: _Reader, sections: list[_Section], kind: str, count: int, sys_line: int
) -> list[Variable]:
    """The ``count`` [Input<k>] (or [Output<k>]) sections, in order, as variables."""
    secs = [s for s in sections if s[0] == kind]
    idxs = [s[1] for s in secs]
    if idxs != list(range(1, count + 1)):
        raise rd.err(
            secs[0][2] if secs else sys_line,
            f"expected sections [{kind}1]..[{kind}{count}] in order "
            f"(Num{kind}s={count}), found {[f'{kind}{i}' for i in idxs]}",
        )
    return [_variable(rd, kind, idx, start, lines) for _kind, idx, start, lines in secs]


def _variable(
    rd: _Reader, kind: str, idx: int, start: int, lines: list[tuple[int, str]]
) -> Variable:
    """One [Input<k>] or [Output<k>] section as a variable."""
    kv: dict[str, tuple[int, str]] = {}
    mfs: dict[int, tuple[int, str]] = {}
    for lineno, line in lines:
        m = _KV_RE.match(line)
        if not m:
            raise rd.err(lineno, f"expected Key=Value in [{kind}{idx}]", line)
        key, val = m.group(1), m.group(2).strip()
        mm = re.fullmatch(r"MF(\d+)", key)
        if mm:
            k = rd.int_(lineno, mm.group(1), shorten(key), MAX_TERMS)  # MF111...: one line
            if k in mfs:
                raise rd.err(lineno, f"duplicate {key}", line)
            mfs[k] = (lineno, val)
            continue
        if key not in _VAR_KEYS:
            raise rd.err(lineno, f"unknown [{kind}{idx}] key {shorten(repr(key))}", line)
        if key in kv:
            raise rd.err(lineno, f"duplicate [{kind}{idx}] key {shorten(repr(key))}", line)
        kv[key] = (lineno, val)
    for key in ("Name", "Range", "NumMFs"):
        if key not in kv:
            raise rd.err(start, f"[{kind}{idx}] lacks {key}=")
    vname = rd.string(*kv["Name"], "Name")
    rng = rd.vector(*kv["Range"], "Range")
    if len(rng) != 2 or not rng[0] < rng[1]:
        raise rd.err(kv["Range"][0], "Range must be [lo hi] with lo < hi", kv["Range"][1])
    nmf = rd.count(*kv["NumMFs"], "NumMFs", MAX_TERMS)
    if sorted(mfs) != list(range(1, nmf + 1)):
        raise rd.err(
            kv["NumMFs"][0],
            f"expected MF1..MF{nmf} (NumMFs={nmf}), found {[f'MF{k}' for k in sorted(mfs)]}",
        )
    terms = [_term(rd, k, *mfs[k]) for k in range(1, nmf + 1)]
    try:
        return Variable(vname, (rng[0], rng[1]), tuple(terms))
    except ValueError as e:
        raise rd.err(start, f"[{kind}{idx}]: {e}") from None


def _term(rd: _Reader, k: int, lineno: int, val: str) -> Term:
    """``MF<k>='name':'type',[params]`` as a term."""
    m = _MF_RE.match(val)
    if not m:
        raise rd.err(lineno, f"MF{k}: expected 'name':'type',[params]", val)
    tname, family = m.group(1), mf.shape_for_matlab(m.group(2))
    if family is None:
        known = [s.matlab for s in mf.SHAPES.values() if s.matlab]
        raise rd.err(
            lineno,
            f"MF{k}: unsupported membership function type "
            f"{shorten(repr(m.group(2)))} (supported: {', '.join(known)})",
            val,
        )
    shape = family.name
    params = [rd.num(lineno, t, f"MF{k} parameter") for t in m.group(3).replace(",", " ").split()]
    try:
        return Term(tname, shape, tuple(params))
    except ValueError as e:
        raise rd.err(lineno, f"MF{k}: {e}", val) from None


def _rules(
    rd: _Reader,
    rules_sec: _Section,
    inputs: list[Variable],
    outputs: list[Variable],
    n_rules: int,
) -> list:
    """The [Rules] section: exactly ``n_rules`` rules."""
    rules: list = []
    for lineno, line in rules_sec[3]:
        m = _RULE_RE.match(line)
        if not m:
            raise rd.err(lineno, "expected a rule like '1 0 2 0, 3 1 (1) : 1'", line)
        if len(rules) >= n_rules:
            raise rd.err(lineno, f"more rules than NumRules={n_rules}", line)
        rules.append(_rule(rd, lineno, line, m.groups(), inputs, outputs))
    if len(rules) != n_rules:
        raise rd.err(
            rules_sec[2], f"NumRules={n_rules} but the [Rules] section has {len(rules)} rules"
        )
    return rules


def _rule(
    rd: _Reader,
    lineno: int,
    line: str,
    groups,
    inputs: list[Variable],
    outputs: list[Variable],
) -> Rule:
    """One rule line (its regular expression's groups) as a rule."""
    ant_t, con_t, w_t, conn_t = groups
    n_in, n_out = len(inputs), len(outputs)
    ant = [rd.int_(lineno, t, "antecedent index", MAX_TERMS) for t in ant_t.split()]
    con = [rd.int_(lineno, t, "consequent index", MAX_TERMS) for t in con_t.split()]
    if len(ant) != n_in:
        raise rd.err(
            lineno,
            f"the rule has {len(ant)} antecedent indices, the system has {n_in} inputs",
            line,
        )
    if len(con) != n_out:
        raise rd.err(
            lineno,
            f"the rule has {len(con)} consequent indices, the system has {n_out} outputs",
            line,
        )
    w = rd.num(lineno, w_t, "rule weight")
    if not 0.0 <= w <= 1.0:
        raise rd.err(lineno, "rule weight must be in [0, 1]", w_t.strip())
    conn = rd.int_(lineno, conn_t, "connection", 2)
    if conn not in (1, 2):
        raise rd.err(lineno, "connection must be 1 (AND) or 2 (OR)", conn_t)
    for v, a in zip(inputs, ant):
        if abs(a) > len(v.terms):
            raise rd.err(
                lineno,
                f"term index {a} out of range for input {v.name!r} ({len(v.terms)} MFs)",
                line,
            )
    for v, c in zip(outputs, con):
        if c < 0:
            raise rd.err(lineno, f"negated consequents are not supported (output {v.name!r})", line)
        if c > len(v.terms):
            raise rd.err(
                lineno,
                f"term index {c} out of range for output {v.name!r} ({len(v.terms)} MFs)",
                line,
            )
    try:
        return Rule(
            tuple(None if a == 0 else a - 1 if a > 0 else a for a in ant),
            tuple(c - 1 if c else None for c in con),
            w,
            "and" if conn == 1 else "or",
        )
    except ValueError as e:
        raise rd.err(lineno, str(e), line) from None


def loads_fis(text: str, source: str = "<string>") -> FuzzySystem:
    """Parse .fis text (``source`` names it in error messages)."""
    rd = _Reader(source)
    sections = _sections(rd, text)
    kinds = [s[0] for s in sections]
    for k in ("System", "Rules"):
        if kinds.count(k) != 1:
            raise rd.err(None, f"expected exactly one [{k}] section, found {kinds.count(k)}")
    sys_sec = sections[kinds.index("System")]
    sysd = _system_keys(rd, sys_sec)
    name = rd.string(*sysd["Name"], "Name")
    choices = _system_choices(rd, sysd, sys_sec[2])
    n_in = rd.count(*sysd["NumInputs"], "NumInputs", MAX_VARIABLES)
    n_out = rd.count(*sysd["NumOutputs"], "NumOutputs", MAX_VARIABLES)
    n_rules = rd.int_(*sysd["NumRules"], "NumRules", MAX_RULES)
    inputs = _variables(rd, sections, "Input", n_in, sys_sec[2])
    outputs = _variables(rd, sections, "Output", n_out, sys_sec[2])
    rules = _rules(rd, sections[kinds.index("Rules")], inputs, outputs, n_rules)
    try:
        return FuzzySystem(
            inputs,
            outputs,
            rules,
            name=name,
            n_points=DEFAULT_POINTS,
            inference=Inference(**choices),
        )
    except ValueError as e:
        raise rd.err(None, str(e)) from None


def read_fis(path) -> FuzzySystem:
    """Read a MATLAB .fis file."""
    path = Path(path)
    try:
        text = read_user_text(path, ".fis file")  # a byte-order mark is dropped
    except InputError as e:
        raise FisFormatError(str(e)) from None
    return loads_fis(text, str(path))


def _num(x: float) -> str:
    s = repr(float(x))
    if s.endswith(".0"):
        s = s[:-2]
    return s


def _quoted(s: str, what: str) -> str:
    if "'" in s or "\n" in s:
        raise ValueError(f"cannot write {what} {s!r} to a .fis file (quote or newline)")
    return f"'{s}'"


def dumps_fis(system: FuzzySystem) -> str:
    """The system as .fis text (numbers written so that they read back exactly).

    Raises
    ------
    ValueError
        The system reads NONE as "sensed nothing" for some input (``unsensed_none``):
        MATLAB's rule editor knows only its own NONE, so a .fis would drive differently;
        or a term's family has no MATLAB name (``Shape.matlab``); or its defuzzification
        grid is not MATLAB's 101 points (a .fis holds no point count, so it would read
        back, and run in MATLAB, with another grid and other voltages).
    """
    if system.n_points != DEFAULT_POINTS:
        raise ValueError(
            f"{system.name}: cannot write its {system.n_points}-point defuzzification grid "
            f"to a .fis file, which holds no point count (MATLAB's evalfis uses "
            f"{DEFAULT_POINTS}): the file would drive otherwise. Use the TOML rule base "
            f"(its 'points' key), or system.replace(n_points={DEFAULT_POINTS})"
        )
    if system.unsensed_none:
        raise ValueError(
            f"{system.name}: its rules read NONE for {', '.join(system.unsensed_none)} as "
            "'sensed nothing' (the paper's text), which a .fis cannot say: MATLAB reads "
            "NONE as 'takes no part', and the exported system would drive differently. "
            "Use the TOML rule base instead (fuzzynav.write_toml), or drop "
            "unsensed_none (system.replace(unsensed_none=())) to export MATLAB's reading"
        )
    L = [
        "[System]",
        f"Name={_quoted(system.name, 'system name')}",
        "Type='mamdani'",
        "Version=2.0",
        f"NumInputs={len(system.inputs)}",
        f"NumOutputs={len(system.outputs)}",
        f"NumRules={len(system.rules)}",
    ]
    L += [f"{key}='{getattr(system.inference, field)}'" for field, key in FIS_KEYS.items()]
    for kind, vs in (("Input", system.inputs), ("Output", system.outputs)):
        for i, v in enumerate(vs, start=1):
            L += [
                "",
                f"[{kind}{i}]",
                f"Name={_quoted(v.name, 'variable name')}",
                f"Range=[{_num(v.range[0])} {_num(v.range[1])}]",
                f"NumMFs={len(v.terms)}",
            ]
            for k, t in enumerate(v.terms, start=1):
                matlab = mf.SHAPES[t.shape].matlab
                if matlab is None:
                    raise ValueError(f"{v.name}.{t.name}: MATLAB has no {t.shape} (no .fis name)")
                L.append(
                    f"MF{k}={_quoted(t.name, 'term name')}:'{matlab}',"
                    f"[{' '.join(_num(p) for p in t.params)}]"
                )
    L += ["", "[Rules]"]
    for r in system.rules:
        # 1-based; NOT term k (~k = -k - 1) is MATLAB's negative index -(k + 1) as it is
        ant = " ".join(str(0 if a is None else a + 1 if a >= 0 else a) for a in r.antecedent)
        con = " ".join(str(0 if c is None else c + 1) for c in r.consequent)
        L.append(f"{ant}, {con} ({_num(r.weight)}) : {1 if r.connection == 'and' else 2}")
    return "\n".join(L) + "\n"


def write_fis(system: FuzzySystem, path) -> None:
    """Write a MATLAB .fis file."""
    from fuzzynav.safe_files import write_text_atomically

    write_text_atomically(path, dumps_fis(system))
