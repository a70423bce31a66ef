"""The TOML rule-base format: reader, writer and the rule sentence parser/formatter.

Format (every key below is allowed; any other key is an error)::

    [system]
    name = "fuzzy-husky-paper"           # required
    description = "..."                  # optional
    points = 101                         # optional: defuzzification grid points (default 101)
    # Inference (optional keys, MATLAB's names and meanings, the defaults first;
    # controller/inference.py): and = "min" | "prod", or = "max" | "probor" (the OR
    # rules'), implication = "min" | "prod",
    # aggregation = "max" | "sum" | "probor",
    # defuzzification = "centroid" | "bisector" | "mom" | "som" | "lom"
    # unsensed_none = ["d_o"]            # optional: inputs whose NONE in a rule means
    #   "sensed nothing" (the paper's text for d_o), not MATLAB's "takes no part"

    [[inputs]]                           # one table per input, in column order
    name = "d_t"
    range = [-1.13, 30.0]
    unit = "m"                           # optional
    description = "distance to target"   # optional
    terms = [                            # in order; rules refer to them by name
      { name = "VS", shape = "linzmf", params = [0.0, 1.0] },
      ...
    ]

    [[outputs]]                          # same keys as [[inputs]]
    ...

    [rulebase]
    rules = [
      "IF d_t IS VL AND phi_t IS VN THEN left IS L AND right IS VS",
      "IF d_o IS near AND phi_o IS Z THEN left IS VS AND right IS M WEIGHT 0.5",
      "IF d_o IS near OR phi_o IS NOT Z THEN left IS S",
      ...
    ]

A rule sentence is ``IF <input> IS [NOT] <term> [AND <input> IS [NOT] <term>]... THEN
<output> IS <term> [AND <output> IS <term>]... [WEIGHT <w>]``, or the same with OR in
place of every AND of the antecedent (an OR rule, MATLAB's connection 2; one rule is all
AND or all OR, as in MATLAB). ``IS NOT <term>`` takes 1 - the term's membership
(MATLAB's negative term index). An input that takes no part (the paper's NONE) is simply
left out; so is an output the rule says nothing about. The keywords IF, AND, OR, NOT,
THEN, IS, WEIGHT are case-insensitive; variable and term names are case-sensitive. The
weight defaults to 1 and must lie in [0, 1].

The reader is strict: unknown keys, unknown variable or term names, bad shapes or
parameter counts, non-finite numbers and malformed rules raise ValueError naming the
file, the key and the value.
"""

from __future__ import annotations

import math
import re
from pathlib import Path
from typing import Any

from fuzzynav.resources import InputError, escape_controls, loads_user_toml, read_user_text, shown

from . import membership as mf
from .fuzzy import DEFAULT_POINTS, FuzzySystem, Rule, Term, Variable, rule_sentence
from .inference import CHOICES, TOML_KEYS, Inference

__all__ = ["read_toml", "write_toml", "parse_rule", "format_rule", "loads_toml", "dumps_toml"]

_SYSTEM_KEYS = {"name", "description", "points", "unsensed_none"} | set(TOML_KEYS.values())
_VAR_KEYS = {"name", "range", "unit", "description", "terms"}
_VAR_REQUIRED = ("name", "range", "terms")
_TERM_KEYS = {"name", "shape", "params"}
_TOP_KEYS = {"system", "inputs", "outputs", "rulebase"}
_RULEBASE_KEYS = {"rules"}

_NAME_RE = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*$")

# Limits on what a rule base (TOML or .fis) may ask the engine to build: far beyond any
# controller here (4 inputs, 2 outputs, 5 terms, 40 rules, 101 points), and small
# enough that building one takes well under a second and at most ~40 MB (the output
# terms are sampled on the grid: outputs x terms x points floats).
MAX_VARIABLES = 16  #: inputs, and outputs, each
MAX_TERMS = 32  #: terms (membership functions) per variable
MAX_RULES = 5000
MAX_POINTS = 10_001  #: defuzzification grid points
MAX_NAME_CHARS = 200


class _Err:
    def __init__(self, source: str):
        self.source = source

    def __call__(self, key: str, value: Any, why: str) -> ValueError:
        return ValueError(
            f"{escape_controls(self.source)}: key {key!r}: value {shown(value)}: {why}"
        )


# --------------------------------------------------------------------------- rules


def _tokens(text: str) -> list[str]:
    return text.split()


def parse_rule(text: str, inputs: list[Variable], outputs: list[Variable]) -> Rule:
    """Parse one rule sentence. Raises ValueError (without location; callers add it)."""
    toks = _tokens(text)
    if not toks or toks[0].upper() != "IF":
        raise ValueError("a rule must start with IF")
    upper = [t.upper() for t in toks]
    if upper.count("THEN") != 1:
        raise ValueError("a rule needs exactly one THEN")
    t_then = upper.index("THEN")
    weight = 1.0
    end = len(toks)
    if "WEIGHT" in upper:
        t_w = upper.index("WEIGHT")
        if t_w < t_then or t_w != len(toks) - 2:
            raise ValueError("WEIGHT <w> must come last, after the consequent")
        wtxt = toks[-1]
        if not re.fullmatch(r"[+]?(\d+(\.\d*)?|\.\d+)([eE][+-]?\d+)?", wtxt):
            raise ValueError(f"weight {wtxt!r} is not a number")
        weight = float(wtxt)
        if not (0.0 <= weight <= 1.0):
            raise ValueError(f"weight {wtxt} is not in [0, 1]")
        end = t_w

    ant, connection = _clauses(toks[1:t_then], inputs, outputs, "antecedent")
    con, _ = _clauses(toks[t_then + 1 : end], outputs, inputs, "consequent")
    return Rule(ant, con, weight, connection)


def _clauses(
    part: list[str], variables: list[Variable], others: list[Variable], side: str
) -> tuple[tuple[int | None, ...], str]:
    """One side of a rule sentence: its term indices (``~k`` for NOT term k) and its
    connective ("and" or "or"; a consequent is joined by AND, without NOT)."""
    by_name = {v.name: i for i, v in enumerate(variables)}
    picked: list[int | None] = [None] * len(variables)
    if not part:
        raise ValueError(f"the {side} is empty")
    groups: list[list[str]] = [[]]
    joints = set()
    for t in part:
        if t.upper() in ("AND", "OR"):
            joints.add(t.upper())
            groups.append([])
        else:
            groups[-1].append(t)
    if len(joints) > 1:
        raise ValueError(
            f"the {side} mixes AND and OR; a rule is all AND or all OR (write two rules)"
        )
    if side == "consequent" and joints == {"OR"}:
        raise ValueError("the consequent joins its outputs with AND, not OR")
    for g in groups:
        negate = len(g) == 4 and g[1].upper() == "IS" and g[2].upper() == "NOT"
        if negate and side == "consequent":
            raise ValueError(f"NOT is for the antecedent, not the consequent: {' '.join(g)!r}")
        if not negate and (len(g) != 3 or g[1].upper() != "IS"):
            raise ValueError(
                f"expected '<variable> IS <term>' or '<variable> IS NOT <term>' in the {side}, "
                f"got {' '.join(g)!r}"
            )
        var, term = g[0], g[-1]
        if var not in by_name:
            known = [v.name for v in variables]
            if any(v.name == var for v in others):
                other = "an output" if side == "antecedent" else "an input"
                raise ValueError(f"{var!r} is {other}; it cannot appear in the {side}")
            raise ValueError(f"unknown variable {var!r} in the {side} (known: {known})")
        i = by_name[var]
        if picked[i] is not None:
            raise ValueError(f"variable {var!r} appears twice in the {side}")
        v = variables[i]
        if term not in v.term_names:
            hint = (
                " (leave the input out instead of writing NONE)" if term.upper() == "NONE" else ""
            )
            raise ValueError(f"unknown term {term!r} of {var!r} (terms: {v.term_names}){hint}")
        k = v.term_names.index(term)
        picked[i] = ~k if negate else k
    return tuple(picked), "or" if joints == {"OR"} else "and"


def format_rule(system: FuzzySystem, rule: Rule) -> str:
    """The rule as a sentence (the inverse of :func:`parse_rule`)."""
    return rule_sentence(system.inputs, system.outputs, rule)


# --------------------------------------------------------------------------- reading


def _finite(err: _Err, key: str, value: Any) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise err(key, value, "must be a number")
    if isinstance(value, int) and abs(value) > 2**63:
        raise err(key, value, "is too large (at most 9.22e18 in magnitude)")
    v = float(value)
    if not math.isfinite(v):
        raise err(key, value, "must be finite")
    return v


def _string(err: _Err, key: str, value: Any, name: bool = False) -> str:
    if not isinstance(value, str):
        raise err(key, value, "must be a string")
    if len(value) > MAX_NAME_CHARS and name:
        raise err(key, value, f"a name of {len(value)} characters (at most {MAX_NAME_CHARS})")
    if name:
        why = _bad_name(value)
        if why:
            raise err(key, value, why)
    return value


_KEYWORDS = {"IF", "AND", "THEN", "IS", "WEIGHT", "OR", "NOT"}


def _bad_name(value: str) -> str | None:
    if not _NAME_RE.match(value):
        return "must be a name: letters, digits and _, not starting with a digit"
    if value.upper() in _KEYWORDS:
        return f"a rule keyword ({'/'.join(sorted(_KEYWORDS))}) cannot be a name"
    return None


def _check_keys(err: _Err, where: str, table: Any, allowed: set[str], required=()) -> None:
    if not isinstance(table, dict):
        raise err(where, table, "must be a table")
    for k in table:
        if k not in allowed:
            raise err(
                f"{where}.{k}" if where else k,
                table[k],
                f"unknown key (allowed: {sorted(allowed)})",
            )
    for k in required:
        if k not in table:
            raise err(f"{where}.{k}" if where else k, None, "missing required key")


def _variable(err: _Err, where: str, t: Any) -> Variable:
    _check_keys(err, where, t, _VAR_KEYS, _VAR_REQUIRED)
    name = _string(err, f"{where}.name", t["name"], name=True)
    rng = t["range"]
    if not isinstance(rng, list) or len(rng) != 2:
        raise err(f"{where}.range", rng, "must be [lo, hi]")
    lo = _finite(err, f"{where}.range", rng[0])
    hi = _finite(err, f"{where}.range", rng[1])
    if not lo < hi:
        raise err(f"{where}.range", rng, "needs lo < hi")
    unit = _string(err, f"{where}.unit", t.get("unit", ""))
    desc = _string(err, f"{where}.description", t.get("description", ""))
    terms_raw = t["terms"]
    if not isinstance(terms_raw, list) or not terms_raw:
        raise err(f"{where}.terms", terms_raw, "must be a non-empty array of terms")
    if len(terms_raw) > MAX_TERMS:
        raise err(
            f"{where}.terms", terms_raw, f"{len(terms_raw)} terms: at most {MAX_TERMS} allowed"
        )
    terms = []
    seen = set()
    for j, tt in enumerate(terms_raw):
        tw = f"{where}.terms[{j}]"
        _check_keys(err, tw, tt, _TERM_KEYS, ("name", "shape", "params"))
        tname = _string(err, f"{tw}.name", tt["name"], name=True)
        if tname in seen:
            raise err(f"{tw}.name", tname, f"duplicate term name in {name!r}")
        seen.add(tname)
        shape = _string(err, f"{tw}.shape", tt["shape"])
        if shape not in mf.SHAPES:
            raise err(f"{tw}.shape", shape, f"unknown shape (supported: {sorted(mf.SHAPES)})")
        params = tt["params"]
        if not isinstance(params, list):
            raise err(f"{tw}.params", params, "must be an array of numbers")
        vals = [_finite(err, f"{tw}.params", p) for p in params]
        try:
            mf.check_params(shape, vals)
        except ValueError as e:
            raise err(f"{tw}.params", params, str(e)) from None
        terms.append(Term(tname, shape, tuple(vals)))
    return Variable(name, (lo, hi), tuple(terms), unit, desc)


def _from_dict(data: dict, source: str) -> FuzzySystem:
    err = _Err(source)
    _check_keys(err, "", data, _TOP_KEYS, tuple(_TOP_KEYS))
    sysd = data["system"]
    _check_keys(err, "system", sysd, _SYSTEM_KEYS, ("name",))
    name = escape_controls(_string(err, "system.name", sysd["name"]))
    desc = escape_controls(_string(err, "system.description", sysd.get("description", "")), "\n\t")
    points = sysd.get("points", DEFAULT_POINTS)
    if isinstance(points, bool) or not isinstance(points, int) or not 2 <= points <= MAX_POINTS:
        raise err("system.points", points, f"must be an integer from 2 to {MAX_POINTS}")
    choices = {}
    for field, k in TOML_KEYS.items():
        if k in sysd:
            if sysd[k] not in CHOICES[field]:
                allowed = ", ".join(map(repr, CHOICES[field]))
                raise err(f"system.{k}", sysd[k], f"must be one of {allowed}")
            choices[field] = sysd[k]

    variables = {}
    groups = {}
    for side in ("inputs", "outputs"):
        arr = data[side]
        if not isinstance(arr, list) or not arr:
            raise err(side, arr, f"must be a non-empty array of tables ([[{side}]])")
        if len(arr) > MAX_VARIABLES:
            raise err(side, arr, f"{len(arr)} {side}: at most {MAX_VARIABLES} allowed")
        vs = []
        for i, t in enumerate(arr):
            v = _variable(err, f"{side}[{i}]", t)
            if v.name in variables:
                raise err(f"{side}[{i}].name", v.name, "duplicate variable name")
            variables[v.name] = v
            vs.append(v)
        groups[side] = vs

    rb = data["rulebase"]
    _check_keys(err, "rulebase", rb, _RULEBASE_KEYS, ("rules",))
    rules_raw = rb["rules"]
    if not isinstance(rules_raw, list) or not rules_raw:
        raise err("rulebase.rules", rules_raw, "must be a non-empty array of rule strings")
    if len(rules_raw) > MAX_RULES:
        raise err(
            "rulebase.rules", rules_raw, f"{len(rules_raw)} rules: at most {MAX_RULES} allowed"
        )
    unsensed = sysd.get("unsensed_none", [])
    names = [v.name for v in groups["inputs"]]
    if not isinstance(unsensed, list) or any(n not in names for n in unsensed):
        raise err(
            "system.unsensed_none", unsensed, f"must be a list of input names ({', '.join(names)})"
        )
    rules = []
    for i, text in enumerate(rules_raw):
        key = f"rulebase.rules[{i}]"
        if not isinstance(text, str):
            raise err(key, text, "must be a string")
        try:
            rules.append(parse_rule(text, groups["inputs"], groups["outputs"]))
        except ValueError as e:
            raise err(key, text, f"rule {i + 1}: {e}") from None
    return FuzzySystem(
        groups["inputs"],
        groups["outputs"],
        rules,
        name=name,
        description=desc,
        n_points=points,
        inference=Inference(**choices),
        unsensed_none=tuple(unsensed),
    )


def loads_toml(text: str, source: str = "<string>") -> FuzzySystem:
    """Parse a TOML rule base from a string (``source`` names it in errors)."""
    try:
        data = loads_user_toml(text, source)
    except InputError as e:
        raise ValueError(str(e)) from None
    return _from_dict(data, source)


def read_toml(path) -> FuzzySystem:
    """Read a TOML rule base file."""
    path = Path(path)
    try:
        text = read_user_text(path, "rule base file")
    except InputError as e:
        raise ValueError(str(e)) from None
    return loads_toml(text, str(path))


# --------------------------------------------------------------------------- writing


def _num(x: float) -> str:
    """Shortest text that reads back as the same float (TOML float syntax)."""
    s = repr(float(x))
    if "inf" in s or "nan" in s:
        raise ValueError(f"cannot write non-finite number {x!r}")
    return s


_TOML_ESCAPES = {'"': '\\"', "\\": "\\\\", "\n": "\\n", "\t": "\\t"}
_TOML_NEEDS_ESCAPE = re.compile(r'["\\\x00-\x1f\x7f]')


def _toml_escape(match: re.Match) -> str:
    ch = match.group()
    return _TOML_ESCAPES.get(ch) or f"\\u{ord(ch):04x}"


def _str(s: str) -> str:
    """A TOML basic string (a rule base's long header text went a character at a time)."""
    return '"' + _TOML_NEEDS_ESCAPE.sub(_toml_escape, s) + '"'


def dumps_toml(system: FuzzySystem) -> str:
    """The rule base as TOML text (reads back to an equal system)."""
    # Written by hand, not by tomli-w: the layout is the point. A rule base is read and
    # edited by people (the shipped ones, a tuned file): one term per line as an inline
    # table, each rule one line of its own text, [system] first; tomli-w would write
    # every term as an [[inputs.terms]] table and every number pair over four lines.
    # (Its bytes are also what a run's rules digest is taken of: app/runs.py.)
    for v in system.inputs + system.outputs:
        for n in [v.name] + v.term_names:
            why = _bad_name(n)
            if why:
                raise ValueError(
                    f"cannot write {n!r} (variable {v.name!r}) to a TOML rule base: {why}"
                )
    lines = ["[system]", f"name = {_str(system.name)}"]
    if system.description:
        lines.append(f"description = {_str(system.description)}")
    lines.append(f"points = {system.n_points}")
    inference = system.inference.as_dict()
    if inference["or_method"] == "max":  # the default: left out
        del inference["or_method"]
    lines += [f"{TOML_KEYS[field]} = {_str(value)}" for field, value in inference.items()]
    if system.unsensed_none:
        lines.append(f"unsensed_none = [{', '.join(_str(n) for n in system.unsensed_none)}]")
    for side, vs in (("inputs", system.inputs), ("outputs", system.outputs)):
        for v in vs:
            lines += [
                "",
                f"[[{side}]]",
                f"name = {_str(v.name)}",
                f"range = [{_num(v.range[0])}, {_num(v.range[1])}]",
            ]
            if v.unit:
                lines.append(f"unit = {_str(v.unit)}")
            if v.description:
                lines.append(f"description = {_str(v.description)}")
            lines.append("terms = [")
            for t in v.terms:
                ps = ", ".join(_num(p) for p in t.params)
                lines.append(
                    f"  {{ name = {_str(t.name)}, shape = {_str(t.shape)}, params = [{ps}] }},"
                )
            lines.append("]")
    lines += ["", "[rulebase]", "rules = ["]
    for r in system.rules:
        lines.append(f"  {_str(format_rule(system, r))},")
    lines.append("]")
    return "\n".join(lines) + "\n"


def write_toml(system: FuzzySystem, path) -> None:
    from fuzzynav.safe_files import write_text_atomically

    write_text_atomically(path, dumps_toml(system))
