"""fuzzynav as an installed package: one import name, layered imports, no circles,
shipped data through importlib.resources, a command line that explains itself."""

from __future__ import annotations

import argparse
import ast
import shlex
import subprocess
import sys
import tomllib
from pathlib import Path

import pytest

import fuzzynav
from fuzzynav.app.cli import COMMAND_DOCS, build_parser
from fuzzynav.resources import asset_path, assets_dir

ROOT = Path(__file__).resolve().parents[1]
# The repository's folders and the import package each becomes (pyproject's package-dir).
PACKAGE_DIRS = {
    "fuzzynav": ROOT / "fuzzynav",
    "fuzzynav.world": ROOT / "world",
    "fuzzynav.controller": ROOT / "controller",
    "fuzzynav.app": ROOT / "app",
}


def _module_files() -> dict[str, Path]:
    modules = {}
    for package, folder in PACKAGE_DIRS.items():
        for path in sorted(folder.rglob("*.py")):
            parts = path.relative_to(folder).with_suffix("").parts
            if parts[-1] == "__init__":
                parts = parts[:-1]
            modules[".".join((package, *parts))] = path
    return modules


def _imports(name: str, path: Path, known: set[str]) -> set[str]:
    """The fuzzynav modules ``name`` imports anywhere in its file (function-level
    imports too: a circle through a lazy import is still a circle)."""
    package = name if path.stem == "__init__" else name.rpartition(".")[0]
    found = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            targets = [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                parts = package.split(".")
                base = ".".join(parts[: len(parts) - node.level + 1] + ([base] if base else []))
            targets = [base] + [f"{base}.{alias.name}" for alias in node.names]
        else:
            continue
        for target in targets:
            while target and target not in known:
                target = target.rpartition(".")[0]
            if target and target != name and target != "fuzzynav":
                found.add(target)
    return found


def import_graph() -> dict[str, set[str]]:
    modules = _module_files()
    known = set(modules)
    return {name: _imports(name, path, known) for name, path in modules.items()}


def test_the_import_graph_is_read_correctly():
    graph = import_graph()
    assert "fuzzynav.controller.fuzzy" in graph["fuzzynav.controller.rulebase"]
    assert "fuzzynav.world.scenario" in graph["fuzzynav.app.args"]
    assert "fuzzynav.app.args" in graph["fuzzynav.app.experiments.studies"]


#: The only module that may import the command line: ``python -m fuzzynav``.
ENTRY_POINTS = {"fuzzynav.__main__"}


def test_only_the_entry_point_imports_the_command_line():
    """Command modules take UsageError and the argument types from app.args, below
    them, so none needs the command line (nor a function-level import to dodge the
    circle that would make)."""
    importers = {m for m, targets in import_graph().items() if "fuzzynav.app.cli" in targets}
    assert importers <= ENTRY_POINTS, sorted(importers - ENTRY_POINTS)


FUNCTION_LIMIT_LINES = 100
#: Production functions over FUNCTION_LIMIT_LINES (``def`` to its last line, docstring
#: included), each waiting for its split by responsibility; none may join them, and the list only shrinks: a function split under the limit (or gone) leaves it
#: (test_the_long_function_list_names_only_long_functions).
KNOWN_LONG_FUNCTIONS: set[str] = set()


def _function_lengths(path: Path) -> dict[str, int]:
    """Every function of a module (methods and nested functions too) by its qualified
    name (``Class.method``, ``outer.inner``): its length in lines, ``def`` to its end."""
    lengths: dict[str, int] = {}

    def visit(node, prefix: str) -> None:
        for child in ast.iter_child_nodes(node):
            if isinstance(child, ast.FunctionDef | ast.AsyncFunctionDef):
                name = prefix + child.name
                lines = child.end_lineno - child.lineno + 1
                lengths[name] = max(lines, lengths.get(name, 0))  # a redefinition: the longer
                visit(child, name + ".")
            elif isinstance(child, ast.ClassDef):
                visit(child, prefix + child.name + ".")
            else:
                visit(child, prefix)

    visit(ast.parse(path.read_text(encoding="utf-8")), "")
    return lengths


def _all_function_lengths() -> dict[str, int]:
    return {
        f"{module}.{name}": lines
        for module, path in _module_files().items()
        for name, lines in _function_lengths(path).items()
    }


def test_function_lengths_are_measured_from_def_to_end():
    lengths = _all_function_lengths()
    assert lengths["fuzzynav.controller.navigator.controller.FuzzyNavController.__call__"] > 20
    assert lengths["fuzzynav.world.shortest_path.shortest_path"] > 20
    assert lengths["fuzzynav.app.experiments.search._search.callback"] < 10


def test_no_new_function_over_the_length_limit():
    """A function over the limit is split by responsibility, not listed. (Modules have
    no size cap: they are split by concept, never by size.)"""
    long = {
        name: lines
        for name, lines in _all_function_lengths().items()
        if lines > FUNCTION_LIMIT_LINES and name not in KNOWN_LONG_FUNCTIONS
    }
    assert not long, f"over {FUNCTION_LIMIT_LINES} lines: {long}"


def test_the_long_function_list_names_only_long_functions():
    """A function split (or moved, or deleted) leaves KNOWN_LONG_FUNCTIONS, so that the
    list only shrinks."""
    lengths = _all_function_lengths()
    for name in sorted(KNOWN_LONG_FUNCTIONS):
        assert name in lengths, f"{name}: no such function; remove it from KNOWN_LONG_FUNCTIONS"
        assert lengths[name] > FUNCTION_LIMIT_LINES, (
            f"{name}: {lengths[name]} lines, within the limit; remove it from KNOWN_LONG_FUNCTIONS"
        )


#: app/'s top level holds the command line and what sits below it; the rest lives in
#: rooms (subpackages), each with one job that its docstring says (issue 24).
APP_TOP_LEVEL_LIMIT = 8


def test_app_is_rooms_with_a_small_top_level():
    app = PACKAGE_DIRS["fuzzynav.app"]
    top = sorted(p.name for p in app.glob("*.py"))
    assert len(top) <= APP_TOP_LEVEL_LIMIT, top
    rooms = sorted(p.parent for p in app.glob("*/__init__.py"))
    assert {r.name for r in rooms} >= {"viewer", "recordings", "experiments", "figures"}
    for room in rooms:
        doc = ast.get_docstring(ast.parse((room / "__init__.py").read_text(encoding="utf-8")))
        assert doc and len(doc.splitlines()) >= 3, f"{room.name}/__init__.py says what it holds"
        for module in room.glob("*.py"):
            assert f":mod:`.{module.stem}`" in doc or module.stem == "__init__", (
                f"{room.name}/__init__.py does not name {module.stem}"
            )


def test_layers_import_one_way():
    """app uses controller and world; controller never imports app; world knows nothing
    of the controller (it takes wheel voltages and gives sensor readings)."""
    for module, targets in import_graph().items():
        for target in targets:
            if module.startswith("fuzzynav.world"):
                assert not target.startswith(("fuzzynav.controller", "fuzzynav.app")), (
                    f"{module} imports {target}"
                )
            if module.startswith("fuzzynav.controller"):
                assert not target.startswith("fuzzynav.app"), f"{module} imports {target}"


def test_no_import_circles():
    graph = import_graph()
    state: dict[str, int] = {}  # 1: on the current path, 2: done
    path: list[str] = []

    def visit(node: str) -> None:
        state[node] = 1
        path.append(node)
        for nxt in sorted(graph.get(node, ())):
            if state.get(nxt) == 1:
                circle = path[path.index(nxt) :] + [nxt]
                pytest.fail("import circle: " + " -> ".join(circle))
            if nxt not in state:
                visit(nxt)
        path.pop()
        state[node] = 2

    for node in sorted(graph):
        if node not in state:
            visit(node)


def test_the_engine_knows_no_file_format():
    assert (
        not {"fuzzynav.controller.fis", "fuzzynav.controller.rulebase"}
        & import_graph()["fuzzynav.controller.fuzzy"]
    )


def test_shipped_data_comes_through_importlib_resources():
    assert assets_dir() == ROOT / "assets"  # an editable install points at the checkout
    for name in ("husky.toml", "rules/paper.toml", "scenarios/s1.toml"):
        assert asset_path(*name.split("/")).is_file(), name
    pyproject = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))
    patterns = pyproject["tool"]["setuptools"]["package-data"]["fuzzynav.assets"]
    shipped = {p for pattern in patterns for p in (ROOT / "assets").glob(pattern)}
    on_disk = {p for p in (ROOT / "assets").rglob("*") if p.is_file() and p.suffix != ".py"}
    on_disk = {p for p in on_disk if "__pycache__" not in p.parts}
    assert on_disk == shipped, f"data files the wheel would leave out: {on_disk - shipped}"


def test_python_dash_m_fuzzynav_and_version():
    done = subprocess.run(
        [sys.executable, "-m", "fuzzynav", "--version"], capture_output=True, text=True, timeout=60
    )
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == f"fuzzynav {fuzzynav.__version__}"
    assert fuzzynav.__version__ != "0+unknown"


def _subparsers(parser: argparse.ArgumentParser, prefix: str = ""):
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for name, sub in action.choices.items():
                yield f"{prefix}{name}", sub
                yield from _subparsers(sub, f"{prefix}{name} ")


def test_every_command_has_a_description_an_example_and_helped_options():
    parser = build_parser()
    commands = dict(_subparsers(parser))
    assert {"run", "tune", "sweep", "compare", "report", "serve", "fis export"} <= set(commands)
    for name, sub in commands.items():
        assert sub.description and len(sub.description) > 20, name
        assert sub.epilog and "examples:" in sub.epilog, name
        for action in sub._actions:
            if isinstance(action, argparse._HelpAction | argparse._SubParsersAction):
                continue
            assert action.help, f"{name} {action.option_strings or action.dest}: no help"
        text = sub.format_help()
        assert "assets/" not in text, f"{name}'s help speaks of repository paths"


def test_every_example_parses():
    for _name, (_, examples) in COMMAND_DOCS.items():
        for example in examples:
            argv = shlex.split(example)
            assert argv[0] == "fuzzynav", example
            build_parser().parse_args(argv[1:])  # SystemExit(2) fails the test


def test_options_with_a_fixed_set_list_it():
    parser = build_parser()
    commands = dict(_subparsers(parser))
    for name in ("tune", "sweep", "compare", "report", "serve", "fis export", "run"):
        for action in commands[name]._actions:
            if "--controller" in action.option_strings or "--perception" in action.option_strings:
                if name == "tune" and "--perception" in action.option_strings:
                    continue  # a comma-separated list, checked value by value
                assert action.choices, f"{name} {action.option_strings}: no choices"


def test_tune_writes_into_the_current_folder_not_the_installation(tmp_path, monkeypatch):
    from fuzzynav.app.cli import main

    shipped = asset_path("rules", "paper.toml")
    before = shipped.read_bytes()
    monkeypatch.chdir(tmp_path)
    argv = ["tune", "--scenarios", "s1", "--perception", "ideal", "--maxiter", "1"]
    argv += ["--popsize", "1", "--free", "phi_o", "--workers", "1", "--json"]
    assert main(argv) == 0
    assert (tmp_path / "paper_tuned.toml").is_file()
    assert shipped.read_bytes() == before


def test_recordings_name_the_package_version():
    from fuzzynav.app.provenance import package_versions

    versions = package_versions()
    assert versions["fuzzynav"] == fuzzynav.__version__
    # This test runs from a checkout: the revision is there, and it is this checkout's.
    if (ROOT / ".git").exists():
        assert versions.get("git")


def test_the_papers_numbers_live_in_one_place():
    """Table 4 is written once, in assets/paper/results.toml; the code reads it there
    (app/published.py) instead of carrying copies that can drift apart."""
    results = tomllib.loads(asset_path("paper", "results.toml").read_text(encoding="utf-8"))
    numbers = {
        repr(value)
        for table in ("table4", "table4_ref19")
        for row in results[table].values()
        for value in row.values()
        if len(repr(value)) >= 6  # 0.2557, 11.8332, ...: specific enough to find
    }
    assert len(numbers) >= 20
    for name, path in _module_files().items():
        text = path.read_text(encoding="utf-8")
        found = sorted(n for n in numbers if n in text)
        assert not found, f"{name} carries Table 4's {found}: read app.published instead"
