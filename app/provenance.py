"""Provenance: what made a result and how to make it again.

The package versions and the git revision a result was made with
(:func:`package_versions`), the process's command line (:func:`command_line`), and the
command that reproduces a result: a run's (:func:`reproduce_run`, the ``fuzzynav run``
command with every option that changes it), or any command's, quoted for a shell
(:func:`shell_command`) and written as the ``Reproduce with:`` line that a fitted or
tuned rule base carries in its header (:func:`reproduce_line`). Recordings, sweeps and
tuning take them from here.
"""

from __future__ import annotations

import functools
import platform
import shlex
import subprocess
import sys
from pathlib import Path

_VERSIONED = {
    "fuzzynav": None,
    "rerun-sdk": "rerun",
    "numpy": "numpy",
    "scipy": "scipy",
    "pymunk": "pymunk",
    "matplotlib": "matplotlib",
    "viser": "viser",
}


@functools.cache
def package_versions() -> dict:
    """Python, platform, the packages a run depends on, and the git revision (once per
    process: reading distribution metadata costs milliseconds a package)."""
    from importlib import metadata

    out = {"python": platform.python_version(), "platform": platform.platform()}
    for name, module in _VERSIONED.items():
        version = getattr(sys.modules.get(module), "__version__", None) if module else None
        if not isinstance(version, str):
            try:
                version = metadata.version(name)
            except metadata.PackageNotFoundError:
                version = "not installed"
        out[name] = version
    revision = git_revision()
    if revision:  # only from a checkout of this project
        out["git"] = revision
    return out


def git_revision() -> str | None:
    """The checkout's revision when fuzzynav runs from a git checkout of this project
    (an editable install); None for an installed wheel, which says its version instead
    of the revision of whatever repository it happens to sit in."""
    root = Path(__file__).resolve().parents[1]  # app/ sits in the checkout's root
    if not (
        (root / ".git").exists()
        and (root / "fuzzynav" / "__init__.py").is_file()
        and (root / "pyproject.toml").is_file()
    ):
        return None
    try:
        done = subprocess.run(
            ["git", "describe", "--always", "--dirty", "--abbrev=12"],
            cwd=root,
            capture_output=True,
            text=True,
            timeout=5,
        )
    except (OSError, subprocess.SubprocessError):
        return None
    return done.stdout.strip() if done.returncode == 0 and done.stdout.strip() else None


def command_line() -> str:
    """The process's own command line, quoted for a shell (``fuzzynav run s1 ...``)."""
    return " ".join(shlex.quote(a) for a in [Path(sys.argv[0]).name] + sys.argv[1:])


def reproduce_run(
    scenario,
    controller,
    perception,
    seed,
    control_period_s,
    *,
    geometry: str = "husky",
    noise_std_m: float = 0.0,
    voltage_limit_v: float = 12.0,
    parameters=None,
):
    """The run's :class:`app.runs.Reproduction`: the ``fuzzynav run`` command with every
    option that changes the run, and what it cannot carry."""
    from fuzzynav.app.runs import reproduce

    return reproduce(
        scenario,
        controller,
        perception=perception,
        seed=seed,
        control_period_s=control_period_s,
        geometry=geometry,
        noise_std_m=noise_std_m,
        voltage_limit_v=voltage_limit_v,
        parameters=parameters,
    )


def wrap_command(command: str, width: int = 72) -> str:
    """A shell command on several lines (`` \\`` continuations, one option and its value
    a line where the line would grow past ``width``): the same command to a shell."""
    words = shlex.split(command)
    lines, current = [], ""
    k = 0
    while k < len(words):
        piece = shlex.quote(words[k])
        if words[k].startswith("--") and k + 1 < len(words) and not words[k + 1].startswith("--"):
            piece += " " + shlex.quote(words[k + 1])
            k += 1
        k += 1
        if current and len(current) + 1 + len(piece) > width:
            lines.append(current)
            current = "    " + piece
        else:
            current = f"{current} {piece}" if current else piece
    lines.append(current)
    return " \\\n".join(lines)


def fuzzynav_version() -> str:
    """This fuzzynav's version (what a sweep's row fingerprint and a recording name)."""
    from fuzzynav import __version__

    return __version__


def shell_command(argv) -> str:
    """``argv`` (strings or numbers) as one command line, each word quoted for a shell."""
    return shlex.join(str(a) for a in argv)


#: The prefix of the line in a written file's header that says how to make it again.
REPRODUCE_PREFIX = "Reproduce with: "


def reproduce_line(command: str) -> str:
    """``Reproduce with: <command>``: the line a fitted or tuned file's header begins with."""
    return REPRODUCE_PREFIX + command
